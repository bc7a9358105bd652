#include "gearwatch/twin/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>
#include <numbers>
#include <optional>

#include "gearwatch/dsp/decimation.hpp"
#include "gearwatch/twin/integration.hpp"
#include "gearwatch/twin/modal_analysis.hpp"
#include "gearwatch/twin/slow_modes.hpp"

namespace gearwatch::twin {

namespace {

// The settling run's output grid: coarse, the same checks.
double settle_rate(const SimulationOptions& options) { return std::max(options.sample_rate_hz / 10.0, 1000.0); }

// The checks before anything is built; the number of samples to record.
double checked_sample_count(const GearboxParameters& p, const OperatingPoint& op, double duration_s,
                            const SimulationOptions& options) {
  p.validate();
  if (!std::isfinite(duration_s) || duration_s <= 0) throw TwinParameterError("simulation duration must be positive");
  if (!std::isfinite(op.input_speed_hz) || op.input_speed_hz <= 0) throw TwinParameterError("input speed must be positive");
  if (!(options.settle_s >= 0)) throw TwinParameterError("settle time must be non-negative");
  if (!(options.sample_rate_hz > 0)) throw TwinParameterError("sample rate must be positive");
  const double samples_d = std::ceil(duration_s * options.sample_rate_hz);
  if (samples_d > 2e9) throw TwinParameterError("simulation too long for one run");
  return samples_d;
}

// Integrates the settling time without recording; the right-hand side's evaluations.
std::size_t settle(const GearboxDynamics& dynamics, State& state, const SimulationOptions& options) {
  if (!(options.settle_s > 0)) return 0;
  const double rate = settle_rate(options);
  const auto settle_count = static_cast<std::size_t>(std::ceil(options.settle_s * rate)) + 1;
  return integrate_sampled(dynamics, state, 0.0, rate, settle_count, options, [](const State&, double) {});
}

// The time of the first recorded sample: the end of the settling grid.
double record_start_s(const SimulationOptions& options) {
  return options.settle_s > 0 ? std::ceil(options.settle_s * settle_rate(options)) / settle_rate(options) : 0.0;
}

// Sized, not reserved: the periodic path writes samples out of order.
void size_signals(SimulationResult& result, std::size_t count, bool casing_only) {
  result.casing_acceleration.resize(count);
  if (casing_only) return;
  result.time_s.resize(count);
  result.mesh_force_n.resize(count);
  result.mesh_stiffness_n_m.resize(count);
  result.transmission_error_m.resize(count);
  result.gte_m.resize(count);
  result.pairs_in_contact.resize(count);
}

// The slowest elastic mode of the linearised model (Hz): the periodicity check must watch at least
// half its period, or a transient in it could look periodic between two boundaries.
double slowest_elastic_mode_hz(const GearboxMatrices& m) {
  Eigen::VectorXd frequencies;
  Eigen::MatrixXd shapes;
  solve_modes(m.mass, m.linearised_stiffness(), frequencies, shapes);
  const double rigid_below = 1e-3 * frequencies.maxCoeff();  // the free rotation solves to ~0 Hz
  for (Eigen::Index i = 0; i < frequencies.size(); ++i)
    if (frequencies[i] > rigid_below) return frequencies[i];
  return frequencies.maxCoeff();
}

// Follows one tooth pair over a full pass: the pair that enters in the first full cycle.
class ContactProfileTracker {
 public:
  explicit ContactProfileTracker(const GearGeometry& geometry) : geometry_(geometry) {}

  bool done() const { return done_; }

  void observe(const GearboxDynamics::MeshState& ms, ContactForceProfile& prof) {
    if (done_) return;
    if (tracked_cycle_ < 0 && ms.phase < 0.5) tracked_cycle_ = ms.cycle + 1;  // the next pair to enter
    if (tracked_cycle_ < 0) return;
    const long long j = tracked_cycle_ <= ms.cycle ? ms.cycle - tracked_cycle_ : -1;
    if (j >= 0 && j < ms.pairs) {
      const double s = ms.positions[j];
      const HertzContact h = hertz_contact(geometry_, s, ms.pair_force[j]);
      prof.position_m.push_back(s);
      prof.pinion_fraction.push_back(geometry_.profile_fraction_pinion(s));
      prof.force_n.push_back(ms.pair_force[j]);
      prof.max_pressure_pa.push_back(h.max_pressure_pa);
      prof.half_width_m.push_back(h.half_width_m);
    } else if (j >= ms.pairs) {
      done_ = true;
    }
  }

