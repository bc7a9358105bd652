#pragma once
// Per-record indicator computation (issue 3): order tracking, TSA of both shafts, residual,
// RMS_SA, GMF harmonics, squared-envelope ICS2 (full band, fixed carrier bands, 1/3-binary tree
// band selection), spectral coherence at the gear-mesh order with mean carrier frequencies, and
// the classical indicators. The daemon's processing thread owns one RecordAnalyzer per rig.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/dsp/envelope.hpp"
#include "gearwatch/dsp/fft.hpp"
#include "gearwatch/dsp/filter_bank.hpp"
#include "gearwatch/dsp/line_removal.hpp"
#include "gearwatch/dsp/order_tracking.hpp"
#include "gearwatch/dsp/spectral_coherence.hpp"
#include "gearwatch/dsp/tsa.hpp"
#include "gearwatch/dsp/wear_mechanism.hpp"
#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/types/indicator.hpp"
#include "gearwatch/types/record.hpp"
#include "gearwatch/types/skip_reason.hpp"

namespace gearwatch::dsp {

struct FrequencyBand {
  double low_hz = 0.0;
  double high_hz = 0.0;
};

/// Defaults are the thesis's values where it gives them (§4.4 bands, §7.2 N = 2, Fig. 4.13
/// ranges, ±3 cyclic bins); the config file overrides them.
struct SignalProcessingSettings {
  /// Order-tracking resolution. 0 = automatic: per record, the smallest 2^a 3^b 5^c with
  /// samples_per_revolution x (slowest revolution's speed) >= sample rate, so no part of the
  /// acquired band is lost and FFT sizes stay fast. A fixed value must be such a number in
  /// [64, 2^20] (a power of two is fine).
  int samples_per_revolution = 0;
  int rms_sa_harmonics = 2;           ///< N of Eq. 7.1 (thesis: 2 mild, 6 severe profile change)
  int stored_gmf_harmonics = 10;
  int ics2_harmonics = 3;             ///< H of Eq. 4.3 (the thesis does not state it)
  int ics2_tolerance_bins = 3;
  FrequencyBand pitting_band{2000.0, 13000.0};
  FrequencyBand abrasion_band{20000.0, 37000.0};
  int filter_bank_levels = 6;
  bool kurtogram_band_selection = true;   ///< also report the kurtosis-selected band
  std::vector<FrequencyBand> mean_carrier_ranges{{0.0, 30000.0}, {0.0, 50000.0}};
  double min_revolutions_for_tsa = 5.0;   ///< per shaft
  double max_clipped_fraction = 1.0e-4;   ///< samples at +-full scale tolerated
  /// A channel whose standard deviation is at most this many LSB of its scale is a flat line
  /// (a dead or disconnected sensor): skipped "flat_line". 0 = only an exactly constant channel;
  /// a channel without a configured scale is flat only when exactly constant.
  double flat_line_max_std_lsb = 0.5;
  /// Residual RMS below this fraction of the raw RMS (about its mean, so a DC offset does not
  /// count) is numerical residue (quantisation,
  /// interpolation, order-tracking error: ~1e-4 to 1e-3 of the raw RMS), not signal: the
  /// residual-structure indicators (ICS2, band selection, spectral coherence) are skipped
  /// "residual_below_floor".
  double residual_rms_floor = 0.005;
  /// The residual's structure indicators (ICS2, band selection, spectral coherence) see its
  /// random part only: discrete lines the TSA leaves (not synchronous with either shaft) are
  /// removed first (DiscreteLineRemover, the DRS of thesis §4.3.2's choice). RMS and kurtosis of
  /// the residual stay those of the TSA residual, the thesis's.
  bool remove_residual_lines = true;
  /// Bands whose energy is below this many dB of the analysed residual's total energy are not
  /// trusted: a fixed band is skipped "band_below_floor" and tree bands are not selectable
  /// (the tree's 17/25-tap filters leak about -55 dB, so a weaker band may hold only leakage).
  double band_energy_floor_db = -40.0;
  double trend_significance = 0.05;       ///< wear-mechanism trend tests
  /// Materiality of a wear trend (dsp::material_ics2_rise): the share of a carrier band's power the
  /// wear vibration must reach before that band's rise names a mechanism; in [0, 1], 0 = the
  /// significance alone decides.
  double wear_min_band_share = 0.5;
  /// The gear pair's first this many finite records of a carrier band are its healthy baseline:
  /// the band's materiality floor rises to a multiple of their measured wander
  /// (dsp::band_material_floor). 0 = off (material_ics2_rise alone); else in [10, 200] (each verdict
  /// re-derives the floors of the growing baseline, cubic in its length).
  int wear_baseline_records = 50;
  /// The trend tests use the most recent records only: Mann-Kendall is O(n²), and a daemon
  /// recording every 10 min for years must not slow down with age (the thesis's lubricated test
  /// had ~540 records over 3.25 M cycles).
  int trend_window_records = 500;
  /// Band jumps (see dsp::BandJump): records the new band must last, and how many standard
  /// deviations of the established band's ICS2 the new band's mean must exceed.
  int band_jump_persistence_records = 2;
  double band_jump_sigma = 3.0;

