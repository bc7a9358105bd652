// The pitting forecast against a closed-form pitting law (issue 34). The truth is Eq. 7.8 without
// its width feedback: D_j(N) = 1 − exp(−K A_j N^m) at each profile point j, A_j the unworn pair's
// Lundberg–Palmgren terms at K = 1 (`BlueLoop::pitting_rates(1)`, a direct computation), the mean
// density the pair's. Inspections and a linear ICS2 are drawn from it; the model must give the
// cycles to the limit that the closed form gives, its interval must hold them, and where the
// model's own density is at the limit while the measured one is not it must not say 0 left; a
// saturated ICS2 reading gives a lower bound only: the limit cannot be ruled out (near end 0), and
// the nominal and far end follow from the model and the bound.
#include "gearwatch/wear/updating.hpp"
#include "model_observation.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <vector>

#include <catch2/catch.hpp>

namespace test_pitting_forecast {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::wear;
using gearwatch::testing::observation;

namespace {

constexpr double kSpeedHz = 10, kTorqueNm = 20;

/// The closed-form truth: the unworn pair's terms A_j and a K.
struct ClosedFormPitting {
  std::vector<double> terms;
  double k = 0, m = 0;
  double at_point(std::size_t j, double cycles) const { return -std::expm1(-k * terms[j] * std::pow(cycles, m)); }
  double mean(double cycles) const {
    double s = 0;
    for (std::size_t j = 0; j < terms.size(); ++j) s += at_point(j, cycles);
    return s / static_cast<double>(terms.size());
  }
};

/// The first x in [lo, hi] where the increasing f reaches `level`, by bisection to 1 cycle.
double solve_increasing(const std::function<double(double)>& f, double level, double lo, double hi) {
  REQUIRE(f(lo) < level);
  REQUIRE(f(hi) >= level);
  while (hi - lo > 1.0) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) >= level ? hi : lo) = mid;
  }
  return hi;
}

ModelSettings small_density_settings() {
  ModelSettings s;
  s.loop.k_wear_si = 1e-22;            // no wear: the pressure stays the unworn pair's
  s.update_k_wear = false;
  s.pitting_limit = 2e-4;              // small densities: Eq. 7.12's width feedback stays below 1 % (see the tolerance)
  s.forecast_horizon_cycles = 1e7;
  s.pitting_interval_cycles = 1e12;    // no correlation step: the calibration alone is tested
  s.pitting_growth_law = false;        // Eq. 7.8's own forecast and flags (the growth law: its own test below)
  s.pitting_exponent_from_inspections = false;   // the same (the exponent reading: its own test below)
  return s;
}

ClosedFormPitting truth_for(const ModelSettings& s) {
  WearLoopOptions o = s.loop;
  o.operating_point = {kSpeedHz, kTorqueNm};
  const BlueLoop unworn(twin::GearboxParameters{}, o);
  ClosedFormPitting t{unworn.pitting_rates(1.0), 0, s.loop.material.m};
  double mean_terms = 0;
  for (double a : t.terms) mean_terms += a / static_cast<double>(t.terms.size());
  t.k = 1e-4 / (mean_terms * std::pow(1e6, t.m));   // about 1e-4 mean density at 1 M cycles
  return t;
}

// Tolerance on the cycles to the limit, as a share of them. Eq. 7.12 narrows the tooth's width by
// (1 − D), D its mean density: p_max and b both grow as (1 − D)^(-1/2), so τ0^c V / z0^h grows as
// (1 − D)^(−(c + 2 − h)/2) = (1 − D)^-5, i.e. the model pits up to 5 D ≤ 5 max_j D_j faster than the
// closed form; over N^m the cycles move by at most that over m. Plus 0.1 % for the calibration's
// bisection, the step interpolation of the crossing and the closed form's 1-cycle bisection.
double cycles_tolerance(const ClosedFormPitting& t, double n_limit) {
  double max_d = 0;
  for (std::size_t j = 0; j < t.terms.size(); ++j) max_d = std::max(max_d, t.at_point(j, n_limit));
  return 5.0 * max_d / t.m + 1e-3;
}

bool has_flag(const Forecast& f, ForecastFlag flag) { return std::find(f.flags.begin(), f.flags.end(), flag) != f.flags.end(); }

