#pragma once
// `gearwatch publish`: the MQTT sender in a process and a systemd unit of its own
// ([mqtt] sender = "publisher", docs/mqtt.md). The daemon keeps filling the outbox in the
// transactions that store what it reports, and needs no IP; this process needs IP and no CAN,
// so each unit keeps its own exposure low. It delivers the outbox exactly as the daemon's own
// sender thread would (the same MqttSender), raises its alerts through a storage writer of its
// own (alerts need no run), and stores its counters in publisher_health.
#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>

#include "gearwatch/config/config.hpp"
#include "gearwatch/storage/database_lock.hpp"
#include "gearwatch/storage/writer.hpp"
#include "mqtt_sender.hpp"

namespace gearwatch::daemon {

/// What the publisher needs beyond the config, with its defaults.
struct PublisherOptions {
  /// How often to look again for a database the daemon has not created yet.
  std::chrono::milliseconds database_poll{2000};
};

class Publisher {
 public:
  Publisher(config::GearwatchConfig config, PublisherOptions options = {});
  ~Publisher();
  Publisher(const Publisher&) = delete;
  Publisher& operator=(const Publisher&) = delete;

  /// Runs until SIGTERM or SIGINT (or returns at once when stopped while waiting for the
  /// database). Throws std::runtime_error (one line) when the config or the database cannot be used.
  void run();

 private:
  void check_config() const;
  void handle_signals();
  bool database_ready() const;
  bool wait_for_database();
  void take_publisher_lock();
  void open_writer();
  void start_sender();
  void notify_ready();
  void arm_health_timer();
  void arm_watchdog();
  void write_health(bool final);
  void stop_in_reverse();

  config::GearwatchConfig config_;
  PublisherOptions options_;
  boost::asio::io_context io_;
  std::optional<boost::asio::signal_set> signals_;
  boost::asio::steady_timer health_timer_;
  boost::asio::steady_timer watchdog_;
  std::uint64_t watchdog_usec_ = 0;
  bool stop_requested_ = false;
  std::optional<storage::DatabaseLock> lock_;  // one publisher per database
  std::optional<storage::StorageWriter> writer_;
  std::unique_ptr<MqttSender> sender_;
};

}  // namespace gearwatch::daemon
