#include "gearwatch/acquisition/protocol_encoder.hpp"

#include <cmath>
#include <cstring>
#include <stdexcept>

namespace gearwatch::acquisition {
namespace {

void put_u32(CanFrame& f, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) f.data[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
}

}  // namespace

CanFrame make_vibration_frame(const ProtocolIds& ids, int channel, std::uint32_t first_index,
                              std::span<const std::int16_t> samples, bool fd) {
  const std::size_t max = fd ? 30 : 2;
  if (samples.size() > max) throw std::invalid_argument("too many samples for one frame");
  CanFrame f;
  f.id = ids.vibration_base + static_cast<std::uint32_t>(channel);
  f.fd = fd;
  f.fd_flags = fd ? 0x1 : 0x0;  // bit-rate switch, as an FD front-end sends
  put_u32(f, 0, first_index);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const auto u = static_cast<std::uint16_t>(samples[i]);
    f.data[4 + 2 * i] = static_cast<std::uint8_t>(u & 0xFF);
    f.data[5 + 2 * i] = static_cast<std::uint8_t>(u >> 8);
  }
  f.len = static_cast<std::uint8_t>(4 + 2 * samples.size());
  if (fd && !is_valid_fd_length(f.len)) throw std::invalid_argument("sample count gives an invalid CAN FD length");
  return f;
}

CanFrame make_tacho_frame(const ProtocolIds& ids, int shaft, double position) {
  CanFrame f;
  f.id = ids.tacho_base + static_cast<std::uint32_t>(shaft);
  f.len = 8;
  const double whole = std::floor(position);
  auto frac = static_cast<std::uint64_t>(std::llround((position - whole) * 4294967296.0));
  std::uint64_t w = static_cast<std::uint64_t>(whole);
  if (frac >= 4294967296ull) {
    frac -= 4294967296ull;
    ++w;
  }
  put_u32(f, 0, static_cast<std::uint32_t>(w));
  put_u32(f, 4, static_cast<std::uint32_t>(frac));
  return f;
}

CanFrame make_stream_header(const ProtocolIds& ids, std::uint32_t sample_rate_hz, std::uint8_t channel_count,
                            std::uint16_t stream_id, std::uint8_t version) {
  CanFrame f;
  f.id = ids.stream_header;
  f.len = 8;
  put_u32(f, 0, sample_rate_hz);
  f.data[4] = channel_count;
  f.data[5] = version;
  f.data[6] = static_cast<std::uint8_t>(stream_id & 0xFF);
  f.data[7] = static_cast<std::uint8_t>(stream_id >> 8);
  return f;
}

CanFrame make_operating_condition(const ProtocolIds& ids, float torque_nm, float speed_hz, std::uint32_t index) {
  CanFrame f;
  f.id = ids.operating_condition;
  f.len = 12;
  std::uint32_t bits;
  std::memcpy(&bits, &torque_nm, 4);
  put_u32(f, 0, bits);
  std::memcpy(&bits, &speed_hz, 4);
  put_u32(f, 4, bits);
  put_u32(f, 8, index);
  f.fd = true;  // 12 bytes only fit an FD frame; classic set-ups send the 8-byte form
  return f;
}

CanFrame make_life_counter(const ProtocolIds& ids, std::uint64_t input_revolutions) {
  CanFrame f;
  f.id = ids.life_counter;
  f.len = 8;
  for (int i = 0; i < 8; ++i) f.data[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(input_revolutions >> (8 * i));
  return f;
}

}  // namespace gearwatch::acquisition
