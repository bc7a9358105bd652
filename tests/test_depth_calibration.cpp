// The depth calibration by inspected wear depths (docs/model.md, "Depth calibration") against known
// answers: the closed-form normal posterior of ln ρ with and without the random walk, the prior
// from the shape range, the interval's coverage where the truth is the model itself (the ratio
// drawn from the prior, walking, measured with the stated relative noise), and the model's use of
// it: the depth estimate and the wear crossing at limit / ρ.
#include "gearwatch/wear/depth_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <random>
#include <unistd.h>
#include <vector>

#include <catch2/catch.hpp>

#include "gearwatch/storage/messages.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/storage/writer.hpp"
#include "gearwatch/wear/updating.hpp"
#include "model_observation.hpp"

namespace test_depth_calibration {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::wear;

TEST_CASE("depth calibration: the log variance of a relative error is ln(1 + s^2)", "[model][depth_calibration]") {
  CHECK(log_relative_variance(0.05) == Approx(std::log(1.0025)).epsilon(1e-12));
  const DepthRatioMeasurement m = depth_ratio_measurement(7, 1e6, 30e-6, 20e-6, 0.1);
  CHECK(m.inspection_id == 7);
  CHECK(m.cycles == 1e6);
  CHECK(m.log_ratio == Approx(std::log(1.5)).epsilon(1e-15));
  CHECK(m.var == Approx(std::log(1.01)).epsilon(1e-15));
}

TEST_CASE("depth calibration: the prior's central interval is the shape range", "[model][depth_calibration]") {
  const double z = 1.6448536269514722;   // the normal's 95 % point: a central 90 %
  const LogPosterior p = shape_range_prior(2.0, 0.1, 0.90, 4.6);
  REQUIRE(p.valid);
  CHECK(p.mean - z * std::sqrt(p.var) == Approx(-z * 0.1).epsilon(1e-12));
  CHECK(p.mean + z * std::sqrt(p.var) == Approx(std::log(2.0) + z * 0.1).epsilon(1e-12));
  // A shape below the model's: the range's low end is ln ρ_s.
  const LogPosterior q = shape_range_prior(0.5, 0.0, 0.90, 4.6);
  CHECK(q.mean == Approx(std::log(0.5) / 2).epsilon(1e-12));
  CHECK(std::sqrt(q.var) == Approx(-std::log(0.5) / (2 * z)).epsilon(1e-12));
  // No shape reading: N(0, fallback²).
  const LogPosterior none = shape_range_prior(0.0, 0.1, 0.90, 4.6);
  CHECK(none.mean == 0.0);
  CHECK(none.var == Approx(4.6 * 4.6).epsilon(1e-15));
}

TEST_CASE("depth calibration: the posterior of ln rho in closed form", "[model][depth_calibration]") {
  LogPosterior prior;
  prior.valid = true;
  prior.mean = 0.2;
  prior.var = 0.09;
  const double z1 = std::log(1.3), r1 = std::log1p(0.05 * 0.05), z2 = std::log(1.45), r2 = std::log1p(0.1 * 0.1);
  const std::vector<DepthRatioMeasurement> ms{{2, 2e6, z2, r2}, {1, 1e6, z1, r1}};   // out of order: sorted by cycles
  SECTION("no random walk: precision-weighted mean") {
    const LogPosterior p = depth_ratio_posterior(prior, ms, 0.0, 3e6);
    const double var = 1.0 / (1.0 / 0.09 + 1.0 / r1 + 1.0 / r2);
    CHECK(p.valid);
    CHECK(p.var == Approx(var).epsilon(1e-12));
    CHECK(p.mean == Approx(var * (0.2 / 0.09 + z1 / r1 + z2 / r2)).epsilon(1e-12));
    CHECK(p.cycles == 3e6);
  }
  SECTION("a random walk between the readings and on to now") {
    const double q = 0.3 / 1e6;
    const LogPosterior p = depth_ratio_posterior(prior, ms, q, 3e6);
    const double v1 = 1.0 / (1.0 / 0.09 + 1.0 / r1), m1 = v1 * (0.2 / 0.09 + z1 / r1);
    const double v1p = v1 + q * 1e6;
    const double v2 = 1.0 / (1.0 / v1p + 1.0 / r2), m2 = v2 * (m1 / v1p + z2 / r2);
    CHECK(p.mean == Approx(m2).epsilon(1e-12));
    CHECK(p.var == Approx(v2 + q * 1e6).epsilon(1e-12));
  }
  SECTION("no readings: no posterior") { CHECK_FALSE(depth_ratio_posterior(prior, {}, 0.0, 3e6).valid); }
}

TEST_CASE("depth calibration: the calibrated depth and its interval", "[model][depth_calibration]") {
  LogPosterior p;
  p.valid = true;
  p.mean = std::log(1.2);
  p.var = 0.04;
  const CalibratedDepth d = calibrated_depth(20e-6, p, 0.90);
  const double z = 1.6448536269514722;
  CHECK(d.estimate_m == Approx(24e-6).epsilon(1e-12));
  CHECK(d.low_m == Approx(24e-6 * std::exp(-z * 0.2)).epsilon(1e-12));
  CHECK(d.high_m == Approx(24e-6 * std::exp(z * 0.2)).epsilon(1e-12));
  CHECK(d.ratio == Approx(1.2).epsilon(1e-12));
}

TEST_CASE("depth calibration: the model's mean at an inspection between records", "[model][depth_calibration]") {
  CHECK(model_mean_at(1.5e6, 1e6, 10e-6, 2e6, 14e-6) == Approx(12e-6).epsilon(1e-12));
  CHECK(model_mean_at(2e6, 1e6, 10e-6, 2e6, 14e-6) == 14e-6);
  CHECK(model_mean_at(0.5e6, 1e6, 10e-6, 2e6, 14e-6) == Approx(5e-6).epsilon(1e-12));   // from the unworn start
  CHECK(model_mean_at(0.5e6, 0.0, 0.0, 2e6, 14e-6) == Approx(3.5e-6).epsilon(1e-12));
}

namespace {
// Coverage of the 90 % interval at `now` over `trials` truths whose ln ρ is `start(rng, n01)` and
// walks with q between the inspections `at` and on to now, each inspection reading the true depth
// times (1 + ε), ε normal with relative SD 5 %; the posterior gated at `gate` (infinite: no gate).
template <class Start>
double ratio_coverage(const LogPosterior& prior, Start start, double gate, int trials, std::uint64_t seed,
                      const std::vector<double>& at, double now) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const double q = std::pow(std::log(2.0), 2) / 1e6, sd = 0.05, model_mean = 20e-6;
  int covered = 0;
  for (int t = 0; t < trials; ++t) {
    double log_rho = start(rng, n01), last = at.front();
    std::vector<DepthRatioMeasurement> ms;
    for (std::size_t k = 0; k < at.size(); ++k) {
      log_rho += std::sqrt(q * (at[k] - last)) * n01(rng);
      last = at[k];
      const double measured = model_mean * std::exp(log_rho) * (1.0 + sd * n01(rng));
      ms.push_back(depth_ratio_measurement(static_cast<std::int64_t>(k + 1), at[k], measured, model_mean, sd));
    }
    log_rho += std::sqrt(q * (now - last)) * n01(rng);
    const CalibratedDepth d = calibrated_depth(model_mean, depth_ratio_posterior(prior, ms, q, now, gate), 0.90);
    const double truth = model_mean * std::exp(log_rho);
    if (d.low_m <= truth && truth <= d.high_m) ++covered;
  }
  return static_cast<double>(covered) / trials;
}
}  // namespace

