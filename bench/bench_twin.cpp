// Simulated seconds of the 21-DOF twin per wall second on one core at the thesis's operating point
// (10 Hz input, 20 N m), output at 100 kHz. Target: >= 1 (real time).
#include <chrono>
#include <cstdio>

#include "gearwatch/twin/simulation.hpp"

int main() {
  using namespace gearwatch::twin;
  const GearboxParameters p;
  double real_time = 0.0;  // of the longest run
  for (double duration : {1.0, 2.0}) {
    SimulationOptions o;
    o.sample_rate_hz = 100000;
    o.settle_s = 0.0;
    const auto t0 = std::chrono::steady_clock::now();
    const SimulationResult r = simulate(p, {}, {10.0, 20.0}, duration, o);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("twin 21-DOF, 10 Hz / 20 N m, %.0f s simulated at 100 kHz output: wall %.3f s -> %.2f x real time "
                "(%zu samples, %.0f RHS evaluations per simulated second)\n",
                duration, wall, duration / wall, r.time_s.size(), static_cast<double>(r.rhs_evaluations) / duration);
    real_time = duration / wall;
  }
  // One machine-readable line for tools/bench.sh.
  std::printf("BENCH name=twin_real_time figure=%.2f unit=x_real_time target=1 cmp=ge met=%d\n", real_time,
              real_time >= 1.0 ? 1 : 0);
  return 0;
}
