// The Lundberg–Palmgren pitting model (thesis Eqs. 7.3–7.12).
#include "gearwatch/wear/pitting_model.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <catch2/catch.hpp>

#include "gearwatch/twin/errors.hpp"
#include "gearwatch/wear/wear_loop.hpp"

namespace test_pitting_model {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::wear;

TEST_CASE("Eqs. 7.4-7.6 from one Hertz contact, by hand", "[wear][pitting]") {
  // p0 = 700 MPa, b = 50 µm, R = 4 mm: τ0 = 210 MPa, z0 = 39.3 µm, V = 2·50e-6·39.3e-6·2π·4e-3 = 9.8772e-11 m³.
  const LundbergPalmgrenTerms t = lundberg_palmgren_terms(700e6, 50e-6, 4e-3);
  CHECK(t.max_shear_stress_pa == Approx(210e6).epsilon(1e-12));
  CHECK(t.shear_depth_m == Approx(39.3e-6).epsilon(1e-12));
  CHECK(t.stressed_volume_m3 == Approx(9.8772e-11).epsilon(1e-4));
  // With c = h = 1 the rate is plainly K τ0 V / z0 (the logarithmic evaluation changes nothing).
  PittingMaterial linear{1.0, 1.0, 1.0};
  CHECK(survival_rate(2e-3, t, linear) == Approx(2e-3 * 210e6 * 9.8772e-11 / 39.3e-6).epsilon(1e-4));
  CHECK(survival_rate(0.0, t, PittingMaterial{}) == 0.0);
  CHECK_THROWS_AS(survival_rate(-1.0, t, PittingMaterial{}), twin::TwinParameterError);
  CHECK_THROWS_AS((PittingMaterial{0.0, 1.0, 1.0}.validate()), twin::TwinParameterError);
}

TEST_CASE("Eq. 7.11 increments summed over uneven steps equal Eq. 7.8 when B is held fixed", "[wear][pitting]") {
  const PittingMaterial material;  // c = 31/3, m = 10/9, h = 7/3
  for (double rate : {1e-9, 3e-8, 1e-6}) {
    double density = 0, cycles = 0;
    double step = 10;
    while (cycles < 2e6) {
      const double dn = std::min(step, 2e6 - cycles);
      density = pitting_density_step(density, rate, cycles, dn, material);
      cycles += dn;
      step *= 1.7;  // uneven steps: the telescoping must not depend on them
    }
    const double direct = 1.0 - std::exp(-rate * std::pow(2e6, 10.0 / 9.0));
    CHECK(density == Approx(direct).epsilon(1e-12).margin(1e-15));
    CHECK(pitting_density_direct(rate, 2e6, material) == Approx(direct).epsilon(1e-14));
  }
}

namespace {
// K_pitting giving A = target at the most loaded pinion point of an unworn pair at 20 N·m.
double k_for_rate(const PittingMaterial& material, double target) {
  const twin::GearGeometry g = twin::GearGeometry::from_spec(GearPairSpec{});
  const double force = 20.0 / g.base_radius_pinion;
  // The lowest point of single contact: s0 + L − p_b... i.e. s = contact_end − p_b.
  const double s = g.contact_end - g.base_pitch;
  const double rho1 = s, rho2 = g.line_of_action_length - s, r = rho1 * rho2 / (rho1 + rho2);
  const LineContact c = line_contact(force / g.spec.face_width_m, r, g.effective_modulus);
  return target / survival_rate(1.0, lundberg_palmgren_terms(c.max_pressure_pa, c.half_width_m, r), material);
}
}  // namespace

TEST_CASE("Pitting in the blue loop: monotone, bounded by 1, starting at the dedendum (Fig. 7.11)", "[wear][pitting]") {
  WearLoopOptions o;
  o.k_wear_si = 0.0;  // pitting alone: the load stays the unworn quasi-static one
  o.operating_point = {20.0, 20.0};
  // D = 15 % at the most loaded point after 2e6 cycles at a fixed width: the thesis's regime (17.4 %
  // at 2.00 M cycles was its scrapping point, §7.4.1).
  const double fixed_width_density = 0.15;
  o.k_pitting = k_for_rate(o.material, -std::log(1.0 - fixed_width_density) / std::pow(2e6, 10.0 / 9.0));
  o.max_step_cycles = 5e4;
  BlueLoop loop(twin::GearboxParameters{}, o);
  const twin::GearGeometry& g = loop.geometry();
  std::vector<double> previous = loop.state().pinion_pitting;
  while (loop.state().cycles < 2e6) {
    loop.step(2e6);
    const auto& d = loop.state().pinion_pitting;
    for (std::size_t j = 0; j < d.size(); ++j) {
      REQUIRE(d[j] >= previous[j]);
      REQUIRE(d[j] <= 1.0);
    }
    previous = d;
  }
  const WearSummary s = summarise(loop.state());
  // Highest Hertz stress on the pinion: its lowest point of single contact (LPSTC), below the pitch point.
  const double lpstc = g.profile_fraction_pinion(g.contact_end - g.base_pitch);
  const double pitch = g.profile_fraction_pinion(g.pitch_radius_pinion * std::sin(g.pressure_angle_rad));
  CHECK(lpstc < pitch);
  CHECK(s.max_pitting_fraction == Approx(lpstc).margin(0.011));  // one profile step (1/100)
  CHECK(s.max_pitting_fraction < pitch);
  // Contact-width feedback (Eq. 7.12) raises the pressure and so A; while A N^m < 1 a larger A gives
  // a larger Eq. 7.11 increment, so D exceeds the fixed-width Eq. 7.8 value (here A N^m ≈ 0.16).
  CHECK(s.max_pitting_density > fixed_width_density);
  CHECK(s.max_pitting_density <= 1.0);
  // The addendum (tip side, single → double contact, lower stress) lags the dedendum.
  const auto& d = loop.state().pinion_pitting;
  const std::size_t i_lpstc = static_cast<std::size_t>(std::ceil(lpstc * 100));  // first grid point in single contact
  CHECK(d[90] < d[i_lpstc]);
  CHECK(d[0] < d[i_lpstc]);
}

TEST_CASE("a pitting step from a density set off Eq. 7.8's curve decays the unpitted area by exp(-A dN^m)",
          "[wear][pitting]") {
  const PittingMaterial material;  // m = 10/9
  const double m = 10.0 / 9.0;
  // A density set from an inspection (0.011 at 2.2 M cycles) and a rate far beyond the one that
  // gave it: the unpitted area 0.989 decays by exp(-A ((2.7e6)^m - (2.2e6)^m)) in closed form.
  const double d0 = 0.011, n0 = 2.2e6, n1 = 2.7e6;
  for (double rate : {1e-9, 1e-7, 1e-5}) {
    double density = d0, cycles = n0, step = 1e3;
    while (cycles < n1) {
      const double dn = std::min(step, n1 - cycles);
      density = pitting_density_step(density, rate, cycles, dn, material);
      cycles += dn;
      step *= 1.5;
    }
    const double expected = 1.0 - (1.0 - d0) * std::exp(-rate * (std::pow(n1, m) - std::pow(n0, m)));
    CHECK(density == Approx(expected).epsilon(1e-12));
  }
  // Monotone in the rate, reaching any density below 1: the calibration's bisection has a root.
  double previous = d0;
  for (double rate : {1e-12, 1e-10, 1e-8, 1e-6, 1e-4}) {
    const double d = pitting_density_step(d0, rate, n0, n1 - n0, material);
    CHECK(d > previous);
    previous = d;
  }
  CHECK(previous == Approx(1.0).margin(1e-12));
  // The closed-form calibration K of forecast_intervals (T = 1): the step through it returns A1.
  const double a1 = 0.0639;
  const double k = std::log((1.0 - d0) / (1.0 - a1)) / (std::pow(n1, m) - std::pow(n0, m));
  CHECK(pitting_density_step(d0, k, n0, n1 - n0, material) == Approx(a1).epsilon(1e-12));
}

TEST_CASE("Eq. 7.12 narrows the tooth's face width by its pitting density (the mean over the profile), the same at every point",
          "[wear][pitting]") {
  // Hertz on a line load F / B: p_max and b grow as B^(-1/2), so τ0^c V / z0^h grows as
  // B^(−(c + 2 − h)/2) = B^-5 with the classical exponents: B = B0 (1 − D) multiplies the rate A by
  // (1 − D)^-5 (the force is the unworn pair's: no depth, and pitting does not enter the GTE).
  WearLoopOptions o;
  o.k_wear_si = 1e-16;
  o.k_pitting = 1e-94;
  o.operating_point = {20.0, 20.0};
  BlueLoop unpitted(twin::GearboxParameters{}, o);
  const std::vector<double> rate0 = unpitted.pitting_rates(1.0);
  const std::size_t n = rate0.size();
  WearState uniform = unpitted.state(), graded = unpitted.state();
  for (std::size_t j = 0; j < n; ++j) {
    uniform.pinion_pitting[j] = 0.2;
    graded.pinion_pitting[j] = 0.4 * static_cast<double>(j) / static_cast<double>(n - 1);   // root 0 → tip 0.4, mean 0.2
  }
  CHECK(pitted_width_factor(uniform) == Approx(0.8).epsilon(1e-15));
  CHECK(pitted_width_factor(graded) == Approx(0.8).epsilon(1e-14));
  BlueLoop a(twin::GearboxParameters{}, o), b(twin::GearboxParameters{}, o);
  a.restore(uniform, 100.0);
  b.restore(graded, 100.0);
  const std::vector<double> ra = a.pitting_rates(1.0), rb = b.pitting_rates(1.0);
  const double expected = std::pow(0.8, -5.0);   // 3.0518
  int loaded = 0;
  for (std::size_t j = 0; j < n; ++j) {
    if (!(rate0[j] > 0)) continue;
    ++loaded;
    // Uniform: the point's and the tooth's density agree, so either reading gives (1 − 0.2)^-5.
    CHECK(ra[j] / rate0[j] == Approx(expected).epsilon(1e-12));
    // Graded: the tooth's mean 0.2 again, whatever the point's own density. A per-point width
    // would have given (1 − D_j)^-5 instead, ((1 − 0.2) / (1 − D_j))^5 times this: 4.21 at the tip
    // (D = 0.4), 0.328 at the root (D = 0).
    CHECK(rb[j] / rate0[j] == Approx(expected).epsilon(1e-12));
  }
  CHECK(loaded > static_cast<int>(n) / 2);
  // The Archard side takes the same factor: one step from either state wears the flanks alike.
  a.step(1e3);
  b.step(1e3);
  REQUIRE(a.state().cycles == b.state().cycles);
  for (std::size_t j = 0; j < n; ++j) {
    CHECK(a.state().pinion_depth_m[j] == Approx(b.state().pinion_depth_m[j]).epsilon(1e-12));
    CHECK(a.state().gear_depth_m[j] == Approx(b.state().gear_depth_m[j]).epsilon(1e-12));
  }
  CHECK(*std::max_element(a.state().pinion_depth_m.begin(), a.state().pinion_depth_m.end()) > 0);
}

}  // namespace test_pitting_model
