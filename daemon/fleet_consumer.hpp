#pragma once
// The fleet consumer (docs/fleet.md): a persistent MQTT session (clean_session false, a fixed
// client id, QoS 1) on every gearbox under the prefix, and one thread that writes what arrives into
// the fleet store. The class owns its queue: libmosquitto's network thread pushes, the writer
// thread pops, parses and writes; bad input is counted, logged (rate-limited) and kept in
// fleet.rejects; the database going away holds the message and retries.
//
// Holes: while the queue is empty, every resend_interval, the ids of each gearbox that neither
// arrived nor are known lost are asked for again on <prefix>/<site>/<gearbox>/resend; the daemon's
// resend_gone answer is stored in fleet.lost_messages, counted and logged; a hole nobody answers
// within resend_give_up is recorded there as no_answer.
//
// Stop: the session is closed first (the broker keeps what arrives later for this client id),
// then the writer drains the queue, so what was acknowledged to the broker is in the database.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "fleet_messages.hpp"
#include "mqtt_sender.hpp"

struct mosquitto;

namespace gearwatch::daemon {

struct FleetIngestSettings {
  std::string host = "127.0.0.1";
  int port = 1883;
  std::string client_id = "gearwatch-fleet";
  std::optional<MqttCredentials> credentials;
  /// TLS: the CA that signed the broker's certificate turns it on; a client certificate and its
  /// key go together (as the daemon's [mqtt] ca_file, cert_file, key_file).
  std::string ca_file, cert_file, key_file;
  std::string database;  ///< libpq connection string or postgresql:// URI
  FleetAcceptance accept{"gearwatch", {}};
  std::size_t queue_capacity = 10000;  ///< beyond it the network thread waits (the broker holds the rest)
  std::size_t batch_size = 200;        ///< messages per database transaction, at most (fewer when fewer wait)
  int retry_initial_ms = 200, retry_max_ms = 5000;
  /// How often, while the queue is empty, the holes are looked for and asked for again.
  std::chrono::milliseconds resend_interval{60000};
  /// A hole asked for this long without an answer is recorded lost (no_answer). The default is the
  /// daemon's MQTT session expiry: past it the broker no longer keeps the request for the daemon.
  std::chrono::seconds resend_give_up{7 * 24 * 3600};
  /// Test hook (GEARWATCH_FLEET_TEST_STALL_AFTER, read by `fleet ingest` only): write this many
  /// messages, then hold everything received after them uncommitted, as a kill -9 would find it.
  std::optional<std::uint64_t> stall_after;
};

struct FleetCounters {
  std::uint64_t received = 0, stored = 0, duplicates = 0, statuses = 0, database_retries = 0, connects = 0;
  std::uint64_t resend_requests = 0;              ///< requests published (one per gearbox with holes, each check)
  std::uint64_t resend_refused = 0;               ///< of them refused by the broker (PUBACK reason >= 0x80)
  std::uint64_t lost_ranges = 0, lost_messages = 0;  ///< new fleet.lost_messages rows and the ids they cover
  std::map<fleet::RejectReason, std::uint64_t> rejected;
  std::uint64_t rejected_total() const;
};
/// One line: "received N, stored N, duplicates N, ..., rejected N (reason N, ...)".
std::string to_string(const FleetCounters& c);

class FleetConsumer {
 public:
  explicit FleetConsumer(FleetIngestSettings settings);
  ~FleetConsumer();
  FleetConsumer(const FleetConsumer&) = delete;
  FleetConsumer& operator=(const FleetConsumer&) = delete;

  /// Connects to the database and migrates its fleet schema (throws with one line when it cannot),
  /// then starts the writer thread and the MQTT session (which retries the broker on its own).
  void start();
  /// Closes the session, stores what was received, joins. Idempotent.
  void stop();
  FleetCounters counters() const;

 private:
  struct Inbound {
    std::string topic, payload;
  };
  void connect_store();
  void start_session();
  void use_tls();
  void enqueue(Inbound m);
  void writer_loop();
  std::vector<Inbound> next_batch();
  void stall_for_test(std::uint64_t taken);
  void ask_for_holes();
  void ask(const std::vector<fleet::MessageHole>& holes);
  void handle(const std::vector<Inbound>& batch);
  void count(const FleetMessage& m, const fleet::BatchOutcome& outcome, const Inbound& source);
  void store_reject(const Inbound& m, fleet::RejectReason reason, const std::string& detail,
                    std::optional<fleet::MessageHeader> header = std::nullopt);
  void count_lost(const fleet::GoneMessage& gone, fleet::WriteOutcome outcome);
  void count_unanswered(const fleet::MessageHole& h);
  template <class Write>
  void with_database(Write&& write);
  void on_connect(int rc);
  void on_request_refused(int reason);
  bool stop_requested() const;

  FleetIngestSettings settings_;
  std::unique_ptr<fleet::FleetStore> store_;
  // Holes asked for, with when (writer thread only): the same hole is asked again only after
  // kReaskIntervals intervals, so requests do not pile up while a daemon is away.
  std::map<std::tuple<std::string, std::string, std::int64_t, std::int64_t>, std::chrono::steady_clock::time_point> asked_;
  mosquitto* client_ = nullptr;
  std::mutex client_mutex_;  // the writer thread publishes resend requests while stop() may destroy the client
  std::thread writer_;
  mutable std::mutex mutex_;
  std::condition_variable arrived_, space_;
  std::deque<Inbound> queue_;
  bool stopping_ = false;
  bool started_ = false;
  FleetCounters counters_;  // under mutex_
  class LogLimiter;
  std::unique_ptr<LogLimiter> log_;
};

}  // namespace gearwatch::daemon
