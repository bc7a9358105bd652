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

/// The run settings simulate_record refuses, each with its reason.
void validate(const SlidingVibration& sliding, const RigRunSettings& s) {
  if (!(s.sample_rate_hz >= 100) || !std::isfinite(s.sample_rate_hz)) throw RigParameterError("sample rate must be >= 100 Hz");
  if (!(s.duration_s > 0) || s.duration_s * s.sample_rate_hz > 2e9) throw RigParameterError("duration must be positive");
  if (s.channels < 1 || s.channels > 2) throw RigParameterError("channels must be 1 or 2");
  if (!(s.settle_s >= 0)) throw RigParameterError("settle time must be >= 0");
  if (!(s.min_ode_rate_hz > 0)) throw RigParameterError("integration rate must be positive");
  if (!(sliding.pitting_rms_m_s2 >= 0) || !(sliding.abrasion_rms_m_s2 >= 0))
    throw RigParameterError("sliding vibration RMS must be >= 0");
  if (s.front_end_oversampling < 0) throw RigParameterError("front-end oversampling must be 0 (automatic) or at least 1");
}

/// One record's run of the rig (simulate_record): the integration, split where the mesh's pairs
/// change, read at each sample instant and at the sensor front-end's fine points between them; then
/// the tacho and what acts on the sampled record (sliding vibration, the mount, the noise).
class RecordRun {
 public:
  RecordRun(const RigDynamics& dyn, const RigRunSettings& s);
  /// Integrates the settling time (not recorded).
  void settle();
  /// Integrates over the record, reading each sample instant.
  void record_instants();
  /// The tacho: the encoder angle passes 2πk between two samples.
  void find_tacho_edges();
  void add_sliding_vibration(const SlidingVibration& sliding);
  void apply_mounting(const EffectSet& effects);
  void add_noise(const EffectSet& effects);
  RigRecord take();

 private:
  void rk4(double t, double dt);
  bool read_fine(double t, double dt);
  void step(double t, double dt);
  void read_instant(std::size_t n, double ti);
  void keep_sample(std::size_t i, double structure_y, double structure_x);

  const RigDynamics& dyn_;
  const RigRunSettings& s_;
  const double fs_;
  const int substeps_;
  const double h_;
  const std::size_t count_;
  // The sensor front-end (dsp::AntiAliasDecimator): the structure's acceleration is read `factor_`
  // times per sample over the record and the filter's reach on both sides, low-passed and
  // decimated; sample i of the record is instant pad_ + i of the run. factor 1: read once per sample.
  const int factor_;
  std::optional<dsp::AntiAliasDecimator> front_end_;
  std::size_t pad_ = 0, instants_ = 0, fine_per_sample_ = 0;
  double fine_h_ = 0;

  RigRecord rec_;
  RigState y_, k1_, k2_, k3_, k4_, tmp_, k_end_, y_start_, k_start_, y_fine_, dy_fine_;
  bool k1_ready_ = false;  // k1_ already holds f(t, y) in `segment_` at the start of the next step
  std::vector<double> fine_[2];
  std::size_t fine_base_ = 0;  // fine index of the current sample instant
  double instant_t_ = 0;       // its time
  int next_fine_;              // the next fine point after it still to be read (1 .. factor - 1; none while settling)
  RigOutputs fine_out_, out_;
  detail::MeshSegment segment_;
  double t0_ = 0;  // the first instant's time, after settling
  std::vector<double> ch_[2];
  std::vector<double> sliding_factor_, input_angle_;
};

