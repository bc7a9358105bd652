#include "gearwatch/rig/rig_simulator.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <optional>
#include <string>

#include "gearwatch/dsp/decimation.hpp"
#include "gearwatch/dsp/fft.hpp"
#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/gear_geometry.hpp"
#include "random.hpp"
#include "rig_dynamics.hpp"

namespace gearwatch::rig {
namespace {

using detail::RigDynamics;
using detail::RigOutputs;
using detail::RigState;

constexpr int kProfilePoints = 41;

std::vector<double> resample(const std::vector<double>& table, int n) {
  std::vector<double> out(static_cast<std::size_t>(n), 0.0);
  if (table.empty()) return out;
  for (int i = 0; i < n; ++i) {
    const double u = static_cast<double>(i) / (n - 1) * static_cast<double>(table.size() - 1);
    const std::size_t k = std::min(static_cast<std::size_t>(u), table.size() - 2);
    const double f = u - static_cast<double>(k);
    out[static_cast<std::size_t>(i)] = table[k] + f * (table[k + 1] - table[k]);
  }
  return out;
}

/// Second-order section, direct form II transposed.
struct Biquad {
  double b0 = 1, b1 = 0, b2 = 0, a1 = 0, a2 = 0, z1 = 0, z2 = 0;
  double operator()(double x) {
    const double y = b0 * x + z1;
    z1 = b1 * x - a1 * y + z2;
    z2 = b2 * x - a2 * y;
    return y;
  }
};

/// Butterworth (Q = 1/√2) low- or high-pass section by the bilinear transform with prewarping.
Biquad butterworth_section(double cutoff_hz, double fs, bool high_pass) {
  const double k = std::tan(std::numbers::pi * cutoff_hz / fs);
  const double q = 1.0 / std::sqrt(2.0);
  const double norm = 1.0 / (1.0 + k / q + k * k);
  Biquad b;
  if (high_pass) {
    b.b0 = norm;
    b.b1 = -2.0 * norm;
    b.b2 = norm;
  } else {
    b.b0 = k * k * norm;
    b.b1 = 2.0 * b.b0;
    b.b2 = b.b0;
  }
  b.a1 = 2.0 * (k * k - 1.0) * norm;
  b.a2 = (1.0 - k / q + k * k) * norm;
  return b;
}

/// The accelerometer on its mount, a base-excited single-DOF system: absolute-acceleration
/// transmissibility H(f) = (1 + j2ζr)/(1 − r² + j2ζr), r = f/fn, applied in the frequency domain so
/// that the record sees the analog mount's response at every frequency. (A bilinear transform is
/// exact at one frequency and warps the others towards Nyquist: prewarped at a 40 kHz mount with
/// fs = 100 kHz, it gave 20 kHz the response the mount has at 9.4 kHz.) The record is extended by
/// its mirror image at both ends first, long enough for the mount's ringing to die away, so the
/// circular transform sees no jump at the record's edges. Built once per record length (the plan,
/// the response per bin and the scratch), applied to each channel.
class AnalogMount {
 public:
  AnalogMount(std::size_t n, double fn_hz, double zeta, double fs)
      : n_(n),
        // 12 decay times 1/(2π·fn·ζ) of the ringing, in samples, as the mirrored pad.
        pad_(n < 2 ? 0 : std::min(n - 1, static_cast<std::size_t>(std::ceil(12.0 * fs / (2.0 * std::numbers::pi * fn_hz * zeta))) + 16)),
        fft_(dsp::next_smooth_size(n + 2 * pad_)),
        buffer_(fft_.size(), 0.0),
        spectrum_(fft_.spectrum_size()) {
    for (std::size_t k = 0; k < spectrum_.size(); ++k) {
      const double r = static_cast<double>(k) * fs / static_cast<double>(fft_.size()) / fn_hz;
      const std::complex<double> h = std::complex<double>(1.0, 2.0 * zeta * r) / std::complex<double>(1.0 - r * r, 2.0 * zeta * r);
      response_.push_back(h / static_cast<double>(fft_.size()));
    }
  }

