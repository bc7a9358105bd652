// The twin's periodic path (opt-in, SimulationOptions::periodic_path()) against the full
// reference integration (SimulationOptions::reference()) on the same parameters, after the
// reference's start-up transient: the periodic path reads every sample off the steady state, the
// reference carries the start's free oscillation of the lightly damped lowest torsional mode, so the
// two are compared from the periodic run's template start on (where its check found the whole
// state repeating within periodic_tolerance; the reference has the same remnant there).
// Bounds, fixed before the comparison: the casing acceleration's RMS difference within 1e-3 of the
// reference's RMS (fast()'s bound and the check's) and its largest difference within 1e-2 of it; its
// RMS, the 0-2 kHz band RMS, the first three mesh harmonics' amplitudes (those above 1e-3 of the RMS)
// and RMS_SA within 1e-3 relative; the tacho edges within 1e-2 samples.
#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <vector>

#include <catch2/catch.hpp>

#include "gearwatch/dsp/record_analyzer.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "twin_signal_measures.hpp"

namespace test_twin_periodic {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::twin;
using namespace gearwatch::testing;

namespace {

constexpr double kRelative = 1e-3;


// Pits on two pinion teeth: 5 µm deep over the middle fifth of the profile (pitting at the pitch
// line), every other tooth ideal; so the inputs repeat with a pinion turn, not a mesh period.
ToothProfileDeviation periodic_pitting(int pinion_teeth) {
  ToothProfileDeviation pits;
  pits.pinion_per_tooth.assign(static_cast<std::size_t>(pinion_teeth), std::vector<double>(21, 0.0));
  for (int tooth : {3, 11})
    for (int i = 8; i <= 12; ++i) pits.pinion_per_tooth[static_cast<std::size_t>(tooth)][static_cast<std::size_t>(i)] = 5e-6;
  return pits;
}

// The part of a record from sample `first` on, its tacho edges shifted with it.
CasingSignal periodic_tail(const CasingSignal& s, std::size_t first) {
  CasingSignal t;
  t.sample_rate_hz = s.sample_rate_hz;
  t.acceleration.assign(s.acceleration.begin() + static_cast<std::ptrdiff_t>(first), s.acceleration.end());
  for (double e : s.tacho_edges)
    if (e >= static_cast<double>(first)) t.tacho_edges.push_back(e - static_cast<double>(first));
  return t;
}

// The record both ways (simulate_casing_signal: the front-end's record with the default settling),
// compared from `from_s` on within the bounds above.
void compare_periodic_with_reference(double speed_hz, const ToothProfileDeviation& deviation, double duration_s, double from_s) {
  const GearboxParameters p;
  const OperatingPoint op{speed_hz, 20.0};
  const double fs = 100000.0;
  SimulationOptions periodic = SimulationOptions::periodic_path();
  periodic.sample_rate_hz = fs;
  SimulationOptions reference = SimulationOptions::reference();
  reference.sample_rate_hz = fs;
  REQUIRE(periodic.periodic);
  REQUIRE_FALSE(reference.periodic);
  const CasingSignal full_a = simulate_casing_signal(p, deviation, op, duration_s, periodic);
  const CasingSignal full_r = simulate_casing_signal(p, deviation, op, duration_s, reference);
  REQUIRE(full_a.acceleration.size() == full_r.acceleration.size());
  const auto first = static_cast<std::size_t>(std::ceil(from_s * fs));
  REQUIRE(first + static_cast<std::size_t>(0.25 * fs) <= full_r.acceleration.size());  // a quarter second at least
  const CasingSignal a = periodic_tail(full_a, first), r = periodic_tail(full_r, first);
  check_record_agrees(a, r, RecordAgreement{kRelative, 1e-2, 1e-2});
  CHECK(check_lines_agree(a, r, speed_hz * p.gears.pinion_teeth, 3, kRelative) >= 1);
}

// The same parameters through simulate() at the record's rate: the periodic path is taken for them.
SimulationResult periodic_run(double speed_hz, const ToothProfileDeviation& deviation, double duration_s,
                              const GearboxParameters& p = {}) {
  SimulationOptions o = SimulationOptions::periodic_path();
  o.sample_rate_hz = 100000.0;
  return simulate(p, deviation, {speed_hz, 20.0}, duration_s, o);
}

}  // namespace

TEST_CASE("The period every twin input repeats with: a mesh period - a shaft turn - the hunting period", "[twin][twin-periodic]") {
  const GearboxParameters p;  // 19 / 52 teeth
  REQUIRE(p.gears.pinion_teeth == 19);
  REQUIRE(p.gears.gear_teeth == 52);
  const OperatingPoint op{10.0, 20.0};
  SimulationOptions o;
  CHECK(periodic_inputs_period_s(p, root_to_tip_wear(), op, o) == Approx(1.0 / 190.0).epsilon(1e-15));
  CHECK(periodic_inputs_period_s(p, periodic_pitting(19), op, o) == Approx(0.1).epsilon(1e-15));
  o.face_misalignment_rad = 1e-4;  // a flank separation: the same on every pair
  CHECK(periodic_inputs_period_s(p, {}, op, o) == Approx(1.0 / 190.0).epsilon(1e-15));
  o.shaft_run_out.gear_m = 1e-6;  // the gear's turn: 52 mesh periods
  CHECK(periodic_inputs_period_s(p, {}, op, o) == Approx(52.0 / 190.0).epsilon(1e-15));
  // Pinion teeth and the gear's run-out: lcm(19, 52) = 988 mesh periods, 52 pinion turns (5.2 s).
  CHECK(periodic_inputs_period_s(p, periodic_pitting(19), op, o) == Approx(5.2).epsilon(1e-15));
}

TEST_CASE("The periodic twin gives the full integration's record at 10 Hz with wear", "[twin][twin-periodic]") {
  // 3 s: after a worn start the 22 Hz torsional mode rings for over a second (docs/twin.md), and
  // the check waits until the whole state has settled (PeriodicCheck's energy norm).
  const SimulationResult run = periodic_run(10.0, root_to_tip_wear(), 3.0);
  REQUIRE(run.tiled);
  compare_periodic_with_reference(10.0, root_to_tip_wear(), 3.0, run.template_start_s);
}

TEST_CASE("The periodic twin gives the full integration's record at 20 Hz with wear", "[twin][twin-periodic]") {
  const SimulationResult run = periodic_run(20.0, root_to_tip_wear(), 2.5);
  REQUIRE(run.tiled);
  compare_periodic_with_reference(20.0, root_to_tip_wear(), 2.5, run.template_start_s);
}

TEST_CASE("The periodic twin gives the full integration's record of pitted pinion teeth at 10 and 20 Hz", "[twin][twin-periodic]") {
  ToothProfileDeviation worn_and_pitted = periodic_pitting(19);
  worn_and_pitted.gear = root_to_tip_wear().pinion;  // and a worn gear on every tooth
  for (double speed_hz : {10.0, 20.0}) {
    INFO("input speed " << speed_hz << " Hz");
    // 3.5 s: the part after the template's start holds enough turns at 10 Hz for RMS_SA.
    const SimulationResult run = periodic_run(speed_hz, worn_and_pitted, 3.5);
    REQUIRE(run.tiled);
    INFO("template from " << run.template_start_s << " s");
    compare_periodic_with_reference(speed_hz, worn_and_pitted, 3.5, run.template_start_s);
  }
}

TEST_CASE("A twin run whose inputs do not repeat within the record is the full integration sample for sample", "[twin][twin-periodic]") {
  // Pitted pinion teeth and a gear run-out repeat only every hunting period, 5.2 s at 10 Hz: the
  // check and a template do not fit in the search (periodic_search_s).
  SimulationOptions periodic = SimulationOptions::periodic_path();
  periodic.shaft_run_out.gear_m = 2e-6;
  SimulationOptions reference = SimulationOptions::reference();
  reference.shaft_run_out = periodic.shaft_run_out;
  const SimulationResult a = simulate(GearboxParameters{}, periodic_pitting(19), {10.0, 20.0}, 1.0, periodic);
  const SimulationResult r = simulate(GearboxParameters{}, periodic_pitting(19), {10.0, 20.0}, 1.0, reference);
  CHECK_FALSE(a.tiled);
  REQUIRE(a.casing_acceleration.size() == r.casing_acceleration.size());
  CHECK(a.casing_acceleration == r.casing_acceleration);
  CHECK(a.transmission_error_m == r.transmission_error_m);
  CHECK(a.tacho_edges == r.tacho_edges);
  CHECK(a.rhs_evaluations == r.rhs_evaluations);
}

TEST_CASE("A twin run whose start-up transient does not die out is the full integration sample for sample", "[twin][twin-periodic]") {
  // Structural damping a hundredth of the calibrated one: the pedestal modes ring for seconds, so no
  // period boundaries agree within the record and, with the search kept inside the record, the
  // check never lets the template start.
  GearboxParameters p;
  p.structural_damping_ratio = 5e-4;
  SimulationOptions reference = SimulationOptions::reference();
  SimulationOptions periodic = SimulationOptions::periodic_path();
  periodic.periodic_search_s = 0;
  const SimulationResult a = simulate(p, {}, {10.0, 20.0}, 0.5, periodic);
  const SimulationResult r = simulate(p, {}, {10.0, 20.0}, 0.5, reference);
  CHECK_FALSE(a.tiled);
  REQUIRE(a.casing_acceleration.size() == r.casing_acceleration.size());
  CHECK(a.casing_acceleration == r.casing_acceleration);
  CHECK(a.tacho_edges == r.tacho_edges);
  CHECK(a.rhs_evaluations == r.rhs_evaluations);
}

TEST_CASE("The periodic twin's record does not depend on its length: a short record is the long one's start", "[twin][twin-periodic]") {
  // Both read off the same steady-state template from their first sample: the short one's search
  // goes past its end to where the long one's check agrees, with the same steps, so the samples
  // they share are the same numbers.
  const SimulationResult long_run = periodic_run(10.0, root_to_tip_wear(), 2.0);
  const SimulationResult short_run = periodic_run(10.0, root_to_tip_wear(), 0.3);
  REQUIRE(long_run.tiled);
  REQUIRE(short_run.tiled);
  CHECK(short_run.template_start_s == long_run.template_start_s);
  REQUIRE(short_run.casing_acceleration.size() == 30000);
  bool same = true;
  for (std::size_t i = 0; i < short_run.casing_acceleration.size(); ++i)
    same = same && short_run.casing_acceleration[i] == long_run.casing_acceleration[i] &&
           short_run.transmission_error_m[i] == long_run.transmission_error_m[i];
  CHECK(same);
  REQUIRE(short_run.tacho_edges.size() >= 2);  // a turn every 0.1 s
  for (std::size_t i = 0; i < short_run.tacho_edges.size(); ++i) CHECK(short_run.tacho_edges[i] == long_run.tacho_edges[i]);
}

// Amplitudes of the gear shaft's orders 1..orders in y6 over the whole record: a Hann-windowed DFT,
// so the mesh's lines (over a hundred orders away, far above these) leak under them by 1/Δ³.
std::vector<double> periodic_gear_order_amplitudes(const std::vector<double>& x, double fs, double gear_hz, int orders) {
  std::vector<double> amplitudes;
  const auto n = x.size();
  double mean = 0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(n);
  for (int m = 1; m <= orders; ++m) {
    std::complex<double> sum = 0;
    double weight = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double w = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(n));
      sum += w * (x[i] - mean) * std::polar(1.0, -2.0 * std::numbers::pi * m * gear_hz * static_cast<double>(i) / fs);
      weight += w;
    }
    amplitudes.push_back(2.0 * std::abs(sum) / weight);
  }
  return amplitudes;
}

