// The pitting growth law dD/dN = a D^b (1 − D) with b estimated (docs/model.md, "Pitting growth
// law"), against closed forms: the transform's b = 0 and b = 1 integrals; a b = 0 truth
// D = 1 − (1 − D0) e^(−aN) and a logistic one D/(1 − D) = D0/(1 − D0) e^(aN) each recovered from
// near-exact readings with the cycles to 17 % their closed form; the generalised least squares line
// against compound symmetry's closed form and against an independent random-effect fit; and the
// interval's coverage on data drawn from the law itself, with independent errors and with an ICS2
// scale's common inspection errors, near its nominal 90 %.
#include "gearwatch/wear/pitting_growth.hpp"

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Dense>
#include <catch2/catch.hpp>

namespace test_pitting_growth {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::wear;

std::vector<DensityReading> growth_readings_of(double (*truth)(double), const std::vector<double>& cycles, double log_sd) {
  std::vector<DensityReading> r;
  for (double n : cycles) r.push_back({n, truth(n), log_sd, {}});
  return r;
}

// b = 0: dD/dN = a (1 − D), a = 0.1 per Mcycle, D0 = 1 %.
double unpitted_rate_truth(double n) { return 1.0 - 0.99 * std::exp(-0.1e-6 * n); }
// b = 1: the logistic, D/(1 − D) doubling every 0.25 M cycles from 1/99 at N = 0.
double logistic_truth(double n) {
  const double odds = (0.01 / 0.99) * std::exp2(n / 0.25e6);
  return odds / (1.0 + odds);
}

TEST_CASE("growth law transform against its closed forms and its inverse", "[pitting_growth]") {
  for (double d : {1e-4, 0.01, 0.17, 0.6, 0.95}) {
    CHECK(growth_transform(d, 0.0) == Approx(-1.0 - std::log1p(-d)).epsilon(1e-12));
    CHECK(growth_transform(d, 1.0) == Approx(std::log(d / (1.0 - d))).epsilon(1e-12));
    // d g / d ln D = D^(1 − b) / (1 − D) by a central difference in ln D, at b = 0.4.
    const double h = 1e-5;
    const double slope = (growth_transform(d * std::exp(h), 0.4) - growth_transform(d * std::exp(-h), 0.4)) / (2 * h);
    CHECK(slope == Approx(growth_log_slope(d, 0.4)).epsilon(1e-6));
    for (double b : {0.0, 0.3, 0.7, 1.0}) CHECK(growth_inverse(growth_transform(d, b), b) == Approx(d).epsilon(1e-9));
  }
  // No finite-cycle blow-up: however far along the line, the density stays below 1.
  for (double b : {0.0, 0.5, 1.0}) {
    CHECK(growth_inverse(1e3, b) < 1.0);
    CHECK(growth_inverse(1e3, b) > 0.999);
  }
}

TEST_CASE("growth law recovers a b equal 0 truth and its cycles to 17 percent", "[pitting_growth]") {
  // 1 − D = 0.99 e^(−0.1 N/M) reaches 0.83 at N = 10 ln(0.99/0.83) M = 1.7629 M: 0.5629 M after 1.2 M.
  const auto r = growth_readings_of(unpitted_rate_truth, {0.2e6, 0.4e6, 0.6e6, 0.8e6, 1.0e6, 1.2e6}, 0.001);
  const GrowthLawFit f = fit_growth_law(r, 0.17, 1.2e6);
  REQUIRE(f.valid);
  const double truth = 10e6 * std::log(0.99 / 0.83) - 1.2e6;
  CHECK(f.b_mean == Approx(0.0).margin(0.05));
  CHECK(f.cycles_left == Approx(truth).epsilon(0.03));
  CHECK(f.cycles_left_low <= truth);
  CHECK(f.cycles_left_high >= truth);
  CHECK(f.density_now == Approx(unpitted_rate_truth(1.2e6)).epsilon(0.02));
}

TEST_CASE("growth law recovers a logistic truth and its cycles to 17 percent", "[pitting_growth]") {
  // Odds 0.17/0.83 = (1/99) 2^(N / 0.25 M) at N = 0.25 M log2(99 · 17/83).
  const auto r = growth_readings_of(logistic_truth, {0.0, 0.1e6, 0.2e6, 0.3e6, 0.4e6, 0.5e6}, 0.001);
  const GrowthLawFit f = fit_growth_law(r, 0.17, 0.5e6);
  REQUIRE(f.valid);
  const double truth = 0.25e6 * std::log2(99.0 * 17.0 / 83.0) - 0.5e6;
  CHECK(f.b_mean == Approx(1.0).margin(0.05));
  CHECK(f.bound == GrowthExponentBound::at_upper);
  CHECK(f.cycles_left == Approx(truth).epsilon(0.03));
  CHECK(f.cycles_left_low <= truth);
  CHECK(f.cycles_left_high >= truth);
}

TEST_CASE("growth law needs three distinct cycles", "[pitting_growth]") {
  const auto r = growth_readings_of(unpitted_rate_truth, {0.2e6, 0.2e6, 0.4e6}, 0.1);
  CHECK_FALSE(fit_growth_law(r, 0.17, 0.4e6).valid);
}

TEST_CASE("growth line with one common error has compound symmetry's closed form", "[pitting_growth]") {
  // Ten readings of a constant D = 5 %, own SD σ = 0.1 and one common error τ = 0.1 in ln D: the
  // covariance J²(σ² I + τ² 11ᵀ) holds the constant in its span, so GLS is ordinary least squares
  // with var α = J²(σ²/n + τ²) (averaging cannot remove the common error), var β = J² σ²/Sxx.
  std::vector<DensityReading> r;
  double sxx = 0;
  for (int i = 0; i < 10; ++i) {
    r.push_back({1e5 * i, 0.05, 0.1, {0.1, 0.0}});
    sxx += std::pow(1e5 * (i - 4.5), 2);
  }
  const double b = 0.3, j = growth_log_slope(0.05, b);
  const GrowthLine l = growth_line_fit(r, b);
  REQUIRE(l.valid);
  CHECK(l.alpha == Approx(growth_transform(0.05, b)).epsilon(1e-10));
  CHECK(l.beta == Approx(0.0).margin(1e-15));
  CHECK(l.var_alpha == Approx(j * j * (0.01 / 10 + 0.01)).epsilon(1e-9));
  CHECK(l.var_beta == Approx(j * j * 0.01 / sxx).epsilon(1e-9));
  CHECK(l.chi2 == Approx(0.0).margin(1e-12));
}

TEST_CASE("growth line by generalised least squares equals an explicit random-effect fit", "[pitting_growth]") {
  // The reference: weighted least squares on (α, β, δ0, δ1) with each reading
  // g_i = α + β (N_i − c) + J_i Σ_j s_ij δ_j + e_i, e_i ~ N(0, (J_i σ_i)²), and two pseudo-readings
  // δ_j = 0 ± 1: its (α, β) block, estimates and minimum equal the marginal GLS fit.
  const std::vector<DensityReading> r{{3e5, 0.012, 0.02, {0.1, 0.0}},   {5e5, 0.031, 0.03, {0.0, 0.1}},
                                      {6e5, 0.043, 0.1, {0.06, 0.05}}, {7e5, 0.060, 0.1, {0.04, 0.07}},
                                      {8e5, 0.071, 0.1, {0.02, 0.09}}, {9e5, 0.095, 0.1, {0.01, 0.11}}};
  const double b = 0.6;
  const GrowthLine l = growth_line_fit(r, b);
  REQUIRE(l.valid);
  const int n = static_cast<int>(r.size());
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n + 2, 4);
  Eigen::VectorXd y = Eigen::VectorXd::Zero(n + 2), w = Eigen::VectorXd::Ones(n + 2);
  for (int i = 0; i < n; ++i) {
    const auto& x = r[static_cast<std::size_t>(i)];
    // The slope at the line's density there (the fit's fixed point), as the fit takes it.
    const double jac = growth_log_slope(growth_inverse(l.alpha + l.beta * (x.cycles - l.centre), b), b);
    a(i, 0) = 1;
    a(i, 1) = x.cycles - l.centre;
    a(i, 2) = jac * x.shared[0];
    a(i, 3) = jac * x.shared[1];
    y(i) = growth_transform(x.density, b);
    w(i) = 1.0 / std::pow(jac * x.log_sd, 2);
  }
  a(n, 2) = 1;
  a(n + 1, 3) = 1;
  const Eigen::MatrixXd normal = a.transpose() * w.asDiagonal() * a;
  const Eigen::MatrixXd cov = normal.inverse();
  const Eigen::VectorXd theta = cov * (a.transpose() * w.asDiagonal() * y);
  const Eigen::VectorXd e = y - a * theta;
  CHECK(l.alpha == Approx(theta(0)).epsilon(1e-9));
  CHECK(l.beta == Approx(theta(1)).epsilon(1e-9));
  CHECK(l.var_alpha == Approx(cov(0, 0)).epsilon(1e-8));
  CHECK(l.var_beta == Approx(cov(1, 1)).epsilon(1e-8));
  CHECK(l.cov_alpha_beta == Approx(cov(0, 1)).epsilon(1e-7));
  CHECK(l.chi2 == Approx(e.dot(w.asDiagonal() * e)).epsilon(1e-8));
}

