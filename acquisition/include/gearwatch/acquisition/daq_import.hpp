#pragma once
// From a DAQ recording's samples to what a capture carries: physical units, tacho edges on the
// sample clock, and the checks that refuse a recording which does not fit (docs/acquisition.md,
// "Recordings from DAQ files"). Pure functions on samples; no files.
#include <cstddef>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gearwatch/acquisition/daq_file.hpp"

namespace gearwatch::acquisition {

/// The unit of a recording's samples once `scale` is applied.
enum class SampleUnit { m_s2, g, volt };
std::string_view to_string(SampleUnit unit);
/// "m/s2" (or "m/s^2", "m/s²"), "g", "V"; nullopt for anything else.
std::optional<SampleUnit> parse_sample_unit(std::string_view text);

/// Standard gravity (ISO 80000-3): the g an accelerometer's data sheet means.
inline constexpr double kStandardGravity = 9.80665;

struct SampleScaling {
  double scale = 1.0;                 ///< multiplies each file value first
  SampleUnit unit = SampleUnit::m_s2;
  double sensitivity_mv_per_g = std::numeric_limits<double>::quiet_NaN();  ///< volt only
};

/// m/s² per file unit. DaqFileError when the unit is volt without a positive sensitivity, or the
/// scale is not finite and non-zero.
double m_s2_per_file_unit(const SampleScaling& s);

/// Rising edges of a tacho signal at fractional sample positions: a pulse counts when the signal
/// goes from below the low threshold to above the high one (hysteresis: noise on a flat top or
/// bottom never counts twice); its position is where the signal crosses the mid level, linearly
/// interpolated between the two samples around it. The levels sit at 50 % ± 10 % of the signal's
/// range (min to max), so any pulse amplitude and offset work.
std::vector<double> detect_tacho_edges(std::span<const double> tacho);

/// Revolutions per second from edges (fractional sample positions), `edges_per_rev` per
/// revolution, over the edges in [from, to): the mean over them, NaN with fewer than two.
double speed_from_edges(std::span<const double> edges, int edges_per_rev, double sample_rate_hz, double from, double to);

/// A channel's samples fit a capture: every one finite, none at the WAV's integer rails (a clipped
/// recording), and each within the protocol's i16 once divided by `lsb_m_s2` (after scaling by
/// `m_s2_per_unit`). DaqFileError with one line naming the channel, the sample and the value.
void check_channel_fits(const DaqRecording& recording, std::size_t channel, double m_s2_per_unit, double lsb_m_s2);

/// The recording's rate and length fit a capture: a whole number of Hz in [10 kHz, 200 kHz] (the
/// rates gearwatch analyses) and at least `min_seconds` of samples. `given_rate_hz` (NaN = none)
/// is the command line's; it must agree with the file's when both exist. Returns the rate.
double check_rate_and_length(const DaqRecording& recording, double given_rate_hz, double min_seconds);

}  // namespace gearwatch::acquisition
