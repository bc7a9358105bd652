#pragma once
// The wear truth of a simulated campaign: the state of the gear pair at a cycle count. An
// interface, so the built-in evolution below can be replaced by the project's Archard and
// pitting models (core wear module) without touching the simulator.
#include <memory>
#include <vector>

#include "gearwatch/rig/wear_state.hpp"
#include "gearwatch/rig/wear_truth_forms.hpp"
#include "gearwatch/twin/gearbox_parameters.hpp"
#include "gearwatch/twin/transmission_error.hpp"
#include "gearwatch/wear/wear_loop.hpp"

namespace gearwatch::rig {

/// A change of the wear coefficient from a cycle count on (run-in, lubricant contamination, ...).
struct WearPhase {
  double from_cycles = 0;
  double k_wear = 0;   ///< m of wear depth per cycle, at the sliding extremes, at the reference torque
};

/// The built-in evolution (docs/rig-simulator.md, "Wear truth"):
///   depth(u, N) = (T / T_ref) · |u − u_pitch| / max|u − u_pitch| · Σ_phases K_i · ΔN_i
/// on the pinion (sliding is proportional to the distance from the pitch point, zero there), the
/// gear's depth scaled by z1/z2 (each gear tooth meshes z1/z2 times as often as a pinion tooth);
///   pitting(N) = min(max, K_pitting · ((N − N_onset)/10⁶)^β) for N > N_onset, else 0;
///   roughness(N) = R0 · exp(−N / N_runin) + R_wear · mean depth / 1 µm.
/// `linear`: the law above, K in m of depth per cycle. `archard`: the project's improved Archard
/// model (core wear, quasi-static force, the same blue loop the twin's model runs), K in m²/N.
/// `forms`: the truth's own forms (wear_truth_forms.hpp: regime-dependent K, Weibull pitting,
/// contamination, load change), K in m of depth per cycle as `linear`'s.
enum class WearLaw { linear, archard, forms };
const char* to_string(WearLaw law);

struct WearModelSettings {
  WearLaw law = WearLaw::linear;
  std::vector<WearPhase> phases;           ///< sorted by from_cycles; before the first: K = 0
  double reference_torque_nm = 20.0;
  double torque_nm = 20.0;
  double load_change_cycles = -1;          ///< `forms` only: the torque becomes torque_after_nm here (< 0: never)
  double torque_after_nm = 20.0;
  FormsSettings forms;                     ///< `forms` only (its pitting and roughness replace the fields below)
  double pitting_onset_cycles = 0;
  double k_pitting = 0;                    ///< pitted fraction at 10⁶ cycles past the onset
  double pitting_exponent = 1.5;
  double max_pitting = 0.3;
  double initial_roughness = 0;            ///< R0
  double runin_cycles = 1;                 ///< e-folding of the initial roughness
  double roughness_per_um = 0;             ///< R_wear: roughness index per µm of mean wear depth
  int profile_points = 41;

  TorqueSchedule torque_schedule() const { return {torque_nm, load_change_cycles, torque_after_nm}; }
};

class BuiltinWearTruth final : public WearTruth {
 public:
  /// Validates (phases sorted, coefficients ≥ 0, exponent > 0, 0 ≤ max ≤ 1); throws RigParameterError.
  BuiltinWearTruth(const WearModelSettings& settings, const GearPairSpec& gears);
  WearState at(double cycles) const override;

 private:
  WearModelSettings s_;
  GearPairSpec gears_;
  double pitch_fraction_pinion_ = 0.5;  ///< profile fraction of the pitch point on the pinion
  double pitch_fraction_gear_ = 0.5;
};

/// The wear depth from the project's Archard model (core wear::BlueLoop, quasi-static force, at the
/// campaign's torque), with K_wear switching at the phases' cycle counts; pitting and roughness as
/// in the built-in law. States are computed forward and cached: asking in increasing cycles (as a
/// campaign does) runs the loop once.
class ArchardWearTruth final : public WearTruth {
 public:
  ArchardWearTruth(const WearModelSettings& settings, const twin::GearboxParameters& params, double speed_hz);
  WearState at(double cycles) const override;

 private:
  WearModelSettings s_;
  BuiltinWearTruth surface_;   ///< pitting and roughness (its own depth unused)
  twin::GearboxParameters params_;
  wear::WearLoopOptions options_;
  mutable std::unique_ptr<wear::BlueLoop> loop_;
};

std::unique_ptr<WearTruth> make_wear_truth(const WearModelSettings& settings, const twin::GearboxParameters& params,
                                           double speed_hz);

}  // namespace gearwatch::rig
