#pragma once
// The alert values that cross from the daemon into the database: the kinds, severities and
// transitions (each with one to_string and a list of every value, from which storage builds its
// vocabulary), the key an alert is tracked by, the state kept per key and the event stored.
// Plain values: the state machine that produces them is gearwatch/alerts.hpp.
#include <array>
#include <cstdint>
#include <string>
#include <utility>

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
  mqtt_publish_refused,///< the MQTT broker refused published messages (MQTT 5 PUBACK reason >= 0x80, e.g. outside the ACL); value = the reason
};
inline constexpr std::array kAllAlertKinds{AlertKind::wear_mechanism,   AlertKind::carrier_band_jump,
                                           AlertKind::sensor_missing,   AlertKind::sensor_flat_line,
                                           AlertKind::sensor_saturated, AlertKind::life_counter_reset,
                                           AlertKind::indicator_threshold, AlertKind::remaining_life,
                                           AlertKind::twin_drift,       AlertKind::tacho_missing,
                                           AlertKind::cycle_count_fault, AlertKind::sample_rate_mismatch,
                                           AlertKind::tacho_speed_mismatch, AlertKind::mqtt_refused,
                                           AlertKind::mqtt_outbox_full, AlertKind::mqtt_publish_refused};
const char* to_string(AlertKind kind) noexcept;

enum class AlertSeverity : std::uint8_t { info, warning, alarm };
inline constexpr std::array kAllAlertSeverities{AlertSeverity::info, AlertSeverity::warning, AlertSeverity::alarm};
const char* to_string(AlertSeverity severity) noexcept;

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

}  // namespace gearwatch
