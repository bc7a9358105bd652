#pragma once
// Alerts: the enumerated values that cross from the daemon into the database (each with one
// to_string and a list of every value, from which storage builds its vocabulary), and the state
// machine that decides when an alert is raised or cleared.
//
// An alert is keyed by (kind, channel, subject). Conditions are observed once per record (or per
// acquisition event); hysteresis keeps a flickering condition from raising an alert at every
// record: a condition must hold for `raise_after` consecutive observations to raise and be
// absent for `clear_after` consecutive observations to clear. While raised, a change of value
// (fatigue_pitting -> both) is a new event. The state is a plain value so the daemon can store
// it with the record that changed it and reload it at start: a restarted process never raises
// again what is already raised.
#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace gearwatch {

enum class AlertKind : std::uint8_t {
  wear_mechanism,      ///< a wear mechanism identified (§4.4); value = the mechanism token
  carrier_band_jump,   ///< the ICS2-selected carrier band moved, significantly and lastingly
  sensor_missing,      ///< a configured channel absent from the stream or stopped; value = how
  sensor_flat_line,    ///< a channel's signal is constant (dead sensor or cable)
  sensor_saturated,    ///< more than max_clipped_fraction of a channel's samples at full scale
  life_counter_reset,  ///< the odometer went backwards: new gear pair or front-end fault
  indicator_threshold, ///< an indicator above its per-gearbox baseline; subject = the indicator
  remaining_life,      ///< the model's remaining life to a limit below the configured cycles; subject = the limit
  twin_drift,          ///< a gap family newly significant between twin and gearbox; subject = the family, value = its distance
  tacho_missing,       ///< a configured tacho sends no edges while the samples go on; channel = the shaft, value = how
  cycle_count_fault,   ///< a record's revolutions cannot be trusted (tacho disagrees with the speed frame, or they go backwards)
  sample_rate_mismatch,///< the stream header's sample rate differs from rig.sample_rate_hz; value = the header's rate
  tacho_speed_mismatch,///< the tacho's mean speed disagrees with the vibration signal's estimate; value = the relative difference
  mqtt_refused,        ///< the MQTT broker refuses this gearbox (bad credentials, not authorised); value = the broker's reason
  mqtt_outbox_full,    ///< the MQTT outbox reached its limit and dropped its oldest messages; value = how many so far
};
inline constexpr std::array kAllAlertKinds{AlertKind::wear_mechanism,   AlertKind::carrier_band_jump,
                                           AlertKind::sensor_missing,   AlertKind::sensor_flat_line,
                                           AlertKind::sensor_saturated, AlertKind::life_counter_reset,
                                           AlertKind::indicator_threshold, AlertKind::remaining_life,
                                           AlertKind::twin_drift,       AlertKind::tacho_missing,
                                           AlertKind::cycle_count_fault, AlertKind::sample_rate_mismatch,
                                           AlertKind::tacho_speed_mismatch, AlertKind::mqtt_refused,
                                           AlertKind::mqtt_outbox_full};
const char* to_string(AlertKind kind) noexcept;

enum class AlertSeverity : std::uint8_t { info, warning, alarm };
inline constexpr std::array kAllAlertSeverities{AlertSeverity::info, AlertSeverity::warning, AlertSeverity::alarm};
const char* to_string(AlertSeverity severity) noexcept;
AlertSeverity severity_of(AlertKind kind) noexcept;

enum class AlertTransition : std::uint8_t {
  raised,   ///< the condition began (or, while raised, its value changed)
  cleared,  ///< the condition ended
  event,    ///< a one-off occurrence with no lasting state (a band jump, a counter reset)
};
inline constexpr std::array kAllAlertTransitions{AlertTransition::raised, AlertTransition::cleared,
                                                 AlertTransition::event};
const char* to_string(AlertTransition transition) noexcept;

/// channel = -1 for alerts about the gearbox as a whole; `subject` tells apart alerts of one
/// kind and channel (e.g. the indicator of a threshold alert), "" when there is one.
struct AlertKey {
  AlertKey() = default;
  AlertKey(AlertKind k, int c, std::string s = {}) : kind(k), channel(c), subject(std::move(s)) {}
  AlertKind kind = AlertKind::wear_mechanism;
  int channel = -1;
  std::string subject;
  auto operator<=>(const AlertKey&) const = default;
};

/// What is stored per key between observations (and across restarts).
struct AlertState {
  bool active = false;
  std::string value;            ///< value of the raised alert ("" when not active)
  int consecutive_present = 0;  ///< observations in a row with the condition present
  int consecutive_absent = 0;   ///< ... absent
  double marker = 0.0;          ///< kind-specific memory (band jump: cycles of the last jump reported)
  bool operator==(const AlertState&) const = default;
};

struct AlertEvent {
  AlertKey key;
  AlertSeverity severity = AlertSeverity::warning;
  AlertTransition transition = AlertTransition::raised;
  std::string value;
  std::string message;
};

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
