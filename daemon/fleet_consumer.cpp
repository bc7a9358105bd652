// The fleet consumer: MQTT session, queue, writer thread (docs/fleet.md).
#include "fleet_consumer.hpp"

#include <mosquitto.h>
#include <mqtt_protocol.h>

#include <chrono>
#include <mutex>

#include <nlohmann/json.hpp>

#include <spdlog/spdlog.h>

#include "gearwatch/acquisition/socketcan.hpp"

namespace gearwatch::daemon {

namespace acq = gearwatch::acquisition;

namespace {

using Clock = std::chrono::steady_clock;

// The gearbox and id of a data message (a rejected one keeps them, so it is not asked for again).
std::optional<fleet::MessageHeader> header_of(const FleetMessage& m) {
  return std::visit(
      [](const auto& x) -> std::optional<fleet::MessageHeader> {
        if constexpr (requires { x.header; }) return x.header;
        else return std::nullopt;
      },
      m);
}

void init_mosquitto_once() {
  static std::once_flag once;
  std::call_once(once, [] { mosquitto_lib_init(); });
}

}  // namespace

// One log line per kind of trouble and interval, with the count of those held back.
class FleetConsumer::LogLimiter {
 public:
  void warn(const std::string& kind, const std::string& line) {
    std::lock_guard lock(mutex_);
    auto it = limiters_.find(kind);
    if (it == limiters_.end()) it = limiters_.emplace(kind, acq::LogRateLimiter(std::chrono::seconds(10))).first;
    std::uint64_t suppressed = 0;
    if (!it->second.allow(Clock::now(), suppressed)) return;
    if (suppressed) spdlog::warn("fleet: {} ({} more like it since the last report)", line, suppressed);
    else spdlog::warn("fleet: {}", line);
  }

