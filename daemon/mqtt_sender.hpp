#pragma once
// The MQTT sender thread (docs/mqtt.md): owns its libmosquitto connection and its own database
// connection, and delivers the outbox's rows in id order with QoS 1, at most `inflight` of them
// unacknowledged. A row is marked delivered when its PUBACK arrives. Any disconnect ends the
// session: the client is destroyed, and the next session (after a backoff) publishes again from
// the oldest undelivered row, so the order holds and only QoS 1's duplicates can occur.
// A refusal by the broker (bad credentials, not authorised) is logged in one line, counted and
// raised as an mqtt_refused alert; a growing outbox drop count raises mqtt_outbox_full. The
// client speaks MQTT 5 so that a publish the broker refuses (PUBACK reason >= 0x80, e.g. outside
// the ACL) is seen: the row is marked refused with the reason, counted, logged (rate-limited) and
// raised as mqtt_publish_refused, cleared when a topic it was raised for is accepted. Alerts go
// through the storage writer (their outbox rows with them) until close_alerts().
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "gearwatch/alerts.hpp"
#include "gearwatch/config/config.hpp"
#include "gearwatch/storage/outbox.hpp"
#include "gearwatch/storage/writer.hpp"

struct mosquitto;

namespace gearwatch::daemon {

struct MqttCounters {
  std::atomic<std::uint64_t> published{0};         ///< PUBLISH sent (resends included)
  std::atomic<std::uint64_t> delivered{0};         ///< rows marked delivered (PUBACK)
  std::atomic<std::uint64_t> connects{0};          ///< sessions accepted by the broker
  std::atomic<std::uint64_t> connect_failures{0};  ///< unreachable, timed out or lost before CONNACK
  std::atomic<std::uint64_t> refused{0};           ///< CONNACK refusals (credentials, authorisation)
  std::atomic<std::uint64_t> outbox_dropped{0};    ///< messages dropped at the outbox limit (database total)
  std::atomic<std::uint64_t> publish_refused{0};   ///< outbox messages the broker refused (PUBACK reason >= 0x80)
  std::atomic<std::uint64_t> resend_requests{0};   ///< resend requests taken (docs/fleet.md)
  std::atomic<std::uint64_t> resent{0};            ///< outbox rows published again for them
  std::atomic<std::uint64_t> resend_gone{0};       ///< ids asked for that the outbox cannot serve (named on resend_gone)
  std::atomic<std::uint64_t> resend_ignored{0};    ///< requests (or ranges) ignored: malformed, another gearbox's, never sent
};

/// The sender's counters into a health snapshot's mqtt_* counters (storage::kMqttHealthCounters).
void add_mqtt_counters(const MqttCounters& m, storage::HealthSnapshot& s);

/// Why a resend request (or one of its ranges) is ignored.
enum class ResendIgnored : std::uint8_t { malformed, other_gearbox, never_sent };
const char* to_string(ResendIgnored why) noexcept;

/// A resend request's id ranges, [from, to] each, or why it is ignored (docs/fleet.md):
/// {"site": S, "gearbox": G, "ranges": [[from, to], ...]} naming this gearbox, 1 <= from <= to.
struct ResendRequest {
  std::vector<std::pair<std::int64_t, std::int64_t>> ranges;
  std::optional<ResendIgnored> ignored;
  std::string detail;  ///< one line, when ignored
};
ResendRequest parse_resend_request(const config::MqttSettings& self, const std::string& payload);

/// "username:password" from the first line of `password_file`; a relative name is looked up in
/// $CREDENTIALS_DIRECTORY (systemd LoadCredential=) when that is set. Throws std::runtime_error.
struct MqttCredentials {
  std::string username, password;
};
MqttCredentials read_mqtt_credentials(const std::string& password_file);

/// The topic of one kind of message: <prefix>/<site>/<gearbox>/<kind>.
std::string mqtt_topic(const config::MqttSettings& s, const std::string& kind);

class MqttSender {
 public:
  MqttSender(config::MqttSettings settings, std::string database, storage::StorageWriter& writer);
  ~MqttSender();
  MqttSender(const MqttSender&) = delete;
  MqttSender& operator=(const MqttSender&) = delete;

  /// Reads the credentials (throws on an unreadable file) and starts the thread.
  void start();
  /// Gives the sender up to 5 s (at most drain_timeout_s) to publish what is committed while it
  /// is connected, so a refusal or a full outbox met now is still raised through the writer.
  /// Returns at once when it is not connected (backing off after a failure or a refusal).
  void settle();
  /// After this, alerts are only logged: call before the storage writer stops.
  void close_alerts();
  /// Delivers what the outbox holds for up to drain_timeout_s, says offline, joins.
  void stop();
  const MqttCounters& counters() const noexcept { return counters_; }

 private:
  struct Session;
  void run();
  bool open_session(Session& s);
  void run_session(Session& s);
  void fill_window(Session& s);
  bool publish_row(Session& s, const storage::OutboxMessage& m);
  void mark_acknowledged(Session& s);
  bool drained(Session& s);
  void publish_status(Session& s, bool online);
  void on_refusal(int rc);
  void on_accepted();
  void on_publish_refusals(Session& s);
  void on_publish_accepted(Session& s);
  void check_dropped();
  void take_resend_requests(Session& s);
  void publish_gone(Session& s, const std::vector<storage::OutboxGone>& gone);
  void fill_resends(Session& s);
  void ignore_resend(ResendIgnored why, const std::string& detail);
  void raise(AlertKind kind, bool present, const std::string& value, const std::string& message);
  bool wait_backoff(std::chrono::milliseconds delay);

  config::MqttSettings settings_;
  std::string database_;
  storage::StorageWriter& writer_;
  MqttCredentials credentials_;
  MqttCounters counters_;
  std::unique_ptr<storage::Database> db_;   // the sender thread's own connection
  AlertTracker alerts_;
  std::int64_t dropped_seen_ = -1;
  std::set<storage::OutboxTopic> refused_topics_;   // topics refused since the alert was raised
  bool clear_on_any_accept_ = false;                // raised by an earlier run: topics unknown
  std::uint64_t refusals_unlogged_ = 0;
  std::chrono::steady_clock::time_point next_refusal_log_{};
  std::chrono::steady_clock::time_point next_ignored_log_{};
  std::chrono::steady_clock::time_point next_drop_check_{};
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  enum class Phase : int { connecting, connected, backing_off };
  std::atomic<Phase> phase_{Phase::connecting};
  std::atomic<bool> idle_{false};  // connected, nothing in flight, nothing committed left to send
  bool alerts_open_ = true;
  std::chrono::steady_clock::time_point drain_deadline_{};
  std::thread thread_;
};

}  // namespace gearwatch::daemon
