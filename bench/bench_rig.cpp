// Seconds to generate one rig-simulator record: 10 s at 100 kHz, 2 channels, every truth effect on
// (parameters at their documented defaults) plus pitting and abrasion sliding vibration, on one
// core. Target: <= 5 s (>= 2x real time).
#include <chrono>
#include <cstdio>

#include "gearwatch/rig/rig_simulator.hpp"

int main() {
  using namespace gearwatch;
  const rig::EffectSet effects = rig::EffectSet::parse("all");
  rig::SlidingVibration sliding;
  sliding.pitting_rms_m_s2 = 2.0;
  sliding.abrasion_rms_m_s2 = 2.0;
  rig::RigRunSettings s;
  s.duration_s = 10.0;
  s.sample_rate_hz = 100000;
  s.channels = 2;
  for (int run = 0; run < 2; ++run) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto r = rig::simulate_record(twin::GearboxParameters{}, effects, {}, sliding, s);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("rig record 10 s, 100 kHz, 2 channels, all effects: wall %.3f s -> %.2f x real time "
                "(%zu integration steps, %zu RHS evaluations, %zu tacho edges)\n",
                wall, s.duration_s / wall, r.integration_steps, r.rhs_evaluations, r.tacho_edges.size());
  }
  return 0;
}
