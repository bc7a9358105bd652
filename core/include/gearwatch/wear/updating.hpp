#pragma once
// The purple loop of thesis Fig. 7.1 (§7.3.3): the twin's wear coefficients updated from measured
// vibration, around the blue loop (wear_loop.hpp), with forecasts and remaining life.
//
// - K_wear (Eqs. 7.13–7.14): when |RMS_SA,sim − RMS_SA,meas| / RMS_SA,meas exceeds a threshold,
//   K_wear is changed and the blue loop re-run from the state at which the current K_wear was
//   accepted (the last K_wear update, or the start of the gear pair's life) to the record, until
//   the error is within a tolerance or the bounded re-runs run out. By default a root-find on
//   ln K with the twin's own elasticity d ln RMS_SA / d ln K (the thesis's rule assumes it is 1);
//   where RMS_SA barely depends on K_wear the update is refused as `insensitive`. The thesis's
//   proportional rule K ← K · RMS_SA,meas / RMS_SA,sim is kept as an option.
//   RMS_SA,sim comes from the twin's casing signal analysed by the measurement code.
// - K_pitting (§7.3.3 steps 1–4): two pitted-area inspections calibrate K_pitting and the
//   ICS2 ↔ pitting-density scale; then at every pitting point (every `pitting_interval_cycles`)
//   the Pearson correlation C of the last three (ICS2 low band, predicted density) pairs
//   (Eq. 7.15) is checked; below 0.95, K_pitting maximises C (Eqs. 7.16–7.17) by a bracketed
//   golden-section search on log K; when 0.95 cannot be reached K_pitting is set to 0.
// - Forecasts: the blue loop run ahead on a copy at the recent operating conditions, with the
//   cycles left to a wear-depth and a pitting-density limit, and a 90 % interval from the normal
//   posterior of ln K (forecast_intervals.hpp) with the random walk accumulated to the crossing,
//   widened when the recent RMS_SA residuals exceed their scatter and brought forward when the
//   ICS2-derived pitting density runs ahead of the model's.
// No I/O and no threads: the daemon's model thread feeds it records and stores what it returns.
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/numeric/line_search.hpp"
#include "gearwatch/twin/gearbox_parameters.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "gearwatch/types/model_run.hpp"
#include "gearwatch/wear/depth_calibration.hpp"
#include "gearwatch/wear/forecast_intervals.hpp"
#include "gearwatch/wear/pitting_growth.hpp"
#include "gearwatch/wear/k_wear_rule.hpp"
#include "gearwatch/wear/wear_loop.hpp"

namespace gearwatch {
struct GearboxSpec;
}
namespace gearwatch::dsp {
struct SignalProcessingSettings;
}