TEST_CASE("A periodic twin run is never read off a template taken while the slowest torsional mode still rings", "[twin][twin-periodic]") {
  // A gear run-out (its inputs repeat with a gear turn) at 8 Hz: the run-out's onset at the start
  // rings the lowest torsional mode, which the casing acceleration hardly shows (the mesh's lines
  // dominate its RMS) but which dominates the gear's own orders. The steady state, known
  // independently: the full integration after 4 s of settling. A tiled record must hold the steady
  // state's gear orders 1-8 within 1 dB each; an untiled one must be the full integration's record.
  const double fs = 20000, seconds = 2.5, speed = 8;
  SimulationOptions periodic = SimulationOptions::periodic_path();
  periodic.sample_rate_hz = fs;
  periodic.shaft_run_out.gear_m = 30e-6;
  periodic.shaft_run_out.gear_phase_rad = 2.1;
  const GearboxParameters p;
  const double gear_hz = speed * p.gears.pinion_teeth / p.gears.gear_teeth;
  const SimulationResult a = simulate(p, {}, {speed, 20.0}, seconds, periodic);
  SimulationOptions reference = SimulationOptions::reference();
  reference.sample_rate_hz = fs;
  reference.shaft_run_out = periodic.shaft_run_out;
  if (a.tiled) {
    INFO("tiled from " << a.template_start_s << " s");
    reference.settle_s = 4.0;
    const SimulationResult steady = simulate(p, {}, {speed, 20.0}, seconds, reference);
    const auto got = periodic_gear_order_amplitudes(a.casing_acceleration, fs, gear_hz, 8);
    const auto want = periodic_gear_order_amplitudes(steady.casing_acceleration, fs, gear_hz, 8);
    for (std::size_t m = 0; m < got.size(); ++m) {
      INFO("gear order " << m + 1 << ": " << got[m] << " against the steady state's " << want[m] << " m/s^2");
      CHECK(std::abs(20.0 * std::log10(got[m] / want[m])) <= 1.0);
    }
  } else {
    const SimulationResult r = simulate(p, {}, {speed, 20.0}, seconds, reference);
    REQUIRE(a.casing_acceleration.size() == r.casing_acceleration.size());
    double diff = 0, rms = 0;
    for (std::size_t i = 0; i < r.casing_acceleration.size(); ++i) {
      diff += std::pow(a.casing_acceleration[i] - r.casing_acceleration[i], 2);
      rms += r.casing_acceleration[i] * r.casing_acceleration[i];
    }
    // The same steps up to the record's last one, which the search does not shorten to end on the
    // last sample: the dense output agrees there within dopri5's error.
    CHECK(std::sqrt(diff / rms) <= kRelative);
    const auto got = periodic_gear_order_amplitudes(a.casing_acceleration, fs, gear_hz, 8);
    const auto want = periodic_gear_order_amplitudes(r.casing_acceleration, fs, gear_hz, 8);
    for (std::size_t m = 0; m < got.size(); ++m) CHECK(got[m] == Approx(want[m]).epsilon(kRelative));
  }
}

}  // namespace test_twin_periodic
