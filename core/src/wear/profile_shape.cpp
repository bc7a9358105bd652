#include "gearwatch/wear/profile_shape.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "gearwatch/wear/forecast_intervals.hpp"

namespace gearwatch::wear {

namespace {
double mean_of_shape(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

double combined_mean(const WearState& s) { return mean_of_shape(s.pinion_depth_m) + mean_of_shape(s.gear_depth_m); }
}  // namespace

WearState concentrated_wear_shape(const twin::GearGeometry& g, const PassLoad& unworn_load, int profile_points) {
  // K = 1: the shape only; the scale comes from RMS_SA.
  const PassWear pass = pass_wear(g, unworn_load, 1.0, profile_points);
  const double ratio = static_cast<double>(g.spec.pinion_teeth) / g.spec.gear_teeth;
  WearState s;
  s.pinion_depth_m = pass.pinion_m;
  s.gear_depth_m = pass.gear_m;
  for (double& d : s.gear_depth_m) d *= ratio;   // as the blue loop's step: z1/z2 passes per gear tooth per cycle
  s.pinion_pitting.assign(s.pinion_depth_m.size(), 0.0);
  const double mean = combined_mean(s);
  if (!(mean > 0) || !std::isfinite(mean)) throw std::invalid_argument("the unworn pass wears nothing: no concentrated-wear shape");
  return scaled_shape(s, 1.0 / mean);
}

WearState scaled_shape(const WearState& unit_shape, double mean_m) {
  WearState s = unit_shape;
  for (double& d : s.pinion_depth_m) d *= mean_m;
  for (double& d : s.gear_depth_m) d *= mean_m;
  return s;
}

double peak_to_mean(const WearState& state) {
  const double mean = combined_mean(state);
  double peak = 0;
  for (double d : state.pinion_depth_m) peak = std::max(peak, d);
  for (double d : state.gear_depth_m) peak = std::max(peak, d);
  return mean > 0 ? peak / mean : std::numeric_limits<double>::quiet_NaN();
}

ShapeDepthMatch match_shape_to_rms_sa(const WearState& unit_shape, double target, double start_mean_m,
                                      const std::function<double(const WearState&)>& rms_sa, double tolerance,
                                      int max_evaluations, double max_mean_m) {
  ShapeDepthMatch m;
  if (!(target > 0) || !(start_mean_m > 0) || !(max_mean_m > 0)) {
    m.why = "no positive target RMS_SA or start depth";
    return m;
  }
  const double max_x = std::log(max_mean_m), max_step = std::log(4.0);
  struct Point { double x, g, g_raw; };   // ln m, ln(RMS_SA / target) (g: Illinois-weighted)
  auto eval = [&](double x) -> std::optional<Point> {
    ++m.evaluations;
    const double r = rms_sa(scaled_shape(unit_shape, std::exp(x)));
    if (!(r > 0) || !std::isfinite(r)) return std::nullopt;
    return Point{x, std::log(r / target), std::log(r / target)};
  };
  auto finish = [&](const Point& p, const std::optional<Point>& other) {
    m.valid = true;
    m.mean_depth_m = std::exp(p.x);
    m.rms_sa = target * std::exp(p.g_raw);
    if (other && other->x != p.x) m.depth_elasticity = (p.g_raw - other->g_raw) / (p.x - other->x);
    return m;
  };
  std::optional<Point> a = eval(std::min(std::log(start_mean_m), max_x));
  if (!a) {
    m.why = "the twin's simulation failed";
    return m;
  }
  if (std::abs(std::expm1(a->g)) <= tolerance) return finish(*a, std::nullopt);
  // First step: RMS_SA ∝ mean depth.
  std::optional<Point> b = eval(std::min(a->x - std::clamp(a->g, -max_step, max_step), max_x));
  if (!b) {
    m.why = "the twin's simulation failed";
    return m;
  }
  while (true) {
    if (std::abs(std::expm1(b->g)) <= tolerance) return finish(*b, a);
    if (m.evaluations >= max_evaluations) {
      m.why = "no mean depth within the tolerance after " + std::to_string(m.evaluations) + " twin runs";
      return m;
    }
    const bool bracketed = (a->g < 0) != (b->g < 0);
    double x = 0;
    if (!bracketed && b->x == a->x) {
      m.why = "the concentrated shape's RMS_SA stays below the target up to the depth limit";
      return m;
    }
    if (!bracketed) {
      const double slope = (b->g_raw - a->g_raw) / (b->x - a->x);
      if (!(slope > 0)) {
        m.why = "RMS_SA does not rise with the concentrated shape's depth here";
        return m;
      }
      if (b->x >= max_x && b->g < 0) {
        m.why = "the concentrated shape's RMS_SA stays below the target up to the depth limit";
        return m;
      }
      x = std::min(b->x + std::clamp(-b->g / slope, -max_step, max_step), max_x);
    } else {
      x = b->x - b->g * (b->x - a->x) / (b->g - a->g);
    }
    const std::optional<Point> c = eval(x);
    if (!c) {
      m.why = "the twin's simulation failed";
      return m;
    }
    if (bracketed && (c->g < 0) == (b->g < 0)) a->g *= 0.5;   // Illinois: the kept end's weight halves
    else a = b;
    b = c;
  }
}

std::optional<double> scaled_path_crossing(const std::vector<std::array<double, 2>>& path, double factor, double limit) {
  if (path.empty()) return std::nullopt;
  if (factor * path.front()[1] >= limit) return 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) {
    const double before = factor * path[i - 1][1], after = factor * path[i][1];
    if (after < limit) continue;
    const double frac = after > before ? (limit - before) / (after - before) : 0.0;
    return std::max(0.0, path[i - 1][0] + std::clamp(frac, 0.0, 1.0) * (path[i][0] - path[i - 1][0]));
  }
  return std::nullopt;
}

std::array<double, 2> shape_depth_interval(double mean_m, double shape_ratio, double log_sd, double coverage) {
  const double z = normal_quantile(0.5 + coverage / 2.0);
  const double spread = std::exp(z * std::max(0.0, log_sd));
  const double rho = shape_ratio > 0 ? shape_ratio : 1.0;
  return {mean_m * std::min(1.0, rho) / spread, mean_m * std::max(1.0, rho) * spread};
}

}  // namespace gearwatch::wear
