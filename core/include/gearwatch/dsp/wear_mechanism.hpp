#pragma once
// Wear-mechanism identification over a record history (thesis §4.4): a monotonic (increasing)
// ICS2 trend in the low carrier band and not the high band -> fatigue pitting; high and not low
// -> abrasive wear; both -> both; neither -> none; too short a history -> undetermined.
// A band "rises" when its rise is both significant and material:
// - significant: a mixture over change points of test-martingales on the sequential ranks of the
//   band's history (rising_change_evidence) reaches 2/alpha, so re-deciding at every new record keeps the chance
//   that a stationary history ever raises a verdict below the configured significance, however
//   long the history grows (Ville's inequality);
// - material: the newest ICS2 stands at least the band's floor above the lowest earlier value
//   of the history: material_ics2_rise(), raised to a multiple of the wander of the band's own
//   healthy baseline once that is measured (band_material_floor), before that to the first records'
//   guard against a wander of up to half the floor (incomplete_baseline_floor). A band holding a
//   wear vibration (mesh-modulated with its own ICS2 I_s) and independent stationary content reads
//   ICS2 = share^2 x I_s, share = the wear vibration's part of the band's power. A band "carries" a
//   mechanism when that share reaches
//   settings.wear_min_band_share (default 1/2: the wear vibration is at least as strong as
//   everything else in the band), taking I_s as the ICS2 of noise amplitude-modulated at depth 1/2
//   (0.2006; a single tooth pair's sliding speed, zero at the pitch point, gives 0.397): 0.050 at
//   the defaults. Rank evidence alone cannot tell a band that gains a trace of another band's
//   modulation (a share of a few percent, ICS2 of a few 1e-3) from one that fills with it. The
//   floor is far above the estimation noise of ICS2: a band of stationary Gaussian noise with
//   N = bandwidth x duration independent samples reads H x (1 + 1/2 + ... + 1/(2 tol + 1)) / N
//   on average (3.5e-4 for the 2-13 kHz band of a 2 s record).
// Mann-Kendall (tie-corrected variance, normal approximation, two-sided) and Spearman's rho
// describe the trend alongside. Jumps of the ICS2-selected carrier band are flagged.
#include <array>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "gearwatch/types/wear_mechanism.hpp"

