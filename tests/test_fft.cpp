#include "gearwatch/dsp/fft.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <thread>
#include <vector>

#include "gearwatch/dsp/envelope.hpp"
#include "gearwatch/dsp/window.hpp"

namespace test_fft {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::dsp;

namespace {

// Direct O(N^2) DFT, the independent reference. Accumulates in long double so its own rounding
// error (~N * 1e-19) is far below the FFT's (~log2 N * 1e-16).
std::vector<Complex> direct_dft(const std::vector<Complex>& x, int sign) {
  const std::size_t n = x.size();
  std::vector<Complex> out(n);
  for (std::size_t k = 0; k < n; ++k) {
    long double re = 0, im = 0;
    for (std::size_t j = 0; j < n; ++j) {
      const long double angle = sign * 2.0L * std::numbers::pi_v<long double> * static_cast<long double>((k * j) % n) / n;
      const long double c = std::cos(angle), s = std::sin(angle);
      re += x[j].real() * c - x[j].imag() * s;
      im += x[j].real() * s + x[j].imag() * c;
    }
    out[k] = Complex(static_cast<double>(re), static_cast<double>(im));
  }
  return out;
}

double max_abs_diff(const std::vector<Complex>& a, std::span<const Complex> b, std::size_t count) {
  double d = 0;
  for (std::size_t k = 0; k < count; ++k) d = std::max(d, std::abs(a[k] - b[k]));
  return d;
}

}  // namespace

TEST_CASE("RealFft forward and inverse match a direct DFT on random input", "[dsp][fft]") {
  std::mt19937_64 rng(42);
  std::normal_distribution<double> normal;
  for (std::size_t n : {2u, 15u, 64u, 100u, 243u, 1000u}) {
    RealFft fft(n);
    RealBuffer x(n);
    std::vector<Complex> xc(n);
    for (std::size_t i = 0; i < n; ++i) xc[i] = x[i] = normal(rng);
    ComplexBuffer spectrum(fft.spectrum_size());
    fft.forward(x, spectrum);
    const auto reference = direct_dft(xc, -1);
    // Unit-variance input: |X| ~ sqrt(n); FFTW's error is O(eps * log n * sqrt(n)), the bound
    // 1e-12 * sqrt(n) leaves a factor > 100 of headroom and still catches any indexing error.
    CHECK(max_abs_diff(reference, spectrum, fft.spectrum_size()) < 1e-12 * std::sqrt(double(n)));
    RealBuffer back(n);
    fft.inverse(spectrum, back);  // destroys spectrum
    double err = 0;
    for (std::size_t i = 0; i < n; ++i) err = std::max(err, std::abs(back[i] / double(n) - xc[i].real()));
    CHECK(err < 1e-13);
  }
}

TEST_CASE("The periodic Hann window has three DFT bins and sums to one at 50 % overlap", "[dsp][fft]") {
  // Closed form: 1/2 − 1/2·cos(2πi/n) = 1/2 − 1/4·e^(2πi·i/n) − 1/4·e^(−2πi·i/n), so its DFT is n/2
  // at bin 0, −n/4 at bins ±1 and 0 elsewhere; and w[i] + w[i + n/2] = 1 (cos changes sign).
  for (std::size_t n : {8u, 64u, 250u}) {
    const auto w = periodic_hann(n);
    REQUIRE(w.size() == n);
    for (std::size_t k = 0; k < n; ++k) {
      std::complex<long double> x = 0;
      for (std::size_t i = 0; i < n; ++i) x += static_cast<long double>(w[i]) * std::polar(1.0L, -2 * std::numbers::pi_v<long double> * k * i / n);
      const double expected = k == 0 ? n / 2.0 : (k == 1 || k == n - 1) ? -(n / 4.0) : 0.0;
      CHECK(static_cast<double>(x.real()) == Approx(expected).margin(1e-12 * n));
      CHECK(static_cast<double>(x.imag()) == Approx(0.0).margin(1e-12 * n));
    }
    for (std::size_t i = 0; i < n / 2; ++i) CHECK(w[i] + w[i + n / 2] == Approx(1.0).margin(1e-15));
  }
}

TEST_CASE("The Hann window's power response is that of a long periodic Hann window's DFT between bins", "[dsp][fft]") {
  // |Σ w(i)·e^(−2πi·ν·i/n)|² / (Σ w)², w the periodic Hann window of n = 4096 samples, against the
  // continuous form at whole, half and quarter bins; the discrete window differs by O(1/n²).
  const std::size_t n = 4096;
  const auto w = periodic_hann(n);
  for (double nu : {0.0, 0.25, 0.5, 1.0, 1.5, 2.0, 2.75, 4.5}) {
    std::complex<long double> x = 0;
    long double sum = 0;
    for (std::size_t i = 0; i < n; ++i) {
      x += static_cast<long double>(w[i]) * std::polar(1.0L, -2 * std::numbers::pi_v<long double> * nu * i / n);
      sum += w[i];
    }
    INFO("nu " << nu);
    CHECK(hann_power_response(nu) == Approx(static_cast<double>(std::norm(x) / (sum * sum))).margin(1e-6));
  }
}

TEST_CASE("ComplexFft forward and backward match a direct DFT", "[dsp][fft]") {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal;
  for (std::size_t n : {1u, 7u, 128u, 300u}) {
    ComplexFft fft(n);
    ComplexBuffer x(n), y(n);
    std::vector<Complex> xc(n);
    for (std::size_t i = 0; i < n; ++i) xc[i] = x[i] = Complex(normal(rng), normal(rng));
    fft.forward(x, y);
    CHECK(max_abs_diff(direct_dft(xc, -1), y, n) < 1e-12 * std::sqrt(double(n) + 1));
    fft.backward(x, y);
    CHECK(max_abs_diff(direct_dft(xc, +1), y, n) < 1e-12 * std::sqrt(double(n) + 1));
  }
}

TEST_CASE("FFT wrappers reject misaligned or mis-sized buffers with a clear error", "[dsp][fft]") {
  RealFft fft(16);
  RealBuffer x(17);
  ComplexBuffer spectrum(9);
  CHECK_THROWS_AS(fft.forward(std::span<const double>(x.data(), 15), spectrum), std::invalid_argument);
  // One double past a SIMD-aligned start is misaligned for FFTW's planning alignment.
  CHECK_THROWS_AS(fft.forward(std::span<const double>(x.data() + 1, 16), spectrum), std::invalid_argument);
  ComplexFft c(8);
  ComplexBuffer a(8);
  CHECK_THROWS_AS(c.forward(a, a), std::invalid_argument);  // out-of-place plans only
  CHECK_THROWS_AS(RealFft(1), std::invalid_argument);
}

TEST_CASE("FFT plans are movable and can be created from several threads", "[dsp][fft]") {
  RealFft a(64);
  RealFft b(std::move(a));
  CHECK(b.size() == 64);
  CHECK(a.size() == 0);
  std::vector<std::thread> threads;
  std::vector<double> dc(4, 0.0);
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([t, &dc] {
      FftPlanCache cache;
      for (std::size_t n = 100; n < 140; ++n) {
        const RealFft& f = cache.real(n);
        RealBuffer x(n, 1.0);
        ComplexBuffer s(f.spectrum_size());
        f.forward(x, s);
        dc[static_cast<std::size_t>(t)] += s[0].real() - static_cast<double>(n);
      }
    });
  for (auto& th : threads) th.join();
  for (double d : dc) CHECK(std::abs(d) < 1e-9);  // DC bin of all-ones = n exactly (sums of 1.0)
}

TEST_CASE("Squared-envelope spectrum and band ICS2 match a direct DFT computation", "[dsp][fft][envelope]") {
  // A 6-revolution signal of 40 samples per revolution; band ICS2 recomputed from scratch with the
  // direct DFT: band bins -> analytic baseband signal (direct inverse DFT on the same grid) ->
  // squared envelope -> direct DFT -> Eq. 4.3.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal;
  const std::size_t revs = 6, spr = 40, n = revs * spr;
  std::vector<Complex> xc(n);
  RealBuffer x(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double theta = double(i) / spr;
    x[i] = (1.0 + 0.6 * std::cos(2 * std::numbers::pi * 3 * theta)) * normal(rng);
    xc[i] = x[i];
  }
  FftPlanCache plans;
  const RealFft& fft = plans.real(n);
  ComplexBuffer spectrum(fft.spectrum_size());
  fft.forward(x, spectrum);
  SquaredEnvelopeAnalyzer envelope(plans);
  const Ics2Parameters p{3.0, 2, 1};
  const std::size_t first = 10, last = 60;
  const auto fast = envelope.band_ics2(spectrum, n, revs, first, last, p);

  // Reference: grid = revs * 2^k >= max(2 * band, 2 * (H*order*revs + tol + 1) + 2)
  std::size_t grid = revs;
  while (grid < std::max<std::size_t>(2 * (last - first + 1), 2 * (2 * 3 * revs + 1 + 1) + 2)) grid *= 2;
  const auto X = direct_dft(xc, -1);
  std::vector<Complex> band(grid);
  for (std::size_t k = first; k <= last; ++k) band[k - first] = X[k];
  const auto z = direct_dft(band, +1);
  std::vector<Complex> e(grid);
  for (std::size_t i = 0; i < grid; ++i) e[i] = std::norm(z[i]);
  const auto E = direct_dft(e, -1);
  std::vector<double> ses(grid / 2 + 1);
  for (std::size_t k = 0; k < ses.size(); ++k) ses[k] = std::abs(E[k]) / double(grid);
  double sum = 0;
  for (int h = 1; h <= 2; ++h) {
    const long c = std::lround(h * 3.0 * revs);
    double peak = 0;
    for (long k = c - 1; k <= c + 1; ++k) peak = std::max(peak, ses[std::size_t(k)]);
    sum += peak * peak;
  }
  const double reference = sum / (ses[0] * ses[0]);
  CHECK(fast.harmonics_used == 2);
  // Both are ratios of O(1) quantities computed with ~1e-13 relative rounding.
  CHECK(fast.value == Approx(reference).epsilon(1e-9));

  // SES magnitudes themselves.
  std::vector<double> env(n);
  for (std::size_t i = 0; i < n; ++i) env[i] = x[i] * x[i];
  const auto ses_fast = envelope.ses(env);
  std::vector<Complex> envc(env.begin(), env.end());
  const auto ENV = direct_dft(envc, -1);
  double err = 0;
  for (std::size_t k = 0; k < ses_fast.size(); ++k) err = std::max(err, std::abs(ses_fast[k] - std::abs(ENV[k]) / double(n)));
  CHECK(err < 1e-13);
}

}  // namespace test_fft