namespace gearwatch::wear {

/// RMS_SA(N) of the twin's casing signal for a wear state at an operating point. Throws what the
/// twin throws (TwinDivergenceError, TwinParameterError) when there is no value.
using RmsSaSimulator = std::function<double(const WearState&, const twin::OperatingPoint&)>;

/// The measurement code on the twin's signal: y6 for `revolutions` input revolutions (after the
/// twin's settling) at the rig's sample rate, as a float Record with exact tacho edges, through
/// dsp::RecordAnalyzer with `settings` (its rms_sa_harmonics is the N of Eq. 7.1). The channel has
/// no i16 scale: a simulated signal is never clipped.
RmsSaSimulator twin_rms_sa_simulator(twin::GearboxParameters params, const GearboxSpec& rig,
                                     const dsp::SignalProcessingSettings& settings, double revolutions);

/// K_pitting on a scale a reader can check. Inside, K_pitting multiplies τ0^c V / z0^h with τ0 in
/// Pa, z0 in m, V in m³ and N in cycles (Eqs. 7.3–7.8), so its unit is Pa^-c · m^(h−3) · cycle^-m
/// and its value (≈ 1e-94 for the rig's pair) says nothing by itself. The readable form: the
/// cycles after which the unworn pair's most loaded profile point reaches `reference_density` at
/// `reference_torque_nm`, by Eq. 7.8: D = 1 − exp(−K T N^m), T = max over the profile of
/// τ0^c V / z0^h. Both directions are closed form, so the one converts exactly into the other.
struct PittingScale {
  double reference_torque_nm = 0;
  double reference_density = 0;
  double terms = 0;   ///< T: τ0^c V / z0^h at the most loaded point of the unworn pair (Pa^c m^(3−h))
  PittingMaterial material;
  /// Cycles to the reference density with coefficient k (infinity when k ≤ 0).
  double cycles_to_reference(double k_pitting) const;
  /// The coefficient that reaches the reference density after `cycles` (the inverse).
  double k_pitting_for(double cycles) const;
  /// "Pa^-10.33 m^-0.667 cycle^-1.111": the unit with the configured exponents.
  std::string unit() const;
  /// One line: K with its unit and the cycles to the reference density.
  std::string describe(double k_pitting) const;
};
/// The scale of the given pair and blue-loop options (its material exponents and profile) at a
/// reference torque; throws TwinParameterError when the pair carries no load there.
PittingScale pitting_scale(const twin::GearboxParameters& params, const WearLoopOptions& loop, double reference_torque_nm,
                           double reference_density);

struct ModelSettings {
  WearLoopOptions loop;                    ///< K values here are the initial ones (SI); operating point ignored
  bool update_k_wear = true;
  bool update_k_pitting = true;
  /// With ≥ 2 pitted-area inspections the pitting forecast follows the fitted growth law
  /// dD/dN = a D^b (pitting_growth.hpp); false (the default): Eq. 7.8's path alone (the thesis's).
  /// Opt-in: on fresh random campaigns its interval held the truth less often than Eq. 7.8's
  /// (docs/model.md), so it does not replace it until that is understood.
  bool pitting_growth_law = false;
  /// With ≥ 2 pitted-area inspections the pitting forecast's nominal is Eq. 7.8's form with its
  /// exponent read from the two newest (inspection_exponent_crossing), its interval joined with
  /// the twin's path's; false: Eq. 7.8 with the material's m alone (the thesis's).
  bool pitting_exponent_from_inspections = true;
  double rms_threshold = 0.05;             ///< relative RMS_SA error that triggers a K_wear update (thesis: 5 %)
  double convergence_tolerance = 0.01;     ///< an update iterates until this (≤ threshold), so it does not sit at the edge
  int max_wear_iterations = 16;            ///< twin re-runs per K_wear update (the root-find's sensitivity read included)
  KWearUpdateRule k_wear_update = KWearUpdateRule::root_find;
  /// Root-find: below this |d ln RMS_SA / d ln K_wear| the update is refused (`insensitive`).
  /// Mismatches under `rms_threshold` are taken as the measurement's scatter; with an elasticity
  /// below rms_threshold / ln 10 (0.0217 at 5 %) a mismatch of that size would move K_wear by more
  /// than a decade, so RMS_SA does not determine K_wear there and an update would follow the scatter.
  double min_wear_elasticity = 0.02;
  /// The RMS_SA reference (docs/model.md, "Commissioning ratio"): up to this many of a pair's first
  /// records at which no configured K_wear moves the twin's RMS_SA by the update threshold give
  /// the pair's commissioning ratio RMS_SA,meas / RMS_SA,sim (their median in the log); K_wear
  /// updates then match the twin's RMS_SA times that ratio. 0: the thesis's absolute comparison.
  int commissioning_records = 3;
  double pitting_reference_torque_nm = 20.0;   ///< torque of K_pitting's readable scale (PittingScale)
  double pitting_reference_density = 0.10;     ///< density of K_pitting's readable scale
  double k_wear_min_si = 1e-22, k_wear_max_si = 1e-9;
  double correlation_threshold = 0.95;     ///< §7.3.3
  double pitting_interval_cycles = 50000;  ///< ΔN between pitting points (the thesis's j)
  int max_pitting_evaluations = 40;        ///< blue-loop re-runs per K_pitting search
  double min_torque_nm = 0.5, max_torque_nm = 1000.0;
  double min_speed_hz = 0.5, max_speed_hz = 60.0;
  double wear_limit_m = 0.314e-3;          ///< deepest flank point; default 10 % of the pitch-circle tooth thickness
  double pitting_limit = 0.17;             ///< mean pitting density (the thesis's scrap level, §7.4.1)
  double forecast_horizon_cycles = 2e7;
  int forecast_points = 10;                ///< forecast curve samples up to the horizon
  int spread_updates = 4;                  ///< recent K values kept (the correlation search starts from the newest non-zero)
  // --- the posterior of ln K and the interval (docs/model.md, "Posterior and interval")
  /// Prior SD of ln K_wear about the configured initial K: two decades. The initial K is a guess
  /// carried from another regime, and Archard coefficients of one pair differ by decades between
  /// lubricated and dry running (the thesis's own: 3.55e-16 and 1.65e-12 m²/N).
  double prior_log_k_wear_sd = 4.605170185988091;
  /// Random walk of ln K (both coefficients): SD per million cycles. A factor 2 per million cycles
  /// at one SD: the truth's K changes over life (run-in, contamination); the thesis's dry test
  /// moved K_wear by a third within thousands of cycles, so this is no upper bound, and the
  /// innovation gate catches larger jumps.
  double log_k_drift_per_million_cycles = 0.6931471805599453;
  /// Floor of the RMS_SA relative record-to-record scatter: the root-find's 1 % tolerance is the
  /// smallest mismatch the twin resolves, so no scatter estimate below it is believed.
  double rms_sa_relative_sd_floor = 0.01;
  /// Relative SD of an inspected pitted area: pits outlined on a mould (replica) image, whose
  /// edges are a matter of judgement; 10 % is a stated choice, not a measured figure.
  double inspection_area_relative_sd = 0.10;
  /// Relative SD of an inspected combined mean wear depth (a mould's profile against the unworn
  /// one, the thesis's LSCM profiles): a stated choice, not a measured figure.
  double inspection_depth_relative_sd = 0.05;
  int disagreement_records = 8;            ///< recent records in the chi-square check of RMS_SA residuals
  int scatter_records = 64;                ///< records whose residuals (without an update) give the RMS_SA scatter
  double innovation_gate_sd = 3.0;         ///< an update's innovation beyond this many SDs raises the prior variance
  int ics2_onset_records = 5;              ///< first ICS2 values of a pair whose median is the ICS2 onset baseline
  int ics2_trend_records = 10;             ///< recent ICS2-derived densities in the robust trend
  /// ICS2 (low band) at and above which a reading bounds the pitting density from below only
  /// (ics2_saturation_level, forecast_intervals.hpp): a quarter of fully modulated AM noise's ICS2
  /// at the analyser's default H = 3. Infinity: every reading is taken as a density estimate.
  double ics2_saturation = ics2_saturation_level(3);
  /// q: the random walk's variance of ln K per cycle.
  double log_k_q_per_cycle() const { return log_k_drift_per_million_cycles * log_k_drift_per_million_cycles / 1e6; }
  int operating_window_records = 10;       ///< records averaged for the forecast's operating point
  std::size_t max_intervals = 256;         ///< record intervals kept for re-runs (oldest merged beyond)
  /// Throws TwinParameterError naming the first bad value.
  void validate() const;
};

/// An inspection entered by staff.
struct Inspection {
  std::int64_t id = 0;
  double cycles = 0;
  std::optional<double> pitted_area;       ///< fraction of the flank area
  std::optional<double> wear_depth_m;
  std::optional<double> wear_depth_max_m;        ///< the deepest flank point (the mould's profile)
  std::optional<double> wear_depth_relative_sd;  ///< this inspection's depths' relative SD (else the setting)
};

/// A blue-loop state with the step its controller tries next (enough to continue exactly).
struct LoopSnapshot {
  WearState state;
  double next_step_cycles = 0;
};

/// A stretch of the pair's life between two records: (previous end, end_cycles] ran at this
/// operating point with these coefficients. Re-runs replay them.
struct LifeInterval {
  double end_cycles = 0;
  double speed_hz = 0, torque_nm = 0;
  double k_wear_si = 0, k_pitting = 0;
};

struct PittingPoint {
  double cycles = 0;
  double ics2 = 0;
  double density = 0;                      ///< mean predicted (or inspected) pitting density
};

/// Everything the model remembers; the daemon stores it and gives it back at start.
struct ModelMemory {
  bool started = false;                    ///< false: no record yet (the loop starts unworn at 0 cycles)
  LoopSnapshot current, wear_anchor, pitting_anchor;
  double k_wear_si = 0, k_pitting = 0;
  std::vector<LifeInterval> intervals;     ///< since the older anchor
  /// K_wear's stretches from the pair's start (depth_calibration.hpp), kept past the anchors: a rate
  /// read between two inspections is put at today's pace with the K its path ran at there, which the
  /// intervals, pruned to the older anchor, no longer hold once both anchors have passed them.
  std::vector<KStretch> k_wear_history;
  std::vector<PittingPoint> pitting_points;   ///< the last three
  bool pitting_calibrated = false;
  std::int64_t calibration_inspection_id = 0; ///< the newer inspection of the last calibration
  bool ics2_scale_valid = false;
  double ics2_scale_ics2 = 0, ics2_scale_density = 0, ics2_scale_slope = 0;  ///< linear: D = density + slope (ICS2 − ics2)
  Ics2ScaleForm ics2_scale_form = Ics2ScaleForm::linear;   ///< square_root: the one-inspection scale (forecast_intervals.hpp)
  double ics2_scale_baseline = 0;          ///< the onset baseline ICS2 of a square_root scale
  std::vector<double> recent_k_wear, recent_k_pitting;   ///< the last spread_updates values set by updates (not the initial guess)
  std::vector<std::array<double, 2>> recent_operating_points;  ///< (speed, torque) of the last records
  /// The posteriors of ln K_wear (prior at the start of a pair) and ln K_pitting (none before
  /// its first calibration).
  LogPosterior log_k_wear, log_k_pitting;
  /// ln(RMS_SA meas / sim) of the last records before any update there, and whether an update was
  /// tried at that record (the scatter estimate takes only those without).
  std::vector<std::array<double, 2>> rms_residuals;
  double pitting_calibration_var = 0;      ///< var ln K of the last calibration from the inspected areas
  double scale_residual_sum_sq = 0;        ///< Σ (ln K gap of the ICS2 scale's density vs the model's at pitting points)²
  std::uint64_t scale_residual_count = 0;
  int ics2_scale_inspections = 0;          ///< 1: the one-inspection scale; 2: two inspections
  double ics2_scale_baseline_sd = 0;       ///< ICS2 SD of the onset baseline (one-inspection scale)
  double last_ics2_calibration_cycles = -1;   ///< the last one-inspection calibration (−1: none)
  double ics2_scale_density_1 = 0;         ///< A1 of a two-inspection scale (its second point); 0: none
  bool k_wear_last_insensitive = false;    ///< the last K_wear update did not identify K_wear (RMS_SA insensitive, or no K reproduced the record)
  double k_wear_elasticity = 1.0;          ///< d ln RMS_SA / d ln K_wear of the last kept K_wear update (1 before any)
  /// The last K_wear an update identified (the initial K before any; 0: unknown, taken as k_wear_si).
  /// An upper-bound update sets K_wear to min(this, the knee), so a bound never becomes the estimate.
  double k_wear_identified_si = 0;
  /// The commissioning ratio RMS_SA,meas / RMS_SA,sim the K_wear updates match against (1: none
  /// established), the (cycles, ln meas/sim) of the records that established it, and whether it is
  /// closed (a record at which wear can move RMS_SA, or commissioning_records reached).
  double rms_sa_reference_ratio = 1.0;
  std::vector<std::array<double, 2>> rms_sa_reference_records;
  bool rms_sa_reference_closed = false;
  /// The profile-shape term (profile_shape.hpp), read at the last kept K_wear update: the
  /// concentrated-wear shape's combined mean depth over the model's at the model's RMS_SA (0: not
  /// read), that shape's deepest point over its mean, d ln RMS_SA / d ln depth there (1 when not
  /// read) and the update's cycles (−1: none).
  double shape_depth_ratio = 0, shape_peak_ratio = 0, shape_depth_elasticity = 1.0, shape_cycles = -1;
  /// (cycles, ICS2 low) of the pair's records: ICS2 at an inspection's cycles. The daemon rebuilds
  /// it from the model's stored runs rather than storing it in the state.
  std::vector<std::array<double, 2>> ics2_series;
  /// The inspected wear depths as readings of ln ρ = ln(measured / model combined mean depth) at
  /// their cycles, taken when each inspection was first seen (depth_calibration.hpp).
  std::vector<DepthRatioMeasurement> depth_ratio_points;
  /// The inspections' deepest point over their mean, ln P = ln(deepest / mean) at their cycles. It
  /// depends on the inspections alone, so it is rebuilt from them at every record, not stored.
  std::vector<DepthRatioMeasurement> peak_ratio_points;
  /// The pitted-area inspections (cycles, area) at or before the newest record: the growth law's
  /// readings (pitting_growth.hpp). Rebuilt from the inspections at every record, not stored.
  std::vector<std::array<double, 2>> pitted_area_points;
  std::uint64_t records_used = 0, k_wear_updates = 0, k_pitting_updates = 0;
};

/// The forecast's operating point (speed, torque) from the newest records' (oldest first): their mean
/// since the last load step. A step splits the records where the two sides' mean torques differ most;
/// it counts when that difference is at least `step_fraction` of the newer side's mean and
/// `step_standard_errors` standard errors, the records' scatter read from their successive
/// differences (robust to the steps; a scattered load is averaged, not cut); the newer side is
/// searched again. Empty input: {0, 0}.
std::array<double, 2> forecast_operating_point(const std::vector<std::array<double, 2>>& points, double step_fraction,
                                               double step_standard_errors);

/// Pearson's correlation coefficient of two triples (Eq. 7.15); NaN when either has no spread.
double pearson3(const std::array<double, 3>& x, const std::array<double, 3>& y);

/// The golden-section line search the updates use (gearwatch/numeric/line_search.hpp).
using numeric::golden_section_maximise;
using numeric::LineSearchResult;

/// A point of the K_wear root-find: x = ln K_wear, g = ln(RMS_SA,sim / RMS_SA,meas); g = +inf where
/// a flank passes the depth limit before the record (the K is too large: a bracket's upper end).
struct LogKPoint {
  double x = 0, g = 0;
};

class TwinModel {
 public:
  /// Throws TwinParameterError on bad settings or a memory that does not fit them.
  TwinModel(twin::GearboxParameters params, ModelSettings settings, RmsSaSimulator simulator, ModelMemory memory = {});