/// The closed-form truth's cycles to the pitting limit.
double closed_form_crossing(const ClosedFormPitting& truth, const ModelSettings& s) {
  return solve_increasing([&](double n) { return truth.mean(n); }, s.pitting_limit, 1e5, 1e8);
}

/// The two inspections the closed-form cases calibrate on, at 0.4 and 0.7 M cycles, exact.
std::vector<Inspection> two_exact_inspections(const ClosedFormPitting& truth) {
  return {{1, 4e5, truth.mean(4e5), {}, {}, {}}, {2, 7e5, truth.mean(7e5), {}, {}, {}}};
}

/// The model with an RMS_SA that does not move (the pitting path alone), fed the truth's ICS2 at n.
TwinModel pitting_only_model(const ModelSettings& s) {
  return TwinModel(twin::GearboxParameters{}, s, [](const WearState&, const twin::OperatingPoint&) -> double { return 1.0; });
}
ModelRunReport observe_truth(TwinModel& model, const ClosedFormPitting& truth, double n, const std::vector<Inspection>& inspections) {
  return model.observe(observation(n, kSpeedHz, kTorqueNm, std::nullopt, 0.01 + 100 * truth.mean(n)), inspections);
}

}  // namespace

TEST_CASE("pitting forecast: calibrated on two inspections of a closed-form law, the cycles to the limit are the closed form's, inside the interval",
          "[model][pitting_forecast]") {
  const ModelSettings s = small_density_settings();
  const ClosedFormPitting truth = truth_for(s);
  const double n_limit = closed_form_crossing(truth, s);
  const double tol = cycles_tolerance(truth, n_limit);
  INFO("closed-form crossing " << n_limit << " cycles, tolerance " << tol * n_limit << " cycles");
  CHECK(tol < 0.02);
  TwinModel model = pitting_only_model(s);
  const std::vector<Inspection> inspections = two_exact_inspections(truth);
  int checked = 0;
  for (double n = 5e4; n <= 1.8e6; n += 5e4) {
    const ModelRunReport r = observe_truth(model, truth, n, inspections);
    if (n < 7e5) continue;
    INFO(n << " cycles: " << r.forecast.evidence);
    REQUIRE(r.forecast.valid);
    REQUIRE(r.forecast.pitting.cycles_left);
    const double expected = n_limit - n;
    CHECK(std::abs(*r.forecast.pitting.cycles_left - expected) <= tol * n_limit);
    REQUIRE(r.forecast.pitting.cycles_left_low);
    REQUIRE(r.forecast.pitting.cycles_left_high);
    CHECK(*r.forecast.pitting.cycles_left_low <= expected);
    CHECK(*r.forecast.pitting.cycles_left_high >= expected);
    CHECK_FALSE(has_flag(r.forecast, ForecastFlag::pitting_limit_reached_by_model_only));
    ++checked;
  }
  CHECK(checked == 23);
  // The calibrated K is the truth's (the bisection's 1e-4 in ln K, and the feedback at 1e-4).
  CHECK(model.memory().k_pitting == Approx(truth.k).epsilon(0.01));
}

TEST_CASE("pitting forecast: the exponent read from two inspections of a closed-form Eq. 7.8 truth gives its cycles to the limit, inside the interval",
          "[model][pitting_forecast][pitting_exponent]") {
  // At small D the inspected mean density is k T̄ N^m: the Weibull plot's slope between the two
  // inspections is m, and the crossing the closed form's within the same tolerance as the path's.
  ModelSettings s = small_density_settings();
  s.pitting_exponent_from_inspections = true;
  const ClosedFormPitting truth = truth_for(s);
  const double n_limit = closed_form_crossing(truth, s);
  const double tol = cycles_tolerance(truth, n_limit);
  TwinModel model = pitting_only_model(s);
  const std::vector<Inspection> inspections = two_exact_inspections(truth);
  int checked = 0;
  for (double n = 5e4; n <= 1.8e6; n += 5e4) {
    const ModelRunReport r = observe_truth(model, truth, n, inspections);
    if (n < 7e5) continue;
    INFO(n << " cycles: " << r.forecast.evidence);
    REQUIRE(r.forecast.valid);
    CHECK(r.forecast.evidence.find("give Eq. 7.8's exponent") != std::string::npos);
    REQUIRE(r.forecast.pitting.cycles_left);
    const double expected = n_limit - n;
    CHECK(std::abs(*r.forecast.pitting.cycles_left - expected) <= tol * n_limit);
    REQUIRE(r.forecast.pitting.cycles_left_low);
    REQUIRE(r.forecast.pitting.cycles_left_high);
    CHECK(*r.forecast.pitting.cycles_left_low <= expected);
    CHECK(*r.forecast.pitting.cycles_left_high >= expected);
    ++checked;
  }
  CHECK(checked == 23);
}

