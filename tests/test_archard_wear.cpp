// The improved Archard model (thesis Eqs. 6.3–6.4) and the Hertz line contact it uses.
#include "gearwatch/wear/archard_wear.hpp"

#include <cmath>
#include <numbers>

#include <catch2/catch.hpp>

#include "gearwatch/twin/errors.hpp"

namespace test_archard_wear {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::wear;

namespace {
// Independent reference for the strip integral: a plain midpoint sum with 200 000 centres over
// x ± 1.5 a (no edge finding, no substitution); error ~ (Δq/a)^1.5 ≈ 1e-7.
double brute_force_depth(const TravellingContact& c, double x, double k) {
  const double a = 1.5 * c.half_width_m(x);
  constexpr int kSteps = 200000;
  const double dq = 2.0 * a / kSteps;
  double sum = 0;
  for (int i = 0; i < kSteps; ++i) {
    const double q = x - a + (i + 0.5) * dq;
    if (q < c.first || q > c.last) continue;
    const double r = (x - q) / c.half_width_m(q);
    if (std::abs(r) < 1.0)
      sum += c.max_pressure_pa(q) * std::sqrt(1.0 - r * r) * c.sliding_speed_m_s(q) / c.rolling_speed_m_s(q) * dq;
  }
  return k * sum;
}
}  // namespace

TEST_CASE("Hertz line contact of two steel cylinders equals the hand computation", "[wear][archard]") {
  // R1 = 10 mm, R2 = 30 mm, E = 210 GPa, ν = 0.3, w = 100 N/mm. By hand:
  // 1/E* = 2(1 − 0.09)/210e9 → E* = 115.3846 GPa; R = 10·30/40 = 7.5 mm;
  // a = sqrt(4 · 1e5 · 7.5e-3 / (π · 115.3846e9)) = 90.9728 µm; p0 = sqrt(1e5 · E* / (π · 7.5e-3)) = 699.791 MPa.
  const double e_star = 210e9 / (2.0 * (1.0 - 0.09));
  const LineContact c = line_contact(1e5, 7.5e-3, e_star);
  CHECK(c.half_width_m == Approx(90.9728e-6).epsilon(1e-6));
  CHECK(c.max_pressure_pa == Approx(699.791e6).epsilon(1e-6));
  // The semi-ellipse carries the load: (π/2) a p0 = w.
  CHECK(0.5 * std::numbers::pi * c.half_width_m * c.max_pressure_pa == Approx(1e5).epsilon(1e-12));
  CHECK(line_contact(0.0, 7.5e-3, e_star).half_width_m == 0.0);
  CHECK_THROWS_AS(line_contact(1e5, -1.0, e_star), twin::TwinParameterError);
}

TEST_CASE("Hertz contact at a gear-pair position agrees with the twin's own Hertz routine", "[wear][archard]") {
  const twin::GearGeometry g = twin::GearGeometry::from_spec(GearPairSpec{});
  for (double s : {0.002, 0.0065, 0.010}) {
    const double rho1 = s, rho2 = g.line_of_action_length - s;
    const LineContact mine = line_contact(1120.0 / g.spec.face_width_m, rho1 * rho2 / (rho1 + rho2), g.effective_modulus);
    const twin::HertzContact theirs = twin::hertz_contact(g, s, 1120.0);
    CHECK(mine.half_width_m == Approx(theirs.half_width_m).epsilon(1e-12));
    CHECK(mine.max_pressure_pa == Approx(theirs.max_pressure_pa).epsilon(1e-12));
  }
}

TEST_CASE("Constant pressure and sliding speed wear linearly in contact time with Archard's slope", "[wear][archard]") {
  // A strip of half-width a and peak p0 passes over a flat flank at rolling speed v_r: a point is
  // under pressure for t = 2a/v_r at mean pressure π p0/4, so h = K (π p0/4) v_s t (Archard, dh/dt = K P v_s).
  const double p0 = 500e6, a = 50e-6, vs = 0.3, k = 2e-13;
  for (double vr : {0.05, 0.1, 0.4, 1.6}) {
    TravellingContact c;
    c.max_pressure_pa = [=](double) { return p0; };
    c.half_width_m = [=](double) { return a; };
    c.sliding_speed_m_s = [=](double) { return vs; };
    c.rolling_speed_m_s = [=](double) { return vr; };
    c.first = 0.0;
    c.last = 0.01;
    const double exposure = 2.0 * a / vr;
    const std::vector<double> h = archard_wear_depth(c, {0.002, 0.005, 0.008}, k);
    for (double v : h) CHECK(v == Approx(k * 0.25 * std::numbers::pi * p0 * vs * exposure).epsilon(1e-9));
  }
}

TEST_CASE("Away from the pitch point one pass wears K·(F/b)·v_s/v_r: the Hertz semi-ellipse integrated", "[wear][archard]") {
  // With a constant pair force the pressure integral over the strip is ∫ p0 sqrt(1 − u²/a²) du =
  // π a p0 / 2 = F/b, so h ≈ K (F/b) v_s/v_r. Over the strip v_s/v_r, p0 and a vary; the first-order
  // terms are odd and cancel, the second-order ones are ~ (a²/8) g''/g for the slip ratio g, which is
  // largest near the pinion root: ≈ 5e-3 at s = 2.5 mm (a = 38 µm). Hence 1 % for the closed form,
  // and 1e-5 against the brute-force sum of the same integrand (the quadrature itself).
  const twin::GearGeometry g = twin::GearGeometry::from_spec(GearPairSpec{});
  const double force = 1120.0, k = 1e-15;
  PassLoad load{{g.contact_start, g.contact_end}, {force, force}};
  const TravellingContact pinion = pinion_contact(g, load);
  const TravellingContact gear = gear_contact(g, load);
  const double ratio = 19.0 / 52.0;
  for (double s : {0.0025, 0.0045, 0.0095}) {
    const double rho1 = s, rho2 = g.line_of_action_length - s;
    const double vs = std::abs(rho1 - ratio * rho2);  // ω1 = 1
    const double expected_p = k * force / g.spec.face_width_m * vs / rho1;
    const double expected_g = k * force / g.spec.face_width_m * vs / (ratio * rho2);
    const double xp = pinion_flank_arc(g, s), xg = gear_flank_arc(g, s);
    const double hp = archard_wear_depth(pinion, {xp}, k)[0], hg = archard_wear_depth(gear, {xg}, k)[0];
    CHECK(hp == Approx(expected_p).epsilon(1e-2));
    CHECK(hg == Approx(expected_g).epsilon(1e-2));
    CHECK(hp == Approx(brute_force_depth(pinion, xp, k)).epsilon(1e-5));
    CHECK(hg == Approx(brute_force_depth(gear, xg, k)).epsilon(1e-5));
  }
}

TEST_CASE("The pitch point wears only through the contact width (Fig. 6.3): closed form of the Hertz integral",
          "[wear][archard]") {
  // At the pitch point v_s = 0, so the point-contact Archard model (Eq. 6.2) gives no wear there. With
  // the strip (Eq. 6.4), centres q = x + u nearby slide at v_s = ω1 (1 + z1/z2) |s − s_p| with
  // s − s_p = u r_b1/ρ1 (dq/ds = ρ1/r_b1), so
  //   h = K p0 (1 + z1/z2) r_b1/ρ1² ∫_{−a}^{a} |u| sqrt(1 − u²/a²) du = K p0 (1 + z1/z2) r_b1/ρ1² · 2a²/3.
  const twin::GearGeometry g = twin::GearGeometry::from_spec(GearPairSpec{});
  const double force = 1120.0, k = 1e-15, ratio = 19.0 / 52.0;
  const double s_pitch = g.pitch_radius_pinion * std::sin(g.pressure_angle_rad);
  PassLoad load{{g.contact_start, g.contact_end}, {force, force}};
  const double rho1 = s_pitch, rho2 = g.line_of_action_length - s_pitch;
  const LineContact c = line_contact(force / g.spec.face_width_m, rho1 * rho2 / (rho1 + rho2), g.effective_modulus);
  const double expected = k * c.max_pressure_pa * (1.0 + ratio) * g.base_radius_pinion / (rho1 * rho1) * 2.0 *
                          c.half_width_m * c.half_width_m / 3.0;
  const TravellingContact pinion = pinion_contact(g, load);
  const double at_pitch = archard_wear_depth(pinion, {pinion_flank_arc(g, s_pitch)}, k)[0];
  // Second-order terms in a/ρ1 (a = 55 µm, ρ1 = 6.5 mm): well below 1 %; the quadrature to 1e-5.
  CHECK(at_pitch == Approx(expected).epsilon(1e-2));
  CHECK(at_pitch == Approx(brute_force_depth(pinion, pinion_flank_arc(g, s_pitch), k)).epsilon(1e-5));
  // Non-zero, yet an order of magnitude below the flank 1 mm away (by the two closed forms: ~5 %).
  const double nearby = archard_wear_depth(pinion, {pinion_flank_arc(g, s_pitch - 1e-3)}, k)[0];
  CHECK(at_pitch > 0.0);
  CHECK(at_pitch < 0.1 * nearby);
}

TEST_CASE("pass_wear samples both flanks root to tip and the thesis-unit conversion is MPa^-1", "[wear][archard]") {
  const twin::GearGeometry g = twin::GearGeometry::from_spec(GearPairSpec{});
  const double force = 1120.0, k = 1e-15;
  PassLoad load{{g.contact_start, g.contact_end}, {force, force}};
  const PassWear w = pass_wear(g, load, k, 11);
  REQUIRE(w.pinion_m.size() == 11);
  REQUIRE(w.gear_m.size() == 11);
  // Pinion point j sits at s = s0 + j L/10; gear point j (from its root) at s = s_end − j L/10.
  for (int j : {1, 3, 8}) {
    const double sp = g.contact_start + g.active_length() * j / 10.0;
    const double sg = g.contact_end - g.active_length() * j / 10.0;
    CHECK(w.pinion_m[static_cast<std::size_t>(j)] ==
          Approx(archard_wear_depth(pinion_contact(g, load), {pinion_flank_arc(g, sp)}, k)[0]).epsilon(1e-12));
    CHECK(w.gear_m[static_cast<std::size_t>(j)] ==
          Approx(archard_wear_depth(gear_contact(g, load), {gear_flank_arc(g, sg)}, k)[0]).epsilon(1e-12));
  }
  // Half the face width left (Eq. 7.12 feedback) doubles the load per width: h ∝ w holds to O((a/ρ)²).
  const PassWear half = pass_wear(g, load, k, 11, [](double) { return 0.5; });
  CHECK(half.pinion_m[2] == Approx(2.0 * w.pinion_m[2]).epsilon(2e-3));
  // h[mm] = K · P[MPa] · s[mm] ⇔ K_SI = 1e-6 K.
  CHECK(k_wear_si_from_seed(1.65e-6) == Approx(1.65e-12).epsilon(1e-14));
  CHECK(k_wear_seed_from_si(k_wear_si_from_seed(3.55e-10)) == Approx(3.55e-10).epsilon(1e-14));
}

}  // namespace test_archard_wear