  void apply(std::vector<double>& x) {
    if (n_ < 2 || x.size() != n_) return;
    const std::size_t n = n_, pad = pad_;
    std::fill(buffer_.begin(), buffer_.end(), 0.0);
    for (std::size_t i = 0; i < pad; ++i) buffer_[i] = x[pad - i];                 // mirrored head
    std::copy(x.begin(), x.end(), buffer_.begin() + static_cast<std::ptrdiff_t>(pad));
    for (std::size_t i = 0; i < pad; ++i) buffer_[pad + n + i] = x[n - 2 - i];     // mirrored tail
    fft_.forward(buffer_, spectrum_);
    for (std::size_t k = 0; k < spectrum_.size(); ++k) spectrum_[k] *= response_[k];
    fft_.inverse(spectrum_, buffer_);
    std::copy(buffer_.begin() + static_cast<std::ptrdiff_t>(pad), buffer_.begin() + static_cast<std::ptrdiff_t>(pad + n), x.begin());
  }

 private:
  std::size_t n_, pad_;
  dsp::RealFft fft_;
  dsp::RealBuffer buffer_;
  dsp::ComplexBuffer spectrum_;
  std::vector<std::complex<double>> response_;
};

/// Unit-RMS Gaussian noise in [low, high] Hz (two Butterworth sections each side).
std::vector<double> band_noise(std::size_t n, double low, double high, double fs, detail::Random& rng) {
  if (!(low > 0) || !(high > low)) throw RigParameterError("sliding vibration band must satisfy 0 < low < high");
  if (high >= 0.5 * fs)
    throw RigParameterError("sliding vibration band up to " + std::to_string(high) + " Hz needs a sample rate above " +
                            std::to_string(2 * high) + " Hz");
  Biquad h1 = butterworth_section(low, fs, true), h2 = h1;
  Biquad l1 = butterworth_section(high, fs, false), l2 = l1;
  std::vector<double> x(n);
  // Run the filters through a start-up stretch first so the record starts in steady state.
  const std::size_t warm = static_cast<std::size_t>(std::ceil(20.0 * fs / low));
  for (std::size_t i = 0; i < warm; ++i) l2(l1(h2(h1(rng.gaussian()))));
  double ss = 0;
  for (auto& v : x) {
    v = l2(l1(h2(h1(rng.gaussian()))));
    ss += v * v;
  }
  const double scale = ss > 0 ? 1.0 / std::sqrt(ss / static_cast<double>(n)) : 0.0;
  for (auto& v : x) v *= scale;
  return x;
}

}  // namespace

twin::ToothProfileDeviation truth_profile(const twin::GearboxParameters& params, const EffectSet& effects,
                                          const WearState& wear) {
  // A wear table finer than the default grid (the Archard truth's 101 points, with its notch at the
  // pitch point) keeps its resolution: resampling it to 41 points would blunt the notch and lower
  // the mesh excitation the wear causes.
  const int points = std::max<int>({kProfilePoints, static_cast<int>(wear.profile.pinion.size()),
                                    static_cast<int>(wear.profile.gear.size())});
  std::vector<double> pinion = resample(wear.profile.pinion, points);
  std::vector<double> gear = resample(wear.profile.gear, points);
  if (effects.enabled(Effect::tip_relief)) {
    // Linear relief from (1 − L) of the active profile to the tip, on both gears.
    const double amount = effects.get("tip_relief.amount_um") * 1e-6, length = effects.get("tip_relief.length_fraction");
    for (int i = 0; i < points; ++i) {
      const double u = static_cast<double>(i) / (points - 1);
      const double relief = amount * std::max(0.0, (u - (1.0 - length)) / length);
      pinion[static_cast<std::size_t>(i)] += relief;
      gear[static_cast<std::size_t>(i)] += relief;
    }
  }
  twin::ToothProfileDeviation d;
  const bool any = std::any_of(pinion.begin(), pinion.end(), [](double v) { return v != 0; }) ||
                   std::any_of(gear.begin(), gear.end(), [](double v) { return v != 0; });
  if (effects.enabled(Effect::tooth_errors)) {
    const int z1 = params.gears.pinion_teeth, z2 = params.gears.gear_teeth;
    const ToothErrorPattern p = effects.tooth_pattern(z1, z2);
    auto per_tooth = [points](const std::vector<double>& base, const std::vector<double>& spacing,
                        const std::vector<double>& slope) {
      std::vector<std::vector<double>> out(spacing.size(), base);
      for (std::size_t n = 0; n < spacing.size(); ++n)
        for (int i = 0; i < points; ++i)
          out[n][static_cast<std::size_t>(i)] += spacing[n] + slope[n] * (static_cast<double>(i) / (points - 1) - 0.5);
      return out;
    };
    d.pinion_per_tooth = per_tooth(pinion, p.pinion_spacing_m, p.pinion_slope_m);
    d.gear_per_tooth = per_tooth(gear, p.gear_spacing_m, p.gear_slope_m);
  } else if (any) {
    d.pinion = std::move(pinion);
    d.gear = std::move(gear);
  }
  return d;
}

RigRecord simulate_record(const twin::GearboxParameters& params, const EffectSet& effects, const WearState& wear,
                          const SlidingVibration& sliding, const RigRunSettings& s) {
  if (!(s.sample_rate_hz >= 100) || !std::isfinite(s.sample_rate_hz)) throw RigParameterError("sample rate must be >= 100 Hz");
  if (!(s.duration_s > 0) || s.duration_s * s.sample_rate_hz > 2e9) throw RigParameterError("duration must be positive");
  if (s.channels < 1 || s.channels > 2) throw RigParameterError("channels must be 1 or 2");
  if (!(s.settle_s >= 0)) throw RigParameterError("settle time must be >= 0");
  if (!(s.min_ode_rate_hz > 0)) throw RigParameterError("integration rate must be positive");
  if (!(sliding.pitting_rms_m_s2 >= 0) || !(sliding.abrasion_rms_m_s2 >= 0))
    throw RigParameterError("sliding vibration RMS must be >= 0");

  if (s.front_end_oversampling < 0) throw RigParameterError("front-end oversampling must be 0 (automatic) or at least 1");

  const RigDynamics dyn(params, effects, truth_profile(params, effects, wear), s.speed_hz, s.torque_nm);
  const double fs = s.sample_rate_hz;
  const int substeps = std::max(1, static_cast<int>(std::ceil(s.min_ode_rate_hz / fs - 1e-9)));
  const double h = 1.0 / (fs * substeps);
  const auto count = static_cast<std::size_t>(std::ceil(s.duration_s * fs));
  // The sensor front-end (dsp::AntiAliasDecimator): the structure's acceleration is read `factor`
  // times per sample over the record and the filter's reach on both sides, low-passed and
  // decimated; sample i of the record is instant pad + i of the run. factor 1: read once per sample.
  const int factor = s.front_end_oversampling > 0 ? s.front_end_oversampling : dsp::front_end_oversampling(fs);
  std::optional<dsp::AntiAliasDecimator> front_end;
  if (factor > 1) front_end.emplace(factor);
  const std::size_t pad = front_end ? front_end->padding_outputs() : 0;
  const std::size_t instants = count + 2 * pad;
  const auto fine_per_sample = static_cast<std::size_t>(factor);
  const double fine_h = 1.0 / (fs * factor);

  RigRecord rec;
  rec.sample_rate_hz = fs;
  RigState y = dyn.initial_state(), k1, k2, k3, k4, tmp, k_end, y_start, k_start, y_fine, dy_fine;
  bool k1_ready = false;  // k1 already holds f(t, y) in `segment` at the start of the next step

  std::vector<double> fine[2];
  if (front_end)
    for (int c = 0; c < s.channels; ++c) fine[c].assign(instants * fine_per_sample, 0.0);
  std::size_t fine_base = 0;  // fine index of the current sample instant
  double instant_t = 0;       // its time
  int next_fine = factor;     // the next fine point after it still to be read (1 .. factor - 1; none while settling)
  RigOutputs fine_out;

  detail::MeshSegment segment = dyn.locate(0.0, y);
  auto rk4 = [&](double t, double dt) {  // k1 holds f(t, y) in `segment`
    tmp = y + 0.5 * dt * k1;
    dyn.derivative(t + 0.5 * dt, tmp, k2, nullptr, &segment);
    tmp = y + 0.5 * dt * k2;
    dyn.derivative(t + 0.5 * dt, tmp, k3, nullptr, &segment);
    tmp = y + dt * k3;
    dyn.derivative(t + dt, tmp, k4, nullptr, &segment);
    y += (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    rec.rhs_evaluations += 3;
    ++rec.integration_steps;
  };
  // Reads the front-end's fine points inside a piece [t, t + dt] that stayed in one segment, on the
  // cubic Hermite interpolant of the state between its ends (k_start: f at the start; f at the
  // end, in the same segment, goes to k_end), so a sample costs one derivative, not a step.
  auto read_fine = [&](double t, double dt) -> bool {
    if (!front_end || next_fine >= factor) return false;
    const double t_fine = instant_t + next_fine * fine_h;
    if (t_fine > t + dt * (1 + 1e-9)) return false;
    dyn.derivative(t + dt, y, k_end, nullptr, &segment);
    ++rec.rhs_evaluations;
    while (next_fine < factor) {
      const double tf = instant_t + next_fine * fine_h;
      if (tf > t + dt * (1 + 1e-9) + 1e-15) break;
      const double u = std::clamp((tf - t) / dt, 0.0, 1.0), u2 = u * u, u3 = u2 * u;
      y_fine = (2 * u3 - 3 * u2 + 1) * y_start + (u3 - 2 * u2 + u) * dt * k_start + (3 * u2 - 2 * u3) * y +
               (u3 - u2) * dt * k_end;
      dyn.derivative(tf, y_fine, dy_fine, &fine_out, &segment);
      ++rec.rhs_evaluations;
      const std::size_t at = fine_base + static_cast<std::size_t>(next_fine);
      fine[0][at] = fine_out.y6_acc + fine_out.casing_y;
      if (s.channels > 1) fine[1][at] = fine_out.x6_acc + fine_out.casing_x;
      ++next_fine;
    }
    return true;
  };
  // One step of length dt from t, split where a tooth pair enters or leaves: every stage of a
  // Runge-Kutta step sees the same pairs in contact, and the switch happens at the located instant.
  auto step = [&](double t, double dt) {
    if (!k1_ready) {
      dyn.derivative(t, y, k1, nullptr, &segment);
      ++rec.rhs_evaluations;
    }
    k1_ready = false;
    double remaining = dt;
    for (;;) {
      const double r = dyn.mesh_cycle_rate(t, y);
      const double phase = dyn.mesh_cycles(t, y) - static_cast<double>(segment.cycle);
      const double tau = r > 0 ? std::max(0.0, (segment.hi - phase) / r) : std::numeric_limits<double>::infinity();
      if (tau < remaining - 1e-6 * h) {
        if (tau > 0) {
          y_start = y;
          k_start = k1;
          rk4(t, tau);
          read_fine(t, tau);
          t += tau;
          remaining -= tau;
        }
        segment = dyn.next(segment);
        dyn.derivative(t, y, k1, nullptr, &segment);
        ++rec.rhs_evaluations;
      } else {
        y_start = y;
        k_start = k1;
        rk4(t, remaining);
        if (read_fine(t, remaining)) {
          k1 = k_end;  // f at the step's end in the same segment: the next step's start
          k1_ready = true;
        }
        return;
      }
    }
  };

  // Settle (not recorded).
  const auto settle_steps = static_cast<std::size_t>(std::ceil(s.settle_s / h - 1e-9));
  for (std::size_t i = 0; i < settle_steps; ++i) {
    step(static_cast<double>(i) * h, h);
    if (!y.allFinite()) throw twin::TwinDivergenceError("rig integration diverged while settling");
  }
  const double t0 = static_cast<double>(settle_steps) * h;

  std::vector<double> ch[2];
  for (int c = 0; c < s.channels; ++c) ch[c].resize(count);
  std::vector<double> sliding_factor(count), input_angle(count);
  if (s.keep_diagnostics) {
    rec.mesh_deflection_m.resize(count);
    rec.mesh_force_n.resize(count);
    rec.bearing_force_y_n.resize(count);
    rec.casing_y_m_s2.resize(count);
    rec.structure_y_m_s2.resize(count);
    rec.mesh_cycles.resize(count);
  }
  RigOutputs out;
  for (std::size_t n = 0; n < instants; ++n) {
    const double ti = t0 + static_cast<double>(n) / fs;
    dyn.derivative(ti, y, k1, &out, &segment);
    ++rec.rhs_evaluations;
    k1_ready = true;
    if (!y.allFinite() || std::abs(out.deflection) > 1e-3)
      throw twin::TwinDivergenceError("rig integration diverged at t = " + std::to_string(ti - t0) + " s");
    const double structure_y = out.y6_acc + out.casing_y, structure_x = out.x6_acc + out.casing_x;
    if (front_end) {
      fine_base = n * fine_per_sample;
      fine[0][fine_base] = structure_y;
      if (s.channels > 1) fine[1][fine_base] = structure_x;
    }
    if (n >= pad && n < pad + count) {
      const std::size_t i = n - pad;
      if (!front_end) {
        ch[0][i] = structure_y;
        if (s.channels > 1) ch[1][i] = structure_x;
      }
      sliding_factor[i] = out.sliding_factor;
      input_angle[i] = out.input_angle;
      if (s.keep_diagnostics) {
        rec.mesh_deflection_m[i] = out.deflection;
        rec.mesh_force_n[i] = out.mesh_force;
        rec.bearing_force_y_n[i] = out.bearing_force_y;
        rec.casing_y_m_s2[i] = out.casing_y;
        rec.structure_y_m_s2[i] = structure_y;
        rec.mesh_cycles[i] = out.mesh_cycles;
      }
    }
    if (n + 1 == instants) break;
    instant_t = ti;
    next_fine = 1;
    for (int k = 0; k < substeps; ++k) step(ti + static_cast<double>(k) * h, h);
  }
  if (front_end) {
    // The last instant's fine points lie beyond the run; the filter never reaches them (the
    // padding covers its half length), so they stay 0 unread.
    for (int c = 0; c < s.channels; ++c) front_end->decimate(fine[c], ch[c]);
  }
  if (s.keep_diagnostics) rec.input_angle_rad = input_angle;

  // Tacho: the encoder angle passes 2πk between two samples.
  for (std::size_t i = 1; i < count; ++i) {
    const double a0 = input_angle[i - 1], a1 = input_angle[i];
    const double edge = 2.0 * std::numbers::pi * std::ceil(a0 / (2.0 * std::numbers::pi));
    if (edge >= a0 && edge < a1) rec.tacho_edges.push_back(static_cast<double>(i) - 1.0 + (edge - a0) / (a1 - a0));
  }

  // Sliding-induced vibration: band noise times the mesh's sliding pattern (unit RMS), one
  // independent realisation per channel and band.
  if (sliding.pitting_rms_m_s2 > 0 || sliding.abrasion_rms_m_s2 > 0) {
    double ss = 0;
    for (double v : sliding_factor) ss += v * v;
    const double norm = ss > 0 ? 1.0 / std::sqrt(ss / static_cast<double>(count)) : 0.0;
    for (int c = 0; c < s.channels; ++c) {
      detail::Random rng(s.seed * 0x9E3779B97F4A7C15ull + 101 + static_cast<std::uint64_t>(c));
      if (sliding.pitting_rms_m_s2 > 0) {
        const auto n = band_noise(count, sliding.pitting_band_low_hz, sliding.pitting_band_high_hz, fs, rng);
        for (std::size_t i = 0; i < count; ++i) ch[c][i] += sliding.pitting_rms_m_s2 * norm * sliding_factor[i] * n[i];
      }
      if (sliding.abrasion_rms_m_s2 > 0) {
        const auto n = band_noise(count, sliding.abrasion_band_low_hz, sliding.abrasion_band_high_hz, fs, rng);
        for (std::size_t i = 0; i < count; ++i) ch[c][i] += sliding.abrasion_rms_m_s2 * norm * sliding_factor[i] * n[i];
      }
    }
  }
  if (effects.enabled(Effect::mounting)) {
    AnalogMount mount(count, effects.get("mounting.frequency_hz"), effects.get("mounting.damping_ratio"), fs);
    for (int c = 0; c < s.channels; ++c) mount.apply(ch[c]);
  }
  if (effects.enabled(Effect::noise)) {
    const double sigma = std::sqrt(effects.get("noise.psd") * fs / 2.0);
    for (int c = 0; c < s.channels; ++c) {
      detail::Random rng(s.seed * 0x2545F4914F6CDD1Dull + 7 + static_cast<std::uint64_t>(c));
      for (auto& v : ch[c]) v += sigma * rng.gaussian();
    }
  }
  rec.acceleration.resize(static_cast<std::size_t>(s.channels));
  for (int c = 0; c < s.channels; ++c) rec.acceleration[static_cast<std::size_t>(c)].assign(ch[c].begin(), ch[c].end());
  return rec;
}

}  // namespace gearwatch::rig
