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

/// The periodic Hann window's power response ν bins from a bin's centre (the continuous-time form,
/// long windows), 1 at 0: (sinc ν / (1 − ν²))²; 1/4 at ν = ±1, 0 at every other integer.
inline double hann_power_response(double nu) {
  if (std::abs(nu) < 1e-9) return 1.0;
  if (std::abs(std::abs(nu) - 1.0) < 1e-9) return 0.25;
  const double v = std::sin(std::numbers::pi * nu) / (std::numbers::pi * nu) / (1.0 - nu * nu);
  return v * v;
}

}  // namespace gearwatch::dsp
