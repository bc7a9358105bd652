#pragma once
// The wear depth calibrated by the engineer's inspections (docs/model.md, "Depth calibration").
// RMS_SA fixes a mean depth only for a given worn profile shape; the thesis measures the profile
// itself at its inspection stops (a mould of the flank, its LSCM profile: Figs. 6.8–6.10, 7.2,
// 7.3, 7.6). An inspection's measured combined mean depth over the model's at the same cycles is
// a measurement of ρ, the factor the model's depth is off by. ln ρ gets a normal posterior: the
// prior is the model-form shape range (profile_shape.hpp), the measurements carry the stated
// relative SD, and ln ρ walks randomly between them (the model's depth path between inspections
// follows its K_wear, whose random walk is the one of ln K). Pure functions on numbers.
#include <cstdint>
#include <vector>

#include "gearwatch/wear/forecast_intervals.hpp"

namespace gearwatch::wear {

/// One inspection's reading of ρ: z = ln(measured / model) at `cycles`, with variance `var`.
struct DepthRatioMeasurement {
  std::int64_t inspection_id = 0;
  double cycles = 0;
  double log_ratio = 0;
  double var = 0;
};

/// The variance of ln(1 + ε) for a relative error ε of SD `relative_sd`, as a lognormal with the
/// same relative variance: ln(1 + s²).
double log_relative_variance(double relative_sd);

/// A measurement of ln ρ from a measured and a model combined mean depth (both > 0) with the
/// measurement's relative SD.
DepthRatioMeasurement depth_ratio_measurement(std::int64_t id, double cycles, double measured_m, double model_m,
                                              double relative_sd);

/// The prior of ln ρ from the shape range: the normal whose central `coverage` interval is the ln
/// of shape_depth_interval over the model's mean, [min(0, ln ρ_s) − z s, max(0, ln ρ_s) + z s]
/// (s: the RMS_SA scatter's ln depth SD). Without a shape reading (ρ_s ≤ 0) the model's depth is
/// as unknown as its K_wear: N(0, fallback_sd²). `valid` is set; `cycles` is left at 0.
LogPosterior shape_range_prior(double shape_ratio, double log_sd, double coverage, double fallback_sd);

/// The posterior of ln ρ at `now`: from the prior (taken at the first measurement's cycles), each
/// measurement in cycle order by the conjugate update after the random walk to its cycles, then
/// the walk to `now` (q: variance per cycle). No measurements: the prior unchanged (valid false).
LogPosterior depth_ratio_posterior(const LogPosterior& prior, std::vector<DepthRatioMeasurement> measurements, double q_per_cycle,
                                   double now);

/// The combined mean depth's estimate and interval from the model's mean and the posterior of
/// ln ρ: the median mean e^μ, the interval mean e^(μ ± z sd) at `coverage`.
struct CalibratedDepth {
  double estimate_m = 0, low_m = 0, high_m = 0;
  double ratio = 1, ratio_low = 1, ratio_high = 1;
};
CalibratedDepth calibrated_depth(double model_mean_m, const LogPosterior& log_ratio, double coverage);

/// The model's combined mean depth at an inspection's cycles, linear between the previous record
/// (prev_cycles, prev_mean) and this one (now_cycles, now_mean); before the previous record,
/// linear from the unworn start (0, 0) to it. Returns ≤ 0 when nothing is known.
double model_mean_at(double cycles, double prev_cycles, double prev_mean, double now_cycles, double now_mean);

/// One inspection's reading of the deepest point over the mean, ln P = ln(deepest / mean), both
/// read off the same mould: each carries the relative SD independently, so var = 2 ln(1 + s²).
DepthRatioMeasurement peak_ratio_measurement(std::int64_t id, double cycles, double deepest_m, double mean_m,
                                             double relative_sd);

/// The prior of ln P from the profile-shape term's range: the normal whose central `coverage`
/// interval is [ln min(a, b), ln max(a, b)] of the model's own peak ratio `model_peak` and the
/// concentrated shape's `shape_peak`. Without a concentrated shape (shape_peak ≤ 0) or a range of
/// no width: N(ln model_peak, fallback_sd²). `valid` is set; `cycles` is left at 0.
LogPosterior peak_ratio_prior(double model_peak, double shape_peak, double coverage, double fallback_sd);

/// The factor the model's deepest point is multiplied by to give the true one: ρ P / model_peak
/// (true deepest = P × true mean = P ρ × model mean = ρ P / model_peak × model deepest), at the
/// posterior medians and at the ends of the central `coverage` interval of ln ρ + ln P. The two
/// posteriors are taken as independent: a shared error in the inspected mean moves ln ρ and ln P
/// in opposite directions, so the sum's true variance is at most the sum of the variances.
struct DeepestFactor {
  double nominal = 1, low = 1, high = 1;
};
DeepestFactor deepest_point_factor(const LogPosterior& log_rho, const LogPosterior& log_peak, double model_peak, double coverage);

}  // namespace gearwatch::wear