TEST_CASE("depth calibration: the 90 % interval holds a truth drawn from the model's own assumptions",
          "[model][depth_calibration]") {
  // The truth is the model itself: ln ρ drawn from the prior, walking with q between the readings
  // and on to now, each reading the true depth times (1 + ε), ε normal with the stated SD.
  const LogPosterior prior = shape_range_prior(1.6, 0.03, 0.90, 4.6);
  const auto from_prior = [&](std::mt19937_64& rng, std::normal_distribution<double>& n01) {
    return prior.mean + std::sqrt(prior.var) * n01(rng);
  };
  const double covered = ratio_coverage(prior, from_prior, std::numeric_limits<double>::infinity(), 4000, 20260, {0.8e6, 1.6e6}, 2.5e6);
  // Binomial SD at 4000 trials: 0.47 %; ±1.5 % is over three SDs.
  CHECK(covered == Approx(0.90).margin(0.015));
}

TEST_CASE("depth calibration: a reading far outside the prior widens it by the innovation rule",
          "[model][depth_calibration]") {
  // The prior is the shape range's normal (0 ± 0.03); the inspection reads ln ρ = 0.34, 5.8 SDs of
  // var + r away. Gate 3: the prior's variance becomes 0.34² − r first (filter_update), so the
  // posterior is the reading shrunk by r / 0.34²; without a gate the old conjugate update.
  LogPosterior prior;
  prior.valid = true;
  prior.var = 0.03 * 0.03;
  const double z = 0.34, r = std::log1p(0.05 * 0.05);
  const std::vector<DepthRatioMeasurement> ms{{1, 1e6, z, r}};
  const double v = z * z - r;
  const LogPosterior gated = depth_ratio_posterior(prior, ms, 0.0, 1e6, 3.0);
  CHECK(gated.mean == Approx(v / (v + r) * z).epsilon(1e-12));
  CHECK(gated.var == Approx(v * r / (v + r)).epsilon(1e-12));
  const LogPosterior plain = depth_ratio_posterior(prior, ms, 0.0, 1e6);
  CHECK(plain.mean == Approx(prior.var / (prior.var + r) * z).epsilon(1e-12));
  // Inside the gate the rule changes nothing.
  const std::vector<DepthRatioMeasurement> near{{1, 1e6, 0.1, r}};
  CHECK(depth_ratio_posterior(prior, near, 0.0, 1e6, 3.0).mean == Approx(depth_ratio_posterior(prior, near, 0.0, 1e6).mean).epsilon(1e-15));
}