TEST_CASE("pitting forecast: with the growth law on a closed-form Lundberg-Palmgren truth the interval holds its cycles to the limit",
          "[model][pitting_forecast]") {
  // The truth D ∝ N^m at small D is the law dD/dN = a D^b with b = (m − 1)/m, inside the family:
  // the fit's interval must hold the closed form's cycles to the limit at every record after the
  // second inspection, and the evidence must name the law.
  ModelSettings s = small_density_settings();
  s.pitting_growth_law = true;
  s.pitting_interval_cycles = 1e5;
  const ClosedFormPitting truth = truth_for(s);
  const double n_limit = closed_form_crossing(truth, s);
  TwinModel model = pitting_only_model(s);
  const std::vector<Inspection> inspections = two_exact_inspections(truth);
  int checked = 0;
  for (double n = 5e4; n <= 1.8e6; n += 5e4) {
    const ModelRunReport r = observe_truth(model, truth, n, inspections);
    if (n < 7e5) continue;
    INFO(n << " cycles: " << r.forecast.evidence);
    REQUIRE(r.forecast.valid);
    CHECK(r.forecast.evidence.find("pitting growth law") != std::string::npos);
    const double expected = n_limit - n;
    REQUIRE(r.forecast.pitting.cycles_left_low);
    CHECK(*r.forecast.pitting.cycles_left_low <= expected);
    if (r.forecast.pitting.cycles_left_high) CHECK(*r.forecast.pitting.cycles_left_high >= expected);
    ++checked;
  }
  CHECK(checked == 23);
}

