#include "gearwatch/gap/gap_report.hpp"

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

}  // namespace gearwatch::gap
