// The forecast's interval (issue 34 items 2 and 3) against known answers: the conjugate normal
// update, K_pitting's uncertainty against finite differences of Eq. 7.8's closed form, the
// one-inspection ICS2 scale on an exact linear series, the interval's coverage where the truth is
// the model itself, the chi-square widening, and the rule that no interval excludes a limit the
// measured estimate has reached.
#include "gearwatch/wear/forecast_intervals.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>

#include <catch2/catch.hpp>

#include "gearwatch/dsp/wear_mechanism.hpp"
#include "gearwatch/wear/updating.hpp"
#include "model_observation.hpp"

namespace test_forecast_intervals {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::wear;

namespace {

using gearwatch::testing::observation;

bool has_flag(const Forecast& f, ForecastFlag flag) { return std::count(f.flags.begin(), f.flags.end(), flag) > 0; }

// The binomial SD of a proportion p over n draws.
double binomial_sd(double p, int n) { return std::sqrt(p * (1 - p) / n); }

}  // namespace

TEST_CASE("forecast intervals: the flags have distinct tokens", "[model][updating][intervals]") {
  std::set<std::string> t;
  for (auto f : kAllForecastFlags) t.insert(to_string(f));
  CHECK(t.size() == kAllForecastFlags.size());
  CHECK_FALSE(t.count("unknown"));
}

TEST_CASE("forecast intervals: the filter step is the conjugate normal update, the random walk adds q dN",
          "[model][updating][intervals]") {
  // Closed form: var' = 1 / (1/4 + 1/1) = 0.8, mean' = 0.8 (1/4 + 3/1) = 2.6.
  const LogPosterior prior{true, 1.0, 4.0, 0.0};
  const LogPosterior post = conjugate_update(prior, 3.0, 1.0);
  CHECK(post.var == Approx(0.8).epsilon(1e-14));
  CHECK(post.mean == Approx(2.6).epsilon(1e-14));
  // Inside the gate (innovation 2 / sqrt(5) = 0.89 SD) the filter is exactly that update.
  const FilterStep s = filter_update(prior, 3.0, 1.0, 3.0);
  CHECK_FALSE(s.inflated);
  CHECK(s.innovation_sd == Approx(2.0 / std::sqrt(5.0)).epsilon(1e-14));
  CHECK(s.posterior.mean == post.mean);
  CHECK(s.posterior.var == post.var);
  // Beyond it (1 / sqrt(0.02) = 7.1 SD) the prior variance becomes 1² − 0.01 = 0.99 first.
  const FilterStep jump = filter_update(LogPosterior{true, 0.0, 0.01, 0.0}, 1.0, 0.01, 3.0);
  CHECK(jump.inflated);
  const double v = 1.0 / (1.0 / 0.99 + 1.0 / 0.01);
  CHECK(jump.posterior.var == Approx(v).epsilon(1e-14));
  CHECK(jump.posterior.mean == Approx(v * (1.0 / 0.01)).epsilon(1e-14));
  // No prior yet: the measurement is the belief.
  const LogPosterior first = conjugate_update(LogPosterior{}, -5.0, 0.3);
  CHECK(first.valid);
  CHECK(first.mean == -5.0);
  CHECK(first.var == 0.3);
  // The random walk: var += q (N − N_p), never backwards.
  const LogPosterior later = predict(LogPosterior{true, 0.0, 0.1, 1e5}, 3e5, 2e-7);
  CHECK(later.var == Approx(0.1 + 2e-7 * 2e5).epsilon(1e-14));
  CHECK(later.cycles == 3e5);
  CHECK(predict(later, 2e5, 2e-7).var == later.var);
  // The path mean's moments against a direct quadrature of E[A] = (1/T) ∫ e^{q t / 2} dt and
  // E[A²] = (2/T²) ∫_0^T ∫_0^s e^{q (3u + s) / 2} du ds (midpoint rule, 2000², error ~1e-7).
  for (const double x : {1e-7, 0.05, 0.48, 1.5}) {
    const int n = 2000;
    double m1 = 0, m2 = 0;
    for (int i = 0; i < n; ++i) {
      const double s_ = (i + 0.5) / n;
      m1 += std::exp(x * s_ / 2) / n;
      for (int j = 0; j < n; ++j) {
        const double u = (j + 0.5) / n * s_;
        m2 += 2.0 * std::exp(x * (3 * u + s_) / 2) * s_ / n / n;
      }
    }
    const PathMeanMoments pm = path_mean_moments(x / 1e6, 1e6);
    const double var = std::log(m2 / (m1 * m1));
    INFO("x = " << x);
    CHECK(pm.log_var == Approx(var).epsilon(1e-5).margin(1e-12));
    CHECK(pm.log_mean == Approx(std::log(m1) - var / 2).epsilon(1e-5).margin(1e-12));
  }
  // The interval: mean + μ ± z_0.95 sqrt(var + σ²), z_0.95 = 1.6448536269514722.
  const LogInterval li = log_interval(LogPosterior{true, 2.0, 0.04, 0.0}, 3e-7, 1e6, 1.5);
  const PathMeanMoments pm = path_mean_moments(3e-7, 1e6);
  const double sd = 1.5 * std::sqrt(0.04 + pm.log_var);
  CHECK(li.sd == Approx(sd).epsilon(1e-14));
  CHECK(li.high == Approx(2.0 + pm.log_mean + 1.6448536269514722 * sd).epsilon(1e-12));
  CHECK(li.low == Approx(2.0 + pm.log_mean - 1.6448536269514722 * sd).epsilon(1e-12));
  // Chi-square quantile: χ²_{8, 0.95} = 15.507313055865453 (tables).
  CHECK(chi_square_quantile(0.95, 8) == Approx(15.507313055865453).epsilon(1e-12));
}

TEST_CASE("forecast intervals: K_pitting's calibration elasticities equal finite differences of D = 1 - exp(-K T N^m)",
          "[model][updating][intervals]") {
  const double n0 = 2e5, n1 = 4e5, terms = 3.1e88, m = 1.111;
  for (const auto& [a0, a1] : {std::pair{0.03, 0.08}, std::pair{0.0, 0.05}, std::pair{0.10, 0.16}}) {
    // The closed form inverts Eq. 7.8: with its K, the point pits A0 at N0's −ln(1 − A0) plus K T Δ(N^m) by N1.
    const double k = closed_form_calibration_k(a0, n0, a1, n1, terms, m);
    CHECK(-std::log1p(-a0) + k * terms * (std::pow(n1, m) - std::pow(n0, m)) == Approx(-std::log1p(-a1)).epsilon(1e-12));
    const CalibrationElasticities g = calibration_elasticities(a0, a1);
    // Central differences in ln A (step 1e-5: truncation error ~1e-10, far below the 1e-6 asked).
    const double h = 1e-5;
    auto ln_k = [&](double x0, double x1) { return std::log(closed_form_calibration_k(x0, n0, x1, n1, terms, m)); };
    const double fd1 = (ln_k(a0, a1 * std::exp(h)) - ln_k(a0, a1 * std::exp(-h))) / (2 * h);
    CHECK(g.d_ln_a1 == Approx(fd1).epsilon(1e-6));
    if (a0 > 0) {
      const double fd0 = (ln_k(a0 * std::exp(h), a1) - ln_k(a0 * std::exp(-h), a1)) / (2 * h);
      CHECK(g.d_ln_a0 == Approx(fd0).epsilon(1e-6));
    } else {
      CHECK(g.d_ln_a0 == 0.0);
    }
    // Var ln K with a shared error: (g0 + g1)² s² when both areas carry the same relative error.
    CHECK(calibration_log_variance(a0, a1, 0.1, 0.1, 1.0) == Approx(std::pow((g.d_ln_a0 + g.d_ln_a1) * 0.1, 2)).epsilon(1e-12));
    CHECK(calibration_log_variance(a0, a1, 0.1, 0.2, 0.0) ==
          Approx(std::pow(g.d_ln_a0 * 0.1, 2) + std::pow(g.d_ln_a1 * 0.2, 2)).epsilon(1e-12));
  }
  // At fixed N two densities differ in ln K by their ln(−ln(1 − D)): the closed form at K and 2K.
  const double d1 = 1 - std::exp(-1e-94 * terms * std::pow(3e5, m)), d2 = 1 - std::exp(-2e-94 * terms * std::pow(3e5, m));
  CHECK(log_k_gap(d2, d1) == Approx(std::log(2.0)).epsilon(1e-9));
}

TEST_CASE("forecast intervals: the one-inspection ICS2 scale reads the model's own ICS2 form - the square root of the rise",
          "[model][updating][intervals]") {
  // The model's ICS2 form at a small pitting share s: ICS2 − baseline = I_s s², D ∝ s, so
  // ICS2 = 0.01 + 40 D². The pair's first records are unpitted, the inspection finds A0 = 0.04.
  const std::vector<double> first{0.01, 0.01, 0.01, 0.01, 0.01};
  auto ics2_of = [](double d) { return 0.01 + 40.0 * d * d; };
  const auto scale = one_inspection_scale(first, ics2_of(0.04), 0.04, 3.0);
  REQUIRE(scale);
  CHECK(scale->form == Ics2ScaleForm::square_root);
  CHECK(scale->baseline == 0.01);
  CHECK(scale->baseline_sd == 0.0);
  for (double d : {0.0, 0.02, 0.09, 0.17}) {
    CHECK(scale->density_at(ics2_of(d)) == Approx(d).margin(1e-15));
    CHECK(scale->ics2_for(d) == Approx(ics2_of(d)).epsilon(1e-14));
  }
  // At three times the inspected density the rise is nine times: 0.12, where a line through the
  // baseline and the inspection reads 0.04 × 9 = 0.36.
  CHECK(scale->density_at(ics2_of(0.12)) == Approx(0.12).epsilon(1e-14));
  // Below the baseline: no pitting.
  CHECK(scale->density_at(0.005) == 0.0);
  // The ICS2 scatter σ through the scale at density d: sqrt(d² + A0² σ / (ICS2_0 − baseline)) − d.
  const double sigma = 1e-3, rise0 = 40.0 * 0.04 * 0.04;
  for (double d : {0.0, 0.04, 0.1})
    CHECK(scale->density_noise(d, sigma) == Approx(std::sqrt(d * d + 0.04 * 0.04 * sigma / rise0) - d).epsilon(1e-12));
  // The linear form (two inspections) is unchanged: D = density + slope (ICS2 − ics2), its inverse, slope × σ.
  Ics2Scale line;
  line.ics2 = 0.03;
  line.density = 0.05;
  line.slope = 2.0;
  CHECK(line.density_at(0.08) == Approx(0.15).epsilon(1e-15));
  CHECK(line.ics2_for(0.15) == Approx(0.08).epsilon(1e-15));
  CHECK(line.density_noise(0.15, 1e-3) == Approx(2e-3).epsilon(1e-15));
  CHECK(ics2_scale_form_from_string(to_string(Ics2ScaleForm::square_root)) == Ics2ScaleForm::square_root);
  CHECK_FALSE(ics2_scale_form_from_string("cubic"));
  // A rise within 3 baseline SDs is no scale: SD = 1.4826 MAD = 1.4826 × 0.01.
  CHECK_FALSE(one_inspection_scale({0.09, 0.11, 0.1, 0.12, 0.08}, 0.1 + 3 * 1.4826 * 0.01 * 0.99, 0.04, 3.0));
  CHECK(one_inspection_scale({0.09, 0.11, 0.1, 0.12, 0.08}, 0.1 + 3 * 1.4826 * 0.01 * 1.01, 0.04, 3.0));
  // The median ignores one outlier in the baseline.
  CHECK(one_inspection_scale({0.1, 0.1, 5.0, 0.1, 0.1}, 0.5, 0.04, 3.0)->baseline == 0.1);
  // Theil–Sen on an exact line with one wild point: the line.
  const RobustLine l = theil_sen({{0, 1}, {1, 3}, {2, 5}, {3, 100}, {4, 9}});
  CHECK(l.slope == 2.0);
  CHECK(l.intercept == 1.0);
}

TEST_CASE("forecast intervals: before the second inspection, one inspection and the ICS2 trend give the pitting point",
          "[model][updating][intervals]") {
  // The truth pits from 0.3 M cycles on (K_pitting 1e-94 from there), ICS2 = 0.01 + 40 D² exactly
  // (the model's ICS2 form at a small pitting share),
  // one inspection at 0.6 M cycles, records every 50 000 cycles at 20 Hz, 20 N m.
  const twin::GearboxParameters params;
  const double kp = 1e-94, kw = 3.55e-16;
  ModelSettings s;
  s.loop.k_wear_si = kw;
  s.update_k_wear = false;
  s.pitting_interval_cycles = 1e5;
  s.forecast_horizon_cycles = 2e5;
  TwinModel model(params, s, [](const WearState&, const twin::OperatingPoint&) -> double { throw std::logic_error("not used"); });
  WearLoopOptions to = s.loop;
  to.k_pitting = 0;
  to.operating_point = {20, 20};
  BlueLoop truth(params, to);
  std::vector<Inspection> inspections;
  std::map<double, double> truth_density;
  int calibrations = 0;
  for (int i = 1; i <= 20; ++i) {
    const double cycles = 5e4 * i;
    if (cycles > 3e5 && truth.options().k_pitting == 0) {
      REQUIRE(truth.run_until(3e5));
      truth.set_coefficients(kw, kp);
    }
    REQUIRE(truth.run_until(cycles));
    const double density = summarise(truth.state()).mean_pitting_density;
    truth_density[cycles] = density;
    if (cycles == 6e5) inspections.push_back({1, cycles, density, {}, {}, {}});
    const ModelRunReport r = model.observe(observation(cycles, 20, 20, std::nullopt, 0.01 + 40 * density * density), inspections);
    INFO(cycles << " cycles: " << r.detail);
    if (cycles >= 6e5) {
      // The one-inspection scale reads the truth's density exactly (ICS2 quadratic in D).
      REQUIRE(r.ics2_density_estimate);
      CHECK(*r.ics2_density_estimate == Approx(density).epsilon(1e-9));
    }
    for (const auto& u : r.updates) {
      INFO(u.evidence);
      CHECK(u.trigger == UpdateTrigger::ics2_one_inspection);
      CHECK(u.outcome == UpdateOutcome::converged);
      ++calibrations;
      // The point: the median ICS2 of the newest three records, at the middle one's cycles (one
      // record back), through the exact scale: the truth's density there.
      const double n1 = cycles - 5e4;
      CHECK(u.measured == Approx(truth_density.at(n1)).epsilon(1e-9));
      // The calibrated model pits it by then (bisection on ln K to 1e-4; the mean to 1e-3).
      CHECK(u.simulated_after == Approx(u.measured).epsilon(1e-3));
      // Now ahead of the truth a little: the model pits from 0 cycles, the truth from 0.3 M.
      CHECK(r.summary.mean_pitting_density > 0);
      CHECK(u.evidence.find("posterior ln K") != std::string::npos);
    }
    // A pitting interval after the inspection and three records after it first, then one per interval.
    if (cycles < 7.5e5 || cycles == 8e5 || cycles == 9e5) CHECK(r.updates.empty());
  }
  CHECK(calibrations >= 2);   // every pitting interval until a second inspection
  CHECK(model.memory().log_k_pitting.valid);
  CHECK_FALSE(model.memory().pitting_calibrated);   // the two-inspection calibration is still to come
}

namespace {

// The stand-in for the blue loop: depth grows as c ∫ K dN. The truth's ln K is a random walk
// with the model's own process noise, its measurements carry the model's own noise; the
// forecast machinery (filter, interval with the walk accumulated to each end's crossing in two
// passes, as TwinModel::set_intervals) gives the interval of the cycles to the limit.
struct StandIn {
  double q = 0, r = 0, prior_sd = 0;
  double c = 1.0, horizon = 0;   ///< the limit: the depth now plus `horizon` cycles at the truth's K now
  double step = 1e5;   ///< cycles between measurements
  int measurements = 10;
};

double crossing_at_k(double left, double c, double k) { return left / (c * k); }

bool stand_in_covers(const StandIn& m, std::mt19937_64& rng) {
  std::normal_distribution<double> n01;
  double ln_k = m.prior_sd * n01(rng);   // prior mean 0
  LogPosterior post{true, 0.0, m.prior_sd * m.prior_sd, 0.0};
  double depth = 0, cycles = 0;
  const double dn = m.step / 20;
  double limit = std::numeric_limits<double>::infinity();
  auto walk = [&](double until, bool stop_at_limit) {
    // Piecewise-constant K over dn: the truth advances, accumulating depth.
    while (cycles < until) {
      const double h = std::min(dn, until - cycles);
      const double k = std::exp(ln_k);
      if (stop_at_limit && depth + m.c * k * h >= limit) return cycles + (limit - depth) / (m.c * k);
      depth += m.c * k * h;
      cycles += h;
      ln_k += std::sqrt(m.q * h) * n01(rng);
    }
    return cycles;
  };
  for (int i = 1; i <= m.measurements; ++i) {
    walk(m.step * i, false);
    post = filter_update(predict(post, cycles, m.q), ln_k + std::sqrt(m.r) * n01(rng), m.r, 3.0).posterior;
  }
  // The limit depends on the truth only through K now: whether the truth's crossing falls in
  // the interval then depends only on the mean K ahead, which the posterior and the walk describe.
  limit = depth + m.c * m.horizon * std::exp(ln_k);
  const double left = limit - depth, now = cycles;
  // Two passes: the walk to the nominal crossing, then to each end's.
  double t_fast = crossing_at_k(left, m.c, std::exp(post.mean)), t_slow = t_fast;
  for (int pass = 0; pass < 2; ++pass) {
    const double hi = log_interval(post, m.q, t_fast, 1.0).high, lo = log_interval(post, m.q, t_slow, 1.0).low;
    t_fast = crossing_at_k(left, m.c, std::exp(hi));
    t_slow = crossing_at_k(left, m.c, std::exp(lo));
  }
  const double t_true = walk(std::numeric_limits<double>::infinity(), true) - now;
  return t_true >= t_fast && t_true <= t_slow;
}

}  // namespace

TEST_CASE("forecast intervals: where the truth is the model itself the 90 % interval covers 90 % of the crossings",
          "[model][updating][intervals]") {
  // The model's own prior (SD ln 100), process noise (ln 2 per million cycles) and measurement
  // noise (1 % RMS_SA scatter at an elasticity 0.3), ten measurements 1e5 cycles apart; the limit
  // 1e5 and 1e6 cycles ahead at the truth's K now.
  ModelSettings defaults;
  StandIn m;
  m.q = defaults.log_k_q_per_cycle();
  m.r = std::pow(0.01 / 0.3, 2);
  m.prior_sd = defaults.prior_log_k_wear_sd;
  std::mt19937_64 rng(34);
  const int draws = 3000;
  // q T up to 0.48 (a million cycles at the default drift). Beyond, the lognormal form of the path
  // mean's tail falls short (docs/model.md gives the coverage measured at 3e6 cycles, q T = 1.44).
  for (double horizon : {1e5, 1e6}) {
    int covered = 0;
    StandIn d = m;
    d.horizon = horizon;
    for (int i = 0; i < draws; ++i) covered += stand_in_covers(d, rng) ? 1 : 0;
    const double p = static_cast<double>(covered) / draws;
    INFO("horizon " << horizon << ": covered " << p);
    // 3 binomial SDs at the nominal 0.90 over 3000 draws: ±0.0164.
    CHECK(std::abs(p - kNominalCoverage) <= 3 * binomial_sd(kNominalCoverage, draws));
  }
}

TEST_CASE("forecast intervals: the chi-square check flags 5 % of stationary residual windows",
          "[model][updating][intervals]") {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.02);
  const int trials = 4000;
  int flagged = 0;
  for (int t = 0; t < trials; ++t) {
    std::vector<double> r(8);
    for (double& x : r) x = noise(rng);
    flagged += residual_scatter_check(r, 0.02).exceeded ? 1 : 0;
  }
  const double rate = static_cast<double>(flagged) / trials;
  INFO("flagged " << rate);
  // Its size is 5 % by construction; 3 binomial SDs over 4000 windows (±0.0103).
  CHECK(rate <= 0.05 + 3 * binomial_sd(0.05, trials));
  CHECK(rate >= 0.05 - 3 * binomial_sd(0.05, trials));
  // A window whose RMS is twice the scatter: S = 8 × 4 = 32 > 15.5, widened by the ratio 2.
  const ScatterCheck twice = residual_scatter_check(std::vector<double>(8, 0.04), 0.02);
  CHECK(twice.exceeded);
  CHECK(twice.ratio == Approx(2.0).epsilon(1e-12));
}