TEST_CASE("depth calibration: the gated posterior's coverage, truth from the prior and far outside it",
          "[model][depth_calibration]") {
  const LogPosterior prior = shape_range_prior(1.0, 0.03, 0.90, 4.6);   // 0 ± 0.03: a narrow RMS_SA-only prior
  const double psd = std::sqrt(prior.var);
  // Truth = the model: the gate fires in 0.27 % of readings, coverage stays nominal (±1.5 %: over
  // three binomial SDs at 4000 trials).
  CHECK(ratio_coverage(prior, [&](std::mt19937_64& g, std::normal_distribution<double>& n) { return psd * n(g); }, 3.0, 4000, 20261, {0.8e6}, 0.8e6) ==
        Approx(0.90).margin(0.015));
  // The truth's ln ρ 10 prior SDs off (a model form outside the shape range): the gated reading
  // carries the interval; the shrink r / innovation² ≤ 1/9 of the reading's variance costs at most a
  // few points of coverage, so 90 % ± 5 % (ungated: the prior's narrow interval holds none).
  const double far = 10.0 * psd;
  CHECK(ratio_coverage(prior, [&](std::mt19937_64&, std::normal_distribution<double>&) { return far; }, 3.0, 4000, 20262, {0.8e6}, 0.8e6) ==
        Approx(0.90).margin(0.05));
  CHECK(ratio_coverage(prior, [&](std::mt19937_64&, std::normal_distribution<double>&) { return -far; }, 3.0, 4000, 20263, {0.8e6}, 0.8e6) ==
        Approx(0.90).margin(0.05));
}

TEST_CASE("depth calibration: the model's depth and wear crossing follow the inspected depth",
          "[model][depth_calibration]") {
  const ModelSettings s = testing::calibration_case_settings();
  const auto obs = testing::observation(4e5, 20, 20);
  TwinModel plain(twin::GearboxParameters{}, s, testing::calibration_case_rms);
  const ModelRunReport r0 = plain.observe(obs, {});
  REQUIRE(r0.forecast.valid);
  const double mean = r0.summary.combined_mean_depth_m;
  REQUIRE(mean > 0);
  CHECK(r0.forecast.depth_inspections == 0);
  CHECK(r0.forecast.depth_mean_m == mean);   // without depth inspections: the model's own

  Inspection in;
  in.id = 3;
  in.cycles = 4e5;
  in.wear_depth_m = 1.5 * mean;
  TwinModel calibrated(twin::GearboxParameters{}, s, testing::calibration_case_rms);
  const ModelRunReport r1 = calibrated.observe(obs, {in});
  REQUIRE(r1.forecast.valid);
  // No K_wear update read a shape: the prior is N(0, prior_log_k_wear_sd²).
  const double v0 = s.prior_log_k_wear_sd * s.prior_log_k_wear_sd, r = std::log1p(s.inspection_depth_relative_sd * s.inspection_depth_relative_sd);
  const double var = 1.0 / (1.0 / v0 + 1.0 / r), mu = var * std::log(1.5) / r;
  CHECK(r1.forecast.depth_inspections == 1);
  CHECK(r1.forecast.depth_ratio == Approx(std::exp(mu)).epsilon(1e-9));
  CHECK(r1.forecast.depth_ratio_log_sd == Approx(std::sqrt(var)).epsilon(1e-9));
  CHECK(r1.forecast.depth_mean_m == Approx(mean * std::exp(mu)).epsilon(1e-9));
  CHECK(r1.summary.combined_mean_depth_m == mean);   // the model's own state is not changed
  // The nominal wear crossing is the model's crossing of limit / ρ: a model whose limit is that.
  ModelSettings scaled = s;
  scaled.wear_limit_m = s.wear_limit_m / r1.forecast.depth_ratio;
  TwinModel reference(twin::GearboxParameters{}, scaled, testing::calibration_case_rms);
  const ModelRunReport r2 = reference.observe(obs, {});
  REQUIRE(r2.forecast.wear.cycles_left);
  REQUIRE(r1.forecast.wear.cycles_left);
  REQUIRE(r0.forecast.wear.cycles_left);
  CHECK(*r1.forecast.wear.cycles_left == Approx(*r2.forecast.wear.cycles_left).epsilon(1e-9));
  CHECK(*r1.forecast.wear.cycles_left < *r0.forecast.wear.cycles_left);
  REQUIRE(r1.forecast.wear.cycles_left_low);
  CHECK(*r1.forecast.wear.cycles_left_low <= *r1.forecast.wear.cycles_left);
  // The reading stays with the memory: the next record does not read the inspection again.
  const ModelRunReport r3 = calibrated.observe(testing::observation(5e5, 20, 20), {in});
  CHECK(calibrated.memory().depth_ratio_points.size() == 1);
  CHECK(r3.forecast.depth_inspections == 1);
}

TEST_CASE("depth calibration: the calibrated depth is stored in the predictions view", "[model][depth_calibration][storage]") {
  const std::filesystem::path db =
      std::filesystem::temp_directory_path() / ("gearwatch-depth-calibration-" + std::to_string(::getpid()) + ".db");
  std::filesystem::remove(db);
  storage::ModelRunResult m;
  m.has_record = false;
  m.gear_pair = 0;
  m.report.advanced = true;
  m.report.observation = testing::observation(1e6, 20, 20);
  Forecast& f = m.report.forecast;
  f.valid = true;
  f.depth_mean_m = 24e-6, f.depth_low_m = 20e-6, f.depth_high_m = 29e-6;
  f.depth_inspections = 2, f.depth_ratio = 1.2, f.depth_ratio_log_sd = 0.05;
  storage::ModelRunResult plain = m;
  plain.report.forecast.depth_inspections = 0, plain.report.forecast.depth_ratio = 0, plain.report.forecast.depth_ratio_log_sd = 0;
  {
    storage::StorageWriter writer(storage::WriterOptions{db.string(), 5000, 256, 512, 200, 30000, 60.0, {}, std::nullopt});
    writer.start();
    writer.submit(m);
    writer.submit(plain);
    writer.stop();
  }
  {
    storage::Database d(db.string(), storage::Database::Mode::read_only);
    storage::Statement s(d, "SELECT wear_mean_estimate_m, wear_depth_ratio, wear_depth_ratio_log_sd, wear_depth_inspections"
                            " FROM predictions ORDER BY run_id");
    REQUIRE(s.step());
    CHECK(s.get_double(0) == 24e-6);
    CHECK(s.get_double(1) == 1.2);
    CHECK(s.get_double(2) == 0.05);
    CHECK(s.get_int(3) == 2);
    REQUIRE(s.step());   // without depth inspections: NULL
    for (int c = 0; c < 4; ++c) CHECK(s.is_null(c));
  }
  std::filesystem::remove(db);
}

