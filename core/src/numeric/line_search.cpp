#include "gearwatch/numeric/line_search.hpp"

#include <cmath>
#include <limits>

namespace gearwatch::numeric {

LineSearchResult golden_section_maximise(const std::function<double(double)>& f, double lo, double hi, double tolerance,
                                         int max_evaluations) {
  const double invphi = (std::sqrt(5.0) - 1.0) / 2.0;
  LineSearchResult best{lo, -std::numeric_limits<double>::infinity(), 0};
  auto eval = [&](double x) {
    double v = f(x);
    if (!std::isfinite(v)) v = -std::numeric_limits<double>::infinity();
    ++best.evaluations;
    if (v > best.value) {
      best.value = v;
      best.x = x;
    }
    return v;
  };
  double a = lo, b = hi;
  double c = b - invphi * (b - a), d = a + invphi * (b - a);
  double fc = eval(c), fd = eval(d);
  while (b - a > tolerance && best.evaluations < max_evaluations) {
    if (fc >= fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - invphi * (b - a);
      fc = eval(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + invphi * (b - a);
      fd = eval(d);
    }
  }
  return best;
}

}  // namespace gearwatch::numeric
