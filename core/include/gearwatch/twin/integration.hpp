#pragma once
// The twin's integrator as a template over the observer, apart from simulation.hpp so that only
// the code that integrates pays for compiling Boost.Odeint.
#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <type_traits>
#include <vector>

#include <boost/numeric/odeint.hpp>

#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/simulation.hpp"

namespace gearwatch::twin {

namespace detail {

/// The divergence checks on one output sample: a non-finite state, or a mesh deflection beyond
/// options.deflection_limit_m, throws TwinDivergenceError.
inline void check_sample(const Vector21& mesh, const SimulationOptions& options, const State& x, double t) {
  double sum = 0;  // one test per sample: a NaN or an infinity anywhere makes the sum non-finite
  for (double v : x) sum += v;
  if (!std::isfinite(sum))
    for (double v : x)
      if (!std::isfinite(v)) throw TwinDivergenceError("integration diverged: non-finite state at t = " + std::to_string(t) + " s");
  const double delta = mesh.dot(Eigen::Map<const Vector21>(x.data()));
  if (std::abs(delta) > options.deflection_limit_m)
    throw TwinDivergenceError("integration diverged: mesh deflection " + std::to_string(delta) + " m at t = " +
                              std::to_string(t) + " s exceeds the limit");
}

}  // namespace detail

/// Integrates an arbitrary GearboxDynamics from `state` at t0, calling observer(state, t) at
/// t0 + i/rate for i = 0..count-1; dopri5 with dense output and the divergence checks
/// described in simulation.hpp.
/// Returns the number of right-hand-side evaluations.
template <class Observer>
std::size_t integrate_sampled(const GearboxDynamics& dynamics, State& state, double t0, double rate, std::size_t count,
                              const SimulationOptions& options, Observer&& observer) {
  namespace odeint = boost::numeric::odeint;
  if (!(rate > 0) || !std::isfinite(rate)) throw TwinParameterError("sample rate must be positive");
  for (double v : state)
    if (!std::isfinite(v)) throw TwinDivergenceError("initial state is not finite");
  if (count == 0) return 0;
  std::size_t evaluations = 0;
  auto system = [&](const State& x, State& dxdt, double t) {
    ++evaluations;
    dynamics(x, dxdt, t);
  };
  std::vector<double> times(count);
  for (std::size_t i = 0; i < count; ++i) times[i] = t0 + static_cast<double>(i) / rate;
  const Vector21& g = dynamics.matrices().mesh;
  auto checked_observer = [&](const State& x, double t) {
    detail::check_sample(g, options, x, t);
    observer(x, t);
  };
  auto stepper = odeint::make_dense_output(options.absolute_tolerance, options.relative_tolerance,
                                           odeint::runge_kutta_dopri5<State>());
  try {
    odeint::integrate_times(stepper, system, state, times.begin(), times.end(), 0.1 / rate, checked_observer,
                            odeint::max_step_checker(options.max_steps_per_sample));
  } catch (const odeint::step_adjustment_error& e) {
    throw TwinDivergenceError(std::string("integration diverged: ") + e.what());
  } catch (const odeint::no_progress_error& e) {
    throw TwinDivergenceError(std::string("integration stalled: ") + e.what());
  }
  return evaluations;
}


/// The periodic path's description (simulation.hpp, SimulationOptions::periodic): every input of
/// the run repeats with `period_s`, so once the start-up transient has died out the state does too.
struct PeriodicTiling {
  double period_s = 0;
  /// Consecutive period boundaries whose states must each agree with the one before (the check
  /// below) before one more period is integrated as the template of the whole record.
  std::size_t agreeing_periods = 1;
  /// The search for the steady state may integrate past the record's end up to this time from the
  /// record's start (a record shorter than the check needs is read off the template all the same).
  double search_s = 0;
  /// watch(state, t): every sample time of the search and the template, in order, also past the
  /// record's end (the check's measure over a period is taken from these).
  std::function<void(const State&, double)> watch;
  /// agrees(anchor state, anchor's time, state at b, b): the periodicity check between the first
  /// boundary of a run of agreeing ones and a later one.
  std::function<bool(const State&, double, const State&, double)> agrees;
  /// correct(x, template time, i): the template's state at its own time made the state at the time
  /// of sample i, t0 + i/rate, which it stands for (a transient still decaying at the template,
  /// carried on); empty: the template's state as it is.
  std::function<void(State&, double, std::size_t)> correct;
  /// retime(template time, i): the template time whose mesh phase is the one sample i has
  /// (a slow transient turns the pinion a little further or less far than the template had); empty:
  /// the template time as it is. Taken modulo the period into the template.
  std::function<double(double, std::size_t)> retime;
  /// ready(): the check can still agree once the record's own samples are over (false: the search
  /// stops at the record's end).
  std::function<bool()> ready;
  /// The samples before the template's start keep their integrated values (the start-up
  /// transient stays in the record); only the later ones are read off the template.
  bool keep_transient = false;
};

struct SampledRun {
  std::size_t evaluations = 0;     ///< right-hand-side evaluations
  bool tiled = false;              ///< every sample was read off the steady-state template
  double template_start_s = 0;     ///< the template period's start (possibly past the record's end)
  /// A template was read and then rejected, so the samples are neither the template's nor the full
  /// integration's: the caller integrates the record again in full.
  bool discarded = false;
};

/// integrate_sampled with the periodic path: the same dopri5 steps as integrate_sampled (its
/// dense-output loop, written out so that it can pause). The search: the record's samples in order
/// (observer(x, t, i, true)), checking each period boundary t0 + kT, past the record's end if need
/// be (PeriodicTiling::search_s). Once `agreeing_periods` boundaries in a row agree with the first
/// of them, the next period [b, b + T] is integrated as the template and every sample i of the
/// record, from the first, is read off its dense output at t_i − kT with the k that puts it in
/// [b, b + T) (the state repeats with T; with PeriodicTiling::retime and ::correct, at the time of
/// the same mesh phase and with a slow transient's decay added), observer(x, t_i, i, false): the record holds no
/// start-up transient and its content does not depend on its length. A search that never agrees
/// leaves the full integration (sample for sample when the search stays inside the record: the
/// same steps). The calc_state calls the checks add do not change the steps (dense output is
/// read-only).
template <class Observer>
class PeriodicSampler {
 public:
  PeriodicSampler(const GearboxDynamics& dynamics, double t0, double rate, std::size_t count,
                  const SimulationOptions& options, const PeriodicTiling& tiling, Observer& observer)
      : dynamics_(dynamics), t0_(t0), rate_(rate), count_(count), options_(options), tiling_(tiling),
        observer_(observer), period_(tiling.period_s),
        stepper_(boost::numeric::odeint::make_dense_output(options.absolute_tolerance, options.relative_tolerance,
                                                           boost::numeric::odeint::runge_kutta_dopri5<State>())) {
    if (!(rate > 0) || !std::isfinite(rate)) throw TwinParameterError("sample rate must be positive");
    if (!(period_ > 0) || !std::isfinite(period_)) throw TwinParameterError("tiling period must be positive");
    search_end_ = count_ > 0 ? last_time() : t0_;
    // Past the record only when the check fits in the search: the anchor, the agreeing boundaries
    // and the template.
    const double needs = t0_ + static_cast<double>(tiling.agreeing_periods + 2) * period_;
    if (needs <= t0_ + tiling.search_s) search_end_ = std::max(search_end_, t0_ + tiling.search_s);
  }