 private:
  const GearGeometry& geometry_;
  long long tracked_cycle_ = -1;
  bool done_ = false;
};

// Tacho: the input shaft angle Ω t + q1 passes 2π k; edges at fractional sample positions.
std::vector<double> tacho_edges(double input_speed_hz, double t0, double sample_rate_hz,
                                const std::vector<double>& input_angle_deviation) {
  std::vector<double> edges;
  const double omega = 2.0 * std::numbers::pi * input_speed_hz;
  for (std::size_t i = 1; i < input_angle_deviation.size(); ++i) {
    const double a0 = omega * (t0 + (static_cast<double>(i) - 1.0) / sample_rate_hz) + input_angle_deviation[i - 1];
    const double a1 = omega * (t0 + static_cast<double>(i) / sample_rate_hz) + input_angle_deviation[i];
    const double k = std::ceil(a0 / (2.0 * std::numbers::pi));
    const double edge = 2.0 * std::numbers::pi * k;
    if (edge >= a0 && edge < a1) edges.push_back(static_cast<double>(i) - 1.0 + (edge - a0) / (a1 - a0));
  }
  return edges;
}

// Writes each output sample into the result: the casing acceleration and the input shaft's angle
// always, the mesh's signals and the contact profile unless casing_only (what a record needs:
// the front-end's oversampled run then does not hold every state signal `factor` times over).
class SampleRecorder {
 public:
  SampleRecorder(const GearboxDynamics& dynamics, const GearGeometry& geometry, SimulationResult& result, std::size_t count,
                 double t0, double path_gain, bool casing_only)
      : dynamics_(dynamics), profile_(geometry), result_(result), input_angle_deviation_(count), t0_(t0),
        path_gain_(path_gain), casing_only_(casing_only) {}

  void operator()(const State& x, double t, std::size_t i, bool in_order) {
    input_angle_deviation_[i] = x[theta1];
    if (casing_only_) {
      result_.casing_acceleration[i] = path_gain_ * dynamics_.acceleration(x, t, y6);
      return;
    }
    const auto ms = dynamics_.mesh_state(x, t);
    result_.casing_acceleration[i] = path_gain_ * dynamics_.acceleration(x, t, y6, ms.force);
    result_.time_s[i] = t - t0_;
    result_.mesh_force_n[i] = ms.force;
    result_.mesh_stiffness_n_m[i] = ms.stiffness;
    result_.transmission_error_m[i] = ms.deflection;
    result_.gte_m[i] = ms.gte;
    result_.pairs_in_contact[i] = ms.pairs;
    if (in_order) profile_.observe(ms, result_.contact_profile);
  }

  /// The contact profile is complete (or not wanted): the run may be tiled.
  bool profile_done() const { return casing_only_ || profile_.done(); }
  const std::vector<double>& input_angle_deviation() const { return input_angle_deviation_; }

 private:
  const GearboxDynamics& dynamics_;
  ContactProfileTracker profile_;
  SimulationResult& result_;
  std::vector<double> input_angle_deviation_;
  const double t0_, path_gain_;
  const bool casing_only_;
};

// The periodic path's check (SimulationOptions::periodic_tolerance,
// periodic_tacho_tolerance_samples): the casing acceleration at two boundaries against its RMS
// over the last period (from every sample time the sampler watches, also past the record's end),
// the input shaft's angle against the angle it turns in that fraction of a sample (what moves
// a tacho edge), and the whole state's difference in the energy norm (Δqᵀ K Δq + Δvᵀ M Δv, K the
// linearised stiffness) against the vibration's (twice its mean kinetic energy over the period).
// The casing acceleration alone is blind to the slow torsional modes: the mesh's lines dominate its
// RMS, and a mode at tens of Hz ringing after the start moves it by far less than 1e-3 of that while
// it still dominates the shaft-order lines. In the energy norm a mode weighs by its energy,
// whatever its frequency.
class PeriodicCheck {
 public:
  PeriodicCheck(const GearboxDynamics& dynamics, const SampleRecorder& recorder, double path_gain, double tolerance,
                double angle_tolerance)
      : dynamics_(dynamics), recorder_(recorder), path_gain_(path_gain), tolerance_(tolerance),
        angle_tolerance_(angle_tolerance), stiffness_(dynamics.matrices().linearised_stiffness()) {}

