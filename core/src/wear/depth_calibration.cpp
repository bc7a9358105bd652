#include "gearwatch/wear/depth_calibration.hpp"

#include <algorithm>
#include <cmath>

namespace gearwatch::wear {

namespace {

// The normal whose central `coverage` interval is [low, high].
LogPosterior normal_spanning(double low, double high, double coverage) {
  LogPosterior p;
  p.valid = true;
  const double z = normal_quantile(0.5 + coverage / 2.0);
  p.mean = (low + high) / 2.0;
  const double sd = (high - low) / (2.0 * z);
  p.var = sd * sd;
  return p;
}

}  // namespace

double log_relative_variance(double relative_sd) { return std::log1p(relative_sd * relative_sd); }

DepthRatioMeasurement depth_ratio_measurement(std::int64_t id, double cycles, double measured_m, double model_m,
                                              double relative_sd) {
  return {id, cycles, std::log(measured_m / model_m), log_relative_variance(relative_sd)};
}

LogPosterior shape_range_prior(double shape_ratio, double log_sd, double coverage, double fallback_sd) {
  LogPosterior p;
  p.valid = true;
  if (!(shape_ratio > 0)) {
    p.var = fallback_sd * fallback_sd;
    return p;
  }
  const double z = normal_quantile(0.5 + coverage / 2.0);
  const double s = std::max(0.0, log_sd), l = std::log(shape_ratio);
  return normal_spanning(std::min(0.0, l) - z * s, std::max(0.0, l) + z * s, coverage);
}

LogPosterior depth_ratio_posterior(const LogPosterior& prior, std::vector<DepthRatioMeasurement> measurements, double q_per_cycle,
                                   double now) {
  if (measurements.empty()) return {};
  std::stable_sort(measurements.begin(), measurements.end(),
                   [](const DepthRatioMeasurement& a, const DepthRatioMeasurement& b) { return a.cycles < b.cycles; });
  LogPosterior p = prior;
  p.valid = true;
  p.cycles = measurements.front().cycles;
  for (const DepthRatioMeasurement& m : measurements) p = conjugate_update(predict(p, m.cycles, q_per_cycle), m.log_ratio, m.var);
  return predict(p, now, q_per_cycle);
}

CalibratedDepth calibrated_depth(double model_mean_m, const LogPosterior& log_ratio, double coverage) {
  const double z = normal_quantile(0.5 + coverage / 2.0), sd = std::sqrt(std::max(0.0, log_ratio.var));
  CalibratedDepth d;
  d.ratio = std::exp(log_ratio.mean);
  d.ratio_low = std::exp(log_ratio.mean - z * sd);
  d.ratio_high = std::exp(log_ratio.mean + z * sd);
  d.estimate_m = model_mean_m * d.ratio;
  d.low_m = model_mean_m * d.ratio_low;
  d.high_m = model_mean_m * d.ratio_high;
  return d;
}

double model_mean_at(double cycles, double prev_cycles, double prev_mean, double now_cycles, double now_mean) {
  if (cycles >= now_cycles || now_cycles <= prev_cycles) return now_mean;
  if (cycles >= prev_cycles) return prev_mean + (cycles - prev_cycles) / (now_cycles - prev_cycles) * (now_mean - prev_mean);
  return prev_cycles > 0 ? prev_mean * cycles / prev_cycles : 0.0;
}

DepthRatioMeasurement peak_ratio_measurement(std::int64_t id, double cycles, double deepest_m, double mean_m,
                                             double relative_sd) {
  return {id, cycles, std::log(deepest_m / mean_m), 2.0 * log_relative_variance(relative_sd)};
}

LogPosterior peak_ratio_prior(double model_peak, double shape_peak, double coverage, double fallback_sd) {
  LogPosterior p;
  p.valid = true;
  const double a = std::log(model_peak);
  if (!(shape_peak > 0) || std::abs(std::log(shape_peak) - a) < 1e-9) {
    p.mean = a;
    p.var = fallback_sd * fallback_sd;
    return p;
  }
  const double b = std::log(shape_peak);
  return normal_spanning(std::min(a, b), std::max(a, b), coverage);
}

DeepestFactor deepest_point_factor(const LogPosterior& log_rho, const LogPosterior& log_peak, double model_peak, double coverage) {
  const double z = normal_quantile(0.5 + coverage / 2.0);
  const double mu = log_rho.mean + log_peak.mean - std::log(model_peak);
  const double sd = std::sqrt(std::max(0.0, log_rho.var) + std::max(0.0, log_peak.var));
  return {std::exp(mu), std::exp(mu - z * sd), std::exp(mu + z * sd)};
}

}  // namespace gearwatch::wear
