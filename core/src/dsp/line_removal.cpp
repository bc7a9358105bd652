#include "gearwatch/dsp/line_removal.hpp"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace gearwatch::dsp {

namespace {
// The alignment FFTW's plans were made for (fftw_malloc'd arrays: RealBuffer).
bool fft_aligned(const double* p) { return fftw_alignment_of(const_cast<double*>(p)) == 0; }
}  // namespace

DiscreteLineRemover::DiscreteLineRemover(std::size_t block_bins) : block_bins_(block_bins) {
  if (block_bins_ < 8) throw std::invalid_argument("DiscreteLineRemover: block of fewer than 8 bins");
}

/// Marks is_line_ around every bin of 1..bins whose power exceeds `factor` times its block's
/// median / ln 2 (the last block takes the remainder with the one before it, so no block is
/// short). Each block's level is compared as soon as it is known: no per-bin level array.
void DiscreteLineRemover::mark_lines(std::size_t bins, double factor) {
  is_line_.assign(bins + 2, 0);
  const std::size_t blocks = std::max<std::size_t>(1, bins / block_bins_);
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t first = 1 + b * block_bins_;
    const std::size_t last = b + 1 == blocks ? bins : first + block_bins_ - 1;
    block_.assign(power_.begin() + static_cast<std::ptrdiff_t>(first), power_.begin() + static_cast<std::ptrdiff_t>(last + 1));
    auto middle = block_.begin() + static_cast<std::ptrdiff_t>(block_.size() / 2);
    std::nth_element(block_.begin(), middle, block_.end());
    const double threshold = factor * (*middle / std::numbers::ln2);
    for (std::size_t k = first; k <= last; ++k)
      if (power_[k] > threshold) is_line_[k - 1] = is_line_[k] = is_line_[k + 1] = 1;
  }
}

LineRemovalResult DiscreteLineRemover::remove(std::span<double> x, FftPlanCache& plans) {
  const std::size_t n = x.size();
  // DC and, for an even length, the Nyquist bin are not tested.
  const std::size_t bins = n % 2 == 0 ? n / 2 - 1 : (n - 1) / 2;
  if (n < min_length()) throw std::invalid_argument("DiscreteLineRemover: need at least 4 blocks of bins");
  const RealFft& fft = plans.real(n);
  spectrum_.resize(fft.spectrum_size());
  // The transforms need SIMD-aligned arrays: x itself when it is (an FFTW buffer), else a copy.
  const bool aligned = fft_aligned(x.data());
  if (aligned) {
    fft.forward(x, spectrum_);  // r2c plans leave their input as it is
  } else {
    power_.assign(x.begin(), x.end());
    fft.forward(power_, spectrum_);
  }
  power_.resize(bins + 1);
  power_[0] = 0.0;
  double total = 0.0;
  for (std::size_t k = 1; k <= bins; ++k) total += (power_[k] = std::norm(spectrum_[k]));
  mark_lines(bins, std::log(static_cast<double>(bins)));
  LineRemovalResult result;
  double removed = 0.0;
  for (std::size_t k = 1; k <= bins; ++k) {
    if (!is_line_[k]) continue;
    removed += power_[k];
    spectrum_[k] = Complex{};
    ++result.bins_removed;
  }
  if (result.bins_removed == 0) return result;
  result.energy_removed_fraction = total > 0.0 ? removed / total : 0.0;
  const double scale = 1.0 / static_cast<double>(n);
  if (aligned) {
    fft.inverse(spectrum_, x);
    for (double& v : x) v *= scale;
  } else {
    power_.resize(n);
    fft.inverse(spectrum_, power_);
    for (std::size_t j = 0; j < n; ++j) x[j] = power_[j] * scale;
  }
  return result;
}

}  // namespace gearwatch::dsp
