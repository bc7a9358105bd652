#include "gearwatch/twin/gear_bodies.hpp"

#include <numbers>

#include "gearwatch/twin/errors.hpp"

namespace gearwatch::twin {

DiscBody pitch_disc(const GearPairSpec& gears, int teeth) {
  if (teeth < 1 || !(gears.module_m > 0) || !(gears.face_width_m > 0) || !(gears.density_kg_m3 > 0))
    throw TwinParameterError("gear body: teeth, module, face width and density must be positive");
  const double r = 0.5 * gears.module_m * teeth;
  DiscBody d;
  d.mass_kg = gears.density_kg_m3 * std::numbers::pi * r * r * gears.face_width_m;
  d.inertia_kg_m2 = 0.5 * d.mass_kg * r * r;
  return d;
}

bool same_gear_pair(const GearPairSpec& a, const GearPairSpec& b) {
  return a.pinion_teeth == b.pinion_teeth && a.gear_teeth == b.gear_teeth && a.module_m == b.module_m &&
         a.pressure_angle_deg == b.pressure_angle_deg && a.face_width_m == b.face_width_m &&
         a.youngs_modulus_pa == b.youngs_modulus_pa && a.poisson_ratio == b.poisson_ratio &&
         a.density_kg_m3 == b.density_kg_m3 && a.addendum_coefficient == b.addendum_coefficient &&
         a.dedendum_coefficient == b.dedendum_coefficient;
}

GearboxParameters with_gear_pair(const GearboxParameters& base, const GearPairSpec& gears, const std::set<std::string>& given) {
  if (same_gear_pair(base.gears, gears)) return base;
  GearboxParameters p = base;
  p.gears = gears;
  const DiscBody old_pinion = pitch_disc(base.gears, base.gears.pinion_teeth);
  const DiscBody old_gear = pitch_disc(base.gears, base.gears.gear_teeth);
  const DiscBody new_pinion = pitch_disc(gears, gears.pinion_teeth);
  const DiscBody new_gear = pitch_disc(gears, gears.gear_teeth);
  // The shaft share is what the base set carries beyond its own disc; it cannot fall below zero.
  auto body = [&](const char* name, double GearboxParameters::*field, double old_disc, double new_disc) {
    if (given.count(name)) return;
    const double share = base.*field - old_disc;
    p.*field = new_disc + (share > 0 ? share : 0.0);
  };
  body("m5", &GearboxParameters::m5, old_pinion.mass_kg, new_pinion.mass_kg);
  body("I5", &GearboxParameters::I5, old_pinion.inertia_kg_m2, new_pinion.inertia_kg_m2);
  body("m10", &GearboxParameters::m10, old_gear.mass_kg, new_gear.mass_kg);
  body("I10", &GearboxParameters::I10, old_gear.inertia_kg_m2, new_gear.inertia_kg_m2);
  p.validate();
  return p;
}

}  // namespace gearwatch::twin
