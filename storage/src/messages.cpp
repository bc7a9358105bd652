#include "gearwatch/storage/messages.hpp"

namespace gearwatch::storage {

// HealthSnapshot indexes its counters by the enum's value: the list must be in that order.
static_assert([] {
  for (std::size_t i = 0; i < kAllHealthCounters.size(); ++i)
    if (static_cast<std::size_t>(kAllHealthCounters[i]) != i) return false;
  return true;
}());

const char* to_string(HealthCounter counter) noexcept {
  switch (counter) {
    case HealthCounter::frames: return "frames";
    case HealthCounter::samples: return "samples";
    case HealthCounter::kernel_drops: return "kernel_drops";
    case HealthCounter::ring_overflows: return "ring_overflows";
    case HealthCounter::ring_high_water: return "ring_high_water";
    case HealthCounter::malformed_frames: return "malformed_frames";
    case HealthCounter::malformed_lines: return "malformed_lines";
    case HealthCounter::unknown_ids: return "unknown_ids";
    case HealthCounter::unconfigured_channel_frames: return "unconfigured_channel_frames";
    case HealthCounter::frames_before_header: return "frames_before_header";
    case HealthCounter::dropouts: return "gaps";
    case HealthCounter::dropout_samples: return "gap_samples";
    case HealthCounter::ring_dropouts: return "ring_gaps";
    case HealthCounter::duplicates: return "duplicates";
    case HealthCounter::tacho_edges: return "tacho_edges";
    case HealthCounter::tacho_out_of_order: return "tacho_out_of_order";
    case HealthCounter::stream_changes: return "stream_changes";
    case HealthCounter::life_counter_resets: return "life_counter_resets";
    case HealthCounter::unsupported_version: return "unsupported_version";
    case HealthCounter::read_errors: return "read_errors";
    case HealthCounter::reopens: return "reopens";
    case HealthCounter::records_complete: return "records_complete";
    case HealthCounter::records_cut: return "records_cut";
    case HealthCounter::records_rejected: return "records_rejected";
    case HealthCounter::records_restarted_after_dropout: return "records_restarted_after_gap";
    case HealthCounter::channels_stopped: return "channels_stopped";
    case HealthCounter::storage_retries: return "storage_retries";
    case HealthCounter::storage_rows_rejected: return "storage_rows_rejected";
    case HealthCounter::storage_queue_waits: return "storage_queue_waits";
    case HealthCounter::mqtt_published: return "mqtt_published";
    case HealthCounter::mqtt_delivered: return "mqtt_delivered";
    case HealthCounter::mqtt_connects: return "mqtt_connects";
    case HealthCounter::mqtt_connect_failures: return "mqtt_connect_failures";
    case HealthCounter::mqtt_refused: return "mqtt_refused";
    case HealthCounter::mqtt_outbox_dropped: return "mqtt_outbox_dropped";
    case HealthCounter::mqtt_publish_refused: return "mqtt_publish_refused";
    case HealthCounter::mqtt_resend_requests: return "mqtt_resend_requests";
    case HealthCounter::mqtt_resent: return "mqtt_resent";
    case HealthCounter::mqtt_resend_gone: return "mqtt_resend_gone";
    case HealthCounter::mqtt_resend_ignored: return "mqtt_resend_ignored";
  }
  return "unknown";
}

}  // namespace gearwatch::storage
