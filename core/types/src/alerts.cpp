#include "gearwatch/types/alerts.hpp"

namespace gearwatch {

const char* to_string(AlertKind kind) noexcept {
  switch (kind) {
    case AlertKind::wear_mechanism: return "wear_mechanism";
    case AlertKind::carrier_band_jump: return "carrier_band_jump";
    case AlertKind::sensor_missing: return "sensor_missing";
    case AlertKind::sensor_flat_line: return "sensor_flat_line";
    case AlertKind::sensor_saturated: return "sensor_saturated";
    case AlertKind::life_counter_reset: return "life_counter_reset";
    case AlertKind::indicator_threshold: return "indicator_threshold";
    case AlertKind::remaining_life: return "remaining_life";
    case AlertKind::twin_drift: return "twin_drift";
    case AlertKind::tacho_missing: return "tacho_missing";
    case AlertKind::cycle_count_fault: return "cycle_count_fault";
    case AlertKind::sample_rate_mismatch: return "sample_rate_mismatch";
    case AlertKind::tacho_speed_mismatch: return "tacho_speed_mismatch";
    case AlertKind::mqtt_refused: return "mqtt_refused";
    case AlertKind::mqtt_outbox_full: return "mqtt_outbox_full";
    case AlertKind::mqtt_publish_refused: return "mqtt_publish_refused";
  }
  return "unknown";
}

const char* to_string(AlertSeverity severity) noexcept {
  switch (severity) {
    case AlertSeverity::info: return "info";
    case AlertSeverity::warning: return "warning";
    case AlertSeverity::alarm: return "alarm";
  }
  return "unknown";
}

const char* to_string(AlertTransition transition) noexcept {
  switch (transition) {
    case AlertTransition::raised: return "raised";
    case AlertTransition::cleared: return "cleared";
    case AlertTransition::event: return "event";
  }
  return "unknown";
}

}  // namespace gearwatch
