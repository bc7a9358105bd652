#include "gearwatch/storage/alert_history.hpp"

#include <algorithm>
#include <stdexcept>

#include "stored_rows.hpp"
#include "stored_tokens.hpp"

namespace gearwatch::storage {
namespace {

using detail::enum_of;
bool has_view(Database& db, const char* name) { return detail::has_object(db, name); }

// Schema 3 added channel, subject and transition together with the active_alerts view.
bool has_transitions(Database& db) { return has_view(db, "active_alerts"); }

using detail::optional_int;
using detail::text_or_empty;

std::string alert_columns(Database& db) {
  return has_transitions(db) ? "id, created_at, severity, kind, channel, subject, transition, value, record_id, message"
                             : "id, created_at, severity, kind, NULL, NULL, 'event', NULL, record_id, message";
}

StoredAlert alert_row(const Statement& s) {
  StoredAlert a;
  a.id = s.get_int(0);
  a.created_at = s.get_text(1);
  const std::string row = "alert " + std::to_string(a.id);
  a.severity = enum_of(kAllAlertSeverities, s.get_text(2), "alert severity", row);
  a.kind = enum_of(kAllAlertKinds, s.get_text(3), "alert kind", row);
  a.channel = optional_int(s, 4);
  a.subject = text_or_empty(s, 5);
  a.transition = enum_of(kAllAlertTransitions, s.get_text(6), "alert transition", row);
  a.value = text_or_empty(s, 7);
  a.record_id = optional_int(s, 8);
  a.message = text_or_empty(s, 9);
  return a;
}

}  // namespace

std::int64_t count_alerts(Database& db) {
  if (!has_view(db, "alerts")) return 0;
  Statement s(db, "SELECT count(*) FROM alerts");
  return s.step() ? s.get_int(0) : 0;
}

std::vector<StoredAlert> load_newest_alerts(Database& db, std::size_t newest) {
  std::vector<StoredAlert> out;
  if (!has_view(db, "alerts")) return out;
  Statement s(db, "SELECT " + alert_columns(db) + " FROM alerts ORDER BY id DESC LIMIT ?");
  s.bind(1, static_cast<std::int64_t>(newest));
  while (s.step()) out.push_back(alert_row(s));
  return out;
}

std::vector<StoredAlert> load_alerts_since(Database& db, std::int64_t first_record, const std::string& since) {
  std::vector<StoredAlert> out;
  if (!has_transitions(db)) return out;
  Statement s(db, "SELECT " + alert_columns(db) + " FROM alerts WHERE record_id >= ? OR (record_id IS NULL AND created_at >= ?) ORDER BY id");
  s.bind(1, first_record).bind(2, since);
  while (s.step()) out.push_back(alert_row(s));
  return out;
}

namespace {

// The view has neither severity nor message: both come from the alert's newest `raised` transition.
std::vector<StoredActiveAlert> read_active_alerts(Database& db, const std::optional<AlertKind>& kind) {
  std::vector<StoredActiveAlert> out;
  if (!has_transitions(db)) return out;
  Statement s(db,
              std::string("SELECT kind, channel, subject, value, raised_at, updated_at,"
              " (SELECT severity FROM alerts a WHERE a.kind = x.kind AND coalesce(a.channel, -1) = coalesce(x.channel, -1)"
              "   AND coalesce(a.subject, '') = coalesce(x.subject, '') AND a.transition = 'raised' ORDER BY a.id DESC LIMIT 1),"
              " (SELECT message FROM alerts a WHERE a.kind = x.kind AND coalesce(a.channel, -1) = coalesce(x.channel, -1)"
              "   AND coalesce(a.subject, '') = coalesce(x.subject, '') AND a.transition = 'raised' ORDER BY a.id DESC LIMIT 1)"
              " FROM active_alerts x") + (kind ? " WHERE kind = ?" : "") + " ORDER BY kind, channel, subject");
  if (kind) s.bind(1, to_string(*kind));
  while (s.step()) {
    StoredActiveAlert a;
    const std::string row = "active alert " + text_or_empty(s, 0);
    a.kind = enum_of(kAllAlertKinds, s.get_text(0), "alert kind", row);
    a.channel = optional_int(s, 1);
    a.subject = text_or_empty(s, 2);
    a.value = text_or_empty(s, 3);
    a.raised_at = text_or_empty(s, 4);
    a.updated_at = text_or_empty(s, 5);
    if (!s.is_null(6)) a.severity = enum_of(kAllAlertSeverities, s.get_text(6), "alert severity", row);
    a.message = text_or_empty(s, 7);
    out.push_back(std::move(a));
  }
  return out;
}

std::optional<AlertKind> known_kind(const std::string& token) {
  for (auto k : kAllAlertKinds)
    if (token == to_string(k)) return k;
  return std::nullopt;
}

}  // namespace

std::vector<StoredActiveAlert> load_active_alerts(Database& db) { return read_active_alerts(db, std::nullopt); }
std::vector<StoredActiveAlert> load_active_alerts(Database& db, AlertKind kind) { return read_active_alerts(db, kind); }

std::map<AlertKey, AlertState> load_alert_states(Database& db, const std::vector<AlertKind>& only) {
  std::map<AlertKey, AlertState> states;
  Statement s(db, "SELECT kind, channel, active, value, consecutive_present, consecutive_absent, marker, subject FROM alert_state");
  while (s.step()) {
    const std::optional<AlertKind> kind = known_kind(s.get_text(0));
    if (!kind || (!only.empty() && std::find(only.begin(), only.end(), *kind) == only.end())) continue;
    AlertState a;
    a.active = s.get_int(2) != 0;
    a.value = text_or_empty(s, 3);
    a.consecutive_present = static_cast<int>(s.get_int(4));
    a.consecutive_absent = static_cast<int>(s.get_int(5));
    a.marker = s.get_double(6);
    states[AlertKey{*kind, static_cast<int>(s.get_int(1)), s.get_text(7)}] = a;
  }
  return states;
}

}  // namespace gearwatch::storage
