#pragma once
// The uncertainty behind the twin's forecasts (docs/model.md, "Posterior and interval"): a
// normal posterior of ln K per coefficient with a random-walk process noise, the 90 % interval it
// gives, K_pitting's measurement variance from the inspections and the ICS2 <-> density scale,
// the one-inspection ICS2 scale, and the checks of the forecast's path against the measured
// indicators. Pure functions on numbers: no I/O, no threads, no twin.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/types/model_run.hpp"

namespace gearwatch::wear {

/// Normal belief about ln K: mean, variance, and the cycles it refers to. `valid` false: no belief
/// yet (K_pitting before its first calibration).
struct LogPosterior {
  bool valid = false;
  double mean = 0, var = 0;
  double cycles = 0;
};

/// The random walk to `cycles`: var += q (cycles − posterior cycles) (q per cycle; never backwards).
LogPosterior predict(LogPosterior p, double cycles, double q_per_cycle);

/// The conjugate normal update with a measurement z of ln K with variance r:
/// var' = 1 / (1/var + 1/r), mean' = var' (mean/var + z/r).
LogPosterior conjugate_update(const LogPosterior& prior, double z, double r);

/// The same, after innovation-based variance matching: when the innovation z − mean is beyond
/// `gate_sd` standard deviations of its predicted spread (var + r), the prior variance is raised
/// to (z − mean)² − r, the moment estimate of the prior's variance from that innovation. A K
/// update is made only when the twin misses the measurement (a detected change), and a change
/// larger than the random walk allows must not be averaged away with the old K.
struct FilterStep {
  LogPosterior posterior;
  bool inflated = false;
  double innovation_sd = 0;   ///< (z − mean) / sqrt(var + r) before any inflation
};
FilterStep filter_update(const LogPosterior& prior, double z, double r, double gate_sd);

/// Standard normal quantile (inverse CDF).
double normal_quantile(double p);
/// Chi-square quantile with `dof` degrees of freedom.
double chi_square_quantile(double p, double dof);

/// The mean of K over a path of T cycles, A = (1/T) ∫ exp(W) with W a random walk of variance q
/// per cycle from 0, as a lognormal with A's exact first two moments (the moment matching used
/// for arithmetic averages of geometric Brownian motion): E[A] = (e^{x/2} − 1)/(x/2),
/// E[A²] = 4/(3x²) ((e^{2x} − 1)/2 − 2(e^{x/2} − 1)), x = q T. To first order ln A ~ N(x/12, x/3).
struct PathMeanMoments {
  double log_mean = 0, log_var = 0;
};
PathMeanMoments path_mean_moments(double q_per_cycle, double cycles);

/// ln K quantiles for the interval: mean + μ_A ± z_{(1+coverage)/2} widen sqrt(var + σ²_A + extra),
/// with (μ_A, σ²_A) the path mean's over T. T is the forecast's cycles to the crossing: what sets a
/// crossing is the mean of K over the path. `widen` multiplies the SD; `extra_var` adds a variance
/// the posterior has not absorbed (a recent miss of the measurements, pitting_miss below).
struct LogInterval {
  double low = 0, high = 0;   ///< ln K at the slow and the fast end
  double sd = 0;
};
LogInterval log_interval(const LogPosterior& p, double q_per_cycle, double horizon_cycles, double widen,
                         double extra_var = 0, double coverage = kNominalCoverage);

/// SD of a two-inspection scale's density at the ICS2 position t = (ICS2 − ICS2_0) / (ICS2_1 − ICS2_0):
/// D = (1 − t) A0 + t A1, the areas with independent relative errors `rel_sd`:
/// sd = rel_sd sqrt((1 − t)² A0² + t² A1²). It grows with the extrapolation beyond the second inspection.
double scale_density_sd(double a0, double a1, double t, double rel_sd);

/// The model's pitting path against the measured (ICS2-derived) density now, in ln K: at fixed N
/// Eq. 7.8 gives gap g = ln(−ln(1 − D_meas)) − ln(−ln(1 − D_model)), the change of K that would put
/// the model on the measurement; its SD from the measurement's, σ_g = σ_D / ((1 − D)(−ln(1 − D)))
/// at D = D_meas. Beyond `gate` σ_g the model's recent predictions missed the measurement, and
/// the K_pitting interval's variance gains g² (`extra_var`): the posterior has not absorbed the miss.
struct PittingMiss {
  double gap = 0, gap_sd = 0;
  bool missed = false;
  double extra_var = 0;
};
PittingMiss pitting_miss(double d_measured, double sd_measured, double d_model, double gate);

/// The measured density's upper bound at the interval's level, D + z_{(1+coverage)/2} σ, reaches
/// the limit: the limit may be reached already, and no interval may exclude that.
bool limit_within_reach(double estimate, double sd, double limit, double coverage = kNominalCoverage);

/// ICS2 saturation (docs/model.md, "ICS2 saturation"). The pitting band holds the pitting vibration,
/// noise modulated by the mesh with its own ICS2 I_s, beside stationary content; with s the
/// pitting share of the band's power, ICS2 = I_s s². With the pitting power proportional to the
/// pitted area, D ∝ s / (1 − s), so d ln D / d ln ICS2 = 1 / (2 (1 − s)) (this function, s in [0, 1)).
double density_elasticity_of_ics2(double share);
/// The level above which an ICS2 reading bounds the density from below only. The elasticity above
/// passes a proportional scale's 1 at s = 1/2, ICS2 = I_s / 4: beyond it the density grows faster
/// than any proportional scale through lower points reads it, without bound as s → 1. I_s is not
/// known; for AM noise (1 + a cos) n with a non-negative envelope (a ≤ 1) the closed form
/// (a² + a⁴/16) / (1 + a²/2)² (dsp::am_noise_ics2) rises with a, so a = 1 is its largest:
/// the level is am_noise_ics2(1, H) / 4 (17/144 for H ≥ 2, 1/9 for H = 1).
double ics2_saturation_level(int harmonics);

/// K_pitting's calibration from two pitted areas A0 at N0, A1 at N1 of one point of Eq. 7.8,
/// D = 1 − exp(−K T N^m): K = ln((1 − A0)/(1 − A1)) / (T (N1^m − N0^m)). Its elasticities
/// d ln K / d ln A0 and d ln K / d ln A1, in closed form (A0 < A1 < 1).
struct CalibrationElasticities {
  double d_ln_a0 = 0, d_ln_a1 = 0;
};
CalibrationElasticities calibration_elasticities(double a0, double a1);
/// Closed-form K of the calibration above (for the tests and the evidence).
double closed_form_calibration_k(double a0, double n0, double a1, double n1, double terms, double m);

/// Var ln K of a calibration whose areas carry relative SDs sd0, sd1, with `correlation` between
/// their errors (1 when A1 is an ICS2 estimate scaled by A0 itself).
double calibration_log_variance(double a0, double a1, double sd0, double sd1, double correlation);

/// At fixed cycles Eq. 7.8 gives ln K = ln(−ln(1 − D)) − ln(T N^m): the difference of two
/// densities' ln(−ln(1 − D)) is their difference in ln K.
double log_k_gap(double density_a, double density_b);

/// The form of an ICS2 <-> density scale. `linear`: D = density + slope (ICS2 − ics2), the thesis's
/// correlation through two inspections (Eqs. 7.15–7.17). `square_root`: D = density
/// sqrt((ICS2 − baseline) / (ics2 − baseline)), the one-inspection scale: the model's own ICS2 form
/// (ICS2 saturation below) has ICS2 − baseline = I_s s² and D ∝ s / (1 − s), so at a small pitting
/// share s the density grows as the square root of the ICS2 rise. Its leading order needs no I_s
/// (which is not known); up to the saturation level (s = 1/2) it reads low by at most (1 − s0)/(1 − s)
/// ≤ 2, and from there on a reading is a lower bound anyway. A linear scale through one point
/// instead reads the rise's square: 9× the density at 3× the inspected one.
enum class Ics2ScaleForm : std::uint8_t { linear, square_root };
const char* to_string(Ics2ScaleForm form);
std::optional<Ics2ScaleForm> ics2_scale_form_from_string(const std::string& text);

/// An ICS2 <-> density scale. nullopt from one_inspection_scale when ICS2_0 does not rise
/// materially above the baseline (by more than `min_rise_sd` baseline SDs, or not at all when the
/// baseline has no spread).
struct Ics2Scale {
  Ics2ScaleForm form = Ics2ScaleForm::linear;
  double ics2 = 0, density = 0, slope = 0;   ///< the scale's point (ICS2, D); slope: linear only
  double baseline = 0, baseline_sd = 0;      ///< the onset baseline (square_root)
  /// D at an ICS2 reading (square_root: 0 at or below the baseline).
  double density_at(double ics2_reading) const;
  /// The ICS2 reading of a density (the inverse of density_at; square_root: D ≤ 0 gives the baseline).
  double ics2_for(double d) const;
  /// The density's change for an ICS2 change of `ics2_sd` above the reading of density d: the
  /// ICS2 scatter through the scale (linear: slope × ics2_sd).
  double density_noise(double d, double ics2_sd) const;
};
/// The one-inspection scale (form square_root) through the inspected area A0 at ICS2_0.
/// The baseline: the median of the first `records` ICS2 values of the pair (a new pair starts
/// unpitted, so its first records hold ICS2 at its noise level; the median ignores one outlier);
/// its SD from their MAD (1.4826 MAD, the normal's).
std::optional<Ics2Scale> one_inspection_scale(const std::vector<double>& first_ics2, double ics2_at_inspection, double area,
                                              double min_rise_sd);

/// Theil–Sen line through (x, y): the median of the pairwise slopes, the median intercept.
struct RobustLine {
  double slope = 0, intercept = 0;
  bool valid = false;
};
RobustLine theil_sen(const std::vector<std::array<double, 2>>& points);

/// The chi-square check of recent ln(RMS_SA meas / sim) against the expected relative scatter:
/// S = Σ r² / σ², exceeded when S > χ²_{n, 0.95}; the widening is the RMS ratio sqrt(S / n).
struct ScatterCheck {
  bool exceeded = false;
  double statistic = 0, critical = 0, ratio = 1;
  int n = 0;
};
ScatterCheck residual_scatter_check(const std::vector<double>& log_residuals, double expected_sd, double level = 0.05);

/// The model-form term of ln K_wear's variance. The residuals r = ln(RMS_SA meas / sim) of the
/// stored records (each before any update at its record) hold the measurement's scatter s and what
/// the twin's RMS_SA-wear relation does not reproduce. When their chi-square against s exceeds its
/// 5 % point, the excess mean square m = mean(r^2) - s^2 is the model-form variance of ln RMS_SA,
/// and through the elasticity e = d ln RMS_SA / d ln K it is m / e^2 in ln K (|e| floored at
/// `min_elasticity`), at most `cap` (the caller's: what brings the variance to the prior's, since no
/// data can leave K_wear less known than before any). 0 when the chi-square does not exceed.
struct ModelFormTerm {
  bool exceeded = false;
  double excess_mean_square = 0;   ///< m, in (ln RMS_SA)^2
  double log_k_var = 0;            ///< min(m / e^2, cap)
};
ModelFormTerm model_form_term(const std::vector<double>& log_residuals, double scatter_sd, double elasticity,
                              double min_elasticity, double cap);

/// The RMS of ln(meas / sim) with a floor: the RMS_SA measurement's record-to-record scatter.
double scatter_sd(const std::vector<double>& log_residuals, double floor);

}  // namespace gearwatch::wear
