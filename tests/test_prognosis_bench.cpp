// `gearwatch bench prognosis` (docs/model.md, "Prognosis benchmark"): its scoring functions
// against hand-computed answers, and the command at small N through the binary.
#include "prognosis_scoring.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "command_runner.hpp"

namespace test_prognosis_bench {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::daemon::prognosis;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

CyclesLeft left(double nominal, double low, double high) { return {true, nominal, low, high}; }

}  // namespace

TEST_CASE("prognosis bench: first_crossing steps forward and bisects to the tolerance", "[prognosis_bench]") {
  // The lubricated campaign's pitting law D = 0.034 ((N − 3e5) / 1e6)^1.5 reaches 0.17 at
  // N* = 3e5 + 1e6 · 5^(2/3) = 3 224 017.7 cycles (closed form).
  int evaluations = 0;
  const TruthCurve pitting = [&](double n) {
    ++evaluations;
    return n > 3e5 ? 0.034 * std::pow((n - 3e5) / 1e6, 1.5) : 0.0;
  };
  const double exact = 3e5 + 1e6 * std::pow(5.0, 2.0 / 3.0);
  const auto found = first_crossing(pitting, 0.17, 0.0, 2e7, 640000.0, 625.0);
  REQUIRE(found);
  // The bracket's upper end: at or after the crossing, by at most the tolerance.
  CHECK(*found >= exact);
  CHECK(*found - exact <= 625.0);
  // 6 forward points (0 .. 3.2e6 reach nothing, 3.84e6 does), then 640000 / 625 = 1024 = 2^10: 10 halvings.
  CHECK(evaluations == 6 + 1 + 10);

  // A crossing between the last step and `to`: the search never evaluates past `to`.
  const TruthCurve line = [](double n) { return n; };
  const auto near_end = first_crossing(line, 2.25, 0.0, 2.3, 1.0, 1e-9);
  REQUIRE(near_end);
  CHECK(*near_end == Approx(2.25).margin(1e-9));
  CHECK_FALSE(first_crossing(line, 2.31, 0.0, 2.3, 1.0, 1e-9));
  // Already at the level where the search starts.
  CHECK(first_crossing(line, 1.0, 5.0, 10.0, 1.0, 1e-3) == std::optional<double>(5.0));
  CHECK_THROWS_AS(first_crossing(line, 1.0, 0.0, 10.0, 0.0, 1e-3), std::invalid_argument);
  CHECK_THROWS_AS(first_crossing(line, 1.0, 0.0, 10.0, 1.0, -1.0), std::invalid_argument);
  CHECK_THROWS_AS(first_crossing(line, 1.0, 10.0, 0.0, 1.0, 1e-3), std::invalid_argument);
}

TEST_CASE("prognosis bench: relative errors and their max and median", "[prognosis_bench]") {
  CHECK(relative_error(110.0, 100.0) == Approx(0.1));
  CHECK(relative_error(50.0, 200.0) == Approx(-0.75));
  CHECK(relative_error(kInf, 200.0) == kInf);
  CHECK(std::isnan(relative_error(1.0, 0.0)));

  // |e| sorted: 0.02 0.05 0.1 0.3: max 0.3, median (0.05 + 0.1) / 2, two within 0.05 (≤ counts).
  const auto even = summarise_errors({0.1, -0.3, 0.02, 0.05}, 0.05);
  CHECK(even.count == 4);
  CHECK(even.max_abs == Approx(0.3));
  CHECK(even.median_abs == Approx(0.075));
  CHECK(even.within == 2);
  // An infinite error (a forecast beyond the horizon) is the max; the median is the middle one.
  const auto odd = summarise_errors({-0.2, 0.1, kInf}, 0.2);
  CHECK(odd.max_abs == kInf);
  CHECK(odd.median_abs == Approx(0.2));
  CHECK(odd.within == 2);
  const auto none = summarise_errors({}, 0.05);
  CHECK(none.count == 0);
  CHECK(std::isnan(none.max_abs));
  CHECK(std::isnan(none.median_abs));
  CHECK_THROWS_AS(summarise_errors({0.1, std::nan("")}, 0.05), std::invalid_argument);
}

