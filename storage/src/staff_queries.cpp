#include "gearwatch/storage/staff_queries.hpp"

#include <stdexcept>
#include <vector>

#include "model_run_columns.hpp"
#include "stored_rows.hpp"
#include "stored_tokens.hpp"

namespace gearwatch::storage {
namespace {

// What each view reads, and the column the time filters apply to.
struct Source {
  const char* sql;
  const char* time_col;
  const char* channel_col = nullptr;  ///< nullptr: the rows are not per channel
};

Source source_of(QueryView view) {
  switch (view) {
    case QueryView::alerts:
      return {"SELECT id, created_at, severity, kind, channel, subject, transition, value, record_id, message FROM alerts", "created_at",
              "channel"};
    case QueryView::active: return {"SELECT kind, channel, subject, value, raised_at, updated_at FROM active_alerts", "updated_at", "channel"};
    case QueryView::indicators:
      return {"SELECT record_id, created_at, cycles, speed_hz, torque_nm, channel, name, value FROM indicators", "created_at", "channel"};
    case QueryView::health: return {"SELECT * FROM acquisition_health", "taken_at"};
    case QueryView::inspections: break;  // source_of(db, ...): columns by schema version
    case QueryView::records: return {"SELECT * FROM record_status", "created_at"};
    case QueryView::gaps:
      return {"SELECT g.id, g.detected_at, s.run_id, s.stream_id, g.channel, g.first_missing_index, g.missing_samples, g.cause"
              " FROM gap_events g JOIN streams s ON s.id = g.stream_key",
              "detected_at", "channel"};
    case QueryView::rejected: return {"SELECT id, received_at, run_id, kind, reason, frame FROM rejected_frames", "received_at"};
    case QueryView::updates:
      return {"SELECT id, created_at, gear_pair, cycles, kind, triggered_by, outcome, old_value, new_value, applies_from_cycles,"
              " iterations, measured, simulated_before, simulated_after, correlation_before, correlation_after, record_id, evidence"
              " FROM k_updates",
              "created_at"};
    case QueryView::predictions: break;
  }
  throw std::logic_error("query view without a source");
}

// `columns` (a comma-separated list) as `object` has them, each missing one (a database from before
// the schema that added it) read as NULL under its name: the old views keep working.
std::string columns_or_null(Database& db, const char* object, const std::string& columns) {
  std::string out, name;
  auto flush = [&] {
    const auto b = name.find_first_not_of(' '), e = name.find_last_not_of(' ');
    const std::string n = name.substr(b, e - b + 1);
    out += ", " + (detail::has_column(db, object, n) ? n : "NULL AS " + n);
    name.clear();
  };
  for (char c : columns) {
    if (c == ',') flush();
    else name += c;
  }
  flush();
  return out;
}

Source source_of(Database& db, QueryView view, std::string& sql) {
  switch (view) {
    case QueryView::inspections:
      sql = "SELECT id, entered_at, cycles, pitted_area_fraction, wear_depth_m, note" +
            columns_or_null(db, "inspections", GW_INSPECTION_DEEPEST_COLUMNS) + " FROM inspections";
      return {sql.c_str(), "entered_at"};
    case QueryView::predictions:
      sql = "SELECT run_id, created_at, record_id, gear_pair, cycles, speed_hz, torque_nm, k_wear, k_pitting, rms_sa_measured,"
            " rms_sa_simulated, ics2_low, ics2_density_estimate, wear_mean_m, wear_max_m, pitting_mean, pitting_max, wear_limit_m,"
            " wear_cycles_left, wear_cycles_left_low, wear_cycles_left_high, pitting_limit, pitting_cycles_left,"
            " pitting_cycles_left_low, pitting_cycles_left_high, interval_coverage, forecast_flags, issues, detail, forecast_evidence" +
            columns_or_null(db, "predictions", GW_DEPTH_RATIO_COLUMNS ", " GW_PEAK_RATIO_COLUMNS) + " FROM predictions";
      return {sql.c_str(), "created_at"};
    default: return source_of(view);
  }
}

}  // namespace

const char* to_string(QueryView view) noexcept {
  switch (view) {
    case QueryView::alerts: return "alerts";
    case QueryView::active: return "active";
    case QueryView::indicators: return "indicators";
    case QueryView::health: return "health";
    case QueryView::updates: return "updates";
    case QueryView::predictions: return "predictions";
    case QueryView::inspections: return "inspections";
    case QueryView::records: return "records";
    case QueryView::gaps: return "gaps";
    case QueryView::rejected: return "rejected";
  }
  return "?";
}

std::optional<QueryView> parse_query_view(const std::string& word) {
  for (auto v : kAllQueryViews)
    if (word == to_string(v)) return v;
  return std::nullopt;
}

bool has_channel(QueryView view) noexcept {
  return view == QueryView::alerts || view == QueryView::active || view == QueryView::indicators || view == QueryView::gaps;
}

QueryViewAvailability query_view_availability(Database& db, QueryView view) {
  Statement exists(db, "SELECT 1 FROM sqlite_master WHERE name = ?");
  if (view == QueryView::updates) {
    exists.bind(1, "k_updates");
    return exists.step() ? QueryViewAvailability::available : QueryViewAvailability::needs_schema_4;
  }
  if (view == QueryView::predictions) {
    exists.bind(1, "predictions");
    if (!exists.step()) return QueryViewAvailability::needs_schema_4;
    if (!detail::has_column(db, "predictions", "interval_coverage")) return QueryViewAvailability::needs_schema_8;
  }
  return QueryViewAvailability::available;
}

StoredTable query_view(Database& db, QueryView view, const QueryFilter& filter) {
  std::string view_sql;
  const Source source = source_of(db, view, view_sql);
  const std::string time_col = source.time_col;
  std::string sql = source.sql;
  std::vector<std::string> bind;
  std::vector<std::string> where;
  if (!filter.since.empty()) {
    where.push_back(time_col + " >= ?");
    bind.push_back(filter.since);
  }
  if (!filter.until.empty()) {
    where.push_back(time_col + " < ?");
    bind.push_back(filter.until);
  }
  if (filter.channel) {
    if (!source.channel_col) throw std::invalid_argument(std::string("query ") + to_string(view) + " has no channel filter");
    where.push_back(std::string(source.channel_col) + " = " + std::to_string(*filter.channel));
  }
  if (!filter.name.empty()) {
    if (view != QueryView::indicators) throw std::invalid_argument(std::string("query ") + to_string(view) + " has no name filter");
    where.push_back("name = ?");
    bind.push_back(filter.name);
  }
  for (std::size_t i = 0; i < where.size(); ++i) sql += (i ? " AND " : " WHERE ") + where[i];
  if (filter.limit)
    sql = "SELECT * FROM (" + sql + " ORDER BY " + time_col + " DESC LIMIT " + std::to_string(*filter.limit) + ") ORDER BY " + time_col;
  Statement s(db, sql);
  for (std::size_t i = 0; i < bind.size(); ++i) s.bind(static_cast<int>(i + 1), bind[i]);
  return detail::read_table(s);
}

}  // namespace gearwatch::storage
