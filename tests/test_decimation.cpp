// The front-end's decimation filter against its closed-form response, a plain convolution, and
// the folding it exists to prevent.
#include "gearwatch/dsp/decimation.hpp"

#include <cmath>
#include <complex>
#include <cstdint>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <catch2/catch.hpp>

namespace test_decimation {  // this file's own: the test files compile together (unity build)

using gearwatch::dsp::AntiAliasDecimator;

namespace {

constexpr double kPi = std::numbers::pi;

// |H| at f (cycles per output sample) from the taps' DTFT at f / factor per fine sample.
double magnitude(const AntiAliasDecimator& d, double f_out) {
  const auto taps = d.taps();
  const double w = 2 * kPi * f_out / d.factor();
  std::complex<double> h = 0;
  const double centre = static_cast<double>(taps.size() / 2);
  for (std::size_t i = 0; i < taps.size(); ++i) h += taps[i] * std::polar(1.0, -w * (static_cast<double>(i) - centre));
  return std::abs(h);
}

}  // namespace

TEST_CASE("Decimation filter: flat to 0.45 of the output rate, 100 dB down from 0.55 up to the fine Nyquist", "[dsp][decimation]") {
  for (int factor : {2, 8, 32}) {
    const AntiAliasDecimator d(factor);
    const auto taps = d.taps();
    REQUIRE(taps.size() % 2 == 1);
    double sum = 0, asymmetry = 0;
    for (std::size_t i = 0; i < taps.size(); ++i) {
      sum += taps[i];
      asymmetry = std::max(asymmetry, std::abs(taps[i] - taps[taps.size() - 1 - i]));
    }
    CHECK(sum == Approx(1.0).margin(1e-12));
    CHECK(asymmetry == 0.0);
    CHECK(d.padding_outputs() * static_cast<std::size_t>(factor) >= taps.size() / 2);
    double pass_error = 0, stop_gain = 0;
    for (double f = 0; f <= 0.45; f += 0.001) pass_error = std::max(pass_error, std::abs(magnitude(d, f) - 1.0));
    for (double f = 0.55; f <= 0.5 * factor; f += 0.001 * factor) stop_gain = std::max(stop_gain, magnitude(d, f));
    INFO("factor " << factor << ": pass-band error " << pass_error << ", stop-band gain " << stop_gain);
    CHECK(pass_error < 1e-5);   // Kaiser at 100 dB: ripple δ = 1e-5 both sides
    CHECK(stop_gain < 1e-5);
  }
}

TEST_CASE("Decimation equals the plain convolution read at every factor-th fine sample", "[dsp][decimation]") {
  const AntiAliasDecimator d(8);
  const std::size_t outputs = 300, pad = d.padding_outputs();
  std::vector<double> fine((outputs + 2 * pad) * 8);
  std::uint64_t state = 12345;
  for (double& v : fine) {  // a reproducible pseudo-random signal
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    v = static_cast<double>(state >> 11) / 9007199254740992.0 - 0.5;
  }
  std::vector<double> out(outputs);
  d.decimate(fine, out);
  const auto taps = d.taps();
  const std::size_t half = taps.size() / 2;
  double worst = 0;
  for (std::size_t j = 0; j < outputs; ++j) {
    const std::size_t centre = (pad + j) * 8;
    double ref = 0;
    for (std::size_t i = 0; i < taps.size(); ++i) ref += taps[i] * fine[centre + i - half];
    worst = std::max(worst, std::abs(out[j] - ref));
  }
  CHECK(worst < 1e-14);
  std::vector<float> out_f(outputs);
  d.decimate(fine, out_f);
  for (std::size_t j = 0; j < outputs; ++j) CHECK(out_f[j] == Approx(out[j]).margin(1e-7));
}

TEST_CASE("Decimation keeps a pass-band tone in amplitude and phase and removes one that would fold onto it", "[dsp][decimation]") {
  const int factor = 8;
  const AntiAliasDecimator d(factor);
  const std::size_t outputs = 2000, pad = d.padding_outputs();
  const std::size_t n = (outputs + 2 * pad) * factor;
  // Output rate 1: a tone at 0.4 and one at 0.6, which read once per output sample would be the
  // same samples as a tone at 0.4 (cos(2π·0.6·j) = cos(2π·0.4·j)).
  std::vector<double> kept(n), folding(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / factor;
    kept[i] = std::cos(2 * kPi * 0.4 * t + 0.3);
    folding[i] = std::cos(2 * kPi * 0.6 * t + 0.3);
  }
  std::vector<double> a(outputs), b(outputs);
  d.decimate(kept, a);
  d.decimate(folding, b);
  double error = 0, leak = 0;
  for (std::size_t j = 0; j < outputs; ++j) {
    const double t = static_cast<double>(pad + j);  // output j is fine sample (pad + j)·factor
    error = std::max(error, std::abs(a[j] - std::cos(2 * kPi * 0.4 * t + 0.3)));
    leak = std::max(leak, std::abs(b[j]));
  }
  CHECK(error < 2e-5);
  CHECK(leak < 2e-5);
  CHECK(std::abs(std::cos(2 * kPi * 0.6 * 7 + 0.3) - std::cos(2 * kPi * 0.4 * 7 - 0.3)) < 1e-12);  // the fold itself
}

TEST_CASE("Decimation refuses a factor below 2, crossed bands and a mis-sized output", "[dsp][decimation]") {
  CHECK_THROWS_AS(AntiAliasDecimator(1), std::invalid_argument);
  CHECK_THROWS_AS(AntiAliasDecimator(8, 0.5, 0.4), std::invalid_argument);
  CHECK_THROWS_AS(AntiAliasDecimator(8, 0.45, 0.6), std::invalid_argument);  // would fold below the pass edge
  const AntiAliasDecimator d(4);
  std::vector<double> fine(4 * (10 + 2 * d.padding_outputs()));
  std::vector<double> wrong(11), right(10);
  CHECK_THROWS_AS(d.decimate(fine, wrong), std::invalid_argument);
  CHECK_NOTHROW(d.decimate(fine, right));
  CHECK(d.outputs_for(fine.size()) == 10);
  CHECK(d.outputs_for(4 * 2 * d.padding_outputs()) == 0);
}

TEST_CASE("The simulators' front-end oversampling reads the model at 400 kHz or faster, never under 4x", "[dsp][decimation]") {
  CHECK(gearwatch::dsp::front_end_oversampling(100000) == 4);  // exactly 400 kHz
  CHECK(gearwatch::dsp::front_end_oversampling(50000) == 8);
  CHECK(gearwatch::dsp::front_end_oversampling(25000) == 16);
  CHECK(gearwatch::dsp::front_end_oversampling(20000) == 20);
  CHECK(gearwatch::dsp::front_end_oversampling(30000) == 14);  // 420 kHz: the next whole factor
  CHECK(gearwatch::dsp::front_end_oversampling(200000) == 4);  // 800 kHz: 4 is the least
  CHECK_THROWS_AS(gearwatch::dsp::front_end_oversampling(0), std::invalid_argument);
  CHECK_THROWS_AS(gearwatch::dsp::front_end_oversampling(std::numeric_limits<double>::infinity()), std::invalid_argument);
}

}  // namespace test_decimation
