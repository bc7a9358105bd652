#pragma once
// Spectral coherence at one cyclic order (thesis Eq. 4.2),
//   gamma(alpha, f) = S(alpha, f) / sqrt(S(0, f) S(0, f - alpha)),
// estimated by the averaged cyclic periodogram (Welch: Hann windows, 50 % overlap) of an
// angle-domain signal, and the "mean carrier frequency" of Fig. 4.13: the first moment of
// |gamma(alpha, .)| along the spectral frequency axis over a range.
#include <cstddef>
#include <span>
#include <vector>

#include "gearwatch/dsp/fft.hpp"

namespace gearwatch::dsp {

class CyclicCoherenceEstimator {
 public:
  explicit CyclicCoherenceEstimator(FftPlanCache& plans) : plans_(&plans) {}

  /// x: angle-domain signal, samples_per_rev per revolution; cyclic_order must be a whole number
  /// of orders (the gear-mesh order); the window is one revolution, so the spectral resolution is
  /// one order and alpha falls on a bin. Returns the number of segments averaged.
  /// Throws std::invalid_argument when x holds fewer than two revolutions.
  std::size_t estimate(std::span<const double> x, std::size_t samples_per_rev, int cyclic_order);

  /// |gamma(alpha, f)| for f = k orders, k = 0..samples_per_rev/2; 0 where f < alpha.
  std::span<const double> coherence() const noexcept { return coherence_; }

  /// Mean of f weighted by |gamma| over [low, high] orders (inclusive bins); NaN when the
  /// weights sum to zero.
  double mean_carrier_order(double low_order, double high_order) const;

 private:
  FftPlanCache* plans_;
  RealBuffer segment_;
  ComplexBuffer spectrum_;
  std::vector<double> window_, power_, coherence_;
  std::vector<Complex> cross_;
};

}  // namespace gearwatch::dsp