// The rate read from two inspections' increments (docs/model.md, "Depth calibration"). A truth
// that is the model's path scaled by a trending ratio: D_t = c D_m + b (ρ = c + b / D_m trends from
// below towards c), D_m = a N^p. The increments give c exactly, and the crossing follows.
TEST_CASE("depth calibration: the rate from two inspections gives a trending truth's crossing exactly",
          "[model][depth_calibration]") {
  const double a = 2e-10, p = 0.8, c = 2.6, b = -12e-6, limit = 100e-6;
  auto model = [&](double n) { return a * std::pow(n, p); };
  auto truth = [&](double n) { return c * model(n) + b; };
  const double n1 = 0.8e6, n2 = 1.6e6, now = 2.2e6;
  const DepthRatioMeasurement m1 = depth_ratio_measurement(1, n1, truth(n1), model(n1), 0.05);
  const DepthRatioMeasurement m2 = depth_ratio_measurement(2, n2, truth(n2), model(n2), 0.05);
  REQUIRE(std::exp(m2.log_ratio) - std::exp(m1.log_ratio) > 0.1);   // ρ trends: "ρ constant" fails
  const RateReading r = depth_rate_reading(m1, m2);
  REQUIRE(r.valid);
  CHECK(std::exp(r.log_mean) == Approx(c).epsilon(1e-12));
  // Its variance from the two relative errors, and its derivatives in the readings.
  const double d1 = truth(n1), d2 = truth(n2), dd = d2 - d1, s2 = 0.05 * 0.05;
  CHECK(r.var == Approx(std::log1p(s2 * (d1 * d1 + d2 * d2) / (dd * dd))).epsilon(1e-9));
  CHECK(r.dk_dz_to == Approx(d2 / dd).epsilon(1e-12));
  CHECK(r.dk_dz_from == Approx(-d1 / dd).epsilon(1e-12));
  // The level now read exactly, the rate exactly: the model's depth at which the truth crosses is
  // (limit − b) / c, and the model reaches it at the truth's crossing.
  const LevelRate exact{std::log(truth(now) / model(now)), 0, r.log_mean, 0, 0};
  const double t = truth_crossing_threshold(exact, model(now), limit, 0.5);
  const double crossing = std::pow(t / a, 1.0 / p), truth_crossing = std::pow((limit - b) / c / a, 1.0 / p);
  CHECK(crossing == Approx(truth_crossing).epsilon(1e-12));
  // The level alone (the model's path times ρ now) crosses later: at limit / ρ(now).
  const double level_only = std::pow(limit * model(now) / truth(now) / a, 1.0 / p);
  CHECK(level_only > truth_crossing * 1.05);
  // Past the limit: the crossing is now.
  CHECK(truth_crossing_threshold(LevelRate{std::log(2.0 * limit / model(now)), 0, 0, 0, 0}, model(now), limit, 0.5) == model(now));
}

// The depth now carried from the newest inspection by the rate (docs/model.md, "Depth calibration"):
// on a truth c m + b (ρ trending) with exact readings the carried depth is the truth's at every later
// cycle, while ρ held from the newest inspection on the model's path misses it; the delta method's
// variance and covariance in closed form.
TEST_CASE("depth calibration: the depth carried by the rate follows a trending truth exactly", "[model][depth_calibration]") {
  const double a = 2e-10, p = 0.8, c = 2.6, b = -12e-6;
  auto model = [&](double n) { return a * std::pow(n, p); };
  auto truth = [&](double n) { return c * model(n) + b; };
  const double n1 = 0.8e6, n2 = 1.6e6;
  const DepthRatioMeasurement m1 = depth_ratio_measurement(1, n1, truth(n1), model(n1), 0.05);
  const DepthRatioMeasurement m2 = depth_ratio_measurement(2, n2, truth(n2), model(n2), 0.05);
  const RateReading r = depth_rate_reading(m1, m2);
  REQUIRE(r.valid);
  for (double now : {1.6e6, 2.2e6, 3.0e6}) {
    const CarriedDepth d = rate_carried_depth(m2.model_m, m2.log_ratio, 0, r.log_mean, 0, 0, 0, model(now), 0.9);
    REQUIRE(d.valid);
    CHECK(d.estimate_m == Approx(truth(now)).epsilon(1e-12));
    CHECK(d.low_m == Approx(d.estimate_m).epsilon(1e-12));
    CHECK(d.high_m == Approx(d.estimate_m).epsilon(1e-12));
  }
  // ρ held at its newest reading on the model's path: 6 % or more short by 3 M cycles.
  CHECK(std::exp(m2.log_ratio) * model(3.0e6) < 0.94 * truth(3.0e6));
  // Closed form: level 1.5 × 10, increment 2 × (14 − 10): D = 23, w_x = 15/23, w_y = 8/23.
  const CarriedDepth d = rate_carried_depth(10.0, std::log(1.5), 0.01, std::log(2.0), 0.04, 0.005, 0.02, 14.0, 0.9);
  REQUIRE(d.valid);
  const double wx = 15.0 / 23.0, wy = 8.0 / 23.0;
  const double var = wx * wx * 0.01 + wy * wy * (0.04 + 0.02) + 2.0 * wx * wy * 0.005;
  CHECK(d.estimate_m == Approx(23.0).epsilon(1e-12));
  CHECK(d.log_var == Approx(var).epsilon(1e-12));
  CHECK(d.cov_with_rate == Approx(wx * 0.005 + wy * 0.04).epsilon(1e-12));
  CHECK(d.low_m == Approx(23.0 * std::exp(-1.6448536269514722 * std::sqrt(var))).epsilon(1e-9));
  CHECK(d.high_m == Approx(23.0 * std::exp(1.6448536269514722 * std::sqrt(var))).epsilon(1e-9));
  // The model's depth below the newest inspection's, or none there: not carried.
  CHECK_FALSE(rate_carried_depth(10.0, 0, 0, 0, 0, 0, 0, 9.0, 0.9).valid);
  CHECK_FALSE(rate_carried_depth(0.0, 0, 0, 0, 0, 0, 0, 9.0, 0.9).valid);
}

