#pragma once
// Writes a protocol-v1 capture (candump -L log) of the synthetic rig: `gearwatch simulate`.
#include <cstdint>
#include <string>

#include "gearwatch/acquisition/protocol_decoder.hpp"
#include "gearwatch/synthetic_rig.hpp"

namespace gearwatch::daemon {

struct CaptureSettings {
  SyntheticRigSettings signal;
  double duration_s = 10.0;
  bool fd = true;
  std::uint16_t stream_id = 1;
  std::uint64_t start_revolutions = 0;   ///< life counter at the first sample
  double start_time_s = 1700000000.0;    ///< candump timestamp of sample 0
  std::uint32_t first_index = 0;         ///< sample index of sample 0 (u32, wraps)
  int edges_per_rev = 1;
  double scale_m_s2_per_lsb = 0.01;
  std::string interface = "can0";
  acquisition::ProtocolIds ids;
};

struct CaptureSummary {
  std::uint64_t frames = 0, samples_per_channel = 0, tacho_edges = 0, clipped_samples = 0;
};

/// Throws std::runtime_error when the file cannot be written (the message names it).
CaptureSummary write_synthetic_capture(const CaptureSettings& settings, const std::string& path);

}  // namespace gearwatch::daemon
