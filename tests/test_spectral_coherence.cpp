#include "gearwatch/dsp/spectral_coherence.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace test_spectral_coherence {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::dsp;

namespace {
constexpr double kPi = std::numbers::pi;

// Direct reference of the averaged cyclic periodogram: the same segments and Hann window, each
// segment's DFT computed by the O(N^2) sum, the cyclic phase exp(-j 2 pi alpha theta_s) applied.
std::vector<double> direct_coherence(const std::vector<double>& x, std::size_t nw, int alpha) {
  const std::size_t bins = nw / 2 + 1, hop = nw / 2;
  std::vector<double> power(bins, 0.0);
  std::vector<Complex> cross(bins);
  for (std::size_t start = 0; start + nw <= x.size(); start += hop) {
    std::vector<Complex> X(bins);
    for (std::size_t k = 0; k < bins; ++k) {
      Complex acc{};
      for (std::size_t i = 0; i < nw; ++i) {
        const double w = 0.5 - 0.5 * std::cos(2 * kPi * double(i) / double(nw));
        acc += w * x[start + i] * std::polar(1.0, -2 * kPi * double((k * i) % nw) / double(nw));
      }
      X[k] = acc;
    }
    const Complex rotate = std::polar(1.0, -2 * kPi * alpha * double(start) / double(nw));
    for (std::size_t k = 0; k < bins; ++k) power[k] += std::norm(X[k]);
    for (std::size_t k = std::size_t(alpha); k < bins; ++k) cross[k] += X[k] * std::conj(X[k - std::size_t(alpha)]) * rotate;
  }
  std::vector<double> gamma(bins, 0.0);
  for (std::size_t k = std::size_t(alpha); k < bins; ++k) gamma[k] = std::abs(cross[k]) / std::sqrt(power[k] * power[k - std::size_t(alpha)]);
  return gamma;
}

}  // namespace

TEST_CASE("Spectral coherence matches a direct DFT computation of the averaged cyclic periodogram",
          "[dsp][spectral_coherence]") {
  std::mt19937_64 rng(8);
  std::normal_distribution<double> normal;
  const std::size_t nw = 64, revs = 6;
  std::vector<double> x(nw * revs);
  for (std::size_t i = 0; i < x.size(); ++i)
    x[i] = (1 + 0.7 * std::cos(2 * kPi * 5 * double(i) / double(nw))) * normal(rng);
  FftPlanCache plans;
  CyclicCoherenceEstimator estimator(plans);
  CHECK(estimator.estimate(x, nw, 5) == 2 * revs - 1);
  const auto reference = direct_coherence(x, nw, 5);
  double worst = 0;
  for (std::size_t k = 0; k < reference.size(); ++k) worst = std::max(worst, std::abs(estimator.coherence()[k] - reference[k]));
  // Coherence is a ratio of O(1) sums: both computations agree to rounding (~1e-15 per term).
  CHECK(worst < 1e-12);
  CHECK_THROWS_AS(estimator.estimate(std::vector<double>(nw), nw, 5), std::invalid_argument);
  CHECK_THROWS_AS(estimator.estimate(x, nw, 40), std::invalid_argument);
}

