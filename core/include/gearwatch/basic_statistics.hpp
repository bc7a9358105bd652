#pragma once
// Plain per-channel statistics of a record, and the input speed measured from the tacho.
// These are the classical indicators' raw-signal half (seed Tables 4.1/4.2: RMS, kurtosis).
#include <optional>
#include <span>

namespace gearwatch {

struct SignalStatistics {
  double mean = 0, rms = 0, peak = 0, kurtosis = 0, crest_factor = 0;
  std::size_t non_finite = 0;   ///< NaN/Inf samples (excluded from the moments)
};

/// Moments about the mean; kurtosis is the plain fourth standardised moment (3 for Gaussian).
SignalStatistics compute_statistics(std::span<const float> x) noexcept;

/// Mean shaft speed (Hz) from edge positions (samples) — (edges−1)/edges_per_rev revolutions
/// over the time between the first and the last edge. nullopt with fewer than two edges.
std::optional<double> mean_speed_from_edges(std::span<const double> edges, int edges_per_rev, double sample_rate_hz) noexcept;

}  // namespace gearwatch