namespace {

// The closed-form twin of the root-find tests: at a negligible K the mean depth is c K N, and
// RMS_SA = a (depth / (c k_ref N_ref))^e + b.
struct ClosedFormTwin {
  double a = 1.0, b = 0.5, e = 0.3, k_ref = 1e-22, depth_ref = 0;
  explicit ClosedFormTwin(const ModelSettings& s) {
    WearLoopOptions ref = s.loop;
    ref.operating_point = {10, 20};
    BlueLoop probe(twin::GearboxParameters{}, ref);
    REQUIRE(probe.run_until(1e5));
    depth_ref = summarise(probe.state()).combined_mean_depth_m / s.loop.k_wear_si * k_ref;
  }
  double rms(const WearState& st) const { return a * std::pow(summarise(st).combined_mean_depth_m / depth_ref, e) + b; }
  RmsSaSimulator simulator() const {
    return [this](const WearState& st, const twin::OperatingPoint&) { return rms(st); };
  }
};

ModelSettings closed_form_settings() {
  ModelSettings s;
  s.loop.k_wear_si = 1e-22;
  s.loop.profile_points = 21;
  s.k_wear_min_si = 1e-30;
  s.update_k_pitting = false;
  s.forecast_horizon_cycles = 1e6;
  s.forecast_points = 4;
  s.wear_limit_m = 1e-11;
  return s;
}

}  // namespace

