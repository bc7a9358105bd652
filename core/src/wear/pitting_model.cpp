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
  // The surviving area (1 − D) decays by exp(−A (n1 − n0)) over the step: Eq. 7.8's survival law
  // applied to the area that is still unpitted. Eq. 7.11's e^{−A N^m} − e^{−A (N+ΔN)^m} is the
  // same step only while D = 1 − e^{−A N^m}, i.e. while A has been constant since N = 0; after a
  // change of A (load, width feedback, a K update) or a density set from an inspection, its
  // increments shrink as A grows (e^{−A N^m} → 0) and the density stalls. expm1: no cancellation
  // for small A.
  return std::clamp(density - (1.0 - density) * std::expm1(-rate * (n1 - n0)), 0.0, 1.0);
}

}  // namespace gearwatch::wear
