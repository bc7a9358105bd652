#include "gearwatch/dsp/envelope.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace gearwatch::dsp {

double tukey_weight(std::size_t i, std::size_t n, double fraction) noexcept {
  const double ramp = 0.5 * fraction * static_cast<double>(n);
  const double from_end = std::min(static_cast<double>(i), static_cast<double>(n - 1 - i)) + 0.5;
  if (!(from_end < ramp)) return 1.0;
  return 0.5 * (1.0 - std::cos(std::numbers::pi * from_end / ramp));
}

void apply_tukey_taper(std::span<double> x, double fraction) noexcept {
  const std::size_t n = x.size();
  const auto ramp = static_cast<std::size_t>(std::ceil(0.5 * fraction * static_cast<double>(n)));
  for (std::size_t i = 0; i < ramp && i < n - 1 - i; ++i) {
    const double w = tukey_weight(i, n, fraction);
    x[i] *= w;
    x[n - 1 - i] *= w;
  }
  if (n % 2 == 1 && ramp > n / 2) x[n / 2] *= tukey_weight(n / 2, n, fraction);
}

namespace {

// ICS2 from SES magnitudes read through `magnitude(bin)` over bins 0..size-1: ics2_from_ses and the
// analyzer's own paths share it, the latter reading only the bins it needs from the spectrum.
template <class Magnitude>
Ics2Result ics2_from_magnitudes(Magnitude&& magnitude, std::size_t size, double bins_per_order, const Ics2Parameters& p) {
  if (p.harmonics < 1 || p.tolerance_bins < 0 || !(p.cyclic_order > 0.0) || !(bins_per_order > 0.0))
    throw std::invalid_argument("ics2_from_ses: bad parameters");
  Ics2Result result;
  if (size == 0) return result;
  const double dc = magnitude(std::size_t{0});
  if (!(dc > 0.0)) return result;
  const double dc2 = dc * dc;
  double sum = 0.0;
  for (int h = 1; h <= p.harmonics; ++h) {
    const auto centre = static_cast<long>(std::lround(h * p.cyclic_order * bins_per_order));
    const long lo = centre - p.tolerance_bins, hi = centre + p.tolerance_bins;
    if (lo < 1 || hi >= static_cast<long>(size)) break;
    double peak = 0.0;
    for (long n = lo; n <= hi; ++n) peak = std::max(peak, magnitude(static_cast<std::size_t>(n)));
    sum += peak * peak;
    result.harmonics_used = h;
  }
  result.value = sum / dc2;
  return result;
}

}  // namespace

Ics2Result ics2_from_ses(std::span<const double> ses, double bins_per_order, const Ics2Parameters& p) {
  return ics2_from_magnitudes([&](std::size_t k) { return ses[k]; }, ses.size(), bins_per_order, p);
}

namespace {

// r2c of envelope[0, n) into spectrum.
void ses_spectrum(FftPlanCache& plans, const RealBuffer& envelope, std::size_t n, ComplexBuffer& spectrum) {
  const RealFft& fft = plans.real(n);
  spectrum.resize(fft.spectrum_size());
  fft.forward(std::span<const double>(envelope.data(), n), spectrum);
}

// sqrt(norm) rather than abs: std::abs(complex) calls hypot, which is several times slower and
// whose overflow protection is not needed at these magnitudes.
double ses_bin_magnitude(const Complex& bin, double scale) { return std::sqrt(std::norm(bin)) * scale; }

// ICS2 of the squared envelope in `envelope` (its whole length). Only the bins ICS2 reads (DC and
// the windows around the harmonics) become magnitudes: the values ses() gives at those bins.
Ics2Result ses_ics2(FftPlanCache& plans, const RealBuffer& envelope, ComplexBuffer& spectrum, double bins_per_order,
                    const Ics2Parameters& p) {
  const std::size_t n = envelope.size();
  ses_spectrum(plans, envelope, n, spectrum);
  const double scale = 1.0 / static_cast<double>(n);
  return ics2_from_magnitudes([&](std::size_t k) { return ses_bin_magnitude(spectrum[k], scale); }, spectrum.size(),
                              bins_per_order, p);
}

}  // namespace