  SampledRun run(State& state) {
    for (double v : state)
      if (!std::isfinite(v)) throw TwinDivergenceError("initial state is not finite");
    if (count_ == 0) return run_;
    start(state);
    while (templating_ || keep_searching()) {
      step();
      const double now = stepper_.current_time(), dt = stepper_.current_time_step();
      watch_in_order(now, dt);
      if (!templating_) check_boundaries(now, dt);
      if (!templating_) continue;
      emit_template(now, dt);
      if (now < template_start_ + period_) continue;
      if (template_closes()) break;
      resume_search();
    }
    run_.discarded = discarded_ && !run_.tiled;
    state = stepper_.current_state();
    return run_;
  }

 private:
  using Stepper = decltype(boost::numeric::odeint::make_dense_output(
      1.0, 1.0, boost::numeric::odeint::runge_kutta_dopri5<State>()));
  struct Repeat {
    std::size_t next, end;  // the samples [next, end) read off the template at template_time_
  };

  double time_of(std::size_t i) const { return t0_ + static_cast<double>(i) / rate_; }
  static bool leq(double a, double b, double dt) { return boost::numeric::odeint::detail::less_eq_with_sign(a, b, dt); }
  double last_time() const { return time_of(count_ - 1); }
  bool recording() const { return !templating_ && !discarded_ && next_ < count_; }

