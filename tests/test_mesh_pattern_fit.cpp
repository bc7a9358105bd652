// twin::fit_mesh_pattern against patterns of known scale: a single-resonance pattern in closed form
// (the resonance at f0·√scale, as a mesh mode moves with the stiffness), a pattern that does not
// depend on the scale at all, and too few harmonics above the floor.
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>
#include <vector>

#include <catch2/catch.hpp>

#include "gearwatch/twin/mesh_pattern_fit.hpp"

namespace test_mesh_pattern_fit {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::twin;

namespace {

// |1 / (1 − r² + 2iζr)|, r = n·f_mesh / (f0·√scale): harmonic n of a mesh excitation flat across
// harmonics, through one mode whose frequency follows the square root of the stiffness.
std::vector<double> resonance_pattern(double scale, int harmonics = 10) {
  const double f_mesh = 760.0, f0 = 4000.0, zeta = 0.08;
  std::vector<double> out;
  for (int n = 1; n <= harmonics; ++n) {
    const double r = n * f_mesh / (f0 * std::sqrt(scale));
    out.push_back(1.0 / std::abs(std::complex<double>(1.0 - r * r, 2.0 * zeta * r)));
  }
  return out;
}

}  // namespace

TEST_CASE("Mesh pattern fit: a resonance pattern of known scale, under any path gain, gives its scale back", "[commission][mesh_pattern]") {
  for (double truth : {0.62, 0.9, 1.0, 1.1, 1.37}) {
    std::vector<double> measured = resonance_pattern(truth);
    for (double& a : measured) a *= 37.5;  // the sensor's and the casing's gain: invisible to the pattern
    const MeshPatternFit f = fit_mesh_pattern(measured, 0.0, [](double s) { return resonance_pattern(s); });
    INFO("truth " << truth << " fitted " << f.scale);
    CHECK(f.scale == Approx(truth).margin(1e-3));  // the golden section's tolerance
    CHECK(f.evidence == MeshScaleEvidence::identified);
    CHECK(f.gain_ln == Approx(std::log(37.5)).margin(1e-3));
    CHECK(f.harmonics.size() == 10);
    CHECK(f.misfit_ln_rms < 1e-3);
    CHECK(f.interval_low <= f.scale);
    CHECK(f.interval_high >= f.scale);
    CHECK(f.interval_high - f.interval_low < 0.01);  // an exact pattern leaves no room
    CHECK(f.simulations == static_cast<int>(f.scan.size()));
  }
}

TEST_CASE("Mesh pattern fit: under ln noise of known size the stated interval holds the truth and widens with the noise",
          "[commission][mesh_pattern]") {
  // A fixed ±σ alternation (a deterministic draw): the fitted pattern cannot absorb it.
  const double truth = 1.1;
  double previous_width = 0;
  for (double sigma : {0.01, 0.03, 0.1}) {
    std::vector<double> measured = resonance_pattern(truth);
    for (std::size_t i = 0; i < measured.size(); ++i) measured[i] *= std::exp((i % 2 == 0 ? 1.0 : -1.0) * sigma * (1.0 + 0.3 * (i % 3)));
    const MeshPatternFit f = fit_mesh_pattern(measured, 0.0, [](double s) { return resonance_pattern(s); });
    INFO("sigma " << sigma << " fitted " << f.scale << " in " << f.interval_low << "-" << f.interval_high << " misfit " << f.misfit_ln_rms);
    CHECK(f.interval_low <= truth);
    CHECK(f.interval_high >= truth);
    CHECK(f.misfit_ln_rms > 0.5 * sigma);
    CHECK(f.interval_high - f.interval_low > previous_width);
    previous_width = f.interval_high - f.interval_low;
  }
}

TEST_CASE("Mesh pattern fit: a pattern the scale does not move is stated as not identified, never as a fitted value",
          "[commission][mesh_pattern]") {
  const std::vector<double> flat = resonance_pattern(1.0);
  std::vector<double> measured = flat;
  measured[3] *= 1.05;  // a misfit no scale removes
  const MeshPatternFit f = fit_mesh_pattern(measured, 0.0, [&](double) { return flat; });
  CHECK(f.evidence != MeshScaleEvidence::identified);
  CHECK(f.interval_low == Approx(0.5));
  CHECK(f.interval_high == Approx(1.5));
  CHECK(f.scale == 1.0);  // the prior: the baseline does not reject it
}

TEST_CASE("Mesh pattern fit: a pattern no scale makes keeps the prior when the interval holds it, the nearest scale when not",
          "[commission][mesh_pattern]") {
  // The truth at 1.45 with one harmonic off by a factor e: the misfit is large, the interval wide.
  std::vector<double> measured = resonance_pattern(1.45);
  measured[2] *= std::exp(1.0);
  const MeshPatternFit wide = fit_mesh_pattern(measured, 0.0, [](double s) { return resonance_pattern(s); });
  INFO("nearest " << wide.nearest_scale << " in " << wide.interval_low << "-" << wide.interval_high);
  if (wide.evidence == MeshScaleEvidence::identified) {
    CHECK(wide.scale == wide.nearest_scale);
  } else if (wide.interval_low <= 1.0 && wide.interval_high >= 1.0) {
    CHECK(wide.scale == 1.0);
  } else {
    CHECK(wide.scale == wide.nearest_scale);
  }
  // Exact, at the range's end: nearest at the bound and 1.0 rejected, so the bound is kept.
  const MeshPatternFit end = fit_mesh_pattern(resonance_pattern(1.5), 0.0, [](double s) { return resonance_pattern(s); });
  CHECK(end.evidence == MeshScaleEvidence::minimum_at_bound);
  CHECK(end.nearest_scale == Approx(1.5).margin(1e-3));
  CHECK(end.scale == end.nearest_scale);
  CHECK(end.interval_low > 1.0);
}

TEST_CASE("Mesh pattern fit: harmonics under ten times the floor stay out, and fewer than three leave the scale at 1 unfitted",
          "[commission][mesh_pattern]") {
  std::vector<double> measured = resonance_pattern(1.2);
  const double weakest = *std::min_element(measured.begin(), measured.end());
  const double floor = 1.001 * weakest / 10.0;  // the weakest harmonic just stays out
  std::size_t above = 0;
  for (double a : measured) above += a >= 10.0 * floor ? 1 : 0;
  const MeshPatternFit some = fit_mesh_pattern(measured, floor, [](double s) { return resonance_pattern(s); });
  CHECK(some.harmonics.size() == above);
  CHECK(above == measured.size() - 1);
  for (int h : some.harmonics) CHECK(measured[static_cast<std::size_t>(h - 1)] >= 10.0 * floor);
  CHECK(some.scale == Approx(1.2).margin(1e-3));

  std::vector<double> weak(10, std::numeric_limits<double>::quiet_NaN());
  weak[0] = 1.0;
  weak[1] = 0.5;
  weak[2] = 0.001;  // under 10 × 0.01
  int runs = 0;
  const MeshPatternFit none = fit_mesh_pattern(weak, 0.01, [&](double s) {
    ++runs;
    return resonance_pattern(s);
  });
  CHECK(none.evidence == MeshScaleEvidence::too_few_harmonics);
  CHECK(none.scale == 1.0);
  CHECK(runs == 0);
  CHECK(none.harmonics == std::vector<int>{1, 2});
}

TEST_CASE("Mesh pattern fit: a twin without a harmonic in use, or bad settings, is an error", "[commission][mesh_pattern]") {
  const std::vector<double> measured = resonance_pattern(1.0);
  CHECK_THROWS_AS(fit_mesh_pattern(measured, 0.0, [](double s) { return resonance_pattern(s, 5); }), std::invalid_argument);
  MeshPatternSettings bad;
  bad.high = 0.4;
  CHECK_THROWS_AS(fit_mesh_pattern(measured, 0.0, [](double s) { return resonance_pattern(s); }, bad), std::invalid_argument);
  CHECK(std::string(to_string(MeshScaleEvidence::interval_reaches_bound)) == "interval_reaches_bound");
}

}  // namespace test_mesh_pattern_fit
