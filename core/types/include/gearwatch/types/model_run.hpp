#pragma once
// What one run of the purple loop (wear/updating.hpp, thesis §7.3.3) reports for one record: the
// observation, the coefficient updates, the forecast with its interval flags, and why a record
// could not be used. Plain values with their vocabularies (each enum one to_string and a list of
// every value), stored by storage's writer (model_runs, model_updates, model_forecast_flags).
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/types/wear_state.hpp"

namespace gearwatch::wear {

/// The interval's nominal coverage: the 5 % and 95 % quantiles of ln K.
inline constexpr double kNominalCoverage = 0.90;

/// Why a forecast's interval is wider than the posterior alone gives, or where its near end came from.
enum class ForecastFlag : std::uint8_t {
  rms_sa_residuals_exceed_scatter,  ///< recent ln(RMS_SA meas / sim) beyond the expected scatter (chi-square, 5 %): widened
  ics2_density_ahead_of_model,      ///< the ICS2-derived density is ahead of the model's: the near end from the ICS2 trend
  pitting_limit_reached_by_ics2,    ///< the ICS2-derived density is at the pitting limit already: near end 0
  pitting_limit_within_ics2_uncertainty,  ///< the ICS2-derived density's upper bound (interval level) reaches the limit: near end 0
  pitting_path_missed_ics2,         ///< the model's density misses the ICS2-derived one beyond its SD: K_pitting interval widened
  k_wear_not_identified,            ///< the last K_wear update found RMS_SA insensitive: K_wear interval no narrower than the prior's
  rms_sa_model_form_disagreement,   ///< ln(RMS_SA meas / sim) over the stored records beyond the scatter: model-form variance added
  pitting_limit_reached_by_model_only,  ///< the model's density is at the limit, the ICS2-derived one is not: cycles left from the measured density, near end 0
  ics2_saturated_density_lower_bound,   ///< ICS2 at or above its saturation level: the ICS2-derived density is a lower bound, its upper end unknown: near end 0, far end from the bound
  wear_profile_shape_unidentified,  ///< RMS_SA cannot tell the worn profile's shape: depth and wear interval span the model's and the concentrated-wear shape
};
inline constexpr std::array kAllForecastFlags{ForecastFlag::rms_sa_residuals_exceed_scatter,
                                              ForecastFlag::ics2_density_ahead_of_model,
                                              ForecastFlag::pitting_limit_reached_by_ics2,
                                              ForecastFlag::pitting_limit_within_ics2_uncertainty,
                                              ForecastFlag::pitting_path_missed_ics2,
                                              ForecastFlag::k_wear_not_identified,
                                              ForecastFlag::rms_sa_model_form_disagreement,
                                              ForecastFlag::pitting_limit_reached_by_model_only,
                                              ForecastFlag::ics2_saturated_density_lower_bound,
                                              ForecastFlag::wear_profile_shape_unidentified};
const char* to_string(ForecastFlag flag) noexcept;

/// Which coefficient an update changed.
enum class UpdateKind : std::uint8_t { k_wear, k_pitting };
inline constexpr std::array kAllUpdateKinds{UpdateKind::k_wear, UpdateKind::k_pitting};
const char* to_string(UpdateKind kind) noexcept;

/// What started an update.
enum class UpdateTrigger : std::uint8_t {
  rms_sa_mismatch,              ///< |RMS_SA sim − meas| / meas above the threshold (Eqs. 7.13–7.14)
  inspection_calibration,       ///< two pitted-area inspections (§7.3.3 step 2)
  correlation_below_threshold,  ///< Pearson C of the last three (ICS2, density) pairs below 0.95 (steps 3–4)
  ics2_one_inspection,          ///< one inspection and the ICS2 trend: the second point from the ICS2 scale
};
inline constexpr std::array kAllUpdateTriggers{UpdateTrigger::rms_sa_mismatch, UpdateTrigger::inspection_calibration,
                                               UpdateTrigger::correlation_below_threshold, UpdateTrigger::ics2_one_inspection};
const char* to_string(UpdateTrigger trigger) noexcept;

/// How it ended.
enum class UpdateOutcome : std::uint8_t {
  converged,          ///< within the tolerance / correlation threshold reached / inspections matched
  iteration_limit,    ///< K_wear: the bounded iterations ran out; the best K found is kept
  not_monotone,       ///< K_wear: an iteration moved away from the measurement; the best K found is kept
  bound_reached,      ///< K hit its configured bound (or the inspections cannot be matched)
  set_to_zero,        ///< K_pitting: the correlation threshold cannot be reached (§7.3.3, after step 4)
  simulation_failed,  ///< the twin's simulation diverged or could not be analysed: K unchanged
  insensitive,        ///< K_wear: |d ln RMS_SA / d ln K_wear| below the stated minimum: RMS_SA cannot tell K here; K_pitting: an ICS2 of the triple at its saturation level (a lower bound). K unchanged
  upper_bound,        ///< K_wear: the measurement lies on the twin's flat part: K_wear <= the knee; K = min(last identified, knee)
};
inline constexpr std::array kAllUpdateOutcomes{UpdateOutcome::converged,     UpdateOutcome::iteration_limit,
                                               UpdateOutcome::not_monotone,  UpdateOutcome::bound_reached,
                                               UpdateOutcome::set_to_zero,   UpdateOutcome::simulation_failed,
                                               UpdateOutcome::insensitive,   UpdateOutcome::upper_bound};
const char* to_string(UpdateOutcome outcome) noexcept;

/// Why a record could not be used, in whole or in part.
enum class ModelIssue : std::uint8_t {
  missing_cycles,                ///< no life counter: the record has no place in the pair's life (skipped)
  missing_operating_point,       ///< speed or torque unknown or not finite (skipped)
  operating_point_out_of_range,  ///< speed or torque outside the model's range (skipped)
  cycles_not_increasing,         ///< not after the model's last record (skipped)
  missing_rms_sa,                ///< no usable RMS_SA: advanced, K_wear not checked
  missing_ics2,                  ///< no usable ICS2 low band: advanced, no pitting point
  simulation_failed,             ///< the twin's simulation diverged or was not analysable: advanced, K_wear not checked
  depth_limit_reached,           ///< the blue loop reached its depth limit: state held there
  coalesced,                     ///< the model thread was behind: this record was replaced by a newer one (never handled)
};
inline constexpr std::array kAllModelIssues{
    ModelIssue::missing_cycles,    ModelIssue::missing_operating_point, ModelIssue::operating_point_out_of_range,
    ModelIssue::cycles_not_increasing, ModelIssue::missing_rms_sa,   ModelIssue::missing_ics2,
    ModelIssue::simulation_failed, ModelIssue::depth_limit_reached,     ModelIssue::coalesced};
const char* to_string(ModelIssue issue) noexcept;

/// One analysed record as the model sees it.
struct ModelObservation {
  std::int64_t record_id = 0;
  double cycles = 0;                       ///< NaN when the record has no life counter
  double speed_hz = 0, torque_nm = 0;
  std::optional<double> rms_sa;            ///< measured RMS_SA(N)
  std::optional<double> ics2_low;          ///< measured ICS2 in the low (pitting) band
};

struct KUpdate {
  UpdateKind kind = UpdateKind::k_wear;
  UpdateTrigger trigger = UpdateTrigger::rms_sa_mismatch;
  UpdateOutcome outcome = UpdateOutcome::converged;
  double cycles = 0;
  double old_value = 0, new_value = 0;
  double applies_from_cycles = 0;          ///< the re-run start: the new K holds from here
  int iterations = 0;                      ///< K_wear twin re-runs / K_pitting blue-loop evaluations
  /// K_wear root-find: d ln RMS_SA / d ln K_wear read from the twin (NaN: not read).
  double elasticity = std::numeric_limits<double>::quiet_NaN();
  /// K_wear: measured RMS_SA, simulated before and after. K_pitting: the correlation before and
  /// after (calibration: the inspected densities, and the ICS2 at their cycles when known).
  double measured = 0, simulated_before = 0, simulated_after = 0;
  double correlation_before = 0, correlation_after = 0;
  std::string evidence;                    ///< one line: the numbers and, when it did not converge, why
};

struct LimitForecast {
  double limit = 0;
  std::optional<double> cycles_left;        ///< nullopt: not within the horizon
  std::optional<double> cycles_left_low;    ///< the interval's near end: the fast K (or the ICS2 trend)
  std::optional<double> cycles_left_high;   ///< its far end: the slow K (nullopt: beyond the horizon)
};

struct ForecastPoint {
  double cycles = 0;
  double max_depth_m = 0, mean_depth_m = 0, mean_pitting = 0;
};

struct Forecast {
  bool valid = false;
  std::string failure;                     ///< why not (e.g. the loop stopped at its depth limit)
  double speed_hz = 0, torque_nm = 0;      ///< the recent operating point used
  double k_wear_low = 0, k_wear_high = 0, k_pitting_low = 0, k_pitting_high = 0;
  double coverage = kNominalCoverage;      ///< the interval's nominal coverage
  double log_sd_wear = 0, log_sd_pitting = 0;   ///< SD of ln K behind each interval (widening included)
  LimitForecast wear, pitting;
  /// The combined mean depth now and its interval (the RMS_SA scatter and the profile-shape term).
  double depth_mean_m = 0, depth_low_m = 0, depth_high_m = 0;
  /// The profile-shape term: the concentrated-wear shape's mean depth over the model's at one
  /// RMS_SA (0: not read), and its deepest point over its mean.
  double shape_depth_ratio = 0, shape_peak_ratio = 0;
  /// The depth calibration by inspected wear depths (0 inspections: none): the posterior median of
  /// ρ (true combined mean depth over the model's) and the SD of ln ρ. With it, depth_mean_m is the
  /// model's mean times ρ and the wear forecast is the model's crossing of limit / ρ.
  int depth_inspections = 0;
  double depth_ratio = 0, depth_ratio_log_sd = 0;
  /// The deepest point over the mean from inspected profiles (0 inspections: none): the posterior
  /// mean and SD of ln P, and P's posterior median exp(mean). With it, the wear crossings are at
  /// limit over ρ P / the model's own peak ratio.
  int peak_inspections = 0;
  double peak_ratio_log_mean = 0, peak_ratio_log_sd = 0, peak_ratio = 0;
  std::vector<ForecastFlag> flags;         ///< why the interval is wider or nearer than the posterior alone
  std::string evidence;                    ///< one line: the numbers behind the flags
  std::vector<ForecastPoint> curve;        ///< at the nominal K
};

struct ModelRunReport {
  bool advanced = false;                   ///< false: the record was skipped (issues say why)
  std::vector<ModelIssue> issues;
  std::string detail;                      ///< one line per issue, for people
  ModelObservation observation;
  std::optional<double> rms_sa_simulated;  ///< after any update
  std::optional<double> ics2_density_estimate;   ///< the ICS2 through the inspection scale
  WearSummary summary;
  double max_depth_m = 0;
  std::vector<double> combined_depth_m;    ///< root → tip along the pinion's profile
  double k_wear_si = 0, k_pitting = 0;
  std::vector<KUpdate> updates;
  Forecast forecast;
  bool new_gear_pair = false;              ///< the cycles went backwards: a new pair's state began
};

}  // namespace gearwatch::wear
