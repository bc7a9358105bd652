#include "gearwatch/gap/bessel.hpp"

#include <algorithm>
#include <cmath>

namespace gearwatch::gap {
namespace {

// Σ_m (−1)^m (z/2)^{2m+k}/(m!(m+k)!): its terms stay under e^z, so for |z| ≤ 4 double keeps 1e-13
// and 40 terms reach 1e-30.
void by_power_series(int k_max, double z, std::vector<double>& j) {
  const double h = z / 2.0, q = -h * h;
  double lead = 1.0;  // (z/2)^k / k!
  for (int k = 0; k <= k_max; ++k) {
    if (k > 0) lead *= h / k;
    double term = lead, sum = lead;
    for (int m = 1; m < 40 && std::abs(term) > 1e-17 * std::abs(sum); ++m) {
      term *= q / (m * static_cast<double>(m + k));
      sum += term;
    }
    j[static_cast<std::size_t>(k)] = sum;
  }
}

// J_{n−1} = (2n/z) J_n − J_{n+1} run downward is stable (it grows the minimal solution), from an
// order far enough above both K and z that the arbitrary start has died out by order K (the
// classical start: the order plus a margin growing as its square root). The values are scaled down
// whenever they grow large, and the whole set scaled by the sum rule at the end.
void by_backward_recurrence(int k_max, double z, std::vector<double>& j) {
  const double reach = std::max(static_cast<double>(k_max), std::abs(z));
  const int start = 2 * (static_cast<int>(reach + 20.0 + std::sqrt(60.0 * reach)) / 2);  // even
  constexpr double kLarge = 1e250;
  double above = 0.0, here = 1e-300, even_sum = 0.0;
  for (int n = start; n > 0; --n) {
    const double below = 2.0 * n / z * here - above;  // J_{n−1}
    above = here, here = below;
    if (n - 1 <= k_max) j[static_cast<std::size_t>(n - 1)] = here;
    if ((n - 1) % 2 == 0 && n - 1 > 0) even_sum += here;
    if (std::abs(here) > kLarge) {
      above /= kLarge, here /= kLarge, even_sum /= kLarge;
      for (int k = n - 1; k <= k_max; ++k) j[static_cast<std::size_t>(k)] /= kLarge;
    }
  }
  const double norm = here + 2.0 * even_sum;  // J_0 + 2 Σ J_2m = 1
  for (double& v : j) v /= norm;
}

}  // namespace

void bessel_j_up_to(int k_max, double z, std::vector<double>& j) {
  j.assign(static_cast<std::size_t>(std::max(k_max, 0)) + 1, 0.0);
  if (z == 0.0) {
    j[0] = 1.0;
    return;
  }
  if (std::abs(z) <= 4.0) return by_power_series(k_max, z, j);
  by_backward_recurrence(k_max, std::abs(z), j);
  if (z < 0)  // J_k(−z) = (−1)^k J_k(z)
    for (std::size_t k = 1; k < j.size(); k += 2) j[k] = -j[k];
}

}  // namespace gearwatch::gap
