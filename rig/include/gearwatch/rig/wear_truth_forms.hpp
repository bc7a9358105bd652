#pragma once
// Wear truths in forms the twin's model does not share (docs/rig-simulator.md, "Wear truths in
// other forms"): the thesis's regime-dependent wear coefficient (Eq. 2.4, λ = h_min / R with an
// EHL film and a roughness that runs in), pits initiating at Weibull-distributed lives and growing,
// an abrupt lubricant contamination and a load change mid-life. The truth's own code: it uses the
// twin's gear geometry only, never the project's wear model (core wear), so a model-form error of
// that model can show against it.
#include <cstdint>
#include <memory>
#include <vector>

#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/rig/wear_state.hpp"

namespace gearwatch::rig {

/// How the wear coefficient evolves: constant (k0, times the contamination factor), or the
/// thesis's Eq. 2.4 on the film-to-roughness ratio λ.
enum class WearCoefficientForm { constant, regime };
/// Pitting: none, or Weibull initiation of pit sites with exponential pit growth.
enum class PittingForm { none, weibull };
const char* to_string(WearCoefficientForm form);
const char* to_string(PittingForm form);

/// The input torque: T1 until `change_cycles`, T2 from there on (a record at exactly the change
/// is measured at T2). change_cycles < 0: no change.
struct TorqueSchedule {
  double torque_nm = 20;
  double change_cycles = -1;
  double torque_after_nm = 20;

  bool changes() const { return change_cycles >= 0; }
  double at(double cycles) const { return changes() && cycles >= change_cycles ? torque_after_nm : torque_nm; }
  /// ∫₀ᴺ (T(n)/T_ref)^p dn: the cycles at T_ref that do the same fatigue damage (Miner's rule with
  /// life ∝ T^−p), and its inverse (∞ where the torque is 0 from there on).
  double equivalent_cycles(double cycles, double reference_nm, double exponent) const;
  double cycles_at_equivalent(double equivalent, double reference_nm, double exponent) const;
};

/// Inputs of the Dowson–Higginson film. viscosity 0: no lubricant (h_min = 0, λ = 0: boundary).
struct LubricantFilm {
  double viscosity_pa_s = 0.1;              ///< η0, dynamic viscosity at the inlet temperature
  double pressure_viscosity_per_pa = 2e-8;  ///< α of Barus' law η = η0 exp(α p)
};

/// Composite roughness R = (R1 + R2)/2 of the RMS roughnesses (the thesis's §2.4.2) running in:
/// R(N) = R_final + (R0 − R_final) exp(−N/N_r). The roughness index the sliding vibration follows
/// counts the run-in marks above the final surface, a floor, and the roughening by abrasion:
/// index = (R(N) − R_final)/1 µm + floor + per_um · pinion mean depth/µm.
struct RunInRoughness {
  double initial_um = 1.0;
  double final_um = 0.2;
  double runin_cycles = 1e5;
  double index_floor = 0;
  double index_per_um_wear = 0;
  double at_um(double cycles) const;
};

/// Abrupt contamination of the lubricant from `from_cycles` on (< 0: none): the wear coefficient
/// times wear_factor, the pit growth rate times pitting_growth_factor, switching exactly there.
struct Contamination {
  double from_cycles = -1;
  double wear_factor = 1;
  double pitting_growth_factor = 1;
  bool on() const { return from_cycles >= 0; }
  bool active(double cycles) const { return on() && cycles >= from_cycles; }
};

/// Pit initiation and growth. Each of `sites` potential sites initiates when the fatigue damage at
/// the reference torque reaches its life L = γ + η (−ln(1 − U))^(1/β), U uniform (3-parameter
/// Weibull; `seed` draws the U); under another torque the damage accrues (T/T_ref)^p times as fast
/// (TorqueSchedule::equivalent_cycles). A pit initiated at N_i has the area
/// a(N) = min(a_max, a0 exp(G(N) − G(N_i))), G the integral of the growth rate g (times the
/// contamination's factor once it is on). Density = min(max_density, Σ a / active flank area).
/// How a pit's area grows with its growth age x = G(N) − G(N_i): exponential a0 e^x, or a power
/// of the age a0 (1 + x/p)^p (the same initial rate; polynomial, not exponential, in cycles).
enum class PitGrowthForm { exponential, power };
const char* to_string(PitGrowthForm form);

struct WeibullPittingSettings {
  double shape = 1.5;                       ///< β
  double characteristic_life_cycles = 2e6;  ///< η, at the reference torque
  double location_cycles = 0;               ///< γ: no site initiates earlier (at the reference torque)
  int sites = 1000;
  double initial_area_m2 = 1e-8;            ///< a0
  double max_area_m2 = 3e-7;                ///< a_max ≥ a0 (a0 = a_max: a pit appears at its full size)
  double growth_per_cycle = 5e-6;           ///< g
  PitGrowthForm growth = PitGrowthForm::exponential;
  double growth_power = 2;                  ///< p of the power form, > 0
  double reference_torque_nm = 20;
  double load_life_exponent = 4;            ///< p in life ∝ T^−p
  double max_density = 0.3;
  std::uint64_t seed = 1;
};

/// Everything a forms truth needs besides the torque schedule and the reference torque.
struct FormsSettings {
  WearCoefficientForm wear = WearCoefficientForm::regime;
  /// Wear depth per cycle (m) at the pinion's sliding extreme at the reference torque: the
  /// constant K, or the boundary value k0 of Eq. 2.4.
  double k0 = 0;
  LubricantFilm film;
  RunInRoughness roughness;
  Contamination contamination;
  PittingForm pitting = PittingForm::none;
  WeibullPittingSettings weibull;
};

/// Eq. 2.4 of the thesis as a fraction of k0: 1 for λ ≤ 1/2, (2/7)(4 − λ) between, 0 for λ ≥ 4.
double regime_wear_factor(double lambda);

/// The pitch point's line contact for the Dowson–Higginson formula.
struct PitchContact {
  double entraining_speed_m_s = 0;   ///< (u1 + u2)/2 = ω1 r_b1 tan α (both surfaces roll at it there)
  double reduced_radius_m = 0;       ///< R' = ρ1 ρ2 / (ρ1 + ρ2)
  double load_per_width_n_m = 0;     ///< w' = T / (r_b1 b), halved where the pitch point lies in double contact
  double reduced_modulus_pa = 0;     ///< E' = 2 E* (1/E' = ½ Σ (1 − ν²)/E)
};
PitchContact pitch_contact(const GearPairSpec& gears, double speed_hz, double torque_nm);
/// Dowson–Higginson minimum film thickness of an isothermal EHL line contact:
/// h_min = 2.65 R' U^0.70 G^0.54 W^−0.13, U = η0 u/(E'R'), G = α E', W = w'/(E'R').
double min_film_thickness_m(const PitchContact& contact, const LubricantFilm& film);
/// The pinion's active flank area: z1 · b · the involute's arc length between the start and the
/// end of active contact, (s_end² − s_start²)/(2 r_b1).
double active_flank_area_m2(const GearPairSpec& gears);

/// The pits of WeibullPittingSettings, drawn once.
class WeibullPitting {
 public:
  WeibullPitting(const WeibullPittingSettings& settings, double active_area_m2, const TorqueSchedule& torque,
                 const Contamination& contamination);
  double density(double cycles) const;
  double growth_rate(double cycles) const;
  /// A pit's area at growth age x (a_max from the age it reaches it on).
  double pit_area(double age) const;
  /// The growth age at which a pit reaches a_max: ln(a_max/a0), or p((a_max/a0)^(1/p) − 1).
  double full_growth_age() const;
  /// Cycle counts at which the sites initiate, ascending (∞ for a site that never does).
  const std::vector<double>& initiation_cycles() const { return initiation_; }

