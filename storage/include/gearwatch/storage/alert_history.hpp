#pragma once
// Typed readers of the alert history (views alerts and active_alerts, docs/storage.md): kinds,
// severities and transitions come back as their enums, so readers decide on types, never on the
// spelling of a token. A token this build does not know is refused (std::runtime_error naming
// the row). A database before schema version 3 has neither channels, subjects nor transitions:
// its alerts read as one-off events.
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/types/alerts.hpp"

namespace gearwatch::storage {

struct StoredAlert {
  std::int64_t id = 0;
  std::string created_at;
  AlertSeverity severity = AlertSeverity::info;
  AlertKind kind = AlertKind::wear_mechanism;
  std::optional<std::int64_t> channel;  ///< NULL: the gearbox as a whole (for tacho alerts: the shaft)
  std::string subject;
  AlertTransition transition = AlertTransition::event;
  std::string value;
  std::optional<std::int64_t> record_id;
  std::string message;
};

/// Every alert transition stored.
std::int64_t count_alerts(Database& db);

/// The `newest` newest transitions, newest first.
std::vector<StoredAlert> load_newest_alerts(Database& db, std::size_t newest);

/// The transitions of records with id >= first_record, and those without a record made at or
/// after `since` (ISO 8601 UTC), oldest first. Empty before schema version 3.
std::vector<StoredAlert> load_alerts_since(Database& db, std::int64_t first_record, const std::string& since);

/// An alert raised now (view active_alerts) with the severity and message of its newest
/// `raised` transition (the view has neither).
struct StoredActiveAlert {
  AlertKind kind = AlertKind::wear_mechanism;
  std::optional<std::int64_t> channel;
  std::string subject, value, raised_at, updated_at;
  std::optional<AlertSeverity> severity;  ///< nullopt when no `raised` transition is stored
  std::string message;
};

/// The alerts raised now, by kind, channel and subject. Empty before schema version 3.
std::vector<StoredActiveAlert> load_active_alerts(Database& db);
/// The alerts of one kind raised now, by channel and subject (other kinds are not read).
std::vector<StoredActiveAlert> load_active_alerts(Database& db, AlertKind kind);

/// The alert trackers' states as last written back (table alert_state), the one loader of the
/// processing and model threads: the states of the kinds in `only` (every kind when empty). A
/// kind this build does not know was written by a newer one and is skipped: not ours to judge.
std::map<AlertKey, AlertState> load_alert_states(Database& db, const std::vector<AlertKind>& only = {});

}  // namespace gearwatch::storage
