#pragma once
// Tacholess order tracking: the input shaft's angle estimated from the vibration signal by phase
// demodulation of a gear-mesh harmonic (Bonnardot, Randall et al. 2005; Combet & Gelman 2007),
// iterated; and the check of a tacho against that estimate. No I/O. See docs/dsp.md §10.
//
// Steps (SpeedEstimator::estimate):
//  1. coarse speed track: short-time spectra; in each frame the shaft speed whose mesh harmonics
//     1..H stand highest above the local spectral floor (a harmonic sum of log-SNRs, robust to
//     single strong lines and to the shaft-order sidebands), over the search range; then again with
//     frames four revolutions long, searched around the first track, and each frame's line refined
//     by parabolic interpolation. The mesh harmonic h* demodulated: by its SNR against the median
//     power beside it: at a steady speed the one whose angle is most precise (largest h²·SNR),
//     else the lowest within 6 dB of the strongest.
//  2. the coarse angle: the track integrated.
//  3. refinement, `iterations` times: the signal demodulated at order m = z1·h* on the current
//     angle (x·exp(-i2πmθ)), integrated over the angle with a window of one input-shaft revolution
//     cascaded with one of one output-shaft revolution (zeros at every order of either shaft, so
//     the mesh line's shaft sidebands and the other harmonics drop out); the window's phase is
//     2πm(θ_true - θ) + const, which corrects the angle. This is the order-domain band-pass of
//     the resample-and-refilter iteration, done without resampling the record.
//  4. synthetic tacho edges: one per input revolution, where the angle crosses an integer.
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "gearwatch/dsp/fft.hpp"
#include "gearwatch/types/speed_source.hpp"

namespace gearwatch::dsp {

struct SpeedEstimationSettings {
  int pinion_teeth = 19;          ///< z1, on the input shaft (mesh order z1)
  int gear_teeth = 52;            ///< z2, on the output shaft
  double min_speed_hz = 0.5;      ///< search range of the input shaft's speed
  double max_speed_hz = 60.0;
  int harmonics = 10;             ///< mesh harmonics in the search (the line used is one of them)
  int iterations = 3;             ///< refinement passes
  /// The estimate is refused when its window phases scatter more than this (radians, standard
  /// deviation between independent windows): beyond ~π/8 the unwrapping between neighbouring
  /// windows is no longer safe and the line is too weak to hold the angle.
  double max_phase_noise_rad = 0.39;
};

struct SpeedEstimate {
  bool ok = false;
  std::string failure;                 ///< why not ("" when ok)
  int harmonic = 0;                    ///< mesh harmonic h* demodulated
  double mean_speed_hz = 0.0;          ///< input shaft, over the whole-window span below
  /// Sample positions between which the whole demodulation window fits in the record: there the
  /// window nulls the shaft sidebands and the other mesh harmonics; nearer the ends it is cut short
  /// and a stronger neighbouring harmonic leaks into the line's phase.
  double whole_window_first = 0.0, whole_window_last = 0.0;
  double phase_noise_rad = 0.0;        ///< scatter of independent window phases (last pass)
  /// Standard error of a mean speed taken between two angles of the estimate (relative): the two
  /// ends' angle errors, sqrt(2)·phase_noise / (2π m), over the revolutions between them; see
  /// relative_standard_error().
  double angle_error_rev = 0.0;        ///< one window's angle standard error, revolutions
  std::vector<double> edges;           ///< input-shaft, one per revolution, fractional sample positions
  std::vector<double> knot_samples;    ///< the angle function: sample positions ...
  std::vector<double> knot_revs;       ///< ... and the input-shaft angle there (revolutions)

  /// Input-shaft angle (revolutions) at a sample position, linear between knots.
  double angle_at(double sample) const;
  /// Relative standard error of the mean speed over `revolutions` revolutions of the estimate.
  double relative_standard_error(double revolutions) const;
};

class SpeedEstimator {
 public:
  /// Throws std::invalid_argument for unusable settings (teeth < 1, an empty range, ...).
  explicit SpeedEstimator(const SpeedEstimationSettings& settings);
  /// nominal_speed_hz: a speed the input shaft turned at during the record (the speed frame, or a
  /// tacho's mean), NaN when none: the search then spans [nominal/2, 2·nominal] within the range
  /// (a 2x run-up either way), else the whole range. Never throws on bad data: ok = false with a
  /// reason. The result stays valid until the next call.
  const SpeedEstimate& estimate(std::span<const float> x, double sample_rate_hz,
                                double nominal_speed_hz = std::numeric_limits<double>::quiet_NaN());
  const SpeedEstimationSettings& settings() const noexcept { return settings_; }

