#include "gearwatch/rig/synthetic_signal.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace gearwatch::rig {
namespace {
constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr double kFluctuationHz = 0.5;
}  // namespace

SyntheticSignal::SyntheticSignal(const SyntheticSignalSettings& settings) : s_(settings), rng_state_(settings.seed * 0x9E3779B97F4A7C15ull + 1) {
  if (s_.sample_rate_hz <= 0 || s_.speed_hz <= 0 || s_.channels < 1 || s_.pinion_teeth < 1)
    throw std::invalid_argument("synthetic rig: sample rate, speed, channels and teeth must be positive");
  if (std::fabs(s_.speed_fluctuation) >= 1.0) throw std::invalid_argument("synthetic rig: speed fluctuation must be below 100 %");
  resonators_.resize(static_cast<std::size_t>(s_.channels));
  // Two-pole resonator at resonance_hz with a bandwidth of 10 % of it.
  const double r = std::exp(-std::numbers::pi * 0.1 * s_.resonance_hz / s_.sample_rate_hz);
  const double w = kTwoPi * s_.resonance_hz / s_.sample_rate_hz;
  a1_ = 2 * r * std::cos(w);
  a2_ = -r * r;
  // White noise of unit variance through 1/(1 - a1 z^-1 - a2 z^-2) has variance
  // (1 + r²) / ((1 - r²)((1 + r²)² - a1²)); normalise to unit RMS.
  const double r2 = r * r;
  const double var = (1 + r2) / ((1 - r2) * ((1 + r2) * (1 + r2) - a1_ * a1_));
  gain_ = 1.0 / std::sqrt(var);
}

double SyntheticSignal::gaussian() {
  // splitmix64 + Box–Muller: fast, portable, and identical on every platform for a given seed.
  auto next = [this] {
    std::uint64_t z = (rng_state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
  };
  const double u1 = std::max(next(), 1e-300), u2 = next();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(kTwoPi * u2);
}

double SyntheticSignal::input_revolutions_at(double t) const noexcept {
  // speed(t) = f0 (1 + e sin(2π fm t))  =>  θ(t) = f0 (t + e (1 - cos(2π fm t)) / (2π fm))
  const double f0 = s_.speed_hz, e = s_.speed_fluctuation;
  return f0 * (t + e * (1.0 - std::cos(kTwoPi * kFluctuationHz * t)) / (kTwoPi * kFluctuationHz));
}

void SyntheticSignal::generate(std::uint64_t first, std::size_t count, std::vector<std::vector<double>>& out) {
  if (first != next_index_) throw std::logic_error("synthetic rig: blocks must be consecutive");
  next_index_ = first + count;
  out.resize(static_cast<std::size_t>(s_.channels));
  const double load = s_.torque_nm / 20.0;
  static constexpr double kHarmonics[] = {1.0, 0.5, 0.3, 0.2, 0.1};
  for (auto& ch : out) ch.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    const double t = static_cast<double>(first + i) / s_.sample_rate_hz;
    const double theta = input_revolutions_at(t);
    const double mesh_phase = kTwoPi * s_.pinion_teeth * theta;
    const double shaft_mod = 1.0 + s_.shaft_modulation * std::cos(kTwoPi * theta);
    for (int c = 0; c < s_.channels; ++c) {
      double mesh = 0;
      for (int h = 0; h < 5; ++h)
        mesh += kHarmonics[h] * std::cos((h + 1) * mesh_phase + 0.7 * h + 1.3 * c) / (1.0 + 0.5 * c);
      auto& res = resonators_[static_cast<std::size_t>(c)];
      const double y = gain_ * gaussian() + a1_ * res.y1 + a2_ * res.y2;
      res.y2 = res.y1;
      res.y1 = y;
      // The resonance's excitation is modulated by the mesh: energy at the GMF cyclic order.
      const double cyclo = s_.resonance_rms_m_s2 * (1.0 + 0.8 * std::cos(mesh_phase)) * y;
      out[static_cast<std::size_t>(c)][i] =
          s_.mesh_amplitude_m_s2 * load * shaft_mod * mesh + cyclo + s_.noise_rms_m_s2 * gaussian();
    }
  }
}

std::vector<double> SyntheticSignal::tacho_edges(double from_sample, double to_sample, int edges_per_rev) const {
  std::vector<double> edges;
  const double fs = s_.sample_rate_hz;
  const double theta0 = input_revolutions_at(from_sample / fs) * edges_per_rev;
  const double theta1 = input_revolutions_at(to_sample / fs) * edges_per_rev;
  // Membership by edge number, not by the computed position: consecutive blocks share the
  // boundary angle bit for bit, so an edge on a block boundary lands in exactly one block.
  for (double k = std::ceil(theta0); k < std::ceil(theta1); k += 1.0) {
    // Newton on θ(t)·epr = k; θ is smooth and strictly increasing (|e| < 1).
    double t = k / (edges_per_rev * s_.speed_hz);
    for (int it = 0; it < 50; ++it) {
      const double f = input_revolutions_at(t) * edges_per_rev - k;
      const double df = edges_per_rev * s_.speed_hz * (1.0 + s_.speed_fluctuation * std::sin(kTwoPi * kFluctuationHz * t));
      const double step = f / df;
      t -= step;
      if (std::fabs(step) < 1e-13) break;
    }
    edges.push_back(std::clamp(t * fs, from_sample, std::nextafter(to_sample, from_sample)));
  }
  return edges;
}

}  // namespace gearwatch::rig
