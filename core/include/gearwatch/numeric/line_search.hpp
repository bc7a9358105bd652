#pragma once

#include <functional>

namespace gearwatch::numeric {

/// The best point a line search evaluated: x, f(x) and how many evaluations it took.
struct LineSearchResult {
  double x = 0, value = 0;
  int evaluations = 0;
};

/// Maximises f on [lo, hi] by golden-section search (f unimodal there), to a bracket of `tolerance`
/// or `max_evaluations`. A non-finite f(x) counts as -inf. Returns the best x evaluated and f(x).
LineSearchResult golden_section_maximise(const std::function<double(double)>& f, double lo, double hi, double tolerance,
                                         int max_evaluations);

}  // namespace gearwatch::numeric