 private:
  struct Frame {
    double centre = 0.0;                    // sample position
    double speed = 0.0;                     // chosen shaft speed (Hz)
    std::vector<double> line_speed, snr;    // per harmonic: refined speed, log-SNR (the search's floor)
    std::vector<double> line_snr;           // per harmonic: log-SNR against the median beside the line
  };
  bool track_speed(std::span<const float> x, double fs, double low, double high);
  void scan_frames(std::span<const float> x, double fs, std::size_t length, std::size_t hop,
                   const std::vector<Frame>* guide, double low, double high, std::vector<Frame>& frames);
  void frame_spectrum(std::span<const float> x, std::size_t start, std::size_t length, std::size_t last_bin);
  Frame search_frame(double fs, std::size_t length, double low, double high);
  double line_snr(std::size_t peak);
  bool steady_speed(std::size_t line) const;
  static int finest_angle_line(const std::vector<double>& line_log_snr);
  void whole_window_span(double window);
  template <class SnrAt>
  double resolve_octave(double speed, double low, double high, double top, SnrAt snr_at) const;
  void coarse_angle(std::span<const float> x, double fs);
  double refine(std::span<const float> x, double fs, int order);
  void demodulate(std::span<const float> x, int order);
  bool synthesise_edges(std::size_t samples);

  SpeedEstimationSettings settings_;
  SpeedEstimate result_;
  FftPlanCache plans_;
  RealBuffer frame_;
  ComplexBuffer spectrum_;
  std::vector<double> power_, cumulative_, floor_, line_score_, neighbours_;
  std::size_t power_written_ = 0, floor_written_ = 0, line_score_written_ = 0;  ///< see zero_from
  std::size_t scored_bins_ = 0;  ///< floor_ holds log-SNRs below this bin, zeros above
  std::map<std::size_t, std::vector<double>> windows_;  ///< Hann window per frame length
  std::vector<Frame> coarse_, fine_;
  std::vector<double> segment_re_, segment_im_, grid_re_, grid_im_, phase_;
};

/// A disagreement beyond this (relative) is not a tacho's small error: the estimate more likely
/// followed another line (a harmonic sum's octave, a foreign tone), and a tacho that far off the
/// speed frame is refused by the record assembler's own 10 % check. The tacho is kept; the alert
/// is still raised.
inline constexpr double kGrossSpeedDifference = 0.10;

/// The decision for one record: which angle the analysis uses, and whether the tacho disagrees.
struct SpeedCheck {
  SpeedSource source = SpeedSource::tacho;
  bool mismatch = false;          ///< tacho and estimate differ by more than the tolerance
  bool gross = false;             ///< ... by more than kGrossSpeedDifference: the tacho is kept
  double tacho_speed_hz = 0.0;    ///< mean over the tacho edges' span (0 = no tacho)
  double signal_speed_hz = 0.0;   ///< the estimate's mean over the same span (0 = no estimate)
  double relative_difference = 0.0;  ///< (tacho - signal) / signal
  double tolerance = 0.0;            ///< relative
};

/// The relative tolerance between a tacho's mean speed and the estimate's over `revolutions`
/// input revolutions: the larger of four standard errors of the estimate's mean
/// (SpeedEstimate::relative_standard_error, from the record's own phase scatter) and the mismatch
/// that slips the mesh phase by a tenth of a cycle over the span, 0.1 / (z1 x revolutions) (the
/// TSA of mesh harmonic 1 then keeps sinc(0.1) = 98.4 % of its amplitude: a smaller disagreement
/// costs the indicators nothing worth an alert).
double speed_tolerance(const SpeedEstimate& estimate, double revolutions, int pinion_teeth);

/// Compares a tacho's edges (input shaft, `input_revs_per_edge` input revolutions between
/// successive edges) with the estimate over the tacho's span. With no usable estimate the tacho is
/// used as it is (source tacho, no mismatch). A mismatch within kGrossSpeedDifference switches the
/// source to the estimate.
SpeedCheck check_tacho(std::span<const double> tacho_edges, double input_revs_per_edge, const SpeedEstimate& estimate,
                       double sample_rate_hz, int pinion_teeth);

}  // namespace gearwatch::dsp
