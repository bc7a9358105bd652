#include "gearwatch/dsp/tsa.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace test_tsa {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::dsp;

namespace {
constexpr double kPi = std::numbers::pi;
double rms(std::span<const double> x) {
  double s = 0;
  for (double v : x) s += v * v;
  return std::sqrt(s / double(x.size()));
}
}  // namespace

TEST_CASE("TSA residual of periodic signal plus noise is the noise, error shrinking as 1/sqrt(averages)",
          "[dsp][tsa]") {
  // x = p + n, p periodic (period spr), n white with sigma = 1. The TSA is p + mean_r(n), so
  //   residual = n - mean_r(n)   (exactly, by linearity) and
  //   TSA - p  = mean_r(n), whose RMS is sigma / sqrt(R).
  // rms(residual)^2 = sigma^2 (1 - 1/R) in expectation, so |rms(residual) - sigma| ~ sigma/(2R) plus
  // the sampling error of an RMS over R*spr samples (sigma / sqrt(2 R spr)).
  const std::size_t spr = 256;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal;
  for (std::size_t revs : {8u, 32u, 128u, 512u}) {
    std::vector<double> x(revs * spr), noise(revs * spr), periodic(spr);
    for (std::size_t k = 0; k < spr; ++k)
      periodic[k] = 3.0 * std::cos(2 * kPi * 19 * double(k) / spr) + std::sin(2 * kPi * 2 * double(k) / spr + 0.3);
    for (std::size_t i = 0; i < x.size(); ++i) {
      noise[i] = normal(rng);
      x[i] = periodic[i % spr] + noise[i];
    }
    std::vector<double> tsa(spr);
    REQUIRE(time_synchronous_average(x, spr, tsa) == revs);
    std::vector<double> residual(x.size()), tsa_error(spr);
    for (std::size_t i = 0; i < x.size(); ++i) residual[i] = x[i] - tsa[i % spr];
    for (std::size_t k = 0; k < spr; ++k) tsa_error[k] = tsa[k] - periodic[k];
    const double r = double(revs);
    // RMS of mean_r(n) over spr samples: chi distribution with spr dof around sigma/sqrt(R);
    // 4 standard deviations of it (1/sqrt(2 spr) relative) bound the check.
    CHECK(rms(tsa_error) == Approx(1.0 / std::sqrt(r)).epsilon(4.0 / std::sqrt(2.0 * spr)));
    const double noise_rms = rms(noise);
    // Residual RMS vs the noise RMS: expected ratio sqrt(1 - 1/R); the bound 2/R + 4/sqrt(2 R spr)
    // shrinks as the number of averages grows.
    CHECK(std::abs(rms(residual) - noise_rms) < 2.0 / r + 4.0 / std::sqrt(2.0 * r * spr));
    CHECK(rms(residual) / noise_rms == Approx(std::sqrt(1 - 1 / r)).epsilon(4.0 / std::sqrt(2.0 * r * spr)));
  }
  std::vector<double> out(16);
  std::vector<double> short_signal(10);
  CHECK(time_synchronous_average(short_signal, 16, out) == 0);
}

TEST_CASE("Gear-mesh harmonic amplitudes and RMS_SA (Eq. 7.1)", "[dsp][tsa]") {
  const std::size_t spr = 512;
  std::vector<double> tsa(spr);
  const double amplitudes[] = {2.0, 0.5, 0.25};
  for (std::size_t k = 0; k < spr; ++k) {
    const double theta = double(k) / spr;
    tsa[k] = 0.7 + 0.3 * std::cos(2 * kPi * 5 * theta);  // DC and a shaft order: not mesh harmonics
    for (int h = 1; h <= 3; ++h) tsa[k] += amplitudes[h - 1] * std::cos(2 * kPi * 19 * h * theta + h);
  }
  FftPlanCache plans;
  std::vector<double> a;
  synchronous_harmonic_amplitudes(tsa, 19, 15, plans, a);
  REQUIRE(a.size() == 15);
  CHECK(a[0] == Approx(2.0).epsilon(1e-12));
  CHECK(a[1] == Approx(0.5).epsilon(1e-12));
  CHECK(a[2] == Approx(0.25).epsilon(1e-12));
  CHECK(a[3] == Approx(0.0).margin(1e-12));
  CHECK(std::isnan(a[13]));  // 14 x 19 = 266 > 256: above the TSA's Nyquist order
  CHECK(rms_sa(a, 2) == Approx(std::sqrt(4.0 + 0.25)).epsilon(1e-12));
  CHECK(rms_sa(a, 3) == Approx(std::sqrt(4.0 + 0.25 + 0.0625)).epsilon(1e-12));
  CHECK_THROWS_AS(rms_sa(a, 14), std::invalid_argument);
  CHECK_THROWS_AS(rms_sa(a, 0), std::invalid_argument);
}

