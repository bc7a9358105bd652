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
#include <limits>
#include <vector>

#include "gearwatch/wear/forecast_intervals.hpp"

namespace gearwatch::wear {

/// One inspection's reading of ρ: z = ln(measured / model) at `cycles`, with variance `var`.
struct DepthRatioMeasurement {
  std::int64_t inspection_id = 0;
  double cycles = 0;
  double log_ratio = 0;
  double var = 0;
  double model_m = 0;   ///< the model's depth it was read against (0: not kept; no rate reading)
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
/// `gate_sd` (finite): a reading whose innovation lies beyond that many SDs of var + r says the
/// prior misplaced ln ρ (the shape range is a range, not a distribution): its variance is raised
/// to the innovation² − r first (filter_update, the rule K_wear's belief uses).
LogPosterior depth_ratio_posterior(const LogPosterior& prior, std::vector<DepthRatioMeasurement> measurements, double q_per_cycle,
                                   double now, double gate_sd = std::numeric_limits<double>::infinity());

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

/// The rate ratio read from two inspections' increments (docs/model.md, "Depth calibration"):
/// κ = ln((D_b − D_a) / (m_b − m_a)), the truth's depth increment between the inspections over the
/// model's between the same cycles (D = m e^z, each with its stated relative SD s, s² = e^var − 1).
/// var = ln(1 + ((s_a D_a)² + (s_b D_b)²) / (D_b − D_a)²); dk_dz_* = ∂κ/∂z_* (= D_b/ΔD, −D_a/ΔD).
/// Not valid unless both model depths were kept and both increments are positive.
struct RateReading {
  bool valid = false;
  double log_mean = 0, var = 0;
  std::int64_t from_id = 0, to_id = 0;
  double from_cycles = 0, to_cycles = 0;
  double dk_dz_from = 0, dk_dz_to = 0;
};
RateReading depth_rate_reading(const DepthRatioMeasurement& a, const DepthRatioMeasurement& b);

/// The model's combined mean depth along a path given at points (cycles ascending), linear between
/// them; outside the points' span: -1 (not on the path).
struct PathPoint {
  double cycles = 0, mean_m = 0;
};
double path_mean_at(const std::vector<PathPoint>& path, double cycles);

/// A reading taken against the model's depth m, read again against the model's depth m2 at the same
/// cycles (a re-run changed the model's path there): the measured depth m e^z is kept, z becomes
/// ln(m e^z / m2), the variance (the measurement's) stays. Unchanged when m or m2 is not positive.
DepthRatioMeasurement reread(const DepthRatioMeasurement& m, double model_m);

/// One stretch of the model's K_wear history: (previous end, end_cycles] at K `k` (the first from 0).
struct KStretch {
  double end_cycles = 0, k = 0;
};
/// The cycle-weighted mean K over [from, to] (from < to) of stretches in ascending order; cycles
/// beyond the last stretch count at its K. Not positive when nothing is known.
double cycle_mean_k(const std::vector<KStretch>& stretches, double from, double to);

/// The model's K history from the pair's start, as cycle_mean_k reads it: the life ran at `k` up to
/// `end_cycles` (past the last end). A stretch at the last one's K extends it.
void extend_k_history(std::vector<KStretch>& history, double end_cycles, double k);
/// An update's K from `from_cycles` on (a re-run from its anchor): the stretch holding `from_cycles`
/// is split there, every later one takes `k`, and neighbours at one K become one stretch.
void set_k_from(std::vector<KStretch>& history, double from_cycles, double k);

/// A rate reading taken against the model's increments at (cycle-weighted mean) K k_path, read
/// against the model's pace at K k_now: Archard's depth increment is proportional to K, so
/// κ' = κ − ln(k_now / k_path); the variance and the derivatives in the readings are unchanged.
/// Unchanged when either K is not positive.
RateReading rate_at_pace(RateReading r, double k_path, double k_now);

/// The two-sided 5 % quantile of the normal: a rate change beyond this many SDs ends the rate's window.
constexpr double kRateChangeZ = 1.959963984540054;

/// The rate reading of the newest inspection (largest cycles) paired with the earlier one that
/// gives the smallest variance among those inside the rate's window: the newest carries the rate the
/// truth has now, the partner the longest increment the errors allow at one rate. The window grows
/// back from the newest's predecessor s, one reading a at a time, while the segment [a, s] reads the
/// same rate as [s, newest] (|κ_sb − κ_as| ≤ rate_change_z SDs of the difference, delta method over
/// the three readings; two-sided 5 % by default); it stops at the first change. Not valid with fewer
/// than two usable readings.
RateReading newest_rate_reading(const std::vector<DepthRatioMeasurement>& points, double rate_change_z = kRateChangeZ);

/// ∂μ/∂z_i of depth_ratio_posterior's mean at `now` for the reading with `inspection_id` (the
/// posterior mean is linear in the readings inside the gate: the weight the level gives that reading).
double posterior_weight(const LogPosterior& prior, const std::vector<DepthRatioMeasurement>& points, double q_per_cycle,
                        double now, std::int64_t inspection_id, double gate_sd = std::numeric_limits<double>::infinity());

/// The truth's level and rate against the model's path, jointly normal: x = ln(truth / model) of
/// the depth now, y = ln of the factor the truth's future increments are the model's times.
struct LevelRate {
  double x_mean = 0, x_var = 0, y_mean = 0, y_var = 0, cov = 0;
};

/// The depth now carried from the newest inspection b by the rate (docs/model.md, "Depth calibration"):
/// the truth at b is e^x_b m_b (ln ρ's posterior at b), its increment since b e^y (m_now − m_b), y the
/// rate reading at the pace the model's path ran between b and now. D = e^x_b m_b + e^y (m_now − m_b);
/// ln D is taken as normal by the delta method: var = w_x² var_x + w_y² (var_y + walk) + 2 w_x w_y cov,
/// w_x = e^x_b m_b / D, w_y = 1 − w_x, walk the rate's own random walk since b (independent of the
/// readings). The level for the rate's crossing is ln(D / m_now) with that variance and the
/// covariance cov(ln D, y) = w_x cov + w_y var_y. Not valid unless m_b > 0 and m_now ≥ m_b.
struct CarriedDepth {
  bool valid = false;
  double estimate_m = 0, low_m = 0, high_m = 0;
  double log_var = 0;        ///< var ln D
  double cov_with_rate = 0;  ///< cov(ln D, y)
};
CarriedDepth rate_carried_depth(double model_at_b, double x_b_mean, double x_b_var, double y_mean, double y_var, double cov_xy,
                                double walk_var, double model_now, double coverage);

/// The model's depth at which the truth reaches `limit`, the truth being e^x model_now now and
/// growing e^y times the model's from now on: T = model_now + max(0, limit − e^x model_now) / e^y
/// (the path is continuous at now; T = model_now: the truth is past the limit). Its q-quantile
/// under LevelRate's normal (x, y); T falls in x and y. Zero variances: T at the means.
double truth_crossing_threshold(const LevelRate& j, double model_now, double limit, double q);

}  // namespace gearwatch::wear
