// RMS_SA against the combined mean wear depth, the twin (twin::simulated_rms_sa) beside the rig
// (rig::simulate_record through dsp::RecordAnalyzer) on the same profile, for three profile shapes:
// the rig's linear law (V), the twin's Archard blue loop, and the rig's closed-form Archard shape
// (rig::archard_profile_shape). Usage: bench_depth_scale [torque N·m = 7.5] [harmonics N = 2];
// 10 Hz, 0.8 s rig records, 6 twin revolutions. docs/model.md, "Where the depth scale went wrong".
#include <cstdio>
#include <cmath>
#include <vector>
#include "gearwatch/rig/rig_simulator.hpp"
#include "gearwatch/rig/wear_truth.hpp"
#include "gearwatch/rig/wear_truth_forms.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "gearwatch/wear/wear_loop.hpp"
#include "gearwatch/dsp/record_analyzer.hpp"

using namespace gearwatch;

static double rig_rms(const twin::GearboxParameters& p, const twin::ToothProfileDeviation& d, double T, const GearboxSpec& rs,
                      const dsp::SignalProcessingSettings& set) {
  rig::WearState w; w.profile = d;
  rig::RigRunSettings run; run.speed_hz = 10; run.torque_nm = T; run.duration_s = 0.8; run.channels = 1;
  run.sample_rate_hz = rs.sample_rate_hz;
  rig::RigRecord rr = rig::simulate_record(p, rig::EffectSet{}, w, rig::SlidingVibration{}, run);
  Record r; r.sample_rate_hz = rr.sample_rate_hz; r.channels.push_back(rr.acceleration[0]); r.channel_numbers.push_back(0);
  r.tacho_edges[0] = rr.tacho_edges;
  dsp::RecordAnalyzer a(rs, set);
  auto v = a.analyze(r, 0).value(dsp::Indicator::rms_sa);
  return v ? *v : NAN;
}
[[maybe_unused]] static double mean(const std::vector<double>& v) { double s=0; for (size_t i=0;i<v.size();++i) s += (i==0||i+1==v.size()?0.5:1)*v[i]; return s/(v.size()-1); }

int main(int argc, char** argv) {
  const double T = argc > 1 ? atof(argv[1]) : 7.5;
  const int N = argc > 2 ? atoi(argv[2]) : 2;
  twin::GearboxParameters p;
  GearboxSpec rs; rs.channels = {ChannelSpec{0, "y6", 0.0}};
  dsp::SignalProcessingSettings set; set.rms_sa_harmonics = N;
  twin::OperatingPoint op{10.0, T};
  std::vector<double> targets = {0, 0.5e-6, 1e-6, 2.5e-6, 5e-6, 10e-6, 20e-6, 40e-6};
  // V profile (rig linear law)
  rig::WearModelSettings ws; ws.law = rig::WearLaw::linear; ws.phases = {{0, 1e-12}}; ws.torque_nm = 20; ws.reference_torque_nm = 20;
  rig::BuiltinWearTruth vt(ws, p.gears);
  const double per_cycle = vt.at(1e6).combined_mean_wear_depth_m / 1e6;
  wear::WearLoopOptions o; o.k_wear_si = 1.65e-12; o.operating_point = op;
  wear::BlueLoop loop(p, o);
  std::printf("T=%.1f N=%d\n target_um | V: mean_um pin_share twin rig | A: mean_um pin_share twin rig\n", T, N);
  for (double t : targets) {
    twin::ToothProfileDeviation dv;
    double vmean = 0, vshare = 0;
    if (t > 0) { auto w = vt.at(t / per_cycle); dv = w.profile; vmean = w.combined_mean_wear_depth_m; vshare = w.mean_wear_depth_m / vmean; }
    while (t > 0 && wear::summarise(loop.state()).combined_mean_depth_m < t) loop.run_until(loop.state().cycles * 1.02 + 20);
    auto sm = wear::summarise(loop.state());
    twin::ToothProfileDeviation da = t > 0 ? wear::to_profile_deviation(loop.state()) : twin::ToothProfileDeviation{};
    const double dur = 6.05 / 10.0;
    double tv = twin::simulated_rms_sa(p, dv, op, dur, rs, set), ta = twin::simulated_rms_sa(p, da, op, dur, rs, set);
    double rv = rig_rms(p, dv, T, rs, set), ra = rig_rms(p, da, T, rs, set);
    auto sh = rig::archard_profile_shape(p.gears, 41);
    twin::ToothProfileDeviation dc; double cm = mean(sh.pinion) + mean(sh.gear);
    if (t > 0) { dc.pinion = sh.pinion; dc.gear = sh.gear; for (auto& x : dc.pinion) x *= t / cm; for (auto& x : dc.gear) x *= t / cm; }
    double tc = twin::simulated_rms_sa(p, dc, op, dur, rs, set), rc = rig_rms(p, dc, T, rs, set);
    std::printf("%6.2f | %6.2f %.3f %9.4g %9.4g | %6.2f %.3f %9.4g %9.4g | C: share %.3f %9.4g %9.4g\n", t*1e6, vmean*1e6, vshare, tv, rv,
                t>0?sm.combined_mean_depth_m*1e6:0, sm.pinion_share, ta, ra, mean(sh.pinion)/cm, tc, rc);
    if (t == 5e-6) { std::printf("  closed-form shape (u, pin, gear) um at 5um:\n"); for (int i=0;i<=10;++i) std::printf("   %.1f %7.2f %7.2f\n", i/10.0, dc.pinion[i*4]*1e6, dc.gear[i*4]*1e6); }
    if (t == 5e-6) {
      std::printf("  profiles at 5um (u, V pin, V gear, A pin, A gear) um:\n");
      for (int i = 0; i <= 10; ++i) { double u = i/10.0;
        auto s = [&](const std::vector<double>& v){ if (v.empty()) return 0.0; double x=u*(v.size()-1); size_t j=std::min((size_t)x, v.size()-2); double f=x-j; return (v[j]+f*(v[j+1]-v[j]))*1e6; };
        std::printf("   %.1f %7.2f %7.2f %7.2f %7.2f\n", u, s(dv.pinion), s(dv.gear), s(da.pinion), s(da.gear)); }
    }
    std::fflush(stdout);
  }
}
