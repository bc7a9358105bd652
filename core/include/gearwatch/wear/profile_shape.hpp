#pragma once
// The worn profile's shape is a model form RMS_SA cannot identify (docs/model.md, "Profile-shape
// term"). The model's blue loop moves load off worn points (the load-sharing feedback), so its
// wear spreads along the flank; the same Archard law without that feedback keeps wearing where the
// unworn pair's load and sliding put it, so its wear stays concentrated. Both are the model's own
// physics (thesis §6.2.3, Fig. 7.1 with and without the profile → GTE → force step). At one RMS_SA
// they hold different mean depths; the depth and the cycles left to the wear limit are given over
// the range the two shapes span.
#include <array>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/types/wear_state.hpp"
#include "gearwatch/wear/archard_wear.hpp"

namespace gearwatch::wear {

/// The concentrated-wear shape: one tooth pass's Archard wear at the unworn pair's load (no
/// load-sharing feedback), pinion and gear flanks as the blue loop adds them (the gear's times
/// z1/z2 passes per cycle), scaled so the combined mean depth (pinion mean + gear mean) is 1 m.
/// Throws std::invalid_argument when the pass wears nothing.
WearState concentrated_wear_shape(const twin::GearGeometry& g, const PassLoad& unworn_load, int profile_points);

/// `unit_shape` (combined mean 1 m) scaled to a combined mean of `mean_m`.
WearState scaled_shape(const WearState& unit_shape, double mean_m);

/// The deepest flank point (pinion or gear) over the combined mean depth.
double peak_to_mean(const WearState& state);

/// Where the shape's RMS_SA equals a target.
struct ShapeDepthMatch {
  bool valid = false;
  double mean_depth_m = std::numeric_limits<double>::quiet_NaN();   ///< the shape's combined mean at the target
  double rms_sa = std::numeric_limits<double>::quiet_NaN();         ///< its RMS_SA there
  /// d ln RMS_SA / d ln mean depth between the last two evaluations (NaN: one evaluation only).
  double depth_elasticity = std::numeric_limits<double>::quiet_NaN();
  int evaluations = 0;
  std::string why;                                                  ///< when not valid
};

/// Solves RMS_SA(shape scaled to mean m) = target on ln m: the first step assumes RMS_SA ∝ m
/// (m ← m · target / RMS_SA), then the secant through the last two points, Illinois once the
/// target is bracketed; each step at most a factor 4 in m, m at most `max_mean_m`. Within
/// `tolerance` (relative) it is valid; a flat or falling RMS_SA, a failed simulation or
/// `max_evaluations` without convergence is not (the reason in `why`).
ShapeDepthMatch match_shape_to_rms_sa(const WearState& unit_shape, double target, double start_mean_m,
                                      const std::function<double(const WearState&)>& rms_sa, double tolerance,
                                      int max_evaluations, double max_mean_m);

/// The first cycles (from now) at which `factor` × a mean-depth path reaches `limit`: the path is
/// (cycles from now, combined mean depth) in increasing cycles, linear between its points; 0 when
/// its first point is at the limit already; nullopt when it never reaches it.
std::optional<double> scaled_path_crossing(const std::vector<std::array<double, 2>>& path, double factor, double limit);

/// The depth interval over the shape range: the model's mean m and the other shape's ρ m at the
/// same RMS_SA, each with its own scatter interval exp(± z log_sd), z for `coverage`:
/// [m min(1, ρ) e^(−z s), m max(1, ρ) e^(z s)]. ρ ≤ 0 (no shape read): the model's alone.
std::array<double, 2> shape_depth_interval(double mean_m, double shape_ratio, double log_sd, double coverage);

}  // namespace gearwatch::wear
