// The pitting forecast against a closed-form pitting law (issue 34). The truth is Eq. 7.8 without
// its width feedback: D_j(N) = 1 − exp(−K A_j N^m) at each profile point j, A_j the unworn pair's
// Lundberg–Palmgren terms at K = 1 (`BlueLoop::pitting_rates(1)`, a direct computation), the mean
// density the pair's. Inspections and a linear ICS2 are drawn from it; the model must give the
// cycles to the limit that the closed form gives, its interval must hold them, and where the
// model's own density is at the limit while the measured one is not it must not say 0 left.
#include "gearwatch/wear/updating.hpp"
#include "model_observation.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include <catch2/catch.hpp>

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

// Tolerance on the cycles to the limit, as a share of them. Eq. 7.12 narrows a pitted point's width
// by (1 − D_j): p_max and b both grow as (1 − D_j)^(-1/2), so τ0^c V / z0^h grows as
// (1 − D_j)^(−(c + 2 − h)/2) = (1 − D_j)^-5, i.e. the model pits up to 5 max_j D_j faster than the
// closed form; over N^m the cycles move by at most that over m. Plus 0.1 % for the calibration's
// bisection, the step interpolation of the crossing and the closed form's 1-cycle bisection.
double cycles_tolerance(const ClosedFormPitting& t, double n_limit) {
  double max_d = 0;
  for (std::size_t j = 0; j < t.terms.size(); ++j) max_d = std::max(max_d, t.at_point(j, n_limit));
  return 5.0 * max_d / t.m + 1e-3;
}

bool has_flag(const Forecast& f, ForecastFlag flag) { return std::find(f.flags.begin(), f.flags.end(), flag) != f.flags.end(); }

}  // namespace

TEST_CASE("pitting forecast: calibrated on two inspections of a closed-form law, the cycles to the limit are the closed form's, inside the interval",
          "[model][pitting_forecast]") {
  const ModelSettings s = small_density_settings();
  const ClosedFormPitting truth = truth_for(s);
  const double n_limit = solve_increasing([&](double n) { return truth.mean(n); }, s.pitting_limit, 1e5, 1e8);
  const double tol = cycles_tolerance(truth, n_limit);
  INFO("closed-form crossing " << n_limit << " cycles, tolerance " << tol * n_limit << " cycles");
  CHECK(tol < 0.02);
  TwinModel model(twin::GearboxParameters{}, s, [](const WearState&, const twin::OperatingPoint&) -> double { return 1.0; });
  const std::vector<Inspection> inspections{{1, 4e5, truth.mean(4e5), {}}, {2, 7e5, truth.mean(7e5), {}}};
  int checked = 0;
  for (double n = 5e4; n <= 1.8e6; n += 5e4) {
    const ModelRunReport r = model.observe(observation(n, kSpeedHz, kTorqueNm, std::nullopt, 0.1 + 1000 * truth.mean(n)), inspections);
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

TEST_CASE("pitting forecast: the model's density at the limit while ICS2 reads half of it gives no 0 left but the closed form from the measured density, flagged",
          "[model][pitting_forecast]") {
  const ModelSettings s = small_density_settings();
  const ClosedFormPitting truth = truth_for(s);
  TwinModel model(twin::GearboxParameters{}, s, [](const WearState&, const twin::OperatingPoint&) -> double { return 1.0; });
  const std::vector<Inspection> inspections{{1, 4e5, truth.mean(4e5), {}}, {2, 7e5, truth.mean(7e5), {}}};
  // The ICS2 scale from the inspections is D = (ICS2 − 0.1) / 1000; from 1.4 M cycles ICS2 holds at
  // a density of 1e-4 (half the limit), so its trend and latest value are both 1e-4.
  const double measured = 1e-4;
  auto ics2 = [&](double n) { return 0.1 + 1000 * (n < 1.4e6 ? truth.mean(n) : measured); };
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
  const ModelRunReport r = model.observe(observation(2.25e6, kSpeedHz, kTorqueNm, std::nullopt, 0.1 + 1000 * 3e-4), inspections);
  CHECK_FALSE(has_flag(r.forecast, ForecastFlag::pitting_limit_reached_by_model_only));
  CHECK(has_flag(r.forecast, ForecastFlag::pitting_limit_reached_by_ics2));
  REQUIRE(r.forecast.pitting.cycles_left);
  CHECK(*r.forecast.pitting.cycles_left == 0.0);
}
