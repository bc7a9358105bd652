// The profile-shape term of the depth and wear intervals (docs/model.md, "Profile-shape term")
// against known answers: the concentrated shape is one unworn pass of the Archard model, the mean
// depth matched to an RMS_SA that follows the deepest point or a power of the mean is the closed
// form, the scaled path's crossing and the depth interval are the hand computation, and a
// stand-in whose truth is either shape is covered at least at the nominal level.
#include "gearwatch/wear/profile_shape.hpp"

#include <cmath>
#include <random>

#include <catch2/catch.hpp>

#include "gearwatch/twin/gear_geometry.hpp"
#include "gearwatch/wear/forecast_intervals.hpp"

namespace test_profile_shape {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::wear;

namespace {

double shape_test_mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}

double shape_test_deepest(const WearState& w) {
  double m = 0;
  for (double d : w.pinion_depth_m) m = std::max(m, d);
  for (double d : w.gear_depth_m) m = std::max(m, d);
  return m;
}

// A unit shape by hand: pinion 0 … 2 (mean 1, deepest 2), gear unworn.
WearState shape_test_ramp() {
  WearState w;
  w.pinion_depth_m = {0.0, 0.5, 1.0, 1.5, 2.0};
  w.gear_depth_m.assign(5, 0.0);
  w.pinion_pitting.assign(5, 0.0);
  return w;
}

}  // namespace

TEST_CASE("profile shape: the concentrated shape is one unworn pass of Archard wear scaled to a combined mean of 1 m",
          "[model][intervals][profile_shape]") {
  const twin::GearGeometry g = twin::GearGeometry::from_spec(GearPairSpec{});
  // A load that rises along the line (any unworn load will do: the shape is the pass's).
  PassLoad load{{g.contact_start, g.contact_end}, {800.0, 1400.0}};
  const WearState shape = concentrated_wear_shape(g, load, 21);
  const PassWear pass = pass_wear(g, load, 3e-16, 21);   // any K: the shape is K's ratio-free part
  const double ratio = static_cast<double>(g.spec.pinion_teeth) / g.spec.gear_teeth;
  REQUIRE(shape.pinion_depth_m.size() == 21);
  const double mean = shape_test_mean(pass.pinion_m) + ratio * shape_test_mean(pass.gear_m);
  CHECK(shape_test_mean(shape.pinion_depth_m) + shape_test_mean(shape.gear_depth_m) == Approx(1.0).epsilon(1e-12));
  for (std::size_t j : {0u, 5u, 13u, 20u}) {
    CHECK(shape.pinion_depth_m[j] == Approx(pass.pinion_m[j] / mean).epsilon(1e-12));
    CHECK(shape.gear_depth_m[j] == Approx(ratio * pass.gear_m[j] / mean).epsilon(1e-12));
  }
  CHECK(peak_to_mean(shape) == Approx(shape_test_deepest(shape)).epsilon(1e-12));
  CHECK(peak_to_mean(shape_test_ramp()) == Approx(2.0).epsilon(1e-15));
  const WearState twice = scaled_shape(shape_test_ramp(), 3e-6);
  CHECK(twice.pinion_depth_m[4] == Approx(6e-6).epsilon(1e-15));
  PassLoad none{{g.contact_start, g.contact_end}, {0.0, 0.0}};
  CHECK_THROWS_AS(concentrated_wear_shape(g, none, 21), std::invalid_argument);
}

TEST_CASE("profile shape: matched to an RMS_SA of the deepest point the mean depth is the ratio of the peak ratios",
          "[model][intervals][profile_shape]") {
  // RMS_SA = b0 + b1 · deepest point. The model's profile: uniform (deepest = mean) at 10 um gives
  // RMS_SA = b0 + b1 · 10 um; the ramp (deepest = 2 × mean) gives that at a mean of 5 um: ρ = 1/2.
  const double b0 = 0.3, b1 = 1e5;
  int calls = 0;
  auto rms = [&](const WearState& w) {
    ++calls;
    return b0 + b1 * shape_test_deepest(w);
  };
  const double model_mean = 10e-6, target = b0 + b1 * model_mean;
  const ShapeDepthMatch m = match_shape_to_rms_sa(shape_test_ramp(), target, model_mean, rms, 1e-10, 12, 1e-3);
  REQUIRE(m.valid);
  CHECK(m.mean_depth_m == Approx(5e-6).epsilon(1e-8));
  CHECK(m.mean_depth_m / model_mean == Approx(0.5).epsilon(1e-8));
  CHECK(m.rms_sa == Approx(target).epsilon(1e-10));
  // d ln RMS_SA / d ln m = b1 · 2m / (b0 + 2 b1 m) at the root (the secant of two nearby points).
  CHECK(m.depth_elasticity == Approx(b1 * 1e-5 / target).epsilon(1e-3));
  CHECK(m.evaluations == calls);
  CHECK(m.evaluations <= 8);
}

