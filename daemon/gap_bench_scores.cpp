#include "gap_bench_scores.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <iomanip>

#include "gap_bench_output.hpp"

namespace gearwatch::cli {
namespace {

bool contains(const std::vector<gap::CandidateEffect>& v, gap::CandidateEffect c) {
  return std::find(v.begin(), v.end(), c) != v.end();
}

ScoreFigure rate(RigFigure figure, int part, int whole) {
  return {figure, fraction(part, whole), part, whole, rig_target(figure), rig_bound(figure)};
}

/// Median of the finite values; NaN when there are none.
double finite_median(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

const char* to_string(RigFigure figure) noexcept {
  switch (figure) {
    case RigFigure::identifiable_named: return "identifiable_named";
    case RigFigure::non_identifiable_silent: return "non_identifiable_silent";
    case RigFigure::no_effect_false_alarms: return "no_effect_false_alarms";
    case RigFigure::shrinkage: return "shrinkage";
    case RigFigure::both_named: return "both_named";
  }
  return "unknown";
}

double rig_target(RigFigure figure) noexcept {
  switch (figure) {
    case RigFigure::identifiable_named: return 0.95;
    case RigFigure::non_identifiable_silent: return 0.95;
    case RigFigure::no_effect_false_alarms: return 0.05;
    case RigFigure::shrinkage: return 0.70;
    case RigFigure::both_named: return 0.70;
  }
  return 0;
}

TargetBound rig_bound(RigFigure figure) noexcept {
  return figure == RigFigure::no_effect_false_alarms ? TargetBound::at_most : TargetBound::at_least;
}

bool ScoreFigure::met() const noexcept {
  if (!measured() || !std::isfinite(value)) return false;
  return bound == TargetBound::at_least ? value >= target : value <= target;
}

double ScoreFigure::missed_by() const noexcept {
  if (!measured() || !std::isfinite(value) || met()) return 0;
  return std::abs(value - target);
}

bool finds_something(const RigOutcome& o) noexcept { return o.detected || !o.chosen.empty(); }

std::vector<ScoreFigure> score_rig_outcomes(const std::vector<RigOutcome>& scenarios, const std::vector<RigOutcome>& no_effect) {
  int named = 0, with_trace = 0, silent = 0, without_trace = 0, both = 0, both_identifiable = 0;
  std::vector<double> shrink;
  for (const auto& s : scenarios) {
    if (s.identifiable.empty()) {
      ++without_trace;
      silent += !finds_something(s);
      continue;
    }
    ++with_trace;
    named += !s.chosen.empty() && contains(s.identifiable, s.chosen.front());
    if (std::isfinite(s.shrinkage)) shrink.push_back(s.shrinkage);
    if (s.truth.size() == 2 && s.identifiable.size() == 2) {
      ++both_identifiable;
      both += contains(s.chosen, s.truth[0]) && contains(s.chosen, s.truth[1]);
    }
  }
  int alarms = 0;
  for (const auto& q : no_effect) alarms += finds_something(q);
  const int n_shrink = static_cast<int>(shrink.size());
  ScoreFigure median_shrinkage{RigFigure::shrinkage, finite_median(std::move(shrink)), 0, n_shrink,
                               rig_target(RigFigure::shrinkage), rig_bound(RigFigure::shrinkage)};
  return {rate(RigFigure::identifiable_named, named, with_trace), rate(RigFigure::non_identifiable_silent, silent, without_trace),
          rate(RigFigure::no_effect_false_alarms, alarms, static_cast<int>(no_effect.size())), median_shrinkage,
          rate(RigFigure::both_named, both, both_identifiable)};
}

nlohmann::json scores_json(const std::vector<ScoreFigure>& figures) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& f : figures) {
    nlohmann::json e{{"value", number_or_null(f.value)},
                     {"whole", f.whole},
                     {"target", f.target},
                     {"bound", f.bound == TargetBound::at_least ? ">=" : "<="},
                     {"met", f.met()},
                     {"missed_by", f.missed_by()}};
    if (f.figure != RigFigure::shrinkage) e["part"] = f.part;
    j[to_string(f.figure)] = e;
  }
  return j;
}

std::vector<std::string> scores_lines(const std::vector<ScoreFigure>& figures) {
  std::vector<std::string> lines;
  for (const auto& f : figures) {
    auto s = table_stream();
    s << to_string(f.figure) << " ";
    if (!f.measured()) {
      s << "not measured (no such scenario)";
    } else {
      s << f.value << " (";
      if (f.figure == RigFigure::shrinkage)
        s << "median of " << f.whole;
      else
        s << f.part << "/" << f.whole;
      s << "; target " << (f.bound == TargetBound::at_least ? ">= " : "<= ") << f.target << ": ";
      if (f.met())
        s << "met)";
      else
        s << "missed by " << f.missed_by() << ")";
    }
    lines.push_back(s.str());
  }
  return lines;
}

}  // namespace gearwatch::cli
