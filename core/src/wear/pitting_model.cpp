#include "gearwatch/wear/pitting_model.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "gearwatch/twin/errors.hpp"

namespace gearwatch::wear {

void PittingMaterial::validate() const {
  for (double v : {c, m, h})
    if (!std::isfinite(v) || v <= 0) throw twin::TwinParameterError("pitting exponents c, m, h must be finite and positive");
}

LundbergPalmgrenTerms lundberg_palmgren_terms(double max_pressure_pa, double half_width_m, double reduced_radius_m) {
  LundbergPalmgrenTerms t;
  if (!(max_pressure_pa > 0) || !(half_width_m > 0) || !(reduced_radius_m > 0)) return t;
  t.max_shear_stress_pa = 0.3 * max_pressure_pa;                                            // Eq. 7.4
  t.shear_depth_m = 0.786 * half_width_m;                                                   // Eq. 7.5
  t.stressed_volume_m3 = 2.0 * half_width_m * t.shear_depth_m * 2.0 * std::numbers::pi * reduced_radius_m;  // Eq. 7.6
  return t;
}

double survival_rate(double k_pitting, const LundbergPalmgrenTerms& t, const PittingMaterial& material) {
  if (!std::isfinite(k_pitting) || k_pitting < 0) throw twin::TwinParameterError("K_pitting must be finite and non-negative");
  if (k_pitting == 0 || !(t.max_shear_stress_pa > 0) || !(t.shear_depth_m > 0) || !(t.stressed_volume_m3 > 0)) return 0.0;
  // τ0^c alone is ~1e85 in Pa: combine in logarithms.
  const double log_rate = std::log(k_pitting) + material.c * std::log(t.max_shear_stress_pa) +
                          std::log(t.stressed_volume_m3) - material.h * std::log(t.shear_depth_m);
  return std::exp(std::min(log_rate, 700.0));
}

double pitting_density_direct(double rate, double cycles, const PittingMaterial& material) {
  if (!(rate > 0) || !(cycles > 0)) return 0.0;
  return -std::expm1(-rate * std::pow(cycles, material.m));
}

double pitting_density_step(double density, double rate, double cycles, double step_cycles,
                            const PittingMaterial& material) {
  if (!(rate > 0) || !(step_cycles > 0)) return density;
  const double n0 = std::pow(std::max(cycles, 0.0), material.m);
  const double n1 = std::pow(std::max(cycles, 0.0) + step_cycles, material.m);
  // exp(−A n0) − exp(−A n1) = exp(−A n0) (1 − exp(−A (n1 − n0))): no cancellation for small A.
  return std::min(1.0, density - std::exp(-rate * n0) * std::expm1(-rate * (n1 - n0)));
}

}  // namespace gearwatch::wear
