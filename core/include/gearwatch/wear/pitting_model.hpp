#pragma once
// Surface pitting density from the Lundberg–Palmgren survival model (thesis §7.3.2, Eqs. 7.3–7.12).
//
// Per contact position θ (here: a point of the pinion's active profile, root → tip):
//   τ0 = 0.3 p_max (7.4), z0 = 0.786 b (7.5), V = 2b · z0 · 2π R (7.6), b the Hertz half-width,
//   R the reduced radius; D(N) = 1 − exp(−K τ0^c N^m V / z0^h) (7.8), accumulated step by step
//   with Eq. 7.11 while the face width shrinks with the tooth's pitting density (its mean over the
//   profile), B = B0 (1 − D) (7.12, p. 152; wear_loop.hpp, pitted_width_factor).
// Units: τ0 in Pa, z0 in m, V in m³, so K_pitting is in Pa^-c m^(h-3) (the thesis gives no unit and
// no exponents for its K_pitting = 5.64e-15; see docs/wear.md).
#include <vector>

namespace gearwatch::wear {

/// Material exponents of Eq. 7.3. Defaults: the classical Lundberg–Palmgren values (1947):
/// c = 31/3 (shear stress), h = 7/3 (depth), m = e = 10/9 (Weibull slope, the exponent of N).
/// The thesis names them "material coefficients" [27] without values.
struct PittingMaterial {
  double c = 31.0 / 3.0;
  double m = 10.0 / 9.0;
  double h = 7.0 / 3.0;
  /// Throws TwinParameterError unless all are finite and positive.
  void validate() const;
};

/// Eqs. 7.4–7.6 from the Hertz contact at one position.
struct LundbergPalmgrenTerms {
  double max_shear_stress_pa = 0;   ///< τ0
  double shear_depth_m = 0;         ///< z0
  double stressed_volume_m3 = 0;    ///< V
};
LundbergPalmgrenTerms lundberg_palmgren_terms(double max_pressure_pa, double half_width_m, double reduced_radius_m);

/// The exponent rate A = K τ0^c V / z0^h, so that ln(1/S) = A N^m (computed in logarithms).
double survival_rate(double k_pitting, const LundbergPalmgrenTerms& t, const PittingMaterial& material);

/// Eq. 7.8: D(N) = 1 − exp(−A N^m).
double pitting_density_direct(double rate, double cycles, const PittingMaterial& material);

/// One step of Eq. 7.8 on the unpitted area: D_{i+1} = 1 − (1 − D_i) exp(−A ((N + ΔN)^m − N^m)).
/// Equal to Eq. 7.11 (D_i + exp(−A N^m) − exp(−A (N + ΔN)^m)) while D_i = 1 − exp(−A N^m) with A
/// constant since N = 0; unlike Eq. 7.11 it keeps growing with A after A changed (docs/wear.md).
double pitting_density_step(double density, double rate, double cycles, double step_cycles,
                            const PittingMaterial& material);

}  // namespace gearwatch::wear
