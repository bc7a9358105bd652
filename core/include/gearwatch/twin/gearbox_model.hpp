#pragma once
// The 21-DOF lumped model of the rig (thesis Eqs. 5.1–5.7): assembled matrices, the linearised
// (mean mesh stiffness) system, and the time-varying equations of motion as an odeint system.
#include <array>
#include <complex>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "gearwatch/twin/gearbox_parameters.hpp"
#include "gearwatch/twin/gear_geometry.hpp"
#include "gearwatch/twin/mesh_stiffness.hpp"
#include "gearwatch/twin/transmission_error.hpp"

namespace gearwatch::twin {

inline constexpr int kDofCount = 21;
using Vector21 = Eigen::Matrix<double, kDofCount, 1>;
using Matrix21 = Eigen::Matrix<double, kDofCount, kDofCount>;

/// Indices into x of Eq. 5.2.
enum Dof : int {
  theta1 = 0, theta2, theta3, theta5, theta7, theta8, theta10, theta12, theta13,
  y4, y5, y6, y9, y10, y11,
  x4, x5, x6, x9, x10, x11
};
const char* dof_name(int dof);

/// A spring between two DOFs (b = -1: to ground), with the name of its parameter.
struct SpringElement {
  std::string name;
  int a = 0;
  int b = -1;
  double stiffness = 0;
};

/// Structural springs of Eqs. 5.6–5.7 (the mesh is separate).
std::vector<SpringElement> spring_elements(const GearboxParameters& p);

/// δ = gᵀx (Eq. 5.3 without the GTE): the mesh's direction in DOF space. The mesh force enters the
/// equations as −g F (Eq. 5.5), so the mesh adds k_m g gᵀ to the stiffness.
Vector21 mesh_direction(const GearGeometry& geometry);

/// The assembled linear parts. Structural damping is modal: C = M Φ diag(2 ζ ω) Φᵀ M over the modes
/// of the structure without the mesh (its two rigid-body modes get none), so damping never acts on
/// the nominal rotation. The mesh adds k_m(t) g gᵀ and c_m(t) g gᵀ.
struct GearboxMatrices {
  Vector21 mass;                 ///< diagonal of M
  Matrix21 stiffness;            ///< structural K (no mesh)
  Matrix21 damping;              ///< structural C (no mesh)
  Vector21 mesh;                 ///< g
  double mean_mesh_stiffness = 0;
  double mesh_damping_time_constant = 0;  ///< μ of Eq. 5.13
  /// K + k̄ g gᵀ: the linearised stiffness used for modal analysis and static equilibrium.
  Matrix21 linearised_stiffness() const { return stiffness + mean_mesh_stiffness * mesh * mesh.transpose(); }
};

/// Builds M, K, C, g (validates the parameters; throws TwinParameterError).
GearboxMatrices assemble(const GearboxParameters& p, const GearMeshStiffness& mesh_stiffness);
GearboxMatrices assemble(const GearboxParameters& p);

/// The linearised model's steady response to a transmission error of one metre at the mesh, as
/// e^{i2πft}: the complex amplitude of every DOF. An error e enters each pair's force as k(δ + e)
/// (GearboxDynamics), so the response solves (K + k̄ggᵀ − ω²M + iω(C + μk̄ggᵀ)) q = −(k̄ + iωμk̄) g;
/// the loaded deflection then changes by gᵀq + 1 per metre. A run-out of either shaft along the line
/// of action is such an error at that shaft's frequency. Throws TwinParameterError for a frequency
/// that is not positive and finite.
Eigen::Matrix<std::complex<double>, kDofCount, 1> transmission_error_response(const GearboxMatrices& m, double frequency_hz);

/// State of the integrator: [q; q̇], q = x minus the nominal rigid rotation at constant speed.
using State = std::array<double, 2 * kDofCount>;

/// An external harmonic load f sin(2π f_hz t) (used for FRF checks and excitation studies).
struct HarmonicLoad {
  Vector21 amplitude = Vector21::Zero();
  double frequency_hz = 0;
};

/// Run-out of eccentric shafts along the line of action (an addition the thesis's twin does not have):
/// the pinion's (input) and the gear's (output) shaft, each an amplitude (m) and the angle of its
/// eccentricity at zero shaft angle (rad). Both zero: concentric.
struct ShaftRunOut {
  double pinion_m = 0, pinion_phase_rad = 0;
  double gear_m = 0, gear_phase_rad = 0;
  bool any() const noexcept { return pinion_m != 0 || gear_m != 0; }
};

/// Mesh model used by the equations of motion.
enum class MeshModel {
  time_varying,       ///< per-pair stiffness from the potential-energy table, contact loss allowed
  constant_mean,      ///< k̄ always, no contact loss (the linearised system; used for checks)
};

/// The equations of motion M q̈ + C q̇ + K q = f − g F_mesh as an odeint system(x, dxdt, t).
/// Coordinates are deviations from the nominal rotation θ_in = Ω t, θ_out = Ω t r_b1/r_b2, so the
/// state stays small and bounded; the mesh phase follows the actual pinion angle Ω t + q5.
/// Mesh force per pair in contact (Eqs. 5.3–5.4 applied per pair):
///   F_i = k_i (δ + e_i) + μ k_i (δ̇ + ė_i) while δ + e_i > 0, else 0 (contact loss).
class GearboxDynamics {
 public:
  GearboxDynamics(const GearboxMatrices& matrices, std::shared_ptr<const GearMeshStiffness> mesh_stiffness,
                  std::shared_ptr<const GeometricTransmissionError> gte, double input_speed_hz,
                  double input_torque_nm, MeshModel model = MeshModel::time_varying);

