#include "gearwatch/dsp/spectral_coherence.hpp"
#include "gearwatch/dsp/window.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace gearwatch::dsp {

std::size_t CyclicCoherenceEstimator::estimate(std::span<const double> x, std::size_t samples_per_rev,
                                               int cyclic_order) {
  const std::size_t nw = samples_per_rev;
  if (nw < 4 || x.size() < 2 * nw) throw std::invalid_argument("spectral coherence: need two revolutions");
  if (cyclic_order < 1 || static_cast<std::size_t>(cyclic_order) >= nw / 2)
    throw std::invalid_argument("spectral coherence: cyclic order outside (0, Nyquist)");
  const auto alpha = static_cast<std::size_t>(cyclic_order);
  const RealFft& fft = plans_->real(nw);
  const std::size_t bins = fft.spectrum_size();
  if (window_.size() != nw) window_ = periodic_hann(nw);
  segment_.resize(nw);
  spectrum_.resize(bins);
  power_.assign(bins, 0.0);
  cross_.assign(bins, Complex{});
  const std::size_t hop = nw / 2;
  std::size_t segments = 0;
  for (std::size_t start = 0; start + nw <= x.size(); start += hop, ++segments) {
    for (std::size_t i = 0; i < nw; ++i) segment_[i] = x[start + i] * window_[i];
    fft.forward(segment_, spectrum_);
    // The cyclic periodogram of a segment starting at angle theta_s carries the phase
    // exp(j 2 pi alpha theta_s); remove it so segments add coherently.
    const double theta = static_cast<double>(start) / static_cast<double>(nw);
    const Complex rotate = std::polar(1.0, -2.0 * std::numbers::pi * static_cast<double>(alpha) * theta);
    for (std::size_t k = 0; k < bins; ++k) power_[k] += std::norm(spectrum_[k]);
    // S[k] conj(S[k - alpha]) rotate in real arithmetic: the products and sums std::complex forms
    // for finite operands, without its NaN recovery call, which keeps the loop from vectorising.
    const double rr = rotate.real(), ri = rotate.imag();
    for (std::size_t k = alpha; k < bins; ++k) {
      const double ar = spectrum_[k].real(), ai = spectrum_[k].imag();
      const double br = spectrum_[k - alpha].real(), bi = -spectrum_[k - alpha].imag();
      const double pr = ar * br - ai * bi, pi = ar * bi + ai * br;
      cross_[k] += Complex(pr * rr - pi * ri, pr * ri + pi * rr);
    }
  }
  coherence_.assign(bins, 0.0);
  for (std::size_t k = alpha; k < bins; ++k) {
    const double denom = std::sqrt(power_[k] * power_[k - alpha]);
    coherence_[k] = denom > 0.0 ? std::abs(cross_[k]) / denom : 0.0;
  }
  return segments;
}

double CyclicCoherenceEstimator::mean_carrier_order(double low_order, double high_order) const {
  if (coherence_.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto lo = static_cast<std::size_t>(std::max(0.0, std::ceil(low_order)));
  const auto hi = std::min(coherence_.size() - 1, static_cast<std::size_t>(std::floor(high_order)));
  double weighted = 0.0, total = 0.0;
  for (std::size_t k = lo; k <= hi; ++k) {
    weighted += static_cast<double>(k) * coherence_[k];
    total += coherence_[k];
  }
  return total > 0.0 ? weighted / total : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace gearwatch::dsp
