#pragma once
// Writes a protocol-v1 capture (candump -L log): `gearwatch simulate`. The signal comes from a
// CaptureSignal: the synthetic rig (known content) or the digital twin's casing acceleration.
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "gearwatch/acquisition/protocol_decoder.hpp"
#include "gearwatch/rig/synthetic_signal.hpp"

namespace gearwatch::daemon {

/// What a capture is made of: accelerations on the sample clock and the input shaft's angle.
class CaptureSignal {
 public:
  virtual ~CaptureSignal() = default;
  virtual int channels() const = 0;
  virtual double sample_rate_hz() const = 0;
  /// Input-shaft revolutions at time t (s) since sample 0: the odometer and the tacho follow it.
  virtual double input_revolutions_at(double t) const = 0;
  /// Fills out[c][i] (m/s²) for samples [first, first + count); called for consecutive blocks.
  virtual void generate(std::uint64_t first, std::size_t count, std::vector<std::vector<double>>& out) = 0;
  /// Tacho edge positions (fractional samples) in [from, to), `edges_per_rev` per revolution.
  virtual std::vector<double> tacho_edges(double from, double to, int edges_per_rev) const = 0;
  /// The input speed (Hz) the operating-condition frame at sample `index` carries; NaN (the
  /// default) = CaptureSettings::signal.speed_hz throughout.
  virtual double speed_hz_at(std::uint64_t /*index*/) const { return std::numeric_limits<double>::quiet_NaN(); }
};

/// The synthetic signal of known content (rig/synthetic_signal.hpp).
std::unique_ptr<CaptureSignal> synthetic_capture_signal(const rig::SyntheticSignalSettings& settings);

/// A precomputed single-channel signal with its input-shaft edges (one per revolution), e.g. the
/// twin's casing acceleration y6. Edges per revolution other than 1 are refused.
std::unique_ptr<CaptureSignal> sampled_capture_signal(double sample_rate_hz, std::vector<float> acceleration,
                                                      std::vector<double> input_edges);

struct CaptureSettings {
  rig::SyntheticSignalSettings signal;           ///< speed, torque, rate, channels (and the synthetic content)
  double duration_s = 10.0;
  bool fd = true;
  std::uint16_t stream_id = 1;
  std::uint64_t start_revolutions = 0;   ///< life counter at the first sample
  double start_time_s = 1700000000.0;    ///< candump timestamp of sample 0
  std::uint32_t first_index = 0;         ///< sample index of sample 0 (u32, wraps)
  int edges_per_rev = 1;
  int tacho_shaft = 0;                   ///< the protocol shaft the input tacho's edges go out on
  bool tacho = true;                     ///< false: no tacho frames (an accelerometer alone)
  double scale_m_s2_per_lsb = 0.01;
  /// Per channel (m/s² per LSB), e.g. each configured channel's own; empty = scale_m_s2_per_lsb for all.
  std::vector<double> channel_scales_m_s2_per_lsb;
  std::string interface = "can0";
  acquisition::ProtocolIds ids;
};

struct CaptureSummary {
  std::uint64_t frames = 0, samples_per_channel = 0, tacho_edges = 0, clipped_samples = 0;
};

/// Throws std::runtime_error when the file cannot be written (the message names it).
CaptureSummary write_capture(const CaptureSettings& settings, CaptureSignal& signal, const std::string& path);
/// write_capture with the synthetic rig described by settings.signal.
CaptureSummary write_synthetic_capture(const CaptureSettings& settings, const std::string& path);

}  // namespace gearwatch::daemon