  /// Throws std::invalid_argument naming the setting when it is unusable for any record
  /// (non-power-of-two resolution, N > stored harmonics, inverted or negative bands, ...).
  /// A band above the Nyquist frequency is NOT an error here: Nyquist depends on the record (its
  /// rate and, in the angle domain, its speed), so such a band marks that indicator skipped
  /// ("band_above_nyquist") at analysis time.
  void validate(const GearboxSpec& rig) const;
};

struct IndicatorValue {
  std::string name;
  double value = 0.0;
};
struct SkippedIndicator {
  std::string name;
  SkipReason reason = SkipReason::not_computed;   ///< stored as to_string(reason); see docs/dsp.md
  std::string detail;   ///< free text for some reasons (e.g. the filter bank's message), else empty
};
struct IndicatorNoteEntry {
  std::string name;
  IndicatorNote note = IndicatorNote::band_trimmed;   ///< stored as to_string(note)
  std::string detail;
};
struct BandSelection {
  BandSelectionCriterion criterion = BandSelectionCriterion::ics2;   ///< stored as to_string(criterion)
  double level = 0.0;
  double centre_hz = 0.0;
  double bandwidth_hz = 0.0;
  double value = 0.0;
};

struct ChannelAnalysis {
  std::vector<IndicatorValue> indicators;   ///< stable snake_case names, see docs/dsp.md
  std::vector<SkippedIndicator> skipped;
  std::vector<IndicatorNoteEntry> notes;    ///< caveats of computed indicators (a trimmed band)
  std::vector<BandSelection> band_selections;
  double tsa_averages_input = 0;
  double tsa_averages_output = 0;
  std::vector<double> speed_profile_hz;     ///< input-shaft speed per whole revolution
  std::size_t samples_per_revolution = 0;   ///< order-tracking resolution used (0 = none)
  double mean_speed_hz = 0.0;               ///< input shaft, from the tacho (0 = none)

  std::optional<double> value(const std::string& name) const;
  std::optional<double> value(Indicator indicator) const { return value(to_string(indicator)); }
  /// Reason the indicator was skipped, or nullptr.
  const SkippedIndicator* skip_reason(const std::string& name) const;
  const SkippedIndicator* skip_reason(Indicator indicator) const { return skip_reason(to_string(indicator)); }
};

class RecordAnalyzer {
 public:
  /// Validates the settings against the rig (std::invalid_argument).
  RecordAnalyzer(const GearboxSpec& rig, const SignalProcessingSettings& settings);
  /// Never throws on bad data: every indicator is either in `indicators` or in `skipped` with a
  /// reason. Throws only std::out_of_range for a channel index the record does not have.
  /// `input_edges`, when not empty, replaces the record's tacho: input-shaft edges, one per
  /// revolution (a SpeedEstimate's synthetic edges), used exactly as a tacho's.
  ChannelAnalysis analyze(const Record& record, std::size_t channel_index, std::span<const double> input_edges = {});

  const SignalProcessingSettings& settings() const noexcept { return settings_; }
  /// Every indicator name analyze() can produce, in output order.
  std::vector<std::string> indicator_names() const;

 private:
  struct Context;
  void analyze_order_domain(const Record& record, std::span<const float> x, double raw_std_dev,
                            std::span<const double> input_edges, ChannelAnalysis& out);

  GearboxSpec rig_;
  SignalProcessingSettings settings_;
  FftPlanCache plans_;
  ShaftAngle angle_;
  AngularResampler resampler_;          // input shaft
  AngularResampler output_resampler_;   // output shaft (its own cutoff: no table rebuild per record)
  SynchronousSeparation separation_;
  SquaredEnvelopeAnalyzer envelope_;
  OneThirdBinaryFilterBank filter_bank_;
  CyclicCoherenceEstimator coherence_;
  KurtosisCriterion kurtosis_criterion_;
  BandPowerCriterion power_criterion_;
  DiscreteLineRemover line_remover_;
  RealBuffer input_angle_, output_angle_, residual_, tapered_residual_;
  std::vector<double> speed_scratch_;
  ComplexBuffer residual_spectrum_;
  std::vector<double> gmf_amplitudes_;
  std::vector<BandMap> band_maps_;
};

/// The tacho the analysis uses for a record: the input shaft's own if it has edges, else any
/// other configured shaft's with edges (scaled by its ratio); nullptr when no tacho has edges.
const TachoSpec* input_tacho(const GearboxSpec& rig, const Record& record);

/// The highest carrier frequency analysed at a sample rate: 0.45·fs. Above it a converter's
/// anti-alias filter is in its transition band (flat to ~0.45·fs, stopped by ~0.55·fs in the
/// usual sigma-delta front end), so what is there is attenuated or aliased.
inline constexpr double kUsableBandFraction = 0.45;

/// Name of the mean-carrier indicator for a range: "mean_carrier_hz_<low>_<high>" (whole Hz).
std::string mean_carrier_indicator_name(const FrequencyBand& range);

}  // namespace gearwatch::dsp
