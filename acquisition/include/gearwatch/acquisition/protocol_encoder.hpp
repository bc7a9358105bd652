#pragma once
// Builds protocol v1 frames (the sending side: captures, simulators, tests).
#include <cstdint>
#include <span>

#include "gearwatch/acquisition/can_frame.hpp"
#include "gearwatch/acquisition/protocol_decoder.hpp"

namespace gearwatch::acquisition {

/// `samples.size()` must be ≤ 30 for FD, ≤ 2 for classic. FD frames are padded up to the next
/// valid FD length by the caller choosing a sample count that fits (30 samples = 64 bytes).
CanFrame make_vibration_frame(const ProtocolIds& ids, int channel, std::uint32_t first_index,
                              std::span<const std::int16_t> samples, bool fd);
CanFrame make_tacho_frame(const ProtocolIds& ids, int shaft, double position);
CanFrame make_stream_header(const ProtocolIds& ids, std::uint32_t sample_rate_hz, std::uint8_t channel_count,
                            std::uint16_t stream_id, std::uint8_t version = 1);
CanFrame make_operating_condition(const ProtocolIds& ids, float torque_nm, float speed_hz, std::uint32_t index);
CanFrame make_life_counter(const ProtocolIds& ids, std::uint64_t input_revolutions);

}  // namespace gearwatch::acquisition
