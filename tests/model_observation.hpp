#pragma once
// One analysed record as the model sees it, for the model's tests (test_updating,
// test_forecast_intervals).
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

}  // namespace gearwatch::testing