TEST_CASE("forecast intervals: a truth whose K doubles widens the interval and says so, and a stationary one does not",
          "[model][updating][intervals]") {
  ModelSettings s = closed_form_settings();
  const ClosedFormTwin twin(s);
  for (const bool doubles : {false, true}) {
    TwinModel model(twin::GearboxParameters{}, s, twin.simulator());
    WearLoopOptions to = s.loop;
    to.k_wear_si = 1e-22;
    to.operating_point = {10, 20};
    BlueLoop truth(twin::GearboxParameters{}, to);
    bool flagged_after = false, flagged_before = false;
    for (int i = 1; i <= 12; ++i) {
      const double cycles = 1e4 * i;
      if (doubles && i == 7) truth.set_coefficients(2e-22, 0);
      REQUIRE(truth.run_until(cycles));
      const ModelRunReport r = model.observe(observation(cycles, 10, 20, twin.rms(truth.state())), {});
      INFO((doubles ? "doubling" : "stationary") << " at " << cycles << ": " << r.forecast.evidence);
      REQUIRE(r.forecast.valid);
      const bool flagged = has_flag(r.forecast, ForecastFlag::rms_sa_residuals_exceed_scatter);
      (i >= 7 ? flagged_after : flagged_before) |= flagged;
      if (flagged) {
        CHECK(r.forecast.evidence.find("widened") != std::string::npos);
        CHECK(r.forecast.coverage == kNominalCoverage);
      }
    }
    CHECK_FALSE(flagged_before);   // the same truth as the model's: residuals 0 after the first update
    CHECK(flagged_after == doubles);
  }
}

