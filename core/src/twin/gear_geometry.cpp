#include "gearwatch/twin/gear_geometry.hpp"

#include <cmath>
#include <numbers>
#include <string>

#include "gearwatch/twin/errors.hpp"

namespace gearwatch::twin {
namespace {
void require(bool ok, const std::string& what) {
  if (!ok) throw TwinParameterError("gear geometry: " + what);
}
}  // namespace

GearGeometry GearGeometry::from_spec(const GearPairSpec& spec) {
  require(spec.pinion_teeth >= 5 && spec.gear_teeth >= 5, "tooth counts must be at least 5");
  require(std::isfinite(spec.module_m) && spec.module_m > 0, "module must be positive");
  require(std::isfinite(spec.face_width_m) && spec.face_width_m > 0, "face width must be positive");
  require(std::isfinite(spec.pressure_angle_deg) && spec.pressure_angle_deg > 5 && spec.pressure_angle_deg < 40,
          "pressure angle must lie in (5, 40) degrees");
  require(std::isfinite(spec.youngs_modulus_pa) && spec.youngs_modulus_pa > 0, "Young's modulus must be positive");
  require(std::isfinite(spec.poisson_ratio) && spec.poisson_ratio > 0 && spec.poisson_ratio < 0.5,
          "Poisson's ratio must lie in (0, 0.5)");
  require(std::isfinite(spec.density_kg_m3) && spec.density_kg_m3 > 0, "density must be positive");
  require(spec.addendum_coefficient > 0 && spec.dedendum_coefficient > spec.addendum_coefficient * 0.5,
          "addendum/dedendum coefficients are not physical");

  GearGeometry g;
  g.spec = spec;
  const double m = spec.module_m;
  g.pressure_angle_rad = spec.pressure_angle_deg * std::numbers::pi / 180.0;
  g.pitch_radius_pinion = 0.5 * m * spec.pinion_teeth;
  g.pitch_radius_gear = 0.5 * m * spec.gear_teeth;
  g.base_radius_pinion = g.pitch_radius_pinion * std::cos(g.pressure_angle_rad);
  g.base_radius_gear = g.pitch_radius_gear * std::cos(g.pressure_angle_rad);
  g.tip_radius_pinion = g.pitch_radius_pinion + spec.addendum_coefficient * m;
  g.tip_radius_gear = g.pitch_radius_gear + spec.addendum_coefficient * m;
  g.root_radius_pinion = g.pitch_radius_pinion - spec.dedendum_coefficient * m;
  g.root_radius_gear = g.pitch_radius_gear - spec.dedendum_coefficient * m;
  g.centre_distance = g.pitch_radius_pinion + g.pitch_radius_gear;
  g.base_pitch = 2.0 * std::numbers::pi * g.base_radius_pinion / spec.pinion_teeth;
  g.line_of_action_length = g.centre_distance * std::sin(g.pressure_angle_rad);
  const double gear_tip_reach = std::sqrt(g.tip_radius_gear * g.tip_radius_gear - g.base_radius_gear * g.base_radius_gear);
  const double pinion_tip_reach =
      std::sqrt(g.tip_radius_pinion * g.tip_radius_pinion - g.base_radius_pinion * g.base_radius_pinion);
  g.contact_start = g.line_of_action_length - gear_tip_reach;
  g.contact_end = pinion_tip_reach;
  require(g.contact_start > 0 && g.contact_end < g.line_of_action_length,
          "a tip reaches past the other gear's base circle (involute interference)");
  g.contact_ratio = (g.contact_end - g.contact_start) / g.base_pitch;
  require(g.contact_ratio >= 1.0, "contact ratio " + std::to_string(g.contact_ratio) + " is below 1");
  require(g.contact_ratio < 3.0, "contact ratio of 3 or more is not supported");
  g.effective_modulus = spec.youngs_modulus_pa / (2.0 * (1.0 - spec.poisson_ratio * spec.poisson_ratio));
  return g;
}

double GearGeometry::sliding_speed(double s, double omega1) const {
  const double omega2 = omega1 * spec.pinion_teeth / spec.gear_teeth;
  return std::abs(omega1 * curvature_radius_pinion(s) - omega2 * curvature_radius_gear(s));
}

HertzContact hertz_contact(const GearGeometry& g, double s, double normal_force_n) {
  HertzContact c;
  if (!(normal_force_n > 0) || s <= 0 || s >= g.line_of_action_length) return c;
  const double r1 = g.curvature_radius_pinion(s), r2 = g.curvature_radius_gear(s);
  const double reduced_radius = r1 * r2 / (r1 + r2);
  const double load_per_width = normal_force_n / g.spec.face_width_m;
  c.max_pressure_pa = std::sqrt(load_per_width * g.effective_modulus / (std::numbers::pi * reduced_radius));
  c.half_width_m = std::sqrt(4.0 * load_per_width * reduced_radius / (std::numbers::pi * g.effective_modulus));
  return c;
}

}  // namespace gearwatch::twin