TEST_CASE("Two-shaft separation removes both shafts' synchronous parts without double-counting the mesh",
          "[dsp][tsa]") {
  // Angle-domain signal on the input shaft (z1 = 19, z2 = 52): input order 2, the mesh order 19
  // (common to both shafts) and output orders 1 and 3 (input orders 19/52 and 57/52), plus white
  // noise. With 208 input revolutions (= 76 output revolutions, 4 hunting periods) the expected
  // residual is the noise minus its synchronous averages on both shafts.
  const int z1 = 19, z2 = 52;
  const std::size_t spr = 256, input_revs = 208, output_revs = input_revs * z1 / z2;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal;
  auto deterministic_input = [&](double theta_in) {
    const double theta_out = theta_in * z1 / z2;
    return 0.8 * std::cos(2 * kPi * 2 * theta_in) + 2.0 * std::cos(2 * kPi * 19 * theta_in + 0.2) +
           0.6 * std::cos(2 * kPi * 1 * theta_out + 1.0) + 0.3 * std::sin(2 * kPi * 3 * theta_out);
  };
  const double sigma = 0.5;
  std::vector<double> noise_in(input_revs * spr);
  RealBuffer input(input_revs * spr), output(output_revs * spr), residual(input_revs * spr);
  for (std::size_t j = 0; j < input.size(); ++j) {
    noise_in[j] = sigma * normal(rng);
    input[j] = deterministic_input(double(j) / spr) + noise_in[j];
  }
  // The output-angle record is the same deterministic signal at output-angle samples, with its
  // own noise (in the analyzer it is the same physical signal resampled; independence only
  // makes the bound below conservative).
  for (std::size_t j = 0; j < output.size(); ++j)
    output[j] = deterministic_input(double(j) / spr * z2 / z1) + sigma * normal(rng);
  FftPlanCache plans;
  SynchronousSeparation separation;
  const auto result = separation.separate(input, output, spr, z1, z2, plans, residual);
  CHECK(result.input_averages == input_revs);
  CHECK(result.output_averages == output_revs);
  // Deterministic leftovers in the residual: each TSA carries noise sigma/sqrt(R) per sample;
  // the residual's RMS must equal sigma within sqrt(1/R_in + 1/R_out) sigma (both TSAs' noise)
  // plus the RMS sampling error (4 / sqrt(2 N)). A missed or doubled mesh component (amplitude 2)
  // would add ~1.4 to the RMS; a missed output order 0.4 or more.
  std::vector<double> leftover(residual.size());
  for (std::size_t j = 0; j < residual.size(); ++j) leftover[j] = residual[j] - noise_in[j];
  const double bound = sigma * (std::sqrt(1.0 / input_revs + 1.0 / output_revs) * 1.5 + 4.0 / std::sqrt(2.0 * residual.size()));
  INFO("leftover rms " << rms(leftover) << " bound " << bound);
  CHECK(rms(leftover) < bound);
  CHECK(rms(residual) == Approx(sigma).epsilon(bound / sigma + 4.0 / std::sqrt(2.0 * residual.size())));
}

TEST_CASE("Two-shaft separation's residual: the very numbers of the per-sample reference", "[dsp][tsa]") {
  // The residual computed directly from the two TSAs the separation exposes: input minus the input
  // TSA at j mod spr minus the output TSA (its shared orders, DC and Nyquist dropped) upsampled by
  // an inverse FFT onto the input-angle grid, read every z1/g-th sample.
  const int z1 = 19, z2 = 52;
  const std::size_t spr = 160, input_revs = 105, output_revs = input_revs * z1 / z2;
  std::mt19937_64 rng(38);
  std::normal_distribution<double> normal;
  RealBuffer input(input_revs * spr), output(output_revs * spr), residual(input_revs * spr);
  for (auto& v : input) v = normal(rng);
  for (auto& v : output) v = normal(rng);
  FftPlanCache plans;
  SynchronousSeparation separation;
  const auto result = separation.separate(input, output, spr, z1, z2, plans, residual);
  REQUIRE(result.input_averages == input_revs);
  const std::size_t shared = z2, step = z1, upsampled = spr * shared;  // gcd(19, 52) = 1
  RealBuffer output_tsa(separation.output_tsa().begin(), separation.output_tsa().end()), up(upsampled);
  ComplexBuffer spectrum(spr / 2 + 1), padded(upsampled / 2 + 1, Complex{});
  plans.real(spr).forward(output_tsa, spectrum);
  for (std::size_t k = 1; 2 * k < spr; ++k)
    if (k % shared != 0) padded[k] = spectrum[k] / static_cast<double>(spr);
  plans.real(upsampled).inverse(padded, up);
  std::size_t differing = 0;
  for (std::size_t j = 0; j < input_revs * spr; ++j)
    differing += residual[j] != input[j] - separation.input_tsa()[j % spr] - up[(j * step) % upsampled];
  CHECK(differing == 0);
}

}  // namespace test_tsa
