#include "publisher.hpp"

#include <systemd/sd-daemon.h>
#include <unistd.h>

#include <filesystem>
#include <stdexcept>
#include <system_error>

#include <spdlog/spdlog.h>

#include "gearwatch/storage/schema.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "vocabulary.hpp"

namespace gearwatch::daemon {

namespace {

// The publisher's own lock file beside the writer's: two publishers would each send every message.
std::string publisher_lock_name(const std::string& database) { return database + ".publisher"; }

}  // namespace

Publisher::Publisher(config::GearwatchConfig config, PublisherOptions options)
    : config_(std::move(config)), options_(options), health_timer_(io_), watchdog_(io_) {}

Publisher::~Publisher() = default;

void Publisher::run() {
  check_config();
  handle_signals();
  if (!wait_for_database()) return;  // stopped while waiting: nothing was started
  take_publisher_lock();
  open_writer();
  start_sender();
  notify_ready();
  arm_health_timer();
  arm_watchdog();
  io_.run();
  stop_in_reverse();
}

// Publishing needs [mqtt] on, and the daemon told not to send itself (else every message twice).
void Publisher::check_config() const {
  const auto& m = config_.mqtt;
  if (!m.enabled) throw std::runtime_error("[mqtt] enabled = false: there is nothing to publish");
  if (m.sender != config::MqttSender::publisher)
    throw std::runtime_error(std::string("[mqtt] sender = \"") + config::to_string(m.sender) +
                             "\": the daemon delivers the outbox itself; set sender = \"publisher\" for `gearwatch publish`");
}

// SIGTERM and SIGINT stop; the signal closes the timers so io_.run() returns.
void Publisher::handle_signals() {
  signals_.emplace(io_, SIGTERM, SIGINT);
  signals_->async_wait([this](const boost::system::error_code& ec, int signal) {
    if (ec) return;
    spdlog::info("publish: {} received, stopping", signal == SIGINT ? "SIGINT" : "SIGTERM");
    stop_requested_ = true;
    health_timer_.cancel();
    watchdog_.cancel();
  });
}

// The daemon creates (and migrates) the database; the publisher may come up first. Ready means
// gearwatch's and at this build's schema version: never two processes migrating one file.
bool Publisher::database_ready() const {
  const std::string& path = config_.storage.database;
  if (!std::filesystem::exists(path)) return false;
  try {
    storage::Database db(path, storage::Database::Mode::read_only);
    const auto identity = storage::identify_database(db);
    storage::refuse_foreign_database(path, identity);
    return identity.kind == storage::DatabaseKind::gearwatch && identity.user_version == storage::current_schema_version();
  } catch (const storage::ForeignDatabase&) {
    throw;
  } catch (const storage::SqliteError&) {
    return false;  // being created right now
  }
}

bool Publisher::wait_for_database() {
  bool told = false;
  while (!database_ready()) {
    if (!told) spdlog::info("publish: waiting for the daemon to create or migrate {}", config_.storage.database);
    told = true;
    health_timer_.expires_after(options_.database_poll);
    health_timer_.async_wait([](const boost::system::error_code&) {});
    io_.run_one();  // the timer, or a signal that cancels it
    if (stop_requested_) return false;
    io_.restart();
  }
  return true;
}

void Publisher::take_publisher_lock() {
  try {
    lock_.emplace(storage::DatabaseLock::acquire(publisher_lock_name(config_.storage.database)));
  } catch (const storage::DatabaseInUse& e) {
    throw std::runtime_error("another `gearwatch publish` (pid " + std::to_string(e.holder()) + ") delivers " +
                             config_.storage.database + "'s outbox");
  }
}

// Its own writer: the sender's alerts (and their outbox rows) and the publisher's counters.
void Publisher::open_writer() {
  storage::WriterOptions w;
  w.database = config_.storage.database;
  w.busy_timeout_ms = static_cast<int>(config_.storage.busy_timeout_ms);
  w.retry_initial_ms = static_cast<int>(config_.storage.retry_initial_ms);
  w.retry_max_ms = static_cast<int>(config_.storage.retry_max_ms);
  w.vocabulary = acquisition_vocabulary();
  w.outbox = storage::OutboxIdentity{config_.mqtt.site, config_.mqtt.gearbox, config_.mqtt.outbox_limit};
  writer_.emplace(w);
  try {
    writer_->start();
  } catch (const std::exception& e) {
    throw std::runtime_error("database " + config_.storage.database + " cannot be opened for writing: " + e.what());
  }
}

void Publisher::start_sender() {
  sender_ = std::make_unique<MqttSender>(config_.mqtt, config_.storage.database, *writer_);
  try {
    sender_->start();
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("mqtt: ") + e.what());
  }
  spdlog::info("publish: delivering {}'s outbox to {}:{}", config_.storage.database, config_.mqtt.host, config_.mqtt.port);
}

void Publisher::notify_ready() {
  sd_notify(0, "READY=1");
  if (sd_watchdog_enabled(0, &watchdog_usec_) <= 0) watchdog_usec_ = 0;
}

void Publisher::arm_health_timer() {
  if (stop_requested_) return;
  health_timer_.expires_after(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(config_.daemon.health_interval_s)));
  health_timer_.async_wait([this](const boost::system::error_code& ec) {
    if (ec) return;
    write_health(false);
    arm_health_timer();
  });
}

void Publisher::arm_watchdog() {
  if (watchdog_usec_ == 0 || stop_requested_) return;
  watchdog_.expires_after(std::chrono::microseconds(static_cast<long>(watchdog_usec_ * config_.daemon.watchdog_margin)));
  watchdog_.async_wait([this](const boost::system::error_code& ec) {
    if (ec) return;
    sd_notify(0, "WATCHDOG=1");
    arm_watchdog();
  });
}

void Publisher::write_health(bool final) {
  storage::PublisherHealth h;
  h.final = final;
  h.pid = static_cast<std::int64_t>(::getpid());
  add_mqtt_counters(sender_->counters(), h.counters);
  writer_->submit(h);
}

// As the daemon stops its own sender: settle while alerts can still be stored, then the writer,
// then the sender delivers what the outbox holds for up to drain_timeout_s.
void Publisher::stop_in_reverse() {
  sd_notify(0, "STOPPING=1");
  sender_->settle();
  sender_->close_alerts();
  write_health(true);
  writer_->stop();
  sender_->stop();
  const auto& c = sender_->counters();
  spdlog::info("publish: stopped: {} published, {} delivered, {} sessions", c.published.load(), c.delivered.load(), c.connects.load());
}

}  // namespace gearwatch::daemon
