#include "rig_dynamics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "gearwatch/twin/errors.hpp"

namespace gearwatch::rig::detail {
namespace {
using twin::Dof;
constexpr int kInputTorsional[] = {twin::theta1, twin::theta2, twin::theta3, twin::theta5, twin::theta7};
constexpr int kOutputTorsional[] = {twin::theta8, twin::theta10, twin::theta12, twin::theta13};
constexpr int kBearingY[] = {twin::y4, twin::y6, twin::y9, twin::y11};
constexpr int kBearingX[] = {twin::x4, twin::x6, twin::x9, twin::x11};
constexpr int N = twin::kDofCount;
}  // namespace

RigDynamics::RigDynamics(const twin::GearboxParameters& p, const EffectSet& fx, const twin::ToothProfileDeviation& deviation,
                         double speed_hz, double torque_nm) {
  p.validate();
  if (!(speed_hz > 0) || !std::isfinite(speed_hz)) throw RigParameterError("speed must be positive");
  // A negative torque is the load driving the motor (overrun): only back-flank contact (backlash)
  // can carry it.
  if (!std::isfinite(torque_nm)) throw RigParameterError("torque must be finite");
  const auto geometry = twin::GearGeometry::from_spec(p.gears);
  twin::MeshStiffnessOptions mo;
  mo.scale = p.mesh_stiffness_scale;
  mo.engagement_ramp_fraction = p.engagement_ramp_fraction;
  mesh_ = std::make_shared<const twin::GearMeshStiffness>(geometry, mo);
  gte_ = std::make_shared<const twin::GeometricTransmissionError>(geometry, deviation);
  m_ = twin::assemble(p, *mesh_);
  inverse_mass_ = m_.mass.cwiseInverse();
  linear_.leftCols(N) = -(inverse_mass_.asDiagonal() * m_.stiffness);
  linear_.rightCols(N) = -(inverse_mass_.asDiagonal() * m_.damping);
  mu_ = m_.mesh_damping_time_constant;
  z1_ = p.gears.pinion_teeth;
  z2_ = p.gears.gear_teeth;
  omega_ = 2.0 * std::numbers::pi * speed_hz;
  ratio_ = geometry.base_radius_pinion / geometry.base_radius_gear;
  pitch_angle_ = 2.0 * std::numbers::pi / z1_;
  base_pitch_ = geometry.base_pitch;
  s_pitch_ = geometry.base_radius_pinion * std::tan(geometry.pressure_angle_rad);
  exit_phase_ = mesh_->double_contact_share();
  brake_torque_ = torque_nm / ratio_;
  external_.setZero();
  external_[twin::theta1] = torque_nm;
  external_[twin::theta13] = -brake_torque_;
  fictitious_.setZero();
  for (int i : kInputTorsional) fictitious_[i] = m_.mass[i];
  for (int i : kOutputTorsional) fictitious_[i] = m_.mass[i] * ratio_;
  j_equivalent_ = 0;
  for (int i : kInputTorsional) j_equivalent_ += m_.mass[i];
  for (int i : kOutputTorsional) j_equivalent_ += m_.mass[i] * ratio_ * ratio_;

  using E = Effect;
  if (fx.enabled(E::speed_fluctuation)) {
    speed_depth_ = fx.get("speed_fluctuation.depth");
    speed_omega_ = 2.0 * std::numbers::pi * fx.get("speed_fluctuation.frequency_hz");
    speed_phase_ = fx.get("speed_fluctuation.phase_rad");
  }
  if (fx.enabled(E::load_fluctuation)) {
    load_depth_ = fx.get("load_fluctuation.depth");
    load_omega_ = 2.0 * std::numbers::pi * fx.get("load_fluctuation.frequency_hz");
    // The VFD's PI speed loop on the motor, tuned for a second-order closed loop on the drive's
    // total inertia: bandwidth ω_c, damping 0.7.
    const double wc = 2.0 * std::numbers::pi * fx.get("load_fluctuation.speed_loop_hz");
    loop_ki_ = j_equivalent_ * wc * wc;
    loop_kp_ = 2.0 * 0.7 * j_equivalent_ * wc;
  }
  if (fx.enabled(E::eccentricity)) {
    ecc_pinion_ = fx.get("eccentricity.pinion_um") * 1e-6;
    ecc_pinion_phase_ = fx.get("eccentricity.pinion_phase_rad");
    ecc_gear_ = fx.get("eccentricity.gear_um") * 1e-6;
    ecc_gear_phase_ = fx.get("eccentricity.gear_phase_rad");
  }
  if (fx.enabled(E::misalignment)) misalignment_width_ = fx.get("misalignment.angle_mrad") * 1e-3 * p.gears.face_width_m;
  if (fx.enabled(E::backlash)) backlash_ = fx.get("backlash.clearance_um") * 1e-6;
  if (fx.enabled(E::casing)) {
    casing_ = true;
    casing_omega_[0] = 2.0 * std::numbers::pi * fx.get("casing.mode1_hz");
    casing_omega_[1] = 2.0 * std::numbers::pi * fx.get("casing.mode2_hz");
    casing_zeta_ = fx.get("casing.damping_ratio");
    casing_mass_ = fx.get("casing.modal_mass_kg");
  }
  const double ky[] = {p.ky4, p.ky6, p.ky9, p.ky11}, kx[] = {p.kx4, p.kx6, p.kx9, p.kx11};
  for (int i = 0; i < 4; ++i) {
    ky_[i] = ky[i];
    kx_[i] = kx[i];
  }
  initial_ = static_state();
}

RigDynamics::Nominal RigDynamics::nominal(double t) const {
  if (speed_depth_ == 0) return {omega_ * t, omega_, 0.0};
  // Θ̇ = Ω (1 + m sin(ω_m t + φ)); Θ(0) = 0.
  const double a = speed_omega_ * t + speed_phase_;
  return {omega_ * t - omega_ * speed_depth_ / speed_omega_ * (std::cos(a) - std::cos(speed_phase_)),
          omega_ * (1.0 + speed_depth_ * std::sin(a)), omega_ * speed_depth_ * speed_omega_ * std::cos(a)};
}

double RigDynamics::mesh_cycles(double t, const RigState& y) const {
  return (nominal(t).angle + y[twin::theta5]) / pitch_angle_;
}

double RigDynamics::mesh_cycle_rate(double t, const RigState& y) const {
  return (nominal(t).speed + y[kRigDof + twin::theta5]) / pitch_angle_;
}

double RigDynamics::deflection(const RigState& y) const { return m_.mesh.dot(y.head<N>()); }

double RigDynamics::pair_force(double k, double c, double c_rate) const {
  if (backlash_ >= 0 && c < -backlash_) {
    // Back flanks in contact: the pair pushes back with the same stiffness (a reversed pair).
    return std::min(0.0, k * (c + backlash_) + mu_ * k * c_rate);
  }
  if (c <= 0) return 0.0;  // contact loss
  const double w = misalignment_width_;
  if (w > 0 && c < w) {
    // Flanks touch over the part of the face where the compression c − β z is positive: a
    // Winkler face gives F = k c² / (2 w), the damping acting on the loaded share c/w.
    return std::max(0.0, k * c * c / (2.0 * w) + mu_ * k * (c / w) * c_rate);
  }
  return std::max(0.0, k * (c - 0.5 * w) + mu_ * k * c_rate);
}

MeshSegment RigDynamics::locate(double t, const RigState& y) const {
  const double cycles = mesh_cycles(t, y);
  const double c = std::floor(cycles);
  const double phase = cycles - c;
  MeshSegment s;
  s.cycle = static_cast<long long>(c);
  if (phase < exit_phase_) {
    s.lo = 0;
    s.hi = exit_phase_;
  } else {
    s.lo = exit_phase_;
    s.hi = 1;
  }
  return s;
}

MeshSegment RigDynamics::next(const MeshSegment& s) const {
  if (s.hi < 1) return {s.cycle, exit_phase_, 1.0};
  return {s.cycle + 1, 0.0, exit_phase_};
}

RigDynamics::MeshPosition RigDynamics::mesh_position(double pinion_angle, const MeshSegment* segment) const {
  MeshPosition m;
  m.cycles = pinion_angle / pitch_angle_;
  if (segment) {
    m.cycle = segment->cycle;
    m.phase = std::clamp(m.cycles - static_cast<double>(m.cycle), segment->lo, segment->hi - 1e-12);
  } else {
    const double cycle_floor = std::floor(m.cycles);
    m.phase = m.cycles - cycle_floor;
    m.cycle = static_cast<long long>(cycle_floor);
  }
  return m;
}

// The run-out of eccentric shafts along the line of action, and its rate: all pairs share it.
void RigDynamics::shaft_run_out(const RigState& y, const Nominal& nom, double pinion_angle, double& e, double& e_rate) const {
  e = 0;
  e_rate = 0;
  if (ecc_pinion_ == 0 && ecc_gear_ == 0) return;
  const double pinion_speed = nom.speed + y[kRigDof + twin::theta5];
  const double gear_angle = nom.angle * ratio_ + y[twin::theta10];
  const double gear_speed = nom.speed * ratio_ + y[kRigDof + twin::theta10];
  const double ap = pinion_angle + ecc_pinion_phase_, ag = gear_angle + ecc_gear_phase_;
  e = -(ecc_pinion_ * std::sin(ap) + ecc_gear_ * std::sin(ag));
  e_rate = -(ecc_pinion_ * std::cos(ap) * pinion_speed + ecc_gear_ * std::cos(ag) * gear_speed);
}

// The mesh (Eqs. 5.3–5.4 per pair) with the GTE of the worn, erroneous, relieved teeth and the
// run-out of eccentric shafts.
RigDynamics::MeshContact RigDynamics::mesh_contact(const RigState& y, const Nominal& nom, const MeshSegment* segment) const {
  const auto q = y.head<N>();
  const auto v = y.segment<N>(kRigDof);
  MeshContact mc;
  mc.delta = m_.mesh.dot(q);
  const double delta_rate = m_.mesh.dot(v);
  const double pinion_angle = nom.angle + q[twin::theta5];
  const MeshPosition pos = mesh_position(pinion_angle, segment);
  mc.cycles = pos.cycles;
  double e_shaft, e_shaft_rate;
  shaft_run_out(y, nom, pinion_angle, e_shaft, e_shaft_rate);
  double positions[3];
  const int pairs = mesh_->pairs_in_contact(pos.phase, positions);
  const double contact_speed = mesh_->geometry().base_radius_pinion * (nom.speed + v[twin::theta5]);
  for (int j = 0; j < pairs; ++j) {
    const double k = mesh_->pair_stiffness(positions[j]);
    double e = e_shaft, e_rate = e_shaft_rate;
    if (!gte_->is_zero()) {
      const int pt = static_cast<int>((pos.cycle - j) % z1_), gt = static_cast<int>((pos.cycle - j) % z2_);
      e += gte_->pair_error(positions[j], pt, gt);
      e_rate += gte_->pair_error_slope(positions[j], pt, gt) * contact_speed;
    }
    mc.force += pair_force(k, mc.delta + e, delta_rate + e_rate);
    mc.sliding += std::abs(positions[j] - s_pitch_);
  }
  return mc;
}

twin::Vector21 RigDynamics::structural_load(double t, const RigState& y, const Nominal& nom, double mesh_force) const {
  twin::Vector21 load = external_ - m_.mesh * mesh_force - fictitious_ * nom.acceleration;
  load[twin::theta1] += j_equivalent_ * nom.acceleration;  // the VFD drives the commanded speed ripple
  if (load_depth_ != 0) {
    load[twin::theta13] -= brake_torque_ * load_depth_ * std::sin(load_omega_ * t);
    load[twin::theta1] -= loop_kp_ * y[kRigDof + twin::theta1] + loop_ki_ * (y[twin::theta1] - q1_static_);
  }
  return load;
}

// Casing modes: η̈ + 2ζω η̇ + ω² η = F_bearings / m (one-way: the casing is heavy next to the
// bearing pedestals, its motion does not feed back).
RigDynamics::CasingResponse RigDynamics::casing_response(const RigState& y, RigState& dy) const {
  CasingResponse r;
  for (int i = 0; i < 4; ++i) {
    r.bearing_y += ky_[i] * y[kBearingY[i]];
    r.bearing_x += kx_[i] * y[kBearingX[i]];
  }
  for (int c = 0; c < kCasingDof; ++c) {
    const int s = N + c;
    if (casing_) {
      const double w = casing_omega_[c % 2];
      const double f = c < 2 ? r.bearing_y : r.bearing_x;
      r.acc[c] = f / casing_mass_ - 2.0 * casing_zeta_ * w * y[kRigDof + s] - w * w * y[s];
    }
    dy[s] = y[kRigDof + s];
    dy[kRigDof + s] = r.acc[c];
  }
  return r;
}

void RigDynamics::derivative(double t, const RigState& y, RigState& dy, RigOutputs* out, const MeshSegment* segment) const {
  const auto q = y.head<N>();
  const auto v = y.segment<N>(kRigDof);
  const Nominal nom = nominal(t);
  const MeshContact mc = mesh_contact(y, nom, segment);
  const twin::Vector21 load = structural_load(t, y, nom, mc.force);
  Eigen::Matrix<double, 2 * N, 1> qv;
  qv << q, v;
  dy.head<N>() = v;
  dy.segment<N>(kRigDof) = linear_ * qv + inverse_mass_.cwiseProduct(load);
  const CasingResponse casing = casing_response(y, dy);
  if (out) {
    out->casing_y = casing.acc[0] + casing.acc[1];
    out->casing_x = casing.acc[2] + casing.acc[3];
    out->y6_acc = dy[kRigDof + twin::y6];
    out->x6_acc = dy[kRigDof + twin::x6];
    out->mesh_force = mc.force;
    out->deflection = mc.delta;
    out->bearing_force_y = casing.bearing_y;
    out->mesh_cycles = mc.cycles;
    out->sliding_factor = mc.sliding / base_pitch_;
    out->input_angle = nom.angle + q[twin::theta7];
  }
}

RigState RigDynamics::static_state() {
  // The twin's static equilibrium (q5 = 0 fixes the rigid rotation), the casing at its static
  // deflection under the static bearing forces.
  // The equilibrium is linear in the loads: under a reversed torque it is the mirror image (the
  // twin takes only a driving torque). Backlash then has the back flanks close the gap first.
  const double torque = external_[twin::theta1];
  const twin::GearboxDynamics core(m_, mesh_, gte_, omega_ / (2.0 * std::numbers::pi), std::abs(torque));
  const twin::State s = core.static_equilibrium();
  RigState y = RigState::Zero();
  for (int i = 0; i < 2 * N; ++i) y[i < N ? i : i - N + kRigDof] = (torque < 0 ? -1.0 : 1.0) * s[static_cast<std::size_t>(i)];
  q1_static_ = y[twin::theta1];
  if (casing_) {
    double by = 0, bx = 0;
    for (int i = 0; i < 4; ++i) {
      by += ky_[i] * y[kBearingY[i]];
      bx += kx_[i] * y[kBearingX[i]];
    }
    for (int c = 0; c < kCasingDof; ++c) {
      const double w = casing_omega_[c % 2];
      y[N + c] = (c < 2 ? by : bx) / (casing_mass_ * w * w);
    }
  }
  return y;
}

}  // namespace gearwatch::rig::detail