/// A truth of the law: D = 1 % at N = 0 reaching 17 % at `cross`, exponent b.
struct GrowthLawTruth {
  double b = 0, g0 = 0, slope = 0;
  double at(double n) const { return growth_inverse(g0 + slope * n, b); }
};
GrowthLawTruth draw_growth_truth(std::mt19937_64& rng, const GrowthLawSettings& s, double cross) {
  std::normal_distribution<double> normal(0.0, 1.0);
  GrowthLawTruth t;
  t.b = -1;
  while (t.b < s.b_min || t.b > s.b_max) t.b = s.b_prior_mean + s.b_prior_sd * normal(rng);
  t.g0 = growth_transform(0.01, t.b);
  t.slope = (growth_transform(0.17, t.b) - t.g0) / cross;
  return t;
}

TEST_CASE("growth law interval covers truths drawn from the law near its nominal 90 percent", "[pitting_growth]") {
  // b from the fit's own prior (truncated to its range), N* in [1.5, 3] M; five readings
  // 0.25 … 1.25 M with independent lognormal errors of SD 0.1 in ln D.
  const GrowthLawSettings s;
  std::mt19937_64 rng(20261130);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(1.5e6, 3.0e6);
  const int trials = 1000;
  int held = 0;
  for (int t = 0; t < trials; ++t) {
    const double cross = uniform(rng);
    const GrowthLawTruth truth = draw_growth_truth(rng, s, cross);
    std::vector<DensityReading> r;
    for (double n : {0.25e6, 0.5e6, 0.75e6, 1.0e6, 1.25e6}) r.push_back({n, truth.at(n) * std::exp(0.1 * normal(rng)), 0.1, {}});
    const GrowthLawFit f = fit_growth_law(r, 0.17, 1.25e6);
    REQUIRE(f.valid);
    if (f.cycles_left_low <= cross - 1.25e6 && cross - 1.25e6 <= f.cycles_left_high) ++held;
  }
  const double coverage = static_cast<double>(held) / trials;
  INFO("coverage " << coverage);
  // Binomial SD at 90 % over 1000 draws: 0.95 %; three SDs either side.
  CHECK(coverage == Approx(0.90).margin(0.03));
}

}  // namespace test_pitting_growth