RecordRun::RecordRun(const RigDynamics& dyn, const RigRunSettings& s)
    : dyn_(dyn),
      s_(s),
      fs_(s.sample_rate_hz),
      substeps_(std::max(1, static_cast<int>(std::ceil(s.min_ode_rate_hz / fs_ - 1e-9)))),
      h_(1.0 / (fs_ * substeps_)),
      count_(static_cast<std::size_t>(std::ceil(s.duration_s * fs_))),
      factor_(s.front_end_oversampling > 0 ? s.front_end_oversampling : dsp::front_end_oversampling(fs_)),
      next_fine_(factor_) {
  if (factor_ > 1) front_end_.emplace(factor_);
  pad_ = front_end_ ? front_end_->padding_outputs() : 0;
  instants_ = count_ + 2 * pad_;
  fine_per_sample_ = static_cast<std::size_t>(factor_);
  fine_h_ = 1.0 / (fs_ * factor_);
  rec_.sample_rate_hz = fs_;
  y_ = dyn.initial_state();
  if (front_end_)
    for (int c = 0; c < s.channels; ++c) fine_[c].assign(instants_ * fine_per_sample_, 0.0);
  segment_ = dyn.locate(0.0, y_);
}

void RecordRun::rk4(double t, double dt) {  // k1_ holds f(t, y) in `segment_`
  tmp_ = y_ + 0.5 * dt * k1_;
  dyn_.derivative(t + 0.5 * dt, tmp_, k2_, nullptr, &segment_);
  tmp_ = y_ + 0.5 * dt * k2_;
  dyn_.derivative(t + 0.5 * dt, tmp_, k3_, nullptr, &segment_);
  tmp_ = y_ + dt * k3_;
  dyn_.derivative(t + dt, tmp_, k4_, nullptr, &segment_);
  y_ += (dt / 6.0) * (k1_ + 2.0 * k2_ + 2.0 * k3_ + k4_);
  rec_.rhs_evaluations += 3;
  ++rec_.integration_steps;
}

/// Reads the front-end's fine points inside a piece [t, t + dt] that stayed in one segment, on the
/// cubic Hermite interpolant of the state between its ends (k_start_: f at the start; f at the
/// end, in the same segment, goes to k_end_), so a sample costs one derivative, not a step.
bool RecordRun::read_fine(double t, double dt) {
  if (!front_end_ || next_fine_ >= factor_) return false;
  const double t_fine = instant_t_ + next_fine_ * fine_h_;
  if (t_fine > t + dt * (1 + 1e-9)) return false;
  dyn_.derivative(t + dt, y_, k_end_, nullptr, &segment_);
  ++rec_.rhs_evaluations;
  while (next_fine_ < factor_) {
    const double tf = instant_t_ + next_fine_ * fine_h_;
    if (tf > t + dt * (1 + 1e-9) + 1e-15) break;
    const double u = std::clamp((tf - t) / dt, 0.0, 1.0), u2 = u * u, u3 = u2 * u;
    y_fine_ = (2 * u3 - 3 * u2 + 1) * y_start_ + (u3 - 2 * u2 + u) * dt * k_start_ + (3 * u2 - 2 * u3) * y_ +
              (u3 - u2) * dt * k_end_;
    dyn_.derivative(tf, y_fine_, dy_fine_, &fine_out_, &segment_);
    ++rec_.rhs_evaluations;
    const std::size_t at = fine_base_ + static_cast<std::size_t>(next_fine_);
    fine_[0][at] = fine_out_.y6_acc + fine_out_.casing_y;
    if (s_.channels > 1) fine_[1][at] = fine_out_.x6_acc + fine_out_.casing_x;
    ++next_fine_;
  }
  return true;
}

