#include "gearwatch/wear/depth_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

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
  return {id, cycles, std::log(measured_m / model_m), log_relative_variance(relative_sd), model_m};
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
                                   double now, double gate_sd) {
  if (measurements.empty()) return {};
  std::stable_sort(measurements.begin(), measurements.end(),
                   [](const DepthRatioMeasurement& a, const DepthRatioMeasurement& b) { return a.cycles < b.cycles; });
  LogPosterior p = prior;
  p.valid = true;
  p.cycles = measurements.front().cycles;
  for (const DepthRatioMeasurement& m : measurements) p = filter_update(predict(p, m.cycles, q_per_cycle), m.log_ratio, m.var, gate_sd).posterior;
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

RateReading depth_rate_reading(const DepthRatioMeasurement& a, const DepthRatioMeasurement& b) {
  RateReading r;
  if (!(a.model_m > 0) || !(b.model_m > 0) || !(b.cycles > a.cycles)) return r;
  const double da = a.model_m * std::exp(a.log_ratio), db = b.model_m * std::exp(b.log_ratio);
  const double dd = db - da, dm = b.model_m - a.model_m;
  if (!(dd > 0) || !(dm > 0)) return r;
  const double sa = da * std::sqrt(std::expm1(a.var)), sb = db * std::sqrt(std::expm1(b.var));
  r.valid = true;
  r.log_mean = std::log(dd / dm);
  r.var = std::log1p((sa * sa + sb * sb) / (dd * dd));
  r.from_id = a.inspection_id, r.to_id = b.inspection_id;
  r.from_cycles = a.cycles, r.to_cycles = b.cycles;
  r.dk_dz_from = -da / dd, r.dk_dz_to = db / dd;
  return r;
}

namespace {
/// The rate ratio's change between two adjacent segments [a, s] and [s, b] and its SD by the delta
/// method (the three readings independent, relative variances e^var − 1): d = κ_sb − κ_as with
/// ∂d/∂z_a = D_a/ΔD_as, ∂d/∂z_s = −D_s (1/ΔD_as + 1/ΔD_sb), ∂d/∂z_b = D_b/ΔD_sb.
struct RateChange {
  bool valid = false;
  double change = 0, sd = 0;
};
RateChange rate_change(const DepthRatioMeasurement& a, const DepthRatioMeasurement& s, const DepthRatioMeasurement& b) {
  const RateReading older = depth_rate_reading(a, s), newer = depth_rate_reading(s, b);
  if (!older.valid || !newer.valid) return {};
  const double da = a.model_m * std::exp(a.log_ratio), ds = s.model_m * std::exp(s.log_ratio), db = b.model_m * std::exp(b.log_ratio);
  const double d_as = ds - da, d_sb = db - ds;
  const double ga = da / d_as, gs = ds * (1.0 / d_as + 1.0 / d_sb), gb = db / d_sb;
  const double var = ga * ga * std::expm1(a.var) + gs * gs * std::expm1(s.var) + gb * gb * std::expm1(b.var);
  return {true, newer.log_mean - older.log_mean, std::sqrt(var)};
}
}  // namespace

RateReading newest_rate_reading(const std::vector<DepthRatioMeasurement>& points, double rate_change_z) {
  std::vector<const DepthRatioMeasurement*> usable;
  for (const DepthRatioMeasurement& m : points)
    if (m.model_m > 0) usable.push_back(&m);
  std::sort(usable.begin(), usable.end(), [](const auto* x, const auto* y) { return x->cycles < y->cycles; });
  RateReading best;
  if (usable.size() < 2) return best;
  const DepthRatioMeasurement& newest = *usable.back();
  // Walk back from the newest: the window [s, newest] takes an older partner a only while the
  // segment [a, s] runs at the window's rate (within rate_change_z SDs of the change): a rate that
  // changed (a truth K step, a regime, a load) would otherwise average the old rate into the new.
  const DepthRatioMeasurement* start = usable[usable.size() - 2];
  for (std::size_t k = usable.size() - 1; k-- > 0;) {
    const DepthRatioMeasurement& a = *usable[k];
    if (&a != start) {
      const RateChange c = rate_change(a, *start, newest);
      if (c.valid && std::abs(c.change) > rate_change_z * c.sd) break;
      if (c.valid) start = &a;
    }
    const RateReading r = depth_rate_reading(a, newest);
    if (r.valid && (!best.valid || r.var < best.var)) best = r;
  }
  return best;
}

double path_mean_at(const std::vector<PathPoint>& path, double cycles) {
  if (path.empty() || cycles < path.front().cycles || cycles > path.back().cycles) return -1.0;
  const auto hi = std::lower_bound(path.begin(), path.end(), cycles,
                                   [](const PathPoint& p, double c) { return p.cycles < c; });
  if (hi->cycles == cycles || hi == path.begin()) return hi->mean_m;
  const auto lo = hi - 1;
  return lo->mean_m + (cycles - lo->cycles) / (hi->cycles - lo->cycles) * (hi->mean_m - lo->mean_m);
}

DepthRatioMeasurement reread(const DepthRatioMeasurement& m, double model_m) {
  if (!(m.model_m > 0) || !(model_m > 0)) return m;
  DepthRatioMeasurement r = m;
  r.log_ratio = m.log_ratio + std::log(m.model_m / model_m);   // ln(m e^z / m2)
  r.model_m = model_m;
  return r;
}

double cycle_mean_k(const std::vector<KStretch>& stretches, double from, double to) {
  if (stretches.empty() || !(to > from)) return -1.0;
  double start = 0, sum = 0;
  for (const KStretch& s : stretches) {
    const double overlap = std::min(to, s.end_cycles) - std::max(from, start);
    if (overlap > 0) sum += overlap * s.k;
    start = s.end_cycles;
  }
  if (to > start) sum += (to - std::max(from, start)) * stretches.back().k;
  return sum / (to - from);
}

void extend_k_history(std::vector<KStretch>& history, double end_cycles, double k) {
  if (!history.empty() && !(end_cycles > history.back().end_cycles)) return;
  if (!history.empty() && history.back().k == k)
    history.back().end_cycles = end_cycles;
  else
    history.push_back({end_cycles, k});
}

void set_k_from(std::vector<KStretch>& history, double from_cycles, double k) {
  std::vector<KStretch> out;
  double start = 0;
  for (const KStretch& s : history) {
    if (s.end_cycles <= from_cycles) {
      extend_k_history(out, s.end_cycles, s.k);
    } else {
      if (start < from_cycles) extend_k_history(out, from_cycles, s.k);   // the part before the anchor keeps its K
      extend_k_history(out, s.end_cycles, k);
    }
    start = s.end_cycles;
  }
  history = std::move(out);
}

RateReading rate_at_pace(RateReading r, double k_path, double k_now) {
  if (r.valid && k_path > 0 && k_now > 0) r.log_mean -= std::log(k_now / k_path);
  return r;
}

CarriedDepth rate_carried_depth(double model_at_b, double x_b_mean, double x_b_var, double y_mean, double y_var, double cov_xy,
                                double walk_var, double model_now, double coverage) {
  CarriedDepth c;
  if (!(model_at_b > 0) || !(model_now >= model_at_b) || !std::isfinite(x_b_mean) || !std::isfinite(y_mean)) return c;
  const double level = std::exp(x_b_mean) * model_at_b, growth = std::exp(y_mean) * (model_now - model_at_b);
  const double d = level + growth;
  const double wx = level / d, wy = growth / d;
  c.valid = true;
  c.estimate_m = d;
  c.log_var = std::max(0.0, wx * wx * x_b_var + wy * wy * (y_var + std::max(0.0, walk_var)) + 2.0 * wx * wy * cov_xy);
  c.cov_with_rate = wx * cov_xy + wy * y_var;
  const double z = normal_quantile(0.5 + 0.5 * coverage) * std::sqrt(c.log_var);
  c.low_m = d * std::exp(-z);
  c.high_m = d * std::exp(z);
  return c;
}

double posterior_weight(const LogPosterior& prior, const std::vector<DepthRatioMeasurement>& points, double q_per_cycle,
                        double now, std::int64_t inspection_id, double gate_sd) {
  std::vector<DepthRatioMeasurement> moved = points;
  bool found = false;
  const double h = 1e-3;
  for (DepthRatioMeasurement& m : moved)
    if (m.inspection_id == inspection_id) m.log_ratio += h, found = true;
  if (!found) return 0.0;
  return (depth_ratio_posterior(prior, moved, q_per_cycle, now, gate_sd).mean - depth_ratio_posterior(prior, points, q_per_cycle, now, gate_sd).mean) / h;
}

namespace {

double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

// P(T ≤ model_now + e^log_u): over x by Simpson's rule on ±8 SD, y given x in closed form
// (T ≤ now + u ⇔ y ≥ ln(limit − e^x model_now) − ln u; certain once the truth is past the limit).
double threshold_cdf(const LevelRate& j, double model_now, double limit, double log_u) {
  const double sx = std::sqrt(std::max(0.0, j.x_var));
  const double slope = sx > 0 ? j.cov / j.x_var : 0.0;
  const double vy = std::max(0.0, j.y_var - slope * j.cov);
  auto given = [&](double x) {
    const double rest = limit - std::exp(x) * model_now;
    if (rest <= 0) return 1.0;
    const double my = j.y_mean + slope * (x - j.x_mean), b = std::log(rest) - log_u;
    if (vy <= 0) return my >= b ? 1.0 : 0.0;
    return 1.0 - normal_cdf((b - my) / std::sqrt(vy));
  };
  if (sx <= 0) return given(j.x_mean);
  constexpr int n = 800;
  const double h = 16.0 * sx / n;
  double sum = 0;
  for (int i = 0; i <= n; ++i) {
    const double x = j.x_mean - 8.0 * sx + i * h, w = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
    const double u = (x - j.x_mean) / sx;
    sum += w * std::exp(-0.5 * u * u) * given(x);
  }
  return sum * h / 3.0 / (sx * 2.5066282746310002);
}

}  // namespace

double truth_crossing_threshold(const LevelRate& j, double model_now, double limit, double q) {
  if (!(j.x_var > 0) && !(j.y_var > 0))
    return model_now + std::max(0.0, limit - std::exp(j.x_mean) * model_now) / std::exp(j.y_mean);
  // The share of truths already past the limit: T = model_now for them.
  const double past = model_now > 0 && j.x_var > 0
                          ? 1.0 - normal_cdf((std::log(limit / model_now) - j.x_mean) / std::sqrt(j.x_var))
                          : (std::exp(j.x_mean) * model_now >= limit ? 1.0 : 0.0);
  if (q <= past) return model_now;
  double lo = std::log(limit) - 40.0, hi = std::log(limit) + 40.0;
  for (int k = 0; k < 80; ++k) {
    const double mid = 0.5 * (lo + hi);
    (threshold_cdf(j, model_now, limit, mid) < q ? lo : hi) = mid;
  }
  return model_now + std::exp(0.5 * (lo + hi));
}

}  // namespace gearwatch::wear