TEST_CASE("pitting forecast: the model's density at the limit while ICS2 reads half of it gives no 0 left but the closed form from the measured density, flagged",
          "[model][pitting_forecast]") {
  const ModelSettings s = small_density_settings();
  const ClosedFormPitting truth = truth_for(s);
  TwinModel model(twin::GearboxParameters{}, s, [](const WearState&, const twin::OperatingPoint&) -> double { return 1.0; });
  const std::vector<Inspection> inspections{{1, 4e5, truth.mean(4e5), {}, {}, {}}, {2, 7e5, truth.mean(7e5), {}, {}, {}}};
  // The ICS2 scale from the inspections is D = (ICS2 − 0.01) / 100 (under the saturation level
  // 0.118 throughout, so every reading is an estimate); from 1.4 M cycles ICS2 holds at
  // a density of 1e-4 (half the limit), so its trend and latest value are both 1e-4.
  const double measured = 1e-4;
  auto ics2 = [&](double n) { return 0.01 + 100 * (n < 1.4e6 ? truth.mean(n) : measured); };
  int flagged = 0;
  for (double n = 5e4; n <= 2.2e6; n += 5e4) {
    const ModelRunReport r = model.observe(observation(n, kSpeedHz, kTorqueNm, std::nullopt, ics2(n)), inspections);
    const Forecast& f = r.forecast;
    INFO(n << " cycles: " << f.evidence);
    REQUIRE(f.valid);
    const double model_density = r.summary.mean_pitting_density;
    if (model_density < s.pitting_limit) {
      CHECK_FALSE(has_flag(f, ForecastFlag::pitting_limit_reached_by_model_only));
      continue;
    }
    // The model (calibrated K, no correction) is at the limit; the measurement reads 1e-4.
    ++flagged;
    CHECK(has_flag(f, ForecastFlag::pitting_limit_reached_by_model_only));
    REQUIRE(f.pitting.cycles_left);
    CHECK(*f.pitting.cycles_left > 0);
    // The closed form from the measured density: the model's profile shape (the calibrated K's
    // closed form at n) rescaled to the measured mean, then Eq. 7.8 on the unpitted area.
    ClosedFormPitting calibrated = truth;
    calibrated.k = r.k_pitting;
    const double scale = measured / calibrated.mean(n);
    auto mean_from_measured = [&](double later) {
      double sum = 0;
      for (std::size_t j = 0; j < calibrated.terms.size(); ++j) {
        const double d0 = calibrated.at_point(j, n) * scale;
        sum += 1.0 - (1.0 - d0) * std::exp(-calibrated.k * calibrated.terms[j] * (std::pow(later, calibrated.m) - std::pow(n, calibrated.m)));
      }
      return sum / static_cast<double>(calibrated.terms.size());
    };
    const double expected = solve_increasing(mean_from_measured, s.pitting_limit, n, n + 1e8) - n;
    const double tol = cycles_tolerance(calibrated, n + expected);
    CHECK(std::abs(*f.pitting.cycles_left - expected) <= tol * (n + expected));
    REQUIRE(f.pitting.cycles_left_low);
    CHECK(*f.pitting.cycles_left_low == 0.0);   // the model's own state has the limit reached
    REQUIRE(f.pitting.cycles_left_high);
    CHECK(*f.pitting.cycles_left_high >= expected);
  }
  CHECK(flagged >= 5);
  // The measurement at the limit too: 0 left stands, named by the ICS2 flag.
  const ModelRunReport r = model.observe(observation(2.25e6, kSpeedHz, kTorqueNm, std::nullopt, 0.01 + 100 * 3e-4), inspections);
  CHECK_FALSE(has_flag(r.forecast, ForecastFlag::pitting_limit_reached_by_model_only));
  CHECK(has_flag(r.forecast, ForecastFlag::pitting_limit_reached_by_ics2));
  REQUIRE(r.forecast.pitting.cycles_left);
  CHECK(*r.forecast.pitting.cycles_left == 0.0);
}

namespace {
/// Mean density `later` cycles on, Eq. 7.8 on the unpitted area of each point, from the closed
/// form's profile at n (coefficient `shape_k`) rescaled to the mean `start`, with coefficient `k`.
double mean_from(const ClosedFormPitting& truth, double shape_k, double n, double start, double k, double later) {
  ClosedFormPitting shape = truth;
  shape.k = shape_k;
  const double scale = start / shape.mean(n);
  double sum = 0;
  for (std::size_t j = 0; j < truth.terms.size(); ++j) {
    const double d0 = shape.at_point(j, n) * scale;
    sum += 1.0 - (1.0 - d0) * std::exp(-k * truth.terms[j] * (std::pow(later, truth.m) - std::pow(n, truth.m)));
  }
  return sum / static_cast<double>(truth.terms.size());
}

/// The model's memory after the records up to `n` cycles, calibrated by the two inspections.
/// Catch2 runs a test case's body once per SECTION and both sections below start from this state:
/// it is computed once per process (the same settings and truth each time), not once per section.
const ModelMemory& memory_calibrated_to(const ModelSettings& s, const ClosedFormPitting& truth, double n) {
  static const ModelMemory memory = [&] {
    TwinModel model(twin::GearboxParameters{}, s, [](const WearState&, const twin::OperatingPoint&) -> double { return 1.0; });
    const std::vector<Inspection> inspections{{1, 4e5, truth.mean(4e5), {}, {}, {}}, {2, 7e5, truth.mean(7e5), {}, {}, {}}};
    for (double c = 5e4; c <= n; c += 5e4) model.observe(observation(c, kSpeedHz, kTorqueNm, std::nullopt, 0.01 + 100 * truth.mean(c)), inspections);
    return model.memory();
  }();
  return memory;
}
}  // namespace

