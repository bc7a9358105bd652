#include "gearwatch/dsp/decimation.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace gearwatch::dsp {

int front_end_oversampling(double sample_rate_hz) {
  if (!(sample_rate_hz > 0) || !std::isfinite(sample_rate_hz))
    throw std::invalid_argument("front-end oversampling: the sample rate must be positive and finite");
  // 1e-9: a rate that divides the fine rate exactly (100 kHz) gets its exact factor.
  const double factor = std::ceil(kFrontEndMinimumFineRateHz / sample_rate_hz - 1e-9);
  return static_cast<int>(std::clamp(factor, 4.0, 4096.0));
}

AntiAliasDecimator::AntiAliasDecimator(int factor, double pass_fraction, double stop_fraction, double stop_db)
    : factor_(factor) {
  if (factor < 2) throw std::invalid_argument("decimation factor must be at least 2");
  if (!(pass_fraction > 0) || !(stop_fraction > pass_fraction) || !(stop_fraction <= 1.0 - pass_fraction))
    throw std::invalid_argument("decimation bands must satisfy 0 < pass < stop <= 1 - pass");
  if (!(stop_db > 20) || !std::isfinite(stop_db)) throw std::invalid_argument("decimation stop-band attenuation must exceed 20 dB");
  // Kaiser's design rules: β and the length for an attenuation A over a transition Δω (rad per
  // fine sample); the cut-off sits mid-transition, in cycles per fine sample. The rules are
  // empirical (at A = 100 dB they leave a pass-band ripple of 1.2e-5, not 1e-5), so they are
  // given 3 dB more than asked.
  const double a = stop_db + 3.0;
  const double width = 2.0 * std::numbers::pi * (stop_fraction - pass_fraction) / factor;
  const double beta = a > 50 ? 0.1102 * (a - 8.7) : 0.5842 * std::pow(a - 21, 0.4) + 0.07886 * (a - 21);
  const auto half = static_cast<std::size_t>(std::ceil((a - 8.0) / (2.285 * width) / 2.0));
  const double cutoff = 0.5 * (pass_fraction + stop_fraction) / factor;
  taps_.resize(2 * half + 1);
  const double norm = std::cyl_bessel_i(0.0, beta);
  double sum = 0;
  for (std::size_t i = 0; i < taps_.size(); ++i) {
    const double n = static_cast<double>(i) - static_cast<double>(half);
    const double x = n / static_cast<double>(half);
    const double window = std::cyl_bessel_i(0.0, beta * std::sqrt(std::max(0.0, 1.0 - x * x))) / norm;
    const double sinc = n == 0 ? 2.0 * cutoff : std::sin(2.0 * std::numbers::pi * cutoff * n) / (std::numbers::pi * n);
    taps_[i] = sinc * window;
    sum += taps_[i];
  }
  for (double& t : taps_) t /= sum;
  padding_ = (half + static_cast<std::size_t>(factor) - 1) / static_cast<std::size_t>(factor);
}

std::size_t AntiAliasDecimator::outputs_for(std::size_t fine_count) const noexcept {
  const std::size_t whole = fine_count / static_cast<std::size_t>(factor_);
  return whole > 2 * padding_ ? whole - 2 * padding_ : 0;
}

template <class T>
void AntiAliasDecimator::run(std::span<const double> fine, std::span<T> out) const {
  if (out.size() != outputs_for(fine.size()) || out.empty())
    throw std::invalid_argument("decimation: the output must hold fine / factor - 2 padding samples");
  const std::size_t half = taps_.size() / 2;
  const auto step = static_cast<std::size_t>(factor_);
  for (std::size_t j = 0; j < out.size(); ++j) {
    const double* x = fine.data() + (padding_ + j) * step - half;
    double acc = 0;
    for (std::size_t i = 0; i < taps_.size(); ++i) acc += taps_[i] * x[i];
    out[j] = static_cast<T>(acc);
  }
}

void AntiAliasDecimator::decimate(std::span<const double> fine, std::span<float> out) const { run(fine, out); }
void AntiAliasDecimator::decimate(std::span<const double> fine, std::span<double> out) const { run(fine, out); }

}  // namespace gearwatch::dsp
