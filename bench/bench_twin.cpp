// Simulated seconds of the 21-DOF twin per second of this thread's CPU on one core, at 20 N m and
// 10 Hz and 20 Hz input, output at 100 kHz (simulate(): every state signal kept), in the same run:
// the default (the full integration until the faster modes of the start-up transient have died
// out, then the template of one input period tiled with the slow modes' decay carried), the full integration (SimulationOptions::reference()), the
// opt-in periodic path (every sample read off the steady state's template,
// SimulationOptions::periodic_path()) and the fast integration (SimulationOptions::fast()).
// Targets: >= 10x real time at 10 Hz and >= 5x at 20 Hz, for the default. CPU time, not wall
// time, so that a shared machine's other work does not count; the wall figure is printed too.
#include <chrono>
#include <cstdio>
#include <ctime>

#include "gearwatch/twin/simulation.hpp"

namespace {

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Speed {
  double cpu = 0, wall = 0;
  std::size_t rhs = 0;
  bool tiled = false;
  double template_start_s = 0;
};

Speed run(double input_hz, const gearwatch::twin::SimulationOptions& base, double duration) {
  using namespace gearwatch::twin;
  SimulationOptions o = base;
  o.sample_rate_hz = 100000;
  o.settle_s = 0.0;
  const double c0 = thread_cpu_s();
  const auto t0 = std::chrono::steady_clock::now();
  const SimulationResult r = simulate(GearboxParameters{}, {}, {input_hz, 20.0}, duration, o);
  Speed s;
  s.wall = duration / std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  s.cpu = duration / (thread_cpu_s() - c0);
  s.rhs = r.rhs_evaluations;
  s.tiled = r.tiled;
  s.template_start_s = r.template_start_s;
  return s;
}

}  // namespace

int main() {
  using gearwatch::twin::SimulationOptions;
  const double duration = 2.0;
  struct Target {
    double hz, target;
    const char* name;
  };
  const Target targets[] = {{10.0, 10.0, "twin_real_time_10hz"}, {20.0, 5.0, "twin_real_time_20hz"}};
  for (const auto& t : targets) {
    const Speed periodic = run(t.hz, SimulationOptions::periodic_path(), duration);
    const Speed fast = run(t.hz, SimulationOptions::fast(), duration);
    const Speed full = run(t.hz, SimulationOptions::reference(), duration);
    const Speed deflt = run(t.hz, SimulationOptions{}, duration);
    std::printf("twin 21-DOF, %.0f Hz / 20 N m, %.0f s at 100 kHz: default (%s, template from %.3f s) %.2f x real time (CPU; "
                "wall %.2f x, %.0f RHS/s); full integration %.2f x (CPU; wall %.2f x, %.0f RHS/s); periodic path (opt-in, %s, "
                "template from %.3f s) %.2f x (CPU; wall %.2f x); fast %.2f x (CPU; wall %.2f x); default / full %.2f\n",
                t.hz, duration, deflt.tiled ? "tiled after the transient" : "not tiled", deflt.template_start_s, deflt.cpu, deflt.wall,
                static_cast<double>(deflt.rhs) / duration, full.cpu, full.wall, static_cast<double>(full.rhs) / duration,
                periodic.tiled ? "tiled" : "not tiled", periodic.template_start_s, periodic.cpu, periodic.wall, fast.cpu, fast.wall,
                deflt.cpu / full.cpu);
    std::printf("BENCH name=%s figure=%.2f unit=x_real_time target=%.0f cmp=ge met=%d\n", t.name, deflt.cpu, t.target,
                deflt.cpu >= t.target ? 1 : 0);
    std::printf("BENCH name=%s_full_integration figure=%.2f unit=x_real_time target=%.0f cmp=ge met=%d\n", t.name, full.cpu,
                t.target, full.cpu >= t.target ? 1 : 0);
    std::printf("BENCH name=%s_periodic_opt_in figure=%.2f unit=x_real_time target=%.0f cmp=ge met=%d\n", t.name, periodic.cpu,
                t.target, periodic.cpu >= t.target ? 1 : 0);
  }
  return 0;
}