TEST_CASE("forecast intervals: no interval excludes a pitting limit the ICS2 estimate has reached, and an ICS2 trend ahead sets the near end",
          "[model][updating][intervals]") {
  ModelSettings s = closed_form_settings();
  const ClosedFormTwin twin(s);
  TwinModel first(twin::GearboxParameters{}, s, twin.simulator());
  first.observe(observation(1e4, 10, 20), {});
  ModelMemory m = first.memory();
  // The scale D = 0.05 + 2 (ICS2 − 0.03); the model's own density is 0. Every ICS2 below stays
  // under the saturation level 17/144 = 0.118, so each reading is a density estimate.
  m.ics2_scale_valid = true;
  m.ics2_scale_ics2 = 0.03;
  m.ics2_scale_density = 0.05;
  m.ics2_scale_slope = 2.0;
  m.ics2_scale_inspections = 1;
  const double now = m.current.state.cycles;
  SECTION("reached: the latest estimate at 0.19 >= 0.17") {
    m.ics2_series = {{now - 2e3, 0.05}, {now - 1e3, 0.06}, {now, 0.1}};
    const Forecast f = TwinModel(twin::GearboxParameters{}, s, twin.simulator(), m).forecast();
    REQUIRE(f.valid);
    CHECK(has_flag(f, ForecastFlag::pitting_limit_reached_by_ics2));
    CHECK(f.pitting.cycles_left_low == 0.0);
    CHECK(f.evidence.find("near end 0") != std::string::npos);
  }
  SECTION("within reach: 0.15 with SD 0.015 (10 % of it) has its 95 % bound 0.1747 >= 0.17, 0.14 (bound 0.163) has not") {
    m.ics2_series = {{now - 2e3, 0.08}, {now - 1e3, 0.08}, {now, 0.08}};
    const Forecast f = TwinModel(twin::GearboxParameters{}, s, twin.simulator(), m).forecast();
    REQUIRE(f.valid);
    CHECK(has_flag(f, ForecastFlag::pitting_limit_within_ics2_uncertainty));
    CHECK_FALSE(has_flag(f, ForecastFlag::pitting_limit_reached_by_ics2));
    CHECK(f.pitting.cycles_left_low == 0.0);
    m.ics2_series = {{now - 2e3, 0.075}, {now - 1e3, 0.075}, {now, 0.075}};
    const Forecast g = TwinModel(twin::GearboxParameters{}, s, twin.simulator(), m).forecast();
    REQUIRE(g.valid);
    CHECK_FALSE(has_flag(g, ForecastFlag::pitting_limit_within_ics2_uncertainty));
    CHECK_FALSE(g.pitting.cycles_left_low);   // flat trend, K_pitting 0: nothing brings the limit nearer
  }
  SECTION("k_wear_not_identified: after an insensitive update the K_wear interval is at least the prior's") {
    m.log_k_wear.var = 0.01;   // a narrow posterior the insensitive update cannot vouch for
    m.k_wear_last_insensitive = true;
    const Forecast f = TwinModel(twin::GearboxParameters{}, s, twin.simulator(), m).forecast();
    REQUIRE(f.valid);
    CHECK(has_flag(f, ForecastFlag::k_wear_not_identified));
    CHECK(f.log_sd_wear >= s.prior_log_k_wear_sd);
    m.k_wear_last_insensitive = false;
    const Forecast g = TwinModel(twin::GearboxParameters{}, s, twin.simulator(), m).forecast();
    CHECK_FALSE(has_flag(g, ForecastFlag::k_wear_not_identified));
    CHECK(g.log_sd_wear < f.log_sd_wear);
  }
  SECTION("ahead: the Theil-Sen trend of an exact line crosses the limit where the line does") {
    // D = 0.05 + 2 (ICS2 − 0.03): 0.08, 0.09, 0.10 now, rising 0.01 per 1000 cycles: the limit 0.17 in 7000 cycles.
    m.ics2_series = {{now - 2e3, 0.045}, {now - 1e3, 0.05}, {now, 0.055}};
    const Forecast f = TwinModel(twin::GearboxParameters{}, s, twin.simulator(), m).forecast();
    REQUIRE(f.valid);
    CHECK(has_flag(f, ForecastFlag::ics2_density_ahead_of_model));
    CHECK_FALSE(has_flag(f, ForecastFlag::pitting_limit_reached_by_ics2));
    REQUIRE(f.pitting.cycles_left_low);
    CHECK(*f.pitting.cycles_left_low == Approx(7000.0).epsilon(1e-9));
    CHECK_FALSE(f.pitting.cycles_left);   // the model itself pits nothing (K_pitting 0)
  }
}