  // The record's samples are not over, or the search may go on past them.
  bool keep_searching() const {
    if (next_ < count_) return true;
    return stepper_.current_time() < search_end_ && (!tiling_.ready || tiling_.ready());
  }

  void start(const State& state) {
    stepper_.initialize(state, t0_, 0.1 / rate_);
    detail::check_sample(dynamics_.matrices().mesh, options_, state, t0_);
    if (tiling_.watch) tiling_.watch(state, t0_);
    observer_(state, t0_, std::size_t{0}, true);
    boundary_state_ = state;
    boundary_time_ = t0_;
  }

  // One dopri5 step; while the search ends with the record, the last one is shortened to end on
  // its last sample (as integrate_sampled's); bounded per sample.
  void step() {
    namespace odeint = boost::numeric::odeint;
    if (++steps_since_output_ > options_.max_steps_per_sample)
      throw TwinDivergenceError("integration stalled: more than " + std::to_string(options_.max_steps_per_sample) +
                                " steps between two samples");
    auto system = [this](const State& x, State& dxdt, double t) {
      ++run_.evaluations;
      dynamics_(x, dxdt, t);
    };
    try {
      const double now = stepper_.current_time(), dt = stepper_.current_time_step();
      if (!templating_ && search_end_ <= last_time() && !leq(now + dt, last_time(), dt))
        stepper_.initialize(stepper_.current_state(), now, last_time() - now);
      stepper_.do_step(system);
    } catch (const odeint::step_adjustment_error& e) {
      throw TwinDivergenceError(std::string("integration diverged: ") + e.what());
    }
  }

  // Every sample time up to now, in order, also past the record: the check's watch; while the
  // search is on, the record's own samples too.
  void watch_in_order(double now, double dt) {
    for (; leq(time_of(next_), now, dt); ++next_) {
      const double t = time_of(next_);
      stepper_.calc_state(t, x_);
      detail::check_sample(dynamics_.matrices().mesh, options_, x_, t);
      steps_since_output_ = 0;
      if (tiling_.watch) tiling_.watch(static_cast<const State&>(x_), t);
      if (recording()) observer_(static_cast<const State&>(x_), t, next_, true);
    }
  }

  // Each boundary against the first of the run of agreeing ones (the anchor), not against the one
  // before: a slow transient moves little in one period but its whole swing in half its own.
  void check_boundaries(double now, double dt) {
    while (!templating_ && leq(t0_ + static_cast<double>(boundary_) * period_, now, dt)) {
      const double b = t0_ + static_cast<double>(boundary_) * period_;
      stepper_.calc_state(b, x_);
      if (tiling_.agrees && tiling_.agrees(boundary_state_, boundary_time_, x_, b)) {
        ++agreeing_;
      } else {
        agreeing_ = 0;
        boundary_state_ = x_;
        boundary_time_ = b;
      }
      ++boundary_;
      // The template must start inside this step (its dense output is read from here on).
      if (agreeing_ >= tiling_.agreeing_periods && b + period_ > now) start_template(b);
    }
  }

