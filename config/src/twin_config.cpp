#include "gearwatch/config/twin_config.hpp"

#include <fstream>
#include <set>
#include <sstream>

#include <toml++/toml.h>

#include "gearwatch/config/config.hpp"
#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/gear_bodies.hpp"

namespace gearwatch::config {
namespace {

// The twin follows the configured gear pair: [gears] replaces the thesis's pair, and the gear
// bodies the [twin] table does not set follow its geometry (twin::with_gear_pair).
twin::GearboxParameters with_configured_gears(const twin::GearboxParameters& p, const toml::table& root, std::string_view text,
                                              const std::string& source, const std::set<std::string>& given) {
  if (!root.get("gears")) return p;
  const GearwatchConfig config = parse_config(std::string(text), source);
  try {
    return twin::with_gear_pair(p, config.rig.gears, given);
  } catch (const twin::TwinParameterError& e) {
    throw TwinConfigError(source + ": [gears]: " + e.what());
  }
}

}  // namespace

twin::GearboxParameters twin_parameters_from_toml(std::string_view text, const std::string& source) {
  toml::table root;
  try {
    root = toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    throw TwinConfigError(source + " line " + std::to_string(e.source().begin.line) + ": " + std::string(e.description()));
  }
  twin::GearboxParameters p;
  std::set<std::string> given;
  const toml::node* node = root.get("twin");
  if (!node) return with_configured_gears(p, root, text, source, given);
  const toml::table* table = node->as_table();
  if (!table)
    throw TwinConfigError(source + " line " + std::to_string(node->source().begin.line) + ": [twin] must be a table");
  for (const auto& [key, value] : *table) {
    const std::string name(key.str());
    const std::string where = source + " line " + std::to_string(value.source().begin.line) + ": [twin]." + name;
    const twin::ParameterInfo* info = twin::find_parameter(name);
    if (!info) throw TwinConfigError(where + ": unknown key");
    const auto number = value.value<double>();
    if (!(value.is_integer() || value.is_floating_point()) || !number)
      throw TwinConfigError(where + ": expected a number");
    p.*(info->field) = *number;
    given.insert(name);
    try {
      p.validate();
    } catch (const twin::TwinParameterError& e) {
      throw TwinConfigError(where + ": " + e.what());
    }
  }
  return with_configured_gears(p, root, text, source, given);
}

twin::GearboxParameters load_twin_parameters(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw TwinConfigError("cannot read config file " + path);
  std::ostringstream text;
  text << in.rdbuf();
  return twin_parameters_from_toml(text.str(), path);
}

}  // namespace gearwatch::config
