#pragma once
// Error types of the digital twin. Bad parameters are rejected when a model is built
// (never a NaN or a crash later); a run that diverges is stopped by the integrator's checks.
#include <stdexcept>
#include <string>

namespace gearwatch::twin {

/// A non-physical or inconsistent parameter (negative stiffness, zero mass, contact ratio < 1,
/// a parameter outside its documented prior range when one is required, ...). The message names it.
struct TwinParameterError : std::invalid_argument {
  explicit TwinParameterError(const std::string& what) : std::invalid_argument(what) {}
};

/// An integration that diverged (non-finite state, deflection beyond a physical bound, or the
/// step-size controller making no progress). Nothing of such a run is returned.
struct TwinDivergenceError : std::runtime_error {
  explicit TwinDivergenceError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace gearwatch::twin
