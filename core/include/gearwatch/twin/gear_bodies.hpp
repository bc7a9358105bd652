#pragma once
// The gear bodies' masses and inertias for a gear pair other than the thesis rig's: each gear a
// solid steel disc at its pitch diameter across the face width, plus the share of its shaft that
// the rig's calibrated set carries (the shafts, bearings and pedestals stay the rig's unless the
// [twin] table gives them). Closed form; used when [gears] differs from the thesis pair and the
// [twin] table does not set m5, I5, m10, I10.
#include <set>
#include <string>

#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/twin/gearbox_parameters.hpp"

namespace gearwatch::twin {

/// A solid disc of radius r and width b: m = ρ π r² b, I = m r² / 2.
struct DiscBody {
  double mass_kg = 0;
  double inertia_kg_m2 = 0;
};
DiscBody pitch_disc(const GearPairSpec& gears, int teeth);

/// `base` with its gear pair replaced by `gears`: m5, I5 (pinion) and m10, I10 (gear) become the
/// new pair's pitch discs plus the shaft share of `base` (its value minus the disc of its own
/// pair), except for the names in `given`, which keep `base`'s value. When `gears` is `base`'s pair
/// the result is `base` exactly.
GearboxParameters with_gear_pair(const GearboxParameters& base, const GearPairSpec& gears, const std::set<std::string>& given = {});

/// True when the two specs describe the same pair (every field equal).
bool same_gear_pair(const GearPairSpec& a, const GearPairSpec& b);

}  // namespace gearwatch::twin
