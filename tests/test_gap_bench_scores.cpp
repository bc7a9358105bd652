// The rig bench's headline scores (issue 35 item 6, docs/gap-bench.md "What the records can show"):
// hand-made scenario outcomes whose scores are counted by hand here.
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "gap_bench_scores.hpp"

namespace test_gap_bench_scores {  // this file's own: the test files compile together (unity build)

using gearwatch::cli::RigFigure;
using gearwatch::cli::RigOutcome;
using gearwatch::cli::ScoreFigure;
using gearwatch::gap::CandidateEffect;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

const ScoreFigure& figure(const std::vector<ScoreFigure>& figures, RigFigure which) {
  for (const auto& f : figures)
    if (f.figure == which) return f;
  FAIL("figure missing: " << gearwatch::cli::to_string(which));
  throw;  // not reached
}

}  // namespace

TEST_CASE("gap bench scores: hand-made outcomes give the hand-counted figures", "[gap_bench_scores]") {
  using C = CandidateEffect;
  // truth, identifiable (from the truth), chosen, detected, shrinkage.
  const std::vector<RigOutcome> scenarios{
      {{C::casing_mode}, {C::casing_mode}, {C::casing_mode, C::noise_floor}, true, 0.9},    // 1 named
      {{C::backlash}, {}, {}, false, kNaN},                                                 // 2 silent
      {{C::backlash}, {}, {}, true, 0.99},                   // 3 a significant family: not silent; shrinkage not counted
      {{C::backlash}, {}, {C::tip_relief}, true, 0.2},                                      // 4 names something
      {{C::eccentricity}, {C::eccentricity}, {C::tooth_errors, C::eccentricity}, true, 0.5},  // 5 wrong first
      {{C::noise_floor}, {C::noise_floor}, {}, false, kNaN},  // 6 missed, no shrinkage
      {{C::mount_resonance}, {C::mount_resonance}, {C::mount_resonance}, true, 0.8},        // 7 named
      {{C::casing_mode, C::misalignment}, {C::casing_mode, C::misalignment}, {C::misalignment, C::casing_mode}, true, 0.6},  // 8 both
      {{C::tooth_errors, C::casing_mode}, {C::tooth_errors, C::casing_mode}, {C::tooth_errors}, true, 0.4},  // 9 one of two
      // 10: the first named is true but leaves no trace: not named; not in both_named (one identifiable).
      {{C::eccentricity, C::backlash}, {C::eccentricity}, {C::backlash, C::eccentricity}, true, 0.7},
  };
  const std::vector<RigOutcome> quiet{
      {{}, {}, {}, false, kNaN}, {{}, {}, {}, true, kNaN}, {{}, {}, {C::noise_floor}, false, kNaN}, {{}, {}, {}, false, kNaN}};
  const auto s = gearwatch::cli::score_rig_outcomes(scenarios, quiet);
  REQUIRE(s.size() == gearwatch::cli::kAllRigFigures.size());

  const auto& named = figure(s, RigFigure::identifiable_named);  // 1, 7, 8, 9 of 1, 5, 6, 7, 8, 9, 10
  CHECK(named.part == 4);
  CHECK(named.whole == 7);
  CHECK(named.value == Approx(4.0 / 7).epsilon(1e-12));
  CHECK_FALSE(named.met());
  CHECK(named.missed_by() == Approx(0.95 - 4.0 / 7).epsilon(1e-12));

  const auto& silent = figure(s, RigFigure::non_identifiable_silent);  // 2 of 2, 3, 4
  CHECK(silent.part == 1);
  CHECK(silent.whole == 3);
  CHECK(silent.missed_by() == Approx(0.95 - 1.0 / 3).epsilon(1e-12));

  const auto& alarms = figure(s, RigFigure::no_effect_false_alarms);  // runs 2 and 3 of 4
  CHECK(alarms.part == 2);
  CHECK(alarms.whole == 4);
  CHECK(alarms.value == 0.5);
  CHECK(alarms.missed_by() == Approx(0.45).epsilon(1e-12));

  const auto& shrink = figure(s, RigFigure::shrinkage);  // 0.4 0.5 0.6 0.7 0.8 0.9 (3's 0.99 and 6's NaN out)
  CHECK(shrink.whole == 6);
  CHECK(shrink.value == Approx(0.65).epsilon(1e-12));
  CHECK(shrink.missed_by() == Approx(0.05).epsilon(1e-9));

  const auto& both = figure(s, RigFigure::both_named);  // 8 of 8, 9
  CHECK(both.part == 1);
  CHECK(both.whole == 2);
  CHECK(both.value == 0.5);
  CHECK(both.missed_by() == Approx(0.2).epsilon(1e-12));

  const auto lines = gearwatch::cli::scores_lines(s);
  REQUIRE(lines.size() == 5);
  CHECK(lines[0] == "identifiable_named 0.57 (4/7; target >= 0.95: missed by 0.38)");
  CHECK(lines[3] == "shrinkage 0.65 (median of 6; target >= 0.70: missed by 0.05)");
  const auto j = gearwatch::cli::scores_json(s);
  CHECK(j["no_effect_false_alarms"]["bound"] == "<=");
  CHECK(j["no_effect_false_alarms"]["met"] == false);
  CHECK(j["both_named"]["part"] == 1);
  CHECK_FALSE(j["shrinkage"].contains("part"));
}

TEST_CASE("gap bench scores: a target reached exactly is met, and a figure without scenarios is not measured",
          "[gap_bench_scores]") {
  using C = CandidateEffect;
  // 19 of 20 identifiable named, 19 of 20 without a trace silent, 1 of 20 no-effect runs alarmed:
  // each exactly at its target.
  std::vector<RigOutcome> scenarios, quiet;
  for (int i = 0; i < 20; ++i) {
    scenarios.push_back({{C::misalignment}, {C::misalignment}, {i == 0 ? C::tip_relief : C::misalignment}, true, 0.70});
    scenarios.push_back({{C::backlash}, {}, {}, i == 0, kNaN});
    quiet.push_back({{}, {}, {}, i == 0, kNaN});
  }
  const auto s = gearwatch::cli::score_rig_outcomes(scenarios, quiet);
  for (auto which : {RigFigure::identifiable_named, RigFigure::non_identifiable_silent, RigFigure::no_effect_false_alarms,
                     RigFigure::shrinkage}) {
    INFO(gearwatch::cli::to_string(which));
    CHECK(figure(s, which).met());
    CHECK(figure(s, which).missed_by() == 0.0);
  }
  CHECK(figure(s, RigFigure::identifiable_named).value == 0.95);
  CHECK(figure(s, RigFigure::no_effect_false_alarms).value == 0.05);
  const auto& both = figure(s, RigFigure::both_named);
  CHECK_FALSE(both.measured());
  CHECK_FALSE(both.met());
  CHECK(std::isnan(both.value));
  CHECK(gearwatch::cli::scores_json(s)["both_named"]["value"].is_null());
  CHECK(gearwatch::cli::scores_lines(s)[4] == "both_named not measured (no such scenario)");
}

}  // namespace test_gap_bench_scores