TEST_CASE("prognosis bench: intervals, coverage and limits already reached", "[prognosis_bench]") {
  CHECK(interval_holds(left(20, 10, 30), 10));
  CHECK(interval_holds(left(20, 10, 30), 30));
  CHECK_FALSE(interval_holds(left(20, 10, 30), 31));
  CHECK(interval_holds(left(kInf, 10, kInf), kInf));
  CHECK_FALSE(interval_holds(CyclesLeft{}, 20));

  // The truth reaches the limit at 1000 cycles. Hand-computed, record by record:
  //   600: truth 400 left; 500 in [300, 700]: error +0.25, covered.
  //   800: truth 200 left; 150 in [100, 190]: error −0.25, not covered.
  //   900: no forecast: missing, error +inf, not covered.
  //  1000: reached; [0, 50] holds 0: covered.
  //  1100: reached; [10, 40] excludes 0: not covered, excluded.
  const std::vector<ForecastAt> forecasts{
      {600, left(500, 300, 700)}, {800, left(150, 100, 190)}, {900, CyclesLeft{}}, {1000, left(0, 0, 50)}, {1100, left(20, 10, 40)}};
  const LimitScore s = score_limit(forecasts, 1000.0);
  CHECK(s.forecasts == 5);
  CHECK(s.missing == 1);
  CHECK(s.covered == 2);
  CHECK(s.reached == 2);
  CHECK(s.excluded_reached == 1);
  CHECK(s.truth_beyond == 0);
  REQUIRE(s.errors.size() == 3);
  CHECK(s.errors[0] == Approx(0.25));
  CHECK(s.errors[1] == Approx(-0.25));
  CHECK(s.errors[2] == kInf);
  CHECK(coverage(s) == Approx(0.4));

  // A truth that does not reach the limit within the search: only an interval open above holds it,
  // and there is no relative error.
  const LimitScore beyond = score_limit({{0, left(kInf, 5e6, kInf)}, {10, left(4e6, 3e6, 5e6)}}, kInf);
  CHECK(beyond.forecasts == 2);
  CHECK(beyond.covered == 1);
  CHECK(beyond.truth_beyond == 2);
  CHECK(beyond.errors.empty());

  const LimitScore both = combine({s, beyond});
  CHECK(both.forecasts == 7);
  CHECK(both.covered == 3);
  CHECK(both.missing == 1);
  CHECK(both.reached == 2);
  CHECK(both.excluded_reached == 1);
  CHECK(both.truth_beyond == 2);
  CHECK(both.errors.size() == 3);
  CHECK(coverage(both) == Approx(3.0 / 7.0));
  CHECK(std::isnan(coverage(LimitScore{})));
}

TEST_CASE("prognosis bench: the engineer's inspection stops", "[prognosis_bench]") {
  const std::vector<double> levels{0.01, 0.04};
  // First stop past 1 %, then the first later stop past 4 %.
  CHECK(inspection_stops({0, 0.005, 0.02, 0.03, 0.05, 0.1}, levels) == std::vector<std::size_t>{2, 4});
  // Exactly at a level is not past it.
  CHECK(inspection_stops({0, 0.01, 0.011, 0.04, 0.041}, levels) == std::vector<std::size_t>{2, 4});
  // A jump past both levels at once: the second inspection at the next stop.
  CHECK(inspection_stops({0, 0.05, 0.06}, levels) == std::vector<std::size_t>{1, 2});
  CHECK(inspection_stops({0, 0.05}, levels) == std::vector<std::size_t>{1});
  // A dry campaign without pitting: none.
  CHECK(inspection_stops({0, 0, 0}, levels).empty());
  CHECK(first_above({0, 0.04, 0.06, 0.07}, 0.05) == std::optional<std::size_t>(2));
  CHECK_FALSE(first_above({0, 0.05}, 0.05));
}

