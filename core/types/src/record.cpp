#include "gearwatch/types/record.hpp"

#include <utility>

namespace gearwatch {

const char* to_string(RecordEnd end) noexcept {
  switch (end) {
    case RecordEnd::complete: return "complete";
    case RecordEnd::cut_at_dropout: return "cut_at_gap";  // the stored token (docs/storage.md, "Stored names")
    case RecordEnd::stream_end: return "stream_end";
  }
  return "unknown";
}

const char* to_string(CycleCountFault fault) noexcept {
  switch (fault) {
    case CycleCountFault::none: return "none";
    case CycleCountFault::edge_rate_mismatch: return "edge_rate_mismatch";
    case CycleCountFault::went_backwards: return "went_backwards";
  }
  return "unknown";
}

Record single_channel_record(std::vector<float> samples, std::vector<double> input_tacho_edges, double sample_rate_hz,
                             double speed_hz, double torque_nm, int channel_number) {
  Record r;
  r.sample_rate_hz = sample_rate_hz;
  r.channels = {std::move(samples)};
  r.channel_numbers = {channel_number};
  r.tacho_edges[0] = std::move(input_tacho_edges);
  r.speed_hz = speed_hz;
  r.torque_nm = torque_nm;
  return r;
}

}  // namespace gearwatch