TEST_CASE("depth calibration: the newest inspection pairs with the partner of the smallest variance",
          "[model][depth_calibration]") {
  const std::vector<DepthRatioMeasurement> pts{depth_ratio_measurement(1, 0.5e6, 10e-6, 8e-6, 0.05),
                                               depth_ratio_measurement(2, 1.0e6, 20e-6, 12e-6, 0.05),
                                               depth_ratio_measurement(3, 2.0e6, 50e-6, 20e-6, 0.05),
                                               depth_ratio_measurement(4, 1.8e6, 45e-6, 18e-6, 0.05)};
  // Without the window (no rate change ever significant) the longest increment: (50 − 10) / (20 − 8).
  const RateReading widest = newest_rate_reading(pts, std::numeric_limits<double>::infinity());
  REQUIRE(widest.valid);
  CHECK(widest.to_id == 3);
  CHECK(widest.from_id == 1);
  CHECK(std::exp(widest.log_mean) == Approx(40.0 / 12.0).epsilon(1e-12));
  // With it: [2, 4] (25/6) against [4, 3] (5/2) differs by 0.69 SD and joins; [1, 2] (10/4) against
  // [2, 3] (30/8) by ln 1.5 = 0.405 over an SD of 0.0025 (1 + (20 (1/10 + 1/30))² + (50/30)²), 0.165:
  // 2.46 SDs, a change: the window starts at 2.
  const RateReading r = newest_rate_reading(pts);
  REQUIRE(r.valid);
  CHECK(r.to_id == 3);
  CHECK(r.from_id == 2);
  CHECK(std::exp(r.log_mean) == Approx(30.0 / 8.0).epsilon(1e-12));
  // An increment the errors reversed gives no reading; an old state's reading (no model depth) neither.
  CHECK_FALSE(depth_rate_reading(pts[0], depth_ratio_measurement(5, 1e6, 9e-6, 12e-6, 0.05)).valid);
  DepthRatioMeasurement old = pts[0];
  old.model_m = 0;
  CHECK_FALSE(depth_rate_reading(old, pts[2]).valid);
  // The level's weight on a reading: one reading after a broad prior, walked on: v0 / (v0 + r).
  const LogPosterior prior = shape_range_prior(0, 0, 0.9, 3.0);
  const double rv = log_relative_variance(0.05);
  CHECK(posterior_weight(prior, {pts[2]}, 1e-12, 2.5e6, 3) == Approx(9.0 / (9.0 + rv)).epsilon(1e-6));
  CHECK(posterior_weight(prior, {pts[2]}, 1e-12, 2.5e6, 7) == 0.0);
}

// The rate's window (newest_rate_reading): a truth whose rate over the model's increments steps
// from 2 to 5 between the second and third inspection reads 5 exactly (the widest pair would read the
// mixture 60/15 = 4); a truth at one rate reads it from the oldest partner; and on a truth at one rate
// with independent 2 % readings the change test on three readings cuts the window in 5 % ± 1.5 % of
// 4000 draws (its nominal two-sided level; the delta method's error at a 10-SD increment is small).
TEST_CASE("depth calibration: the rate's window stops at a rate change", "[model][depth_calibration]") {
  auto model = [](double n) { return 10e-6 * n / 1e6; };
  auto stepped = [&](double n) { return n <= 1e6 ? 2.0 * model(n) : 20e-6 + 5.0 * (model(n) - model(1e6)); };
  std::vector<DepthRatioMeasurement> pts;
  for (int k = 1; k <= 4; ++k) pts.push_back(depth_ratio_measurement(k, 0.5e6 * k, stepped(0.5e6 * k), model(0.5e6 * k), 0.05));
  const RateReading r = newest_rate_reading(pts);
  REQUIRE(r.valid);
  CHECK(r.to_id == 4);
  CHECK(r.from_id == 2);
  CHECK(r.log_mean == Approx(std::log(5.0)).epsilon(1e-12));
  CHECK(newest_rate_reading(pts, std::numeric_limits<double>::infinity()).log_mean == Approx(std::log(4.0)).epsilon(1e-12));
  auto trending = [&](double n) { return 2.6 * model(n) + 3e-6; };
  std::vector<DepthRatioMeasurement> one_rate;
  for (int k = 1; k <= 4; ++k) one_rate.push_back(depth_ratio_measurement(k, 0.5e6 * k, trending(0.5e6 * k), model(0.5e6 * k), 0.05));
  const RateReading u = newest_rate_reading(one_rate);
  REQUIRE(u.valid);
  CHECK(u.from_id == 1);
  CHECK(u.log_mean == Approx(std::log(2.6)).epsilon(1e-12));
  std::mt19937_64 rng(77);
  std::normal_distribution<double> n01(0.0, 1.0);
  const double s = 0.02;
  int cut = 0;
  const int draws = 4000;
  for (int k = 0; k < draws; ++k) {
    std::vector<DepthRatioMeasurement> p;
    for (int i = 1; i <= 3; ++i) {
      const double n = 1e6 * i, truth = 2.0 * model(n);
      p.push_back(depth_ratio_measurement(i, n, truth * (1.0 + s * n01(rng)), model(n), s));
    }
    if (newest_rate_reading(p).from_id != 1) ++cut;
  }
  CHECK(static_cast<double>(cut) / draws == Approx(0.05).margin(0.015));
}

