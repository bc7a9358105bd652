#pragma once
// Time-varying gear mesh stiffness by the potential-energy method (thesis §5.2.1, Eqs. 5.8–5.12)
// and the proportional mesh damping of Eqs. 5.13–5.16.
//
// Each tooth is a non-uniform cantilever on its base circle (the usual potential-energy model):
// bending, shear and axial compression energies are integrated along the involute tooth from the
// base circle to the contact point; the Hertz stiffness is the constant of Eq. 5.11. One pair:
// 1/k = 1/k_h + Σ_{pinion,gear} (1/k_b + 1/k_s + 1/k_a) (Eq. 5.12). The mesh stiffness is the sum
// over the pairs in contact, which alternate between one and two with the contact ratio.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "gearwatch/twin/gear_geometry.hpp"

namespace gearwatch::twin {

/// Compliances (1/k, m/N) of one tooth loaded at roll angle t = tan(α_contact).
struct ToothCompliance {
  double bending = 0, shear = 0, axial = 0;
  double total() const { return bending + shear + axial; }
};

/// Potential-energy compliance of one tooth with z teeth and base radius rb (module geometry
/// from the spec), loaded at roll angle `roll`. Gauss–Legendre quadrature along the profile.
ToothCompliance tooth_compliance(const GearGeometry& geometry, bool pinion, double roll);

/// Hertz stiffness of Eq. 5.11: π E b / (4 (1 − ν²)).
double hertz_stiffness(const GearGeometry& geometry);

/// Unscaled single-pair stiffness (Eq. 5.12) at position s on the line of action.
double single_pair_stiffness(const GearGeometry& geometry, double s);

/// ISO 6336-1 method B single-pair stiffness c'·b of the thesis's pair (13.25 N/(mm·µm) × 20 mm).
inline constexpr double kIsoSinglePairStiffness = 2.65e8;

struct MeshStiffnessOptions {
  double scale = 1.0;                 ///< calibration scale on the level (thesis Fig. 5.15)
  /// The potential-energy curve (no fillet-foundation term, as Eq. 5.12) is stiffer than the
  /// ISO 6336 value for this pair (by how much: docs/twin.md, Design); like the thesis (Fig. 5.15) the *shape* is kept and its peak is
  /// normalised to this level before `scale` applies. 0 keeps the raw potential-energy level.
  double normalise_peak_to = kIsoSinglePairStiffness;
  /// Gradual engagement: the pair stiffness rises/falls smoothly (cosine ramp) over this length at
  /// each end of the active line, as a fraction of the base pitch. 0 = the thesis's abrupt step.
  double engagement_ramp_fraction = 0.0;
  int table_points = 1025;            ///< samples of the single-pair curve along the active line
};

/// The mesh stiffness of a pair over the mesh cycle. Built once (tabulated), evaluated cheaply.
class GearMeshStiffness {
 public:
  GearMeshStiffness(const GearGeometry& geometry, MeshStiffnessOptions options = {});

  const GearGeometry& geometry() const { return geometry_; }
  const MeshStiffnessOptions& options() const { return options_; }

  /// Stiffness of one pair in contact at s (scaled, ramped). 0 outside the active line.
  double pair_stiffness(double s) const;
  /// Contact positions of the pairs in contact at mesh phase `phase` ∈ [0,1) (fraction of one
  /// mesh period; 0 = a pair enters at the start of the active line). pair j sits at
  /// contact_start + (phase + j)·p_b; returns how many (1 or 2 for 1 < ε < 2; up to 3 allowed).
  int pairs_in_contact(double phase, double positions[3]) const;
  /// Total mesh stiffness at mesh phase (periodic with period 1).
  double mesh_stiffness(double phase) const;
  /// Mean over one mesh period (k_ave of Eq. 5.14), computed once on a fine grid.
  double mean_stiffness() const { return mean_; }
  /// Fraction of the mesh period with two pairs in contact (= ε − 1 for 1 < ε < 2).
  double double_contact_share() const;

 private:
  GearGeometry geometry_;
  MeshStiffnessOptions options_;
  std::vector<double> table_;   ///< scaled single-pair stiffness on a uniform grid over the active line
  double mean_ = 0;
};

// Inline: the equations of motion evaluate both for every pair at every right-hand side.
inline double GearMeshStiffness::pair_stiffness(double s) const {
  const double u = (s - geometry_.contact_start) / geometry_.active_length();
  if (u < 0.0 || u > 1.0) return 0.0;
  const double pos = u * static_cast<double>(table_.size() - 1);
  const std::size_t i = std::min(static_cast<std::size_t>(pos), table_.size() - 2);
  const double f = pos - static_cast<double>(i);
  return table_[i] + f * (table_[i + 1] - table_[i]);
}

inline int GearMeshStiffness::pairs_in_contact(double phase, double positions[3]) const {
  phase -= std::floor(phase);
  int n = 0;
  for (int j = 0; j < 3; ++j) {
    const double s = geometry_.contact_start + (phase + j) * geometry_.base_pitch;
    if (s > geometry_.contact_end) break;
    positions[n++] = s;
  }
  return n;
}

/// Mesh damping of Eqs. 5.13–5.16: c_m = μ k_m with μ = c_ave / k_ave and
/// c_ave = 2 ζ sqrt(k_ave m5 m10 / (m5 + m10)). Returns μ (s).
double mesh_damping_time_constant(double damping_ratio, double mean_stiffness, double pinion_mass,
                                  double gear_mass);

}  // namespace gearwatch::twin