TEST_CASE("profile shape: on a power law of the mean the match is exact and the elasticity the power",
          "[model][intervals][profile_shape]") {
  // RMS_SA = c · m^0.5: the target 2 at c = 1000 needs m = 4e-6 exactly; the secant on ln m is
  // exact on a line in ln m, so two steps after the proportional one suffice.
  auto rms = [](const WearState& w) { return 1000.0 * std::sqrt(shape_test_mean(w.pinion_depth_m) + shape_test_mean(w.gear_depth_m)); };
  const ShapeDepthMatch m = match_shape_to_rms_sa(shape_test_ramp(), 2.0, 1e-6, rms, 1e-9, 8, 1e-3);
  REQUIRE(m.valid);
  CHECK(m.mean_depth_m == Approx(4e-6).epsilon(1e-8));
  CHECK(m.depth_elasticity == Approx(0.5).epsilon(1e-9));
  CHECK(m.evaluations == 3);
  // An RMS_SA that falls with the depth: no match, and the reason.
  auto falling = [](const WearState& w) { return 1.0 / (1.0 + 1e5 * shape_test_mean(w.pinion_depth_m)); };
  const ShapeDepthMatch f = match_shape_to_rms_sa(shape_test_ramp(), 0.5, 1e-6, falling, 1e-6, 8, 1e-3);
  CHECK_FALSE(f.valid);
  CHECK(f.why.find("does not rise") != std::string::npos);
  // Below the target up to the largest mean allowed: no match.
  const ShapeDepthMatch capped = match_shape_to_rms_sa(shape_test_ramp(), 2.0, 1e-6, rms, 1e-9, 8, 2e-6);
  CHECK_FALSE(capped.valid);
  CHECK(capped.why.find("depth limit") != std::string::npos);
}

TEST_CASE("profile shape: the scaled path's crossing and the depth interval are the hand computation",
          "[model][intervals][profile_shape]") {
  // Mean 10 um now, 30 um a million cycles on: 2 × the mean reaches 50 um at a mean of 25 um,
  // 0.75 M cycles on; 6 × the mean is past it now; 1 × never within the path.
  const std::vector<std::array<double, 2>> path{{0.0, 10e-6}, {5e5, 20e-6}, {1e6, 30e-6}};
  REQUIRE(scaled_path_crossing(path, 2.0, 50e-6));
  CHECK(*scaled_path_crossing(path, 2.0, 50e-6) == Approx(7.5e5).epsilon(1e-12));
  CHECK(*scaled_path_crossing(path, 6.0, 50e-6) == 0.0);
  CHECK_FALSE(scaled_path_crossing(path, 1.0, 50e-6));
  CHECK_FALSE(scaled_path_crossing({}, 1.0, 50e-6));
  // The interval: each shape's own scatter interval exp(± z s), z = 1.6449 for 90 %, and their union.
  const double z = 1.6448536269514722, s = 0.05;
  const auto wide = shape_depth_interval(10e-6, 1.7, s, 0.9);
  CHECK(wide[0] == Approx(10e-6 * std::exp(-z * s)).epsilon(1e-12));
  CHECK(wide[1] == Approx(17e-6 * std::exp(z * s)).epsilon(1e-12));
  const auto below = shape_depth_interval(10e-6, 0.6, s, 0.9);
  CHECK(below[0] == Approx(6e-6 * std::exp(-z * s)).epsilon(1e-12));
  CHECK(below[1] == Approx(10e-6 * std::exp(z * s)).epsilon(1e-12));
  const auto none = shape_depth_interval(10e-6, 0.0, s, 0.9);
  CHECK(none[0] == Approx(10e-6 * std::exp(-z * s)).epsilon(1e-12));
  CHECK(none[1] == Approx(10e-6 * std::exp(z * s)).epsilon(1e-12));
}

TEST_CASE("profile shape: a truth of either shape is covered at least at the nominal level and one shape exactly at it",
          "[model][intervals][profile_shape]") {
  // Stand-in: RMS_SA = a m for the model's shape, a m / ρ0 for the concentrated one, measured with
  // a lognormal scatter s. The model reads m = RMS / a, the shape term ρ0; the interval is the
  // union of each shape's 90 % scatter interval. A truth of either shape lies in its own shape's
  // interval 90 % of the time and the union can only add: ≥ 90 %; with one shape (ρ0 = 1) = 90 %.
  std::mt19937_64 rng(3583);
  std::normal_distribution<double> n01;
  const double a = 2e5, s = 0.04;
  const int draws = 4000;
  const double sd3 = 3 * std::sqrt(0.9 * 0.1 / draws);
  for (const double rho0 : {1.0, 1.7}) {
    for (const bool truth_concentrated : {false, true}) {
      int covered = 0;
      for (int i = 0; i < draws; ++i) {
        const double truth = 20e-6;
        const double rms = (truth_concentrated ? a * truth / rho0 : a * truth) * std::exp(s * n01(rng));
        const auto in = shape_depth_interval(rms / a, rho0, s, kNominalCoverage);
        covered += in[0] <= truth && truth <= in[1] ? 1 : 0;
      }
      const double p = static_cast<double>(covered) / draws;
      INFO("rho0 " << rho0 << ", truth concentrated " << truth_concentrated << ": covered " << p);
      if (rho0 == 1.0) CHECK(std::abs(p - kNominalCoverage) <= sd3);
      else CHECK(p >= kNominalCoverage - sd3);
    }
  }
}

}  // namespace test_profile_shape
