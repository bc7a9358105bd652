#include "gearwatch/dsp/order_tracking.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "gearwatch/dsp/fft.hpp"

namespace test_order_tracking {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::dsp;

namespace {

constexpr double kPi = std::numbers::pi;

// Shaft angle (revolutions) of a speed profile f(t) = f0 (1 + drift t / T) (1 + d sin(2 pi fm t)),
// integrated numerically on a fine grid; tacho edges are the times where the angle crosses k/N.
struct SpeedProfile {
  double f0, drift, duration, depth, fm;
  double speed(double t) const { return f0 * (1 + drift * t / duration) * (1 + depth * std::sin(2 * kPi * fm * t)); }
};

struct Synthetic {
  std::vector<double> angle;   // revolutions at each sample
  std::vector<double> edges;   // fractional sample positions
};

Synthetic make_angle(const SpeedProfile& p, double fs, std::size_t n, int edges_per_rev) {
  Synthetic s;
  s.angle.resize(n);
  // Simpson-accurate integration with 8 sub-steps per sample.
  double theta = 0.0;
  const int sub = 8;
  const double h = 1.0 / (fs * sub);
  for (std::size_t i = 0; i < n; ++i) {
    s.angle[i] = theta;
    for (int k = 0; k < sub; ++k) {
      const double t = (double(i) * sub + k) * h;
      theta += h / 6 * (p.speed(t) + 4 * p.speed(t + h / 2) + p.speed(t + h));
    }
  }
  // Edges: angle = (m + 0.37) / N (the tacho mark is not at the signal's zero phase), located by
  // cubic interpolation of the angle between samples and Newton refinement.
  for (int m = 0;; ++m) {
    const double target = (m + 0.37) / edges_per_rev;
    if (target >= s.angle.back()) break;
    auto it = std::upper_bound(s.angle.begin(), s.angle.end(), target);
    if (it == s.angle.begin()) continue;
    const std::size_t i = std::size_t(it - s.angle.begin()) - 1;
    double t = double(i) + (target - s.angle[i]) / (s.angle[i + 1] - s.angle[i]);
    // Newton on the exact angle: integrate from sample i to t.
    for (int iter = 0; iter < 4; ++iter) {
      const double t0 = double(i) / fs, t1 = t / fs;
      const int steps = 16;
      double acc = 0, dt = (t1 - t0) / steps;
      for (int k = 0; k < steps; ++k) {
        const double a = t0 + k * dt;
        acc += dt / 6 * (p.speed(a) + 4 * p.speed(a + dt / 2) + p.speed(a + dt));
      }
      const double err = s.angle[i] + acc - target;
      t -= err * fs / p.speed(t1);
    }
    s.edges.push_back(t);
  }
  return s;
}

/// A tone at order k of a 10 Hz shaft whose angle deviates by ε sin(2π x f0 t) revolutions, sampled
/// at 20 kHz and order-tracked through one edge per revolution (128 revolutions, 128 samples each).
class RippledToneTracked {
 public:
  static constexpr std::size_t kRevolutions = 128, kSpr = 128;
  RippledToneTracked(double x, double epsilon, double k) : resampled_(kRevolutions * kSpr) {
    constexpr double f0 = 10, fs = 20000;
    const auto n = static_cast<std::size_t>((kRevolutions + 2) * fs / f0);
    auto angle_at = [&](double t) { return f0 * t + epsilon * std::sin(2 * kPi * x * f0 * t); };
    std::vector<float> signal(n);
    for (std::size_t i = 0; i < n; ++i) signal[i] = static_cast<float>(std::cos(2 * kPi * k * angle_at(double(i) / fs)));
    std::vector<double> edges;
    double t = 0;
    for (int m = 0; m <= static_cast<int>(kRevolutions) + 1; ++m) {
      for (int iteration = 0; iteration < 30; ++iteration)
        t -= (angle_at(t) - m) / (f0 * (1 + epsilon * 2 * kPi * x * std::cos(2 * kPi * x * f0 * t)));
      edges.push_back(t * fs);
    }
    ShaftAngle angle;
    REQUIRE(angle.assign(edges, 1, 1.0).ok());
    AngularResampler resampler;
    resampler.resample(signal, angle, kSpr, kRevolutions, resampled_);
  }
  /// |DFT| at `order` over the middle 96 revolutions: the spline's not-a-knot ends bend the first
  /// and last revolutions' angle.
  double middle_bin(double order) const {
    std::complex<double> sum = 0;
    for (std::size_t j = 16 * kSpr; j < 112 * kSpr; ++j) sum += resampled_[j] * std::polar(1.0, -2 * kPi * order * double(j) / kSpr);
    return std::abs(sum);
  }

