#pragma once
// The wear-mechanism verdict's values (thesis §4.4; dsp/wear_mechanism.hpp decides them): the
// mechanism and the two fixed carrier bands, stored with the verdict (vocabulary domains
// wear_mechanism and carrier_band).
#include <array>

namespace gearwatch::dsp {

enum class WearMechanism { none, fatigue_pitting, abrasive_wear, both, undetermined };
/// The stored tokens: none, fatigue_pitting, abrasive_wear, both, undetermined.
const char* to_string(WearMechanism mechanism) noexcept;
inline constexpr std::array kAllWearMechanisms{WearMechanism::none, WearMechanism::fatigue_pitting,
                                               WearMechanism::abrasive_wear, WearMechanism::both,
                                               WearMechanism::undetermined};
/// True for the verdicts that mean wear is under way.
constexpr bool is_wear(WearMechanism m) noexcept {
  return m == WearMechanism::fatigue_pitting || m == WearMechanism::abrasive_wear || m == WearMechanism::both;
}

/// The two fixed carrier bands of §4.4 (stored as the wear verdict's unseen band, vocabulary
/// domain carrier_band).
enum class CarrierBand { pitting, abrasion };
inline constexpr std::array kAllCarrierBands{CarrierBand::pitting, CarrierBand::abrasion};
/// The stored tokens: pitting, abrasion.
const char* to_string(CarrierBand band) noexcept;

}  // namespace gearwatch::dsp