TEST_CASE("forecast intervals: the scale's extrapolated SD, the pitting miss in ln K and the limit within reach in closed form",
          "[model][updating][intervals]") {
  // D = (1 - t) A0 + t A1 with 10 % on each area: t = 0 gives A0's, t = 1 A1's, t = 5 both, weighted.
  CHECK(scale_density_sd(0.01, 0.04, 0.0, 0.1) == Approx(0.001).epsilon(1e-14));
  CHECK(scale_density_sd(0.01, 0.04, 1.0, 0.1) == Approx(0.004).epsilon(1e-14));
  CHECK(scale_density_sd(0.01, 0.04, 5.0, 0.1) == Approx(0.1 * std::sqrt(16 * 1e-4 + 25 * 16e-4)).epsilon(1e-14));
  // Eq. 7.8 at fixed N: 0.10 measured against 0.05 modelled is ln(ln 0.9 / ln 0.95) in ln K, its SD
  // 0.01 / (0.9 (-ln 0.9)); beyond 2 SD the variance gains the gap squared.
  const PittingMiss miss = pitting_miss(0.10, 0.01, 0.05, 2.0);
  const double gap = std::log(std::log(0.9) / std::log(0.95));
  CHECK(miss.gap == Approx(gap).epsilon(1e-12));
  CHECK(miss.gap_sd == Approx(0.01 / (0.9 * -std::log(0.9))).epsilon(1e-12));
  CHECK(miss.missed);
  CHECK(miss.extra_var == Approx(gap * gap).epsilon(1e-12));
  const PittingMiss near = pitting_miss(0.10, 0.01, 0.095, 2.0);   // gap 0.053, SD 0.105: inside
  CHECK_FALSE(near.missed);
  CHECK(near.extra_var == 0.0);
  // The variance adds inside the interval: sd = sqrt(var + σ²_A + extra).
  const LogInterval li = log_interval(LogPosterior{true, 0.0, 0.04, 0.0}, 0.0, 1e6, 1.0, 0.5);
  CHECK(li.sd == Approx(std::sqrt(0.54)).epsilon(1e-14));
  CHECK(li.high == Approx(1.6448536269514722 * std::sqrt(0.54)).epsilon(1e-12));
  // D + z_0.95 σ >= limit.
  CHECK(limit_within_reach(0.15, 0.015, 0.17));        // 0.1747
  CHECK_FALSE(limit_within_reach(0.14, 0.014, 0.17));  // 0.1630
  CHECK(limit_within_reach(0.17 - 1.6448536269514722 * 0.01 + 1e-12, 0.01, 0.17));
}

