// The twin's default record (SimulationOptions{}: the full integration until the start-up
// transient has died out, then one input period's template tiled) against the full integration
// (SimulationOptions::reference()) on the same parameters, over the whole record: the start-up
// transient the rig's records hold stays in the default's record.
// Bounds, fixed before the comparison (the periodic path's, tests/test_twin_periodic.cpp): the
// casing acceleration's RMS difference within 1e-3 of the reference's RMS and its largest
// difference within 1e-2 of it; its RMS, the 0-2 kHz band RMS, the first three mesh harmonics'
// amplitudes and the gear's first four orders (those above 1e-3 of the RMS) and RMS_SA within 1e-3
// relative; the tacho edges within 1e-2 samples. Up to the template's start the default's samples
// are the full integration's, bit for bit.
#include <algorithm>
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include "gearwatch/twin/simulation.hpp"
#include "twin_signal_measures.hpp"

namespace test_twin_default_tiling {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::twin;
using namespace gearwatch::testing;

namespace {

// The record both ways (simulate_casing_signal, the default settling), compared whole.
void compare_default_with_reference(double speed_hz, const ToothProfileDeviation& deviation, double duration_s, double fs,
                                    const ShaftRunOut& run_out) {
  const GearboxParameters p;
  const OperatingPoint op{speed_hz, 20.0};
  SimulationOptions tiled;
  tiled.sample_rate_hz = fs;
  tiled.shaft_run_out = run_out;
  SimulationOptions reference = SimulationOptions::reference();
  reference.sample_rate_hz = fs;
  reference.shaft_run_out = run_out;
  REQUIRE(tiled.periodic);
  REQUIRE(tiled.periodic_keeps_transient);
  const CasingSignal a = simulate_casing_signal(p, deviation, op, duration_s, tiled);
  const CasingSignal r = simulate_casing_signal(p, deviation, op, duration_s, reference);
  check_record_agrees(a, r, RecordAgreement{});
  CHECK(check_lines_agree(a, r, speed_hz * p.gears.pinion_teeth, 3, RecordAgreement{}.relative) >= 1);
  check_lines_agree(a, r, speed_hz * p.gears.pinion_teeth / p.gears.gear_teeth, 4, RecordAgreement{}.relative);
}

}  // namespace

TEST_CASE("The default twin record is tiled after its transient and is the full integration's before", "[twin][twin-periodic]") {
  SimulationOptions tiled;
  const SimulationResult a = simulate(GearboxParameters{}, root_to_tip_wear(), {10.0, 20.0}, 2.0, tiled);
  const SimulationResult r = simulate(GearboxParameters{}, root_to_tip_wear(), {10.0, 20.0}, 2.0, SimulationOptions::reference());
  REQUIRE(a.tiled);
  REQUIRE(a.template_start_s > 0.0);
  REQUIRE(a.template_start_s < 2.0);
  REQUIRE(a.casing_acceleration.size() == r.casing_acceleration.size());
  const auto before = static_cast<std::size_t>(std::floor(a.template_start_s * tiled.sample_rate_hz));
  std::size_t equal = 0;
  while (equal < before && a.casing_acceleration[equal] == r.casing_acceleration[equal] && a.mesh_force_n[equal] == r.mesh_force_n[equal])
    ++equal;
  CHECK(equal == before);
  CHECK(a.rhs_evaluations < r.rhs_evaluations);
}

TEST_CASE("The default twin record gives the full integration's at 10 and 20 Hz with wear", "[twin][twin-periodic]") {
  compare_default_with_reference(10.0, root_to_tip_wear(), 3.0, 100000.0, {});
  compare_default_with_reference(20.0, root_to_tip_wear(), 2.0, 100000.0, {});
}

TEST_CASE("The default twin record keeps the ringing a gear run-out starts at 8 Hz", "[twin][twin-periodic]") {
  ShaftRunOut run_out;
  run_out.gear_m = 30e-6;
  run_out.gear_phase_rad = 2.1;
  compare_default_with_reference(8.0, {}, 4.0, 50000.0, run_out);
}

}  // namespace test_twin_default_tiling