Ics2Result SquaredEnvelopeAnalyzer::band_ics2(std::span<const Complex> spectrum, std::size_t signal_size,
                                              std::size_t revolutions, std::size_t first_bin,
                                              std::size_t last_bin, const Ics2Parameters& p) {
  if (revolutions == 0 || first_bin > last_bin || last_bin >= spectrum.size() || 2 * last_bin > signal_size)
    throw std::invalid_argument("band_ics2: band outside the spectrum");
  const std::size_t band_bins = last_bin - first_bin + 1;
  // |z|^2 of a band B bins wide has cyclic content up to B-1 bins; the grid must hold 2B bins
  // and the highest A_h window so neither aliases.
  const auto highest =
      static_cast<std::size_t>(std::ceil(p.harmonics * p.cyclic_order * static_cast<double>(revolutions))) +
      static_cast<std::size_t>(p.tolerance_bins) + 1;
  const std::size_t needed = std::max(2 * band_bins, 2 * highest + 2);
  const std::size_t grid = revolutions * next_smooth_size((needed + revolutions - 1) / revolutions);
  const ComplexFft& inverse = plans_->complex(grid);
  baseband_.assign(grid, Complex{});
  for (std::size_t k = 0; k < band_bins && k < grid; ++k) baseband_[k] = spectrum[first_bin + k];
  analytic_.resize(grid);
  inverse.backward(baseband_, analytic_);
  envelope_.resize(grid);
  for (std::size_t i = 0; i < grid; ++i) envelope_[i] = std::norm(analytic_[i]);
  return ses_ics2(*plans_, envelope_, ses_spectrum_, static_cast<double>(revolutions), p);
}

Ics2Result SquaredEnvelopeAnalyzer::full_band_ics2(std::span<const double> signal, std::span<const Complex> spectrum,
                                                   std::size_t revolutions, const Ics2Parameters& p) {
  const std::size_t n = signal.size();
  if (revolutions == 0 || n < 4 || spectrum.size() < n / 2 + 1)
    throw std::invalid_argument("full_band_ics2: bad sizes");
  const RealFft& fft = plans_->real(n);
  // The quadrature (Hilbert) part: X[k] -> -j X[k], DC and Nyquist dropped; unnormalised like
  // the c2r transform (n times the signal's scale).
  baseband_.resize(fft.spectrum_size());
  baseband_[0] = Complex{};
  for (std::size_t k = 1; 2 * k < n; ++k) baseband_[k] = Complex(spectrum[k].imag(), -spectrum[k].real());
  if (n % 2 == 0) baseband_[n / 2] = Complex{};
  quadrature_.resize(n);
  fft.inverse(baseband_, quadrature_);
  // The in-phase part on the same scale: n x[i] less the DC bin and, for an even n, the Nyquist
  // bin X[n/2] (-1)^i, which is what the inverse of the spectrum without those two bins gives.
  const double dc = spectrum[0].real();
  const double nyquist = n % 2 == 0 ? spectrum[n / 2].real() : 0.0;
  const double scale = static_cast<double>(n);
  envelope_.resize(n);
  // Even and odd samples in pairs (the Nyquist bin's sign alternates), so the loop vectorises.
  const double odd_nyquist = -nyquist;
  std::size_t i = 0;
  for (; i + 1 < n; i += 2) {
    const double even_phase = scale * signal[i] - dc - nyquist;
    const double odd_phase = scale * signal[i + 1] - dc - odd_nyquist;
    envelope_[i] = even_phase * even_phase + quadrature_[i] * quadrature_[i];
    envelope_[i + 1] = odd_phase * odd_phase + quadrature_[i + 1] * quadrature_[i + 1];
  }
  if (i < n) {
    const double in_phase = scale * signal[i] - dc - nyquist;  // i even
    envelope_[i] = in_phase * in_phase + quadrature_[i] * quadrature_[i];
  }
  return ses_ics2(*plans_, envelope_, ses_spectrum_, static_cast<double>(revolutions), p);
}

Ics2Result SquaredEnvelopeAnalyzer::complex_ics2(std::span<const Complex> c, double revolutions,
                                                 const Ics2Parameters& p) {
  if (c.size() < 2) return {};
  envelope_.resize(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) envelope_[i] = std::norm(c[i]);
  return ses_ics2(*plans_, envelope_, ses_spectrum_, revolutions, p);
}

std::span<const double> SquaredEnvelopeAnalyzer::ses(std::span<const double> squared_envelope) {
  const std::size_t n = squared_envelope.size();
  if (squared_envelope.data() != envelope_.data()) {
    envelope_.assign(squared_envelope.begin(), squared_envelope.end());
  }
  ses_spectrum(*plans_, envelope_, n, ses_spectrum_);
  ses_magnitude_.resize(ses_spectrum_.size());
  const double scale = 1.0 / static_cast<double>(n);
  for (std::size_t k = 0; k < ses_magnitude_.size(); ++k) ses_magnitude_[k] = ses_bin_magnitude(ses_spectrum_[k], scale);
  return ses_magnitude_;
}

}  // namespace gearwatch::dsp
