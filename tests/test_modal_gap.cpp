// The modal gap: grouped calibration, candidate structural effects scored by leave-two-out
// prediction, and the report. Synthetic "measured" frequencies come from models with known values.
#include "gearwatch/twin/modal_gap.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <random>
#include <string>

#include <catch2/catch.hpp>

#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/modal_analysis.hpp"

namespace test_modal_gap {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::twin;

namespace {

// A small, identifiable knob set (5 knobs for 8 frequencies) keeps each fit to milliseconds.
std::vector<ModalKnob> small_knobs() {
  std::vector<ModalKnob> out;
  for (const auto& k : grouped_modal_knobs())
    if (k.name == "couplings" || k.name == "bearing_y" || k.name == "bearing_x" || k.name == "shaft_bending" ||
        k.name == "brake_inertia")
      out.push_back(k);
  return out;
}

StructuralModel with_factors(StructuralModel m, const std::vector<ModalKnob>& knobs, const std::map<std::string, double>& factors) {
  for (const auto& k : knobs) {
    const auto it = factors.find(k.name);
    if (it == factors.end()) continue;
    for (const auto& p : k.parameters) structural_parameter(m, p) *= it->second;
  }
  return m;
}

// The model's eight lowest elastic frequencies: the synthetic "measurement".
std::vector<double> lowest_eight(const StructuralModel& m) {
  std::vector<double> f;
  for (const auto& mode : structural_modes(m))
    if (mode.frequency_hz > 1.0 && f.size() < 8) f.push_back(mode.frequency_hz);
  return f;
}

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

const std::map<std::string, double> kTruth = {
    {"couplings", 0.3}, {"bearing_y", 0.7}, {"bearing_x", 1.4}, {"shaft_bending", 1.3}, {"brake_inertia", 1.8}};

}  // namespace

TEST_CASE("Structural model without a base equals the 21-DOF modal analysis", "[twin][modal_gap]") {
  const StructuralModel m;
  const auto reference = modal_analysis(m.gearbox);
  const auto modes = structural_modes(m);
  REQUIRE(modes.size() == reference.size());
  for (std::size_t i = 1; i < modes.size(); ++i) {
    INFO("mode " << i);
    CHECK(modes[i].frequency_hz == Approx(reference[i].frequency_hz).epsilon(1e-9));
    CHECK(modes[i].dominant_element == reference[i].dominant_element);
  }
}

TEST_CASE("Base support: a rigid bed alone on its mounts has the closed-form frequency", "[twin][modal_gap]") {
  // Pedestal mounts far stiffer than the bed's: the bed carries the whole gearbox, so its bounce
  // frequency is sqrt(k / (M_bed + every translating mass)) / 2π in y and in x.
  StructuralModel m;
  for (const auto* p : {"ky4", "ky6", "ky9", "ky11", "kx4", "kx6", "kx9", "kx11"}) structural_parameter(m, p) = 1e9;
  m.base = {true, 80.0, 1.0e6, 4.0e5};
  const GearboxParameters& g = m.gearbox;
  const double total = 80.0 + g.m4 + g.m5 + g.m6 + g.m9 + g.m10 + g.m11;
  const double fy = std::sqrt(1.0e6 / total) / (2 * std::numbers::pi), fx = std::sqrt(4.0e5 / total) / (2 * std::numbers::pi);
  const auto modes = structural_modes(m);
  REQUIRE(modes.size() == 23);
  auto nearest = [&](double f) {
    double best = 1e9;
    for (const auto& mode : modes) best = std::min(best, std::abs(mode.frequency_hz - f) / f);
    return best;
  };
  CHECK(nearest(fy) < 2e-4);  // the shaft-bending/bearing coupling shifts it by far less than this
  CHECK(nearest(fx) < 2e-4);
}

TEST_CASE("Grouped calibration fits a synthetic model's own frequencies back to its knob values", "[twin][modal_gap]") {
  const StructuralModel prior;
  const auto knobs = small_knobs();
  const StructuralModel truth = with_factors(prior, knobs, kTruth);
  const std::vector<double> measured = lowest_eight(truth);
  ModalFitOptions o;
  o.frequency_sigma = 1e-5;  // the prior's pull on the answer becomes negligible
  o.starts = 12;  // from the prior centre alone the monotone pairing lands on a 1 % local minimum
  const ModalFit fit = fit_modal_model(prior, knobs, measured, std::vector<bool>(8, true), o);
  CHECK(fit.max_abs_error_pct < 1e-3);
  // Identifiable: every fit the ensemble keeps is the same one, so it predicts what the best fit does.
  REQUIRE(fit.ensemble_members >= 1);
  CHECK(fit.ensemble_members <= o.starts);
  for (std::size_t i = 0; i < 8; ++i) CHECK(fit.ensemble_hz[i] == Approx(fit.model_hz[i]).epsilon(1e-6));
  for (std::size_t j = 0; j < knobs.size(); ++j) {
    INFO(knobs[j].name);
    CHECK(fit.factors[j] == Approx(kTruth.at(knobs[j].name)).epsilon(1e-4));
    CHECK_FALSE(fit.at_bound[j]);
  }
}

TEST_CASE("A base mode in the data is recovered and adopted by leave-out scoring, and not adopted without it", "[twin][modal_gap]") {
  const StructuralModel prior;
  const auto knobs = small_knobs();
  // The candidate's prior is off the truth by ×0.8 in mass and ×1.3 in mount stiffness.
  const StructuralCandidate base = base_support_candidate({true, 50.0, 2.0e6, 1.0e6}, 0.2, 5.0, 0.1, 10.0, "test prior");
  StructuralModel with_base = with_factors(prior, knobs, kTruth);
  with_base.base = {true, 40.0, 2.6e6, 1.3e6};
  const std::vector<double> measured = lowest_eight(with_base);
  ModalGapOptions o;
  o.fit.starts = 12;
  o.spread_seeds = {};  // the seed spread is checked on the second data set below

  const ModalGapReport r = modal_gap_analysis(prior, knobs, {base}, measured, o);
  REQUIRE(r.adopted == std::vector<std::string>{"base support"});
  REQUIRE(r.candidates.size() == 1);  // one candidate: no pairs, and nothing left for a second step
  CHECK(r.candidates[0].adopted);
  CHECK(r.final_score.median_fold_error_pct < 0.5 * r.baseline.median_fold_error_pct);
  // Recovered: the frequencies fix each mount stiffness per unit of the mass it carries (bed plus
  // every translating mass, 10 kg here, no mass knob): the bed's bounce frequency. The split
  // between bed mass and stiffness is the prior's.
  CHECK(r.final_fit.max_abs_error_pct < 0.1);
  const GearboxParameters& g = r.final_fit.model.gearbox;
  const double carried = g.m4 + g.m5 + g.m6 + g.m9 + g.m10 + g.m11;
  REQUIRE(carried == Approx(10.0));
  // Frequencies alone do not tell the bed's y mode from its x mode (that needs the shapes): the
  // two mount stiffnesses per carried mass come back as a pair.
  const double low = std::min(r.final_fit.model.base.k_y, r.final_fit.model.base.k_x);
  const double high = std::max(r.final_fit.model.base.k_y, r.final_fit.model.base.k_x);
  CHECK(high / (r.final_fit.model.base.mass + carried) == Approx(2.6e6 / (40.0 + carried)).epsilon(0.003));
  CHECK(low / (r.final_fit.model.base.mass + carried) == Approx(1.3e6 / (40.0 + carried)).epsilon(0.003));
  int base_modes = 0;
  const auto modes = structural_modes(r.final_fit.model);
  for (int m : r.final_fit.paired_mode) {
    const std::string& e = modes[static_cast<std::size_t>(m)].dominant_element;
    if (e == "base_ky" || e == "base_kx") ++base_modes;
  }
  CHECK(base_modes == 2);  // both bed modes in the data are paired with the bed
  CHECK(r.knobs_inside_priors);

  // The reported figures equal a direct recomputation.
  const LeaveOutScore before = leave_two_out(prior, knobs, measured, o.fit);
  StructuralModel m = prior;
  auto k = knobs;
  base.apply(m, k);
  const LeaveOutScore after = leave_two_out(m, k, measured, o.fit);
  CHECK(r.baseline.median_fold_error_pct == before.median_fold_error_pct);
  CHECK(r.final_score.median_fold_error_pct == after.median_fold_error_pct);
  CHECK(r.candidates[0].median_fold_before_pct == before.median_fold_error_pct);
  CHECK(r.candidates[0].median_fold_after_pct == after.median_fold_error_pct);
  for (std::size_t i = 0; i < measured.size(); ++i) {
    CHECK(r.modes[i].median_error_before_pct == before.median_by_frequency_pct[i]);
    CHECK(r.modes[i].median_error_after_pct == after.median_by_frequency_pct[i]);
    // One seed here: the worst over the seeds is that seed's.
    CHECK(r.modes[i].worst_seed_median_before_pct == before.median_by_frequency_pct[i]);
    CHECK(r.modes[i].worst_seed_median_after_pct == after.median_by_frequency_pct[i]);
    const ModalGapStatus expected = before.median_by_frequency_pct[i] <= o.explained_within_pct
                                        ? ModalGapStatus::explained_by_twin
                                        : (after.median_by_frequency_pct[i] <= o.explained_within_pct ? ModalGapStatus::explained_by_effect
                                                                                                     : ModalGapStatus::unexplained);
    CHECK(r.modes[i].status == expected);
    CHECK(r.modes[i].worse_with_effects ==
          (expected == ModalGapStatus::explained_by_twin && after.median_by_frequency_pct[i] > o.explained_within_pct));
  }

  // Without a bed in the data the same candidate is not adopted.
  const std::vector<double> plain = lowest_eight(with_factors(prior, knobs, kTruth));
  o.spread_seeds = {7};
  const ModalGapReport none = modal_gap_analysis(prior, knobs, {base}, plain, o);
  CHECK(none.adopted.empty());
  CHECK_FALSE(none.candidates.at(0).adopted);
  CHECK(none.candidates[0].median_fold_after_pct > o.adopt_ratio * none.baseline.median_fold_error_pct);
  // The seed spread: the same scores with seed 7; nothing adopted, so the final model is the baseline.
  ModalFitOptions seven = o.fit;
  seven.seed = 7;
  REQUIRE(none.seeds == std::vector<unsigned>{o.fit.seed, 7});
  CHECK(none.baseline_fold_by_seed[0] == none.baseline.median_fold_error_pct);
  CHECK(none.baseline_fold_by_seed[1] == leave_two_out(prior, knobs, plain, seven).median_fold_error_pct);  // deterministic
  CHECK(none.final_fold_by_seed == none.baseline_fold_by_seed);
  const LeaveOutScore seven_score = leave_two_out(prior, knobs, plain, seven);
  for (std::size_t i = 0; i < plain.size(); ++i) {
    const double worst = std::max(none.baseline.median_by_frequency_pct[i], seven_score.median_by_frequency_pct[i]);
    CHECK(none.modes[i].worst_seed_median_before_pct == worst);
    CHECK((none.modes[i].status == ModalGapStatus::explained_by_twin) == (worst <= o.explained_within_pct));
  }
  CHECK(none.target_met == (none.knobs_inside_priors && std::max(none.final_fold_by_seed[0], none.final_fold_by_seed[1]) <= 15.0));
}

TEST_CASE("Leave-two-out: 28 folds equal direct refits", "[twin][modal_gap]") {
  const StructuralModel prior;
  const auto knobs = small_knobs();
  const std::vector<double> measured = lowest_eight(with_factors(prior, knobs, {{"couplings", 0.5}, {"bearing_x", 0.4}}));
  ModalFitOptions o;
  o.starts = 3;
  o.prediction = GENERATE(HeldOutPrediction::ensemble, HeldOutPrediction::best_fit);
  INFO(to_string(o.prediction));
  const LeaveOutScore s = leave_two_out(prior, knobs, measured, o);
  REQUIRE(s.folds.size() == 28);
  std::vector<double> fold_errors, all;
  std::vector<std::vector<double>> per(8);
  std::size_t f = 0;
  for (std::size_t a = 0; a < 8; ++a)
    for (std::size_t b = a + 1; b < 8; ++b, ++f) {
      std::vector<bool> use(8, true);
      use[a] = use[b] = false;
      const ModalFit fit = fit_modal_model(prior, knobs, measured, use, o);
      for (int k = 0; k < 2; ++k) {
        const std::size_t i = k == 0 ? a : b;
        const double predicted = o.prediction == HeldOutPrediction::ensemble ? fit.ensemble_hz[i] : fit.model_hz[i];
        const double e = 100.0 * (predicted - measured[i]) / measured[i];
        CHECK(s.folds[f].held_out[k] == static_cast<int>(i));
        CHECK(s.folds[f].error_pct[k] == e);
        all.push_back(std::abs(e));
        per[i].push_back(std::abs(e));
      }
      fold_errors.push_back(std::max(std::abs(s.folds[f].error_pct[0]), std::abs(s.folds[f].error_pct[1])));
    }
  CHECK(s.median_fold_error_pct == median_of(fold_errors));
  CHECK(s.median_abs_error_pct == median_of(all));
  CHECK(s.worst_abs_error_pct == *std::max_element(all.begin(), all.end()));
  for (std::size_t i = 0; i < 8; ++i) {
    CHECK(s.median_by_frequency_pct[i] == median_of(per[i]));
    CHECK(per[i].size() == 7);
  }
}

TEST_CASE("An ensemble of one start predicts what its fit predicts", "[twin][modal_gap]") {
  const StructuralModel prior;
  const auto knobs = small_knobs();
  const std::vector<double> measured = lowest_eight(with_factors(prior, knobs, {{"couplings", 0.5}}));
  ModalFitOptions o;
  o.starts = 1;
  std::vector<bool> use(8, true);
  use[2] = use[5] = false;
  const ModalFit fit = fit_modal_model(prior, knobs, measured, use, o);
  CHECK(fit.ensemble_members == 1);
  CHECK(fit.ensemble_hz == fit.model_hz);
}

TEST_CASE("Leave-two-out naming held-out modes by full-fit shape predicts the best-matching free mode", "[twin][modal_gap]") {
  const StructuralModel prior;
  const auto knobs = small_knobs();
  const std::vector<double> measured = lowest_eight(with_factors(prior, knobs, {{"couplings", 0.5}, {"bearing_x", 0.4}}));
  ModalFitOptions o;
  o.starts = 2;
  const LeaveOutScore s = leave_two_out(prior, knobs, measured, o, HeldOutIdentity::full_fit_shape);
  REQUIRE(s.folds.size() == 28);
  const ModalFit full = fit_modal_model(prior, knobs, measured, std::vector<bool>(8, true), o);
  const auto full_modes = structural_modes(full.model);
  // Three folds recomputed by hand: the fold's modes not paired with a fitted value, ranked by MAC
  // (mass of the fold model) against the named shape.
  for (std::size_t f : {0u, 13u, 27u}) {
    const auto a = static_cast<std::size_t>(s.folds[f].held_out[0]), b = static_cast<std::size_t>(s.folds[f].held_out[1]);
    std::vector<bool> use(8, true);
    use[a] = use[b] = false;
    const ModalFit fit = fit_modal_model(prior, knobs, measured, use, o);
    const auto modes = structural_modes(fit.model);
    const GearboxParameters& g = fit.model.gearbox;
    Eigen::VectorXd mass(21);
    mass << g.I1, g.I2, g.I3, g.I5, g.I7, g.I8, g.I10, g.I12, g.I13, g.m4, g.m5, g.m6, g.m9, g.m10, g.m11, g.m4, g.m5, g.m6,
        g.m9, g.m10, g.m11;
    std::vector<bool> taken(modes.size(), false);
    for (std::size_t i = 0; i < 8; ++i)
      if (use[i]) taken[static_cast<std::size_t>(fit.paired_mode[i])] = true;
    double best_mac = -1;
    std::size_t best_k = 0, best_m = 0;
    for (std::size_t k = 0; k < 2; ++k)
      for (std::size_t m = 1; m < modes.size(); ++m) {
        const double mac = modal_assurance(full_modes[static_cast<std::size_t>(full.paired_mode[k == 0 ? a : b])].shape, modes[m].shape, mass);
        if (!taken[m] && mac > best_mac) best_mac = mac, best_k = k, best_m = m;
      }
    INFO("fold " << f);
    // The best (value, mode) match overall is taken first.
    CHECK(s.folds[f].predicted_hz[best_k] == modes[best_m].frequency_hz);
    CHECK(s.folds[f].error_pct[best_k] == Approx(100.0 * (modes[best_m].frequency_hz - measured[best_k == 0 ? a : b]) /
                                                 measured[best_k == 0 ? a : b]).epsilon(1e-12));
  }
}

TEST_CASE("Grouped knobs keep every parameter inside its sheet range", "[twin][modal_gap]") {
  const StructuralModel prior;
  for (const auto& k : grouped_modal_knobs())
    for (const auto& p : k.parameters) {
      const ParameterInfo* info = find_parameter(p);
      REQUIRE(info != nullptr);
      INFO(k.name << " / " << p);
      CHECK(structural_parameter(prior, p) * k.low >= info->prior_low * (1 - 1e-12));
      CHECK(structural_parameter(prior, p) * k.high <= info->prior_high * (1 + 1e-12));
      CHECK_FALSE(k.source.empty());
    }
  // The coupling-type candidates split the sheet's 1e2–2e5 N m/rad at 5e3.
  for (const auto& c : structural_candidates()) {
    StructuralModel m = prior;
    auto knobs = grouped_modal_knobs();
    c.apply(m, knobs);
    for (const auto& k : knobs)
      if (k.name == "couplings") {
        INFO(c.name);
        const double low = m.gearbox.kt12 * k.low, high = m.gearbox.kt12 * k.high;
        if (c.name == "elastomer couplings") {
          CHECK(low == Approx(1e2));
          CHECK(high == Approx(5e3));
        } else if (c.name == "stiff couplings") {
          CHECK(low == Approx(5e3));
          CHECK(high == Approx(2e5));
        } else {
          CHECK(low == Approx(1e2));
          CHECK(high == Approx(2e5));
        }
      }
  }
}

TEST_CASE("The softest corner bounds every mode from below, and its check counts the peaks it cannot hold", "[twin][modal_gap]") {
  const StructuralModel prior;
  const auto knobs = grouped_modal_knobs();
  const auto corner = structural_modes(softest_corner(prior, knobs));
  // Any set of factors inside the ranges: the i-th frequency is at least the corner's i-th.
  std::mt19937 rng(7);
  for (int draw = 0; draw < 20; ++draw) {
    StructuralModel m = prior;
    for (const auto& k : knobs) {
      std::uniform_real_distribution<double> u(std::log(k.low), std::log(k.high));
      const double factor = std::exp(u(rng));
      for (const auto& p : k.parameters) structural_parameter(m, p) *= factor;
    }
    const auto modes = structural_modes(m);
    for (std::size_t i = 1; i < modes.size(); ++i) CHECK(modes[i].frequency_hz >= corner[i].frequency_hz * (1 - 1e-9));
  }
  // The check against a hand count on the corner's own elastic frequencies.
  std::vector<double> elastic;
  for (const auto& m : corner)
    if (m.frequency_hz > 1.0) elastic.push_back(m.frequency_hz);
  const std::vector<double> peaks = {0.5 * elastic[0], 0.9 * elastic[0], elastic[1] * 1.01, 0.99 * elastic[3]};
  const CornerCheck c = corner_check("grouped twin", prior, knobs, peaks);
  CHECK(c.modes_at_or_below == std::vector<int>{0, 0, 2, 3});
  CHECK(c.deficit == std::vector<int>{1, 2, 1, 1});
  CHECK(c.max_deficit == 2);
}

TEST_CASE("With torsionally stiff couplings (seed 3.2) no knob inside the priors gives a gearbox mode at 22 Hz", "[twin][modal_gap]") {
  StructuralModel model;
  auto knobs = grouped_modal_knobs();
  const auto candidates = structural_candidates();
  const auto stiff = std::find_if(candidates.begin(), candidates.end(), [](const auto& c) { return c.name == "stiff couplings"; });
  REQUIRE(stiff != candidates.end());
  stiff->apply(model, knobs);
  const StructuralModel corner = softest_corner(model, knobs);
  CHECK(corner.gearbox.kt12 == Approx(5e3));
  CHECK(corner.gearbox.I13 == Approx(3.5e-2));
  // The corner's frequencies from the 21-DOF modal analysis itself (the shipped code path).
  const auto modes = modal_analysis(corner.gearbox);
  CHECK(modes[1].frequency_hz > 22.0 * 1.5);
  CHECK(modes[2].frequency_hz > 87.0 * 1.5);
  const CornerCheck c = corner_check("stiff couplings", model, knobs, table_5_5_frequencies());
  CHECK(c.elastic_hz.front() == Approx(modes[1].frequency_hz).epsilon(1e-9));
  CHECK(c.modes_at_or_below[0] == 0);  // nothing at or below 22 Hz
  CHECK(c.modes_at_or_below[1] == 1);  // one mode for the two peaks at or below 87 Hz
  CHECK(c.deficit[0] == 1);
  CHECK(c.deficit[1] == 1);
  // The sheet's full coupling range (down to 1e2 N m/rad) can hold every peak.
  CHECK(corner_check("grouped twin", StructuralModel{}, grouped_modal_knobs(), table_5_5_frequencies()).max_deficit == 0);
}

TEST_CASE("Modal fit rejects bad input", "[twin][modal_gap]") {
  const StructuralModel prior;
  const auto knobs = small_knobs();
  CHECK_THROWS_AS(fit_modal_model(prior, knobs, {}, {}), TwinParameterError);
  CHECK_THROWS_AS(fit_modal_model(prior, knobs, {100, -3}, {true, true}), TwinParameterError);
  CHECK_THROWS_AS(fit_modal_model(prior, {{"x", {"no_such_parameter"}, 0.5, 2, "?"}}, {100, 200}, {true, true}), TwinParameterError);
  CHECK_THROWS_AS(fit_modal_model(prior, {{"x", {"kt12"}, 2, 3, "?"}}, {100, 200}, {true, true}), TwinParameterError);
  CHECK_THROWS_AS(leave_two_out(prior, knobs, {100, 200, 300}), TwinParameterError);
}

}  // namespace test_modal_gap
