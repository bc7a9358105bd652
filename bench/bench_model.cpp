// The model thread's cost (docs/model.md): one blue-loop step, one simulated RMS_SA, one K_wear
// update, and the whole per-record work (blue loop to the record, purple loop, forecast) on one
// core, for the thesis's dry regime (10 Hz, 5 N·m, deep wear) and a lubricated one (20 Hz, 20 N·m).
// Target: at most 10 s per record (records come every few minutes).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "gearwatch/dsp/record_analyzer.hpp"
#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/wear/updating.hpp"

using namespace gearwatch;
using namespace gearwatch::wear;
using Clock = std::chrono::steady_clock;

namespace {
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct Regime {
  const char* name;
  double speed, torque, k_truth, k_start, record_cycles;
  int harmonics;
};
}  // namespace

int main() {
  const twin::GearboxParameters params;
  const Regime regimes[] = {{"dry (10 Hz, 5 N m, K 1.65e-12 m2/N)", 10, 5, 1.65e-12, 1.0e-12, 1000, 6},
                            {"lubricated (20 Hz, 20 N m, K 3.55e-16 m2/N)", 20, 20, 3.55e-16, 2.0e-16, 50000, 2}};
  for (const Regime& g : regimes) {
    std::printf("== %s\n", g.name);
    dsp::SignalProcessingSettings dsp_settings;
    dsp_settings.rms_sa_harmonics = g.harmonics;
    const RmsSaSimulator sim = twin_rms_sa_simulator(params, GearboxSpec{}, dsp_settings, 6.0);

    // One blue-loop step (quasi-static force, 101 profile points), averaged over a run.
    WearLoopOptions o;
    o.k_wear_si = g.k_truth;
    o.operating_point = {g.speed, g.torque};
    BlueLoop loop(params, o);
    const auto t0 = Clock::now();
    loop.run_until(10 * g.record_cycles);
    const double step_s = seconds_since(t0) / std::max(1, loop.steps());
    std::printf("blue-loop step: %.2f ms (%d steps, %d rejected, to %.0f cycles)\n", 1e3 * step_s, loop.steps(), loop.rejections(),
                loop.state().cycles);

    const auto t1 = Clock::now();
    const double rms = sim(loop.state(), {g.speed, g.torque});
    std::printf("simulated RMS_SA(N=%d) of 6 revolutions: %.2f s (value %.4g)\n", g.harmonics, seconds_since(t1), rms);

    // The model from a wrong K: records every record_cycles with the truth's RMS_SA; the first
    // record is the K_wear update (the thesis's first calibration).
    ModelSettings s;
    s.loop.k_wear_si = g.k_start;
    TwinModel model(params, s, sim);
    BlueLoop truth(params, o);
    std::vector<double> per_record;
    double update_s = 0;
    int update_iterations = 0;
    for (int i = 1; i <= 6; ++i) {
      const double cycles = g.record_cycles * i;
      truth.run_until(cycles);
      ModelObservation obs;
      obs.cycles = cycles;
      obs.speed_hz = g.speed;
      obs.torque_nm = g.torque;
      obs.rms_sa = sim(truth.state(), {g.speed, g.torque});
      const auto t = Clock::now();
      const ModelRunReport r = model.observe(obs, {});
      const double dt = seconds_since(t);
      per_record.push_back(dt);
      for (const auto& u : r.updates)
        if (u.kind == UpdateKind::k_wear) update_s = dt, update_iterations = u.iterations;
    }
    const auto t2 = Clock::now();
    const Forecast f = model.forecast();
    const double forecast_s = seconds_since(t2);
    std::printf("record with a K_wear update (%d iterations, incl. blue loop and forecast): %.2f s\n", update_iterations, update_s);
    std::printf("forecast (3 runs: nominal and the K spread; horizon %.3g cycles): %.2f s, wear limit in %.4g cycles\n",
                s.forecast_horizon_cycles, forecast_s, f.wear.cycles_left.value_or(-1));
    std::sort(per_record.begin(), per_record.end());
    std::printf("model thread per record: median %.2f s, max %.2f s -> target <= 10 s: %s\n", per_record[per_record.size() / 2],
                per_record.back(), per_record.back() <= 10.0 ? "MET" : "MISSED");
  }
}
