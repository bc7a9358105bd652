#include "gearwatch/dsp/tsa.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "gearwatch/dsp/envelope.hpp"

namespace gearwatch::dsp {

std::size_t time_synchronous_average(std::span<const double> x, std::size_t period, std::span<double> out) {
  if (period == 0 || out.size() < period) throw std::invalid_argument("time_synchronous_average: bad period");
  const std::size_t periods = x.size() / period;
  std::fill(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(period), 0.0);
  if (periods == 0) return 0;
  for (std::size_t r = 0; r < periods; ++r) {
    const double* row = x.data() + r * period;
    for (std::size_t k = 0; k < period; ++k) out[k] += row[k];
  }
  const double scale = 1.0 / static_cast<double>(periods);
  for (std::size_t k = 0; k < period; ++k) out[k] *= scale;
  return periods;
}

void synchronous_harmonic_amplitudes(std::span<const double> tsa, int order, std::size_t count,
                                     FftPlanCache& plans, std::vector<double>& amplitudes) {
  if (order < 1) throw std::invalid_argument("synchronous_harmonic_amplitudes: order < 1");
  const std::size_t n = tsa.size();
  const RealFft& fft = plans.real(n);
  RealBuffer in(tsa.begin(), tsa.end());
  ComplexBuffer spectrum(fft.spectrum_size());
  fft.forward(in, spectrum);
  amplitudes.assign(count, std::numeric_limits<double>::quiet_NaN());
  for (std::size_t h = 1; h <= count; ++h) {
    const std::size_t bin = h * static_cast<std::size_t>(order);
    if (2 * bin >= n) break;
    amplitudes[h - 1] = 2.0 * std::abs(spectrum[bin]) / static_cast<double>(n);
  }
}

double rms_sa(std::span<const double> gmf_amplitudes, std::size_t harmonics) {
  if (harmonics == 0 || harmonics > gmf_amplitudes.size())
    throw std::invalid_argument("rms_sa: need " + std::to_string(harmonics) + " harmonic amplitudes, have " +
                                std::to_string(gmf_amplitudes.size()));
  double sum = 0.0;
  for (std::size_t i = 0; i < harmonics; ++i) {
    if (!std::isfinite(gmf_amplitudes[i]))
      throw std::invalid_argument("rms_sa: gear-mesh harmonic " + std::to_string(i + 1) + " is above Nyquist");
    sum += gmf_amplitudes[i] * gmf_amplitudes[i];
  }
  return std::sqrt(sum);
}

std::size_t tapered_synchronous_average(std::span<const double> x, std::size_t period, double end_taper_fraction,
                                        std::span<double> out) {
  const std::size_t periods = time_synchronous_average(x, period, out);
  if (periods == 0 || !(end_taper_fraction > 0.0)) return periods;
  // Only the ramps differ from the plain mean: correct the sums there instead of weighting every
  // sample.
  const std::size_t n = periods * period;
  const auto ramp = std::min(n / 2, static_cast<std::size_t>(std::ceil(0.5 * end_taper_fraction * static_cast<double>(n))));
  std::vector<double> weight_sum(period, static_cast<double>(periods));
  for (std::size_t k = 0; k < period; ++k) out[k] *= static_cast<double>(periods);
  auto reweight = [&](std::size_t j) {
    const double w = tukey_weight(j, n, end_taper_fraction);
    out[j % period] -= (1.0 - w) * x[j];
    weight_sum[j % period] -= 1.0 - w;
  };
  for (std::size_t j = 0; j < ramp; ++j) {
    reweight(j);
    if (n - 1 - j != j) reweight(n - 1 - j);
  }
  for (std::size_t k = 0; k < period; ++k) out[k] /= weight_sum[k];
  return periods;
}

SynchronousSeparation::Result SynchronousSeparation::separate(std::span<const double> input_angle,
                                                              std::span<const double> output_angle,
                                                              std::size_t samples_per_rev, int pinion_teeth,
                                                              int gear_teeth, FftPlanCache& plans,
                                                              std::span<double> residual) {
  if (pinion_teeth < 1 || gear_teeth < 1) throw std::invalid_argument("SynchronousSeparation: tooth counts");
  if (residual.size() < input_angle.size()) throw std::invalid_argument("SynchronousSeparation: residual size");
  const std::size_t spr = samples_per_rev;
  input_tsa_.resize(spr);
  output_tsa_.resize(spr);
  Result result;
  result.input_averages = tapered_synchronous_average(input_angle, spr, end_taper_fraction_, input_tsa_);
  result.output_averages = tapered_synchronous_average(output_angle, spr, end_taper_fraction_, output_tsa_);

  const auto g = static_cast<std::size_t>(std::gcd(pinion_teeth, gear_teeth));
  const std::size_t shared_period = static_cast<std::size_t>(gear_teeth) / g;  // output orders shared
  const std::size_t step = static_cast<std::size_t>(pinion_teeth) / g;
  const std::size_t upsampled = spr * shared_period;

  const RealFft& small = plans.real(spr);
  spectrum_.resize(small.spectrum_size());
  small.forward(output_tsa_, spectrum_);
  const RealFft& large = plans.real(upsampled);
  padded_.assign(large.spectrum_size(), Complex{});
  for (std::size_t k = 1; 2 * k < spr; ++k)   // DC and the Nyquist bin dropped
    if (k % shared_period != 0) padded_[k] = spectrum_[k] / static_cast<double>(spr);
  upsampled_.resize(upsampled);
  large.inverse(padded_, upsampled_);

  // Revolution by revolution: the TSA's index is the position within the revolution, without a
  // division per sample.
  std::size_t out_index = 0;
  for (std::size_t r = 0, j = 0; r < result.input_averages; ++r) {
    for (std::size_t k = 0; k < spr; ++k, ++j) {
      residual[j] = input_angle[j] - input_tsa_[k] - upsampled_[out_index];
      out_index += step;
      if (out_index >= upsampled) out_index -= upsampled;
    }
  }
  return result;
}

}  // namespace gearwatch::dsp
