#pragma once
// Gauss–Legendre rules on [-1, 1], computed once per order (Newton on the Legendre recurrence).
#include <vector>

namespace gearwatch::wear {

struct QuadratureRule {
  std::vector<double> nodes;
  std::vector<double> weights;
};

/// The n-point rule (1 ≤ n ≤ 64); exact for polynomials of degree 2n − 1. Cached, thread-safe.
const QuadratureRule& gauss_legendre(int n);

}  // namespace gearwatch::wear