TEST_CASE("forecast intervals: the model-form term is the residuals' excess mean square over the scatter, through the elasticity",
          "[model][updating][intervals]") {
  // Eight residuals of ±0.3 against a scatter of 0.05: chi-square 8 · 0.09 / 0.0025 = 288 > 15.51
  // (8 degrees of freedom, 5 %); excess mean square 0.09 − 0.0025 = 0.0875.
  const std::vector<double> r{0.3, -0.3, 0.3, -0.3, 0.3, -0.3, 0.3, -0.3};
  const ModelFormTerm a = model_form_term(r, 0.05, 0.5, 0.02, 100.0);
  CHECK(a.exceeded);
  CHECK(a.excess_mean_square == Approx(0.0875).epsilon(1e-12));
  CHECK(a.log_k_var == Approx(0.0875 / 0.25).epsilon(1e-12));
  // A negative elasticity counts by its size; below the minimum it is the minimum (0.02).
  CHECK(model_form_term(r, 0.05, -0.5, 0.02, 100.0).log_k_var == Approx(0.35).epsilon(1e-12));
  CHECK(model_form_term(r, 0.05, 0.001, 0.02, 1000.0).log_k_var == Approx(0.0875 / 4e-4).epsilon(1e-12));
  // Capped: no more than the caller allows (what brings the variance to the prior's).
  CHECK(model_form_term(r, 0.05, 0.001, 0.02, 21.2).log_k_var == 21.2);
  // Residuals at the scatter itself: chi-square 8 < 15.51, no term.
  const std::vector<double> quiet{0.05, -0.05, 0.05, -0.05, 0.05, -0.05, 0.05, -0.05};
  const ModelFormTerm b = model_form_term(quiet, 0.05, 0.5, 0.02, 100.0);
  CHECK_FALSE(b.exceeded);
  CHECK(b.log_k_var == 0);
  // Just over the 5 % point: 8 r² / s² = 16 > 15.51 with r = s sqrt(2): excess s² (2 − 1).
  const double s = 0.05, rr = s * std::sqrt(2.0);
  const std::vector<double> edge(8, rr);
  const ModelFormTerm c = model_form_term(edge, s, 1.0, 0.02, 100.0);
  CHECK(c.exceeded);
  CHECK(c.log_k_var == Approx(s * s).epsilon(1e-12));
  CHECK_FALSE(model_form_term({}, 0.05, 1.0, 0.02, 100.0).exceeded);
}

