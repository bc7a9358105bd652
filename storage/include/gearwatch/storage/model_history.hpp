#pragma once
// Typed readers of what the model thread stored (docs/storage.md, docs/model.md): its newest
// state, the ICS2 series its runs hold, and for `gearwatch twin state` the K updates, the newest
// prediction with its forecast curve, and the predictions nearest an inspection. A database
// before schema version 4 has none of the model's tables.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/storage/stored_table.hpp"

namespace gearwatch::storage {

/// The model's state as stored (table model_state): the JSON the model thread wrote.
struct StoredModelState {
  std::int64_t gear_pair = 0;
  std::string updated_at;
  std::string state_json;
};

/// True when the database has the model's state table (schema version 4).
bool has_model_state(Database& db);
/// The state of the newest gear pair, nullopt before the model handled a record.
std::optional<StoredModelState> load_newest_model_state(Database& db);
/// Life-counter resets so far: the number of the gear pair now installed (0: the first).
std::int64_t count_life_counter_resets(Database& db);
/// (cycles, ICS2 low band) of the runs of `gear_pair` the model advanced to, by run.
std::vector<std::array<double, 2>> load_advanced_ics2_series(Database& db, std::int64_t gear_pair);

/// The K updates of `gear_pair`, by id, as view k_updates has them (without gear_pair,
/// record_id): id, created_at, cycles, kind, ... correlation_after, evidence.
StoredTable load_gear_pair_k_updates(Database& db, std::int64_t gear_pair);
/// The newest row of view predictions for `gear_pair` (every column), or no row.
StoredTable load_newest_prediction(Database& db, std::int64_t gear_pair);
/// The forecast curve (JSON) stored with model run `run_id`, nullopt when it has none.
std::optional<std::string> load_forecast_curve(Database& db, std::int64_t run_id);

/// The depth calibration model run `run_id` stored: ρ (schema 16) and the deepest point P
/// (schema 18); each none where the run had no such inspections or the schema predates it.
struct StoredRunCalibration {
  std::optional<double> depth_estimate_m, depth_ratio, depth_ratio_log_sd;
  std::optional<std::int64_t> depth_inspections;
  std::optional<double> peak_ratio_log_mean, peak_ratio_log_sd, peak_ratio;
  std::optional<std::int64_t> peak_inspections;
};
/// nullopt when there is no such run.
std::optional<StoredRunCalibration> load_run_calibration(Database& db, std::int64_t run_id);

/// The predicted means of a run at its cycles.
struct PredictionPoint {
  double cycles = 0, wear_mean_m = 0, pitting_mean = 0;
};
/// The `n` predictions of `gear_pair` whose cycles are nearest `cycles`, nearest first.
std::vector<PredictionPoint> load_predictions_nearest(Database& db, std::int64_t gear_pair, double cycles, int n);

}  // namespace gearwatch::storage
