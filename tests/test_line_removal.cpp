#include "gearwatch/dsp/line_removal.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <numbers>
#include <random>
#include <set>
#include <vector>

namespace test_line_removal {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::dsp;

namespace {
constexpr double kPi = std::numbers::pi;

// x with the one-sided DFT bins in `bins` taken out, by direct sums (no FFT): x[j] minus
// (2/N) Re(X_k e^{i 2 pi k j / N}) for each k, X_k = sum_j x[j] e^{-i 2 pi k j / N}.
std::vector<double> without_bins(const std::vector<double>& x, const std::set<std::size_t>& bins) {
  const std::size_t n = x.size();
  std::vector<double> out = x;
  for (std::size_t k : bins) {
    std::complex<double> X{};
    for (std::size_t j = 0; j < n; ++j) X += x[j] * std::polar(1.0, -2 * kPi * double(k * j % n) / double(n));
    for (std::size_t j = 0; j < n; ++j) out[j] -= 2.0 / double(n) * std::real(X * std::polar(1.0, 2 * kPi * double(k * j % n) / double(n)));
  }
  return out;
}
}  // namespace

TEST_CASE("Discrete line removal: white noise keeps all but about one bin in M, bin-centred lines go with their neighbours exactly",
          "[dsp][residual][line_removal]") {
  const std::size_t n = 8192;  // M = 4095 tested bins, 63 blocks of 64
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal;
  std::vector<double> noise(n);
  for (auto& v : noise) v = normal(rng);
  FftPlanCache plans;
  DiscreteLineRemover remover;

  SECTION("white noise alone: the expected number of bins over ln(M) x the mean is 1 (each takes its two neighbours)") {
    RealBuffer x(noise.begin(), noise.end());
    const auto r = remover.remove(x, plans);
    // P(exp(1) > ln M) = 1/M exactly; the level is a block median / ln 2, itself ~10 % uncertain
    // over 64 bins, so a few such bins at most (Poisson mean ~1-2: 6 bins has probability < 1e-3).
    CHECK(r.bins_removed <= 3 * 6);
    CHECK(r.energy_removed_fraction < 0.01);
  }

  SECTION("three bin-centred lines 20 dB over the noise per bin: the output is the noise without bins k-1, k, k+1") {
    const std::vector<std::size_t> lines{700, 1533, 3001};
    RealBuffer x(noise.begin(), noise.end());
    // Per bin, white noise of unit variance has power n; a sinusoid of amplitude A has (A n / 2)^2.
    const double amplitude = 2.0 * std::sqrt(100.0 * double(n)) / double(n);
    for (std::size_t k : lines)
      for (std::size_t j = 0; j < n; ++j) x[j] += amplitude * std::cos(2 * kPi * double(k * j % n) / double(n) + 0.3 * double(k));
    const auto r = remover.remove(x, plans);
    std::set<std::size_t> removed;
    for (std::size_t k : lines)
      for (std::size_t d : {k - 1, k, k + 1}) removed.insert(d);
    // The noise alone may put a bin or two over the threshold too (section above): compare the
    // output with the noise without the bins the remover reports, when those are the lines' nine.
    REQUIRE(r.bins_removed == removed.size());
    const auto expected = without_bins(noise, removed);
    double worst = 0;
    for (std::size_t j = 0; j < n; ++j) worst = std::max(worst, std::abs(x[j] - expected[j]));
    CHECK(worst < 1e-9);
  }

  SECTION("too short a record is refused") {
    RealBuffer x(8 * kLineRemovalBlockBins - 2, 0.0);
    CHECK_THROWS_AS(remover.remove(x, plans), std::invalid_argument);
  }
}

namespace {
// The remover as it was before its transforms ran on x in place and each block's level was
// compared as soon as known: a copy into an aligned buffer, a per-bin level array (block median /
// ln 2), the inverse into a scratch array. The remover must give these very numbers.
std::size_t reference_remove(std::vector<double>& x, FftPlanCache& plans) {
  const std::size_t n = x.size(), bins = n % 2 == 0 ? n / 2 - 1 : (n - 1) / 2, block = kLineRemovalBlockBins;
  const RealFft& fft = plans.real(n);
  ComplexBuffer spectrum(fft.spectrum_size());
  RealBuffer in(x.begin(), x.end()), out(n);
  fft.forward(in, spectrum);
  std::vector<double> power(bins + 1, 0.0), level(bins + 1, 0.0);
  for (std::size_t k = 1; k <= bins; ++k) power[k] = std::norm(spectrum[k]);
  const std::size_t blocks = std::max<std::size_t>(1, bins / block);
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t first = 1 + b * block, last = b + 1 == blocks ? bins : first + block - 1;
    std::vector<double> values(power.begin() + std::ptrdiff_t(first), power.begin() + std::ptrdiff_t(last + 1));
    std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(values.size() / 2), values.end());
    for (std::size_t k = first; k <= last; ++k) level[k] = values[values.size() / 2] / std::numbers::ln2;
  }
  const double factor = std::log(double(bins));
  std::vector<char> is_line(bins + 2, 0);
  for (std::size_t k = 1; k <= bins; ++k)
    if (power[k] > factor * level[k]) is_line[k - 1] = is_line[k] = is_line[k + 1] = 1;
  std::size_t removed = 0;
  for (std::size_t k = 1; k <= bins; ++k)
    if (is_line[k]) spectrum[k] = Complex{}, ++removed;
  if (removed == 0) return 0;
  fft.inverse(spectrum, out);
  for (std::size_t j = 0; j < n; ++j) x[j] = out[j] * (1.0 / double(n));
  return removed;
}
}  // namespace

TEST_CASE("Discrete line removal in place: the very numbers of the copying remover, aligned input or not",
          "[dsp][residual][line_removal]") {
  // Lengths with an odd count of bins and a short last block; lines off bin centres (leakage).
  for (std::size_t n : {std::size_t{8192}, std::size_t{10584}, std::size_t{6615}}) {
    std::mt19937_64 rng(38 + n);
    std::normal_distribution<double> normal;
    std::vector<double> signal(n);
    for (std::size_t j = 0; j < n; ++j)
      signal[j] = normal(rng) + 0.3 * std::cos(2 * kPi * 301.37 * double(j) / double(n)) +
                  0.05 * std::sin(2 * kPi * 1201.5 * double(j) / double(n));
    FftPlanCache plans;
    DiscreteLineRemover remover;
    std::vector<double> expected = signal;
    const std::size_t removed = reference_remove(expected, plans);
    REQUIRE(removed > 0);
    RealBuffer aligned(signal.begin(), signal.end());
    CHECK(remover.remove(aligned, plans).bins_removed == removed);
    std::vector<double> unaligned(n + 1);  // one double in: not SIMD-aligned, so copied
    std::copy(signal.begin(), signal.end(), unaligned.begin() + 1);
    const std::span<double> shifted(unaligned.data() + 1, n);
    REQUIRE(reinterpret_cast<std::uintptr_t>(shifted.data()) % 16 != 0);  // FFTW's SIMD alignment is 16 or 32
    CHECK(remover.remove(shifted, plans).bins_removed == removed);
    std::size_t differing = 0;
    for (std::size_t j = 0; j < n; ++j) differing += (aligned[j] != expected[j]) + (shifted[j] != expected[j]);
    INFO("n " << n);
    CHECK(differing == 0);
  }
}

}  // namespace test_line_removal
