#pragma once
// Loader for the optional [twin] table of the daemon's TOML config file: it overrides the twin's
// built-in (calibrated) parameters. Keys are the parameter names of gearwatch::twin::parameter_table()
// (e.g. kt12 = 1290.0, structural_damping_ratio = 0.03). Unknown keys and non-numeric values are
// errors naming the key and its line. Other tables of the file are ignored here.
#include <stdexcept>
#include <string>
#include <string_view>

#include "gearwatch/twin/gearbox_parameters.hpp"

namespace gearwatch::config {

struct TwinConfigError : std::runtime_error {
  explicit TwinConfigError(const std::string& what) : std::runtime_error(what) {}
};

/// Parses TOML text; `source` names it in error messages. Missing [twin] = the defaults.
twin::GearboxParameters twin_parameters_from_toml(std::string_view text, const std::string& source = "config");
/// Reads and parses a file (throws TwinConfigError when it cannot be read or parsed).
twin::GearboxParameters load_twin_parameters(const std::string& path);

}  // namespace gearwatch::config