TEST_CASE("depth calibration: the crossing threshold's quantiles against a direct sampling", "[model][depth_calibration]") {
  // An independent reference: T = now + max(0, limit − e^x now) / e^y over draws of a correlated (x, y).
  const LevelRate j{std::log(1.6), 0.02, std::log(2.4), 0.05, 0.015};
  const double now = 40e-6, limit = 100e-6;
  std::mt19937_64 rng(41);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<double> ts;
  const double sx = std::sqrt(j.x_var), slope = j.cov / j.x_var, sy = std::sqrt(j.y_var - slope * j.cov);
  for (int k = 0; k < 200000; ++k) {
    const double u = n01(rng), x = j.x_mean + sx * u, y = j.y_mean + slope * sx * u + sy * n01(rng);
    ts.push_back(now + std::max(0.0, limit - std::exp(x) * now) / std::exp(y));
  }
  std::sort(ts.begin(), ts.end());
  for (double q : {0.05, 0.5, 0.95}) {
    const double sampled = ts[static_cast<std::size_t>(q * ts.size())];
    CHECK(truth_crossing_threshold(j, now, limit, q) == Approx(sampled).epsilon(0.005));
  }
  // Where 30 % of the truths are past the limit, the 5 % and 25 % quantiles are now.
  const LevelRate past{std::log(limit / now) - 0.5244 * 0.3, 0.09, 0.0, 0.01, 0.0};
  CHECK(truth_crossing_threshold(past, now, limit, 0.25) == now);
  CHECK(truth_crossing_threshold(past, now, limit, 0.35) > now);
}

TEST_CASE("depth calibration: the rate's crossing interval holds a truth drawn from the model's own assumptions",
          "[model][depth_calibration]") {
  // Truths D_t = c D_m + b with c and b drawn, two inspections reading the truth times (1 + ε), ε
  // normal with the stated SD; the forecast at the second: the level from its reading, the rate
  // from the increment, their covariance from the shared reading. Covered: the truth's crossing
  // depth (limit − b) / c inside the 90 % interval of the threshold.
  std::mt19937_64 rng(20261);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> uc(1.2, 3.0), ub(-8e-6, 5e-6);
  const double a = 2e-10, p = 0.8, sd = 0.05, limit = 100e-6, n1 = 0.8e6, n2 = 1.6e6;
  auto model = [&](double n) { return a * std::pow(n, p); };
  const LogPosterior prior = shape_range_prior(0, 0, 0.9, 10.0);
  const int trials = 4000;
  int covered = 0;
  for (int t = 0; t < trials; ++t) {
    const double c = uc(rng), b = ub(rng);
    const DepthRatioMeasurement m1 = depth_ratio_measurement(1, n1, (c * model(n1) + b) * (1.0 + sd * n01(rng)), model(n1), sd);
    const DepthRatioMeasurement m2 = depth_ratio_measurement(2, n2, (c * model(n2) + b) * (1.0 + sd * n01(rng)), model(n2), sd);
    const RateReading r = depth_rate_reading(m1, m2);
    REQUIRE(r.valid);
    const std::vector<DepthRatioMeasurement> level_points{m2};
    const LogPosterior level = depth_ratio_posterior(prior, level_points, 0.0, n2);
    const double cov = posterior_weight(prior, level_points, 0.0, n2, 2) * m2.var * r.dk_dz_to;
    const LevelRate j{level.mean, level.var, r.log_mean, r.var, cov};
    const double truth = (limit - b) / c;
    if (truth_crossing_threshold(j, model(n2), limit, 0.05) <= truth && truth <= truth_crossing_threshold(j, model(n2), limit, 0.95))
      ++covered;
  }
  // Binomial SD at 4000 trials: 0.47 %; ±1.5 % is over three SDs.
  CHECK(static_cast<double>(covered) / trials == Approx(0.90).margin(0.015));
}

