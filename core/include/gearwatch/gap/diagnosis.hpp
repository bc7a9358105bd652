#pragma once
// The sim-to-real gap diagnosis: localise the discrepancy between measured records and the twin's
// simulation of the same operating point and wear state by family, attribute it to candidate
// effects fitted on training records, and quantify the gap before/after on held-out records.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "gearwatch/gap/features.hpp"
#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/twin/gearbox_parameters.hpp"
#include "gearwatch/types/gap_report.hpp"
#include "gearwatch/types/record.hpp"

namespace gearwatch::gap {

/// One measured record and the twin's simulation at the same speed, torque and wear state
/// (same sample rate; the twin's channel is compared with `DiagnosisSettings::channel`).
struct DiagnosisInput {
  Record measured;
  Record twin;
};

/// The twin re-run with one candidate's addition at `values` (a point of its `rerun_grid`, named by
/// `rerun_parameter_names`), at the operating point of `twin_record` (its speed, torque and rate),
/// `duration_s` long (twin_duration_s(): the twin is deterministic, so a rerun need not be as long
/// as the record it stands for). Candidates that change the twin's dynamics (misalignment: a pair
/// carrying load over part of the face stiffens with load; tip relief: a relieved tip engages as the
/// load deflects it) have no spectral form that stands in for them; with a rerun the diagnosis fits
/// them over their grid. The eccentricity candidate is re-run too, at run_out_response_reruns(), for
/// the twin's response to a run-out (when its spectral form ranks among the two best). Throwing
/// std::invalid_argument refuses the diagnosis.
using TwinRerun = std::function<Record(CandidateEffect effect, const std::vector<double>& values,
                                       const Record& twin_record, double duration_s)>;

struct DiagnosisSettings {
  int channel = 0;                 ///< measured channel compared with the twin's casing signal
  /// The twin the counterparts were simulated with: its linearised model gives each record's
  /// response to a run-out (the eccentricity candidate). Must match the twin records.
  twin::GearboxParameters twin_parameters;
  int bootstrap_resamples = 200;   ///< block bootstrap over revolutions
  std::uint64_t seed = 1;          ///< bootstrap resampling seed (deterministic reports)
  std::size_t bootstrap_block_revolutions = 2;  ///< revolutions per bootstrap block
  int candidate_bootstrap_resamples = 20;       ///< for each candidate's own held-out intervals
  double floor_db = -60;           ///< bins below this (re the twin's total line power) compare as equal
  /// A line family's gap (shaft orders, mesh harmonics, sidebands) smaller than this is never
  /// significant. Synchronous averages keep only what repeats every revolution: the rig without
  /// effects sits well under it off the twin there, and a casing's effect on the mesh harmonics is
  /// over it.
  double min_gap_db = 0.5;
  /// The same for the broadband part and the fixed-frequency bands (which read the broadband bins
  /// too). They hold what no model of the gearbox's synchronous vibration has (sensor noise, the
  /// random part of sliding) and move with the acquisition, so the rig without effects sits further
  /// off the twin there than in the line families (the figures: docs/gap.md).
  double min_residual_gap_db = 1.0;
  double fixed_bands_per_octave = 12;  ///< Hz bands of the fixed-frequency family (resonances, ζ ≳ 0.02)
  double accept_ic_drop = 0.3;     ///< held-out information criterion drop an effect must bring to be chosen
  double min_shrinkage = 0.1;      ///< … and the held-out shrinkage in its own families
  int max_effects = 3;             ///< greedy additions at most
  /// false: localise only ("where"): the held-out gaps before, with no candidate fitted, ranked or
  /// chosen (report.candidates and report.chosen stay empty, report.after equals report.before).
  bool attribute = true;
  /// When set, candidates with a rerun grid (rerun_grid()) are fitted by re-running the twin; when
  /// empty they fall back to their spectral forms.
  TwinRerun rerun_twin;
  /// A twin run standing for a record lasts the record's length, but at most the longer of these
  /// two (twin_duration_s()): the diagnosis asks its reruns for that, and a caller may simulate its
  /// counterparts that long too. The twin has no noise and runs at a steady speed, so its lines
  /// repeat every revolution, so a longer run changes no family's distance by more than a small
  /// fraction of `min_gap_db`. Each is one twin simulation, the diagnosis's largest cost.
  double twin_min_seconds = 2.0;
  double twin_min_revolutions = 20;  ///< input revolutions: enough for the bootstrap at low speed
  std::size_t min_revolutions = 4; ///< whole input revolutions a record needs
  /// K_wear inference (thesis Eq. 7.13 taken to its fixed point: the K_wear at which the twin's RMS_SA
  /// equals the measured one). When set, the K_wear the twin's records were simulated with; the
  /// report then carries the K_wear inferred with the twin alone and with the chosen effects.
  std::optional<double> reference_k_wear;
  /// d ln RMS_SA / d ln K_wear of the twin at the records' wear state, from the caller (e.g. twin
  /// runs at scaled wear depths); 1 is Eq. 7.13's proportional update. Must be finite and non-zero.
  double rms_sa_wear_elasticity = 1.0;
  /// The same per held-out record, in their order (empty: `rms_sa_wear_elasticity` for all). The
  /// twin's sensitivity to wear differs with load (at light load the worn profile is a larger share of
  /// the deflection), so the records' log ratios are combined by least squares,
  /// ln(K/K_ref) = Σ e_i ln r_i / Σ e_i², which weights the records that can tell K the most. Each
  /// must be finite.
  std::vector<double> rms_sa_wear_elasticities;
  /// A record whose |e| is below this cannot tell K_wear (a 1 % RMS_SA difference would move K by
  /// more than 20 %) and weighs nothing; with no record left, no K_wear is inferred. Near an unworn
  /// state, where the wear depth is a tiny share of the profile's own deviation, e is near 0.
  double min_rms_sa_wear_elasticity = 0.05;
  int rms_sa_harmonics = 2;        ///< N of RMS_SA(N) (thesis Eq. 7.1), the measurement's setting
  /// Gaps at the resolution of a line or a band (report.features; features.hpp): every record,
  /// training and held out, against the twin alone, over `bootstrap_resamples` draws each.
  bool find_features = true;
  FeatureSettings features;
};

/// The practical minimum of a family's gap: `min_residual_gap_db` for the broadband and
/// fixed-frequency families, `min_gap_db` for the line families.
double min_gap_db_of(const DiagnosisSettings& settings, FamilyKind family) noexcept;

/// The root-mean-square distance (dB) of the resolved gaps among `families`; 0 when none is resolved.
double families_distance_db(const std::vector<FamilyGap>& gaps, const std::vector<FamilyKind>& families);

/// RMS_SA(N) (thesis Eq. 7.1) from a record's input-order lines: the root of the summed power of the
/// first `harmonics` mesh harmonics (the TSA's harmonics). Empty when the lines do not reach the
/// N-th harmonic or hold no power there.
std::optional<double> rms_sa_of_lines(const SpectralSummary& s, int pinion_teeth, int harmonics);
/// The same read from a record's `channel` through the diagnosis's own order tracking
/// (RecordSpectra, which throws std::invalid_argument for a record it cannot read).
std::optional<double> rms_sa_of_record(const Record& record, int channel, const GearPairSpec& gears, int harmonics);

/// The wear-depth factors at which a caller simulates the twin to read d ln RMS_SA / d ln K_wear
/// (depth ∝ K_wear at a constant operating point, Archard), and that central difference in the log.
inline constexpr double kElasticityDepthLow = 0.8, kElasticityDepthHigh = 1.25;
double rms_sa_wear_elasticity(double rms_sa_at_low_depth, double rms_sa_at_high_depth);

/// The K_wear that makes the model's RMS_SA equal the measured one when RMS_SA ∝ K^elasticity near
/// the reference: K_ref · (RMS_meas / RMS_model)^(1/elasticity). Throws std::invalid_argument for
/// non-positive RMS values or K_ref, or a zero/non-finite elasticity.
double inferred_k_wear(double rms_sa_measured, double rms_sa_model, double reference_k_wear, double elasticity);

/// How long a twin run standing for `record` (a rerun of its twin, or the twin counterpart of a
/// measured record) needs to last: the record's length, but at most the longer of
/// `twin_min_seconds` and `twin_min_revolutions` at its speed.
double twin_duration_s(const Record& record, const DiagnosisSettings& settings);

/// Throws std::invalid_argument naming the reason for inputs that cannot be diagnosed (no training
/// or no held-out records, mismatched rates, records shorter than the minimum). Families the records
/// cannot resolve (e.g. fixed_frequency from a single speed) come back with resolved = false and
/// the reason, not as an error.
GapReport diagnose(const std::vector<DiagnosisInput>& training, const std::vector<DiagnosisInput>& held_out,
                   const GearPairSpec& gears, const DiagnosisSettings& settings = {});

}  // namespace gearwatch::gap
