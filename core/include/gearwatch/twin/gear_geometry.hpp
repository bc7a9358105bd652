#pragma once
// Geometry of a standard (unshifted) involute spur pair, from the rig's GearPairSpec.
// Positions along the line of action are measured from T1, the tangency point of the line of
// action on the pinion's base circle (so the pinion's roll distance), in metres.
#include "gearwatch/gearbox_spec.hpp"

namespace gearwatch::twin {

struct GearGeometry {
  GearPairSpec spec;
  double pressure_angle_rad = 0;
  double pitch_radius_pinion = 0, pitch_radius_gear = 0;
  double base_radius_pinion = 0, base_radius_gear = 0;
  double tip_radius_pinion = 0, tip_radius_gear = 0;
  double root_radius_pinion = 0, root_radius_gear = 0;
  double centre_distance = 0;
  double base_pitch = 0;               ///< p_b = 2π r_b1 / z1
  double line_of_action_length = 0;    ///< T1T2 = a sin α
  double contact_start = 0;            ///< start of active contact on the line of action (pinion root side)
  double contact_end = 0;              ///< end of active contact (pinion tip)
  double contact_ratio = 0;            ///< ε_α = (contact_end − contact_start) / p_b
  double effective_modulus = 0;        ///< E* with 1/E* = (1−ν1²)/E1 + (1−ν2²)/E2 (same steel)

  /// Builds and validates (throws TwinParameterError: teeth < 5, module/width ≤ 0, ν outside
  /// (0, 0.5), interference of the tip with the other base circle, contact ratio < 1).
  static GearGeometry from_spec(const GearPairSpec& spec);

  double active_length() const { return contact_end - contact_start; }
  /// Radius of curvature of the pinion / gear involute at position s on the line of action.
  double curvature_radius_pinion(double s) const { return s; }
  double curvature_radius_gear(double s) const { return line_of_action_length - s; }
  /// Pinion roll angle (tan of the local pressure angle) at s, and the gear's.
  double roll_angle_pinion(double s) const { return s / base_radius_pinion; }
  double roll_angle_gear(double s) const { return (line_of_action_length - s) / base_radius_gear; }
  /// Position on the pinion's active profile, 0 = first contact (root side) .. 1 = tip; the gear's
  /// active profile runs the other way along the line of action.
  double profile_fraction_pinion(double s) const { return (s - contact_start) / active_length(); }
  double profile_fraction_gear(double s) const { return (contact_end - s) / active_length(); }
  /// Sliding speed between the flanks at s for pinion speed omega1 (rad/s): |ω1 ρ1 − ω2 ρ2|.
  double sliding_speed(double s, double omega1) const;
};

/// Hertz line contact at position s carrying normal force F (N) over the face width:
/// maximum pressure p0 = sqrt(F' E* /(π R*)) and half-width a = sqrt(4 F' R* /(π E*)), F' = F/b.
struct HertzContact {
  double max_pressure_pa = 0;
  double half_width_m = 0;
};
HertzContact hertz_contact(const GearGeometry& geometry, double s, double normal_force_n);

}  // namespace gearwatch::twin
