#include "gearwatch/dsp/envelope.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace test_envelope {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::dsp;

namespace {

// Gaussian noise band-limited to [0.05, 0.45] x Nyquist (built in the frequency domain), unit
// variance. Keeping it away from DC and Nyquist makes the analytic signal of the modulated noise
// exactly (1 + a cos) times the analytic noise, so the closed form below holds without edge terms.
RealBuffer band_limited_noise(std::size_t n, std::mt19937_64& rng, FftPlanCache& plans) {
  std::normal_distribution<double> normal;
  const RealFft& fft = plans.real(n);
  ComplexBuffer spectrum(fft.spectrum_size());
  for (std::size_t k = 0; k < spectrum.size(); ++k) {
    const double f = double(k) / double(n / 2);
    spectrum[k] = (f > 0.05 && f < 0.45) ? Complex(normal(rng), normal(rng)) : Complex{};
  }
  RealBuffer x(n);
  fft.inverse(spectrum, x);
  double power = 0;
  for (double v : x) power += v * v;
  const double scale = 1.0 / std::sqrt(power / double(n));
  for (double& v : x) v *= scale;
  return x;
}

}  // namespace

TEST_CASE("ics2_from_ses applies Eq. 4.3 with the +-tolerance window", "[dsp][envelope]") {
  std::vector<double> ses(200, 0.01);
  ses[0] = 2.0;
  ses[38 + 2] = 0.5;   // h=1 centre 38 (order 19 x 2 bins/order), peak 2 bins off: inside +-3
  ses[76 - 4] = 0.9;   // h=2: 4 bins off, outside the window -> max is the floor 0.01
  ses[114] = 0.3;
  const auto r = ics2_from_ses(ses, 2.0, Ics2Parameters{19.0, 3, 3});
  CHECK(r.harmonics_used == 3);
  CHECK(r.value == Approx((0.25 + 0.0001 + 0.09) / 4.0).epsilon(1e-14));
  // The fifth harmonic's window (190 +- 3) still fits in 200 bins; the sixth (228 +- 3) does not.
  CHECK(ics2_from_ses(ses, 2.0, Ics2Parameters{19.0, 6, 3}).harmonics_used == 5);
  std::vector<double> zero(50, 0.0);
  CHECK(ics2_from_ses(zero, 1.0, Ics2Parameters{}).value == 0.0);
  CHECK_THROWS_AS(ics2_from_ses(ses, 2.0, Ics2Parameters{19.0, 0, 3}), std::invalid_argument);
}