  void operator()(const State& x, State& dxdt, double t) const;
  /// One row of operator()'s accelerations: d²q[dof]/dt² at (x, t) without the other 20 (a
  /// record's sensor read many times per sample needs only its own DOF).
  double acceleration(const State& x, double t, int dof) const;
  /// The same row with the mesh force already known (MeshState::force at the same x and t), so a
  /// caller that needs both evaluates the mesh once.
  double acceleration(const State& x, double t, int dof, double mesh_force) const;

  /// Mesh quantities at (x, t).
  struct MeshState {
    double phase = 0;                ///< mesh phase ∈ [0,1)
    long long cycle = 0;             ///< mesh cycles since t = 0
    int pairs = 0;
    double positions[3] = {0, 0, 0};
    double pair_force[3] = {0, 0, 0};
    double stiffness = 0;            ///< Σ k_i of the pairs in contact
    double force = 0;                ///< total dynamic mesh force (N)
    double deflection = 0;           ///< δ = gᵀq (m): the dynamic transmission error
    double gte = 0;                  ///< kinematic GTE of the pairs in contact
  };
  MeshState mesh_state(const State& x, double t) const;

  /// Static equilibrium of the linearised system under the operating torque (q5 = 0 fixes the
  /// rigid-body rotation, so the pinion's mesh phase starts at exactly 0). Returns a state with zero velocities.
  State static_equilibrium() const;

  /// Total mechanical energy for the constant-mesh, undamped, unforced case (checks).
  double linear_energy(const State& x) const;

  void set_harmonic_load(const HarmonicLoad& load) { harmonic_ = load; }
  /// Face misalignment as an addition to the twin (a candidate effect of the gap diagnosis): the
  /// flanks of a pair separate linearly across the face by `separation_m` (angle × face width), so
  /// a pair compressed by c < separation carries only the part of the face where it touches.
  /// Throws TwinParameterError for a negative or non-finite value; 0 (the default) is aligned.
  void set_face_misalignment(double separation_m);
  /// Eccentric shafts as an addition to the twin (the gap diagnosis's eccentricity candidate): every
  /// pair's compression gains −(e_p sin(θ_p + φ_p) + e_g sin(θ_g + φ_g)), θ the shaft's angle (its
  /// nominal turn and its torsional DOF at the gear). Throws TwinParameterError for a negative or
  /// non-finite run-out or a non-finite phase.
  void set_shaft_run_out(const ShaftRunOut& run_out);
  const GearboxMatrices& matrices() const { return m_; }
  double input_speed_hz() const { return speed_hz_; }
  double mesh_frequency_hz() const;
  double brake_torque_nm() const { return brake_torque_; }