namespace {

nlohmann::json without_seconds(nlohmann::json campaign) {
  campaign.erase("seconds");
  campaign.erase("cpu_seconds");
  campaign.erase("stage_seconds");
  return campaign;
}

/// The relative error as the bench writes it: a number, or "inf" for a forecast beyond the horizon or none.
nlohmann::json error_json(double value, double truth) {
  return std::isinf(value) ? nlohmann::json("inf") : nlohmann::json((value - truth) / truth);
}

void check_equal_numbers(const nlohmann::json& a, const nlohmann::json& b) {
  REQUIRE(a.size() == b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    INFO("entry " << i);
    if (a[i].is_number()) {
      REQUIRE(b[i].is_number());
      // Recomputed from the trace's doubles (printed exactly by nlohmann-json): the same
      // arithmetic, so equal to rounding.
      CHECK(a[i].get<double>() == Approx(b[i].get<double>()).epsilon(1e-12));
    } else {
      CHECK(a[i] == b[i]);
    }
  }
}

/// The depth errors, recomputed from the campaign's trace: from the record of the second change
/// of K_wear on (all records when there were fewer), records with a truth depth.
void check_depth_scores(const nlohmann::json& c) {
  const auto& trace = c["records_trace"];
  std::size_t changes = 0, from = 0;
  for (std::size_t i = 0; i < trace.size(); ++i)
    for (const auto& u : trace[i]["model"]["updates"])
      if (u["kind"] == "k_wear" && u["new"] != u["old"] && ++changes == 2) from = i;
  CHECK(c["k_wear_updates"] == changes);
  CHECK(c["depth_scored_from_record"] == (changes >= 2 ? from : 0));
  nlohmann::json expected = nlohmann::json::array();
  for (std::size_t i = c["depth_scored_from_record"]; i < trace.size(); ++i) {
    const double truth = trace[i]["truth"]["combined_mean_depth_m"];
    // The model's depth estimate: the forecast's (calibrated by inspected depths where any), else the state's.
    const auto& f = trace[i]["forecast"];
    const double forecast_mean = f["combined_mean_depth_m"][1].get<double>();
    const double estimate = f["valid"].get<bool>() && forecast_mean > 0 ? forecast_mean : trace[i]["model"]["combined_mean_depth_m"].get<double>();
    if (truth > 0) expected.push_back(error_json(estimate, truth));
  }
  check_equal_numbers(c["depth_errors"], expected);
  // The depth interval's coverage over the same records: [low, high] of the forecast's depth holds the truth.
  std::size_t scored = 0, covered = 0;
  for (std::size_t i = c["depth_scored_from_record"]; i < trace.size(); ++i) {
    const double truth = trace[i]["truth"]["combined_mean_depth_m"];
    const auto& f = trace[i]["forecast"];
    if (!(truth > 0) || !f["valid"].get<bool>() || !(f["combined_mean_depth_m"][2].get<double>() > 0)) continue;
    ++scored;
    if (f["combined_mean_depth_m"][0].get<double>() <= truth && truth <= f["combined_mean_depth_m"][2].get<double>()) ++covered;
  }
  CHECK(c["depth_interval"]["scored"] == scored);
  CHECK(c["depth_interval"]["covered"] == covered);
}

/// The pitting forecasts' errors and coverage, recomputed from the trace and the truth's crossing.
void check_pitting_scores(const nlohmann::json& c) {
  const auto& trace = c["records_trace"];
  const auto& p = c["pitting"];
  std::size_t start = trace.size();
  for (std::size_t i = 0; i < trace.size() && start == trace.size(); ++i)
    if (trace[i]["truth"]["pitting_density"].get<double>() > 0.05) start = i;
  CHECK(p["forecasts"] == trace.size() - start);
  if (start == trace.size()) return;
  REQUIRE(p["truth_crossing_cycles"].is_number());
  const double crossing = p["truth_crossing_cycles"];
  nlohmann::json expected = nlohmann::json::array();
  std::size_t covered = 0;
  auto value = [](const nlohmann::json& v) { return v.is_null() ? kInf : v.get<double>(); };
  for (std::size_t i = start; i < trace.size(); ++i) {
    const double truth_left = std::max(0.0, crossing - trace[i]["cycles"].get<double>());
    const auto& f = trace[i]["forecast"];
    const auto& l = f["pitting_cycles_left"];
    const bool valid = f["valid"];
    if (valid && value(l[0]) <= truth_left && truth_left <= value(l[2])) ++covered;
    if (truth_left > 0) expected.push_back(valid ? error_json(value(l[1]), truth_left) : nlohmann::json("inf"));
  }
  check_equal_numbers(p["errors"], expected);
  CHECK(p["covered"] == covered);
}

}  // namespace

