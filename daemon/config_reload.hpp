#pragma once
// What `systemctl reload gearwatch` (SIGHUP) does: the configuration file is read again and
// validated; the settings that can change safely while running are applied, every other changed
// key is named as needing a restart, and the daemon keeps running on its current settings.
// An invalid new file changes nothing (the running settings stay, the error is logged).
#include <array>
#include <string>
#include <vector>

#include "gearwatch/config/config.hpp"

namespace gearwatch::daemon {

/// A setting applied at run time on SIGHUP. Everything else (the interface, records, channels,
/// processing, alerts, storage, the model...) shapes threads, records or histories already under
/// way, so it takes a restart.
enum class ReloadableKey { logging_level };
inline constexpr std::array<ReloadableKey, 1> kAllReloadableKeys{ReloadableKey::logging_level};

/// The key's dotted name in the configuration file ("logging.level").
const char* to_string(ReloadableKey key);

/// The key's value in force in `config`, printed as the file spells it ("info").
std::string reloadable_value(ReloadableKey key, const config::GearwatchConfig& config);

struct ReloadPlan {
  config::GearwatchConfig next;                 ///< the new file, validated
  std::vector<ReloadableKey> apply;             ///< changed keys applied now
  std::vector<std::string> restart_required;    ///< changed keys that take effect only after a restart
};

/// Compares the file's new text against the text the daemon started with, key by key (a key
/// added, removed or changed counts as changed; array entries are compared by position, e.g.
/// `channels[1].scale`). A reloadable key is compared by its value in force (`running`), so a
/// level applied by an earlier reload is not reported again. Throws config::ConfigError when the
/// new text is not a valid config.
ReloadPlan plan_reload(const std::string& started_text, const config::GearwatchConfig& running, const std::string& new_text,
                       const std::string& name);

/// "a, b, c", or "none".
std::string join_keys(const std::vector<std::string>& keys);

}  // namespace gearwatch::daemon