namespace test_inspection_exponent {  // Eq. 7.8's exponent read from two pitted-area inspections

using namespace gearwatch::wear;

// Eq. 7.8 with m = 3, A = 1e-20 per cycle^3: D = 1 % near 1.0 M cycles, 4 % near 1.6 M.
constexpr double kA = 1e-20, kM = 3.0;
double weibull_truth(double n) { return -std::expm1(-kA * std::pow(n, kM)); }
double weibull_crossing(double limit) { return std::pow(-std::log1p(-limit) / kA, 1.0 / kM); }

// ln N_L written out independently of the function: ln n1 + ln(n1/n0) ln(H_L/H1) / ln(H1/H0).
double log_crossing(double n0, double d0, double n1, double d1, double limit) {
  const double h0 = -std::log(1 - d0), h1 = -std::log(1 - d1), hl = -std::log(1 - limit);
  return std::log(n1) + std::log(n1 / n0) * std::log(hl / h1) / std::log(h1 / h0);
}

TEST_CASE("inspection exponent recovers Eq. 7.8's m and its crossing in closed form", "[pitting_growth][pitting_exponent]") {
  const double n0 = 1.0e6, n1 = 1.6e6, now = 1.8e6;
  const ExponentCrossing x = inspection_exponent_crossing(n0, weibull_truth(n0), n1, weibull_truth(n1), 0.1, 0.1, 0.17, now, 0.9);
  REQUIRE(x.valid);
  CHECK(x.exponent == Approx(kM).epsilon(1e-12));
  CHECK(x.crossing_cycles == Approx(weibull_crossing(0.17)).epsilon(1e-9));
  CHECK(x.cycles_left == Approx(weibull_crossing(0.17) - now).epsilon(1e-9));
  CHECK(x.cycles_left_low < x.cycles_left);
  CHECK(x.cycles_left_high > x.cycles_left);
  // Past the crossing: 0 left.
  const ExponentCrossing past = inspection_exponent_crossing(n0, weibull_truth(n0), n1, weibull_truth(n1), 0.1, 0.1, 0.17, 3e6, 0.9);
  CHECK(past.cycles_left == 0.0);
}

TEST_CASE("inspection exponent's ln SD equals the delta method by central differences", "[pitting_growth][pitting_exponent]") {
  const double n0 = 1.0e6, n1 = 1.6e6, d0 = weibull_truth(n0), d1 = weibull_truth(n1), s0 = 0.1, s1 = 0.07;
  const ExponentCrossing x = inspection_exponent_crossing(n0, d0, n1, d1, s0, s1, 0.17, n1, 0.9);
  REQUIRE(x.valid);
  const double h = 1e-5;   // step in ln D
  const double g0 = (log_crossing(n0, d0 * std::exp(h), n1, d1, 0.17) - log_crossing(n0, d0 * std::exp(-h), n1, d1, 0.17)) / (2 * h);
  const double g1 = (log_crossing(n0, d0, n1, d1 * std::exp(h), 0.17) - log_crossing(n0, d0, n1, d1 * std::exp(-h), 0.17)) / (2 * h);
  CHECK(x.log_sd == Approx(std::hypot(g0 * s0, g1 * s1)).epsilon(1e-6));
  // The interval's ends: N_L exp(∓ z sd) − now, z = 1.6449 at 90 %.
  CHECK(x.cycles_left_high == Approx(x.crossing_cycles * std::exp(1.6448536 * x.log_sd) - n1).epsilon(1e-6));
  CHECK(x.cycles_left_low == Approx(x.crossing_cycles * std::exp(-1.6448536 * x.log_sd) - n1).epsilon(1e-6));
}

TEST_CASE("inspection exponent's interval covers Eq. 7.8 truths near its nominal 90 percent", "[pitting_growth][pitting_exponent]") {
  // Readings with independent normal errors in ln D (SD 0.1, the inspections' stated error) on an
  // Eq. 7.8 truth: the interval must hold the true crossing in 90 % ± 2 % of 4000 draws (binomial
  // SD 0.47 %; the rest for the delta method's linearisation).
  const double n0 = 1.0e6, n1 = 1.6e6, truth = weibull_crossing(0.17);
  std::mt19937_64 rng(20261201);
  std::normal_distribution<double> e(0.0, 0.1);
  int held = 0, valid = 0;
  const int draws = 4000;
  for (int k = 0; k < draws; ++k) {
    const double d0 = weibull_truth(n0) * std::exp(e(rng)), d1 = weibull_truth(n1) * std::exp(e(rng));
    const ExponentCrossing x = inspection_exponent_crossing(n0, d0, n1, d1, 0.1, 0.1, 0.17, n1, 0.9);
    if (!x.valid) continue;
    ++valid;
    held += (n1 + x.cycles_left_low <= truth && truth <= n1 + x.cycles_left_high) ? 1 : 0;
  }
  CHECK(valid == draws);
  CHECK(static_cast<double>(held) / draws == Approx(0.90).margin(0.02));
}

TEST_CASE("inspection exponent's crossing is median-unbiased under independent reading errors", "[pitting_growth][pitting_exponent]") {
  // ln N_L is, to first order, linear in the two readings' normal errors, so on an Eq. 7.8 truth
  // the crossing read from two noisy inspections falls early in half the draws: a forecast that is
  // early in most campaigns is not the reading's noise (nor a selection: inspections are triggered
  // by the truth, not the reading). Errors relative in D (as the benchmark draws them) and in ln D.
  // 50 % ± 3 % of 4000 draws each (binomial SD 0.79 %; the rest for second-order terms).
  const double n0 = 1.0e6, n1 = 1.6e6, truth = weibull_crossing(0.17);
  std::mt19937_64 rng(20261202);
  std::normal_distribution<double> e(0.0, 0.1);
  const int draws = 4000;
  for (const bool relative : {false, true}) {
    int early = 0, valid = 0;
    for (int k = 0; k < draws; ++k) {
      const double e0 = e(rng), e1 = e(rng);
      const double d0 = weibull_truth(n0) * (relative ? 1.0 + e0 : std::exp(e0));
      const double d1 = weibull_truth(n1) * (relative ? 1.0 + e1 : std::exp(e1));
      const ExponentCrossing x = inspection_exponent_crossing(n0, d0, n1, d1, 0.1, 0.1, 0.17, n1, 0.9);
      if (!x.valid) continue;
      ++valid;
      early += x.crossing_cycles < truth ? 1 : 0;
    }
    INFO("relative errors " << relative << ", early " << early << " of " << valid);
    CHECK(valid == draws);
    CHECK(static_cast<double>(early) / draws == Approx(0.5).margin(0.03));
  }
}

TEST_CASE("inspection exponent needs two ordered readings with growth", "[pitting_growth][pitting_exponent]") {
  CHECK_FALSE(inspection_exponent_crossing(1e6, 0.04, 1.6e6, 0.04, 0.1, 0.1, 0.17, 2e6, 0.9).valid);
  CHECK_FALSE(inspection_exponent_crossing(1.6e6, 0.01, 1.6e6, 0.04, 0.1, 0.1, 0.17, 2e6, 0.9).valid);
  CHECK_FALSE(inspection_exponent_crossing(1e6, 0.0, 1.6e6, 0.04, 0.1, 0.1, 0.17, 2e6, 0.9).valid);
  CHECK_FALSE(inspection_exponent_crossing(1e6, 0.01, 1.6e6, 0.04, -0.1, 0.1, 0.17, 2e6, 0.9).valid);
}

}  // namespace test_inspection_exponent
