#pragma once
// The database schema (docs/storage.md) and its migrations. The schema version lives in
// PRAGMA user_version; migrate() applies each missing step in its own transaction, so a
// database written by an older gearwatch is upgraded in place and never half-migrated.
#include <map>
#include <string>
#include <vector>

#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::storage {

/// The version this build writes.
int current_schema_version() noexcept;

/// Every enumerated value a column may hold, per domain ("alert_kind" -> {"wear_mechanism", ...}).
/// Each list is made from its enum's to_string over its kAll... array, so the enum is the one
/// source of truth: the vocabulary table holds it and triggers refuse anything else
/// (records.end_reason and wear_mechanism_assessments.mechanism also have CHECK lists from
/// older schema versions; a test asserts they equal the enums).
using Vocabulary = std::map<std::string, std::vector<std::string>>;

/// The domains of core's enums: record_end_reason, wear_mechanism, alert_kind, alert_severity,
/// alert_transition, skip_reason, and the model's model_update_kind, model_update_trigger,
/// model_update_outcome, model_issue (gearwatch/wear/updating.hpp).
Vocabulary core_vocabulary();

/// Sets WAL mode and synchronous=FULL (a committed transaction survives a crash or power
/// loss), migrates, and writes the vocabulary (core's plus `extra`: the domains of the layers
/// above core: rejected_frame_kind, gap_cause). A domain absent from the
/// vocabulary is not checked. Throws SqliteError if the file is newer than this build knows.
void open_and_migrate(Database& db, const Vocabulary& extra = {});

}  // namespace gearwatch::storage