 private:
  double growth_exponent(double cycles) const;   ///< G(N)
  WeibullPittingSettings s_;
  double area_m2_;
  Contamination contamination_;
  std::vector<double> initiation_;
};

/// The worn profiles' shape, root → tip at uniform profile fractions, pinion maximum 1: Archard's
/// depth per pinion revolution in closed form, h = K w |v_s| / v_r per pass (the Hertz width
/// cancels), on rigid teeth sharing the load equally where two pairs are in contact:
///   pinion ∝ share(s) |s − s_pitch| / ρ1(s),  gear ∝ share(s) |s − s_pitch| / ρ2(s)
/// (the gear's fewer passes, z1/z2, cancel its slower rolling). The truth's own code: the twin's
/// geometry only. Not the symmetric V |u − u_pitch| of the linear law, whose two pairs' deviations
/// sum to a constant in double contact, so its wear hardly reaches the mesh harmonics (docs/model.md).
struct ArchardProfileShape {
  std::vector<double> pinion;
  std::vector<double> gear;
};
ArchardProfileShape archard_profile_shape(const GearPairSpec& gears, int points);

/// The forms truth: depth amplitude (the pinion's deepest point)
///   A(N) = k0 ∫₀ᴺ f(λ(n)) c(n) T(n)/T_ref dn
/// with f Eq. 2.4 (1 for the constant form) and c the contamination factor, on ArchardProfileShape;
/// pitting by WeibullPitting.
class FormsWearTruth final : public WearTruth {
 public:
  /// Validates (throws RigParameterError with one line naming the parameter).
  FormsWearTruth(const FormsSettings& settings, const TorqueSchedule& torque, double reference_torque_nm,
                 int profile_points, const GearPairSpec& gears, double speed_hz);
  WearState at(double cycles) const override;

  double film_thickness_m(double cycles) const;        ///< h_min at the torque in force
  double lambda(double cycles) const;                  ///< h_min / R(N)
  double wear_factor(double cycles) const;             ///< f(λ) (regime) or 1, times the contamination factor
  double wear_amplitude_m(double cycles) const;        ///< A(N)
  double active_area_m2() const { return area_m2_; }

 private:
  double integrand(double n) const { return wear_factor(n) * torque_.at(n) / reference_torque_nm_; }
  std::vector<double> breakpoints(double cycles) const;

  FormsSettings s_;
  TorqueSchedule torque_;
  double reference_torque_nm_;
  int profile_points_;
  GearPairSpec gears_;
  double speed_hz_;
  double area_m2_ = 0;
  ArchardProfileShape shape_;
  std::vector<double> film_m_;   ///< h_min at T1 and T2
  std::unique_ptr<WeibullPitting> pitting_;
};

}  // namespace gearwatch::rig
