#pragma once
// What the acquisition thread hands to the processing thread through the SPSC ring: decoded,
// validated protocol content on the sample clock. Fixed size (no heap), trivially copyable.
#include <array>
#include <cstdint>
#include <type_traits>

namespace gearwatch::acquisition {

inline constexpr int kMaxSamplesPerEvent = 30;   // one CAN FD 64-byte frame: (64-4)/2

enum class EventKind : std::uint8_t {
  samples,          ///< `count` samples of channel `channel` starting at `index`
  tacho_edge,       ///< edge of shaft `channel` at `index` + `fraction`
  stream_start,     ///< a new stream begins (first header, or stream id / sample rate changed)
  condition,        ///< operating condition from `index` on
  life_counter,     ///< odometer reading `revolutions`, placed at `index` (latest sample index seen)
  dropout,          ///< channel `channel` misses `missing` samples from `index` on
  life_counter_reset///< the odometer went backwards: `revolutions` new, `previous_revolutions` old
};

struct AcquisitionEvent {
  EventKind kind = EventKind::samples;
  std::uint8_t channel = 0;          ///< vibration channel or tacho shaft
  std::uint8_t count = 0;            ///< samples in this event
  std::uint8_t channel_count = 0;    ///< stream_start: channels announced by the header
  std::uint16_t stream_id = 0;       ///< stream_start
  std::uint32_t sample_rate_hz = 0;  ///< stream_start
  std::uint64_t index = 0;           ///< unwrapped sample index (64-bit: no wrap downstream)
  union {
    std::array<std::int16_t, kMaxSamplesPerEvent> samples;
    double fraction;                 ///< tacho_edge: fractional part in [0, 1)
    struct { float torque_nm; float speed_hz; } condition;
    std::uint64_t missing;           ///< dropout
    struct { std::uint64_t revolutions; std::uint64_t previous_revolutions; } life;
  };
  AcquisitionEvent() : samples{} {}
};

static_assert(std::is_trivially_copyable_v<AcquisitionEvent>);

}  // namespace gearwatch::acquisition