TEST_CASE("depth calibration: a path read again and a rate read at another pace, in closed form", "[model][depth_calibration]") {
  // Along a path 0 → 2 µm over 0 → 1 M cycles: linear between the points.
  const std::vector<PathPoint> path{{0.0, 0.0}, {0.5e6, 1e-6}, {1e6, 2e-6}};
  CHECK(path_mean_at(path, 0.25e6) == Approx(0.5e-6).epsilon(1e-12));
  CHECK(path_mean_at(path, 1e6) == 2e-6);
  CHECK(path_mean_at(path, 1.1e6) < 0);
  // Read against 4 µm, 6 µm measured; against 3 µm the measured 6 µm gives z = ln 2, same variance.
  const DepthRatioMeasurement m = depth_ratio_measurement(5, 1e6, 6e-6, 4e-6, 0.05);
  const DepthRatioMeasurement r = reread(m, 3e-6);
  CHECK(r.log_ratio == Approx(std::log(2.0)).epsilon(1e-12));
  CHECK(r.var == m.var);
  CHECK(r.model_m == 3e-6);
  CHECK(reread(m, 0.0).log_ratio == m.log_ratio);
  // K 1 over (0, 1 M], 3 over (1 M, 2 M]: over [0.5 M, 1.5 M] the mean is 2; past the last stretch its K.
  const std::vector<KStretch> k{{1e6, 1.0}, {2e6, 3.0}};
  CHECK(cycle_mean_k(k, 0.5e6, 1.5e6) == Approx(2.0).epsilon(1e-12));
  CHECK(cycle_mean_k(k, 1.5e6, 2.5e6) == Approx(3.0).epsilon(1e-12));
  // The truth's increment 3 times the model's at K 2: at K 3 the model's increment is 1.5 times as
  // large, the truth's 2 times that.
  RateReading rate;
  rate.valid = true, rate.log_mean = std::log(3.0), rate.var = 0.01;
  const RateReading at = rate_at_pace(rate, 2.0, 3.0);
  CHECK(std::exp(at.log_mean) == Approx(2.0).epsilon(1e-12));
  CHECK(at.var == rate.var);
}

namespace {
/// The combined mean depth of a model run at a fixed K_wear from the pair's start, at each of `at`.
std::vector<double> model_means_at(double k, const std::vector<double>& at) {
  ModelSettings fixed = testing::calibration_case_settings();
  fixed.loop.k_wear_si = k;
  TwinModel m(twin::GearboxParameters{}, fixed, testing::calibration_case_rms);
  std::vector<double> means;
  for (const double n : at) means.push_back(m.observe(testing::observation(n, 20, 20), {}).summary.combined_mean_depth_m);
  return means;
}
}  // namespace

// The model's readings of inspected depths after K_wear updates (docs/model.md, "Depth
// calibration"). The twin's RMS_SA is a stand-in, 1 + mean depth / scale, so RMS_SA picks the
// model's depth and a K_wear update re-runs the path. Two inspections, then an update re-running
// from the pair's start: both readings are read against the new path, which is the path of a model
// run at the new K from the start (same loop, same steps: equal to rounding). Then an update whose
// re-run starts after them: the readings stay, the rate is read against today's pace, κ − ln(K2/K1).
TEST_CASE("depth calibration: inspected depths read against the model's path and pace after K_wear updates",
          "[model][depth_calibration]") {
  ModelSettings s = testing::calibration_case_settings();
  s.update_k_wear = true;
  s.commissioning_records = 0;
  const double n_a = 4e5, n_b = 8e5, n_3 = 1e6, n_4 = 1.4e6;
  const std::vector<double> m0 = model_means_at(s.loop.k_wear_si, {n_a, n_b, n_3});
  const double scale = m0[2];
  REQUIRE(scale > 0);
  auto rms = [scale](const WearState& st, const twin::OperatingPoint&) { return 1.0 + summarise(st).combined_mean_depth_m / scale; };
  TwinModel model(twin::GearboxParameters{}, s, rms);
  Inspection a, b;
  a.id = 1, a.cycles = n_a, a.wear_depth_m = 2.0 * m0[0];
  b.id = 2, b.cycles = n_b, b.wear_depth_m = 2.0 * m0[1] + 0.4 * (m0[1] - m0[0]);   // the truth's increment 2.4 x the model's
  model.observe(testing::observation(n_a, 20, 20), {a});
  model.observe(testing::observation(n_b, 20, 20), {a, b});
  // Against the path at K0: as read.
  REQUIRE(model.memory().depth_ratio_points.size() == 2);
  CHECK(model.memory().depth_ratio_points[1].model_m == Approx(m0[1]).epsilon(1e-12));
  // At n_3 RMS_SA says half the model's depth: K_wear falls, re-run from the start.
  const ModelRunReport r3 = model.observe(testing::observation(n_3, 20, 20, 1.5), {a, b});
  const double k1 = model.memory().k_wear_si;
  REQUIRE(k1 < 0.7 * s.loop.k_wear_si);
  REQUIRE(std::abs(r3.summary.combined_mean_depth_m / m0[2] - 0.5) < 0.05);
  const std::vector<double> m1 = model_means_at(k1, {n_a, n_b, n_3, n_4});
  const auto& p = model.memory().depth_ratio_points;
  REQUIRE(p.size() == 2);
  CHECK(p[0].model_m == Approx(m1[0]).epsilon(1e-9));
  CHECK(p[1].model_m == Approx(m1[1]).epsilon(1e-9));
  CHECK(p[0].log_ratio == Approx(std::log(*a.wear_depth_m / m1[0])).epsilon(1e-9));
  CHECK(p[1].log_ratio == Approx(std::log(*b.wear_depth_m / m1[1])).epsilon(1e-9));
  const double kappa1 = std::log((*b.wear_depth_m - *a.wear_depth_m) / (m1[1] - m1[0]));
  RateReading rate = model.wear_rate_reading();
  REQUIRE(rate.valid);
  CHECK(rate.log_mean == Approx(kappa1).epsilon(1e-9));
  // At n_4 RMS_SA says 1.5 x the model's depth there: K_wear rises, re-run from n_3 (after both).
  model.observe(testing::observation(n_4, 20, 20, 1.0 + 1.5 * m1[3] / scale), {a, b});
  const double k2 = model.memory().k_wear_si;
  REQUIRE(k2 > 1.3 * k1);
  CHECK(model.memory().depth_ratio_points[1].model_m == Approx(m1[1]).epsilon(1e-9));   // not re-run there
  rate = model.wear_rate_reading();
  REQUIRE(rate.valid);
  CHECK(rate.log_mean == Approx(kappa1 - std::log(k2 / k1)).epsilon(1e-9));
}

}  // namespace test_depth_calibration

