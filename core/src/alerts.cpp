#include "gearwatch/alerts.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace gearwatch {

AlertSeverity severity_of(AlertKind kind) noexcept {
  switch (kind) {
    case AlertKind::wear_mechanism: return AlertSeverity::warning;
    case AlertKind::carrier_band_jump: return AlertSeverity::warning;
    // A dead sensor blinds the monitoring of that channel: staff must act.
    case AlertKind::sensor_missing: return AlertSeverity::alarm;
    case AlertKind::sensor_flat_line: return AlertSeverity::alarm;
    case AlertKind::sensor_saturated: return AlertSeverity::warning;
    case AlertKind::life_counter_reset: return AlertSeverity::warning;
    case AlertKind::indicator_threshold: return AlertSeverity::warning;
    // The gear pair is forecast to reach a scrap limit soon: replacement must be planned.
    case AlertKind::remaining_life: return AlertSeverity::alarm;
    // The twin no longer explains part of the spectrum: its wear inferences need a look, the
    // gearbox itself is not in danger because of it.
    case AlertKind::twin_drift: return AlertSeverity::warning;
    // Without the tacho no order-domain indicator and no wear verdict: as blind as a dead accelerometer.
    case AlertKind::tacho_missing: return AlertSeverity::alarm;
    // The records go on being analysed; only their place in the pair's life is unknown.
    case AlertKind::cycle_count_fault: return AlertSeverity::warning;
    case AlertKind::sample_rate_mismatch: return AlertSeverity::warning;
    case AlertKind::tacho_speed_mismatch: return AlertSeverity::warning;
    // The gearbox is watched as before; only the plant does not hear of it.
    case AlertKind::mqtt_refused: return AlertSeverity::warning;
    // Messages are being lost for good: the plant's history of this gearbox gets a hole.
    case AlertKind::mqtt_outbox_full: return AlertSeverity::alarm;
    // The broker took the connection but not these messages: they never reach the plant unless
    // someone fixes the ACL (they stay in the local database, marked refused).
    case AlertKind::mqtt_publish_refused: return AlertSeverity::alarm;
  }
  return AlertSeverity::warning;
}

AlertTracker::AlertTracker(std::map<AlertKey, AlertState> states) : states_(states), stored_(std::move(states)) {}

std::optional<AlertEvent> AlertTracker::observe(AlertKey key, bool present, const std::string& value,
                                                const std::string& message, AlertHysteresis hysteresis) {
  AlertState& s = states_[key];
  AlertEvent e{key, severity_of(key.kind), AlertTransition::raised, value, message};
  if (present) {
    ++s.consecutive_present;
    s.consecutive_absent = 0;
    if (s.active) {
      if (s.value == value) return std::nullopt;
      s.value = value;  // still raised, but what is present changed: staff must hear of it
      return e;
    }
    if (s.consecutive_present < std::max(1, hysteresis.raise_after)) return std::nullopt;
    s.active = true;
    s.value = value;
    return e;
  }
  ++s.consecutive_absent;
  s.consecutive_present = 0;
  if (!s.active || s.consecutive_absent < std::max(1, hysteresis.clear_after)) return std::nullopt;
  s.active = false;
  e.transition = AlertTransition::cleared;
  e.severity = AlertSeverity::info;
  e.value = s.value;
  s.value.clear();
  return e;
}

namespace {

// The value the raised alert was last raised with: its marker, or (for a state stored before the
// marker was kept) its stored text read back.
double raised_value(const AlertState& s) { return s.marker != 0.0 ? s.marker : std::strtod(s.value.c_str(), nullptr); }

}  // namespace

std::optional<AlertEvent> AlertTracker::observe_measured(AlertKey key, bool present, double value, const std::string& value_text,
                                                         const std::string& message, AlertHysteresis hysteresis,
                                                         double reraise_change) {
  const AlertState& s = states_[key];
  const double then = raised_value(s);
  const bool moved = std::abs(value - then) > reraise_change * std::abs(then);
  const bool same_condition = present && s.active && !moved;
  auto e = observe(key, present, same_condition ? s.value : value_text, message, hysteresis);
  if (e && e->transition == AlertTransition::raised) states_[key].marker = value;
  return e;
}

AlertEvent AlertTracker::occurrence(AlertKey key, const std::string& value, const std::string& message) {
  states_[key];  // known key, so a later take_changed() carries its marker
  return AlertEvent{key, severity_of(key.kind), AlertTransition::event, value, message};
}

std::vector<AlertEvent> AlertTracker::clear_all(AlertKind kind, const std::string& message) {
  std::vector<AlertEvent> out;
  for (auto& [key, s] : states_) {
    if (key.kind != kind) continue;
    if (s.active) out.push_back(AlertEvent{key, AlertSeverity::info, AlertTransition::cleared, s.value, message});
    s = AlertState{};
  }
  return out;
}

const AlertState* AlertTracker::state(AlertKey key) const {
  const auto it = states_.find(key);
  return it == states_.end() ? nullptr : &it->second;
}

std::vector<std::pair<AlertKey, AlertState>> AlertTracker::take_changed() {
  std::vector<std::pair<AlertKey, AlertState>> out;
  for (const auto& [key, s] : states_) {
    const auto it = stored_.find(key);
    if (it == stored_.end() || !(it->second == s)) out.emplace_back(key, s);
  }
  for (const auto& [key, s] : out) stored_[key] = s;
  return out;
}

}  // namespace gearwatch
