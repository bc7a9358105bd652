#include "gearwatch/wear/quadrature.hpp"

#include <array>
#include <cmath>
#include <mutex>
#include <numbers>

#include "gearwatch/twin/errors.hpp"

namespace gearwatch::wear {

namespace {
QuadratureRule build(int n) {
  QuadratureRule r;
  r.nodes.resize(static_cast<std::size_t>(n));
  r.weights.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    double x = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));  // Tricomi's first guess
    double dp = 1;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      const double pn = n == 1 ? x : p1, pn1 = n == 1 ? 1.0 : p0;
      dp = n * (x * pn - pn1) / (x * x - 1.0);
      const double dx = pn / dp;
      x -= dx;
      if (std::abs(dx) < 1e-15) break;
    }
    r.nodes[static_cast<std::size_t>(i)] = x;
    r.weights[static_cast<std::size_t>(i)] = 2.0 / ((1.0 - x * x) * dp * dp);
  }
  return r;
}
}  // namespace

const QuadratureRule& gauss_legendre(int n) {
  if (n < 1 || n > 64) throw twin::TwinParameterError("Gauss-Legendre order must lie in [1, 64]");
  static std::array<QuadratureRule, 65> cache;
  static std::array<std::once_flag, 65> once;
  std::call_once(once[static_cast<std::size_t>(n)], [n] { cache[static_cast<std::size_t>(n)] = build(n); });
  return cache[static_cast<std::size_t>(n)];
}

}  // namespace gearwatch::wear
