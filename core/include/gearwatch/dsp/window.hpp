#pragma once
// The periodic Hann window, the one form every block spectrum here uses.

#include <cmath>
#include <cstddef>
#include <numbers>
#include <vector>

namespace gearwatch::dsp {

/// w[i] = 1/2 − 1/2·cos(2π·i/n), i = 0..n−1: periodic (the DFT-even form), so that blocks at 50 %
/// overlap sum to a constant and a bin-centred tone leaks into its two neighbours only.
inline std::vector<double> periodic_hann(std::size_t n) {
  std::vector<double> w(n);
  for (std::size_t i = 0; i < n; ++i) w[i] = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(n));
  return w;
}

}  // namespace gearwatch::dsp
