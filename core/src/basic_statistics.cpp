#include "gearwatch/basic_statistics.hpp"

#include <cmath>

namespace gearwatch {

SignalStatistics compute_statistics(std::span<const float> x) noexcept {
  SignalStatistics s;
  double sum = 0;
  std::size_t n = 0;
  for (float v : x) {
    if (!std::isfinite(v)) {
      ++s.non_finite;
      continue;
    }
    sum += v;
    ++n;
  }
  if (n == 0) return s;
  s.mean = sum / static_cast<double>(n);
  double m2 = 0, m4 = 0, sq = 0, peak = 0;
  for (float v : x) {
    if (!std::isfinite(v)) continue;
    const double d = v - s.mean;
    const double d2 = d * d;
    m2 += d2;
    m4 += d2 * d2;
    sq += static_cast<double>(v) * v;
    peak = std::max(peak, std::fabs(static_cast<double>(v)));
  }
  m2 /= static_cast<double>(n);
  m4 /= static_cast<double>(n);
  s.rms = std::sqrt(sq / static_cast<double>(n));
  s.peak = peak;
  s.kurtosis = m2 > 0 ? m4 / (m2 * m2) : 0.0;
  s.crest_factor = s.rms > 0 ? peak / s.rms : 0.0;
  return s;
}

std::optional<double> mean_speed_from_edges(std::span<const double> edges, int edges_per_rev, double sample_rate_hz) noexcept {
  if (edges.size() < 2 || edges_per_rev < 1 || sample_rate_hz <= 0) return std::nullopt;
  const double span_samples = edges.back() - edges.front();
  if (span_samples <= 0) return std::nullopt;
  const double revolutions = static_cast<double>(edges.size() - 1) / edges_per_rev;
  return revolutions / (span_samples / sample_rate_hz);
}

}  // namespace gearwatch
