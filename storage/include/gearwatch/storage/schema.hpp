#pragma once
// The database schema (docs/storage.md) and its migrations. The schema version lives in
// PRAGMA user_version; migrate() applies each missing step in its own transaction, so a
// database written by an older gearwatch is upgraded in place and never half-migrated.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::storage {

/// The version this build writes.
int current_schema_version() noexcept;

/// What gearwatch writes into PRAGMA application_id ("GWCH"), so that gearwatch and tools such as
/// file(1) tell its databases from other SQLite files.
inline constexpr std::int32_t kApplicationId = 0x47574348;

/// What a SQLite file holds, as far as gearwatch is concerned.
enum class DatabaseKind {
  empty,                            ///< no tables, views or versions: a new file
  gearwatch,                        ///< carries gearwatch's application_id
  gearwatch_before_application_id,  ///< application_id 0, a schema version this build knows and the
                                    ///< tables of the first schema version: written before
                                    ///< gearwatch set application_id
  foreign,                          ///< anything else: another application's database
};
const char* to_string(DatabaseKind kind) noexcept;

struct DatabaseIdentity {
  DatabaseKind kind = DatabaseKind::empty;
  std::int64_t application_id = 0;
  int user_version = 0;
  std::int64_t schema_objects = 0;  ///< tables, views, indexes and triggers
};

/// Reads the identity without changing anything (works on a read-only connection).
DatabaseIdentity identify_database(Database& db);

/// Refused: the file is another application's database (or not one gearwatch can read). Nothing
/// was changed.
struct ForeignDatabase : SqliteError {
  explicit ForeignDatabase(const std::string& what) : SqliteError(0, what) {}
};

/// Throws ForeignDatabase unless `identity` is empty or gearwatch's; the message names `path`, the
/// application_id, the schema version and the number of objects found.
void refuse_foreign_database(const std::string& path, const DatabaseIdentity& identity);

/// Every enumerated value a column may hold, per domain ("alert_kind" -> {"wear_mechanism", ...}).
/// Each list is made from its enum's to_string over its kAll... array, so the enum is the one
/// source of truth: the vocabulary table holds it and triggers refuse anything else
/// (records.end_reason and wear_mechanism_assessments.mechanism also have CHECK lists from
/// older schema versions; a test asserts they equal the enums).
using Vocabulary = std::map<std::string, std::vector<std::string>>;

/// The domains of core's enums: record_end_reason, wear_mechanism, alert_kind, alert_severity,
/// alert_transition, skip_reason, indicator_note, speed_source, carrier_band, and the model's model_update_kind, model_update_trigger,
/// model_update_outcome, model_issue (gearwatch/wear/updating.hpp).
Vocabulary core_vocabulary();

/// The vocabulary domain of acquisition::DropoutCause. The database was released calling
/// acquisition's dropouts "gaps"; staff's queries use those names, so they are kept (the table
/// gap_events, this domain, the health columns gaps, gap_samples, ring_gaps and
/// records_restarted_after_gap, the end reason cut_at_gap): docs/storage.md, "Stored names".
inline constexpr const char* kDropoutCauseDomain = "gap_cause";

/// Sets WAL mode and synchronous=FULL (a committed transaction survives a crash or power
/// loss), migrates, and writes the vocabulary (core's plus `extra`: the domains of the layers
/// above core: rejected_frame_kind, kDropoutCauseDomain). A domain absent from the
/// vocabulary is not checked. Throws SqliteError if the file is newer than this build knows, and
/// ForeignDatabase — before anything is written, so the file stays byte for byte as it was — if
/// it is not empty and not gearwatch's. Sets PRAGMA application_id (also on a gearwatch database
/// written before it was set).
void open_and_migrate(Database& db, const Vocabulary& extra = {});
/// Applies the missing steps up to `version` only (each in its own transaction), writing no
/// vocabulary: for tests that build a database of an older schema and migrate it.
void migrate_to_version(Database& db, int version);

/// Turns on foreign-key checks for this connection (open_and_migrate does it too): for a
/// connection that writes to a database another process has already migrated.
void enable_foreign_keys(Database& db);

}  // namespace gearwatch::storage
