#include "gearwatch/twin/gearbox_parameters.hpp"

#include <cmath>
#include <string>

#include "gearwatch/twin/errors.hpp"

namespace gearwatch::twin {

using P = GearboxParameters;

// Defined in calibrated_values.cpp: overwrites the prior with the calibrated set.
void apply_calibrated_values(GearboxParameters& p);

// Prior values and ranges: the rig parameter sheet (docs/rig-parameters-used.md gives the source
// of each). The ranges bound the calibration; they are not enforced when a model is built.
const std::vector<ParameterInfo>& parameter_table() {
  static const std::vector<ParameterInfo> table = {
      {"I1", &P::I1, 1.0e-2, 3e-3, 3e-2, "kg m^2", "motor rotor + 1/2 coupling 1 (4 kW 4-pole catalogue J)"},
      {"I2", &P::I2, 1.0e-3, 3e-4, 3e-3, "kg m^2", "torque meter rotor + 1/2 couplings 1, 2 (HBM TB1A 1.3e-3)"},
      {"I3", &P::I3, 4.0e-4, 1e-4, 1e-3, "kg m^2", "1/2 coupling 2 + input shaft stub (estimate)"},
      {"I5", &P::I5, 1.0e-4, 6e-5, 2e-4, "kg m^2", "pinion + input shaft in the casing (computed)"},
      {"I7", &P::I7, 2.0e-4, 5e-5, 1e-3, "kg m^2", "input free end: slip ring, adapter, coupling 3 (estimate)"},
      {"I8", &P::I8, 2.0e-4, 5e-5, 1e-3, "kg m^2", "output free end: slip ring, adapter, coupling 5 (estimate)"},
      {"I10", &P::I10, 1.9e-3, 1.8e-3, 2.2e-3, "kg m^2", "gear + output shaft in the casing (computed)"},
      {"I12", &P::I12, 4.0e-4, 1e-4, 1e-3, "kg m^2", "1/2 coupling 4 + output shaft stub (estimate)"},
      {"I13", &P::I13, 1.0e-2, 4e-3, 3.5e-2, "kg m^2", "powder brake rotor + 1/2 coupling 4 (PB series)"},
      {"m4", &P::m4, 2.0, 0.5, 10.0, "kg", "input pedestal + bearing, motor side (effective)"},
      {"m5", &P::m5, 0.4, 0.18, 0.8, "kg", "pinion + shaft share"},
      {"m6", &P::m6, 2.0, 0.5, 10.0, "kg", "input pedestal + bearing, free end (effective)"},
      {"m9", &P::m9, 2.0, 0.5, 10.0, "kg", "output pedestal + bearing, free end (effective)"},
      {"m10", &P::m10, 1.6, 1.2, 2.2, "kg", "gear + shaft share"},
      {"m11", &P::m11, 2.0, 0.5, 10.0, "kg", "output pedestal + bearing, brake side (effective)"},
      {"kt12", &P::kt12, 1.0e4, 1e2, 2e5, "N m/rad", "coupling 1 (with torque-meter shaft)"},
      {"kt23", &P::kt23, 1.0e4, 1e2, 2e5, "N m/rad", "coupling 2 (with torque-meter shaft)"},
      {"kt35", &P::kt35, 2.0e4, 5e3, 6e4, "N m/rad", "input shaft, coupling 2 to pinion (GJ/L)"},
      {"kt57", &P::kt57, 2.0e4, 5e3, 6e4, "N m/rad", "input shaft, pinion to free end (GJ/L)"},
      {"kt810", &P::kt810, 2.0e4, 5e3, 6e4, "N m/rad", "output shaft, free end to gear (GJ/L)"},
      {"kt10_12", &P::kt10_12, 2.0e4, 5e3, 6e4, "N m/rad", "output shaft, gear to coupling 4 (GJ/L)"},
      {"kt12_13", &P::kt12_13, 1.0e4, 1e2, 2e5, "N m/rad", "coupling 4"},
      {"ky4", &P::ky4, 1.0e8, 1e7, 1e9, "N/m", "bearing + pedestal 4, vertical"},
      {"ky6", &P::ky6, 1.0e8, 1e7, 1e9, "N/m", "bearing + pedestal 6, vertical"},
      {"ky9", &P::ky9, 1.0e8, 1e7, 1e9, "N/m", "bearing + pedestal 9, vertical"},
      {"ky11", &P::ky11, 1.0e8, 1e7, 1e9, "N/m", "bearing + pedestal 11, vertical"},
      {"kx4", &P::kx4, 1.0e8, 1e7, 1e9, "N/m", "bearing + pedestal 4, horizontal"},
      {"kx6", &P::kx6, 1.0e8, 1e7, 1e9, "N/m", "bearing + pedestal 6, horizontal"},
      {"kx9", &P::kx9, 1.0e8, 1e7, 1e9, "N/m", "bearing + pedestal 9, horizontal"},
      {"kx11", &P::kx11, 1.0e8, 1e7, 1e9, "N/m", "bearing + pedestal 11, horizontal"},
      {"ky45", &P::ky45, 1.0e8, 2e7, 5e8, "N/m", "input shaft bending, bearing 4 to pinion, vertical"},
      {"ky56", &P::ky56, 1.0e8, 2e7, 5e8, "N/m", "input shaft bending, pinion to bearing 6, vertical"},
      {"ky910", &P::ky910, 1.0e8, 2e7, 5e8, "N/m", "output shaft bending, bearing 9 to gear, vertical"},
      {"ky10_11", &P::ky10_11, 1.0e8, 2e7, 5e8, "N/m", "output shaft bending, gear to bearing 11, vertical"},
      {"kx45", &P::kx45, 1.0e8, 2e7, 5e8, "N/m", "input shaft bending, horizontal"},
      {"kx56", &P::kx56, 1.0e8, 2e7, 5e8, "N/m", "input shaft bending, horizontal"},
      {"kx910", &P::kx910, 1.0e8, 2e7, 5e8, "N/m", "output shaft bending, horizontal"},
      {"kx10_11", &P::kx10_11, 1.0e8, 2e7, 5e8, "N/m", "output shaft bending, horizontal"},
      {"structural_damping_ratio", &P::structural_damping_ratio, 0.05, 0.02, 0.05, "-",
       "modal damping of every structural mode (PHM-BGU model: 0.05)"},
      {"mesh_damping_ratio", &P::mesh_damping_ratio, 0.07, 0.03, 0.17, "-", "zeta of Eq. 5.14"},
      {"mesh_stiffness_scale", &P::mesh_stiffness_scale, 1.0, 0.5, 1.5, "-", "scale on the potential-energy k_m"},
      {"engagement_ramp_fraction", &P::engagement_ramp_fraction, 0.0, 0.0, 0.45, "-",
       "gradual engagement length / base pitch (0 = abrupt step as in the thesis)"},
      {"casing_path_gain", &P::casing_path_gain, 1.0, 0.01, 100.0, "-",
       "pedestal (y6) to accelerometer path gain (1 = the thesis's sensor on the pedestal; fitted by commission)"},
  };
  return table;
}

const ParameterInfo* find_parameter(const std::string& name) {
  for (const auto& info : parameter_table())
    if (name == info.name) return &info;
  return nullptr;
}

GearboxParameters GearboxParameters::prior() {
  GearboxParameters p;
  for (const auto& info : parameter_table()) p.*(info.field) = info.prior_value;
  return p;
}

GearboxParameters::GearboxParameters() {
  for (const auto& info : parameter_table()) this->*(info.field) = info.prior_value;
  apply_calibrated_values(*this);
}

void GearboxParameters::validate() const {
  for (const auto& info : parameter_table()) {
    const double v = this->*(info.field);
    const std::string name = info.name;
    if (!std::isfinite(v)) throw TwinParameterError("twin parameter " + name + " is not finite");
    const bool ratio = name == "structural_damping_ratio" || name == "mesh_damping_ratio";
    if (name == "engagement_ramp_fraction") {
      if (v < 0 || v >= 0.5) throw TwinParameterError("twin parameter " + name + " must lie in [0, 0.5), got " + std::to_string(v));
    } else if (ratio) {
      if (v < 0 || v >= 1) throw TwinParameterError("twin parameter " + name + " must lie in [0, 1), got " + std::to_string(v));
    } else if (v <= 0) {
      throw TwinParameterError("twin parameter " + name + " must be positive, got " + std::to_string(v));
    }
  }
}

}  // namespace gearwatch::twin
