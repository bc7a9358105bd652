#include "gearwatch/types/wear_mechanism.hpp"

namespace gearwatch::dsp {

const char* to_string(WearMechanism mechanism) noexcept {
  switch (mechanism) {
    case WearMechanism::none: return "none";
    case WearMechanism::fatigue_pitting: return "fatigue_pitting";
    case WearMechanism::abrasive_wear: return "abrasive_wear";
    case WearMechanism::both: return "both";
    case WearMechanism::undetermined: return "undetermined";
  }
  return "undetermined";
}

const char* to_string(CarrierBand band) noexcept {
  switch (band) {
    case CarrierBand::pitting: return "pitting";
    case CarrierBand::abrasion: return "abrasion";
  }
  return "unknown";
}

}  // namespace gearwatch::dsp
