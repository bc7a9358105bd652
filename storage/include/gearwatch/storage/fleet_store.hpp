#pragma once
// The fleet store (docs/fleet.md): every gearbox's published messages in one PostgreSQL database,
// written by `gearwatch fleet ingest` through these typed writers. All of its SQL lives in
// storage/src/fleet_store.cpp (libpqxx); callers hand over values, never statements.
//
// Idempotence: table fleet.messages holds (gearbox, message_id) once; a message already there is a
// repeat (QoS 1 allows them) and changes nothing. The data tables carry their own natural keys
// (gearbox, record_id), (gearbox, model_run_id), … with ON CONFLICT DO NOTHING, so a message can
// never add a row twice even if the ledger were bypassed.
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "gearwatch/storage/outbox_gone_reason.hpp"

namespace gearwatch::storage::fleet {

/// The fleet schema's version, kept in fleet.schema_version; migrate() brings a database to it.
int current_fleet_schema_version() noexcept;

/// What every message but `status` starts with (docs/mqtt.md).
struct MessageHeader {
  std::string site, gearbox;
  std::int64_t message_id = 0;
  std::optional<std::int64_t> record_id;
  std::string record_time;  ///< ISO 8601 UTC, as published
};

struct IndicatorValue {
  int channel = 0;
  std::string name;
  std::optional<double> value;
};
struct IndicatorSkip {
  int channel = 0;
  std::string name, reason, detail;
};
struct RecordMessage {
  MessageHeader header;  ///< record_id is set
  std::int64_t stream_sequence = 0, start_index = 0;
  std::optional<double> duration_s;
  bool analysed = false;
  std::string reject_reason;
  std::optional<double> speed_hz, torque_nm, input_revolutions;
  std::vector<IndicatorValue> indicators;
  std::vector<IndicatorSkip> skipped;
};

struct WearVerdict {
  int channel = 0;
  std::string mechanism;
  std::int64_t points = 0;
  std::optional<double> low_band_p, high_band_p;
  std::string evidence;
};
struct WearMessage {
  MessageHeader header;
  std::vector<WearVerdict> verdicts;
};

enum class AlertTransition : std::uint8_t { raised, cleared, event };
const char* to_string(AlertTransition t) noexcept;
std::optional<AlertTransition> parse_alert_transition(const std::string& text) noexcept;

struct AlertMessage {
  MessageHeader header;
  AlertTransition transition = AlertTransition::event;
  std::string severity, kind;
  std::optional<int> channel;
  std::string subject, value, message;
};

struct ModelMessage {
  MessageHeader header;
  std::int64_t model_run_id = 0, gear_pair = 0;
  bool advanced = false;
  std::optional<double> cycles, k_wear, k_pitting, wear_mean_depth_m, wear_max_depth_m, pitting_mean;
  std::string forecast_json;  ///< the forecast object as published (remaining life per mode)
};

struct GapMessage {
  MessageHeader header;
  std::int64_t gap_report_id = 0, gear_pair = 0;
  std::optional<double> input_revolutions;
  std::string significant_families_json, chosen_effects_json, unexplained_families_json;
};

struct HealthMessage {
  MessageHeader header;
  bool final = false;
  std::map<std::string, std::int64_t> counters;
};

struct StatusMessage {
  std::string site, gearbox, state, version;
  std::int64_t schema = 0;
  std::optional<std::int64_t> delivered_through;  ///< every id up to it was published (absent from older daemons)
};

/// A daemon's reason on resend_gone: its outbox's own vocabulary.
using storage::OutboxGoneReason;
/// Reads one from a message.
std::optional<OutboxGoneReason> parse_gone_reason(const std::string& text) noexcept;

/// Why the ids of a fleet.lost_messages range are not expected any more: the daemon's own answer
/// (not_held, refused), or no answer to the consumer's requests within its give-up time.
enum class LostReason : std::uint8_t { not_held, refused, no_answer };
inline constexpr LostReason kAllLostReasons[] = {LostReason::not_held, LostReason::refused, LostReason::no_answer};
const char* to_string(LostReason r) noexcept;
std::optional<LostReason> parse_lost_reason(const std::string& text) noexcept;
LostReason lost_reason_of(OutboxGoneReason r) noexcept;

/// A daemon's answer to a resend request (<prefix>/<site>/<gearbox>/resend_gone): ids it cannot send.
struct LostRange {
  std::int64_t from = 0, to = 0;
  OutboxGoneReason reason = OutboxGoneReason::not_held;
};
struct GoneMessage {
  std::string site, gearbox;
  std::vector<LostRange> ranges;
};

/// Ids of one gearbox that neither arrived nor are known lost, below the newest it is known to
/// have sent: what the consumer asks for again.
struct MessageHole {
  std::string site, gearbox;
  std::int64_t from = 0, to = 0;
};

/// Why a message was not stored as data (each goes to fleet.rejects).
enum class RejectReason : std::uint8_t { not_utf8, malformed_json, wrong_schema, unknown_topic, unknown_gearbox, database_refused };
inline constexpr RejectReason kAllRejectReasons[] = {RejectReason::not_utf8,      RejectReason::malformed_json,
                                                     RejectReason::wrong_schema,  RejectReason::unknown_topic,
                                                     RejectReason::unknown_gearbox, RejectReason::database_refused};
const char* to_string(RejectReason r) noexcept;

struct Reject {
  std::string topic;
  std::string payload;  ///< the bytes as received (stored as bytea: they may not be UTF-8)
  RejectReason reason = RejectReason::malformed_json;
  std::string detail;   ///< one line, UTF-8
  /// The message's gearbox and id when it was read that far (database_refused): counted as seen,
  /// so it is not asked for again.
  std::optional<MessageHeader> header;
};

/// Outcome of writing one data message.
enum class WriteOutcome : std::uint8_t { stored, duplicate };

/// Any message the store takes as data.
using Message =
    std::variant<RecordMessage, WearMessage, AlertMessage, ModelMessage, GapMessage, HealthMessage, StatusMessage, GoneMessage>;

/// One message's fate in a batch: stored, a repeat, or refused by the database (with its reason).
struct BatchOutcome {
  std::optional<WriteOutcome> written;  ///< empty: refused
  std::string refusal;                   ///< one line, when refused
};

/// The database is unreachable or the connection broke: the caller keeps the message and retries.
struct FleetConnectionError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
/// The database refused this message (a constraint, a value out of range): retrying will not help.
struct FleetRefusedError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// One connection to the fleet database, owned by one thread. Each call is one transaction.
class FleetStore {
 public:
  /// Connects (a libpq connection string or postgresql:// URI). Throws FleetConnectionError.
  explicit FleetStore(const std::string& connection);
  ~FleetStore();
  FleetStore(const FleetStore&) = delete;
  FleetStore& operator=(const FleetStore&) = delete;

