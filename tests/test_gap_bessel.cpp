// J_0 … J_K at once (the modulation forms' Jacobi–Anger weights) against the library's J_k one order
// at a time: the power series up to |z| = 4, the backward recurrence beyond.

#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "gearwatch/gap/bessel.hpp"

namespace test_gap_bessel {

using gearwatch::gap::bessel_j_up_to;

TEST_CASE("Bessel J_0 to J_K at once equals the library's J_k order by order", "[gap][bessel]") {
  // Tolerances fixed before running: 1e-12 absolute (|J| ≤ 1), and 1e-9 relative wherever |J| is
  // above 1e-250 (the tail far beyond z, which the forms square and sum, must keep its digits too).
  std::vector<double> j;
  double worst_abs = 0, worst_rel = 0;
  for (double z : {-37.25, -4.5, 0.0, 0.3, 1.0, 3.99, 4.01, 4.5, 7.3, 12.0, 25.5, 63.7, 100.0, 149.9}) {
    for (int k_max : {0, 1, 5, 20, 65}) {
      bessel_j_up_to(k_max, z, j);
      REQUIRE(j.size() == static_cast<std::size_t>(k_max) + 1);
      for (int k = 0; k <= k_max; ++k) {
        const double want = (z < 0 && k % 2 == 1 ? -1.0 : 1.0) * std::cyl_bessel_j(static_cast<double>(k), std::abs(z));
        const double got = j[static_cast<std::size_t>(k)];
        INFO("z " << z << " k " << k << " of " << k_max << ": " << got << " against " << want);
        CHECK(std::abs(got - want) <= 1e-12);
        worst_abs = std::max(worst_abs, std::abs(got - want));
        if (std::abs(want) > 1e-250) {
          CHECK(std::abs(got - want) <= 1e-9 * std::abs(want));
          worst_rel = std::max(worst_rel, std::abs(got - want) / std::abs(want));
        }
      }
    }
  }
  WARN("worst absolute " << worst_abs << ", worst relative " << worst_rel);
}

}  // namespace test_gap_bessel