TEST_CASE("ICS2 of amplitude-modulated noise matches the closed form", "[dsp][envelope]") {
  // x = (1 + a cos(2 pi k theta)) n(theta), n zero-mean Gaussian, analytic noise power P.
  // |x_a|^2 = (1 + a cos)^2 |n_a|^2 and E|n_a|^2 = P, so the expected squared envelope is
  //   P (1 + a^2/2 + 2a cos(k) + (a^2/2) cos(2k)):
  //   SES[0] = P(1 + a^2/2), SES[k] = P a, SES[2k] = P a^2/4, nothing at 3k, 4k, ...
  // => ICS2(H >= 2) = (a^2 + a^4/16) / (1 + a^2/2)^2 plus the noise floor of the other windows.
  //
  // Tolerance, derived: the envelope |n_a|^2 fluctuates with variance P^2, spread over cyclic
  // frequencies within +-B (B = noise bandwidth / sample rate = 0.2 here), so its spectral
  // density near the low cyclic orders is ~P^2 / B and one SES bin of an L-sample record has a
  // noise of relative std sqrt(1 / (B L)) against SES[0]. The modulation scales that variance by
  // g(a) = (1 + 3a^2 + 3a^4/8) / (1 + a^2/2)^2 (the mean of (1 + a cos)^4 over its mean square
  // squared). ICS2 is dominated by SES[k]^2 = (P a)^2, so its relative std is
  //   sigma(a) = 2 sqrt(g(a) / (B L)) / a      (0.016, 0.010, 0.0061 for a = 0.3, 0.5, 1).
  // Each seed must be within 4 sigma; the mean of 4 seeds within 4 sigma / 2. The bias of taking
  // the max over 7 bins (noise-only bins of relative power ~ 1/(B L) = 5e-6) is negligible.
  const std::size_t spr = 1024, revs = 1024, n = spr * revs;  // L = 2^20
  const int k = 19;
  const double bandwidth_fraction = 0.2;
  FftPlanCache plans;
  SquaredEnvelopeAnalyzer envelope(plans);
  std::mt19937_64 rng(2024);
  for (double a : {0.3, 0.5, 1.0}) {
    const double expected = (a * a + std::pow(a, 4) / 16.0) / std::pow(1.0 + a * a / 2.0, 2);
    const double g = (1 + 3 * a * a + 3 * std::pow(a, 4) / 8) / std::pow(1 + a * a / 2, 2);
    const double sigma = 2 * std::sqrt(g / (bandwidth_fraction * double(n))) / a;
    double mean = 0;
    for (int seed = 0; seed < 4; ++seed) {
      RealBuffer x = band_limited_noise(n, rng, plans);
      for (std::size_t i = 0; i < n; ++i)
        x[i] *= 1.0 + a * std::cos(2.0 * std::numbers::pi * k * double(i) / double(spr));
      const RealFft& fft = plans.real(n);
      ComplexBuffer spectrum(fft.spectrum_size());
      fft.forward(x, spectrum);
      const auto r = envelope.band_ics2(spectrum, n, revs, 1, n / 2 - 1, Ics2Parameters{double(k), 3, 3});
      CHECK(r.harmonics_used == 3);
      CHECK(r.value == Approx(expected).epsilon(4 * sigma));
      mean += r.value / 4;
    }
    INFO("a = " << a << " expected " << expected << " mean " << mean);
    WARN("ICS2 closed form a=" << a << ": expected " << expected << ", mean of 4 seeds " << mean
                               << " (rel. err " << (mean / expected - 1) << ")");
    CHECK(mean == Approx(expected).epsilon(2 * sigma));
  }
  // Stationary noise: ICS2 is only the noise floor, H windows of 7 bins each of relative power
  // ~ 1/(B L) = 5e-6: the max of 7 exponentials is < 10x that with probability > 0.999, so
  // ICS2 < 3 x 7 x 5e-6 ~ 1e-4.
  RealBuffer x = band_limited_noise(n, rng, plans);
  const RealFft& fft = plans.real(n);
  ComplexBuffer spectrum(fft.spectrum_size());
  fft.forward(x, spectrum);
  CHECK(envelope.band_ics2(spectrum, n, revs, 1, n / 2 - 1, Ics2Parameters{double(k), 3, 3}).value < 1e-4);
}

