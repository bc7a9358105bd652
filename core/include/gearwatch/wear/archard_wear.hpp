#pragma once
// The improved Archard wear model of thesis §6.2.3 (Eqs. 6.3–6.4): the wear depth at a flank point is
// the integral over time of K_wear · P(x, t) · v_s(t), where P is the Hertzian (semi-elliptical)
// pressure of the travelling contact and v_s the sliding speed at the contact centre. Because the
// pressure covers a strip of half-width a, a point is worn while the neighbouring positions are
// the nominal contact "point" (Eq. 6.4): the pitch point, where v_s = 0, still wears a little.
//
// Units: SI inside (Pa, m, m/s). The thesis quotes K_wear in "Pa⁻¹" with values that only agree with
// its reported depths under a different convention; see k_wear_si_from_seed() and docs/wear.md.
#include <functional>
#include <limits>
#include <vector>

#include "gearwatch/twin/gear_geometry.hpp"

namespace gearwatch::wear {

/// Hertz line contact of two cylinders: load per unit length w (N/m), reduced radius
/// R = R1 R2 / (R1 + R2) (m), effective modulus E* with 1/E* = (1−ν1²)/E1 + (1−ν2²)/E2 (Pa).
/// a = sqrt(4 w R / (π E*)), p0 = 2 w / (π a) = sqrt(w E* / (π R)). Zero load gives zeros.
struct LineContact {
  double max_pressure_pa = 0;
  double half_width_m = 0;
};
LineContact line_contact(double load_per_width_n_m, double reduced_radius_m, double effective_modulus_pa);

/// The thesis's K_wear figures (e.g. 1.65e-6 "Pa⁻¹", dry, §6.3.1) in SI (m²/N = Pa⁻¹ for
/// h = K ∫ P v_s dt with P in Pa, v_s in m/s, h in m). The thesis's values are read as MPa⁻¹ in the
/// N–mm–MPa system (h[mm] = K · P[MPa] · s[mm]), so K_SI = 1e-6 · K_thesis. No constant factor makes
/// both of the thesis's reported (K, depth) pairs agree with this model; this one is within a
/// factor of ~4 of both (docs/wear.md has the numbers).
double k_wear_si_from_seed(double k_wear_seed);
double k_wear_seed_from_si(double k_wear_si);

/// A Hertz contact that travels along one flank, described in the flank's own frame: the contact
/// centre sits at flank arc length q (m) and moves over the flank at the rolling speed v_r(q) > 0.
/// Every quantity is a function of the centre position q ∈ [first, last].
struct TravellingContact {
  std::function<double(double)> max_pressure_pa;
  std::function<double(double)> half_width_m;
  std::function<double(double)> sliding_speed_m_s;
  std::function<double(double)> rolling_speed_m_s;
  double first = 0, last = 0;
  /// Where v_s changes sign (the pitch point), if on the flank: the integrand has a kink there, so
  /// the strip integral is split at it. NaN = none.
  double sliding_reversal = std::numeric_limits<double>::quiet_NaN();
};

/// Wear depth (m) at flank points x (arc lengths) after one passage of the contact:
///   h(x) = K ∫ P(x, t) v_s(t) dt = K ∫ p0(q) sqrt(1 − ((x − q)/a(q))²) v_s(q) / v_r(q) dq,
/// the integral over the centres q whose pressure strip covers x. The strip edges are found by
/// bisection and the integral is taken with a sine substitution that removes the square-root edge,
/// so the result is accurate to ~1e-6 relative for smooth inputs.
std::vector<double> archard_wear_depth(const TravellingContact& contact, const std::vector<double>& flank_points,
                                       double k_wear_si);

/// The load one tooth pair carries over its pass along the line of action, pinion root → tip.
/// position_m must be increasing and span the active line (the twin's ContactForceProfile
/// provides the same two columns).
struct PassLoad {
  std::vector<double> position_m;
  std::vector<double> force_n;
  /// Linear interpolation; 0 outside the sampled span.
  double force_at(double s) const;
};

/// Wear of one tooth pass on each flank, sampled root → tip of the active profile at the profile
/// fractions of twin::ToothProfileDeviation (uniform in the position on the line of action).
struct PassWear {
  std::vector<double> pinion_m;   ///< per pinion tooth per pass (= per pinion revolution)
  std::vector<double> gear_m;     ///< per gear tooth per pass (a gear tooth meets z1/z2 passes per pinion revolution)
};

/// Flank arc length (m) of the pinion / gear involute from its base circle to the contact at s.
double pinion_flank_arc(const twin::GearGeometry& g, double s);
double gear_flank_arc(const twin::GearGeometry& g, double s);

/// The travelling contact of a pair loaded by `load` on the pinion's / the gear's flank (flank arc
/// length coordinates, speeds for ω1 = 1 rad/s: only v_s / v_r matters). `width_factor(s)` ∈ (0, 1]
/// scales the face width that carries the load at s (pitting feedback, Eq. 7.12); {} means 1.
TravellingContact pinion_contact(const twin::GearGeometry& g, const PassLoad& load,
                                 const std::function<double(double)>& width_factor = {});
TravellingContact gear_contact(const twin::GearGeometry& g, const PassLoad& load,
                               const std::function<double(double)>& width_factor = {});
/// Flank arc lengths of `points` profile points root → tip (uniform in the line-of-action position).
std::vector<double> pinion_profile_points(const twin::GearGeometry& g, int points);
std::vector<double> gear_profile_points(const twin::GearGeometry& g, int points);

/// Wear depth per pass on both flanks for a pair loaded by `load`. `width_factor(s)` ∈ (0, 1]
/// scales the face width that carries the load at s (pitting feedback, Eq. 7.12); pass {} for 1.
/// `points` ≥ 2 profile points per flank.
PassWear pass_wear(const twin::GearGeometry& g, const PassLoad& load, double k_wear_si, int points,
                   const std::function<double(double)>& width_factor = {});

}  // namespace gearwatch::wear