  void watch(const State& x, double t) {
    const double a = path_gain_ * dynamics_.acceleration(x, t, y6);
    square_sum_ += a * a;
    kinetic_sum_ += kinetic(x);
    ++samples_;
  }

  /// Carry the slow modes' free decay (nullptr: none): the anchor moved on by it is what a later
  /// boundary must agree with. The record's samples are t0 + i/rate, i < count; the tiling's period.
  void carry(const SlowModes* slow, double omega, double t0, double rate, std::size_t count, double period_s) {
    slow_ = slow != nullptr && !slow->empty() ? slow : nullptr;
    omega_ = omega;
    if (slow_ == nullptr) return;
    grid_.emplace(*slow_, rate, count);
    t0_ = t0, rate_ = rate, period_ = period_s;
    // e^{−λkT} for every whole number of periods a sample of the record lies after its template.
    const auto periods = static_cast<std::size_t>(std::ceil(static_cast<double>(count) / rate / period_s)) + 2;
    periods_back_.assign(slow_->size(), {});
    for (std::size_t j = 0; j < slow_->size(); ++j)
      for (std::size_t k = 0; k < periods; ++k)
        periods_back_[j].push_back(std::exp(-slow_->eigenvalue(j) * (static_cast<double>(k) * period_s)));
    change_.resize(slow_->size());
  }

  /// The anchor at t_anchor against the state at b. With slow modes, the first boundary after a
  /// new anchor gives their amplitudes.
  bool agrees(const State& anchor, double t_anchor, const State& later, double b) {
    const double kinetic_mean = samples_ > 0 ? kinetic_sum_ / static_cast<double>(samples_) : 0.0;
    const double rms = take_period_rms();
    if (!recorder_.profile_done()) return false;
    State earlier = anchor;
    if (slow_ != nullptr) {
      if (t_anchor != anchor_time_) set_anchor(anchor, t_anchor, later, b);
      slow_->advance(earlier, amplitudes_, 0.0, b - t_anchor);
      // The anchor's state at the mesh phase the later one has (retime(), to first order).
      const double dq = slow_->coordinate(amplitudes_, theta5, b - t_anchor) - slow_->coordinate(amplitudes_, theta5, 0.0);
      const double shift = dq / omega_;
      State rate;
      dynamics_(anchor, rate, t_anchor);
      for (std::size_t i = 0; i < earlier.size(); ++i) earlier[i] += rate[i] * shift;
    }
    const double da = path_gain_ * (dynamics_.acceleration(later, b, y6) - dynamics_.acceleration(earlier, b, y6));
    return rms > 0 && std::abs(da) <= tolerance_ * rms && std::abs(later[theta1] - earlier[theta1]) <= angle_tolerance_ &&
           difference_energy(earlier, later) <= tolerance_ * tolerance_ * kinetic_mean;
  }

  /// The template's state at its time made the state at sample i: the slow modes' decay from the
  /// one to the other added (the amplitudes of the anchor the template agreed with).
  void correct(State& x, double template_t, std::size_t i) {
    if (slow_ != nullptr) slow_->add_state(x, change_to_sample(template_t, i));
  }

  /// The template time with the mesh phase of sample i: the mesh phase follows Ω t + q5, so the
  /// pinion's slow turn Δq5 between the template time and the sample's moves it by Δq5 / Ω.
  double retime(double template_t, std::size_t i) {
    if (slow_ == nullptr) return template_t;
    return template_t + slow_->state_coordinate(change_to_sample(template_t, i), theta5) / omega_;
  }

 private:
  // vᵀ M v of the deviation velocities (twice the kinetic energy of the vibration).
  double kinetic(const State& x) const {
    const Vector21& m = dynamics_.matrices().mass;
    double e = 0;
    for (int i = 0; i < kDofCount; ++i) e += m[i] * x[kDofCount + i] * x[kDofCount + i];
    return e;
  }

  // The amplitudes from the anchor and the state one period later; times e^{λ(t0 − anchor)}, what
  // the sample grid's phasors turn into the modal coordinates at a sample.
  void set_anchor(const State& anchor, double t_anchor, const State& later, double b) {
    anchor_time_ = t_anchor;
    amplitudes_ = slow_->amplitudes(anchor, later, b - t_anchor);
    at_grid_start_.resize(slow_->size());
    for (std::size_t j = 0; j < slow_->size(); ++j)
      at_grid_start_[j] = amplitudes_[j] * std::exp(slow_->eigenvalue(j) * (t0_ - t_anchor));
  }

