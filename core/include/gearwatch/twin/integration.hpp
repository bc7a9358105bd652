#pragma once
// The twin's integrator as a template over the observer, apart from simulation.hpp so that only
// the code that integrates pays for compiling Boost.Odeint.
#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include <boost/numeric/odeint.hpp>

#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/simulation.hpp"

namespace gearwatch::twin {

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
    double sum = 0;  // one test per sample: a NaN or an infinity anywhere makes the sum non-finite
    for (double v : x) sum += v;
    if (!std::isfinite(sum))
      for (double v : x)
        if (!std::isfinite(v)) throw TwinDivergenceError("integration diverged: non-finite state at t = " + std::to_string(t) + " s");
    const double delta = g.dot(Eigen::Map<const Vector21>(x.data()));
    if (std::abs(delta) > options.deflection_limit_m)
      throw TwinDivergenceError("integration diverged: mesh deflection " + std::to_string(delta) + " m at t = " +
                                std::to_string(t) + " s exceeds the limit");
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
  /// below) before one more period is integrated as the template of the rest of the record.
  std::size_t agreeing_periods = 1;
  /// agrees(anchor state, state at b, b): the periodicity check between the first boundary of a run
  /// of agreeing ones and a later one.
  std::function<bool(const State&, const State&, double)> agrees;
};

struct SampledRun {
  std::size_t evaluations = 0;     ///< right-hand-side evaluations
  bool tiled = false;              ///< the samples after `tiled_from_s` came from the template period
  double tiled_from_s = 0;         ///< the template period's end (the first tiled sample is at or after it)
};

