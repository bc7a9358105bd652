#pragma once
// The twin's integrator as a template over the observer, apart from simulation.hpp so that only
// the code that integrates pays for compiling Boost.Odeint.
#include <cmath>
#include <string>

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

}  // namespace gearwatch::twin
