#pragma once
// One analysed record as the model sees it, for the model's tests (test_updating,
// test_forecast_intervals), and the settings of the calibration cases (test_depth_calibration,
// test_deepest_point).
#include <optional>

#include "gearwatch/wear/updating.hpp"

namespace gearwatch::testing {

inline wear::ModelObservation observation(double cycles, double speed, double torque, std::optional<double> rms = {},
                                          std::optional<double> ics2 = {}) {
  wear::ModelObservation o;
  o.cycles = cycles;
  o.speed_hz = speed;
  o.torque_nm = torque;
  o.rms_sa = rms;
  o.ics2_low = ics2;
  return o;
}

// The model's settings for the calibration cases: no updates (no twin needed), one profile
// resolution, a 40 µm wear limit.
inline wear::ModelSettings calibration_case_settings() {
  wear::ModelSettings s;
  s.loop.k_wear_si = 2e-15;
  s.loop.profile_points = 21;
  s.update_k_wear = false;
  s.update_k_pitting = false;
  s.wear_limit_m = 40e-6;
  s.forecast_horizon_cycles = 2e7;
  return s;
}

// A twin stand-in for cases that never re-run the twin: RMS_SA 1 everywhere.
inline double calibration_case_rms(const wear::WearState&, const twin::OperatingPoint&) { return 1.0; }

}  // namespace gearwatch::testing