  // The period of the template [start, start + T) that holds t − k·T.
  long long repeat_of(double t, double start) const {
    auto k = static_cast<long long>(std::floor((t - start) / period_));
    if (t - static_cast<double>(k) * period_ < start) --k;
    if (t - static_cast<double>(k) * period_ >= start + period_) ++k;
    return k;
  }

  // The template [start, start + T); every sample of the record, one cursor per run of samples
  // with the same k (k < 0 before the template).
  void start_template(double start) {
    templating_ = true;
    template_start_ = start;
    repeats_.clear();
    std::size_t first = 0;
    if (tiling_.keep_transient)
      while (first < count_ && repeat_of(time_of(first), start) < 0) ++first;
    template_time_.assign(count_, 0.0);
    for (std::size_t i = first; i < count_; ++i) {
      const double t = time_of(i);
      const long long k = repeat_of(t, start);
      double at = t - static_cast<double>(k) * period_;
      if (k != 0 && tiling_.retime) {
        at = tiling_.retime(at, i);
        while (at < start) at += period_;
        while (at >= start + period_) at -= period_;
      }
      template_time_[i] = at;
    }
    // One cursor per run of samples whose template times increase.
    for (std::size_t i = first; i < count_;) {
      std::size_t end = i + 1;
      while (end < count_ && template_time_[end] > template_time_[end - 1]) ++end;
      repeats_.push_back({i, end});
      i = end;
    }
  }

  void emit_template(double now, double dt) {
    for (Repeat& r : repeats_)
      for (; r.next < r.end && leq(template_time_[r.next], now, dt); ++r.next) {
        const double t = time_of(r.next), at = template_time_[r.next];
        stepper_.calc_state(at, x_);
        if (tiling_.correct && at != t) tiling_.correct(x_, at, r.next);
        detail::check_sample(dynamics_.matrices().mesh, options_, x_, t);
        observer_(static_cast<const State&>(x_), t, r.next, false);
      }
  }

  // Every mapped time lies before the template's end, so all are read off by now: the run is tiled
  // when the template's end agrees with the anchor.
  bool template_closes() {
    stepper_.calc_state(template_start_ + period_, x_);
    if (!(tiling_.agrees && tiling_.agrees(boundary_state_, boundary_time_, x_, template_start_ + period_))) return false;
    run_.tiled = true;
    run_.template_start_s = template_start_;
    return true;
  }

  // The template's end disagrees: the samples read off it are discarded and the search carries on
  // from its end (the caller integrates the record again if no later template closes).
  void resume_search() {
    templating_ = false;
    discarded_ = true;
    agreeing_ = 0;
    boundary_state_ = x_;
    boundary_time_ = template_start_ + period_;
    boundary_ = static_cast<std::size_t>(std::llround((template_start_ + period_ - t0_) / period_)) + 1;
  }

  const GearboxDynamics& dynamics_;
  const double t0_, rate_;
  const std::size_t count_;
  const SimulationOptions& options_;
  const PeriodicTiling& tiling_;
  Observer& observer_;
  const double period_;
  Stepper stepper_;
  SampledRun run_;
  State x_{}, boundary_state_{};
  double boundary_time_ = 0;       // the anchor's time
  double search_end_ = 0;          // the search stops here (the record's last sample or later)
  std::size_t next_ = 1;           // the next sample time in order (past count_ after the record)
  int steps_since_output_ = 0;
  std::size_t boundary_ = 1;       // the next boundary is t0 + boundary·T
  std::size_t agreeing_ = 0;
  bool templating_ = false;
  bool discarded_ = false;
  double template_start_ = 0;
  std::vector<Repeat> repeats_;
  std::vector<double> template_time_;  // each tiled sample's time in the template
};

template <class Observer>
SampledRun integrate_sampled_periodic(const GearboxDynamics& dynamics, State& state, double t0, double rate, std::size_t count,
                                      const SimulationOptions& options, const PeriodicTiling& tiling, Observer&& observer) {
  PeriodicSampler<std::remove_reference_t<Observer>> sampler(dynamics, t0, rate, count, options, tiling, observer);
  return sampler.run(state);
}

}  // namespace gearwatch::twin
