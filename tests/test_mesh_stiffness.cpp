// Gear geometry, potential-energy mesh stiffness and mesh damping of the twin (thesis §5.2.1).
#include "gearwatch/twin/mesh_stiffness.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <catch2/catch.hpp>

#include "gearwatch/twin/errors.hpp"

namespace test_mesh_stiffness {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::twin;

namespace {
GearGeometry seed_pair() { return GearGeometry::from_spec(GearPairSpec{}); }

// Simpson's rule on [a, b] with n (even) intervals.
template <class F>
double simpson(F f, double a, double b, int n) {
  const double h = (b - a) / n;
  double s = f(a) + f(b);
  for (int i = 1; i < n; ++i) s += f(a + i * h) * (i % 2 ? 4 : 2);
  return s * h / 3;
}
}  // namespace

TEST_CASE("Seed gear pair geometry matches the closed forms", "[twin]") {
  const GearGeometry g = seed_pair();
  const double alpha = 20.0 * std::numbers::pi / 180.0;
  // r_b = m z cos α / 2; the parameter sheet quotes 17.85 / 48.86 mm and ε = 1.653.
  CHECK(g.base_radius_pinion == Approx(0.5 * 2e-3 * 19 * std::cos(alpha)).epsilon(1e-12));
  CHECK(g.base_radius_gear == Approx(0.5 * 2e-3 * 52 * std::cos(alpha)).epsilon(1e-12));
  const double ra1 = 0.021, ra2 = 0.054, rb1 = g.base_radius_pinion, rb2 = g.base_radius_gear;
  const double eps = (std::sqrt(ra1 * ra1 - rb1 * rb1) + std::sqrt(ra2 * ra2 - rb2 * rb2) - 0.071 * std::sin(alpha)) /
                     (std::numbers::pi * 2e-3 * std::cos(alpha));
  CHECK(g.contact_ratio == Approx(eps).epsilon(1e-12));
  CHECK(g.contact_ratio == Approx(1.653).margin(5e-4));
}

TEST_CASE("Tooth compliance equals the potential-energy integrals in their published angle form", "[twin]") {
  // Independent formulation (Tian's integrals in the tooth angle α from −α1 to α2), integrated by
  // Simpson with 4000 intervals; the implementation uses 20-point Gauss–Legendre on the roll angle.
  // Agreement to 1e-6 relative shows both the derivation and the quadrature.
  const GearGeometry g = seed_pair();
  const double E = 205e9, nu = 0.29, L = 0.02;
  for (bool pinion : {true, false}) {
    const int z = pinion ? 19 : 52;
    const double alpha2 = std::numbers::pi / (2.0 * z) + std::tan(g.pressure_angle_rad) - g.pressure_angle_rad;
    for (double s : {g.contact_start, 0.5 * (g.contact_start + g.contact_end), g.contact_end}) {
      const double roll = pinion ? g.roll_angle_pinion(s) : g.roll_angle_gear(s);
      const double alpha1 = roll - alpha2;
      const double ca = std::cos(alpha1), sa = std::sin(alpha1);
      auto denom = [&](double a) { return std::sin(a) + (alpha2 - a) * std::cos(a); };
      const double kb = simpson([&](double a) {
        const double m = 1 + ca * ((alpha2 - a) * std::sin(a) - std::cos(a));
        return 3 * m * m * (alpha2 - a) * std::cos(a) / (2 * E * L * std::pow(denom(a), 3));
      }, -alpha1, alpha2, 4000);
      const double ks = simpson([&](double a) {
        return 1.2 * (1 + nu) * (alpha2 - a) * std::cos(a) * ca * ca / (E * L * denom(a));
      }, -alpha1, alpha2, 4000);
      const double ka = simpson([&](double a) {
        return (alpha2 - a) * std::cos(a) * sa * sa / (2 * E * L * denom(a));
      }, -alpha1, alpha2, 4000);
      const ToothCompliance c = tooth_compliance(g, pinion, roll);
      CHECK(c.bending == Approx(kb).epsilon(1e-6));
      CHECK(c.shear == Approx(ks).epsilon(1e-6));
      if (std::abs(alpha1) > 1e-3) CHECK(c.axial == Approx(ka).epsilon(1e-6));
    }
  }
}

TEST_CASE("Single-pair stiffness: magnitude and shape", "[twin]") {
  const GearGeometry g = seed_pair();
  CHECK(hertz_stiffness(g) == Approx(3.52e9).epsilon(2e-3));  // Eq. 5.11; the sheet quotes 3.52e9
  double peak = 0, peak_s = 0;
  for (int i = 0; i <= 400; ++i) {
    const double s = g.contact_start + g.active_length() * i / 400.0;
    const double k = single_pair_stiffness(g, s);
    CHECK(k > 1e8);   // order 1e8–1e9 N/m for a 20 mm wide, module 2 pair
    CHECK(k < 1e9);
    if (k > peak) {
      peak = k;
      peak_s = s;
    }
  }
  // The maximum lies near the pitch point (s = r_b1 tan α): within a quarter of a base pitch, and
  // the curve falls off towards both ends of the active line.
  const double pitch_point = g.base_radius_pinion * std::tan(g.pressure_angle_rad);
  CHECK(std::abs(peak_s - pitch_point) < 0.25 * g.base_pitch);
  CHECK(single_pair_stiffness(g, g.contact_start) < 0.8 * peak);
  CHECK(single_pair_stiffness(g, g.contact_end) < 0.8 * peak);
}

TEST_CASE("Mesh stiffness is periodic and its double-contact share is the contact ratio minus one", "[twin]") {
  const GearGeometry g = seed_pair();
  const GearMeshStiffness mesh(g);
  constexpr int kSamples = 200000;
  int doubles = 0;
  double positions[3];
  for (int i = 0; i < kSamples; ++i) {
    const double phase = (i + 0.5) / kSamples;
    const int n = mesh.pairs_in_contact(phase, positions);
    CHECK((n == 1 || n == 2));
    if (n == 2) ++doubles;
    if (i % 997 == 0) {
      CHECK(mesh.mesh_stiffness(phase + 1.0) == Approx(mesh.mesh_stiffness(phase)).epsilon(1e-12));
      CHECK(mesh.mesh_stiffness(phase + 7.0) == Approx(mesh.mesh_stiffness(phase)).epsilon(1e-12));
    }
  }
  // Counting error of a uniform grid is at most 2 samples.
  CHECK(static_cast<double>(doubles) / kSamples == Approx(g.contact_ratio - 1.0).margin(2.0 / kSamples));
  CHECK(mesh.double_contact_share() == Approx(g.contact_ratio - 1.0).epsilon(1e-12));
  // The peak is normalised to ISO 6336 c'·b; the mean then lies in the sheet's 2.8e8–4.0e8 range.
  double peak = 0;
  for (int i = 0; i <= 1000; ++i) peak = std::max(peak, mesh.pair_stiffness(g.contact_start + g.active_length() * i / 1000.0));
  // (sampled between table nodes: linear interpolation of the 1025-point table costs < 1e-5)
  CHECK(peak == Approx(kIsoSinglePairStiffness).epsilon(1e-5));
  CHECK(mesh.mean_stiffness() > 2.8e8);
  CHECK(mesh.mean_stiffness() < 4.0e8);
}

TEST_CASE("Gradual engagement ramps the pair stiffness to zero at the ends", "[twin]") {
  const GearGeometry g = seed_pair();
  MeshStiffnessOptions o;
  o.engagement_ramp_fraction = 0.2;
  const GearMeshStiffness ramped(g, o);
  const GearMeshStiffness step(g);
  CHECK(ramped.pair_stiffness(g.contact_start) == Approx(0.0).margin(1.0));
  CHECK(ramped.pair_stiffness(g.contact_end) == Approx(0.0).margin(1.0));
  // Half-way up the cosine ramp the factor is exactly 0.5 (up to table interpolation, 1e-3).
  const double s = g.contact_start + 0.1 * g.base_pitch;
  CHECK(ramped.pair_stiffness(s) == Approx(0.5 * step.pair_stiffness(s)).epsilon(1e-3));
}

TEST_CASE("Mesh damping follows Eqs. 5.13-5.16", "[twin]") {
  // The sheet: m_e = 0.32 kg, k = 3.4e8, ζ = 0.07 → c_ave ≈ 1460 N s/m, μ ≈ 4.3e-6 s.
  const double mu = mesh_damping_time_constant(0.07, 3.4e8, 0.4, 1.6);
  CHECK(mu * 3.4e8 == Approx(2 * 0.07 * std::sqrt(3.4e8 * 0.32)).epsilon(1e-12));
  CHECK(mu * 3.4e8 == Approx(1460).epsilon(2e-3));
  CHECK_THROWS_AS(mesh_damping_time_constant(0.07, 3.4e8, 0.0, 1.6), TwinParameterError);
}

TEST_CASE("Non-physical gear data are rejected", "[twin]") {
  GearPairSpec spec;
  spec.addendum_coefficient = 0.3;  // short teeth: contact ratio below 1
  CHECK_THROWS_AS(GearGeometry::from_spec(spec), TwinParameterError);
  spec = GearPairSpec{};
  spec.module_m = 0;
  CHECK_THROWS_AS(GearGeometry::from_spec(spec), TwinParameterError);
  spec = GearPairSpec{};
  spec.poisson_ratio = 0.6;
  CHECK_THROWS_AS(GearGeometry::from_spec(spec), TwinParameterError);
  MeshStiffnessOptions o;
  o.scale = -1;
  CHECK_THROWS_AS(GearMeshStiffness(seed_pair(), o), TwinParameterError);
}

}  // namespace test_mesh_stiffness
