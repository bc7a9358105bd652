#pragma once
// A simple synthetic gearbox vibration source for captures and tests: gear-mesh harmonics
// amplitude-modulated by the input shaft, a mesh-modulated resonance excited by noise
// (a cyclostationary component), and broadband noise, with exact tacho edge positions.
// Deterministic for a given seed. It lives with the rig simulator, the other signal generator
// (rig_simulator.hpp), which supersedes its physics; this one makes captures of known content
// without the twin. No diagnosis code uses it.
#include <cstdint>
#include <vector>

namespace gearwatch::rig {

struct SyntheticSignalSettings {
  double sample_rate_hz = 100000.0;
  double speed_hz = 10.0;              ///< nominal input-shaft speed
  double torque_nm = 20.0;
  double speed_fluctuation = 0.0;      ///< relative amplitude of a 0.5 Hz speed oscillation
  int pinion_teeth = 19;
  int channels = 2;
  double mesh_amplitude_m_s2 = 5.0;    ///< first GMF harmonic at 20 N·m (scales with torque)
  double shaft_modulation = 0.1;       ///< depth of the once-per-rev modulation of the mesh
  double resonance_hz = 5000.0;        ///< carrier of the mesh-modulated noise
  double resonance_rms_m_s2 = 1.0;
  double noise_rms_m_s2 = 0.5;
  std::uint64_t seed = 1;
};

class SyntheticSignal {
 public:
  explicit SyntheticSignal(const SyntheticSignalSettings& settings);

  /// Input-shaft angle in revolutions at time t (seconds), from 0 at t = 0.
  double input_revolutions_at(double t) const noexcept;
  /// Fills `out[c][i]` with channel c's acceleration for samples [first, first + count).
  /// Successive calls must ask for consecutive blocks (the noise filters have state).
  void generate(std::uint64_t first, std::size_t count, std::vector<std::vector<double>>& out);
  /// Tacho edge positions (fractional sample index) of `edges_per_rev` per input revolution
  /// in [from_sample, to_sample).
  std::vector<double> tacho_edges(double from_sample, double to_sample, int edges_per_rev) const;

 private:
  SyntheticSignalSettings s_;
  std::uint64_t rng_state_;
  std::uint64_t next_index_ = 0;
  struct Resonator { double y1 = 0, y2 = 0; };
  std::vector<Resonator> resonators_;
  double a1_ = 0, a2_ = 0, gain_ = 0;
  double gaussian();
};

}  // namespace gearwatch::rig
