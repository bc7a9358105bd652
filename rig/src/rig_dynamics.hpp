#pragma once
// The rig's equations of motion: the 21 DOF of the thesis's model (core's matrices, mesh stiffness
// and GTE) with the truth effects inside, plus four casing modal DOF (two modes, vertical and
// horizontal) driven by the bearing forces. Internal to the rig library.
#include <memory>

#include <Eigen/Dense>

#include "gearwatch/rig/effects.hpp"
#include "gearwatch/twin/gearbox_model.hpp"
#include "gearwatch/twin/mesh_stiffness.hpp"
#include "gearwatch/twin/transmission_error.hpp"

namespace gearwatch::rig::detail {

inline constexpr int kCasingDof = 4;                      // y mode 1, y mode 2, x mode 1, x mode 2
inline constexpr int kRigDof = twin::kDofCount + kCasingDof;
inline constexpr int kRigStates = 2 * kRigDof;
using RigState = Eigen::Matrix<double, kRigStates, 1>;

/// Quantities at one instant, for the outputs.
struct RigOutputs {
  double casing_y = 0, casing_x = 0;        ///< casing modes' acceleration (m/s²)
  double y6_acc = 0, x6_acc = 0;            ///< ÿ6, ẍ6
  double mesh_force = 0, deflection = 0;
  double bearing_force_y = 0;
  double mesh_cycles = 0;
  double sliding_factor = 0;                ///< Σ over pairs in contact of |s − s_pitch| / p_b
  double input_angle = 0;                   ///< encoder angle Θ + q7
};

/// A stretch of the mesh cycle in which the same tooth pairs are in contact: mesh cycle `cycle`,
/// phase in [lo, hi). The integrator freezes it over a step so no stage sees a stiffness step.
struct MeshSegment {
  long long cycle = 0;
  double lo = 0, hi = 1;
};

class RigDynamics {
 public:
  RigDynamics(const twin::GearboxParameters& params, const EffectSet& effects,
              const twin::ToothProfileDeviation& deviation, double speed_hz, double torque_nm);

  /// dy/dt at (t, y); fills `out` when given. With a segment, the pairs in contact are those of
  /// the segment (the phase is held inside it).
  void derivative(double t, const RigState& y, RigState& dy, RigOutputs* out, const MeshSegment* segment = nullptr) const;
  /// The segment the state is in, and the one after it.
  MeshSegment locate(double t, const RigState& y) const;
  MeshSegment next(const MeshSegment& s) const;
  RigState initial_state() const { return initial_; }

  /// Mesh cycles (pinion angle / base-pitch angle) and their rate at (t, y).
  double mesh_cycles(double t, const RigState& y) const;
  double mesh_cycle_rate(double t, const RigState& y) const;
  /// Mesh phases at which the stiffness steps (a pair enters or leaves).
  double exit_phase() const { return exit_phase_; }
  double deflection(const RigState& y) const;

 private:
  struct Nominal {
    double angle, speed, acceleration;  // input side, rad, rad/s, rad/s²
  };
  Nominal nominal(double t) const;
  double pair_force(double k, double compression, double compression_rate) const;
  // The steps of derivative().
  struct MeshPosition {
    double cycles = 0;   // pinion angle / base-pitch angle
    long long cycle = 0;
    double phase = 0;    // within the cycle, held inside the segment when one is given
  };
  struct MeshContact {
    double delta = 0, cycles = 0, force = 0, sliding = 0;
  };
  struct CasingResponse {
    double acc[kCasingDof] = {0, 0, 0, 0};
    double bearing_y = 0, bearing_x = 0;
  };
  MeshPosition mesh_position(double pinion_angle, const MeshSegment* segment) const;
  void shaft_run_out(const RigState& y, const Nominal& nom, double pinion_angle, double& e, double& e_rate) const;
  MeshContact mesh_contact(const RigState& y, const Nominal& nom, const MeshSegment* segment) const;
  twin::Vector21 structural_load(double t, const RigState& y, const Nominal& nom, double mesh_force) const;
  CasingResponse casing_response(const RigState& y, RigState& dy) const;
  RigState static_state();
  RigState initial_;

  twin::GearboxMatrices m_;
  std::shared_ptr<const twin::GearMeshStiffness> mesh_;
  std::shared_ptr<const twin::GeometricTransmissionError> gte_;
  Eigen::Matrix<double, twin::kDofCount, 2 * twin::kDofCount> linear_;  // −M⁻¹[K C]
  twin::Vector21 inverse_mass_, external_, fictitious_;  // fictitious: I_i ρ_i (× −Θ̈)
  double omega_ = 0, ratio_ = 0, pitch_angle_ = 0, base_pitch_ = 0, s_pitch_ = 0, exit_phase_ = 0;
  double mu_ = 0;
  int z1_ = 19, z2_ = 52;
  double j_equivalent_ = 0, brake_torque_ = 0;
  // Effects (zero when off).
  double speed_depth_ = 0, speed_omega_ = 0, speed_phase_ = 0;
  double load_depth_ = 0, load_omega_ = 0, loop_kp_ = 0, loop_ki_ = 0, q1_static_ = 0;
  double ecc_pinion_ = 0, ecc_pinion_phase_ = 0, ecc_gear_ = 0, ecc_gear_phase_ = 0;
  double misalignment_width_ = 0;   // β b (m)
  double backlash_ = -1;            // clearance (m), < 0 = no back-flank contact
  bool casing_ = false;
  double casing_omega_[2] = {0, 0}, casing_zeta_ = 0, casing_mass_ = 1;
  double ky_[4] = {0, 0, 0, 0}, kx_[4] = {0, 0, 0, 0};
};

}  // namespace gearwatch::rig::detail
