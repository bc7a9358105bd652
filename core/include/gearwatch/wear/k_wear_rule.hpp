#pragma once
// How a K_wear update moves K (docs/model.md). Its own header, so the configuration can name the
// rule as a type without the twin behind it.
#include <array>
#include <cstdint>

namespace gearwatch::wear {

enum class KWearUpdateRule : std::uint8_t {
  root_find,     ///< bracketed secant on ln K from the twin's elasticity (converges where RMS_SA follows K)
  proportional,  ///< the thesis's Eq. 7.13, K ← K · meas / sim (exact only where RMS_SA ∝ K)
};
inline constexpr std::array kAllKWearUpdateRules{KWearUpdateRule::root_find, KWearUpdateRule::proportional};

constexpr const char* to_string(KWearUpdateRule rule) noexcept {
  switch (rule) {
    case KWearUpdateRule::root_find: return "root_find";
    case KWearUpdateRule::proportional: return "proportional";
  }
  return "unknown";
}

}  // namespace gearwatch::wear
