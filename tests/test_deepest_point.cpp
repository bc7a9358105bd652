// The deepest wear point from inspected profiles (docs/model.md, "Deepest point") against known
// answers: the reading of ln P = ln(deepest / mean) and its variance, the prior from the
// profile-shape term's range, the closed-form posterior, the factor on the model's deepest point,
// the interval's coverage where the truth is the model's own assumptions, the model's wear
// crossing at the limit over ρ P / its own peak ratio, and the inspections table's new columns.
#include <cmath>
#include <random>
#include <vector>

#include <nlohmann/json.hpp>

#include <catch2/catch.hpp>

#include "command_runner.hpp"
#include "gearwatch/storage/inspections.hpp"
#include "gearwatch/storage/model_history.hpp"
#include "gearwatch/storage/writer.hpp"
#include "gearwatch/storage/schema.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/wear/depth_calibration.hpp"
#include "gearwatch/wear/updating.hpp"
#include "model_observation.hpp"
#include "temp_dir.hpp"

namespace test_deepest_point {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::wear;

namespace {

constexpr double kZ90 = 1.6448536269514722;   // the normal's 95 % point: a central 90 %

}  // namespace

TEST_CASE("deepest point: a reading of ln P carries both depths' relative variance", "[model][deepest_point]") {
  const DepthRatioMeasurement m = peak_ratio_measurement(4, 2e6, 72e-6, 20e-6, 0.05);
  CHECK(m.inspection_id == 4);
  CHECK(m.cycles == 2e6);
  CHECK(m.log_ratio == Approx(std::log(3.6)).epsilon(1e-15));
  CHECK(m.var == Approx(2.0 * std::log1p(0.0025)).epsilon(1e-14));
}

TEST_CASE("deepest point: the prior's central interval is the profile-shape term's range", "[model][deepest_point]") {
  const LogPosterior p = peak_ratio_prior(1.2, 3.56, 0.90, 4.6);
  REQUIRE(p.valid);
  CHECK(p.mean - kZ90 * std::sqrt(p.var) == Approx(std::log(1.2)).epsilon(1e-12));
  CHECK(p.mean + kZ90 * std::sqrt(p.var) == Approx(std::log(3.56)).epsilon(1e-12));
  const LogPosterior reversed = peak_ratio_prior(3.56, 1.2, 0.90, 4.6);   // the order does not matter
  CHECK(reversed.mean == Approx(p.mean).epsilon(1e-14));
  CHECK(reversed.var == Approx(p.var).epsilon(1e-14));
  // No concentrated shape read: centred on the model's own, as unknown as the fallback says.
  const LogPosterior none = peak_ratio_prior(1.2, 0.0, 0.90, 4.6);
  CHECK(none.mean == Approx(std::log(1.2)).epsilon(1e-15));
  CHECK(none.var == Approx(4.6 * 4.6).epsilon(1e-15));
}

TEST_CASE("deepest point: the posterior of ln P in closed form", "[model][deepest_point]") {
  const LogPosterior prior = peak_ratio_prior(1.2, 3.56, 0.90, 4.6);
  const double z1 = std::log(3.1), r1 = 2 * std::log1p(0.05 * 0.05), z2 = std::log(3.4), r2 = 2 * std::log1p(0.08 * 0.08);
  const std::vector<DepthRatioMeasurement> ms{peak_ratio_measurement(1, 1e6, 31e-6, 10e-6, 0.05),
                                              peak_ratio_measurement(2, 1e6, 68e-6, 20e-6, 0.08)};
  const LogPosterior p = depth_ratio_posterior(prior, ms, 0.0, 2e6);
  const double var = 1.0 / (1.0 / prior.var + 1.0 / r1 + 1.0 / r2);
  CHECK(p.var == Approx(var).epsilon(1e-12));
  CHECK(p.mean == Approx(var * (prior.mean / prior.var + z1 / r1 + z2 / r2)).epsilon(1e-12));
}

TEST_CASE("deepest point: the factor on the model's deepest point and its interval", "[model][deepest_point]") {
  LogPosterior rho, peak;
  rho.valid = peak.valid = true;
  rho.mean = std::log(1.5), rho.var = 0.0009;
  peak.mean = std::log(3.0), peak.var = 0.0016;
  const DeepestFactor k = deepest_point_factor(rho, peak, 1.25, 0.90);
  CHECK(k.nominal == Approx(1.5 * 3.0 / 1.25).epsilon(1e-12));
  CHECK(k.low == Approx(3.6 * std::exp(-kZ90 * 0.05)).epsilon(1e-12));    // sqrt(0.0009 + 0.0016) = 0.05
  CHECK(k.high == Approx(3.6 * std::exp(kZ90 * 0.05)).epsilon(1e-12));
}

TEST_CASE("deepest point: the 90 % intervals hold truths drawn from the model's own assumptions",
          "[model][deepest_point]") {
  // ln ρ and ln P drawn from their priors, each walking with q; every inspection reads the true mean
  // and the true deepest point, each times (1 + ε), ε normal with the stated SD, independent.
  std::mt19937_64 rng(36050);
  std::normal_distribution<double> n01(0.0, 1.0);
  const double q = std::pow(std::log(1.5), 2) / 1e6, sd = 0.05, model_mean = 20e-6, model_peak = 1.2, now = 2.5e6;
  const LogPosterior rho_prior = shape_range_prior(1.6, 0.03, 0.90, 4.6), peak_prior = peak_ratio_prior(model_peak, 3.56, 0.90, 4.6);
  const std::vector<double> at{0.8e6, 1.6e6};
  const int trials = 4000;
  int peak_covered = 0, deepest_covered = 0;
  for (int t = 0; t < trials; ++t) {
    double log_rho = rho_prior.mean + std::sqrt(rho_prior.var) * n01(rng);
    double log_peak = peak_prior.mean + std::sqrt(peak_prior.var) * n01(rng), last = at.front();
    std::vector<DepthRatioMeasurement> rho_ms, peak_ms;
    for (std::size_t k = 0; k < at.size(); ++k) {
      log_rho += std::sqrt(q * (at[k] - last)) * n01(rng);
      log_peak += std::sqrt(q * (at[k] - last)) * n01(rng);
      last = at[k];
      const double mean = model_mean * std::exp(log_rho);
      const double mean_read = mean * (1.0 + sd * n01(rng)), deepest_read = mean * std::exp(log_peak) * (1.0 + sd * n01(rng));
      const auto id = static_cast<std::int64_t>(k + 1);
      rho_ms.push_back(depth_ratio_measurement(id, at[k], mean_read, model_mean, sd));
      peak_ms.push_back(peak_ratio_measurement(id, at[k], deepest_read, mean_read, sd));
    }
    log_rho += std::sqrt(q * (now - last)) * n01(rng);
    log_peak += std::sqrt(q * (now - last)) * n01(rng);
    const LogPosterior pr = depth_ratio_posterior(rho_prior, rho_ms, q, now), pp = depth_ratio_posterior(peak_prior, peak_ms, q, now);
    const double half = kZ90 * std::sqrt(pp.var);
    if (std::abs(log_peak - pp.mean) <= half) ++peak_covered;
    const DeepestFactor f = deepest_point_factor(pr, pp, model_peak, 0.90);
    const double truth = std::exp(log_rho + log_peak) / model_peak;
    if (f.low <= truth && truth <= f.high) ++deepest_covered;
  }
  // Binomial SD at 4000 trials: 0.47 %; ±1.5 % is over three SDs.
  CHECK(static_cast<double>(peak_covered) / trials == Approx(0.90).margin(0.015));
  // The factor takes ln ρ and ln P as independent; the shared mean reading correlates them
  // negatively, so the sum's interval is at least nominal (never below it by more than the noise).
  CHECK(static_cast<double>(deepest_covered) / trials >= 0.90 - 0.015);
}

TEST_CASE("deepest point: the model's wear crossing follows the inspected deepest point", "[model][deepest_point]") {
  const ModelSettings s = testing::calibration_case_settings();
  const auto obs = testing::observation(4e5, 20, 20);
  TwinModel plain(twin::GearboxParameters{}, s, testing::calibration_case_rms);
  const ModelRunReport r0 = plain.observe(obs, {});
  const double mean = r0.summary.combined_mean_depth_m, model_peak = r0.max_depth_m / mean;
  REQUIRE(mean > 0);
  REQUIRE(model_peak > 1);

  Inspection in;
  in.id = 5;
  in.cycles = 4e5;
  in.wear_depth_m = 1.5 * mean;
  in.wear_depth_max_m = 1.5 * mean * 3.0;
  in.wear_depth_relative_sd = 0.1;   // this inspection's own, not the setting's
  TwinModel calibrated(twin::GearboxParameters{}, s, testing::calibration_case_rms);
  const ModelRunReport r1 = calibrated.observe(obs, {in});
  REQUIRE(r1.forecast.valid);
  // ρ: prior N(0, fallback²) (no shape read), one reading of ln 1.5 with variance ln(1.01).
  const double v0 = s.prior_log_k_wear_sd * s.prior_log_k_wear_sd, r = std::log1p(0.01);
  const double vr = 1.0 / (1.0 / v0 + 1.0 / r), mr = vr * std::log(1.5) / r;
  CHECK(r1.forecast.depth_ratio == Approx(std::exp(mr)).epsilon(1e-9));
  CHECK(r1.forecast.depth_ratio_log_sd == Approx(std::sqrt(vr)).epsilon(1e-9));
  // P: prior N(ln model_peak, fallback²), one reading of ln 3 with variance 2 ln(1.01).
  const double vp = 1.0 / (1.0 / v0 + 1.0 / (2 * r)), mp = vp * (std::log(model_peak) / v0 + std::log(3.0) / (2 * r));
  CHECK(r1.forecast.peak_inspections == 1);
  CHECK(r1.forecast.peak_ratio == Approx(std::exp(mp)).epsilon(1e-9));
  CHECK(r1.forecast.peak_ratio_log_sd == Approx(std::sqrt(vp)).epsilon(1e-9));
  // The nominal crossing is the model's deepest point crossing limit / (ρ P / model_peak).
  ModelSettings scaled = s;
  scaled.wear_limit_m = s.wear_limit_m / (std::exp(mr) * std::exp(mp) / model_peak);
  TwinModel reference(twin::GearboxParameters{}, scaled, testing::calibration_case_rms);
  const ModelRunReport r2 = reference.observe(obs, {});
  REQUIRE(r1.forecast.wear.cycles_left);
  REQUIRE(r2.forecast.wear.cycles_left);
  CHECK(*r1.forecast.wear.cycles_left == Approx(*r2.forecast.wear.cycles_left).epsilon(1e-9));
  REQUIRE(r1.forecast.wear.cycles_left_low);
  REQUIRE(r1.forecast.wear.cycles_left_high);
  CHECK(*r1.forecast.wear.cycles_left_low <= *r1.forecast.wear.cycles_left);
  CHECK(*r1.forecast.wear.cycles_left <= *r1.forecast.wear.cycles_left_high);

  // A deepest point without the same inspection's mean gives no ratio and is said once.
  Inspection alone;
  alone.id = 6;
  alone.cycles = 4e5;
  alone.wear_depth_max_m = 50e-6;
  TwinModel without(twin::GearboxParameters{}, s, testing::calibration_case_rms);
  const ModelRunReport r3 = without.observe(obs, {alone});
  CHECK(r3.forecast.peak_inspections == 0);
  CHECK(r3.forecast.depth_inspections == 0);
  CHECK(r3.detail.find("inspection 6: deepest wear point not used") != std::string::npos);
  CHECK(*r3.forecast.wear.cycles_left == Approx(*r0.forecast.wear.cycles_left).epsilon(1e-12));   // nothing changes
  const ModelRunReport r4 = without.observe(testing::observation(5e5, 20, 20), {alone});
  CHECK(r4.detail.find("inspection 6") == std::string::npos);
}

TEST_CASE("deepest point: the inspections table stores the deepest point and the depths' SD", "[storage][deepest_point]") {
  testing::TempDir dir("deepest-point");
  storage::Database db((dir / "h.db").string());
  // A database at the schema before the columns (16): its inspections read without a deepest point.
  storage::migrate_to_version(db, 16);
  db.exec("INSERT INTO inspections(cycles, pitted_area_fraction, wear_depth_m, note, gear_pair) VALUES (1e6, NULL, 12e-6, NULL, 0)");
  auto old_rows = storage::load_inspections(db);
  REQUIRE(old_rows.size() == 1);
  CHECK_FALSE(old_rows[0].wear_depth_max_m.has_value());
  storage::open_and_migrate(db);
  storage::NewInspection in;
  in.cycles = 2e6;
  in.wear_depth_m = 20e-6;
  in.wear_depth_max_m = 71e-6;
  in.wear_depth_relative_sd = 0.07;
  storage::insert_inspection(db, in);
  const auto rows = storage::load_gear_pair_inspections(db, 0);
  REQUIRE(rows.size() == 2);
  CHECK(rows[0].wear_depth_m == 12e-6);   // the old row survives the migration, without the new values
  CHECK_FALSE(rows[0].wear_depth_max_m.has_value());
  CHECK_FALSE(rows[0].wear_depth_relative_sd.has_value());
  CHECK(rows[1].wear_depth_max_m == 71e-6);
  CHECK(rows[1].wear_depth_relative_sd == 0.07);
}

namespace {

gearwatch::testing::CommandResult deepest_point_cli(const std::string& args) {
  return gearwatch::testing::run_command(std::string(GEARWATCH_BINARY) + " " + args);
}

// A model run with ρ and P posteriors set to known numbers (or none), as the model thread submits it.
storage::ModelRunResult deepest_point_run(double cycles, int depth_inspections, int peak_inspections) {
  storage::ModelRunResult m;
  m.has_record = false;
  m.gear_pair = 0;
  m.report.advanced = true;
  m.report.observation = testing::observation(cycles, 20, 20);
  Forecast& f = m.report.forecast;
  f.valid = true;
  f.depth_mean_m = 24e-6, f.depth_low_m = 20e-6, f.depth_high_m = 29e-6;
  f.depth_inspections = depth_inspections, f.depth_ratio = 1.2, f.depth_ratio_log_sd = 0.05;
  f.peak_inspections = peak_inspections, f.peak_ratio_log_mean = std::log(3.25), f.peak_ratio_log_sd = 0.11;
  f.peak_ratio = std::exp(f.peak_ratio_log_mean);
  return m;
}

}  // namespace

TEST_CASE("deepest point: each model run stores ln P's posterior beside rho's and query shows both", "[storage][deepest_point][cli]") {
  testing::TempDir dir("deepest-point-runs");
  const std::string db = (dir / "h.db").string();
  {
    storage::StorageWriter writer(storage::WriterOptions{db, 5000, 256, 512, 200, 30000, 60.0, {}, std::nullopt});
    writer.start();
    writer.submit(deepest_point_run(1e6, 2, 2));
    writer.submit(deepest_point_run(2e6, 1, 0));   // ρ without an inspected deepest point
    writer.stop();
  }
  {
    storage::Database d(db, storage::Database::Mode::read_only);
    const auto c = storage::load_run_calibration(d, 1);
    REQUIRE(c);
    CHECK(c->depth_ratio == 1.2);
    CHECK(c->depth_inspections == 2);
    CHECK(c->peak_ratio_log_mean == std::log(3.25));
    CHECK(c->peak_ratio_log_sd == 0.11);
    REQUIRE(c->peak_ratio);
    CHECK(*c->peak_ratio == Approx(3.25).epsilon(1e-12));   // exp of ln P's mean
    CHECK(c->peak_inspections == 2);
    const auto plain = storage::load_run_calibration(d, 2);
    REQUIRE(plain);
    CHECK(plain->depth_ratio == 1.2);
    CHECK_FALSE(plain->peak_ratio.has_value());
    CHECK_FALSE(plain->peak_ratio_log_mean.has_value());
    CHECK_FALSE(plain->peak_inspections.has_value());
    CHECK_FALSE(storage::load_run_calibration(d, 3).has_value());
  }
  // Through the binary: `query predictions` lists ρ's and P's columns after the old ones.
  const auto q = deepest_point_cli("query predictions --db " + db + " --format json");
  REQUIRE(q.status == 0);
  const auto rows = nlohmann::json::parse(q.out);
  REQUIRE(rows.size() == 2);
  CHECK(rows[0]["wear_depth_ratio"] == 1.2);
  CHECK(rows[0]["wear_depth_ratio_log_sd"] == 0.05);
  CHECK(rows[0]["wear_depth_inspections"] == 2);
  CHECK(rows[0]["wear_peak_ratio_log_mean"].get<double>() == Approx(std::log(3.25)).epsilon(1e-12));
  CHECK(rows[0]["wear_peak_ratio_log_sd"] == 0.11);
  CHECK(rows[0]["wear_peak_ratio"].get<double>() == Approx(3.25).epsilon(1e-12));
  CHECK(rows[0]["wear_peak_inspections"] == 2);
  CHECK(rows[1]["wear_peak_ratio"].is_null());
  CHECK(rows[1]["wear_peak_inspections"].is_null());
  const auto csv = deepest_point_cli("query predictions --db " + db + " --format csv");
  REQUIRE(csv.status == 0);
  const std::string header = csv.out.substr(0, csv.out.find('\n'));
  CHECK(header.find("forecast_evidence,wear_mean_estimate_m,wear_depth_ratio,wear_depth_ratio_log_sd,wear_depth_inspections,"
                    "wear_peak_ratio_log_mean,wear_peak_ratio_log_sd,wear_peak_ratio,wear_peak_inspections") != std::string::npos);
}

TEST_CASE("deepest point: query lists the new columns and reads older databases with them empty", "[storage][deepest_point][cli]") {
  testing::TempDir dir("deepest-point-query");
  const std::string db = (dir / "h.db").string();
  {
    storage::Database d(db);   // `inspect` writes into an existing history only (no records: at 0 cycles)
    storage::open_and_migrate(d);
  }
  const auto ins = deepest_point_cli("inspect --db " + db + " --cycles 0 --wear-depth 21e-6 --wear-depth-max 68e-6 --depth-sd 0.06");
  INFO(ins.err);
  REQUIRE(ins.status == 0);
  const auto q = deepest_point_cli("query inspections --db " + db + " --format json");
  REQUIRE(q.status == 0);
  const auto rows = nlohmann::json::parse(q.out);
  REQUIRE(rows.size() == 1);
  CHECK(rows[0]["wear_depth_m"] == 21e-6);
  CHECK(rows[0]["wear_depth_max_m"] == 68e-6);
  CHECK(rows[0]["wear_depth_relative_sd"] == 0.06);
  // A database left at schema 16 (opened read-only, never migrated): both views still answer,
  // the columns a later schema added read as empty.
  const std::string old_db = (dir / "old.db").string();
  {
    storage::Database d(old_db);
    storage::migrate_to_version(d, 16);
    d.exec("INSERT INTO inspections(cycles, pitted_area_fraction, wear_depth_m, note, gear_pair) VALUES (1e6, NULL, 12e-6, NULL, 0)");
    d.exec("INSERT INTO model_runs(gear_pair, cycles, advanced, interval_coverage, wear_depth_ratio) VALUES (0, 1e6, 1, 0.9, 1.1)");
  }
  const auto qi = deepest_point_cli("query inspections --db " + old_db + " --format json");
  REQUIRE(qi.status == 0);
  const auto old_rows = nlohmann::json::parse(qi.out);
  REQUIRE(old_rows.size() == 1);
  CHECK(old_rows[0]["wear_depth_m"] == 12e-6);
  CHECK(old_rows[0]["wear_depth_max_m"].is_null());
  const auto qp = deepest_point_cli("query predictions --db " + old_db + " --format json");
  REQUIRE(qp.status == 0);
  const auto old_pred = nlohmann::json::parse(qp.out);
  REQUIRE(old_pred.size() == 1);
  CHECK(old_pred[0]["wear_depth_ratio"] == 1.1);
  CHECK(old_pred[0]["wear_peak_ratio"].is_null());
}

}  // namespace test_deepest_point