TEST_CASE("ICS2 saturation: the level is a quarter of fully modulated AM noise's closed form, where the density's elasticity passes 1",
          "[model][updating][intervals]") {
  // (a² + a⁴/16) / (1 + a²/2)² at a = 1: (1 + 1/16) / (9/4) = 17/36 with H ≥ 2; a² / (1 + a²/2)² = 4/9 with H = 1.
  CHECK(ics2_saturation_level(3) == Approx(17.0 / 144.0).epsilon(1e-15));
  CHECK(ics2_saturation_level(2) == Approx(17.0 / 144.0).epsilon(1e-15));
  CHECK(ics2_saturation_level(1) == Approx(1.0 / 9.0).epsilon(1e-15));
  CHECK(ModelSettings{}.ics2_saturation == ics2_saturation_level(3));
  // a = 1 is the largest for a non-negative envelope: the closed form rises on [0, 1].
  double previous = -1;
  for (int i = 0; i <= 100; ++i) {
    const double v = dsp::am_noise_ics2(i / 100.0, 3);
    CHECK(v > previous);
    previous = v;
  }
  CHECK(previous == Approx(17.0 / 36.0).epsilon(1e-15));
  // The mixing model: ICS2 = I_s s², D = κ s / (1 − s) (pitting power ∝ area, s its share). Its
  // elasticity d ln D / d ln ICS2 by central differences in ln ICS2 against 1 / (2 (1 − s)).
  const double i_s = 17.0 / 36.0;
  auto density_at = [&](double ics2) {
    const double s = std::sqrt(ics2 / i_s);
    return s / (1.0 - s);
  };
  for (double s : {0.05, 0.2, 1.0 / 3.0, 0.5, 0.7, 0.9, 0.99}) {
    const double x = std::log(i_s * s * s), h = 1e-6;   // truncation h²/6 · (ln D)''' ≤ 1e-9 relative at s = 0.99
    const double numeric = (std::log(density_at(std::exp(x + h))) - std::log(density_at(std::exp(x - h)))) / (2 * h);
    INFO("share " << s);
    CHECK(density_elasticity_of_ics2(s) == Approx(numeric).epsilon(1e-8));
  }
  // 1 (a proportional scale's) at the level when I_s is at its largest: there s = 1/2.
  CHECK(density_elasticity_of_ics2(std::sqrt(ics2_saturation_level(3) / i_s)) == Approx(1.0).epsilon(1e-14));
  CHECK_THROWS(density_elasticity_of_ics2(1.0));
  // A proportional scale through a reading at share s0 reads D_true · s (1 − s) / (s0 (1 − s0)):
  // below the truth (a lower bound) from s = 1 − s0 on, and ever further below as s → 1.
  const double s0 = 0.3, c = density_at(i_s * s0 * s0) / (i_s * s0 * s0);
  for (double s : {0.7, 0.8, 0.95}) {
    const double ics2 = i_s * s * s;
    CHECK(c * ics2 / density_at(ics2) == Approx(s * (1 - s) / (s0 * (1 - s0))).epsilon(1e-12));
    CHECK(c * ics2 <= density_at(ics2) * (1 + 1e-12));
  }
}

}  // namespace test_forecast_intervals