TEST_CASE("pitting forecast: a saturated ICS2 reading bounds the density from below: near end 0, nominal from the model, far end from the bound",
          "[model][pitting_forecast]") {
  const ModelSettings s = small_density_settings();
  const ClosedFormPitting truth = truth_for(s);
  const double n = 1e6;
  const ModelMemory& calibrated = memory_calibrated_to(s, truth, n);
  REQUIRE(calibrated.pitting_calibrated);
  const double k = calibrated.k_pitting;
  const double d_model = std::accumulate(calibrated.current.state.pinion_pitting.begin(), calibrated.current.state.pinion_pitting.end(), 0.0) /
                         static_cast<double>(calibrated.current.state.pinion_pitting.size());
  // The same state without ICS2 evidence: the model's own interval.
  ModelMemory none = calibrated;
  none.ics2_scale_valid = false;
  const Forecast own = TwinModel(twin::GearboxParameters{}, s, [](const WearState&, const twin::OperatingPoint&) { return 1.0; }, none).forecast();
  REQUIRE(own.valid);
  REQUIRE(own.pitting.cycles_left);
  // A flat ICS2 of 0.15 (above 17/144) read through a one-inspection scale as `bound`, SD 10 % of it.
  auto saturated = [&](double bound) {
    ModelMemory m = calibrated;
    m.ics2_scale_valid = true;
    m.ics2_scale_inspections = 1;
    m.ics2_scale_ics2 = 0.15;
    m.ics2_scale_density = bound;
    m.ics2_scale_slope = 1e-3;
    m.ics2_scale_baseline_sd = 0;
    m.ics2_series = {{n - 1e5, 0.15}, {n - 5e4, 0.15}, {n, 0.15}};
    return TwinModel(twin::GearboxParameters{}, s, [](const WearState&, const twin::OperatingPoint&) { return 1.0; }, m).forecast();
  };
  const double z = 1.6448536269514722;   // the 95 % quantile: the interval's ends
  SECTION("the model above the bound: near end 0, nominal the model's own, the far end from the bound less 1.645 SD") {
    const double bound = 0.5 * d_model;
    const Forecast f = saturated(bound);
    INFO(f.evidence);
    REQUIRE(f.valid);
    CHECK(has_flag(f, ForecastFlag::ics2_saturated_density_lower_bound));
    for (ForecastFlag other : {ForecastFlag::pitting_path_missed_ics2, ForecastFlag::pitting_limit_within_ics2_uncertainty,
                               ForecastFlag::ics2_density_ahead_of_model, ForecastFlag::pitting_limit_reached_by_model_only})
      CHECK_FALSE(has_flag(f, other));
    CHECK(f.k_pitting_low == own.k_pitting_low);
    CHECK(f.k_pitting_high == own.k_pitting_high);
    CHECK(f.pitting.cycles_left == own.pitting.cycles_left);
    // The upper end is unknown: the limit may be reached already.
    CHECK(f.pitting.cycles_left_low == 0.0);
    const double start = bound * (1 - z * 0.1);
    const double expected = solve_increasing([&](double later) { return mean_from(truth, k, n, start, f.k_pitting_low, later); },
                                             s.pitting_limit, n, n + 1e9) - n;
    REQUIRE(f.pitting.cycles_left_high);
    CHECK(std::abs(*f.pitting.cycles_left_high - expected) <= cycles_tolerance(truth, n + expected) * (n + expected));
    REQUIRE(own.pitting.cycles_left_high);
    CHECK(*f.pitting.cycles_left_high > *own.pitting.cycles_left_high);   // widened
  }
  SECTION("the model below the bound: the nominal from the bound with the working K, near end 0") {
    const double bound = 1.5 * d_model;
    const Forecast f = saturated(bound);
    INFO(f.evidence);
    REQUIRE(f.valid);
    CHECK(has_flag(f, ForecastFlag::ics2_saturated_density_lower_bound));
    const double expected = solve_increasing([&](double later) { return mean_from(truth, k, n, bound, k, later); }, s.pitting_limit, n, n + 1e9) - n;
    REQUIRE(f.pitting.cycles_left);
    CHECK(std::abs(*f.pitting.cycles_left - expected) <= cycles_tolerance(truth, n + expected) * (n + expected));
    CHECK(*f.pitting.cycles_left < *own.pitting.cycles_left);
    CHECK(f.pitting.cycles_left_low == 0.0);
    REQUIRE(f.pitting.cycles_left_high);
    CHECK(*f.pitting.cycles_left_high >= *f.pitting.cycles_left);
  }
}

}  // namespace test_pitting_forecast
