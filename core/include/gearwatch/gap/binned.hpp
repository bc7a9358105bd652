#pragma once
// What a 1-order broadband bin reads of a gain that varies inside it: the bin is the sum of two
// half-order Hann bins, so it sees the gain averaged over frequency with their power responses as
// the weight. A peak narrower than a bin lands in it by its area, wherever in the bin it stands,
// which its value at one point in the bin does not give. Pure computation.

#include <algorithm>
#include <cmath>
#include <vector>

#include "gearwatch/dsp/window.hpp"

namespace gearwatch::gap {

/// The average of gain(hz) weighted by the bin's two half-order Hann bins (centred at `first_hz`
/// and first_hz + half_bin_hz), for a gain with one peak at peak_hz of half-width
/// peak_zeta·peak_hz. Trapezoid rule on a grid fine for the kernel (1/32 of a half-order bin, 4
/// bins of reach each side: the kernel falls as ν⁻⁶) and for the peak (a quarter of its half-width,
/// over 12 half-widths each side); the kernel's own sum on the same grid normalises it, so a flat
/// gain reads exactly its value. Where the gain changes little over the kernel (a peak 8 half-order
/// bins wide and more, or a bin beyond the kernel's main lobe and 24 half-widths from the peak) its
/// value at the kernel's centre, half a half-order bin up, is the average to a few per cent of what
/// it lifts there, so that windows of thousands of bins cost one evaluation a bin.
template <class Gain>
double binned_average(double first_hz, double half_bin_hz, double peak_hz, double peak_zeta, Gain&& gain) {
  struct Point {
    double nu, kernel;
    bool operator<(const Point& o) const { return nu < o.nu; }
  };
  constexpr double kReach = 4, kStep = 1.0 / 32;
  const double width = peak_zeta * peak_hz / half_bin_hz, centre = (peak_hz - first_hz) / half_bin_hz;
  if (width > 8 || std::abs(centre - 0.5) > std::max(6.0, 24 * width)) return gain(first_hz + 0.5 * half_bin_hz);
  auto kernel = [](double nu) { return dsp::hann_power_response(nu) + dsp::hann_power_response(nu - 1); };
  static const std::vector<Point> coarse = [&] {
    std::vector<Point> g;
    for (double v = -kReach; v <= 1 + kReach; v += kStep) g.push_back({v, kernel(v)});
    return g;
  }();
  std::vector<Point> fine;
  if (width > 0 && width < 4 * kStep)
    for (double v = std::max(-kReach, centre - 12 * width); v <= std::min(1 + kReach, centre + 12 * width); v += width / 4)
      fine.push_back({v, kernel(v)});
  std::vector<Point> grid(coarse.size() + fine.size());
  std::merge(coarse.begin(), coarse.end(), fine.begin(), fine.end(), grid.begin());
  double weighted = 0, total = 0, previous = gain(first_hz + grid.front().nu * half_bin_hz);
  for (std::size_t i = 1; i < grid.size(); ++i) {
    const Point &a = grid[i - 1], &b = grid[i];
    const double h = 0.5 * (b.nu - a.nu), here = gain(first_hz + b.nu * half_bin_hz);
    weighted += h * (previous * a.kernel + here * b.kernel);
    total += h * (a.kernel + b.kernel);
    previous = here;
  }
  return total > 0 ? weighted / total : 0.0;
}

}  // namespace gearwatch::gap
