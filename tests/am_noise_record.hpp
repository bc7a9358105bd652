#pragma once
// Test helper: Gaussian noise band-limited (brick wall) to 4-11 kHz and amplitude-modulated at the
// mesh frequency (19 × the shaft speed), the record the record analyzer's and the band trimming's
// tests measure ICS2 and its bands on (its ICS2 has a closed form in the modulation depth). The
// caller scales the samples and stores them as acquisition would; the tacho has one edge a
// revolution, 0.3 of a revolution in.
#include <cmath>
#include <complex>
#include <cstddef>
#include <numbers>
#include <random>
#include <vector>

#include "gearwatch/dsp/fft.hpp"

namespace gearwatch::test {

struct AmNoise {
  dsp::RealBuffer x;  ///< the modulated noise, unscaled
  double rms = 0;     ///< its RMS
};

/// n samples at fs of the noise modulated with depth a at 19 × f0 Hz, drawn from `seed`.
inline AmNoise band_limited_am_noise(unsigned seed, double fs, std::size_t n, double f0, double a) {
  dsp::FftPlanCache plans;
  const dsp::RealFft& fft = plans.real(n);
  dsp::ComplexBuffer spectrum(fft.spectrum_size());
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  for (std::size_t k = 0; k < spectrum.size(); ++k) {
    const double f = double(k) * fs / double(n);
    spectrum[k] = f >= 4000.0 && f <= 11000.0 ? std::complex<double>(normal(rng), normal(rng)) : std::complex<double>{};
  }
  AmNoise noise{dsp::RealBuffer(n), 0.0};
  auto& x = noise.x;
  fft.inverse(spectrum, x);
  double power = 0;
  for (std::size_t i = 0; i < n; ++i) {
    x[i] *= 1.0 + a * std::cos(2 * std::numbers::pi * 19.0 * f0 * double(i) / fs);
    power += x[i] * x[i];
  }
  noise.rms = std::sqrt(power / double(n));
  return noise;
}

/// One tacho edge a revolution of a shaft at a steady f0 Hz, 0.3 of a revolution in, every edge
/// within n samples at fs.
inline std::vector<double> steady_tacho_edges(double f0, double fs, std::size_t n) {
  std::vector<double> edges;
  for (int k = 0;; ++k) {
    const double t = (k + 0.3) / f0 * fs;
    if (t > double(n - 1)) break;
    edges.push_back(t);
  }
  return edges;
}

}  // namespace gearwatch::test
