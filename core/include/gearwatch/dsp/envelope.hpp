#pragma once
// Squared-envelope spectrum (SES) and ICS2 (thesis Eq. 4.3 / 7.2):
//   ICS2 = sum_{h=1..H} max_{n in A_h} SES[n]^2 / SES[0]^2,  A_h = h*GMF +- tolerance bins.
// Signals are angle-domain (a whole number R of shaft revolutions), so SES bin n is the cyclic
// order n / R of that shaft and speed changes do not smear the gear-mesh cyclic frequency.
#include <cstddef>
#include <span>

#include "gearwatch/dsp/fft.hpp"

namespace gearwatch::dsp {

/// Fraction of a stretch tapered (half at each end) before its FFT band-pass. A stretch of R'
/// revolutions cut from a longer record does not join end to start, and the FFT's periodic
/// extension turns that step into a broadband click; in a band 60 dB below the record the click
/// carries most of the band's energy and its squared envelope is an impulse (ICS2 -> H). 2 %
/// removes it and changes the ICS2 of stationary content by < 0.1 % (docs/dsp.md).
inline constexpr double kEnvelopeTaperFraction = 0.02;

/// Tukey weight of sample i of n: raised-cosine ramps over fraction/2 of n at each end, 1
/// between (fraction 0: all 1). Symmetric, never exactly 0.
double tukey_weight(std::size_t i, std::size_t n, double fraction) noexcept;

/// x[i] *= tukey_weight(i, x.size(), fraction).
void apply_tukey_taper(std::span<double> x, double fraction) noexcept;

struct Ics2Parameters {
  double cyclic_order = 19.0;   ///< the gear-mesh order of the shaft the signal is resampled on
  int harmonics = 3;            ///< H
  int tolerance_bins = 3;       ///< half-width of A_h in cyclic-resolution bins
};

struct Ics2Result {
  double value = 0.0;
  int harmonics_used = 0;       ///< harmonics whose whole A_h lies below the SES Nyquist
};

/// ICS2 from SES magnitudes (bins 0..size-1, bin spacing 1/bins_per_order orders). Harmonics whose
/// window reaches past the last bin are not counted (reported in harmonics_used).
/// Returns value 0 when SES[0] is 0 (an all-zero signal has no cyclostationarity).
Ics2Result ics2_from_ses(std::span<const double> ses_magnitude, double bins_per_order, const Ics2Parameters& p);

/// Squared envelopes and their spectra with reusable plans and scratch (no allocation once the
/// largest size has been seen).
class SquaredEnvelopeAnalyzer {
 public:
  explicit SquaredEnvelopeAnalyzer(FftPlanCache& plans) : plans_(&plans) {}

  /// ICS2 of the part of a real signal between spectrum bins [first_bin, last_bin] (inclusive),
  /// given the signal's r2c spectrum (signal_size/2+1 bins) and the revolutions it spans.
  /// The band is moved to baseband as an analytic signal on the smallest grid R*m (m 5-smooth)
  /// that holds it without aliasing its squared envelope, so narrow bands cost little.
  Ics2Result band_ics2(std::span<const Complex> spectrum, std::size_t signal_size, std::size_t revolutions,
                       std::size_t first_bin, std::size_t last_bin, const Ics2Parameters& p);

  /// ICS2 of the whole band of a real signal (the signal and its r2c spectrum given), via the
  /// Hilbert transform: |x + jH(x)|^2 = x^2 + H(x)^2 with one c2r (the quadrature) and one r2c
  /// transform (the SES) instead of a complex one. The in-phase part is the signal itself less its
  /// DC and Nyquist bins, taken in the time domain (no transform). Equals band_ics2 over bins
  /// 1..n/2-1 (DC and Nyquist bins excluded from the analytic signal).
  Ics2Result full_band_ics2(std::span<const double> signal, std::span<const Complex> spectrum, std::size_t revolutions,
                            const Ics2Parameters& p);

  /// ICS2 of a complex (one-sided, e.g. filter-bank) signal whose length spans `revolutions`:
  /// SES of |c|^2.
  Ics2Result complex_ics2(std::span<const Complex> c, double revolutions, const Ics2Parameters& p);

  /// SES magnitude |DFT(e)|/n of a squared envelope e (bins 0..n/2), for tests and plots.
  std::span<const double> ses(std::span<const double> squared_envelope);

 private:
  FftPlanCache* plans_;
  ComplexBuffer baseband_, analytic_, ses_spectrum_;
  RealBuffer envelope_, quadrature_;
  std::vector<double> ses_magnitude_;
};

}  // namespace gearwatch::dsp