TEST_CASE("prognosis bench: two campaigns through the binary, scores recomputed from the trace", "[prognosis_bench][cli]") {
  // Two campaigns of 6 records on two threads, and the second again alone: a campaign's scores do
  // not depend on the threads it ran beside.
  const auto r = gearwatch::testing::run_command(std::string(GEARWATCH_BINARY) +
                                                 " bench prognosis --campaigns 2 --records 6 --jobs 2 --format json");
  INFO(r.err);
  REQUIRE(r.status == 0);
  const auto j = nlohmann::json::parse(r.out);
  REQUIRE(j["campaigns"].size() == 2);
  // The bench's wear limit (100 um by default: inside the campaigns' depths) is the model's and the scores'.
  CHECK(j["settings"]["wear_limit_m"].get<double>() == Approx(1e-4).epsilon(1e-12));
  const auto& summary = j["summary"];
  REQUIRE(summary["targets"].size() == 5);
  const std::vector<std::string> names{"depth_error_max", "pitting_cycles_left_error_max", "wear_cycles_left_error_max",
                                       "interval_coverage", "intervals_excluding_a_reached_limit"};
  for (std::size_t k = 0; k < names.size(); ++k) {
    const auto& t = summary["targets"][k];
    INFO(t.dump());
    CHECK(t["name"] == names[k]);
    // met follows from the value and the target; null only when nothing was scored.
    if (t["count"] == 0) CHECK(t["met"].is_null());
    else if (t["value"].is_number())
      CHECK(t["met"] == (t["comparison"] == "<=" ? t["value"].get<double>() <= t["target"].get<double>()
                                                 : t["value"].get<double>() >= t["target"].get<double>()));
    else CHECK(t["met"] == false);  // "inf": a forecast beyond the horizon, or none
    // Not asserted: what today's model reaches. The targets are issue 34's; printed for the reader.
    WARN("bench prognosis --campaigns 2 --records 6: " << t["name"] << " = " << t["value"] << " (target " << t["comparison"]
                                                       << " " << t["target"] << "): "
                                                       << (t["met"].is_null() ? "no data" : t["met"] ? "met" : "missed"));
  }
  CHECK(j["summary"]["failed_campaigns"] == 0);
  for (const auto& c : j["campaigns"]) {
    INFO(c["campaign"] << " seed " << c["seed"]);
    REQUIRE_FALSE(c.contains("failure"));
    CHECK(c["records"] == 6);
    REQUIRE(c["records_trace"].size() == 6);
    check_depth_scores(c);
    check_pitting_scores(c);
    // The inspection rule on the trace's truth: first stop past 1 %, first later stop past 4 %
    // pitting, and the first stops whose deepest point passes 1/4 and 1/2 of the wear limit; a stop once.
    std::vector<double> density, deepest;
    for (const auto& t : c["records_trace"]) density.push_back(t["truth"]["pitting_density"]), deepest.push_back(t["truth"]["max_depth_m"]);
    std::vector<std::size_t> stops = inspection_stops(density, {0.01, 0.04});
    for (const std::size_t s : inspection_stops(deepest, {0.25e-4, 0.5e-4}))
      if (std::find(stops.begin(), stops.end(), s) == stops.end()) stops.push_back(s);
    CHECK(c["inspections"] == stops.size());
  }
  // Random campaigns (rig::random_campaign): the truth's crossing of the pitting limit agrees with
  // the trace's truth, a stop whose truth is below the limit lies before it, one at or above after.
  for (const auto& c : j["campaigns"]) {
    const auto& crossing = c["pitting"]["truth_crossing_cycles"];
    if (!crossing.is_number()) continue;
    for (const auto& t : c["records_trace"]) {
      const double density = t["truth"]["pitting_density"], cycles = t["cycles"];
      if (density < 0.17) CHECK(cycles < crossing.get<double>());
      else CHECK(cycles >= crossing.get<double>());
    }
  }
  const auto alone = gearwatch::testing::run_command(std::string(GEARWATCH_BINARY) +
                                                     " bench prognosis --campaigns 1 --seed 2 --records 6 --format json");
  REQUIRE(alone.status == 0);
  CHECK(without_seconds(nlohmann::json::parse(alone.out)["campaigns"][0]) == without_seconds(j["campaigns"][1]));
}

TEST_CASE("prognosis bench: bad options are refused in one line before anything is simulated", "[prognosis_bench][cli]") {
  const std::string bench = std::string(GEARWATCH_BINARY) + " bench prognosis";
  for (const char* bad : {" --campaigns 0", " --records 1", " --jobs 0", " --seconds 0.1", " --inspection-sd -0.1",
                          " --wear-limit-um -1", " --wear-limit-um 500", " --inspection-depth-sd 0", " --inspection-depth-sd 1"}) {
    INFO(bad);
    const auto r = gearwatch::testing::run_command(bench + bad);
    CHECK(r.status == 64);  // the parser's refusal (EX_USAGE)
    CHECK(r.out.empty());
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  }
  // A directory is not a configuration file: refused with the path (docs/cli.md, --config).
  const auto dir = gearwatch::testing::run_command(bench + " --config " + GEARWATCH_SOURCE_DIR);
  CHECK(dir.status != 0);
  CHECK(dir.out.empty());
  CHECK(dir.err.rfind("gearwatch: ", 0) == 0);
  CHECK(dir.err.find(GEARWATCH_SOURCE_DIR) != std::string::npos);
  CHECK(std::count(dir.err.begin(), dir.err.end(), '\n') == 1);
}

}  // namespace test_prognosis_bench