  // c_j (e^{λ(t_i − a)} − e^{λ(template_t − a)}): the sample's phasor from the grid, the template
  // time's as that times e^{−λkT} (k whole periods back) and e^{λε} (ε the rest: the retiming's
  // fraction of a sample, so its series converges at once).
  const SlowModes::Amplitudes& change_to_sample(double template_t, std::size_t i) {
    const double t = t0_ + static_cast<double>(i) / rate_;
    const double k = std::nearbyint((t - template_t) / period_);
    const double epsilon = template_t - (t - k * period_);
    for (std::size_t j = 0; j < slow_->size(); ++j) {
      const SlowModes::Complex lambda = slow_->eigenvalue(j);
      const SlowModes::Complex at_sample = at_grid_start_[j] * grid_->at(j, i);
      const bool tabulated = k >= 0 && k < static_cast<double>(periods_back_[j].size());
      const SlowModes::Complex back =
          tabulated ? periods_back_[j][static_cast<std::size_t>(k)] : std::exp(-lambda * (k * period_));
      change_[j] = at_sample * (1.0 - back * small_exp(lambda * epsilon));
    }
    return change_;
  }

  // e^z: its series to z² where |z| < 1e-6 and to z⁴ where |z| < 1e-3 (the rest under 1e-17 of
  // 1), the library's elsewhere.
  static SlowModes::Complex small_exp(SlowModes::Complex z) {
    const double size = std::abs(z.real()) + std::abs(z.imag());
    if (size < 1e-6) return 1.0 + z * (1.0 + 0.5 * z);
    if (size < 1e-3) return 1.0 + z * (1.0 + z * (0.5 + z * (1.0 / 6.0 + z * (1.0 / 24.0))));
    return std::exp(z);
  }

  // Δqᵀ K Δq + Δvᵀ M Δv between two states (twice the energy of their difference).
  double difference_energy(const State& earlier, const State& later) const {
    Vector21 dq;
    State dv{};
    for (int i = 0; i < kDofCount; ++i) {
      dq[i] = later[i] - earlier[i];
      dv[kDofCount + i] = later[kDofCount + i] - earlier[kDofCount + i];
    }
    return dq.dot(stiffness_ * dq) + kinetic(dv);
  }

  // The casing acceleration's RMS over the samples watched since the last call (0 if none).
  double take_period_rms() {
    const double rms = samples_ > 0 ? std::sqrt(square_sum_ / static_cast<double>(samples_)) : 0.0;
    square_sum_ = 0;
    kinetic_sum_ = 0;
    samples_ = 0;
    return rms;
  }