TEST_CASE("Tukey taper: weights and the end-discontinuity click it removes", "[dsp][envelope]") {
  // Weights: n = 1000, fraction 0.02 -> ramps of 10 samples, w(i) = (1 - cos(pi (i + 0.5) / 10)) / 2.
  CHECK(tukey_weight(0, 1000, 0.02) == Approx(0.5 * (1 - std::cos(std::numbers::pi * 0.05))).epsilon(1e-15));
  CHECK(tukey_weight(999, 1000, 0.02) == tukey_weight(0, 1000, 0.02));
  CHECK(tukey_weight(4, 1000, 0.02) == Approx(0.5 * (1 - std::cos(std::numbers::pi * 0.45))).epsilon(1e-15));
  CHECK(tukey_weight(10, 1000, 0.02) == 1.0);
  CHECK(tukey_weight(500, 1000, 0.02) == 1.0);
  CHECK(tukey_weight(0, 1000, 0.0) == 1.0);
  std::vector<double> ones(1001, 1.0);
  apply_tukey_taper(ones, 0.02);
  for (std::size_t i = 0; i < ones.size(); ++i) CHECK(ones[i] == tukey_weight(i, ones.size(), 0.02));

  // The mechanism: AM noise (a = 0.5) in [0.05, 0.2] x the sample rate, periodic over 1030
  // revolutions, of which the first 1024 are analysed, so the stretch does not join end to start.
  // White noise 80 dB below fills the band [0.3, 0.45]. Untapered, the FFT's periodic extension
  // puts the end step into that band as a click: its squared envelope is an impulse, ICS2 ~ H = 3.
  // Tapered (kEnvelopeTaperFraction), the band reads the white noise's floor: windows of 7 bins of
  // relative power 1/(B L) = 1/(0.15 x 2^20) = 6.4e-6, so < 3 x 8.9 x 6.4e-6 = 1.7e-4 (0.999).
  // The carrier's own ICS2 moves by < 0.1 %.
  const std::size_t spr = 1024, revs = 1024, total_revs = 1030, n = spr * revs, total = spr * total_revs;
  FftPlanCache plans;
  std::mt19937_64 rng(31);
  std::normal_distribution<double> normal;
  const RealFft& long_fft = plans.real(total);
  ComplexBuffer long_spectrum(long_fft.spectrum_size());
  for (std::size_t k = 0; k < long_spectrum.size(); ++k) {
    const double f = double(k) / double(total);
    long_spectrum[k] = f > 0.05 && f < 0.2 ? Complex(normal(rng), normal(rng)) : Complex{};
  }
  RealBuffer carrier(total);
  long_fft.inverse(long_spectrum, carrier);
  double power = 0;
  for (double v : carrier) power += v * v;
  const double carrier_std = std::sqrt(power / double(total));
  RealBuffer x(n);
  for (std::size_t i = 0; i < n; ++i)
    x[i] = (1 + 0.5 * std::cos(2 * std::numbers::pi * 19 * double(i) / double(spr))) * carrier[i] / carrier_std +
           1e-4 * normal(rng);
  const RealFft& fft = plans.real(n);
  SquaredEnvelopeAnalyzer envelope(plans);
  const Ics2Parameters p{19.0, 3, 3};
  auto band_pair = [&](const RealBuffer& signal) {
    ComplexBuffer spectrum(fft.spectrum_size());
    fft.forward(signal, spectrum);
    const double carrier_ics2 = envelope.band_ics2(spectrum, n, revs, n / 20, n / 5, p).value;
    const double white_ics2 = envelope.band_ics2(spectrum, n, revs, n * 3 / 10, n * 45 / 100, p).value;
    return std::pair{carrier_ics2, white_ics2};
  };
  const auto [carrier_raw, white_raw] = band_pair(x);
  RealBuffer tapered = x;
  apply_tukey_taper(tapered, kEnvelopeTaperFraction);
  const auto [carrier_tapered, white_tapered] = band_pair(tapered);
  WARN("end click: white band ICS2 untapered " << white_raw << ", tapered " << white_tapered << "; carrier "
                                              << carrier_raw << " -> " << carrier_tapered);
  CHECK(white_raw > 1.0);
  CHECK(white_tapered < 1.7e-4);
  CHECK(carrier_tapered == Approx(carrier_raw).epsilon(1e-3));
}

TEST_CASE("Full-band ICS2: the very number of the per-sample squared envelope, even and odd lengths", "[dsp][envelope]") {
  // The reference builds the squared envelope sample by sample (in-phase part n x[i] less the DC
  // bin and the alternating Nyquist bin, quadrature part the c2r of -j X) and takes ICS2 of its
  // spectrum through ses() and ics2_from_ses.
  FftPlanCache plans;
  for (std::size_t n : {std::size_t{4200}, std::size_t{4199}}) {
    std::mt19937_64 rng(38 + n);
    std::normal_distribution<double> normal;
    RealBuffer x(n);
    for (std::size_t i = 0; i < n; ++i)
      x[i] = (1.0 + 0.5 * std::cos(2 * std::numbers::pi * 19.0 * double(i) / double(n) * 20.0)) * normal(rng) + 0.2;
    const RealFft& fft = plans.real(n);
    ComplexBuffer spectrum(fft.spectrum_size()), rotated(fft.spectrum_size());
    fft.forward(x, spectrum);
    rotated[0] = Complex{};
    for (std::size_t k = 1; 2 * k < n; ++k) rotated[k] = Complex(spectrum[k].imag(), -spectrum[k].real());
    if (n % 2 == 0) rotated[n / 2] = Complex{};
    RealBuffer quadrature(n);
    fft.inverse(rotated, quadrature);
    const double dc = spectrum[0].real(), nyquist = n % 2 == 0 ? spectrum[n / 2].real() : 0.0;
    std::vector<double> envelope(n);
    for (std::size_t i = 0; i < n; ++i) {
      const double in_phase = double(n) * x[i] - dc - (i % 2 == 0 ? nyquist : -nyquist);
      envelope[i] = in_phase * in_phase + quadrature[i] * quadrature[i];
    }
    const Ics2Parameters p{19.0, 3, 3};
    SquaredEnvelopeAnalyzer reference(plans), analyzer(plans);
    const auto ses = reference.ses(envelope);
    const double expected = ics2_from_ses(std::vector<double>(ses.begin(), ses.end()), 20.0, p).value;
    INFO("n " << n);
    CHECK(expected > 0.0);
    CHECK(analyzer.full_band_ics2(x, spectrum, 20, p).value == expected);
  }
}

}  // namespace test_envelope
