#pragma once
// Geometric transmission error (thesis §5.2.2) from tooth-profile deviations.
//
// A deviation is material missing from the ideal involute (m, positive = removed, e.g. wear
// depth), given along the active profile of a tooth from the start of active profile (root side,
// fraction 0) to the tip (fraction 1), uniformly spaced. The GTE of a pair in contact at s is
// e = −(d_pinion(u_p(s)) + d_gear(u_g(s))): missing material reduces the pair's compression, which
// enters the mesh force of Eq. 5.3 as k_m (δ + e).
#include <cstddef>
#include <vector>

#include "gearwatch/twin/gear_geometry.hpp"

namespace gearwatch::twin {

struct ToothProfileDeviation {
  /// Uniform deviation on all pinion / gear teeth (root → tip). Empty = ideal involute.
  std::vector<double> pinion;
  std::vector<double> gear;
  /// Optional per-tooth deviations; when non-empty, tooth n uses entry n mod size (size must be z1
  /// resp. z2) instead of the uniform profile.
  std::vector<std::vector<double>> pinion_per_tooth;
  std::vector<std::vector<double>> gear_per_tooth;
};

/// `base` with a linear tip relief added on every pinion and gear tooth (an addition the thesis's
/// twin does not have, for the gap diagnosis's tip_relief candidate): material removed from
/// (1 − length_fraction) of the active profile to the tip, rising linearly to `amount_m` at the tip.
/// Profiles are resampled to at least `points` (the base's own points kept where finer). Throws
/// TwinParameterError for a negative amount or a length fraction outside (0, 1].
ToothProfileDeviation with_linear_tip_relief(const ToothProfileDeviation& base, double amount_m, double length_fraction,
                                             std::size_t points = 201);

class GeometricTransmissionError {
 public:
  /// Validates (finite values, per-tooth sizes equal to the tooth counts, ≥ 2 points per profile).
  GeometricTransmissionError(const GearGeometry& geometry, ToothProfileDeviation deviation);

  /// GTE of the pair at s formed by pinion tooth `pinion_tooth` and gear tooth `gear_tooth`.
  double pair_error(double s, int pinion_tooth, int gear_tooth) const;
  /// d(pair_error)/ds (1/m·m), by the profile tables' piecewise-linear slope.
  double pair_error_slope(double s, int pinion_tooth, int gear_tooth) const;
  /// Kinematic (unloaded) GTE of teeth 0/0 at the positions of the pairs in contact: the pair
  /// that touches first decides, i.e. the max of the pair errors.
  double kinematic_error(const double* positions, int pair_count) const;
  bool is_zero() const { return zero_; }

 private:
  static double sample(const std::vector<double>& table, double u);
  static double slope(const std::vector<double>& table, double u);
  const std::vector<double>& pinion_table(int tooth) const;
  const std::vector<double>& gear_table(int tooth) const;
  GearGeometry geometry_;
  ToothProfileDeviation deviation_;
  bool zero_ = true;
};

}  // namespace gearwatch::twin
