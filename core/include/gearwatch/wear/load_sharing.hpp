#pragma once
// The load one tooth pair carries over its pass, for the wear models: either quasi-static (load
// sharing between the pairs in contact from the mesh stiffness and the worn-profile GTE), or the
// dynamic contact force of the 21-DOF twin.
#include "gearwatch/twin/gearbox_parameters.hpp"
#include "gearwatch/twin/mesh_stiffness.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "gearwatch/twin/transmission_error.hpp"
#include "gearwatch/wear/archard_wear.hpp"

namespace gearwatch::wear {

/// Static force sharing among pairs: F_i = k_i (δ + e_i) for pairs with δ + e_i > 0, else 0, with
/// Σ F_i = F. `stiffness` and `gap_error` (the GTE e_i, ≤ 0 where material is missing) have `count`
/// entries; the result goes to `forces`. Returns δ (m). All pairs out of contact cannot carry F:
/// then the pair with the largest e_i takes it all.
double share_load(double total_force_n, const double* stiffness, const double* gap_error, int count, double* forces);

/// Quasi-static pass: the tracked pair at `points` positions over the active line, with the other
/// pairs at s ± p_b, under the static mesh force T_in / r_b1.
PassLoad quasi_static_pass_load(const twin::GearMeshStiffness& mesh, const twin::GeometricTransmissionError& gte,
                                double input_torque_nm, int points = 1025);

/// Dynamic pass: the twin's ContactForceProfile (first full pass after settling) at `op`.
/// Throws what twin::simulate throws.
PassLoad dynamic_pass_load(const twin::GearboxParameters& p, const twin::ToothProfileDeviation& deviation,
                           const twin::OperatingPoint& op, const twin::SimulationOptions& options = {});

}  // namespace gearwatch::wear
