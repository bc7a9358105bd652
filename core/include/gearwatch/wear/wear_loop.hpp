#pragma once
// The "blue loop" of thesis Fig. 7.1 (open loop, no measurements): worn profile → GTE → contact force
// of the pair → Archard wear increment and pitting increment → new worn profile, every ΔN cycles.
// ΔN adapts: a step whose wear changes the pair's force anywhere on the pass by more than a
// tolerance (fraction of the static force) is retried with half the cycles; quiet steps double it.
#include <string>
#include <vector>

#include "gearwatch/twin/gearbox_parameters.hpp"
#include "gearwatch/twin/mesh_stiffness.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "gearwatch/twin/transmission_error.hpp"
#include "gearwatch/types/wear_state.hpp"
#include "gearwatch/wear/archard_wear.hpp"
#include "gearwatch/wear/force_model.hpp"
#include "gearwatch/wear/pitting_model.hpp"

namespace gearwatch::wear {

struct WearLoopOptions {
  double k_wear_si = 0;                 ///< Archard K in SI (m²/N); k_wear_si_from_seed() converts the thesis's figures
  double k_pitting = 0;                 ///< Lundberg–Palmgren K (SI, see pitting_model.hpp); 0 = no pitting
  PittingMaterial material;
  twin::OperatingPoint operating_point;
  ForceModel force_model = ForceModel::quasi_static;
  twin::SimulationOptions simulation;   ///< for ForceModel::dynamic
  int profile_points = 101;             ///< root → tip samples per flank (also the GTE tables)
  double initial_step_cycles = 100;
  double max_step_cycles = 1e5;
  double min_step_cycles = 1;
  double force_tolerance = 0.05;        ///< max |ΔF| on the pass per step, as a fraction of T/r_b1
  double depth_limit_m = 0.5e-3;        ///< the loop stops when a flank is worn this deep
  /// Throws TwinParameterError naming the first bad value.
  void validate() const;
};

/// The worn profiles as the twin's profile deviation (material removed, root → tip), for the GTE.
twin::ToothProfileDeviation to_profile_deviation(const WearState& state);

/// The state's mean depths, the pinion's share and its pitting density (WearSummary).
WearSummary summarise(const WearState& state);

/// The share of the face width that carries the load, B / B_initial = 1 − D (the thesis's Eq. 7.12,
/// §7.3.2, p. 152) with D the tooth's pitting density (the mean over the profile), at least 0.05.
/// The same factor for every profile point, for the pitting rates and the Archard pressure alike.
double pitted_width_factor(const WearState& state);

/// Combined depth along the line of action, indexed by the pinion's profile fraction (root → tip):
/// pinion depth at u plus the gear depth of the flank point it touches (gear fraction 1 − u).
std::vector<double> combined_profile(const WearState& state);

struct StepReport {
  double step_cycles = 0;
  double force_change = 0;              ///< max |ΔF| / (T/r_b1) over the pass
  int rejected = 0;                     ///< halvings before the step was accepted
};

class BlueLoop {
 public:
  /// An unworn pair. Throws TwinParameterError on bad parameters or options.
  BlueLoop(twin::GearboxParameters params, WearLoopOptions options);

  const WearState& state() const { return state_; }
  const PassLoad& current_load() const { return load_; }
  const twin::GearGeometry& geometry() const { return geometry_; }
  /// Steps taken, rejected trials and force evaluations so far.
  int steps() const { return steps_; }
  int rejections() const { return rejections_; }
  int force_evaluations() const { return force_evaluations_; }

  /// New wear coefficients from now on (the purple loop's updates, Eqs. 7.13–7.17); validated.
  void set_coefficients(double k_wear_si, double k_pitting);
  /// A new operating point from now on (the daemon follows the measured speed and torque); the
  /// pass force is recomputed. Validated like the options.
  void set_operating_point(const twin::OperatingPoint& op);
  /// Continues from a stored state (a restart, or a re-run from an earlier state): the state, the
  /// step the controller would try next, and the force of that state. The profile tables must
  /// have `profile_points` entries; throws TwinParameterError otherwise.
  void restore(const WearState& state, double next_step_cycles);
  /// The Lundberg–Palmgren exponent rate A = K τ0^c V / z0^h (ln(1/S) = A N^m) per pinion profile
  /// point, at the current force and the tooth's pitted width (Eq. 7.12), for a given K_pitting.
  std::vector<double> pitting_rates(double k_pitting) const;
  /// The step the controller tries next (part of what restore() needs to continue exactly).
  double next_step_cycles() const { return next_step_; }
  const WearLoopOptions& options() const { return options_; }

  /// One adaptive step, not past `until_cycles`.
  StepReport step(double until_cycles);
  /// Steps until `cycles` or until a flank reaches depth_limit_m. Returns false in the latter case
  /// (state() then holds the last state inside the limit).
  bool run_until(double cycles);

 private:
  PassLoad load_for(const WearState& s);
  std::vector<double> pass_positions() const;
  twin::GearboxParameters params_;
  WearLoopOptions options_;
  twin::GearGeometry geometry_;
  twin::GearMeshStiffness mesh_;
  WearState state_;
  PassLoad load_;
  double next_step_;
  int steps_ = 0, rejections_ = 0, force_evaluations_ = 0;
};

}  // namespace gearwatch::wear
