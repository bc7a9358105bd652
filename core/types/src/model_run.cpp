#include "gearwatch/types/model_run.hpp"

namespace gearwatch::wear {

const char* to_string(ForecastFlag flag) noexcept {
  switch (flag) {
    case ForecastFlag::rms_sa_residuals_exceed_scatter: return "rms_sa_residuals_exceed_scatter";
    case ForecastFlag::ics2_density_ahead_of_model: return "ics2_density_ahead_of_model";
    case ForecastFlag::pitting_limit_reached_by_ics2: return "pitting_limit_reached_by_ics2";
    case ForecastFlag::pitting_limit_within_ics2_uncertainty: return "pitting_limit_within_ics2_uncertainty";
    case ForecastFlag::pitting_path_missed_ics2: return "pitting_path_missed_ics2";
    case ForecastFlag::k_wear_not_identified: return "k_wear_not_identified";
    case ForecastFlag::rms_sa_model_form_disagreement: return "rms_sa_model_form_disagreement";
    case ForecastFlag::pitting_limit_reached_by_model_only: return "pitting_limit_reached_by_model_only";
    case ForecastFlag::ics2_saturated_density_lower_bound: return "ics2_saturated_density_lower_bound";
    case ForecastFlag::wear_profile_shape_unidentified: return "wear_profile_shape_unidentified";
  }
  return "unknown";
}

const char* to_string(UpdateKind kind) noexcept {
  switch (kind) {
    case UpdateKind::k_wear: return "k_wear";
    case UpdateKind::k_pitting: return "k_pitting";
  }
  return "unknown";
}

const char* to_string(UpdateTrigger trigger) noexcept {
  switch (trigger) {
    case UpdateTrigger::rms_sa_mismatch: return "rms_sa_mismatch";
    case UpdateTrigger::inspection_calibration: return "inspection_calibration";
    case UpdateTrigger::correlation_below_threshold: return "correlation_below_threshold";
    case UpdateTrigger::ics2_one_inspection: return "ics2_one_inspection";
  }
  return "unknown";
}

const char* to_string(UpdateOutcome outcome) noexcept {
  switch (outcome) {
    case UpdateOutcome::converged: return "converged";
    case UpdateOutcome::iteration_limit: return "iteration_limit";
    case UpdateOutcome::not_monotone: return "not_monotone";
    case UpdateOutcome::bound_reached: return "bound_reached";
    case UpdateOutcome::set_to_zero: return "set_to_zero";
    case UpdateOutcome::simulation_failed: return "simulation_failed";
    case UpdateOutcome::insensitive: return "insensitive";
    case UpdateOutcome::upper_bound: return "upper_bound";
  }
  return "unknown";
}

const char* to_string(ModelIssue issue) noexcept {
  switch (issue) {
    case ModelIssue::missing_cycles: return "missing_cycles";
    case ModelIssue::missing_operating_point: return "missing_operating_point";
    case ModelIssue::operating_point_out_of_range: return "operating_point_out_of_range";
    case ModelIssue::cycles_not_increasing: return "cycles_not_increasing";
    case ModelIssue::missing_rms_sa: return "missing_rms_sa";
    case ModelIssue::missing_ics2: return "missing_ics2";
    case ModelIssue::simulation_failed: return "simulation_failed";
    case ModelIssue::depth_limit_reached: return "depth_limit_reached";
    case ModelIssue::coalesced: return "coalesced";
  }
  return "unknown";
}

}  // namespace gearwatch::wear