 private:
  std::vector<double> resampled_;
};

}  // namespace

TEST_CASE("Band-limited interpolator reproduces a sampled sinusoid between samples", "[dsp][order_tracking]") {
  // A sinusoid at 0.3 x the sample rate (60 % of Nyquist) evaluated at irregular fractional
  // positions. Kaiser's design relation A = 2.285 (N - 1) dw + 8 with beta = 8 (A ~ 80 dB) and
  // N = 32 taps gives a transition half-width of ~0.16 Nyquist around the cutoff and a pass-band
  // ripple delta = 10^(-A/20) = 1e-4 below it; the 512-phase table with linear interpolation
  // adds ~ (pi f / 512)^2 / 8 ~ 4e-7. We require 1e-4 of the amplitude.
  const std::size_t n = 400;
  std::vector<float> x(n);
  const double f = 0.3;
  for (std::size_t i = 0; i < n; ++i) x[i] = float(std::cos(2 * kPi * f * double(i) + 0.4));
  BandLimitedInterpolator interpolator;
  double worst = 0;
  for (double t = 50.0; t < 350.0; t += 0.6180339887) {
    const double exact = std::cos(2 * kPi * f * t + 0.4);
    worst = std::max(worst, std::abs(interpolator(x, t) - exact));
  }
  // float storage of the samples contributes up to ~6e-8 x sum|h| ~ 1e-7.
  WARN("interpolator max error at 0.6 Nyquist: " << worst);
  CHECK(worst < 1e-4);
  // At integer positions it returns the samples themselves (sinc zeros), to float precision.
  CHECK(interpolator(x, 123.0) == Approx(double(x[123])).margin(1e-7));
  CHECK_THROWS_AS(interpolator.set_cutoff(0.0), std::invalid_argument);
}

TEST_CASE("Band-limited interpolators share their kernel tables: a lowered cutoff is the direct Kaiser-sinc sum, identical however reached", "[dsp][order_tracking]") {
  // Reference: the kernel computed directly in double precision at the exact fractional offset (no
  // table, no phase interpolation): Σ_m x[k]·c·sinc(c·u)·I0(β√(1 − (u/h)²))/I0(β) over the taps,
  // normalised to unit DC gain, h = ⌈16/c⌉ rounded up to even. The table's linear interpolation
  // between phases δ = 1/512 apart errs by at most δ²/8·max|h''| per tap, max|h''| = c·(πc)²/3 (the
  // sinc's at 0) = 0.80 for c = 40/64: 3.8e-7 per tap, at most 52 × 3.8e-7 × 1.5 (the signal's
  // largest value) = 3e-5 over the 52 taps; the float storage adds ~1e-7.
  const std::size_t n = 600;
  std::vector<float> x(n);
  for (std::size_t i = 0; i < n; ++i) x[i] = float(std::cos(2 * kPi * 0.07 * double(i) + 0.3) + 0.5 * std::sin(2 * kPi * 0.13 * double(i)));
  auto i0 = [](double v) {
    double sum = 1, term = 1;
    for (int k = 1; k < 80; ++k) term *= v * v / 4 / (double(k) * k), sum += term;
    return sum;
  };
  const double cutoff = 40.0 / 64, beta = 8.0;
  int half = int(std::ceil(16 / cutoff));
  half += half % 2;
  auto reference = [&](double t) {
    const double base = std::floor(t);
    double acc = 0, dc = 0;
    for (int m = 0; m < 2 * half; ++m) {
      const double u = t - base + half - 1 - m, v = cutoff * u, r = u / half;
      const double sinc = std::abs(v) < 1e-12 ? 1.0 : std::sin(kPi * v) / (kPi * v);
      const double w = std::abs(r) >= 1 ? 0.0 : i0(beta * std::sqrt(1 - r * r)) / i0(beta);
      acc += cutoff * sinc * w * x[std::size_t(base) - half + 1 + m], dc += cutoff * sinc * w;
    }
    return acc / dc;
  };
  BandLimitedInterpolator direct, roundabout, fresh;
  direct.set_cutoff(cutoff);
  roundabout.set_cutoff(0.25);
  roundabout.set_cutoff(1.0);
  roundabout.set_cutoff(cutoff);
  fresh.set_cutoff(cutoff);
  CHECK(direct.taps() == 2 * half);
  double worst = 0;
  std::size_t identical = 0, count = 0;
  for (double t = 100.0; t < 500.0; t += 0.3819660113, ++count) {
    worst = std::max(worst, std::abs(direct(x, t) - reference(t)));
    identical += direct(x, t) == roundabout(x, t) && direct(x, t) == fresh(x, t);
  }
  CHECK(worst < 3e-5);
  CHECK(identical == count);
}

TEST_CASE("Shaft angle rejects missing, irregular or too few tacho edges", "[dsp][order_tracking]") {
  ShaftAngle angle;
  CHECK(angle.assign({}, 1, 1.0).reason == "no_tacho");
  const std::vector<double> one{10.0};
  CHECK(angle.assign(one, 1, 1.0).reason == "too_few_edges");
  const std::vector<double> backwards{10.0, 20.0, 15.0, 30.0};
  CHECK(angle.assign(backwards, 1, 1.0).reason == "tacho_irregular");
  const std::vector<double> missing{0, 100, 200, 400, 500, 600};  // one edge missing
  CHECK(angle.assign(missing, 1, 1.0).reason == "tacho_irregular");
  const std::vector<double> with_nan{0, 100, std::nan(""), 300};
  CHECK(angle.assign(with_nan, 1, 1.0).reason == "tacho_irregular");
  const std::vector<double> good{0, 100, 200, 300, 400};
  REQUIRE(angle.assign(good, 2, 1.0).ok());
  CHECK(angle.total_revolutions() == Approx(2.0));
  // Uniform edges: the spline is exactly linear.
  CHECK(angle.time_at(1.25) == Approx(250.0).epsilon(1e-14));
  std::vector<double> speeds;
  angle.speed_per_revolution(1000.0, speeds);
  REQUIRE(speeds.size() == 2);
  CHECK(speeds[0] == Approx(5.0));  // 200 samples per revolution at 1 kHz
}

TEST_CASE("Order tracking puts a fluctuating-speed order into one bin", "[dsp][order_tracking]") {
  // 8 s at 20 kHz, shaft at 10 Hz drifting +10 % over the record with a +-5 % fluctuation at
  // 0.7 Hz, one tacho edge per revolution. Signal: order 19 (gear mesh) plus order 7 at half
  // the amplitude.
  const double fs = 20000.0;
  const std::size_t n = 160000;
  const SpeedProfile profile{10.0, 0.10, 8.0, 0.05, 0.7};
  const auto s = make_angle(profile, fs, n, 1);
  std::vector<float> x(n);
  for (std::size_t i = 0; i < n; ++i)
    x[i] = float(std::cos(2 * kPi * 19.0 * (s.angle[i] - 0.37)) + 0.5 * std::sin(2 * kPi * 7.0 * (s.angle[i] - 0.37)));

  ShaftAngle angle;
  REQUIRE(angle.assign(s.edges, 1, 1.0).ok());
  std::vector<double> speed;
  angle.speed_per_revolution(fs, speed);
  // Per-revolution mean speed against the profile averaged over that revolution: the spline
  // of edge times is exact at the edges, so only the edge-location error (< 1e-6 sample) counts.
  REQUIRE(speed.size() >= 80);
  const double mean_speed_exact = (s.angle.back() - 0.0) / (double(n - 1) / fs);
  CHECK(speed.front() > 9.0);
  CHECK(speed.back() < 12.0);

  const std::size_t spr = 1024;  // 10.24 kHz at 10 Hz: downsampling, anti-aliased by the resampler
  const std::size_t revs = std::size_t(std::floor(angle.total_revolutions()));
  RealBuffer resampled(revs * spr);
  AngularResampler resampler;
  resampler.resample(x, angle, spr, revs, resampled);
  CHECK(resampler.interpolator().cutoff() < 1.0);  // 1024 x ~9.5 Hz < 20 kHz: cutoff lowered

  FftPlanCache plans;
  const RealFft& fft = plans.real(resampled.size());
  ComplexBuffer spectrum(fft.spectrum_size());
  fft.forward(resampled, spectrum);
  double total = 0;
  for (std::size_t k = 1; k < spectrum.size(); ++k) total += std::norm(spectrum[k]);
  const double order19 = std::norm(spectrum[19 * revs]);
  const double order7 = std::norm(spectrum[7 * revs]);
  // Energy ratio 1 : 0.25 between the two orders; everything else is leakage.
  const double leakage = 1.0 - (order19 + order7) / total;
  INFO("leakage " << leakage << " mean speed " << mean_speed_exact);
  WARN("order tracking leakage (energy outside the two order bins): " << leakage);
  // The error budget: the cubic spline of edge times with one edge per revolution follows a 0.7 Hz
  // (0.07 order) fluctuation with phase error ~ (2 pi 0.07)^4 / 384 x amplitude; at order 19 this
  // is a residual phase modulation of ~1.3e-3 rad -> ~9e-7 of the energy in sidebands (measured
  // 1.0e-6; with natural spline ends it was 1.6e-4). We allow 1e-5.
  CHECK(leakage < 1e-5);
  CHECK(order19 / total == Approx(0.8).epsilon(1e-4));
  // Amplitude: |X| = A L / 2.
  CHECK(2 * std::sqrt(order19) / double(resampled.size()) == Approx(1.0).epsilon(1e-3));
}

TEST_CASE("Shaft angle from one edge per revolution follows a slow speed ripple and aliases one faster than half the shaft speed",
          "[dsp][order_tracking]") {
  // Speed f0 (1 + d sin 2π fm t): the angle ripple is f0 d / (2π fm) revolutions. The spline of edge
  // times interpolates it between edges one revolution apart, so its error is the cubic spline's,
  // at most (5/384) (2π fm/f0)^4 of the ripple (the classic bound for an interpolated sinusoid).
  // Above fm/f0 = 1/2 the edges cannot hold the ripple (the sampling theorem at one sample per
  // revolution): the spline follows an alias, and the residual is at least the ripple itself.
  const double f0 = 10, depth = 0.01, rate = 100000;
  auto residual_share = [&](double ratio) {
    const double fm = ratio * f0;
    const double ripple_revs = f0 * depth / (2 * kPi * fm);
    auto angle_revs = [&](double t) { return f0 * t - ripple_revs * (std::cos(2 * kPi * fm * t) - 1); };
    std::vector<double> edges;
    double t = 0;
    for (int m = 0; m < 200; ++m) {
      for (int iter = 0; iter < 50; ++iter) t -= (angle_revs(t) - m) / (f0 * (1 + depth * std::sin(2 * kPi * fm * t)));
      edges.push_back(t * rate);
    }
    ShaftAngle angle;
    REQUIRE(angle.assign(edges, 1, 1.0).ok());
    double worst = 0;
    for (double revs = 20; revs < 180; revs += 0.01) worst = std::max(worst, std::abs(angle_revs(angle.time_at(revs) / rate) - revs));
    return worst / ripple_revs;
  };
  for (double ratio : {0.05, 0.1, 0.2}) {
    INFO("fm/f0 = " << ratio);
    CHECK(residual_share(ratio) <= 5.0 / 384.0 * std::pow(2 * kPi * ratio, 4));
  }
  CHECK(residual_share(0.6) >= 1.0);
  CHECK(residual_share(0.8) >= 1.0);
}

TEST_CASE("Tracking residual share: all of a deviation at the shaft's own order stays, a slow one is followed, and the "
          "order-tracked sidebands of a phase-modulated tone say the same",
          "[dsp][order_tracking]") {
  // At ratio 1 (and 2) every edge meets the deviation at the same phase: the spline sees a uniform
  // rotation and the whole deviation stays in the tracked signal.
  CHECK(tracking_residual_share(1.0) == Approx(1.0).margin(1e-3));
  CHECK(tracking_residual_share(2.0) == Approx(1.0).margin(1e-3));
  // Above 1 the edges hold only an alias of it (here 0.26 orders, which the spline follows), not the
  // deviation itself: 52/19, a step-up through this rig's pair.
  CHECK(tracking_residual_share(52.0 / 19.0) == Approx(1.0).margin(1e-3));
  // A slow one is followed to within the interpolated sinusoid's bound (5/384)(2π ratio)^4.
  for (double ratio : {0.1, 0.2}) CHECK(tracking_residual_share(ratio) <= 5.0 / 384.0 * std::pow(2 * kPi * ratio, 4));
  CHECK_THROWS_AS(tracking_residual_share(0.0), std::invalid_argument);
  CHECK_THROWS_AS(tracking_residual_share(16.5), std::invalid_argument);

  // Independently, through the whole order tracking: a tone at order k of a shaft whose angle deviates
  // by ε sin(2π x f0 t) revolutions, resampled with the spline through one edge per revolution. The
  // tracked tone is phase-modulated by 2π k ε r at x orders, so each first sideband holds
  // (2π k ε r / 2) of the tone's amplitude (small index), r = tracking_residual_share(x).
  const double epsilon = 2e-4, k = 19;
  for (double x : {0.375, 0.625, 1.0}) {
    const RippledToneTracked tracked(x, epsilon, k);
    auto bin = [&](double order) { return tracked.middle_bin(order); };
    const double carrier = bin(k), sidebands = 0.5 * (bin(k - x) + bin(k + x));
    const double measured = 2 * sidebands / carrier / (2 * kPi * k * epsilon);
    INFO("x = " << x << ": sidebands say " << measured << ", tracking_residual_share " << tracking_residual_share(x));
    CHECK(measured == Approx(tracking_residual_share(x)).epsilon(0.005));  // measured: within 6e-5
  }
}

TEST_CASE("Tracking image: the spline through one edge per revolution leaves a deviation's residual at x and its images "
          "at 1 - x, 1 + x, 2 - x as the cardinal cubic spline's response says, and the order-tracked tone's sidebands agree",
          "[dsp][order_tracking]") {
  // Closed form: a deviation sin(2π·x·θ) sampled once a revolution comes back through the cubic
  // spline as Σ_k η(x + k)·sin(2π(x + k)θ), η(f) = sinc⁴(f)·3/(2 + cos 2πf); the error keeps
  // 1 − η(x) at x, +η(k − x) at k − x and −η(k + x) at k + x. Tolerance fixed before running:
  // 1 % of the closed form plus 2e-5 of the deviation.
  // The cardinal cubic spline's response: the B-spline's sinc⁴ over its samples' 1/6, 4/6, 1/6.
  auto eta = [](double f) {
    if (f == 0.0) return 1.0;
    const double a = kPi * f, sinc = std::sin(a) / a;
    return std::pow(sinc, 4) * 3.0 / (2.0 + std::cos(2.0 * a));
  };
  for (double x : {0.15, 0.3, 0.42, 0.6, 0.8}) {
    CAPTURE(x);
    const std::vector<std::pair<double, double>> components{
        {x, 1.0 - eta(x)}, {1.0 - x, eta(1.0 - x)}, {1.0 + x, -eta(1.0 + x)}, {2.0 - x, eta(2.0 - x)}};
    for (const auto& [at, want] : components) {
      CAPTURE(at, want);
      CHECK(tracking_error_component(x, at) == Approx(want).margin(0.01 * std::abs(want) + 2e-5));
    }
  }
  CHECK(eta(0.0) == 1.0);
  CHECK(std::abs(eta(1.0)) < 1e-15);
  CHECK_THROWS_AS(tracking_error_component(0.3, 0.0), std::invalid_argument);

  // Through the whole order tracking: a tone at order k of a shaft whose angle deviates by
  // ε sin(2π x f0 t) revolutions; the tracked tone's first sidebands at k ± (1 − x) hold
  // (2π k ε η(1 − x) / 2) of its amplitude (small index). Read over the middle 96 revolutions, where
  // x and 1 − x make whole cycles. Tolerance fixed before running: 1 %.
  const double epsilon = 2e-4, k = 19;
  for (double x : {0.25, 0.375}) {
    const RippledToneTracked tracked(x, epsilon, k);
    auto bin = [&](double order) { return tracked.middle_bin(order); };
    const double y = 1.0 - x, carrier = bin(k), image = 0.5 * (bin(k - y) + bin(k + y));
    const double measured = 2 * image / carrier / (2 * kPi * k * epsilon);
    INFO("x = " << x << ": image sidebands say " << measured << ", closed form " << eta(y));
    CHECK(measured == Approx(eta(y)).epsilon(0.01));
  }
}

// How many of the block path's values differ (in any bit) from one call per position at `cutoff`.
std::size_t block_values_differing(std::span<const float> x, std::span<const double> t, double cutoff) {
  BandLimitedInterpolator interpolator;
  interpolator.set_cutoff(cutoff);
  std::vector<double> block(t.size());
  interpolator.interpolate(x, t, block);
  std::size_t differing = 0;
  for (std::size_t k = 0; k < t.size(); ++k) differing += block[k] != interpolator(x, t[k]);
  return differing;
}

TEST_CASE("Order tracking in blocks: positions and interpolated values bit-identical to one call per sample", "[dsp][order_tracking]") {
  // The block paths (ShaftAngle::times_at, BandLimitedInterpolator::interpolate) must give the
  // very numbers of the per-sample calls, at the record's edges (zeros outside) and inside, for the
  // full-band kernel and a widened (lowered-cutoff) one.
  std::mt19937_64 rng(38);
  std::normal_distribution<double> normal;
  std::vector<float> x(4000);
  for (auto& v : x) v = static_cast<float>(normal(rng));
  std::uniform_real_distribution<double> position(-30.0, 4030.0);
  std::vector<double> t(1001);  // not a multiple of the four lanes
  for (auto& v : t) v = position(rng);
  t[0] = 0.0, t[1] = 15.0, t[2] = 3999.0, t[3] = 2000.5;
  for (double cutoff : {1.0, 0.5, 0.34375}) {
    INFO("cutoff " << cutoff);
    CHECK(block_values_differing(x, t, cutoff) == 0);
  }
  std::vector<double> edges;
  for (int m = 0; m <= 40; ++m) edges.push_back(100.0 + 250.0 * m + 20.0 * std::sin(0.7 * m));
  ShaftAngle angle;
  REQUIRE(angle.assign(edges, 2, 1.0).ok());  // knot spacing 1/2: the division by it is kept
  const double step = 19.0 / 52.0 / 64.0;
  std::vector<double> times(500);
  angle.times_at(step, 123, times);
  std::size_t differing = 0;
  for (std::size_t k = 0; k < times.size(); ++k) differing += times[k] != angle.time_at(static_cast<double>(123 + k) * step);
  CHECK(differing == 0);
  // Up to the last knot (20 revolutions) and past it, where the last interval's cubic goes on.
  const auto near_end = static_cast<std::size_t>(19.0 / step);
  std::vector<double> end_times(700);
  angle.times_at(step, near_end, end_times);
  REQUIRE(static_cast<double>(near_end + end_times.size()) * step > angle.total_revolutions() + 1.0);
  differing = 0;
  for (std::size_t k = 0; k < end_times.size(); ++k)
    differing += end_times[k] != angle.time_at(static_cast<double>(near_end + k) * step);
  CHECK(differing == 0);
}

TEST_CASE("Interpolator blocks: the row-pair table gives the per-sample values bit for bit at the resampler's cutoffs", "[dsp][order_tracking]") {
  // interpolate() reads both phase rows from a row-pair copy of the kernel table; operator() reads
  // the rows themselves. Every tap count the resampler's quantised cutoffs (k/64) can give is
  // checked, on positions spread over phases 0 to 511 and the last phase row (position just
  // below a whole sample), each against the per-sample value.
  std::mt19937_64 rng(3838);
  std::normal_distribution<double> normal;
  std::vector<float> x(6000);
  for (auto& v : x) v = static_cast<float>(normal(rng));
  std::uniform_real_distribution<double> position(0.0, 6000.0);
  std::vector<double> t(2002);
  for (auto& v : t) v = position(rng);
  for (std::size_t p = 0; p < 512; ++p) t[p] = 3000.0 + static_cast<double>(p) / 512.0;
  t[512] = std::nextafter(3001.0, 0.0);
  for (int k : {1, 5, 13, 24, 37, 50, 63}) {
    INFO("cutoff " << k << "/64");
    CHECK(block_values_differing(x, t, k / 64.0) == 0);
  }
}

}  // namespace test_order_tracking
