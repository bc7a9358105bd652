#pragma once
// A pitting growth law whose shape is estimated from the readings (docs/model.md, "Pitting growth law").
// dD/dN = a D^b: b = 0 linear growth, b = 1 exponential, in between a power law, above it faster
// than exponential. Integrated, g(D) = (D^λ − 1)/λ (ln D at λ = 0), λ = 1 − b, is linear in N, so
// for each λ the fit is a weighted straight line; λ's posterior on a grid from the line's χ² and a
// stated prior (centred on Lundberg–Palmgren's own small-density exponent). Pure functions.

#include <cstdint>
#include <vector>

namespace gearwatch::wear {

/// A pitted-density reading: an inspection or an ICS2-derived density, with the SD of its ln.
struct DensityReading {
  double cycles = 0;
  double density = 0;   ///< > 0
  double log_sd = 0.1;  ///< SD of ln(reading / truth), > 0
};

struct GrowthLawSettings {
  double b_prior_mean = 0.1;   ///< Lundberg–Palmgren D ∝ N^m at small D: b = (m − 1)/m
  double b_prior_sd = 0.5;
  double b_min = 0.0, b_max = 1.5;
  int grid_points = 61;
  int samples = 4000;          ///< draws of (λ, α, β) for the cycles-to-limit quantiles
  std::uint64_t seed = 0x9e3779b97f4a7c15ULL;   ///< fixed: one forecast per state, reproducible
  double coverage = 0.90;
};

struct GrowthLawFit {
  bool valid = false;
  int readings = 0;
  double b_mean = 0, b_sd = 0;           ///< the exponent's posterior
  double density_now = 0;                ///< the fit's density at `now` (at b's posterior mode)
  /// Cycles from `now` to the limit: median and the central `coverage` interval (infinite: never
  /// within the fit's law; 0: past it already).
  double cycles_left = 0, cycles_left_low = 0, cycles_left_high = 0;
};

/// Box–Cox transform g_λ(D) = (D^λ − 1)/λ, ln D at λ = 0.
double growth_transform(double density, double lambda);
/// Its inverse: D = (1 + λ y)^(1/λ) (e^y at λ = 0); +inf past a finite-time blow-up (λ < 0).
double growth_inverse(double y, double lambda);

/// Fits dD/dN = a D^b to the readings (≥ 3 at ≥ 3 distinct cycles, else invalid) and gives the
/// cycles from `now` to `limit` with the exponent's and the line's uncertainty carried.
GrowthLawFit fit_growth_law(const std::vector<DensityReading>& readings, double limit, double now,
                            const GrowthLawSettings& settings = {});

}  // namespace gearwatch::wear
