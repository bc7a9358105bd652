#include "config_reload.hpp"

#include <algorithm>
#include <map>
#include <sstream>

#include <toml++/toml.h>

#include "gearwatch/types/token.hpp"

namespace gearwatch::daemon {
namespace {

// Every leaf of a TOML document as "dotted.key" -> its value printed as TOML.
void flatten(const toml::node& node, const std::string& key, std::map<std::string, std::string>& out) {
  if (const auto* table = node.as_table()) {
    for (const auto& [k, v] : *table) flatten(v, key.empty() ? std::string(k.str()) : key + "." + std::string(k.str()), out);
    if (table->empty() && !key.empty()) out[key] = "{}";
  } else if (const auto* array = node.as_array()) {
    for (std::size_t i = 0; i < array->size(); ++i) flatten(*array->get(i), key + "[" + std::to_string(i) + "]", out);
    if (array->empty()) out[key] = "[]";
  } else {
    std::ostringstream s;
    node.visit([&](const auto& v) { s << v; });
    out[key] = s.str();
  }
}

std::map<std::string, std::string> leaves(const std::string& text, const std::string& name) {
  std::map<std::string, std::string> out;
  try {
    flatten(toml::parse(text, name), "", out);
  } catch (const toml::parse_error& e) {
    // parse_config has already refused such a text with its own message; this keeps the
    // comparison total for the text the daemon started with.
    throw config::ConfigError(name + ": " + std::string(e.description()));
  }
  return out;
}

}  // namespace

const char* to_string(ReloadableKey key) {
  switch (key) {
    case ReloadableKey::logging_level: return "logging.level";
  }
  return "unknown";
}

std::string reloadable_value(ReloadableKey key, const config::GearwatchConfig& config) {
  switch (key) {
    case ReloadableKey::logging_level: return config::to_string(config.logging.level);
  }
  return {};
}

ReloadPlan plan_reload(const std::string& started_text, const config::GearwatchConfig& running, const std::string& new_text,
                       const std::string& name) {
  ReloadPlan plan{config::parse_config(new_text, name), {}, {}};
  for (const ReloadableKey key : kAllReloadableKeys)
    if (reloadable_value(key, running) != reloadable_value(key, plan.next)) plan.apply.push_back(key);
  const auto before = leaves(started_text, name);
  const auto after = leaves(new_text, name);
  auto consider = [&](const std::string& key) {
    if (!from_token(kAllReloadableKeys, key)) plan.restart_required.push_back(key);
  };
  for (const auto& [key, value] : before) {
    const auto it = after.find(key);
    if (it == after.end() || it->second != value) consider(key);
  }
  for (const auto& [key, value] : after)
    if (!before.count(key)) consider(key);
  std::sort(plan.restart_required.begin(), plan.restart_required.end());
  return plan;
}

std::string join_keys(const std::vector<std::string>& keys) {
  if (keys.empty()) return "none";
  std::string out;
  for (const auto& k : keys) out += (out.empty() ? "" : ", ") + k;
  return out;
}

}  // namespace gearwatch::daemon
