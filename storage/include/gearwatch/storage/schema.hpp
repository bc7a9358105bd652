#pragma once
// The database schema (docs/storage.md) and its migrations. The schema version lives in
// PRAGMA user_version; migrate() applies each missing step in its own transaction, so a
// database written by an older gearwatch is upgraded in place and never half-migrated.
#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::storage {

/// The version this build writes.
int current_schema_version() noexcept;

/// Sets WAL mode and synchronous=FULL (a committed transaction survives a crash or power
/// loss), then migrates. Throws SqliteError if the file is newer than this build knows.
void open_and_migrate(Database& db);

}  // namespace gearwatch::storage
