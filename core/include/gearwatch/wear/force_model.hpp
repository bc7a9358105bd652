#pragma once
// Where the blue loop's pass force comes from (docs/wear.md). Its own header, so the configuration
// and the command line can name it as a type without the twin behind it.
#include <array>
#include <cstdint>

namespace gearwatch::wear {

enum class ForceModel : std::uint8_t {
  quasi_static,   ///< load sharing from the mesh stiffness and the worn GTE (no dynamics; ~ms per step)
  dynamic,        ///< the 21-DOF twin's dynamic contact force (one simulated pass; ~0.1–0.3 s per step)
};
inline constexpr std::array kAllForceModels{ForceModel::quasi_static, ForceModel::dynamic};

/// The token of the configuration (model.force_model) and of `twin wear --force-model` (read back
/// by gearwatch::from_token).
constexpr const char* to_string(ForceModel model) noexcept {
  switch (model) {
    case ForceModel::quasi_static: return "quasi-static";
    case ForceModel::dynamic: return "dynamic";
  }
  return "unknown";
}

}  // namespace gearwatch::wear
