#pragma once
// A pitting growth law whose shape is estimated from the readings (docs/model.md, "Pitting growth law").
// dD/dN = a D^b (1 − D), b in [0, 1]: the factor (1 − D) is Eq. 7.8's own (only unpitted area can
// pit), so D stays below 1 and never runs away in finite cycles; b = 0 is Eq. 7.8 with m = 1, b = 1
// the logistic. Integrated, g_b(D) = ∫ x^-b / (1 − x) dx is linear in N, so for each b the fit is a
// straight line by generalised least squares: the readings' errors are independent parts plus
// common errors (an ICS2 scale drawn through inspections shares their errors with every reading it
// gives). b's posterior on a grid from the line's χ² and a stated prior. Pure functions.

#include <array>
#include <cstdint>
#include <vector>

namespace gearwatch::wear {

/// How many common errors a reading can load on (the two inspections an ICS2 scale goes through).
inline constexpr std::size_t kGrowthSharedErrors = 2;

/// A pitted-density reading: an inspection or an ICS2-derived density. Its error in ln D is
/// `log_sd` (its own, independent of every other reading's) plus Σ_j shared[j] ε_j, ε_j ~ N(0, 1)
/// common to every reading loading on j.
struct DensityReading {
  double cycles = 0;
  double density = 0;   ///< in (0, 1)
  double log_sd = 0.1;  ///< SD of the reading's own error in ln D, ≥ 0
  std::array<double, kGrowthSharedErrors> shared{};   ///< loadings (SD in ln D) on the common errors
};

struct GrowthLawSettings {
  double b_prior_mean = 0.1;   ///< Lundberg–Palmgren D ∝ N^m at small D: b = (m − 1)/m
  double b_prior_sd = 0.5;
  double b_min = 0.0, b_max = 1.0;   ///< b > 1: the pitted area's relative growth rate rising with the area
  int grid_points = 41;
  int samples = 4000;          ///< draws of (b, α, β) for the cycles-to-limit quantiles
  std::uint64_t seed = 0x9e3779b97f4a7c15ULL;   ///< fixed: one forecast per state, reproducible
  double coverage = 0.90;
};

/// Where b's posterior sits against its range: at a bound the readings ask for a form the law
/// does not have, and its interval is not the whole uncertainty.
enum class GrowthExponentBound : std::uint8_t { inside, at_lower, at_upper };
const char* to_string(GrowthExponentBound bound) noexcept;

struct GrowthLawFit {
  bool valid = false;
  int readings = 0;
  double b_mean = 0, b_sd = 0;           ///< the exponent's posterior
  GrowthExponentBound bound = GrowthExponentBound::inside;   ///< the posterior's mode at a range end
  double density_now = 0;                ///< the fit's density at `now` (at b's posterior mode)
  /// Cycles from `now` to the limit: median and the central `coverage` interval (infinite: never
  /// within the fit's law; 0: past it already).
  double cycles_left = 0, cycles_left_low = 0, cycles_left_high = 0;
};

/// A straight line g_b(D) = α + β (N − centre) fitted by generalised least squares, its
/// covariance and its χ² (`growth_line_fit`; exposed for its known-answer test).
struct GrowthLine {
  bool valid = false;
  double centre = 0, alpha = 0, beta = 0;
  double var_alpha = 0, var_beta = 0, cov_alpha_beta = 0;
  double chi2 = 0;
};

/// g_b(D) = ∫ x^-b / (1 − x) dx = (D^λ − 1)/λ + Σ_k D^(k+1+λ)/(k+1+λ), λ = 1 − b (ln D + … at
/// λ = 0); closed forms: b = 0 −1 − ln(1 − D), b = 1 ln(D / (1 − D)). D in (0, 1).
double growth_transform(double density, double b);
/// Its inverse in (0, 1): the density whose transform is y (0 below the transform at D → 0).
double growth_inverse(double y, double b);
/// d g_b / d ln D = D^(1 − b) / (1 − D): a reading's ln-D error in the line's units.
double growth_log_slope(double density, double b);

/// The line at exponent b with covariance J (diag(log_sd²) + Σ_j s_j s_jᵀ) J, J = d g / d ln D.
GrowthLine growth_line_fit(const std::vector<DensityReading>& readings, double b);

/// Fits dD/dN = a D^b (1 − D) to the readings (≥ 3 distinct cycles, else invalid) and gives the
/// cycles from `now` to `limit` with the exponent's and the line's uncertainty carried.
GrowthLawFit fit_growth_law(const std::vector<DensityReading>& readings, double limit, double now,
                            const GrowthLawSettings& settings = {});

/// Eq. 7.8's form D = 1 − exp(−A N^m) through two pitted-area readings (n0, d0), (n1, d1), the
/// exponent read from them instead of the material's m: on a Weibull plot (ln H against ln N,
/// H = −ln(1 − D)) m̂ = ln(H1 / H0) / ln(n1 / n0), and A from H1. The limit's crossing is then
/// N_L = n1 (H_L / H1)^(1/m̂). Assumptions: the two readings' relative errors in D are independent
/// normal with the given SDs (in ln D); the density goes on along the same Weibull line (the
/// operating point and the mechanism as between the readings). The interval is the delta method's
/// on ln N_L from the two readings' errors alone: no term for a line that bends (the caller's).
struct ExponentCrossing {
  bool valid = false;
  double exponent = 0, exponent_sd = 0;   ///< m̂ and its SD from the readings' errors
  double crossing_cycles = 0;             ///< N_L, absolute cycles
  double log_sd = 0;                      ///< SD of ln N_L
  /// Cycles from `now` to the limit: median and the central `coverage` interval (0: past it).
  double cycles_left = 0, cycles_left_low = 0, cycles_left_high = 0;
};

/// Invalid unless 0 < n0 < n1, 0 < d0 < d1 < 1, 0 < limit < 1 and the SDs are finite and ≥ 0.
ExponentCrossing inspection_exponent_crossing(double n0, double d0, double n1, double d1, double log_sd0, double log_sd1,
                                              double limit, double now, double coverage);

}  // namespace gearwatch::wear
