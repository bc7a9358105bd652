#pragma once
// The modal gap on measured data (thesis Table 5.5): a calibration with physically grouped knobs whose
// ranges are the sourced priors, candidate structural effects the thesis left out (§5.3: the bed under
// the pedestals, the coupling type, the pedestal masses), each scored by leave-two-out prediction of
// the measured natural frequencies, and a report of which measured modes the twin explains, which an
// added effect explains and which remain unexplained (docs/twin.md, "The modal gap").
//
// The fit is the same method as calibrate() (Levenberg–Marquardt on log factors with box bounds, a
// Gaussian prior of σ = ¼ of the log range, monotone sensitivity-weighted pairing at each start,
// modes followed by shape during the fit), on a model that may carry extra DOFs. calibrate() and the
// shipped calibrated set are untouched by it.
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "gearwatch/twin/calibration.hpp"
#include "gearwatch/twin/gearbox_parameters.hpp"

namespace gearwatch::twin {

/// The rig's bed: one rigid body under the four pedestals, translating in y and in x on its mounts.
/// With it, the pedestal-to-ground springs (ky4…, kx4…) end on the bed instead of on the ground.
struct BaseSupport {
  bool enabled = false;
  double mass = 0;  ///< kg: bed plate and the pedestal feet moving with it
  double k_y = 0;   ///< N/m: mounts to the floor, vertical (all mounts together)
  double k_x = 0;   ///< N/m: mounts to the floor, horizontal
};

/// The 21-DOF model plus its optional structural additions.
struct StructuralModel {
  GearboxParameters gearbox = GearboxParameters::prior();
  BaseSupport base;
  int dof_count() const { return 21 + (base.enabled ? 2 : 0); }
};

/// Every scalar of a StructuralModel by name: the names of parameter_table(), and "base_mass",
/// "base_ky", "base_kx". Throws TwinParameterError for an unknown name.
double& structural_parameter(StructuralModel& model, const std::string& name);
double structural_parameter(const StructuralModel& model, const std::string& name);

/// The model's natural frequencies (Hz, ascending) at the mean mesh stiffness, with the element that
/// stores the largest share of each mode's strain energy (spring names as in spring_elements(),
/// "base_ky"/"base_kx" for the bed's mounts, "mesh").
struct StructuralMode {
  double frequency_hz = 0;
  std::string dominant_element;
  double dominant_share = 0;
  Eigen::VectorXd shape;  ///< mass-normalised
};
std::vector<StructuralMode> structural_modes(const StructuralModel& model);

/// One fitted quantity: parameters moved by one common factor (their ratios stay as in the model),
/// the factor bounded by the sourced prior range.
struct ModalKnob {
  std::string name;
  std::vector<std::string> parameters;
  double low = 1;   ///< smallest factor on the model's values the prior allows
  double high = 1;  ///< largest factor
  std::string source;
};

/// The grouped knobs on the 21-DOF model, each range the parameter sheet's prior
/// (docs/rig-parameters-used.md): one coupling type for couplings 1, 2 and 4, shaft torsion, shaft
/// bending (a round shaft bends alike in x and y), bearing + pedestal stiffness per direction, the
/// pedestal mass, and the inertias grouped by part (motor, torque meter, brake, coupling hubs with
/// shaft stubs, free ends, gear bodies).
std::vector<ModalKnob> grouped_modal_knobs();

/// What a fit predicts for a value it did not use.
enum class HeldOutPrediction {
  /// The frequency of its paired mode in the lowest-cost fit over all starts.
  best_fit,
  /// The weighted median over every start's converged fit within `ensemble_cost_window` of the lowest
  /// cost, weights exp(−Δcost): a crude sample of the posterior's modes. With 6 values and 12+ knobs
  /// many fits of nearly equal cost predict very different held-out values, and the lowest of them is
  /// picked by the random starts as much as by the data (docs/twin.md).
  ensemble,
};
const char* to_string(HeldOutPrediction prediction);

struct ModalFitOptions {
  double frequency_sigma = 0.005;  ///< as CalibrationOptions
  /// The prior centre, then random starts inside the box. On Table 5.5 the leave-two-out figures
  /// still move with the seed at 60 or 80 starts (docs/twin.md); 20 keeps the report near 30 s.
  int starts = 20;
  int max_iterations = 200;
  unsigned seed = 12345;
  HeldOutPrediction prediction = HeldOutPrediction::ensemble;
  double ensemble_cost_window = 2.0;  ///< in ½Σr² units: e^-2 of the best fit's posterior density
};

struct ModalFit {
  StructuralModel model;
  std::vector<double> factors;      ///< per knob, fitted value / model value
  std::vector<bool> at_bound;       ///< per knob
  std::vector<int> paired_mode;     ///< per measured frequency: index into structural_modes()
  std::vector<double> model_hz;     ///< per measured frequency, the lowest-cost fit
  std::vector<double> ensemble_hz;  ///< per measured frequency, the ensemble's weighted median
  int ensemble_members = 0;         ///< starts whose fit lies within the cost window
  double max_abs_error_pct = 0;     ///< over the used frequencies
  double cost = 0;
};

/// Fits the knobs to the measured frequencies with use[i]; the others are predicted from their
/// paired modes (model_hz by the lowest-cost fit, ensemble_hz by the near-equal fits). Throws
/// TwinParameterError for empty or invalid input.
ModalFit fit_modal_model(const StructuralModel& prior, const std::vector<ModalKnob>& knobs,
                         const std::vector<double>& measured_hz, const std::vector<bool>& use,
                         const ModalFitOptions& options = {});

/// Which model mode predicts a held-out frequency.
enum class HeldOutIdentity {
  /// As cross_validate(): the mode the monotone pairing of all values gave it at the fold's best
  /// start, followed by shape during the fold's fit. At a random start that identity is arbitrary.
  start_pairing,
  /// The fold model's mode (among those not paired with a fitted value) whose shape matches best
  /// (MAC) the shape of the value's mode in the fit to all values: the measured mode is named once,
  /// by its shape, and each fold predicts the frequency of that mode. No held-out value enters a
  /// fold's parameters; it only named its mode, as an experimenter names a peak by its shape. The
  /// fold's lowest-cost fit supplies the modes (HeldOutPrediction does not apply).
  full_fit_shape,
};
const char* to_string(HeldOutIdentity identity);

/// Leave-two-out prediction (every pair held out, as cross_validate()), with per-frequency figures.
struct LeaveOutScore {
  std::vector<CrossValidationFold> folds;
  double median_fold_error_pct = 0;           ///< median over folds of the fold's larger |error|
  double worst_abs_error_pct = 0;
  double median_abs_error_pct = 0;
  std::vector<double> median_by_frequency_pct;  ///< per measured frequency, over the folds holding it out
  std::vector<double> worst_by_frequency_pct;
};
LeaveOutScore leave_two_out(const StructuralModel& prior, const std::vector<ModalKnob>& knobs,
                            const std::vector<double>& measured_hz, const ModalFitOptions& options = {},
                            HeldOutIdentity identity = HeldOutIdentity::start_pairing);

/// A candidate structural effect: what it adds to or changes in a model and its knobs, with its
/// sourced priors.
struct StructuralCandidate {
  std::string name;
  std::string description;
  std::string exclusive_group;  ///< candidates of one group are alternatives (at most one adopted)
  int added_knobs = 0;
  std::function<void(StructuralModel&, std::vector<ModalKnob>&)> apply;
};

/// The candidates: "base support" (the bed as 2 DOFs; its mass and its mount stiffness in y and in x
/// as 3 knobs), "elastomer couplings" and "stiff couplings" (the coupling knob's range split at the
/// boundary between the two types inside the sheet's range; thesis §3.2 states stiff ones), "pedestal
/// masses per shaft" (input and output pedestals as separate knobs).
std::vector<StructuralCandidate> structural_candidates();

/// The base-support candidate with a given prior (mass, mount stiffness y and x) and factor ranges
/// (the two mount knobs share the range).
StructuralCandidate base_support_candidate(const BaseSupport& prior, double mass_low, double mass_high,
                                           double mounts_low, double mounts_high, const std::string& source);

/// The model with every knob at the end of its range that lowers frequencies: springs at their low
/// factor, masses and inertias at their high one. K grows and M shrinks monotonically with each
/// knob, so (Courant–Fischer) each of its frequencies is the lowest that mode can reach inside the
/// priors.
StructuralModel softest_corner(const StructuralModel& model, const std::vector<ModalKnob>& knobs);

/// What the softest corner says about the measured peaks: below peak i (ascending) the model can
/// hold at most `modes_at_or_below[i]` modes; when fewer than the peaks at or below it, at least
/// `deficit[i]` of those peaks cannot be modes of this model, whatever the knobs inside the priors.
struct CornerCheck {
  std::string name;                   ///< "grouped twin" or the candidate's name
  std::vector<double> elastic_hz;     ///< the corner's elastic frequencies below the highest peak × 1.5
  std::vector<int> modes_at_or_below; ///< per measured frequency, in the measured order
  std::vector<int> deficit;           ///< per measured frequency: peaks ≤ it minus modes ≤ it, at least 0
  int max_deficit = 0;
};
CornerCheck corner_check(const std::string& name, const StructuralModel& model, const std::vector<ModalKnob>& knobs,
                         const std::vector<double>& measured_hz);

/// How a measured mode fares.
enum class ModalGapStatus { explained_by_twin, explained_by_effect, unexplained };
const char* to_string(ModalGapStatus status);

struct ModalGapMode {
  double measured_hz = 0;
  ModalGapStatus status = ModalGapStatus::unexplained;
  std::string effect;                ///< the adopted effects ("+"-joined) that brought it within tolerance
  bool worse_with_effects = false;   ///< explained by the twin, but outside the tolerance with the adopted effects
  double median_error_before_pct = 0, worst_error_before_pct = 0;  ///< held out, grouped twin
  double median_error_after_pct = 0, worst_error_after_pct = 0;    ///< held out, with the adopted effects
  /// The largest of its held-out medians over the seeds (fit.seed and spread_seeds): the verdict uses these.
  double worst_seed_median_before_pct = 0, worst_seed_median_after_pct = 0;
  std::string element_before, element_after;  ///< dominant strain energy of its mode in the full fits
  double share_before = 0, share_after = 0;   ///< that element's share of the mode's strain energy
  double fitted_hz_after = 0;                 ///< the full fit with the adopted effects
};

/// One option of structural candidates scored at a greedy step: a candidate, or two joined by " + "
/// (not gap::CandidateScore, the gap diagnosis's candidate effect scored on held-out records).
struct StructuralOptionScore {
  std::string name, description;
  int added_knobs = 0;
  int step = 0;                      ///< greedy step at which it was scored (1, 2, …)
  double median_fold_before_pct = 0; ///< of the model it was added to
  double median_fold_after_pct = 0;
  double worst_after_pct = 0;
  bool adopted = false;
};

struct ModalGapOptions {
  ModalFitOptions fit;
  HeldOutIdentity identity = HeldOutIdentity::start_pairing;
  /// A measured mode counts as explained when its median held-out |error| is within this (%) at
  /// every seed.
  double explained_within_pct = 15.0;
  /// An effect is adopted only if the median fold error falls to at most this share of the current
  /// one: a smaller fall is within the spread the extra knobs buy by chance.
  double adopt_ratio = 0.9;
  /// Target of the median leave-two-out fold error (%).
  double target_median_fold_pct = 15.0;
  /// The random starts pick among fits of nearly equal cost that predict differently, so the
  /// grouped twin's and the final model's scores are recomputed with these seeds as well.
  std::vector<unsigned> spread_seeds = {1, 2};
};

struct ModalGapReport {
  std::vector<double> measured_hz;
  std::vector<ModalKnob> baseline_knobs;
  LeaveOutScore baseline;            ///< the grouped twin
  std::vector<StructuralOptionScore> candidates;  ///< in the order scored
  std::vector<std::string> adopted;  ///< in the order adopted
  std::vector<ModalKnob> final_knobs;
  LeaveOutScore final_score;         ///< with the adopted effects
  ModalFit final_fit;                ///< all frequencies, the adopted effects
  ModalFit baseline_fit;             ///< all frequencies, the grouped twin
  std::vector<ModalGapMode> modes;
  /// The softest-corner check of the grouped twin and of each candidate applied alone.
  std::vector<CornerCheck> corners;
  double target_median_fold_pct = 15.0;
  /// Median fold error of the grouped twin and of the final model per seed: fit.seed first, then
  /// spread_seeds.
  std::vector<unsigned> seeds;
  std::vector<double> baseline_fold_by_seed, final_fold_by_seed;
  bool knobs_inside_priors = false;  ///< the final full fit's factors inside every knob's range
  /// Knobs inside their priors and the final median fold within target for every seed.
  bool target_met = false;
};

/// Grouped calibration, greedy forward selection over the candidates (singly and in pairs) by
/// leave-two-out median fold error, and the per-mode verdicts.
ModalGapReport modal_gap_analysis(const StructuralModel& baseline, const std::vector<ModalKnob>& knobs,
                                  const std::vector<StructuralCandidate>& candidates,
                                  const std::vector<double>& measured_hz, const ModalGapOptions& options = {});

/// The analysis on thesis Table 5.5 with the grouped knobs and every candidate.
ModalGapReport table_5_5_modal_gap(const ModalGapOptions& options = {});

}  // namespace gearwatch::twin