  /// Creates the fleet schema or brings it to current_fleet_schema_version(), under an advisory
  /// lock so two consumers starting together do not both migrate. Returns the version found.
  int migrate();
  /// Brings the schema to `version` only (for the migration test). Returns the version found.
  int migrate_to(int version);

  /// Several messages in one transaction (one commit, one WAL flush), each inside its own
  /// savepoint: a message the database refuses is rolled back alone and reported, the others
  /// commit. Throws FleetConnectionError (nothing committed: retry the whole batch; the ledger
  /// makes a retry of an in-doubt commit harmless).
  std::vector<BatchOutcome> write_batch(const std::vector<Message>& messages);
  /// A message not stored as data, with its bytes and reason (its own transaction).
  void write(const Reject& r);
  /// Every gearbox's holes (docs/fleet.md), oldest first.
  std::vector<MessageHole> holes();
  /// The consumer's periodic look (docs/fleet.md, "No answer"), one transaction: every hole, with
  /// when it was first asked for (a hole inherits the time of the holes it overlaps, so a hole that
  /// shrinks keeps its age); holes first asked for at least give_up_after ago are recorded lost
  /// (no_answer) and returned apart.
  struct HoleCheck {
    std::vector<MessageHole> to_ask, given_up;
  };
  HoleCheck check_holes(std::chrono::seconds give_up_after);

 private:

  std::string connection_string_;
  struct Connection;  ///< the libpqxx connection (storage/src/fleet_store.cpp)
  std::unique_ptr<Connection> conn_;
};

}  // namespace gearwatch::storage::fleet