namespace test_depth_calibration {

TEST_CASE("depth calibration: the K_wear history from the pair's start, split at an update's anchor", "[model][depth_calibration]") {
  std::vector<KStretch> h;
  extend_k_history(h, 1e6, 1.0);
  extend_k_history(h, 2e6, 1.0);   // the same K: one stretch
  extend_k_history(h, 3e6, 2.0);
  REQUIRE(h.size() == 2);
  CHECK(h[0].end_cycles == 2e6);
  CHECK(h[1].end_cycles == 3e6);
  // An update of 4 from 1.5 M on: (0, 1.5 M] at 1, (1.5 M, 3 M] at 4.
  set_k_from(h, 1.5e6, 4.0);
  REQUIRE(h.size() == 2);
  CHECK(h[0].end_cycles == 1.5e6);
  CHECK(h[0].k == 1.0);
  CHECK(h[1].end_cycles == 3e6);
  CHECK(h[1].k == 4.0);
  // Over [1 M, 2 M]: half at 1, half at 4.
  CHECK(cycle_mean_k(h, 1e6, 2e6) == Approx(2.5).epsilon(1e-12));
  // An update at a stretch's end splits nothing; one back to the older K joins the neighbours.
  set_k_from(h, 1.5e6, 1.0);
  REQUIRE(h.size() == 1);
  CHECK(h[0].end_cycles == 3e6);
  CHECK(h[0].k == 1.0);
}

// As the case above, but a pitting calibration from two pitted-area inspections at n_3 moves both
// anchors there (as the bench's 4 % inspection does), so the intervals before them are pruned: the
// pace the rate was read at is still the K its path ran at between the inspections, κ − ln(K2/K1).
TEST_CASE("depth calibration: the rate is read at today's pace after the intervals before both anchors are pruned",
          "[model][depth_calibration]") {
  ModelSettings s = testing::calibration_case_settings();
  s.update_k_wear = true;
  s.update_k_pitting = true;
  s.commissioning_records = 0;
  const double n_a = 4e5, n_b = 8e5, n_3 = 1e6, n_4 = 1.4e6;
  const std::vector<double> m0 = model_means_at(s.loop.k_wear_si, {n_a, n_b, n_3});
  const double scale = m0[2];
  REQUIRE(scale > 0);
  auto rms = [scale](const WearState& st, const twin::OperatingPoint&) { return 1.0 + summarise(st).combined_mean_depth_m / scale; };
  TwinModel model(twin::GearboxParameters{}, s, rms);
  Inspection a, b;
  a.id = 1, a.cycles = n_a, a.wear_depth_m = 2.0 * m0[0];
  b.id = 2, b.cycles = n_b, b.wear_depth_m = 2.0 * m0[1] + 0.4 * (m0[1] - m0[0]);
  Inspection p1, p2;
  p1.id = 3, p1.cycles = n_a, p1.pitted_area = 0.01;
  p2.id = 4, p2.cycles = n_3, p2.pitted_area = 0.04;
  model.observe(testing::observation(n_a, 20, 20, {}, 0.004), {a, p1});
  model.observe(testing::observation(n_b, 20, 20, {}, 0.01), {a, b, p1});
  model.observe(testing::observation(n_3, 20, 20, 1.5, 0.02), {a, b, p1, p2});
  const double k1 = model.memory().k_wear_si;
  REQUIRE(k1 < 0.7 * s.loop.k_wear_si);
  const std::vector<double> m1 = model_means_at(k1, {n_a, n_b, n_3, n_4});
  const double kappa1 = std::log((*b.wear_depth_m - *a.wear_depth_m) / (m1[1] - m1[0]));
  REQUIRE(model.wear_rate_reading().log_mean == Approx(kappa1).epsilon(1e-9));
  model.observe(testing::observation(n_4, 20, 20, 1.0 + 1.5 * m1[3] / scale, 0.03), {a, b, p1, p2});
  const double k2 = model.memory().k_wear_si;
  REQUIRE(k2 > 1.3 * k1);
  // The case this is about: both anchors past the inspections, the intervals between them gone.
  REQUIRE(model.memory().wear_anchor.state.cycles >= n_3);
  REQUIRE(model.memory().pitting_anchor.state.cycles >= n_3);
  REQUIRE((model.memory().intervals.empty() || model.memory().intervals.front().end_cycles > n_b));
  const RateReading rate = model.wear_rate_reading();
  REQUIRE(rate.valid);
  CHECK(rate.log_mean == Approx(kappa1 - std::log(k2 / k1)).epsilon(1e-9));
}

}  // namespace test_depth_calibration