/// One step of length dt from t, split where a tooth pair enters or leaves: every stage of a
/// Runge-Kutta step sees the same pairs in contact, and the switch happens at the located instant.
void RecordRun::step(double t, double dt) {
  if (!k1_ready_) {
    dyn_.derivative(t, y_, k1_, nullptr, &segment_);
    ++rec_.rhs_evaluations;
  }
  k1_ready_ = false;
  double remaining = dt;
  for (;;) {
    const double r = dyn_.mesh_cycle_rate(t, y_);
    const double phase = dyn_.mesh_cycles(t, y_) - static_cast<double>(segment_.cycle);
    const double tau = r > 0 ? std::max(0.0, (segment_.hi - phase) / r) : std::numeric_limits<double>::infinity();
    if (tau < remaining - 1e-6 * h_) {
      if (tau > 0) {
        y_start_ = y_;
        k_start_ = k1_;
        rk4(t, tau);
        read_fine(t, tau);
        t += tau;
        remaining -= tau;
      }
      segment_ = dyn_.next(segment_);
      dyn_.derivative(t, y_, k1_, nullptr, &segment_);
      ++rec_.rhs_evaluations;
    } else {
      y_start_ = y_;
      k_start_ = k1_;
      rk4(t, remaining);
      if (read_fine(t, remaining)) {
        k1_ = k_end_;  // f at the step's end in the same segment: the next step's start
        k1_ready_ = true;
      }
      return;
    }
  }
}

void RecordRun::settle() {
  const auto settle_steps = static_cast<std::size_t>(std::ceil(s_.settle_s / h_ - 1e-9));
  for (std::size_t i = 0; i < settle_steps; ++i) {
    step(static_cast<double>(i) * h_, h_);
    if (!y_.allFinite()) throw twin::TwinDivergenceError("rig integration diverged while settling");
  }
  t0_ = static_cast<double>(settle_steps) * h_;
}

void RecordRun::keep_sample(std::size_t i, double structure_y, double structure_x) {
  if (!front_end_) {
    ch_[0][i] = structure_y;
    if (s_.channels > 1) ch_[1][i] = structure_x;
  }
  sliding_factor_[i] = out_.sliding_factor;
  input_angle_[i] = out_.input_angle;
  if (s_.keep_diagnostics) {
    rec_.mesh_deflection_m[i] = out_.deflection;
    rec_.mesh_force_n[i] = out_.mesh_force;
    rec_.bearing_force_y_n[i] = out_.bearing_force_y;
    rec_.casing_y_m_s2[i] = out_.casing_y;
    rec_.structure_y_m_s2[i] = structure_y;
    rec_.mesh_cycles[i] = out_.mesh_cycles;
  }
}

/// The state's outputs at instant n (time ti): the front-end's first fine point of the instant, and
/// within the record its sample.
void RecordRun::read_instant(std::size_t n, double ti) {
  dyn_.derivative(ti, y_, k1_, &out_, &segment_);
  ++rec_.rhs_evaluations;
  k1_ready_ = true;
  if (!y_.allFinite() || std::abs(out_.deflection) > 1e-3)
    throw twin::TwinDivergenceError("rig integration diverged at t = " + std::to_string(ti - t0_) + " s");
  const double structure_y = out_.y6_acc + out_.casing_y, structure_x = out_.x6_acc + out_.casing_x;
  if (front_end_) {
    fine_base_ = n * fine_per_sample_;
    fine_[0][fine_base_] = structure_y;
    if (s_.channels > 1) fine_[1][fine_base_] = structure_x;
  }
  if (n >= pad_ && n < pad_ + count_) keep_sample(n - pad_, structure_y, structure_x);
}

void RecordRun::record_instants() {
  for (int c = 0; c < s_.channels; ++c) ch_[c].resize(count_);
  sliding_factor_.resize(count_);
  input_angle_.resize(count_);
  if (s_.keep_diagnostics) {
    rec_.mesh_deflection_m.resize(count_);
    rec_.mesh_force_n.resize(count_);
    rec_.bearing_force_y_n.resize(count_);
    rec_.casing_y_m_s2.resize(count_);
    rec_.structure_y_m_s2.resize(count_);
    rec_.mesh_cycles.resize(count_);
  }
  for (std::size_t n = 0; n < instants_; ++n) {
    const double ti = t0_ + static_cast<double>(n) / fs_;
    read_instant(n, ti);
    if (n + 1 == instants_) break;
    instant_t_ = ti;
    next_fine_ = 1;
    for (int k = 0; k < substeps_; ++k) step(ti + static_cast<double>(k) * h_, h_);
  }
  if (front_end_) {
    // The last instant's fine points lie beyond the run; the filter never reaches them (the
    // padding covers its half length), so they stay 0 unread.
    for (int c = 0; c < s_.channels; ++c) front_end_->decimate(fine_[c], ch_[c]);
  }
  if (s_.keep_diagnostics) rec_.input_angle_rad = input_angle_;
}

