#include "gearwatch/gap/gap_report.hpp"

#include <cmath>
#include <cstdio>
#include <string>

namespace gearwatch::gap {

const char* to_string(FamilyKind family) noexcept {
  switch (family) {
    case FamilyKind::input_shaft_orders: return "input_shaft_orders";
    case FamilyKind::output_shaft_orders: return "output_shaft_orders";
    case FamilyKind::mesh_harmonics: return "mesh_harmonics";
    case FamilyKind::input_sidebands: return "input_sidebands";
    case FamilyKind::output_sidebands: return "output_sidebands";
    case FamilyKind::fixed_frequency: return "fixed_frequency";
    case FamilyKind::broadband: return "broadband";
  }
  return "unknown";
}

const char* to_string(CandidateEffect effect) noexcept {
  switch (effect) {
    case CandidateEffect::casing_mode: return "casing_mode";
    case CandidateEffect::tooth_errors: return "tooth_errors";
    case CandidateEffect::eccentricity: return "eccentricity";
    case CandidateEffect::tip_relief: return "tip_relief";
    case CandidateEffect::speed_fluctuation: return "speed_fluctuation";
    case CandidateEffect::load_fluctuation: return "load_fluctuation";
    case CandidateEffect::noise_floor: return "noise_floor";
    case CandidateEffect::mount_resonance: return "mount_resonance";
    case CandidateEffect::misalignment: return "misalignment";
    case CandidateEffect::backlash: return "backlash";
  }
  return "unknown";
}


const char* to_string(FeatureMovement movement) noexcept {
  switch (movement) {
    case FeatureMovement::fixed_in_orders: return "fixed_in_orders";
    case FeatureMovement::fixed_in_hz: return "fixed_in_hz";
    case FeatureMovement::neither: return "neither";
    case FeatureMovement::undetermined: return "undetermined";
  }
  return "unknown";
}

const char* to_string(FeatureShaft shaft) noexcept {
  switch (shaft) {
    case FeatureShaft::input: return "input";
    case FeatureShaft::output: return "output";
  }
  return "unknown";
}

namespace {
std::string format(const char* fmt, double a, double b = 0, double c = 0) {
  char buf[160];
  std::snprintf(buf, sizeof buf, fmt, a, b, c);
  return buf;
}
}  // namespace

std::string describe(const GapFeature& f) {
  const std::string order = std::string(to_string(f.shaft)) + format(" order %.2f", f.order);
  const std::string hz = format("%.1f Hz (band %.1f-%.1f Hz)", f.hz, f.hz_low, f.hz_high);
  std::string where;
  switch (f.movement) {
    case FeatureMovement::fixed_in_orders: where = order + ", fixed in orders"; break;
    case FeatureMovement::fixed_in_hz: where = hz + ", fixed in Hz"; break;
    case FeatureMovement::neither: where = order + " / " + hz + ", moves with neither"; break;
    case FeatureMovement::undetermined: where = order + " / " + hz + ", speeds too close to tell"; break;
  }
  return where + format(", %+.1f dB [%+.1f, %+.1f]", f.size_db, f.size_interval_db.low, f.size_interval_db.high) +
         ", seen in " + std::to_string(f.seen_in.size()) + (f.seen_in.size() == 1 ? " record" : " records");
}

std::string describe(const ParameterBound& b) {
  const bool metres = b.name.size() > 2 && b.name.compare(b.name.size() - 2, 2, "_m") == 0;
  const std::string value = metres && std::abs(b.bound) < 1e-2 ? format("%.4g µm", b.bound * 1e6) : format("%.4g", b.bound);
  return b.name + " would need " + (b.upper ? "> " : "< ") + value + (b.upper ? " (the top of its range)" : " (the bottom of its range)");
}

}  // namespace gearwatch::gap
