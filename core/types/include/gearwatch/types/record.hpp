#pragma once
// A record: a contiguous stretch of the sample clock, cut by the processing thread from the
// acquisition stream (thesis §3.2.2: 10 s records at 100 kHz). Value type only: no I/O.
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace gearwatch {

inline constexpr int kMaxShafts = 4;

/// How a record ended. A record containing a dropout (missing samples) is never analysed as
/// if continuous: it is cut at the dropout (analysed if still long enough) or rejected.
enum class RecordEnd : std::uint8_t {
  complete = 0,     ///< the configured length was reached
  cut_at_dropout = 1,  ///< a dropout ended it early; the samples before it are kept
  stream_end = 2,   ///< the stream changed or the source ended; kept if long enough
};

const char* to_string(RecordEnd end) noexcept;
inline constexpr std::array kAllRecordEnds{RecordEnd::complete, RecordEnd::cut_at_dropout, RecordEnd::stream_end};

/// Why a record's input revolutions failed the assembler's check (they are then not used).
enum class CycleCountFault : std::uint8_t {
  none = 0,
  edge_rate_mismatch = 1,  ///< the input tacho's speed (edges / edges_per_rev) disagrees with the speed frame
  went_backwards = 2,      ///< below zero, or below the previous record's count in the same stream
};
const char* to_string(CycleCountFault fault) noexcept;

struct Record {
  std::int64_t stream_key = 0;        ///< database id of the stream (0 when not stored)
  std::uint16_t stream_id = 0;        ///< protocol stream id (header frame)
  double sample_rate_hz = 0.0;
  std::uint64_t start_index = 0;      ///< unwrapped sample index of the first sample
  RecordEnd end = RecordEnd::complete;
  /// One vector per configured channel, physical units (m/s²), all the same length.
  std::vector<std::vector<float>> channels;
  std::vector<int> channel_numbers;   ///< protocol channel number c of each vector above
  /// Tacho edge positions per shaft, in samples relative to start_index (fractional).
  std::array<std::vector<double>, kMaxShafts> tacho_edges;
  double torque_nm = std::numeric_limits<double>::quiet_NaN();
  double speed_hz = std::numeric_limits<double>::quiet_NaN();
  /// Input-shaft revolutions since the pair was installed, at the first sample (life counter
  /// plus revolutions counted from the tacho since the last life-counter frame).
  std::optional<double> input_revolutions;
  /// Set when input_revolutions failed the check; `cycle_fault_detail` says why, with the numbers.
  CycleCountFault cycle_fault = CycleCountFault::none;
  std::string cycle_fault_detail;

  std::size_t sample_count() const noexcept { return channels.empty() ? 0 : channels.front().size(); }
  double duration_s() const noexcept { return sample_rate_hz > 0 ? sample_count() / sample_rate_hz : 0.0; }
};

/// A one-channel record with input-shaft tacho edges, as a simulator (the twin, the rig) hands a
/// signal to the analysis.
Record single_channel_record(std::vector<float> samples, std::vector<double> input_tacho_edges, double sample_rate_hz,
                             double speed_hz, double torque_nm, int channel_number = 0);

}  // namespace gearwatch
