// The twin's fast integration (SimulationOptions::fast()) against the reference one
// (SimulationOptions::reference(), the full integration): the same record within stated bounds.
// Bounds, fixed before the comparison: the casing acceleration sample by sample within 1e-3 of the
// reference's RMS; its RMS, the 0-2 kHz band RMS, the first three mesh harmonics' amplitudes and
// RMS_SA within 1e-3 relative; the tacho edges within 1e-6 samples.
#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <vector>

#include <catch2/catch.hpp>

#include "gearwatch/dsp/record_analyzer.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "twin_signal_measures.hpp"

namespace test_twin_fast_path {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::twin;
using namespace gearwatch::testing;

namespace {

constexpr double kRelative = 1e-3;


void compare_with_reference(double speed_hz, const ToothProfileDeviation& deviation) {
  const GearboxParameters p;
  const OperatingPoint op{speed_hz, 20.0};
  const double fs = 100000.0;
  SimulationOptions fast = SimulationOptions::fast();
  fast.sample_rate_hz = fs;
  SimulationOptions reference = SimulationOptions::reference();
  reference.sample_rate_hz = fs;
  REQUIRE(fast.relative_tolerance > reference.relative_tolerance);  // the two paths differ
  const CasingSignal a = simulate_casing_signal(p, deviation, op, 1.0, fast);
  const CasingSignal r = simulate_casing_signal(p, deviation, op, 1.0, reference);
  REQUIRE(a.acceleration.size() == r.acceleration.size());
  const double r_rms = signal_rms(r.acceleration);
  double diff = 0;
  for (std::size_t i = 0; i < r.acceleration.size(); ++i) {
    const double d = static_cast<double>(a.acceleration[i]) - r.acceleration[i];
    diff += d * d;
  }
  CHECK(std::sqrt(diff / static_cast<double>(r.acceleration.size())) <= kRelative * r_rms);
  CHECK(signal_rms(a.acceleration) == Approx(r_rms).epsilon(kRelative));
  const std::vector<double> a64(a.acceleration.begin(), a.acceleration.end());
  const std::vector<double> r64(r.acceleration.begin(), r.acceleration.end());
  CHECK(lowpass_rms(a64, fs, 2000.0) == Approx(lowpass_rms(r64, fs, 2000.0)).epsilon(kRelative));
  const double mesh_hz = speed_hz * p.gears.pinion_teeth;
  for (int h = 1; h <= 3; ++h) {
    const double ref_amplitude = mesh_harmonic_amplitude(r.acceleration, fs, mesh_hz, h);
    REQUIRE(ref_amplitude > 1e-3 * r_rms);  // a line that is there, not the noise floor
    CHECK(mesh_harmonic_amplitude(a.acceleration, fs, mesh_hz, h) == Approx(ref_amplitude).epsilon(kRelative));
  }
  REQUIRE(a.tacho_edges.size() == r.tacho_edges.size());
  for (std::size_t i = 0; i < r.tacho_edges.size(); ++i) CHECK(a.tacho_edges[i] == Approx(r.tacho_edges[i]).margin(1e-6));
  CHECK(simulated_signal_rms_sa(a) == Approx(simulated_signal_rms_sa(r)).epsilon(kRelative));
}

}  // namespace

TEST_CASE("The fast twin gives the reference integration's record at 10 Hz", "[twin][twin-fast]") {
  compare_with_reference(10.0, {});
}

TEST_CASE("The fast twin gives the reference integration's record at 20 Hz", "[twin][twin-fast]") {
  compare_with_reference(20.0, {});
}

TEST_CASE("The fast twin gives the reference integration's record of a worn pinion", "[twin][twin-fast]") {
  ToothProfileDeviation wear;  // 10 µm at the root falling to 0 at the tip, as the RMS_SA test wears it
  for (int i = 0; i <= 20; ++i) wear.pinion.push_back(10e-6 * std::pow(1.0 - i / 20.0, 2));
  compare_with_reference(10.0, wear);
}

}  // namespace test_twin_fast_path