void RecordRun::find_tacho_edges() {
  for (std::size_t i = 1; i < count_; ++i) {
    const double a0 = input_angle_[i - 1], a1 = input_angle_[i];
    const double edge = 2.0 * std::numbers::pi * std::ceil(a0 / (2.0 * std::numbers::pi));
    if (edge >= a0 && edge < a1) rec_.tacho_edges.push_back(static_cast<double>(i) - 1.0 + (edge - a0) / (a1 - a0));
  }
}

/// Sliding-induced vibration: band noise times the mesh's sliding pattern (unit RMS), one
/// independent realisation per channel and band.
void RecordRun::add_sliding_vibration(const SlidingVibration& sliding) {
  if (!(sliding.pitting_rms_m_s2 > 0 || sliding.abrasion_rms_m_s2 > 0)) return;
  double ss = 0;
  for (double v : sliding_factor_) ss += v * v;
  const double norm = ss > 0 ? 1.0 / std::sqrt(ss / static_cast<double>(count_)) : 0.0;
  for (int c = 0; c < s_.channels; ++c) {
    detail::Random rng(s_.seed * 0x9E3779B97F4A7C15ull + 101 + static_cast<std::uint64_t>(c));
    if (sliding.pitting_rms_m_s2 > 0) {
      const auto n = band_noise(count_, sliding.pitting_band_low_hz, sliding.pitting_band_high_hz, fs_, rng);
      for (std::size_t i = 0; i < count_; ++i) ch_[c][i] += sliding.pitting_rms_m_s2 * norm * sliding_factor_[i] * n[i];
    }
    if (sliding.abrasion_rms_m_s2 > 0) {
      const auto n = band_noise(count_, sliding.abrasion_band_low_hz, sliding.abrasion_band_high_hz, fs_, rng);
      for (std::size_t i = 0; i < count_; ++i) ch_[c][i] += sliding.abrasion_rms_m_s2 * norm * sliding_factor_[i] * n[i];
    }
  }
}

void RecordRun::apply_mounting(const EffectSet& effects) {
  if (!effects.enabled(Effect::mounting)) return;
  AnalogMount mount(count_, effects.get("mounting.frequency_hz"), effects.get("mounting.damping_ratio"), fs_);
  for (int c = 0; c < s_.channels; ++c) mount.apply(ch_[c]);
}

void RecordRun::add_noise(const EffectSet& effects) {
  if (!effects.enabled(Effect::noise)) return;
  const double sigma = std::sqrt(effects.get("noise.psd") * fs_ / 2.0);
  for (int c = 0; c < s_.channels; ++c) {
    detail::Random rng(s_.seed * 0x2545F4914F6CDD1Dull + 7 + static_cast<std::uint64_t>(c));
    for (auto& v : ch_[c]) v += sigma * rng.gaussian();
  }
}

RigRecord RecordRun::take() {
  rec_.acceleration.resize(static_cast<std::size_t>(s_.channels));
  for (int c = 0; c < s_.channels; ++c) rec_.acceleration[static_cast<std::size_t>(c)].assign(ch_[c].begin(), ch_[c].end());
  return std::move(rec_);
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
  validate(sliding, s);
  const RigDynamics dyn(params, effects, truth_profile(params, effects, wear), s.speed_hz, s.torque_nm);
  RecordRun run(dyn, s);
  run.settle();
  run.record_instants();
  run.find_tacho_edges();
  run.add_sliding_vibration(sliding);
  run.apply_mounting(effects);
  run.add_noise(effects);
  return run.take();
}

}  // namespace gearwatch::rig
