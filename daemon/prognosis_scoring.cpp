#include "prognosis_scoring.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace gearwatch::daemon::prognosis {

std::optional<double> first_crossing(const TruthCurve& curve, double level, double from, double to, double step,
                                     double tolerance) {
  if (!(step > 0) || !(tolerance > 0)) throw std::invalid_argument("first_crossing: step and tolerance must be positive");
  if (!(to >= from)) throw std::invalid_argument("first_crossing: the search ends before it starts");
  if (curve(from) >= level) return from;
  double lo = from;
  double hi = from;
  for (;;) {
    if (hi >= to) return std::nullopt;
    lo = hi;
    hi = std::min(to, lo + step);
    if (curve(hi) >= level) break;
  }
  // curve(lo) < level ≤ curve(hi).
  while (hi - lo > tolerance) {
    const double mid = 0.5 * (lo + hi);
    if (curve(mid) >= level) hi = mid;
    else lo = mid;
  }
  return hi;
}

std::vector<std::size_t> inspection_stops(const std::vector<double>& truth, const std::vector<double>& levels) {
  std::vector<std::size_t> stops;
  std::size_t next = 0;
  for (double level : levels) {
    while (next < truth.size() && !(truth[next] > level)) ++next;
    if (next == truth.size()) break;
    stops.push_back(next++);
  }
  return stops;
}

std::optional<std::size_t> first_above(const std::vector<double>& values, double level) {
  for (std::size_t i = 0; i < values.size(); ++i)
    if (values[i] > level) return i;
  return std::nullopt;
}

double relative_error(double value, double truth) {
  if (truth == 0) return std::numeric_limits<double>::quiet_NaN();
  if (std::isinf(value)) return kInfinity;
  return (value - truth) / truth;
}

ErrorSummary summarise_errors(const std::vector<double>& errors, double target) {
  ErrorSummary s;
  std::vector<double> a;
  a.reserve(errors.size());
  for (double e : errors) {
    if (std::isnan(e)) throw std::invalid_argument("summarise_errors: an undefined (NaN) error");
    a.push_back(std::abs(e));
  }
  s.count = a.size();
  if (a.empty()) return s;
  std::sort(a.begin(), a.end());
  s.max_abs = a.back();
  const std::size_t n = a.size();
  s.median_abs = n % 2 == 1 ? a[n / 2] : 0.5 * (a[n / 2 - 1] + a[n / 2]);
  s.within = static_cast<std::size_t>(std::count_if(a.begin(), a.end(), [target](double x) { return x <= target; }));
  return s;
}

bool interval_holds(const CyclesLeft& f, double truth) {
  return f.valid && f.low <= truth && truth <= f.high;
}

LimitScore score_limit(const std::vector<ForecastAt>& forecasts, double crossing) {
  LimitScore s;
  for (const auto& f : forecasts) {
    ++s.forecasts;
    if (!f.left.valid) ++s.missing;
    const double truth_left = std::max(0.0, crossing - f.cycles);
    if (std::isinf(crossing)) ++s.truth_beyond;
    if (interval_holds(f.left, truth_left)) ++s.covered;
    if (truth_left == 0) {
      ++s.reached;
      if (f.left.valid && !interval_holds(f.left, 0.0)) ++s.excluded_reached;
    } else if (!std::isinf(truth_left)) {
      s.errors.push_back(f.left.valid ? relative_error(f.left.nominal, truth_left) : kInfinity);
    }
  }
  return s;
}

LimitScore combine(const std::vector<LimitScore>& scores) {
  LimitScore t;
  for (const auto& s : scores) {
    t.forecasts += s.forecasts;
    t.missing += s.missing;
    t.covered += s.covered;
    t.reached += s.reached;
    t.excluded_reached += s.excluded_reached;
    t.truth_beyond += s.truth_beyond;
    t.errors.insert(t.errors.end(), s.errors.begin(), s.errors.end());
  }
  return t;
}

double coverage(const LimitScore& s) {
  return s.forecasts == 0 ? std::numeric_limits<double>::quiet_NaN()
                          : static_cast<double>(s.covered) / static_cast<double>(s.forecasts);
}

}  // namespace gearwatch::daemon::prognosis
