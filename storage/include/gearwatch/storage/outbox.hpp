#pragma once
// The MQTT outbox (docs/mqtt.md): store and forward. Every message a gearbox publishes is first a
// row of table `outbox`, written by OutboxWriter inside the very transaction that stores the data
// it reports, so a message exists exactly when its data does. The sender thread reads the rows in
// id order through OutboxReader (its own connection) and marks them delivered on PUBACK.
//
// Limit: at most `limit` undelivered rows are kept. When a transaction would leave more, the
// oldest undelivered rows are deleted in that transaction and counted (outbox_counters 'dropped');
// the sender turns a growing count into an mqtt_outbox_full alert. Delivered and refused rows are
// pruned to the newest `limit` as well. A row the broker refused (MQTT 5 PUBACK reason >= 0x80)
// is marked refused with the reason and counted (outbox_counters 'refused'); it is not sent again.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "gearwatch/storage/messages.hpp"
#include "gearwatch/storage/outbox_gone_reason.hpp"

namespace gearwatch::storage {

class Database;

/// One topic per kind of message, under <prefix>/<site>/<gearbox>/.
enum class OutboxTopic : std::uint8_t { alert, record, wear, model, health, gap };
inline constexpr std::array kAllOutboxTopics{OutboxTopic::alert, OutboxTopic::record, OutboxTopic::wear,
                                             OutboxTopic::model, OutboxTopic::health, OutboxTopic::gap};
const char* to_string(OutboxTopic topic) noexcept;
std::optional<OutboxTopic> parse_outbox_topic(const std::string& text) noexcept;

/// Who publishes: copied into every payload so a fleet consumer can tell gearboxes apart.
struct OutboxIdentity {
  std::string site;
  std::string gearbox;
  std::uint64_t limit = 100000;  ///< undelivered messages kept
};

/// Writes outbox rows on the writer's connection, inside the caller's transaction.
class OutboxWriter {
 public:
  OutboxWriter(Database& db, OutboxIdentity identity) : db_(db), identity_(std::move(identity)) {}
  void record(std::int64_t record_id, const RecordResult& r);
  void alerts(std::optional<std::int64_t> record_id, const std::vector<AlertEvent>& alerts);
  void model(std::optional<std::int64_t> record_id, std::int64_t run_id, const ModelRunResult& m);
  void gap(std::optional<std::int64_t> record_id, std::int64_t report_id, const GapReportResult& g);
  void health(const HealthSnapshot& h);
  /// Drops the oldest undelivered rows beyond the limit (counted) and prunes delivered rows.
  void enforce_limit();

 private:
  Database& db_;
  OutboxIdentity identity_;
};

struct OutboxMessage {
  std::int64_t id = 0;
  OutboxTopic topic = OutboxTopic::record;
  std::string payload;  ///< JSON, as stored and as published
};

/// A message the broker refused: its row and the broker's reason ("0x87 Not authorized").
struct OutboxRefusal {
  std::int64_t id = 0;
  std::string reason;
};

/// A run of ids [from, to] that a resend cannot serve.
struct OutboxGone {
  std::int64_t from = 0, to = 0;
  OutboxGoneReason reason = OutboxGoneReason::not_held;
};

struct OutboxResend {
  std::vector<OutboxMessage> rows;
  std::vector<OutboxGone> gone;
};

/// The sender's side, on its own connection. "Undelivered" means neither delivered nor refused.
class OutboxReader {
 public:
  explicit OutboxReader(Database& db) : db_(db) {}
  /// Undelivered rows with id > after, oldest first, at most `limit`.
  std::vector<OutboxMessage> undelivered_after(std::int64_t after, std::size_t limit);
  void mark_delivered(const std::vector<std::int64_t>& ids);
  /// Marks the rows refused with their reasons (never sent again) and counts each once.
  void mark_refused(const std::vector<OutboxRefusal>& refusals);
  /// Messages the broker refused since the database was made (pruned rows included).
  std::int64_t refused();
  std::int64_t undelivered_count();
  /// Messages dropped at the limit since the database was made.
  std::int64_t dropped();
  /// Every id up to this one has had the broker's answer (delivered or refused) or is gone: the
  /// id below the oldest waiting row, or the newest id when none waits.
  std::int64_t delivered_through();
  /// The newest id the outbox has given out (0 when none): ids above it were never sent.
  std::int64_t newest_id();
  /// What a resend request for `ranges` (each [from, to], at most the newest id) finds, read in
  /// one transaction so both parts agree: the rows held and not refused, delivered or not, oldest
  /// first and at most `limit` of them; and the runs of ids that cannot be served.
  OutboxResend resend(const std::vector<std::pair<std::int64_t, std::int64_t>>& ranges, std::size_t limit);

 private:
  Database& db_;
};

}  // namespace gearwatch::storage