 private:
  std::mutex mutex_;
  std::map<std::string, acq::LogRateLimiter> limiters_;
};

std::uint64_t FleetCounters::rejected_total() const {
  std::uint64_t n = 0;
  for (const auto& [reason, count] : rejected) n += count;
  return n;
}

std::string to_string(const FleetCounters& c) {
  std::string reasons;
  for (const auto& [reason, count] : c.rejected)
    if (count) reasons += std::string(reasons.empty() ? "" : ", ") + fleet::to_string(reason) + " " + std::to_string(count);
  return "received " + std::to_string(c.received) + ", stored " + std::to_string(c.stored) + ", duplicates " +
         std::to_string(c.duplicates) + ", statuses " + std::to_string(c.statuses) + ", rejected " +
         std::to_string(c.rejected_total()) + (reasons.empty() ? "" : " (" + reasons + ")") + ", database retries " +
         std::to_string(c.database_retries) + ", broker connections " + std::to_string(c.connects) + ", resend requests " +
          std::to_string(c.resend_requests) + " (refused " + std::to_string(c.resend_refused) + "), lost " + std::to_string(c.lost_messages) + " messages in " +
         std::to_string(c.lost_ranges) + " ranges";
}

FleetConsumer::FleetConsumer(FleetIngestSettings settings) : settings_(std::move(settings)), log_(std::make_unique<LogLimiter>()) {}

FleetConsumer::~FleetConsumer() { stop(); }

void FleetConsumer::start() {
  connect_store();
  const int found = store_->migrate();
  if (found != fleet::current_fleet_schema_version())
    spdlog::info("fleet: database schema {} -> {}", found, fleet::current_fleet_schema_version());
  started_ = true;
  writer_ = std::thread([this] { writer_loop(); });
  start_session();
}

void FleetConsumer::connect_store() { store_ = std::make_unique<fleet::FleetStore>(settings_.database); }

// TLS files that libmosquitto cannot read are refused at start, in one line.
void FleetConsumer::use_tls() {
  if (settings_.ca_file.empty()) return;
  const char* cert = settings_.cert_file.empty() ? nullptr : settings_.cert_file.c_str();
  const char* key = settings_.key_file.empty() ? nullptr : settings_.key_file.c_str();
  if (const int rc = mosquitto_tls_set(client_, settings_.ca_file.c_str(), nullptr, cert, key, nullptr); rc != MOSQ_ERR_SUCCESS)
    throw std::runtime_error("fleet: TLS files (--ca-file, --cert-file, --key-file): " + std::string(mosquitto_strerror(rc)));
}

// clean_session false and a fixed client id: the broker keeps this consumer's subscription and
// queues its QoS 1 messages while it is away; libmosquitto's thread reconnects on its own.
void FleetConsumer::start_session() {
  init_mosquitto_once();
  client_ = mosquitto_new(settings_.client_id.c_str(), false, this);
  if (!client_) throw std::runtime_error("fleet: cannot create the MQTT client");
  // MQTT 5, as the daemons: the broker's PUBACK says when it refuses a resend request (ACL), and
  // the subscription can leave out this client's own requests (no local).
  mosquitto_int_option(client_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V5);
  mosquitto_publish_v5_callback_set(client_, [](mosquitto*, void* self, int, int reason, const mosquitto_property*) {
    if (reason >= 0x80) static_cast<FleetConsumer*>(self)->on_request_refused(reason);
  });
  if (settings_.credentials)
    mosquitto_username_pw_set(client_, settings_.credentials->username.c_str(), settings_.credentials->password.c_str());
  use_tls();
  mosquitto_reconnect_delay_set(client_, 1, 10, true);
  mosquitto_connect_callback_set(client_, [](mosquitto*, void* self, int rc) { static_cast<FleetConsumer*>(self)->on_connect(rc); });
  mosquitto_disconnect_callback_set(client_, [](mosquitto*, void* self, int rc) {
    // rc 0: our own disconnect at stop; anything else: lost, libmosquitto reconnects.
    if (rc != 0) static_cast<FleetConsumer*>(self)->log_->warn("broker", std::string("connection to the broker lost: ") + mosquitto_strerror(rc) + "; reconnecting");
  });
  mosquitto_message_callback_set(client_, [](mosquitto*, void* self, const mosquitto_message* m) {
    auto* consumer = static_cast<FleetConsumer*>(self);
    if (is_resend_request(consumer->settings_.accept, m->topic)) return;
    consumer->enqueue(
        {m->topic, std::string(static_cast<const char*>(m->payload), static_cast<std::size_t>(m->payloadlen))});
  });
  // MQTT 5 keeps a session only as long as its expiry says: "never expires", as clean_session
  // false did under 3.1.1. libmosquitto keeps the properties for its reconnects.
  mosquitto_property* properties = nullptr;
  mosquitto_property_add_int32(&properties, MQTT_PROP_SESSION_EXPIRY_INTERVAL, 0xFFFFFFFFu);
  const int rc = mosquitto_connect_bind_v5(client_, settings_.host.c_str(), settings_.port, 30, nullptr, properties);
  mosquitto_property_free_all(&properties);
  if (rc != MOSQ_ERR_SUCCESS)
    log_->warn("broker", "broker " + settings_.host + ":" + std::to_string(settings_.port) + " unreachable: " + mosquitto_strerror(rc) +
                             "; retrying");
  mosquitto_loop_start(client_);
}

void FleetConsumer::on_connect(int rc) {
  if (rc != 0) {
    log_->warn("refused", std::string("the broker refused the session: ") + mosquitto_reason_string(rc));
    return;
  }
  {
    std::lock_guard lock(mutex_);
    ++counters_.connects;
  }
  // Subscribing again on a resumed session is harmless; under the prefix, everything (unknown
  // topics too, so they are counted and kept rather than never seen).
  const std::string filter = settings_.accept.prefix + "/#";
  mosquitto_subscribe_v5(client_, nullptr, filter.c_str(), 1, MQTT_SUB_OPT_NO_LOCAL, nullptr);
}

// The broker refused a resend request (its ACL lacks write on <prefix>/+/+/resend): counted, logged.
void FleetConsumer::on_request_refused(int reason) {
  {
    std::lock_guard lock(mutex_);
    ++counters_.resend_refused;
  }
  log_->warn("resend refused", std::string("the broker refused a resend request: ") + mosquitto_reason_string(reason) +
                                   "; let this consumer write <prefix>/+/+/resend (its ACL) or the holes stay open");
}

void FleetConsumer::enqueue(Inbound m) {
  std::unique_lock lock(mutex_);
  // Back-pressure: the network thread waits, so the broker holds what the database cannot take yet.
  space_.wait(lock, [&] { return queue_.size() < settings_.queue_capacity || stopping_; });
  ++counters_.received;
  queue_.push_back(std::move(m));
  arrived_.notify_one();
}

void FleetConsumer::stop() {
  if (std::lock_guard lock(client_mutex_); client_) {
    mosquitto_disconnect(client_);
    mosquitto_loop_stop(client_, false);
    mosquitto_destroy(client_);
    client_ = nullptr;
  }
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  arrived_.notify_all();
  space_.notify_all();
  if (writer_.joinable()) writer_.join();
}

FleetCounters FleetConsumer::counters() const {
  std::lock_guard lock(mutex_);
  return counters_;
}

// Runs `write` until it succeeds; a lost database connection is retried with a growing pause
// (the message is held, never dropped), a refusal is the caller's to handle.
template <class Write>
void FleetConsumer::with_database(Write&& write) {
  int pause_ms = settings_.retry_initial_ms;
  const auto first_try = Clock::now();
  for (;;) {
    try {
      if (!store_) connect_store();
      write(*store_);
      return;
    } catch (const fleet::FleetConnectionError& e) {
      store_.reset();
      {
        std::lock_guard lock(mutex_);
        ++counters_.database_retries;
      }
      log_->warn("database", std::string(e.what()) + "; holding the message and retrying");
      if (stop_requested() && Clock::now() - first_try > std::chrono::seconds(30)) {
        spdlog::error("fleet: stopping with the database unreachable: a message received was not stored");
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(pause_ms));
      pause_ms = std::min(pause_ms * 2, settings_.retry_max_ms);
    }
  }
}

// Drains the queue also after stop(): the session is closed by then, nothing more arrives. Takes
// what waits, up to a batch: one transaction for many messages while the consumer is behind, one
// per message when it keeps up.
void FleetConsumer::writer_loop() {
  auto next_check = Clock::now();
  std::uint64_t taken = 0;
  for (;;) {
    if (settings_.stall_after && taken >= *settings_.stall_after) return stall_for_test(taken);
    if (Clock::now() >= next_check && !stop_requested()) {
      bool idle = false;
      {
        std::lock_guard lock(mutex_);
        idle = queue_.empty();
      }
      if (idle) {
        ask_for_holes();
        next_check = Clock::now() + settings_.resend_interval;
      }
    }
    std::vector<Inbound> batch;
    {
      std::unique_lock lock(mutex_);
      arrived_.wait_until(lock, next_check, [&] { return stopping_ || !queue_.empty(); });
      if (queue_.empty() && stopping_) return;
      std::size_t room = settings_.batch_size;
      if (settings_.stall_after) room = std::min<std::size_t>(room, *settings_.stall_after - taken);
      while (!queue_.empty() && batch.size() < room) {
        batch.push_back(std::move(queue_.front()));
        queue_.pop_front();
      }
    }
    if (batch.empty()) continue;
    taken += batch.size();
    space_.notify_all();
    handle(batch);
  }
}

// The test hook: what arrives now stays in the queue, received and acknowledged, never stored.
void FleetConsumer::stall_for_test(std::uint64_t taken) {
  std::size_t said = 0;
  for (;;) {
    std::unique_lock lock(mutex_);
    if (stopping_) return;
    if (queue_.size() != said) {
      said = queue_.size();
      spdlog::warn("fleet: test hook: {} messages written, holding {} received messages uncommitted", taken, said);
    }
    arrived_.wait_for(lock, std::chrono::milliseconds(100));
  }
}

void FleetConsumer::ask_for_holes() {
  fleet::FleetStore::HoleCheck check;
  try {
    with_database([&](fleet::FleetStore& store) { check = store.check_holes(settings_.resend_give_up); });
  } catch (const std::exception& e) {
    log_->warn("holes", std::string("cannot look for missing messages: ") + e.what());
    return;
  }
  for (const auto& h : check.given_up) count_unanswered(h);
  auto& holes = check.to_ask;
  // A hole asked for recently waits (the daemon may be away or busy sending it); a new one goes now.
  constexpr int kReaskIntervals = 10;
  const auto now = Clock::now();
  std::erase_if(asked_, [&](const auto& a) { return now - a.second >= kReaskIntervals * settings_.resend_interval; });
  std::erase_if(holes, [&](const fleet::MessageHole& h) {
    return !asked_.emplace(std::make_tuple(h.site, h.gearbox, h.from, h.to), now).second;
  });
  for (std::size_t first = 0; first < holes.size();) {
    std::size_t end = first;
    while (end < holes.size() && holes[end].site == holes[first].site && holes[end].gearbox == holes[first].gearbox) ++end;
    ask({holes.begin() + static_cast<std::ptrdiff_t>(first), holes.begin() + static_cast<std::ptrdiff_t>(end)});
    first = end;
  }
}

// One request per gearbox, at most kMaxRanges ranges (the rest at the next check).
void FleetConsumer::ask(const std::vector<fleet::MessageHole>& holes) {
  constexpr std::size_t kMaxRanges = 100;
  nlohmann::json ranges = nlohmann::json::array();
  std::int64_t ids = 0;
  for (std::size_t i = 0; i < holes.size() && i < kMaxRanges; ++i) {
    ranges.push_back({holes[i].from, holes[i].to});
    ids += holes[i].to - holes[i].from + 1;
  }
  const auto& g = holes.front();
  const std::string payload = nlohmann::json{{"site", g.site}, {"gearbox", g.gearbox}, {"ranges", ranges}}.dump();
  const std::string topic = settings_.accept.prefix + "/" + g.site + "/" + g.gearbox + "/resend";
  int rc = MOSQ_ERR_NO_CONN;
  {
    std::lock_guard lock(client_mutex_);
    if (client_) rc = mosquitto_publish(client_, nullptr, topic.c_str(), static_cast<int>(payload.size()), payload.data(), 1, false);
  }
  if (rc != MOSQ_ERR_SUCCESS) {  // not connected: asked again at the next check
    for (const auto& h : holes) asked_.erase(std::make_tuple(h.site, h.gearbox, h.from, h.to));
    log_->warn("resend", std::string("cannot ask for missing messages now: ") + mosquitto_strerror(rc));
    return;
  }
  {
    std::lock_guard lock(mutex_);
    ++counters_.resend_requests;
  }
  log_->warn("resend " + g.site + "/" + g.gearbox, "asked " + g.site + "/" + g.gearbox + " to send " + std::to_string(ids) +
                                                       " missing messages again (first " + std::to_string(g.from) + ".." +
                                                       std::to_string(g.to) + ", " + std::to_string(ranges.size()) + " ranges)");
}

void FleetConsumer::handle(const std::vector<Inbound>& batch) {
  std::vector<FleetMessage> messages;
  std::vector<const Inbound*> sources;
  for (const auto& m : batch) {
    auto parsed = parse_fleet_message(settings_.accept, m.topic, m.payload);
    if (const auto* r = std::get_if<FleetRejection>(&parsed)) {
      store_reject(m, r->reason, utf8_or_replaced(r->detail));
      continue;
    }
    messages.push_back(std::get<FleetMessage>(std::move(parsed)));
    sources.push_back(&m);
  }
  if (messages.empty()) return;
  std::vector<fleet::BatchOutcome> outcomes;
  with_database([&](fleet::FleetStore& store) { outcomes = store.write_batch(messages); });
  if (outcomes.size() != messages.size()) return;  // given up at stop (logged)
  for (std::size_t i = 0; i < messages.size(); ++i) count(messages[i], outcomes[i], *sources[i]);
}

void FleetConsumer::count(const FleetMessage& m, const fleet::BatchOutcome& outcome, const Inbound& source) {
  if (!outcome.written) {
    store_reject(source, fleet::RejectReason::database_refused, utf8_or_replaced(outcome.refusal), header_of(m));
    return;
  }
  if (const auto* gone = std::get_if<fleet::GoneMessage>(&m)) return count_lost(*gone, *outcome.written);
  std::lock_guard lock(mutex_);
  if (std::holds_alternative<fleet::StatusMessage>(m)) ++counters_.statuses;
  else ++(*outcome.written == fleet::WriteOutcome::stored ? counters_.stored : counters_.duplicates);
}

// A daemon named ids it cannot send: recorded (fleet.lost_messages), counted and logged, never silent.
void FleetConsumer::count_lost(const fleet::GoneMessage& gone, fleet::WriteOutcome outcome) {
  if (outcome == fleet::WriteOutcome::duplicate) return;  // every range known already
  std::int64_t ids = 0;
  std::string ranges;
  for (const auto& r : gone.ranges) {
    ids += r.to - r.from + 1;
    ranges += (ranges.empty() ? "" : ", ") + std::to_string(r.from) + ".." + std::to_string(r.to) + " (" + storage::to_string(r.reason) + ")";
  }
  {
    std::lock_guard lock(mutex_);
    counters_.lost_ranges += gone.ranges.size();
    counters_.lost_messages += static_cast<std::uint64_t>(ids);
  }
  spdlog::error("fleet: {}/{} cannot send {} messages again, recorded in fleet.lost_messages: {}", gone.site, gone.gearbox, ids, ranges);
}

// A hole asked for since the give-up time without an answer: recorded lost (no_answer), counted
// and logged once; if its gearbox comes back and sends the ids, they are stored all the same.
void FleetConsumer::count_unanswered(const fleet::MessageHole& h) {
  const std::int64_t ids = h.to - h.from + 1;
  {
    std::lock_guard lock(mutex_);
    ++counters_.lost_ranges;
    counters_.lost_messages += static_cast<std::uint64_t>(ids);
  }
  spdlog::error("fleet: {}/{} has not answered requests for {} missing messages ({}..{}) for {} s; recorded in fleet.lost_messages as "
                "no_answer (stored all the same if they come)",
                h.site, h.gearbox, ids, h.from, h.to, settings_.resend_give_up.count());
}

void FleetConsumer::store_reject(const Inbound& m, fleet::RejectReason reason, const std::string& detail,
                                 std::optional<fleet::MessageHeader> header) {
  {
    std::lock_guard lock(mutex_);
    ++counters_.rejected[reason];
  }
  log_->warn(fleet::to_string(reason), std::string("rejected a message on ") + utf8_or_replaced(m.topic) + ": " +
                                            fleet::to_string(reason) + ": " + detail + " (kept in fleet.rejects)");
  try {
    with_database([&](fleet::FleetStore& store) { store.write(fleet::Reject{m.topic, m.payload, reason, detail, header}); });
  } catch (const fleet::FleetRefusedError& e) {
    spdlog::error("fleet: the database refused a reject: {}", e.what());
  }
}

bool FleetConsumer::stop_requested() const {
  std::lock_guard lock(mutex_);
  return stopping_;
}

}  // namespace gearwatch::daemon
