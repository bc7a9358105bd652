#include "gearwatch/twin/gearbox_model.hpp"

#include <cmath>
#include <numbers>

#include <Eigen/Eigenvalues>

#include "gearwatch/twin/errors.hpp"

namespace gearwatch::twin {

const char* dof_name(int dof) {
  static const char* names[kDofCount] = {"theta1", "theta2", "theta3", "theta5", "theta7", "theta8", "theta10",
                                         "theta12", "theta13", "y4", "y5", "y6", "y9", "y10", "y11",
                                         "x4", "x5", "x6", "x9", "x10", "x11"};
  return dof >= 0 && dof < kDofCount ? names[dof] : "?";
}

std::vector<SpringElement> spring_elements(const GearboxParameters& p) {
  return {
      {"kt12", theta1, theta2, p.kt12},       {"kt23", theta2, theta3, p.kt23},
      {"kt35", theta3, theta5, p.kt35},       {"kt57", theta5, theta7, p.kt57},
      {"kt810", theta8, theta10, p.kt810},    {"kt10_12", theta10, theta12, p.kt10_12},
      {"kt12_13", theta12, theta13, p.kt12_13},
      {"ky4", y4, -1, p.ky4},                 {"ky45", y4, y5, p.ky45},
      {"ky56", y5, y6, p.ky56},               {"ky6", y6, -1, p.ky6},
      {"ky9", y9, -1, p.ky9},                 {"ky910", y9, y10, p.ky910},
      {"ky10_11", y10, y11, p.ky10_11},       {"ky11", y11, -1, p.ky11},
      {"kx4", x4, -1, p.kx4},                 {"kx45", x4, x5, p.kx45},
      {"kx56", x5, x6, p.kx56},               {"kx6", x6, -1, p.kx6},
      {"kx9", x9, -1, p.kx9},                 {"kx910", x9, x10, p.kx910},
      {"kx10_11", x10, x11, p.kx10_11},       {"kx11", x11, -1, p.kx11},
  };
}

Vector21 mesh_direction(const GearGeometry& g) {
  const double c = std::cos(g.pressure_angle_rad), s = std::sin(g.pressure_angle_rad);
  Vector21 v = Vector21::Zero();
  v[theta5] = g.base_radius_pinion;
  v[theta10] = -g.base_radius_gear;
  v[y5] = -c;
  v[y10] = c;
  v[x5] = s;
  v[x10] = -s;
  return v;
}

GearboxMatrices assemble(const GearboxParameters& p, const GearMeshStiffness& mesh_stiffness) {
  p.validate();
  GearboxMatrices m;
  m.mass << p.I1, p.I2, p.I3, p.I5, p.I7, p.I8, p.I10, p.I12, p.I13, p.m4, p.m5, p.m6, p.m9, p.m10, p.m11, p.m4,
      p.m5, p.m6, p.m9, p.m10, p.m11;
  m.stiffness.setZero();
  for (const auto& e : spring_elements(p)) {
    m.stiffness(e.a, e.a) += e.stiffness;
    if (e.b >= 0) {
      m.stiffness(e.b, e.b) += e.stiffness;
      m.stiffness(e.a, e.b) -= e.stiffness;
      m.stiffness(e.b, e.a) -= e.stiffness;
    }
  }
  m.mesh = mesh_direction(mesh_stiffness.geometry());
  m.mean_mesh_stiffness = mesh_stiffness.mean_stiffness();
  m.mesh_damping_time_constant =
      mesh_damping_time_constant(p.mesh_damping_ratio, m.mean_mesh_stiffness, p.m5, p.m10);

  // Modal structural damping over the modes of the structure without the mesh.
  const Vector21 inv_sqrt_mass = m.mass.cwiseSqrt().cwiseInverse();
  const Matrix21 a = inv_sqrt_mass.asDiagonal() * m.stiffness * inv_sqrt_mass.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Matrix21> eig(a);
  if (eig.info() != Eigen::Success) throw TwinParameterError("structural eigenproblem failed");
  const Matrix21 shapes = inv_sqrt_mass.asDiagonal() * eig.eigenvectors();  // mass-normalised
  Vector21 modal = Vector21::Zero();
  const double omega_floor = 1e-6 * std::sqrt(std::max(eig.eigenvalues().maxCoeff(), 1.0));
  for (int i = 0; i < kDofCount; ++i) {
    const double omega = std::sqrt(std::max(eig.eigenvalues()[i], 0.0));
    modal[i] = omega > omega_floor ? 2.0 * p.structural_damping_ratio * omega : 0.0;  // rigid modes: none
  }
  const Matrix21 mphi = m.mass.asDiagonal() * shapes;
  m.damping = mphi * modal.asDiagonal() * mphi.transpose();
  return m;
}

GearboxMatrices assemble(const GearboxParameters& p) {
  p.validate();
  const GearGeometry geometry = GearGeometry::from_spec(p.gears);
  MeshStiffnessOptions options;
  options.scale = p.mesh_stiffness_scale;
  options.engagement_ramp_fraction = p.engagement_ramp_fraction;
  GearMeshStiffness mesh(geometry, options);
  return assemble(p, mesh);
}

Eigen::Matrix<std::complex<double>, kDofCount, 1> transmission_error_response(const GearboxMatrices& m, double frequency_hz) {
  if (!std::isfinite(frequency_hz) || frequency_hz <= 0)
    throw TwinParameterError("transmission error response: the frequency must be positive and finite");
  using Complex = std::complex<double>;
  const double omega = 2.0 * std::numbers::pi * frequency_hz;
  const Complex mesh(m.mean_mesh_stiffness, omega * m.mesh_damping_time_constant * m.mean_mesh_stiffness);
  const Matrix21 ggt = m.mesh * m.mesh.transpose();
  Eigen::Matrix<Complex, kDofCount, kDofCount> dynamic = (m.stiffness - omega * omega * Matrix21(m.mass.asDiagonal())).cast<Complex>();
  dynamic += Complex(0, omega) * m.damping.cast<Complex>() + mesh * ggt.cast<Complex>();
  const Eigen::Matrix<Complex, kDofCount, 1> load = -mesh * m.mesh.cast<Complex>();
  return dynamic.partialPivLu().solve(load);
}

GearboxDynamics::GearboxDynamics(const GearboxMatrices& matrices, std::shared_ptr<const GearMeshStiffness> mesh_stiffness,
                                 std::shared_ptr<const GeometricTransmissionError> gte, double input_speed_hz,
                                 double input_torque_nm, MeshModel model)
    : m_(matrices), mesh_stiffness_(std::move(mesh_stiffness)), gte_(std::move(gte)), speed_hz_(input_speed_hz),
      input_torque_(input_torque_nm), model_(model) {
  if (!mesh_stiffness_) throw TwinParameterError("gearbox dynamics needs a mesh stiffness");
  if (!std::isfinite(input_speed_hz) || input_speed_hz < 0)
    throw TwinParameterError("input speed must be finite and non-negative");
  if (!std::isfinite(input_torque_nm) || input_torque_nm < 0)
    throw TwinParameterError("input torque must be finite and non-negative");
  if ((m_.mass.array() <= 0).any() || !m_.mass.allFinite()) throw TwinParameterError("masses must be positive");
  inverse_mass_ = m_.mass.cwiseInverse();
  structural_ = StructuralRows(m_.stiffness, m_.damping);
  blocks_ = StructuralBlocks(m_.stiffness, m_.damping);
  const GearGeometry& g = mesh_stiffness_->geometry();
  omega_ = 2.0 * std::numbers::pi * input_speed_hz;
  // Balanced torques: the brake holds T r_b2 / r_b1 so the nominal speed is steady (a rigid-body
  // mode of the free–free chain must not be driven).
  brake_torque_ = input_torque_nm * g.base_radius_gear / g.base_radius_pinion;
  external_ = Vector21::Zero();
  external_[theta1] = input_torque_nm;
  external_[theta13] = -brake_torque_;
  base_pitch_angle_ = 2.0 * std::numbers::pi / g.spec.pinion_teeth;
  gear_turn_per_pinion_turn_ = static_cast<double>(g.spec.pinion_teeth) / g.spec.gear_teeth;
}

GearboxDynamics::StructuralRows::StructuralRows(const Matrix21& stiffness, const Matrix21& damping) {
  for (std::size_t r = 0; r < kDofCount; ++r) {
    row_start_[r] = entries_.size();
    for (std::size_t c = 0; c < kDofCount; ++c)
      if (stiffness(r, c) != 0.0) entries_.push_back({c, stiffness(r, c)});
    for (std::size_t c = 0; c < kDofCount; ++c)
      if (damping(r, c) != 0.0) entries_.push_back({kDofCount + c, damping(r, c)});
  }
  row_start_[kDofCount] = entries_.size();
}

GearboxDynamics::StructuralBlocks::StructuralBlocks(const Matrix21& stiffness, const Matrix21& damping) {
  auto part_of = [](int dof) {
    int p = 0;
    while (dof >= kPartStart[static_cast<std::size_t>(p + 1)]) ++p;
    return p;
  };
  for (int r = 0; r < kDofCount; ++r)
    for (int c = 0; c < kDofCount; ++c)
      if (part_of(r) != part_of(c) && (stiffness(r, c) != 0.0 || damping(r, c) != 0.0)) return;
  for (std::size_t p = 0; p < kParts; ++p) {
    offset_[p] = columns_.size();
    const int start = kPartStart[p], size = kPartStart[p + 1] - start;
    for (const Matrix21* matrix : {&stiffness, &damping})
      for (int c = start; c < start + size; ++c) {
        std::array<double, kPaddedRows> column{};
        for (int r = start; r < start + size; ++r) column[static_cast<std::size_t>(r - start)] = (*matrix)(r, c);
        columns_.push_back(column);
      }
  }
  offset_[kParts] = columns_.size();
  fits_ = true;
}

namespace {

// One part's rows: acc[r] −= Σ_c column_c[r] x_c over the part's q columns, then its v columns.
template <int Rows>
void subtract_part(const std::array<double, 6>* columns, int size, const double* q, const double* v, double* load) {
  double acc[Rows];
  for (int r = 0; r < Rows; ++r) acc[r] = load[r];
  for (int c = 0; c < size; ++c)
    for (int r = 0; r < Rows; ++r) acc[r] -= columns[c][static_cast<std::size_t>(r)] * q[c];
  for (int c = 0; c < size; ++c)
    for (int r = 0; r < Rows; ++r) acc[r] -= columns[size + c][static_cast<std::size_t>(r)] * v[c];
  for (int r = 0; r < size; ++r) load[r] = acc[r];
}

}  // namespace

void GearboxDynamics::StructuralBlocks::subtract_products(const State& x, Vector21& load) const {
  // The padded rows read past a part's end into the next part's load, and are never written back.
  std::array<double, kDofCount + kPaddedRows> padded{};
  for (int r = 0; r < kDofCount; ++r) padded[static_cast<std::size_t>(r)] = load[r];
  for (std::size_t p = 0; p < kParts; ++p) {
    const int start = kPartStart[p], size = kPartStart[p + 1] - start;
    const double* q = x.data() + start;
    const double* v = x.data() + kDofCount + start;
    double* rows = padded.data() + start;
    const std::array<double, kPaddedRows>* columns = columns_.data() + offset_[p];
    if (size > 4)
      subtract_part<6>(columns, size, q, v, rows);
    else if (size > 2)
      subtract_part<4>(columns, size, q, v, rows);
    else
      subtract_part<2>(columns, size, q, v, rows);
  }
  for (int r = 0; r < kDofCount; ++r) load[r] = padded[static_cast<std::size_t>(r)];
}

void GearboxDynamics::set_face_misalignment(double separation_m) {
  if (!std::isfinite(separation_m) || separation_m < 0)
    throw TwinParameterError("face misalignment separation must be finite and >= 0");
  face_separation_ = separation_m;
}

void GearboxDynamics::set_shaft_run_out(const ShaftRunOut& run_out) {
  for (double e : {run_out.pinion_m, run_out.gear_m})
    if (!std::isfinite(e) || e < 0) throw TwinParameterError("shaft run-out must be finite and >= 0 m");
  if (!std::isfinite(run_out.pinion_phase_rad) || !std::isfinite(run_out.gear_phase_rad))
    throw TwinParameterError("shaft run-out phases must be finite");
  run_out_ = run_out;
}

double GearboxDynamics::mesh_frequency_hz() const { return speed_hz_ * mesh_stiffness_->geometry().spec.pinion_teeth; }

double GearboxDynamics::mesh_force(const Eigen::Ref<const Vector21>& q, const Eigen::Ref<const Vector21>& v, double t,
                                   MeshState* out) const {
  const double delta = m_.mesh.dot(q);
  const double delta_rate = m_.mesh.dot(v);
  const double mu = m_.mesh_damping_time_constant;
  if (model_ == MeshModel::constant_mean) {
    const double k = m_.mean_mesh_stiffness;
    const double f = k * delta + mu * k * delta_rate;
    if (out) {
      out->stiffness = k;
      out->force = f;
      out->deflection = delta;
    }
    return f;
  }
  const double pinion_angle = omega_ * t + q[theta5];
  const double cycles = pinion_angle / base_pitch_angle_;
  const double cycle_floor = std::floor(cycles);
  const double phase = cycles - cycle_floor;
  const long long cycle = static_cast<long long>(cycle_floor);
  double positions[3];
  const int n = mesh_stiffness_->pairs_in_contact(phase, positions);
  const GearGeometry& g = mesh_stiffness_->geometry();
  const double contact_speed = g.base_radius_pinion * (omega_ + v[theta5]);  // ds/dt along the line of action
  // A run-out moves the shaft's centre along the line of action once per its turn: the same
  // transmission error for every pair in contact.
  double e_shaft = 0, e_shaft_rate = 0;
  if (run_out_.any()) {
    const double gear_angle = omega_ * gear_turn_per_pinion_turn_ * t + q[theta10];
    const double gear_speed = omega_ * gear_turn_per_pinion_turn_ + v[theta10];
    const double ap = pinion_angle + run_out_.pinion_phase_rad, ag = gear_angle + run_out_.gear_phase_rad;
    e_shaft = -(run_out_.pinion_m * std::sin(ap) + run_out_.gear_m * std::sin(ag));
    e_shaft_rate = -(run_out_.pinion_m * std::cos(ap) * (omega_ + v[theta5]) + run_out_.gear_m * std::cos(ag) * gear_speed);
  }
  double total = 0, stiffness = 0, gte_max = -1e300;
  for (int j = 0; j < n; ++j) {
    const double k = mesh_stiffness_->pair_stiffness(positions[j]);
    double e = e_shaft, e_rate = e_shaft_rate;
    if (gte_ && !gte_->is_zero()) {
      const int pinion_tooth = static_cast<int>((cycle - j) % g.spec.pinion_teeth);
      const int gear_tooth = static_cast<int>((cycle - j) % g.spec.gear_teeth);
      e += gte_->pair_error(positions[j], pinion_tooth, gear_tooth);
      e_rate += gte_->pair_error_slope(positions[j], pinion_tooth, gear_tooth) * contact_speed;
    }
    gte_max = std::max(gte_max, e);
    const double compression = delta + e;
    double f = 0;
    const double w = face_separation_;
    if (compression > 0 && compression < w) {
      // Winkler face with the flanks separating linearly across it: the loaded width is c/w of the
      // face, so F = ∫ k (c − w ξ) dξ over ξ ∈ [0, c/w] = k c² / (2w); the damping acts on that share.
      f = std::max(0.0, k * compression * compression / (2.0 * w) + mu * k * (compression / w) * (delta_rate + e_rate));
    } else if (compression > 0) {
      f = std::max(0.0, k * (compression - 0.5 * w) + mu * k * (delta_rate + e_rate));
    }
    stiffness += k;
    total += f;
    if (out) out->pair_force[j] = f;
  }
  if (out) {
    out->phase = phase;
    out->cycle = cycle;
    out->pairs = n;
    for (int j = 0; j < n; ++j) out->positions[j] = positions[j];
    out->stiffness = stiffness;
    out->force = total;
    out->deflection = delta;
    out->gte = n > 0 ? gte_max : 0.0;
  }
  return total;
}

void GearboxDynamics::operator()(const State& x, State& dxdt, double t) const {
  const Eigen::Map<const Vector21> q(x.data());
  const Eigen::Map<const Vector21> v(x.data() + kDofCount);
  const double f = mesh_force(q, v, t, nullptr);
  Vector21 load;
  if (blocks_.fits()) {
    for (int r = 0; r < kDofCount; ++r) load[r] = external_[r] - m_.mesh[r] * f;
    blocks_.subtract_products(x, load);
  } else {
    for (int r = 0; r < kDofCount; ++r) load[r] = structural_.subtract_row_product(r, x, external_[r] - m_.mesh[r] * f);
  }
  if (harmonic_.frequency_hz > 0) load += harmonic_.amplitude * std::sin(2.0 * std::numbers::pi * harmonic_.frequency_hz * t);
  Eigen::Map<Vector21>(dxdt.data()) = v;
  Eigen::Map<Vector21>(dxdt.data() + kDofCount) = inverse_mass_.cwiseProduct(load);
}

double GearboxDynamics::acceleration(const State& x, double t, int dof) const {
  const Eigen::Map<const Vector21> q(x.data());
  const Eigen::Map<const Vector21> v(x.data() + kDofCount);
  return acceleration(x, t, dof, mesh_force(q, v, t, nullptr));
}

double GearboxDynamics::acceleration(const State& x, double t, int dof, double f) const {
  double load = structural_.subtract_row_product(dof, x, external_[dof] - m_.mesh[dof] * f);
  if (harmonic_.frequency_hz > 0) load += harmonic_.amplitude[dof] * std::sin(2.0 * std::numbers::pi * harmonic_.frequency_hz * t);
  return inverse_mass_[dof] * load;
}

GearboxDynamics::MeshState GearboxDynamics::mesh_state(const State& x, double t) const {
  MeshState s;
  mesh_force(Eigen::Map<const Vector21>(x.data()), Eigen::Map<const Vector21>(x.data() + kDofCount), t, &s);
  return s;
}

State GearboxDynamics::static_equilibrium() const {
  const Matrix21 k = m_.linearised_stiffness();
  // Fix q5 = 0 (the rigid-body rotation) so that the mesh phase of the static state is exactly
  // Ω t; the loads are balanced so the reduced system is consistent.
  constexpr int n = kDofCount - 1;
  Eigen::Matrix<double, n, n> reduced;
  Eigen::Matrix<double, n, 1> rhs;
  auto full = [](int i) { return i < theta5 ? i : i + 1; };
  for (int i = 0; i < n; ++i) {
    rhs[i] = external_[full(i)];
    for (int j = 0; j < n; ++j) reduced(i, j) = k(full(i), full(j));
  }
  const Eigen::Matrix<double, n, 1> sol = reduced.ldlt().solve(rhs);
  State s{};
  for (int i = 0; i < n; ++i) s[static_cast<std::size_t>(full(i))] = sol[i];
  return s;
}

double GearboxDynamics::linear_energy(const State& x) const {
  const Eigen::Map<const Vector21> q(x.data());
  const Eigen::Map<const Vector21> v(x.data() + kDofCount);
  return 0.5 * v.dot(m_.mass.cwiseProduct(v)) + 0.5 * q.dot(m_.linearised_stiffness() * q);
}

}  // namespace gearwatch::twin