  const GearboxDynamics& dynamics_;
  const SampleRecorder& recorder_;
  const double path_gain_, tolerance_, angle_tolerance_;
  const Matrix21 stiffness_;
  const SlowModes* slow_ = nullptr;
  double omega_ = 1.0;  // the input shaft's nominal speed (rad/s)
  double anchor_time_ = -1.0;  // the amplitudes' anchor (none yet)
  SlowModes::Amplitudes amplitudes_;
  std::optional<SampleGridPhasors> grid_;                  // e^{λ i/rate} at the record's samples
  double t0_ = 0, rate_ = 1, period_ = 1;                  // the samples' times t0 + i/rate; the tiling's period
  SlowModes::Amplitudes at_grid_start_;                    // c·e^{λ(t0 − anchor)}
  std::vector<std::vector<SlowModes::Complex>> periods_back_;  // e^{−λkT}, k = 0, 1, …
  SlowModes::Amplitudes change_;                           // change_to_sample's result
  double square_sum_ = 0, kinetic_sum_ = 0;
  std::size_t samples_ = 0;
};

// The periodic path's description: the inputs' period, how many boundaries must agree (half the
// slowest elastic mode's period watched), how far past the record the search may go.
PeriodicTiling periodic_tiling(const GearboxParameters& p, const ToothProfileDeviation& deviation, const OperatingPoint& op,
                               const SimulationOptions& options, const GearboxMatrices& matrices, PeriodicCheck& check,
                               const SampleRecorder& recorder) {
  PeriodicTiling tiling;
  tiling.period_s = periodic_inputs_period_s(p, deviation, op, options);
  const double watch_s = 0.5 / slowest_elastic_mode_hz(matrices);
  tiling.agreeing_periods = static_cast<std::size_t>(std::ceil(watch_s / tiling.period_s)) + 1;
  tiling.search_s = options.periodic_keeps_transient ? 0.0 : options.periodic_search_s;  // kept: every sample integrated
  tiling.keep_transient = options.periodic_keeps_transient;
  tiling.watch = [&check](const State& x, double t) { check.watch(x, t); };
  tiling.agrees = [&check](const State& anchor, double t_anchor, const State& later, double b) {
    return check.agrees(anchor, t_anchor, later, b);
  };
  if (options.periodic_keeps_transient) {
    tiling.correct = [&check](State& x, double template_t, std::size_t i) { check.correct(x, template_t, i); };
    tiling.retime = [&check](double template_t, std::size_t i) { return check.retime(template_t, i); };
  }
  tiling.ready = [&recorder] { return recorder.profile_done(); };
  return tiling;
}

// The record read off the steady state's template (PeriodicSampler); the full integration again
// when a template was read and rejected.
void sample_periodic(const GearboxParameters& p, const ToothProfileDeviation& deviation, const OperatingPoint& op,
                     const SimulationOptions& options, const GearboxDynamics& dynamics, const GearboxMatrices& matrices,
                     State& state, double t0, std::size_t count, SampleRecorder& recorder, SimulationResult& result) {
  const double angle_tolerance =
      options.periodic_tacho_tolerance_samples * 2.0 * std::numbers::pi * op.input_speed_hz / options.sample_rate_hz;
  PeriodicCheck check(dynamics, recorder, p.casing_path_gain, options.periodic_tolerance, angle_tolerance);
  // Only where the record keeps its transient: the steady-state path's template must hold none.
  const SlowModes slow(matrices, options.periodic_keeps_transient ? op.input_speed_hz * p.gears.pinion_teeth : 0.0);
  const PeriodicTiling tiling = periodic_tiling(p, deviation, op, options, matrices, check, recorder);
  check.carry(&slow, 2.0 * std::numbers::pi * op.input_speed_hz, t0, options.sample_rate_hz, count, tiling.period_s);
  const State initial = state;
  const SampledRun run = integrate_sampled_periodic(dynamics, state, t0, options.sample_rate_hz, count, options, tiling, recorder);
  result.rhs_evaluations += run.evaluations;
  result.tiled = run.tiled;
  result.template_start_s = run.tiled ? run.template_start_s - t0 : 0.0;
  if (!run.discarded) return;
  state = initial;
  std::size_t i = 0;
  result.rhs_evaluations += integrate_sampled(dynamics, state, t0, options.sample_rate_hz, count, options,
                                              [&](const State& x, double t) { recorder(x, t, i++, true); });
}

SimulationResult run_simulation(const GearboxParameters& p, const ToothProfileDeviation& deviation, const OperatingPoint& op,
                                double duration_s, const SimulationOptions& options, bool casing_only) {
  const double samples_d = checked_sample_count(p, op, duration_s, options);
  const GearGeometry geometry = GearGeometry::from_spec(p.gears);
  MeshStiffnessOptions mo;
  mo.scale = p.mesh_stiffness_scale;
  mo.engagement_ramp_fraction = p.engagement_ramp_fraction;
  auto mesh = std::make_shared<const GearMeshStiffness>(geometry, mo);
  auto gte = std::make_shared<const GeometricTransmissionError>(geometry, deviation);
  const GearboxMatrices matrices = assemble(p, *mesh);
  GearboxDynamics dynamics(matrices, mesh, gte, op.input_speed_hz, op.input_torque_nm, options.mesh_model);
  if (!std::isfinite(options.face_misalignment_rad) || options.face_misalignment_rad < 0)
    throw TwinParameterError("face misalignment must be finite and >= 0 rad");
  dynamics.set_face_misalignment(options.face_misalignment_rad * p.gears.face_width_m);
  dynamics.set_shaft_run_out(options.shaft_run_out);

  SimulationResult result;
  result.sample_rate_hz = options.sample_rate_hz;
  result.brake_torque_nm = dynamics.brake_torque_nm();
  State state = dynamics.static_equilibrium();
  result.rhs_evaluations += settle(dynamics, state, options);
  const double t0 = record_start_s(options);
  const auto count = static_cast<std::size_t>(samples_d);
  size_signals(result, count, casing_only);
  SampleRecorder recorder(dynamics, geometry, result, count, t0, p.casing_path_gain, casing_only);
  if (options.periodic) {
    sample_periodic(p, deviation, op, options, dynamics, matrices, state, t0, count, recorder, result);
  } else {
    std::size_t i = 0;
    result.rhs_evaluations += integrate_sampled(dynamics, state, t0, options.sample_rate_hz, count, options,
                                                [&](const State& x, double t) { recorder(x, t, i++, true); });
  }
  result.tacho_edges = tacho_edges(op.input_speed_hz, t0, options.sample_rate_hz, recorder.input_angle_deviation());
  return result;
}

}  // namespace

double periodic_inputs_period_s(const GearboxParameters& p, const ToothProfileDeviation& deviation, const OperatingPoint& op,
                                const SimulationOptions& options) {
  if (!std::isfinite(op.input_speed_hz) || op.input_speed_hz <= 0) throw TwinParameterError("input speed must be positive");
  const long long z1 = p.gears.pinion_teeth, z2 = p.gears.gear_teeth;
  long long mesh_periods = 1;
  if (!deviation.pinion_per_tooth.empty() || options.shaft_run_out.pinion_m != 0) mesh_periods = std::lcm(mesh_periods, z1);
  if (!deviation.gear_per_tooth.empty() || options.shaft_run_out.gear_m != 0) mesh_periods = std::lcm(mesh_periods, z2);
  return static_cast<double>(mesh_periods) / (static_cast<double>(z1) * op.input_speed_hz);
}

SimulationResult simulate(const GearboxParameters& p, const ToothProfileDeviation& deviation, const OperatingPoint& op,
                          double duration_s, const SimulationOptions& options) {
  return run_simulation(p, deviation, op, duration_s, options, false);
}

CasingSignal simulate_casing_signal(const GearboxParameters& p, const ToothProfileDeviation& deviation,
                                    const OperatingPoint& op, double duration_s, double sample_rate_hz) {
  SimulationOptions options;
  options.sample_rate_hz = sample_rate_hz;
  return simulate_casing_signal(p, deviation, op, duration_s, options);
}

CasingSignal simulate_casing_signal(const GearboxParameters& p, const ToothProfileDeviation& deviation,
                                    const OperatingPoint& op, double duration_s, const SimulationOptions& options) {
  const double fs = options.sample_rate_hz;
  if (options.front_end_oversampling < 0) throw TwinParameterError("front-end oversampling must be 0 (automatic) or at least 1");
  if (!(fs > 0) || !std::isfinite(fs)) throw TwinParameterError("sample rate must be positive");
  const int factor = options.front_end_oversampling > 0 ? options.front_end_oversampling : dsp::front_end_oversampling(fs);
  CasingSignal s;
  s.sample_rate_hz = fs;
  if (factor == 1) {
    const SimulationResult r = run_simulation(p, deviation, op, duration_s, options, true);
    s.acceleration.assign(r.casing_acceleration.begin(), r.casing_acceleration.end());
    s.tacho_edges = r.tacho_edges;
    return s;
  }
  if (!std::isfinite(duration_s) || duration_s <= 0) throw TwinParameterError("simulation duration must be positive");
  const double count_d = std::ceil(duration_s * fs);
  if (count_d * factor > 2e9) throw TwinParameterError("simulation too long for one run");
  const auto count = static_cast<std::size_t>(count_d);
  // The record's samples are the front-end's: the model read at factor × fs over the record and
  // the filter's reach on both sides, then low-passed and decimated (output j is fine sample
  // (pad + j)·factor, so the record starts pad samples after the settling).
  const dsp::AntiAliasDecimator front_end(factor);
  const std::size_t pad = front_end.padding_outputs();
  SimulationOptions fine = options;
  fine.sample_rate_hz = fs * factor;
  fine.periodic_tacho_tolerance_samples = options.periodic_tacho_tolerance_samples * factor;  // in the record's samples
  const std::size_t fine_count = (count + 2 * pad) * static_cast<std::size_t>(factor);
  const SimulationResult r = run_simulation(p, deviation, op, (static_cast<double>(fine_count) - 0.5) / fine.sample_rate_hz, fine, true);
  if (r.casing_acceleration.size() != fine_count) throw TwinParameterError("front-end: unexpected oversampled length");
  s.acceleration.resize(count);
  front_end.decimate(r.casing_acceleration, s.acceleration);
  for (double e : r.tacho_edges) {
    const double at = e / factor - static_cast<double>(pad);
    if (at >= 0 && at < static_cast<double>(count) - 1) s.tacho_edges.push_back(at);
  }
  return s;
}

double lowpass_rms(const std::vector<double>& signal, double sample_rate_hz, double cutoff_hz) {
  if (signal.empty()) throw TwinParameterError("lowpass_rms: empty signal");
  if (!(sample_rate_hz > 0) || !(cutoff_hz > 0) || cutoff_hz >= 0.5 * sample_rate_hz)
    throw TwinParameterError("lowpass_rms: cutoff must lie in (0, fs/2)");
  // 4th-order Butterworth as two biquads (Q = 0.5412, 1.3066), bilinear transform with prewarping.
  const double k = std::tan(std::numbers::pi * cutoff_hz / sample_rate_hz);
  double mean = 0;
  for (double v : signal) mean += v;
  mean /= static_cast<double>(signal.size());
  std::vector<double> y(signal.size());
  for (std::size_t i = 0; i < signal.size(); ++i) y[i] = signal[i] - mean;  // RMS of the fluctuation
  for (double q : {0.541196100146197, 1.306562964876377}) {
    const double norm = 1.0 / (1.0 + k / q + k * k);
    const double b0 = k * k * norm, b1 = 2 * b0, b2 = b0;
    const double a1 = 2.0 * (k * k - 1.0) * norm, a2 = (1.0 - k / q + k * k) * norm;
    double z1 = 0, z2 = 0;
    for (double& v : y) {
      const double out = b0 * v + z1;
      z1 = b1 * v - a1 * out + z2;
      z2 = b2 * v - a2 * out;
      v = out;
    }
  }
  // Skip the filter's start-up transient: 5/fc (the slowest pole pair, Q = 1.31, decays by e^-12).
  const std::size_t skip = std::min(y.size() / 2, static_cast<std::size_t>(std::ceil(5.0 * sample_rate_hz / cutoff_hz)));
  double sum = 0;
  for (std::size_t i = skip; i < y.size(); ++i) sum += y[i] * y[i];
  return std::sqrt(sum / static_cast<double>(y.size() - skip));
}

MeshTuningResult tune_mesh_to_rms(const GearboxParameters& p, const OperatingPoint& op, double target_rms,
                                  double duration_s, double cutoff_hz, double low, double high, double sample_rate_hz) {
  if (!(target_rms > 0) || !std::isfinite(target_rms)) throw TwinParameterError("target RMS must be positive");
  if (!(low > 0) || !(high > low)) throw TwinParameterError("mesh scale search range is empty");
  MeshTuningResult r;
  r.target_rms = target_rms;
  SimulationOptions options;
  options.sample_rate_hz = sample_rate_hz;
  auto rms_at = [&](double scale) {
    GearboxParameters q = p;
    q.mesh_stiffness_scale = scale;
    ++r.simulations;
    const SimulationResult s = simulate(q, {}, op, duration_s, options);
    return lowpass_rms(s.casing_acceleration, sample_rate_hz, cutoff_hz);
  };
  double f_lo = rms_at(low) - target_rms, f_hi = rms_at(high) - target_rms;
  if (f_lo * f_hi > 0) {  // target outside what the range can produce: take the closer end
    r.mesh_stiffness_scale = std::abs(f_lo) < std::abs(f_hi) ? low : high;
    r.simulated_rms = target_rms + std::min(std::abs(f_lo), std::abs(f_hi)) * (std::abs(f_lo) < std::abs(f_hi) ? (f_lo > 0 ? 1 : -1) : (f_hi > 0 ? 1 : -1));
    return r;
  }
  double a = low, b = high;
  for (int i = 0; i < 30; ++i) {
    const double m = 0.5 * (a + b);
    const double fm = rms_at(m) - target_rms;
    r.mesh_stiffness_scale = m;
    r.simulated_rms = fm + target_rms;
    if (std::abs(fm) <= 0.002 * target_rms) break;
    if ((fm > 0) == (f_lo > 0)) {
      a = m;
      f_lo = fm;
    } else {
      b = m;
    }
  }
  r.reached = std::abs(r.simulated_rms - target_rms) <= 0.01 * target_rms;
  return r;
}

}  // namespace gearwatch::twin
