#include "gearwatch/dsp/line_removal.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace gearwatch::dsp {

DiscreteLineRemover::DiscreteLineRemover(std::size_t block_bins) : block_bins_(block_bins) {
  if (block_bins_ < 8) throw std::invalid_argument("DiscreteLineRemover: block of fewer than 8 bins");
}

/// level_[k] = the median of bin k's block / ln 2, for bins 1..bins (the last block takes the
/// remainder with the one before it, so no block is short).
void DiscreteLineRemover::local_levels(std::size_t bins) {
  level_.assign(bins + 1, 0.0);
  const std::size_t blocks = std::max<std::size_t>(1, bins / block_bins_);
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t first = 1 + b * block_bins_;
    const std::size_t last = b + 1 == blocks ? bins : first + block_bins_ - 1;
    block_.assign(power_.begin() + static_cast<std::ptrdiff_t>(first), power_.begin() + static_cast<std::ptrdiff_t>(last + 1));
    auto middle = block_.begin() + static_cast<std::ptrdiff_t>(block_.size() / 2);
    std::nth_element(block_.begin(), middle, block_.end());
    const double level = *middle / std::numbers::ln2;
    std::fill(level_.begin() + static_cast<std::ptrdiff_t>(first), level_.begin() + static_cast<std::ptrdiff_t>(last + 1), level);
  }
}

LineRemovalResult DiscreteLineRemover::remove(std::span<double> x, FftPlanCache& plans) {
  const std::size_t n = x.size();
  // DC and, for an even length, the Nyquist bin are not tested.
  const std::size_t bins = n % 2 == 0 ? n / 2 - 1 : (n - 1) / 2;
  if (n < min_length()) throw std::invalid_argument("DiscreteLineRemover: need at least 4 blocks of bins");
  const RealFft& fft = plans.real(n);
  spectrum_.resize(fft.spectrum_size());
  power_.assign(x.begin(), x.end());  // forward needs an aligned input
  fft.forward(power_, spectrum_);
  power_.assign(bins + 1, 0.0);
  double total = 0.0;
  for (std::size_t k = 1; k <= bins; ++k) total += (power_[k] = std::norm(spectrum_[k]));
  local_levels(bins);
  const double factor = std::log(static_cast<double>(bins));
  is_line_.assign(bins + 2, 0);
  for (std::size_t k = 1; k <= bins; ++k)
    if (power_[k] > factor * level_[k]) is_line_[k - 1] = is_line_[k] = is_line_[k + 1] = 1;
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
  power_.resize(n);
  fft.inverse(spectrum_, power_);
  const double scale = 1.0 / static_cast<double>(n);
  for (std::size_t j = 0; j < n; ++j) x[j] = power_[j] * scale;
  return result;
}

}  // namespace gearwatch::dsp
