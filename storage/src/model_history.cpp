#include "gearwatch/storage/model_history.hpp"

#include "model_run_columns.hpp"
#include "stored_rows.hpp"
#include "stored_tokens.hpp"

namespace gearwatch::storage {

bool has_model_state(Database& db) {
  Statement s(db, "SELECT 1 FROM sqlite_master WHERE name = 'model_state'");
  return s.step();
}

std::optional<StoredModelState> load_newest_model_state(Database& db) {
  Statement s(db, "SELECT gear_pair, updated_at, state FROM model_state ORDER BY gear_pair DESC LIMIT 1");
  if (!s.step()) return std::nullopt;
  return StoredModelState{s.get_int(0), s.get_text(1), s.get_text(2)};
}

std::int64_t count_life_counter_resets(Database& db) {
  Statement s(db, "SELECT count(*) FROM life_counter_events");
  s.step();
  return s.get_int(0);
}

std::vector<std::array<double, 2>> load_advanced_ics2_series(Database& db, std::int64_t gear_pair) {
  Statement s(db, "SELECT cycles, ics2_low FROM model_runs WHERE gear_pair = ? AND advanced = 1"
                  " AND cycles IS NOT NULL AND ics2_low IS NOT NULL ORDER BY id");
  s.bind(1, gear_pair);
  std::vector<std::array<double, 2>> out;
  while (s.step()) out.push_back({s.get_double(0), s.get_double(1)});
  return out;
}

StoredTable load_gear_pair_k_updates(Database& db, std::int64_t gear_pair) {
  Statement s(db, "SELECT id, created_at, cycles, kind, triggered_by, outcome, old_value, new_value, applies_from_cycles,"
                  " iterations, measured, simulated_before, simulated_after, correlation_before, correlation_after, evidence"
                  " FROM k_updates WHERE gear_pair = ? ORDER BY id");
  s.bind(1, gear_pair);
  return detail::read_table(s);
}

StoredTable load_newest_prediction(Database& db, std::int64_t gear_pair) {
  Statement s(db, "SELECT * FROM predictions WHERE gear_pair = ? ORDER BY run_id DESC LIMIT 1");
  s.bind(1, gear_pair);
  return detail::read_table(s);
}

std::optional<std::string> load_forecast_curve(Database& db, std::int64_t run_id) {
  Statement s(db, "SELECT forecast_curve FROM model_runs WHERE id = ?");
  s.bind(1, run_id);
  if (!s.step() || s.is_null(0)) return std::nullopt;
  return s.get_text(0);
}

std::optional<StoredRunCalibration> load_run_calibration(Database& db, std::int64_t run_id) {
  const bool has_rho = detail::has_column(db, "model_runs", GW_COL_DEPTH_RATIO);
  const bool has_peak = detail::has_column(db, "model_runs", GW_COL_PEAK_RATIO);
  Statement s(db, std::string("SELECT ") + (has_rho ? GW_DEPTH_RATIO_COLUMNS : "NULL, NULL, NULL, NULL") + ", " +
                      (has_peak ? GW_PEAK_RATIO_COLUMNS : "NULL, NULL, NULL, NULL") + " FROM model_runs WHERE id = ?");
  s.bind(1, run_id);
  if (!s.step()) return std::nullopt;
  StoredRunCalibration c;
  c.depth_estimate_m = detail::optional_double(s, 0);
  c.depth_ratio = detail::optional_double(s, 1);
  c.depth_ratio_log_sd = detail::optional_double(s, 2);
  c.depth_inspections = detail::optional_int(s, 3);
  c.peak_ratio_log_mean = detail::optional_double(s, 4);
  c.peak_ratio_log_sd = detail::optional_double(s, 5);
  c.peak_ratio = detail::optional_double(s, 6);
  c.peak_inspections = detail::optional_int(s, 7);
  return c;
}

std::vector<PredictionPoint> load_predictions_nearest(Database& db, std::int64_t gear_pair, double cycles, int n) {
  Statement s(db, "SELECT cycles, wear_mean_m, pitting_mean FROM predictions WHERE gear_pair = ? AND cycles IS NOT NULL"
                  " ORDER BY abs(cycles - ?) LIMIT ?");
  s.bind(1, gear_pair).bind(2, cycles).bind(3, n);
  std::vector<PredictionPoint> out;
  while (s.step()) out.push_back({s.get_double(0), s.get_double(1), s.get_double(2)});
  return out;
}

}  // namespace gearwatch::storage