 private:
  double mesh_force(const Eigen::Ref<const Vector21>& q, const Eigen::Ref<const Vector21>& v, double t,
                    MeshState* out) const;
  GearboxMatrices m_;
  Vector21 inverse_mass_;
  /// The structural [K C] as its non-zero entries, row by row, each against the state [q v]. The
  /// shaft chains couple only neighbouring DOFs, and the modal C couples only DOFs of one
  /// substructure (the structure without the mesh falls apart into uncoupled parts), so both have
  /// few non-zeros; their dense products were the largest part of a simulation's time. Every entry
  /// that is not exactly 0 is kept, so the product is the dense one whatever the pattern.
  class StructuralRows {
   public:
    StructuralRows() = default;
    StructuralRows(const Matrix21& stiffness, const Matrix21& damping);
    /// acc − Σ_j [K C](row, j) x[j], summed in a register: subtracting each term from the load
    /// vector in memory made every term wait for the previous one's store.
    double subtract_row_product(int row, const State& x, double acc) const {
      const auto r = static_cast<std::size_t>(row);
      for (std::size_t i = row_start_[r]; i < row_start_[r + 1]; ++i) acc -= entries_[i].value * x[entries_[i].state_index];
      return acc;
    }

   private:
    struct Entry {
      std::size_t state_index;  // a column of K (q) or kDofCount + a column of C (v); the row is where it lies
      double value;
    };
    std::vector<Entry> entries_;                   // row by row
    std::array<std::size_t, kDofCount + 1> row_start_{};  // entries_[row_start_[r] .. row_start_[r + 1]) are row r's
  };
  StructuralRows structural_;
  /// The same products by parts: the structure without the mesh falls apart into uncoupled parts
  /// that are contiguous in the DOF order (the input chain θ1–θ7, the output chain θ8–θ13, and the
  /// y and x bearing–shaft chains of each shaft), so [K C] is block diagonal. Each part's block is
  /// stored column by column, padded to an even number of rows, so that one column's product is
  /// two rows at a time. Every row sums the same terms in the same order as StructuralRows (the
  /// zeros a block adds change nothing), so operator() and acceleration() agree to the last bit.
  /// Used only when every entry outside the parts is exactly 0.
  class StructuralBlocks {
   public:
    static constexpr int kParts = 6;
    static constexpr std::array<int, kParts + 1> kPartStart = {theta1, theta8, y4, y9, x4, x9, kDofCount};
    static constexpr int kPaddedRows = 6;  // the largest part (5 DOFs), even
    StructuralBlocks() = default;
    /// Empty (fits() false) when some entry couples two parts.
    StructuralBlocks(const Matrix21& stiffness, const Matrix21& damping);
    bool fits() const { return fits_; }
    /// load[r] − Σ_j [K C](r, j) x[j] for every row, in StructuralRows' order.
    void subtract_products(const State& x, Vector21& load) const;

   private:
    // columns_[offset_[p] + c][r]: part p's column c (its q columns, then its v columns), row r.
    std::vector<std::array<double, kPaddedRows>> columns_;
    std::array<std::size_t, kParts + 1> offset_{};
    bool fits_ = false;
  };
  StructuralBlocks blocks_;
  std::shared_ptr<const GearMeshStiffness> mesh_stiffness_;
  double face_separation_ = 0;  // m: flank separation across the face (0 = aligned)
  ShaftRunOut run_out_;
  double gear_turn_per_pinion_turn_ = 0;  // z1 / z2, the gear's nominal turn per the pinion's
  std::shared_ptr<const GeometricTransmissionError> gte_;
  double speed_hz_;
  double omega_;
  double input_torque_;
  double brake_torque_;
  MeshModel model_;
  HarmonicLoad harmonic_;
  Vector21 external_;
  double base_pitch_angle_;          ///< pinion rotation per mesh period 2π/z1
};

}  // namespace gearwatch::twin