  /// One record: advances the blue loop to its cycles at its speed and torque, uses the
  /// inspections of this gear pair (any order; those after the record's cycles wait), applies the
  /// purple loop and forecasts. Never throws on bad data: it says what it could not do.
  ModelRunReport observe(const ModelObservation& observation, const std::vector<Inspection>& inspections);

  /// A new gear pair: unworn, initial coefficients, no history.
  void start_new_pair();

  const ModelMemory& memory() const noexcept { return memory_; }
  const ModelSettings& settings() const noexcept { return settings_; }
  const twin::GearboxParameters& parameters() const noexcept { return params_; }
  /// K_pitting's readable scale for this pair and settings.
  const PittingScale& pitting_scale() const noexcept { return pitting_scale_; }
  /// Forecast from the current state (what observe() adds to its report).
  Forecast forecast() const;
  /// The wear rate read from the two inspected depths (depth_calibration.hpp: newest_rate_reading) on
  /// the model's current path, against the model's pace at today's K_wear; not valid without one.
  RateReading wear_rate_reading() const;

 private:
  BlueLoop loop_at(const LoopSnapshot& from) const;
  /// Replays the stored intervals after `from` up to `until`, with optional overrides of K_wear
  /// or K_pitting for cycles > override_from. Returns false if the depth limit stopped it.
  /// Snapshots at the anchors' cycles replace them when `recapture` is set; the inspected depths
  /// after `from` are then read against the re-run's path.
  struct Override {
    std::optional<double> k_wear, k_pitting;
    double from_cycles = 0;
  };
  bool rerun(const LoopSnapshot& from, const Override& o, LoopSnapshot& out, bool recapture_anchors);
  /// The inspected depths after the path's start read again against the re-run's path (`path`: the
  /// start and the records' ends, linear between).
  void reread_depth_points(const std::vector<PathPoint>& path);
  void check_k_wear(const ModelObservation& obs, ModelRunReport& report);
  /// A K_wear trial's state at a record where a K_pitting calibration set the pitting profile:
  /// that profile, and the pitting anchor (recaptured by the re-run) on it.
  void hold_calibrated_pitting(LoopSnapshot& at_record);
  /// After the record's K_wear check: a calibration here moves both anchors to the record.
  void accept_calibrated_state();
  /// The twin's RMS_SA at the record; nullopt (the issue in the report) when there is none.
  std::optional<double> simulate_record(const ModelObservation& obs, ModelRunReport& report);
  /// A commissioning record (true): its ln(meas/sim) joins the commissioning ratio, no K_wear update.
  bool commission_rms_sa(const ModelObservation& obs, double measured, double simulated, ModelRunReport& report);
  /// Whether K_wear at either end of the configured range, from the wear anchor, moves the twin's
  /// RMS_SA at this record by the update threshold (or passes the depth limit before it).
  bool wear_can_move_rms_sa(double simulated, const twin::OperatingPoint& op);
  /// One K_wear candidate: the blue loop re-run from the wear anchor with K, and its RMS_SA.
  struct WearTrial {
    double k = 0, sim = 0;
    double log_error = 0;                  ///< ln(sim / measured): the root-find's function
    LoopSnapshot state;
    ModelMemory memory;
  };
  /// What a K_wear update searches with, and the best candidate it found.
  struct WearSearch {
    LoopSnapshot anchor;
    ModelMemory saved;
    twin::OperatingPoint op;
    double measured = 0;
    double k0 = 0, sim0 = 0;
    int evaluations = 0;
    std::optional<WearTrial> best;
    std::string why;                       ///< why it stopped, when it did not converge
    bool depth_limited = false;            ///< the last trial stopped at the depth limit before the record
    double root_elasticity = std::numeric_limits<double>::quiet_NaN();   ///< root-find: d ln RMS_SA / d ln K near the root
    std::vector<LogKPoint> points;         ///< every K tried: (ln K, ln sim/meas), +inf past the depth limit
    std::vector<WearTrial> trials;         ///< the trials that gave an RMS_SA (the knee reading picks one)
  };
  /// The knee reading: the largest K tried whose RMS_SA stays within the convergence tolerance of
  /// the reference (the measurement, or the twin's closest value when that lies above it), and the
  /// smallest K above it that leaves it.
  struct KneeReading {
    WearTrial match;
    LogKPoint rejected;
    double reference = 0;
    int reruns = 0;
  };
  /// Whether the record bounds K_wear from above only: the twin at the current K lies above the
  /// measurement, the closest K reproduces it within the threshold, and the search ended on the
  /// flat part (insensitive, or at the range's lower end).
  bool knee_applies(const WearSearch& search, const KUpdate& u, double simulated) const;
  /// The knee by bisection on ln K between the points the search has; nullopt (reason appended)
  /// when there is none or it lies at the range's lower end (the range's guard, not a knee).
  std::optional<KneeReading> read_knee(WearSearch& search, KUpdate& u, std::string& no_knee);
  /// K_wear = min(last identified, knee), outcome upper_bound; the forecast still counts it as not identified.
  void apply_k_wear_bound(KneeReading& knee, WearSearch& search, KUpdate& u, double simulated, ModelRunReport& report);
  /// The K_wear search by the configured rule (none where no cycles passed since the wear anchor).
  void search_k_wear(WearSearch& search, KUpdate& u);
  /// Whether the best K found is kept: it reproduces the record within the threshold, improves on
  /// the old K, is identified and is no end of the configured range; the reason in search.why if not.
  bool keep_k_wear(WearSearch& search, const KUpdate& u, double simulated) const;
  /// The kept K applied from the wear anchor, or the memory as it was before the search.
  void apply_k_wear_result(bool keep, WearSearch& search, KUpdate& u, double simulated, ModelRunReport& report);
  std::string k_wear_evidence(const WearSearch& search, const KUpdate& u, double ratio, double simulated) const;
  /// A kept update as a measurement of ln K_wear (posterior step, evidence appended).
  void learn_k_wear(KUpdate& u, double simulated, double cycles);
  /// The profile-shape term at a kept update: the concentrated-wear shape at this record's operating
  /// point matched to the model's RMS_SA (`simulated`); stored in the memory, evidence appended.
  void read_profile_shape(const ModelObservation& obs, double simulated, KUpdate& u);
  /// Runs one candidate; on failure sets u.outcome and search.why and returns nullopt.
  std::optional<WearTrial> wear_trial(double k, WearSearch& search, KUpdate& u);
  bool wear_converged(const WearTrial& t, double measured) const;
  void update_k_wear_proportional(WearSearch& search, KUpdate& u);
  void update_k_wear_root_find(WearSearch& search, KUpdate& u);
  /// ln(RMS_SA,sim / meas) at ln K = x; +inf past the depth limit; nullopt when the simulation failed.
  std::optional<double> wear_log_error(double x, WearSearch& search, KUpdate& u);
  /// Geometric steps on ln K (first towards `dir`, then the other way) until the measurement is
  /// bracketed or converged; false with the reason (iteration limit, bound) when neither.
  bool expand_bracket(std::vector<LogKPoint>& pts, int dir, WearSearch& search, KUpdate& u, std::optional<LogKPoint>& converged);
  /// One point of the root-find: ln K = x evaluated and added to `pts`; `converged` set when its
  /// RMS_SA is within the tolerance; `failed` (reason in u, search) when the twin gave no value.
  enum class PointResult { failed, converged, open };
  PointResult evaluate_point(double x, std::vector<LogKPoint>& pts, WearSearch& search, KUpdate& u, std::optional<LogKPoint>& converged);
  /// Insensitive (true, with the reason) when RMS_SA moved by less than min_wear_elasticity · ln 10 over all K tried.
  bool refuse_flat(const std::vector<LogKPoint>& pts, WearSearch& search, KUpdate& u) const;
  /// Illinois inside the bracket; false with the reason (iteration limit, insensitive) when not converged.
  bool refine_bracket(std::vector<LogKPoint>& pts, WearSearch& search, KUpdate& u, std::optional<LogKPoint>& converged);
  /// Of several K whose RMS_SA meets the measurement, the first along the wear path from the
  /// anchor (the smallest): `root` replaced, and search.best with it, when the range's lower end
  /// lies on the other side of the measurement than the K just below the root. False (reason in
  /// u, search) when the smaller root was bracketed but not reached.
  bool seek_first_crossing(std::vector<LogKPoint>& pts, LogKPoint& root, WearSearch& search, KUpdate& u);
  /// Converged at `root`: identified when |d ln RMS_SA / d ln K| there reaches min_wear_elasticity.
  void finish_root(const LogKPoint& root, const std::vector<LogKPoint>& pts, WearSearch& search, KUpdate& u);
  void calibrate_pitting(const std::vector<Inspection>& inspections, double cycles, ModelRunReport& report);
  /// Inspections with a wear depth not yet read: each a reading of ln ρ against the model's combined
  /// mean depth at its cycles (linear between the previous record's state and the current one).
  void read_depth_inspections(const std::vector<Inspection>& inspections, double prev_cycles, double prev_mean,
                              ModelRunReport& report);
  /// The posterior of ln ρ now (valid false without depth inspections).
  /// Inspections with both a mean and a deepest wear depth: each a reading of ln P (rebuilt); an
  /// unusable one is said at the first record after `since`.
  void read_peak_inspections(const std::vector<Inspection>& inspections, double since, double now, ModelRunReport& report);
  LogPosterior depth_ratio_now() const;
  LogPosterior depth_ratio_prior() const;
  /// The level (ln ρ now, ln P) and the rate read from the inspections' increments, jointly
  /// (depth_calibration.hpp); nullopt without a rate reading.
  std::optional<LevelRate> level_and_rate(const LogPosterior& p, const LogPosterior& peak, double model_peak, RateReading& rate) const;
  /// The depth now carried from the newest inspected depth by the rate read from two (depth_calibration.hpp:
  /// rate_carried_depth); not valid without a rate reading or before any record past the newest inspection.
  CarriedDepth carried_depth_now() const;
  /// The wear crossings from the level and the rate; false (nothing set) without a rate reading.
  bool wear_crossings_by_rate(Forecast& f, const LogPosterior& p, const LogPosterior& peak, double model_peak,
                              const WearLoopOptions& deep) const;
  /// The posterior of ln P, the true deepest point over the true mean, now (valid false without
  /// inspections that give both).
  LogPosterior peak_ratio_now(double model_peak) const;
  /// An inspection's relative SD of its depths: its own where stated, the setting otherwise.
  double inspection_depth_sd(const Inspection& i) const;
  /// With depth inspections: the depth estimate and interval and the wear forecast's nominal and
  /// ends from the calibrated ρ (the model's crossing of limit / ρ); false (nothing changed) without.
  bool apply_depth_calibration(Forecast& f, const WearLoopOptions& o) const;
  /// Two pitted areas (A0 at N0, A1 at N1): K_pitting by bisection on ln K so that the model, its
  /// profile rescaled to A0 at N0, pits A1 by N1; the current pitting profile from that run.
  struct CalibrationPoints {
    double n0 = 0, a0 = 0, n1 = 0, a1 = 0;
  };
  double calibrate_k(const CalibrationPoints& c, double cycles, KUpdate& u, std::string& why, int& evaluations);
  /// One inspection and the ICS2 trend: the onset-baseline scale, and the second point from it.
  void calibrate_from_one_inspection(const Inspection& first, double cycles, ModelRunReport& report);
  /// §7.3.3 steps 3–4 at a pitting point: Pearson's C of the last three (ICS2, density) pairs, and
  /// K_pitting maximising it when C is below the threshold (0 when it cannot be reached).
  void check_pitting(const ModelObservation& obs, ModelRunReport& report);
  /// A pitting point is due: calibrated, an ICS2 value, a pitting interval since the last point.
  bool pitting_point_due(const ModelObservation& obs) const;
  /// The ICS2 scale's density against the model's at a new point, in ln K (the scale's scatter).
  void record_scale_residual(double ics2, double density_now);
  /// A new pitting point (the last three kept); the pitting anchor moves to the current state.
  void push_pitting_point(double cycles, double ics2, double density);
  /// The two previous points' densities and the three ICS2 values of Eq. 7.15.
  struct PittingTriple {
    std::array<double, 2> density;
    std::array<double, 3> ics2;
    double correlation(double density_now) const;
  };
  /// A triple with an ICS2 at or above `ics2_saturation`: no K_pitting search; an `insensitive`
  /// update says why and the point is kept. True when it was.
  bool saturated_triple(const PittingTriple& triple, double cycles, double density_now, double c_now, ModelRunReport& report);
  struct PittingSearch {
    double best_k = 0, best_c = -2.0;
    int evaluations = 0;
  };
  /// The mean density now with K_pitting = k from the pitting anchor (memory_ reset to `saved`).
  double pitting_density_with(const ModelMemory& saved, double k, int& evaluations, LoopSnapshot* out);
  /// Eqs. 7.16–7.17: K = 0, then a bracket walked uphill on ln K by decades and a golden section.
  PittingSearch search_k_pitting(const ModelMemory& saved, const PittingTriple& triple);
  /// Converged when the threshold is reached with K > 0; else set_to_zero (best_k 0) and the reason.
  std::string judge_pitting_search(PittingSearch& search, double ics2, double last_ics2, KUpdate& u) const;
  /// The search's K re-run from the pitting anchor for real (anchors recaptured) and applied.
  void apply_k_pitting_search(const ModelMemory& saved, const PittingTriple& triple, PittingSearch& search, KUpdate& u);
  double ics2_at(double cycles) const;
  /// The filter step of ln K_wear / ln K_pitting with a measurement z of variance r; returns the evidence.
  std::string learn(LogPosterior& posterior, double z, double r, double cycles) const;
  double rms_scatter_sd() const;           ///< the RMS_SA relative scatter: residuals without an update, floored
  double pitting_measurement_var() const;  ///< var ln K_pitting of a calibration: the areas and the scale's scatter
  void remember_residual(double log_residual, bool updated);
  struct Crossing {
    std::optional<double> wear, pitting;
  };
  /// The ICS2-derived density now (Theil–Sen trend of the newest records and the latest), its SD,
  /// and the model's density: the measured side of the pitting forecast.
  struct Ics2Evidence {
    bool valid = false;
    double trend = 0, latest = 0, slope = 0, sd = 0, model = 0;
    std::size_t records = 0;
    /// The higher of the latest ICS2 and the trend's ICS2 now, and whether it reaches the
    /// saturation level: then trend and latest are lower bounds of the density.
    double ics2 = 0;
    bool saturated = false;
  };
  Crossing run_forecast(double k_wear, double k_pitting, const WearLoopOptions& o, std::vector<ForecastPoint>* curve) const;
  /// The forecast run from another start (the current state with another pitting level).
  Crossing run_forecast(const LoopSnapshot& from, double k_wear, double k_pitting, const WearLoopOptions& o,
                        std::vector<ForecastPoint>* curve) const;
  /// The same with another wear limit on the model's deepest point (the calibrated crossing).
  Crossing run_forecast(const LoopSnapshot& from, double k_wear, double k_pitting, const WearLoopOptions& o,
                        std::vector<ForecastPoint>* curve, double wear_limit) const;
  /// The 90 % interval: the posteriors now, the disagreement terms, the ends' forecast runs.
  void set_intervals(Forecast& f, const Crossing& nominal, const WearLoopOptions& o, const Ics2Evidence& ev) const;
  /// The chi-square check of the recent RMS_SA residuals: the K_wear SD's widening (1: none).
  double check_recent_residuals(Forecast& f) const;
  /// ln K_wear's posterior now, no narrower than the prior's when K_wear was not identified.
  LogPosterior wear_posterior_now(Forecast& f) const;
  /// The model-form term of ln K_wear from the stored residuals.
  ModelFormTerm rms_model_form(Forecast& f, const LogPosterior& pw) const;
  /// The model's pitting path against the ICS2-derived density (the K_pitting variance's gap term).
  PittingMiss pitting_path_miss(Forecast& f, const LogPosterior& pp, const Ics2Evidence& ev) const;
  struct IntervalInputs {
    LogPosterior wear, pitting;
    double widen = 1.0, wear_form_var = 0, pitting_miss_var = 0;
  };
  /// The ends: K at the quantiles with the random walk to each end's own crossing (two passes).
  void interval_ends(Forecast& f, const Crossing& nominal, const WearLoopOptions& o, const IntervalInputs& in, LogInterval& lw,
                     LogInterval& lp, std::vector<ForecastPoint>* fast_curve = nullptr,
                     std::vector<ForecastPoint>* slow_curve = nullptr) const;
  /// The interval holds the nominal forecast.
  static void hold_nominal(Forecast& f);
  /// The depth interval and the wear interval's ends widened by the profile-shape term (the
  /// concentrated shape's deepest point along the model's mean-depth paths, nominal, fast and slow).
  void apply_profile_shape(Forecast& f, const std::vector<ForecastPoint>& fast, const std::vector<ForecastPoint>& slow) const;
  /// The current state with its pitting profile rescaled to a mean density.
  LoopSnapshot with_mean_pitting(double density) const;
  /// The model's density at the pitting limit while the ICS2-derived one is not: no "0 left" from
  /// the model alone; the nominal and far end from the measured density, flagged.
  void check_model_past_pitting_limit(Forecast& f, const WearLoopOptions& o, const Ics2Evidence& ev) const;
  Ics2Evidence ics2_evidence() const;
  /// SD of the ICS2-derived density `d`: the scale's inspected areas (extrapolated) and the ICS2 scatter.
  double ics2_density_sd(double d) const;
  /// The ICS2 <-> density scale the memory holds (valid only with memory_.ics2_scale_valid).
  Ics2Scale ics2_scale() const;
  void check_ics2_trend(Forecast& f, const Ics2Evidence& ev) const;
  /// A saturated reading: the density is at least the ICS2-derived one, its upper end unknown. The
  /// near end and the nominal from the model's own state (from the lower bound where the model lies
  /// below it), the far end from the lower bound less its SD at the interval's level, flagged.
  void apply_ics2_lower_bound(Forecast& f, const WearLoopOptions& o, const Ics2Evidence& ev) const;
  /// The pitted-area inspections up to `now` into memory_.pitted_area_points.
  void read_pitted_area_inspections(const std::vector<Inspection>& inspections, double now);
  /// The growth law's readings: the inspections and the unsaturated ICS2-derived densities, one
  /// per `pitting_interval_cycles` (the median of its records).
  std::vector<DensityReading> growth_law_readings() const;
  /// With two or more inspections and three or more reading cycles the pitting forecast follows the
  /// fitted growth law dD/dN = a D^b; its near end stays 0 where a measurement put it there.
  void apply_growth_law(Forecast& f) const;
  /// Eq. 7.8's form through the two newest pitted-area inspections, its exponent read from them
  /// (pitting_exponent_from_inspections): the nominal replaced, the interval joined with the path's.
  void apply_inspection_exponent(Forecast& f) const;
  /// The ICS2-derived density of the newest ICS2 values of the pair, (cycles, density).
  std::vector<std::array<double, 2>> ics2_density_series(std::size_t newest) const;
  void remember_k(std::vector<double>& recent, double k) const;
  void prune_intervals();
  void apply_k(bool wear, double value, double from_cycles);

  twin::GearboxParameters params_;
  ModelSettings settings_;
  RmsSaSimulator simulator_;
  ModelMemory memory_;
  BlueLoop loop_;
  PittingScale pitting_scale_;
  /// The pitting profile a calibration set at the record being observed (none otherwise): the
  /// record's K_wear check re-runs from the last K_wear anchor and keeps it at the record.
  std::optional<std::vector<double>> calibrated_pitting_here_;
};

}  // namespace gearwatch::wear
