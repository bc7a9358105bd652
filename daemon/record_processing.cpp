#include "record_processing.hpp"

#include <cmath>

#include "gearwatch/basic_statistics.hpp"

namespace gearwatch::daemon {

RecordProcessor::RecordProcessor(const config::GearwatchConfig& config) : config_(config) {}

storage::RecordResult RecordProcessor::process(const Record& record, bool analysable, std::uint64_t stream_sequence) {
  storage::RecordResult out;
  out.stream_sequence = stream_sequence;
  out.start_index = record.start_index;
  out.sample_count = record.sample_count();
  out.duration_s = record.duration_s();
  out.end_reason = to_string(record.end);
  out.analysed = analysable;
  out.torque_nm = record.torque_nm;
  out.speed_hz = record.speed_hz;
  out.input_revolutions = record.input_revolutions;
  if (!analysable) {
    out.reject_reason = record.end == RecordEnd::cut_at_gap ? "shorter than records.min_length_s after a gap"
                                                             : "shorter than records.min_length_s at stream end";
    return out;
  }
  // Measured input speed from the input-shaft tacho, stored with every channel's values.
  std::optional<double> measured_speed;
  for (const auto& t : config_.rig.tachos) {
    if (t.ratio_to_input == 1.0 && t.shaft < kMaxShafts) {
      measured_speed = mean_speed_from_edges(record.tacho_edges[static_cast<std::size_t>(t.shaft)], t.edges_per_rev,
                                             record.sample_rate_hz);
      break;
    }
  }
  for (std::size_t c = 0; c < record.channels.size(); ++c) {
    storage::ChannelResult ch;
    ch.channel = record.channel_numbers.at(c);
    const SignalStatistics s = compute_statistics(record.channels[c]);
    if (s.non_finite > 0) {
      ch.skipped.emplace_back("rms_raw", "nan_or_inf_samples");
    } else {
      ch.values.emplace_back("mean_raw", s.mean);
      ch.values.emplace_back("rms_raw", s.rms);
      ch.values.emplace_back("peak_raw", s.peak);
      ch.values.emplace_back("kurtosis_raw", s.kurtosis);
      ch.values.emplace_back("crest_factor_raw", s.crest_factor);
    }
    if (measured_speed) ch.values.emplace_back("input_speed_hz", *measured_speed);
    else ch.skipped.emplace_back("input_speed_hz", "no_tacho");
    out.channels.push_back(std::move(ch));
  }
  return out;
}

}  // namespace gearwatch::daemon