namespace gearwatch::dsp {

struct SignalProcessingSettings;

struct WearHistoryPoint {
  double cycles = 0.0;              ///< input-shaft revolutions (or any monotonic life measure)
  double ics2_low = 0.0;            ///< ICS2 in the pitting (low) carrier band; NaN = not available
  double ics2_high = 0.0;           ///< ICS2 in the abrasion (high) carrier band; NaN = not available
  double selected_centre_hz = 0.0;  ///< centre of the ICS2-selected band; NaN = not available
  double selected_ics2 = std::numeric_limits<double>::quiet_NaN();  ///< ICS2 in that band; NaN = not available
};

struct TrendTest {
  std::size_t points = 0;
  double mann_kendall_s = 0.0;
  double mann_kendall_z = 0.0;
  double p_value = 1.0;             ///< two-sided
  double spearman_rho = 0.0;
  bool increasing = false;          ///< significant at the configured level with S > 0 (trend_test);
                                    ///< in a WearMechanismVerdict: significant_rise and material
  bool decreasing = false;          ///< significant with S < 0 (reported, not a wear signature)
  // identify_wear_mechanism only:
  double rising_evidence = 1.0;     ///< e-value of a rise at the newest point
  bool significant_rise = false;    ///< rising_evidence reached rising_evidence_threshold
  double rise = 0.0;                ///< newest ICS2 minus the lowest earlier one (0 with < 2 points)
  bool material = false;            ///< rise >= floor.floor (always, when that is 0)
};

/// Mann-Kendall and Spearman on (x, y) pairs, ordered by x; pairs with a non-finite y are dropped.
TrendTest trend_test(std::span<const double> x, std::span<const double> y, double significance);

/// Smallest number of points at which a perfectly monotonic series can reach `significance`.
std::size_t minimum_points_for_trend(double significance);

/// Evidence that y rises after some change point, as a test-martingale (an "e-value") at the newest
/// point. Pairs are ordered by x, non-finite y dropped. The j-th point's sequential rank gives
/// D_j = sum_{i<j} sign(y_j - y_i); for an exchangeable (stationary, no change) sequence the D_j are
/// independent, uniform on {-(j-1), -(j-3), ..., j-1}, with E exp(lambda D_j) = sinh(j lambda) /
/// (j sinh lambda), so each bet factor e_j(lambda) = exp(lambda D_j) j sinh(lambda) / sinh(j lambda)
/// has mean 1. A change after b baseline points bets from point b + 1 on:
/// L_b(n) = prod_{j=b+1..n} e_j (1 before), a test-martingale of its own. The evidence mixes them,
///   M_n = sum_{b>=1} change_point_prior(b) sum_k w_k L_b(n; lambda_k),
/// with prior weights summing to 1, so M_n is again a test-martingale: P(M_n >= 1/a for some n) <= a
/// for every history length (Ville), the guarantee of a single trend martingale, while a baseline of
/// any length costs only ln(b(b+1)) instead of the bets lost on its noise order. Ties only shrink
/// D_j towards 0, which keeps M a supermartingale. Half the bet weight is on lambda = 3 (each point
/// after the change the highest so far), the rest on 1 and 0.35 (a noisy or saturating rise).
double rising_change_evidence(std::span<const double> x, std::span<const double> y);

/// The prior weight of a change after b baseline points: 1 / (b (b + 1)) (b >= 1; 0 for b = 0), which
/// sums to 1. b = 1 is a rise from the first point (the first point has no rank to bet on).
double change_point_prior(std::size_t baseline_points);

/// The evidence a band needs for a rising verdict: 2 / significance (each band gets half of the
/// significance, so a stationary channel raises any wear verdict with probability <= significance).
double rising_evidence_threshold(double significance);

/// Smallest number of points at which a perfectly rising series reaches rising_evidence_threshold.
std::size_t minimum_points_for_evidence(double significance);

/// After a flat (tied) baseline of `baseline_points` points, the number of strictly rising points
/// at which rising_change_evidence first reaches rising_evidence_threshold.
std::size_t post_change_points_for_evidence(std::size_t baseline_points, double significance);

/// ICS2 (Eq. 4.3, H harmonics) of a band holding only Gaussian noise whose amplitude is modulated
/// as 1 + depth cos(gear-mesh angle): its squared envelope's mean is 1 + depth^2/2, its lines
/// depth at the mesh order and depth^2/4 at twice it, so
/// ICS2 = (depth^2 + [H >= 2] depth^4/16) / (1 + depth^2/2)^2 (0.2006 at depth 1/2, H >= 2).
double am_noise_ics2(double depth, int harmonics);

/// The least rise of a band's ICS2 that is material (see the file comment):
/// settings.wear_min_band_share^2 x am_noise_ics2(1/2, settings.ics2_harmonics); 0.050 at the
/// defaults. 0 when the share is 0 (significance alone decides).
double material_ics2_rise(const SignalProcessingSettings& settings);

/// Where a band's materiality floor came from (band_material_floor).
enum class FloorSource {
  configured,            ///< settings.wear_baseline_records is 0: material_ics2_rise alone
  baseline_incomplete,   ///< fewer than kMinimumBaselinePoints earlier finite values: the configured floor
                         ///< (band_material_floor); the verdict raises it to incomplete_baseline_floor
  baseline_named_wear,   ///< the verdict named wear at the baseline's last record: not a healthy baseline
  baseline,              ///< max(configured, kWanderFloorMultiple x the baseline's wander bound); the
                         ///< baseline may still be growing (baseline_points < wear_baseline_records)
};

/// The floor is this many times the healthy band's wander SD: a rise of that size, measured from
/// the lowest earlier point, is out of reach of the wander for AR(1) correlation up to
/// kWanderMaxCorrelation (docs/dsp.md, figures: false alarms).
inline constexpr double kWanderFloorMultiple = 6.0;
/// The largest lag-one correlation of a healthy band's record-to-record wander the floor allows for.
inline constexpr double kWanderMaxCorrelation = 0.8;
/// The wander bound is a one-sided upper confidence bound at this level.
inline constexpr double kWanderBoundConfidence = 0.95;

/// The law of the residual sum of squares about the least-squares line of n AR(1) points of unit
/// variance and lag-one correlation phi: RSS = y'My, M = I - X(X'X)^-1 X', X = [1, k], has mean
/// tr(MR) and variance 2 tr(MRMR), R_ij = phi^|i-j|; Satterthwaite's chi-square has
/// dof = tr(MR)^2 / tr(MRMR), so RSS ~ s^2 (tr(MR) / dof) chi2_dof.
struct ResidualLaw {
  double mean_factor = 0.0;  ///< tr(MR): E RSS / s^2
  double dof = 0.0;
};
ResidualLaw ar1_line_residual_law(std::size_t n, double phi);

/// Upper confidence bound (kWanderBoundConfidence) on the SD of a band's wander from its baseline:
/// the scatter about the baseline's own line (a steady rise inside it is removed, not counted as
/// wander), RSS s.t. s^2 <= RSS dof / (tr(MR) chi2_dof(1 - confidence)) at phi = kWanderMaxCorrelation,
/// the worst case (a smaller phi leaves more independent records: the bound is larger than needed).
/// NaN with fewer than 3 values.
double wander_sd_upper_bound(std::span<const double> baseline);

struct BandFloor {
  double floor = 0.0;                    ///< the rise a band needs to be material
  FloorSource source = FloorSource::configured;
  std::size_t baseline_points = 0;       ///< finite values in the baseline (at most wear_baseline_records)
  double residual_sd = std::numeric_limits<double>::quiet_NaN();  ///< sqrt(RSS / (n - 2)) of the baseline
  double wander_bound = std::numeric_limits<double>::quiet_NaN(); ///< wander_sd_upper_bound
};

/// The fewest baseline values the wander is measured from (below, the configured floor alone).
inline constexpr std::size_t kMinimumBaselinePoints = 10;

/// Before the wander can be measured, the first records are guarded against a healthy band whose
/// ICS2 wanders (any AR(1) correlation) with an SD up to this fraction of the configured floor.
inline constexpr double kEarlyWanderFraction = 0.5;

/// The floor the verdict asks of a band whose baseline is incomplete (FloorSource::baseline_incomplete),
/// judging a newest point with `earlier_points` earlier finite values: its rise over the lowest of
/// them is a rise over at least one of them; the difference of two records of a stationary Gaussian
/// wander of SD s has SD <= sqrt(2) s whatever their correlation, so with s <= kEarlyWanderFraction x
/// material_ics2_rise, P(rise >= floor) <= earlier_points x (1 - Phi(floor / (sqrt(2) s))) (Bonferroni),
/// which is the band's share of the significance, trend_significance / 2, at
///   floor = sqrt(2) kEarlyWanderFraction material_ics2_rise z(1 - trend_significance / (2 earlier_points)),
/// never below material_ics2_rise (a bound per judged record; the rank evidence must reach its bar
/// too). 0 when materiality is off.
double incomplete_baseline_floor(std::size_t earlier_points, const SignalProcessingSettings& settings);

/// A band's floor from its values in record order (the gear pair's history from its first record),
/// judging a newest point that has `earlier_points` finite values before it: the first
/// min(settings.wear_baseline_records, earlier_points) finite values are its healthy baseline (it
/// grows with the history until complete, so the newest point never measures its own floor);
/// floor = max(material_ics2_rise, kWanderFloorMultiple x wander_sd_upper_bound). With fewer than
/// kMinimumBaselinePoints, or when the verdict named wear at the baseline's last record (its rank
/// evidence over the baseline reached the bar and its last value stood material_ics2_rise above
/// the lowest earlier one: the wear started inside it), the configured floor alone.
BandFloor band_material_floor(std::span<const double> values, std::size_t earlier_points,
                              const SignalProcessingSettings& settings);

/// A significant, lasting move of the ICS2-selected carrier band (thesis Figs 4.8, 4.15): the new
/// centre is an octave or more from the established one, stays within an octave of itself for
/// settings.band_jump_persistence_records records, and its mean ICS2 over them exceeds the
/// established band's mean by more than settings.band_jump_sigma times that band's
/// record-to-record scatter (standard deviation; at least 3 earlier records are needed to judge).
/// A move that persists without the ICS2 rise re-establishes the band silently: on a healthy
/// gearbox the selected band wanders between bands of equal, noise-level ICS2.
struct BandJump {
  double cycles = 0.0;       ///< at the first record in the new band
  double from_hz = 0.0;
  double to_hz = 0.0;
  double from_ics2 = 0.0;    ///< mean ICS2 of the established band
  double to_ics2 = 0.0;      ///< mean ICS2 over the persistence records in the new band
};

struct WearMechanismVerdict {
  WearMechanism mechanism = WearMechanism::undetermined;
  /// The band the verdict could not look at (above 0.45·fs at the record's rate): the verdict is
  /// then about the other band alone, and cannot name this band's mechanism (nullopt = both seen).
  std::optional<CarrierBand> unseen_band;
  TrendTest low_band, high_band;
  BandFloor low_floor, high_floor;    ///< each band's materiality floor (band_material_floor; while
                                      ///< baseline_incomplete, raised to incomplete_baseline_floor)
  std::vector<BandJump> band_jumps;   ///< significant moves of the selected band (see BandJump)
  std::string evidence;               ///< one line: statistics, p-values, jumps
};

/// Uses settings.trend_significance, wear_min_band_share and wear_baseline_records. Points are
/// sorted by cycles internally. A band is rising when its rising_change_evidence reaches
/// rising_evidence_threshold and its newest ICS2 is at least its band_material_floor above the
/// lowest earlier one; Mann-Kendall's `decreasing` is reported only. The floors come from
/// `baseline` (the gear pair's first records, when `history` is a window that no longer holds
/// them), or from `history` itself when `baseline` is empty.
WearMechanismVerdict identify_wear_mechanism(std::span<const WearHistoryPoint> history,
                                             const SignalProcessingSettings& settings,
                                             std::span<const WearHistoryPoint> baseline = {});

/// The same, when one carrier band cannot be seen at the record's sample rate (it lies above
/// 0.45·fs, skipped band_above_nyquist): the verdict comes from the other band alone. Its rise names
/// its mechanism; no rise gives `none` — of what can be seen — where the two-band rule would stay
/// `undetermined` for good; `unseen_band` and the evidence say which mechanism could not be
/// looked for. nullopt behaves as the two-band overload (so do both bands unseen: no points).
WearMechanismVerdict identify_wear_mechanism(std::span<const WearHistoryPoint> history,
                                             const SignalProcessingSettings& settings,
                                             std::optional<CarrierBand> unseen_band,
                                             std::span<const WearHistoryPoint> baseline = {});

}  // namespace gearwatch::dsp
