#pragma once
// Every parameter of the 21-DOF model (thesis Tables 5.2–5.3, Eqs. 5.6–5.7), SI units, with its
// documented prior range (docs/rig-parameters-used.md). Node numbering follows thesis Eq. 5.2.
// The defaults are the calibrated set (docs/twin.md); prior_value() gives the uncalibrated prior.
#include <string>
#include <vector>

#include "gearwatch/gearbox_spec.hpp"

namespace gearwatch::twin {

struct GearboxParameters {
  GearPairSpec gears;

  // Inertias (kg·m²): motor, torque meter, input stub, pinion, free end (input), free end
  // (output), gear, output stub, brake.
  double I1, I2, I3, I5, I7, I8, I10, I12, I13;
  // Masses (kg): pedestals 4, 6 (input shaft), 9, 11 (output shaft); pinion 5, gear 10.
  double m4, m5, m6, m9, m10, m11;
  // Torsional stiffness (N·m/rad): couplings 1, 2, 4 and shaft sections.
  double kt12, kt23, kt35, kt57, kt810, kt10_12, kt12_13;
  // Bearing + pedestal to ground (N/m), vertical (y, ~ along the line of action) and horizontal.
  double ky4, ky6, ky9, ky11, kx4, kx6, kx9, kx11;
  // Shaft bending between gear and bearing (N/m).
  double ky45, ky56, ky910, ky10_11, kx45, kx56, kx910, kx10_11;

  double structural_damping_ratio;   ///< modal ζ of every structural mode (mesh excluded)
  double mesh_damping_ratio;         ///< ζ of Eq. 5.14
  double mesh_stiffness_scale;       ///< scale on the potential-energy mesh stiffness (Fig. 5.15)
  double engagement_ramp_fraction;   ///< gradual engagement length / base pitch (0 = abrupt step)
  /// Gain of the path from the pedestal's acceleration (ÿ6) to the accelerometer the records come
  /// from: 1 for the thesis's sensor on the pedestal; `gearwatch commission` fits it on another
  /// gearbox. It scales every simulated casing signal and nothing else.
  double casing_path_gain;

  /// The calibrated default set.
  GearboxParameters();
  /// The uncalibrated prior (the parameter sheet's defaults).
  static GearboxParameters prior();

  /// Throws TwinParameterError naming the first non-physical value (non-finite, ≤ 0 mass,
  /// inertia or stiffness, damping ratio < 0 or ≥ 1, scale ≤ 0, ramp outside [0, 0.5)).
  void validate() const;
};

/// One scalar parameter: its name (as in the [twin] config table), where it lives, its prior.
struct ParameterInfo {
  const char* name;
  double GearboxParameters::*field;
  double prior_value;
  double prior_low;
  double prior_high;
  const char* unit;
  const char* note;
};

/// All scalar parameters in a fixed order.
const std::vector<ParameterInfo>& parameter_table();
/// nullptr when unknown.
const ParameterInfo* find_parameter(const std::string& name);

}  // namespace gearwatch::twin
