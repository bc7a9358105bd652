#pragma once
// Alerts: the state machine that decides when an alert is raised or cleared, and the severity of
// each kind. The values it works on (kinds, keys, states, events) are gearwatch/types/alerts.hpp.
//
// An alert is keyed by (kind, channel, subject). Conditions are observed once per record (or per
// acquisition event); hysteresis keeps a flickering condition from raising an alert at every
// record: a condition must hold for `raise_after` consecutive observations to raise and be
// absent for `clear_after` consecutive observations to clear. While raised, a change of value
// (fatigue_pitting -> both) is a new event. The state is a plain value so the daemon can store
// it with the record that changed it and reload it at start: a restarted process never raises
// again what is already raised.
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "gearwatch/types/alerts.hpp"

namespace gearwatch {

/// The severity a raised alert of `kind` is stored with.
AlertSeverity severity_of(AlertKind kind) noexcept;

struct AlertHysteresis {
  int raise_after = 1;  ///< consecutive observations with the condition before raising
  int clear_after = 1;  ///< consecutive observations without it before clearing
};

class AlertTracker {
 public:
  explicit AlertTracker(std::map<AlertKey, AlertState> states = {});

  /// One observation of a lasting condition. `value` says what is present (ignored when absent).
  /// Returns the event to store when the alert is raised, changes value, or clears.
  std::optional<AlertEvent> observe(AlertKey key, bool present, const std::string& value, const std::string& message,
                                    AlertHysteresis hysteresis);
  /// The same for a condition with a measured value, stored as `value_text`. While raised, it is
  /// raised again only when the value moved by more than `reraise_change` (a fraction of the value
  /// at the last raise, which the state's marker keeps): a value sitting on a rounding boundary
  /// of its text is one condition, not a stream of changes.
  std::optional<AlertEvent> observe_measured(AlertKey key, bool present, double value, const std::string& value_text,
                                             const std::string& message, AlertHysteresis hysteresis, double reraise_change);
  /// A one-off occurrence: an `event` transition, always reported.
  AlertEvent occurrence(AlertKey key, const std::string& value, const std::string& message);
  /// Clears every raised alert of `kind` (a new gear pair ends the old pair's wear alerts).
  std::vector<AlertEvent> clear_all(AlertKind kind, const std::string& message);

  const AlertState* state(AlertKey key) const;
  AlertState& mutable_state(AlertKey key) { return states_[key]; }
  const std::map<AlertKey, AlertState>& states() const noexcept { return states_; }
  /// Keys whose state changed since the last call (what must be written back).
  std::vector<std::pair<AlertKey, AlertState>> take_changed();

 private:
  std::map<AlertKey, AlertState> states_;
  std::map<AlertKey, AlertState> stored_;  ///< as last handed out by take_changed()
};

}  // namespace gearwatch
