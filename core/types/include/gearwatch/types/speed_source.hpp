#pragma once
// Where a record's shaft angle came from (the tacho, or the vibration signal by
// dsp/speed_estimation.hpp): a value stored with the record, vocabulary domain speed_source.
#include <array>
#include <cstdint>

namespace gearwatch::dsp {

/// Where a record's shaft angle came from. Stored with the record (vocabulary domain speed_source).
enum class SpeedSource : std::uint8_t {
  tacho,            ///< the configured tacho's edges
  signal_estimate,  ///< estimated from the vibration signal (no tacho, or the tacho disagreed)
};
inline constexpr std::array kAllSpeedSources{SpeedSource::tacho, SpeedSource::signal_estimate};
/// The stored tokens: tacho, signal_estimate.
const char* to_string(SpeedSource source) noexcept;

}  // namespace gearwatch::dsp