/// integrate_sampled with the periodic path: the same dopri5 steps as integrate_sampled (its
/// dense-output loop, written out so that it can pause), observer(x, t, i, in_order) at sample i.
/// Checks each period boundary t0 + kT; once `agreeing_periods` boundaries in a row agree with the
/// first of them, the
/// next period [b, b + T] is integrated as the template and every later sample i is read off its
/// dense output at t_i − kT (the state repeats with T), with in_order false. If the template's own
/// end does not agree with its start, the tiled samples are dropped and the integration carries on
/// (observer called again for them), so a run that never agrees is exactly the full integration.
/// The calc_state calls the checks add do not change the steps (dense output is read-only).
template <class Observer>
SampledRun integrate_sampled_periodic(const GearboxDynamics& dynamics, State& state, double t0, double rate, std::size_t count,
                                      const SimulationOptions& options, const PeriodicTiling& tiling, Observer&& observer) {
  namespace odeint = boost::numeric::odeint;
  if (!(rate > 0) || !std::isfinite(rate)) throw TwinParameterError("sample rate must be positive");
  if (!(tiling.period_s > 0) || !std::isfinite(tiling.period_s)) throw TwinParameterError("tiling period must be positive");
  for (double v : state)
    if (!std::isfinite(v)) throw TwinDivergenceError("initial state is not finite");
  SampledRun run;
  if (count == 0) return run;
  auto system = [&](const State& x, State& dxdt, double t) {
    ++run.evaluations;
    dynamics(x, dxdt, t);
  };
  const Vector21& g = dynamics.matrices().mesh;
  auto check = [&](const State& x, double t) {
    double sum = 0;
    for (double v : x) sum += v;
    if (!std::isfinite(sum))
      for (double v : x)
        if (!std::isfinite(v)) throw TwinDivergenceError("integration diverged: non-finite state at t = " + std::to_string(t) + " s");
    const double delta = g.dot(Eigen::Map<const Vector21>(x.data()));
    if (std::abs(delta) > options.deflection_limit_m)
      throw TwinDivergenceError("integration diverged: mesh deflection " + std::to_string(delta) + " m at t = " +
                                std::to_string(t) + " s exceeds the limit");
  };
  auto time_of = [&](std::size_t i) { return t0 + static_cast<double>(i) / rate; };
  const double period = tiling.period_s;
  const double last_time = time_of(count - 1);
  auto stepper = odeint::make_dense_output(options.absolute_tolerance, options.relative_tolerance,
                                           odeint::runge_kutta_dopri5<State>());
  auto leq = [](double a, double b, double dt) { return odeint::detail::less_eq_with_sign(a, b, dt); };
  stepper.initialize(state, t0, 0.1 / rate);
  check(state, t0);
  observer(static_cast<const State&>(state), t0, std::size_t{0}, true);
  std::size_t next = 1;             // the next sample in order
  int steps_since_output = 0;
  std::size_t boundary = 1;         // the next boundary is t0 + boundary·T
  State boundary_state = state, x{};
  std::size_t agreeing = 0;
  // The template: [start, start + T); later samples from `first_tiled` on, one cursor per repeat k.
  bool templating = false;
  double template_start = 0;
  std::size_t first_tiled = count;
  struct Repeat {
    std::size_t next, end;
    double shift;
  };
  std::vector<Repeat> repeats;
  auto start_template = [&](double start) {
    first_tiled = static_cast<std::size_t>(std::max(0.0, std::ceil((start + period - t0) * rate)));
    while (first_tiled < count && time_of(first_tiled) < start + period) ++first_tiled;
    if (first_tiled >= count) return;
    templating = true;
    template_start = start;
    repeats.clear();
    for (std::size_t k = 1, i = first_tiled; i < count; ++k) {
      const double shift = static_cast<double>(k) * period;
      std::size_t end = i;
      while (end < count && time_of(end) < start + shift + period) ++end;
      repeats.push_back({i, end, shift});
      i = end;
    }
  };
  auto step = [&]() {
    if (++steps_since_output > options.max_steps_per_sample)
      throw TwinDivergenceError("integration stalled: more than " + std::to_string(options.max_steps_per_sample) +
                                " steps between two samples");
    try {
      if (leq(stepper.current_time() + stepper.current_time_step(), last_time, stepper.current_time_step())) {
        stepper.do_step(system);
      } else {
        stepper.initialize(stepper.current_state(), stepper.current_time(), last_time - stepper.current_time());
        stepper.do_step(system);
      }
    } catch (const odeint::step_adjustment_error& e) {
      throw TwinDivergenceError(std::string("integration diverged: ") + e.what());
    }
  };
  while (templating || next < count) {
    step();
    const double now = stepper.current_time(), dt = stepper.current_time_step();
    const std::size_t order_end = templating ? first_tiled : count;
    while (next < order_end && leq(time_of(next), now, dt)) {
      stepper.calc_state(time_of(next), x);
      check(x, time_of(next));
      observer(static_cast<const State&>(x), time_of(next), next, true);
      ++next;
      steps_since_output = 0;
    }
    while (!templating && leq(t0 + static_cast<double>(boundary) * period, now, dt)) {
      const double b = t0 + static_cast<double>(boundary) * period;
      stepper.calc_state(b, x);
      // Each boundary against the first of the run of agreeing ones (the anchor), not against the
      // one before: a slow transient moves little in one period but its whole swing in half its own.
      if (tiling.agrees && tiling.agrees(boundary_state, x, b)) {
        ++agreeing;
      } else {
        agreeing = 0;
        boundary_state = x;
      }
      ++boundary;
      // The template must start inside this step (its dense output is read from here on).
      if (agreeing >= tiling.agreeing_periods && b + period > now && b + 2 * period <= last_time) start_template(b);
    }
    if (!templating) continue;
    for (Repeat& r : repeats)
      while (r.next < r.end && leq(time_of(r.next) - r.shift, now, dt)) {
        stepper.calc_state(time_of(r.next) - r.shift, x);
        check(x, time_of(r.next));
        observer(static_cast<const State&>(x), time_of(r.next), r.next, false);
        ++r.next;
        steps_since_output = 0;
      }
    if (now < template_start + period) continue;
    // Every mapped time lies before the template's end, so all are read off by this step.
    stepper.calc_state(template_start + period, x);
    if (tiling.agrees && tiling.agrees(boundary_state, x, template_start + period)) {
      run.tiled = true;
      run.tiled_from_s = template_start + period;
      break;
    }
    // The template's end disagrees: carry on in order from its end (the tiled samples are read again).
    templating = false;
    agreeing = 0;
    boundary_state = x;
    boundary = static_cast<std::size_t>(std::llround((template_start + period - t0) / period)) + 1;
    while (next < count && leq(time_of(next), now, dt)) {
      stepper.calc_state(time_of(next), x);
      check(x, time_of(next));
      observer(static_cast<const State&>(x), time_of(next), next, true);
      ++next;
    }
  }
  state = stepper.current_state();
  return run;
}

}  // namespace gearwatch::twin