TEST_CASE("Spectral coherence of amplitude-modulated noise has the closed-form level and carrier",
          "[dsp][spectral_coherence]") {
  // x = (1 + a cos(2 pi k theta)) n with n white: x(theta) x(theta + tau) has the cyclic
  // component at alpha = k of weight a (from (1 + a cos)^2 = 1 + a^2/2 + 2a cos + ...), against
  // the stationary part 1 + a^2/2, at every frequency: |gamma(k, f)| = a / (1 + a^2/2).
  // The Hann window's leakage between the f and f - alpha bins is negligible (alpha = 19 bins).
  // Estimation: with K ~ 2 x 400 overlapped segments (about 1.9 x 400 effectively independent for
  // Hann at 50 % overlap), the bias of |gamma| is ~ 1/sqrt(K_eff) on small values and its spread
  // per bin ~ 1/sqrt(2 K_eff) = 0.026; the mean over ~230 bins has a spread ~0.002. We require the
  // mean within 0.02 of the closed form.
  const std::size_t spr = 512, revs = 400;
  const double a = 0.6;
  std::mt19937_64 rng(12);
  std::normal_distribution<double> normal;
  std::vector<double> x(spr * revs);
  // Modulated noise only between orders 100 and 200 (built as the sum of band-limited noise and
  // a stationary remainder): the carrier frequency of the CS2 part is in that band.
  FftPlanCache plans;
  const RealFft& fft = plans.real(x.size());
  ComplexBuffer spectrum(fft.spectrum_size());
  RealBuffer band(x.size()), rest(x.size());
  for (std::size_t k = 0; k < spectrum.size(); ++k) {
    const double order = double(k) / double(revs);
    spectrum[k] = (order >= 100 && order <= 200) ? Complex(normal(rng), normal(rng)) : Complex{};
  }
  fft.inverse(spectrum, band);
  for (std::size_t k = 0; k < spectrum.size(); ++k) {
    const double order = double(k) / double(revs);
    spectrum[k] = (order >= 100 && order <= 200) ? Complex{} : Complex(normal(rng), normal(rng));
  }
  fft.inverse(spectrum, rest);
  for (std::size_t i = 0; i < x.size(); ++i)
    x[i] = (1 + a * std::cos(2 * kPi * 19 * double(i) / double(spr))) * band[i] + rest[i];
  CyclicCoherenceEstimator estimator(plans);
  estimator.estimate(x, spr, 19);
  const auto gamma = estimator.coherence();
  // Inside the modulated band, away from its edges by alpha (where f and f - alpha both lie in it).
  double mean = 0;
  int count = 0;
  for (std::size_t k = 100 + 19 + 2; k <= 198; ++k, ++count) mean += gamma[k];
  mean /= count;
  const double expected = a / (1 + a * a / 2);
  INFO("mean coherence in band " << mean << " expected " << expected);
  CHECK(mean == Approx(expected).margin(0.02));
  // Mean carrier frequency: the coherence is ~expected over [100+19, 200] (and spills to 219
  // where f - alpha is still inside), ~bias (< 0.1) elsewhere. Over [0, 256] orders the first
  // moment is pulled toward the band's centre ~160 by the bias elsewhere; over [100, 250] it is
  // near the band centre. The closed form for weights g in [119, 219] and b elsewhere:
  double w = 0, wf = 0;
  double bias = 0;
  int nb = 0;
  for (std::size_t k = 30; k < 90; ++k, ++nb) bias += gamma[k];
  bias /= nb;
  for (std::size_t k = 0; k <= 256; ++k) {
    const double g = (k >= 119 && k <= 200) ? expected : (k > 200 && k <= 219) ? expected / 2 : k < 19 ? 0.0 : bias;
    w += g;
    wf += g * double(k);
  }
  const double carrier = estimator.mean_carrier_order(0, 256);
  INFO("mean carrier " << carrier << " model " << wf / w << " bias level " << bias);
  // The model replaces the measured coherence by its expected shape; the spread of 250 bins of
  // sd 0.026 moves the first moment by ~ sqrt(250) x 0.026 x 128 / sum(g) ~ 2 orders. Allow 5.
  CHECK(carrier == Approx(wf / w).margin(5.0));
  CHECK(bias < 0.1);
}

TEST_CASE("Spectral coherence: the very numbers of the std::complex formulation", "[dsp][spectral_coherence]") {
  // The estimator's cross products are written in real arithmetic; this reference forms them with
  // std::complex (Hann segments, 50 % overlap, each segment's phase removed) as it did before.
  const std::size_t nw = 256, alpha = 19;
  std::mt19937_64 rng(38);
  std::normal_distribution<double> normal;
  std::vector<double> x(nw * 23 + 77);
  for (std::size_t i = 0; i < x.size(); ++i)
    x[i] = (1.0 + 0.7 * std::cos(2 * std::numbers::pi * double(alpha) * double(i) / double(nw))) * normal(rng);
  FftPlanCache plans;
  CyclicCoherenceEstimator estimator(plans);
  estimator.estimate(x, nw, static_cast<int>(alpha));
  const RealFft& fft = plans.real(nw);
  const std::size_t bins = fft.spectrum_size();
  RealBuffer segment(nw);
  ComplexBuffer spectrum(bins);
  std::vector<double> power(bins, 0.0);
  std::vector<Complex> cross(bins, Complex{});
  for (std::size_t start = 0; start + nw <= x.size(); start += nw / 2) {
    for (std::size_t i = 0; i < nw; ++i)
      segment[i] = x[start + i] * (0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * double(i) / double(nw)));
    fft.forward(segment, spectrum);
    const Complex rotate = std::polar(1.0, -2.0 * std::numbers::pi * double(alpha) * (double(start) / double(nw)));
    for (std::size_t k = 0; k < bins; ++k) power[k] += std::norm(spectrum[k]);
    for (std::size_t k = alpha; k < bins; ++k) cross[k] += spectrum[k] * std::conj(spectrum[k - alpha]) * rotate;
  }
  const auto gamma = estimator.coherence();
  std::size_t differing = 0;
  for (std::size_t k = alpha; k < bins; ++k) {
    const double denom = std::sqrt(power[k] * power[k - alpha]);
    differing += gamma[k] != (denom > 0.0 ? std::abs(cross[k]) / denom : 0.0);
  }
  CHECK(differing == 0);
}

}  // namespace test_spectral_coherence
