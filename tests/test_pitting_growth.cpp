// The pitting growth law dD/dN = a D^b with b estimated (docs/model.md, "Pitting growth law"),
// against closed forms: a linear truth D = D0 + c N (b = 0) and an exponential one D = D0 2^(N/T)
// (b = 1) each recovered from near-exact readings (SD 0.1 % in ln D) with the cycles to 17 % their
// closed form; and the interval's coverage on
// data drawn from the law itself (b from its prior, lognormal reading errors) near its nominal 90 %.
#include "gearwatch/wear/pitting_growth.hpp"

#include <cmath>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

namespace test_pitting_growth {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::wear;

std::vector<DensityReading> growth_readings_of(double (*truth)(double), const std::vector<double>& cycles, double log_sd) {
  std::vector<DensityReading> r;
  for (double n : cycles) r.push_back({n, truth(n), log_sd});
  return r;
}

double linear_growth_truth(double n) { return 0.01 + 0.05e-6 * n; }
double exponential_growth_truth(double n) { return 0.01 * std::exp2(n / 0.25e6); }

TEST_CASE("growth law transform and inverse round trip", "[pitting_growth]") {
  for (double lambda : {-0.5, 0.0, 0.3, 1.0})
    for (double d : {0.01, 0.05, 0.17}) CHECK(growth_inverse(growth_transform(d, lambda), lambda) == Approx(d).epsilon(1e-12));
  CHECK(growth_transform(0.17, 1.0) == Approx(0.17 - 1.0));
  CHECK(growth_transform(0.17, 0.0) == Approx(std::log(0.17)));
}

TEST_CASE("growth law recovers a linear truth and its cycles to 17 percent", "[pitting_growth]") {
  // D = 0.01 + 0.05 per Mcycle reaches 0.17 at 3.2 M cycles: 2.0 M after the last reading at 1.2 M.
  const auto r = growth_readings_of(linear_growth_truth, {0.2e6, 0.4e6, 0.6e6, 0.8e6, 1.0e6, 1.2e6}, 0.001);
  const GrowthLawFit f = fit_growth_law(r, 0.17, 1.2e6);
  REQUIRE(f.valid);
  CHECK(f.b_mean == Approx(0.0).margin(0.05));
  CHECK(f.cycles_left == Approx(2.0e6).epsilon(0.03));
  CHECK(f.cycles_left_low <= 2.0e6);
  CHECK(f.cycles_left_high >= 2.0e6);
  CHECK(f.density_now == Approx(linear_growth_truth(1.2e6)).epsilon(0.02));
}

TEST_CASE("growth law recovers an exponential truth and its cycles to 17 percent", "[pitting_growth]") {
  // D = 0.01 · 2^(N / 0.25 M) reaches 0.17 at 0.25 M · log2(17) = 1.0219 M: 0.5219 M after 0.5 M.
  const auto r = growth_readings_of(exponential_growth_truth, {0.0, 0.1e6, 0.2e6, 0.3e6, 0.4e6, 0.5e6}, 0.001);
  const GrowthLawFit f = fit_growth_law(r, 0.17, 0.5e6);
  REQUIRE(f.valid);
  const double truth = 0.25e6 * std::log2(17.0) - 0.5e6;
  CHECK(f.b_mean == Approx(1.0).margin(0.05));
  CHECK(f.cycles_left == Approx(truth).epsilon(0.03));
  CHECK(f.cycles_left_low <= truth);
  CHECK(f.cycles_left_high >= truth);
}

TEST_CASE("growth law needs three distinct cycles", "[pitting_growth]") {
  const auto r = growth_readings_of(linear_growth_truth, {0.2e6, 0.2e6, 0.4e6}, 0.1);
  CHECK_FALSE(fit_growth_law(r, 0.17, 0.4e6).valid);
}

TEST_CASE("growth law interval covers truths drawn from the law near its nominal 90 percent", "[pitting_growth]") {
  // b from the fit's own prior (truncated to its range), D = 1 % at N = 0 reaching 17 % at N* drawn
  // in [1.5, 3] M; five readings 0.25 … 1.25 M with lognormal errors of SD 0.1 in ln D.
  const GrowthLawSettings s;
  std::mt19937_64 rng(20261130);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(1.5e6, 3.0e6);
  const int trials = 1000;
  int held = 0;
  for (int t = 0; t < trials; ++t) {
    double b = -1;
    while (b < s.b_min || b > s.b_max) b = s.b_prior_mean + s.b_prior_sd * normal(rng);
    const double lambda = 1.0 - b, cross = uniform(rng);
    const double g0 = growth_transform(0.01, lambda), slope = (growth_transform(0.17, lambda) - g0) / cross;
    std::vector<DensityReading> r;
    for (double n : {0.25e6, 0.5e6, 0.75e6, 1.0e6, 1.25e6})
      r.push_back({n, growth_inverse(g0 + slope * n, lambda) * std::exp(0.1 * normal(rng)), 0.1});
    const GrowthLawFit f = fit_growth_law(r, 0.17, 1.25e6);
    REQUIRE(f.valid);
    const double truth = cross - 1.25e6;
    if (f.cycles_left_low <= truth && truth <= f.cycles_left_high) ++held;
  }
  const double coverage = static_cast<double>(held) / trials;
  INFO("coverage " << coverage);
  // Binomial SD at 90 % over 1000 draws: 0.95 %; three SDs either side.
  CHECK(coverage == Approx(0.90).margin(0.03));
}

}  // namespace test_pitting_growth
