#pragma once
// Computed order tracking: tacho edges -> shaft angle -> angular resampling of a record to a fixed
// number of samples per revolution, with a band-limited (Kaiser-windowed sinc) interpolator.
#include <cstddef>
#include <optional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "gearwatch/types/skip_reason.hpp"

namespace gearwatch::dsp {

/// Why a tacho edge list cannot give a shaft angle (no failure = usable).
struct TachoCheck {
  std::optional<SkipReason> failure;   ///< no_tacho, too_few_edges or tacho_irregular
  std::string reason;                  ///< to_string(*failure), or "" when usable
  TachoCheck() = default;
  explicit TachoCheck(SkipReason r) : failure(r), reason(to_string(r)) {}
  bool ok() const noexcept { return !failure.has_value(); }
};

/// Shaft angle as a function of time, from tacho edges. The edge times are interpolated as a
/// not-a-knot cubic spline of *time versus angle* (edges are equally spaced in angle), so the sample
/// time of any angle is one spline evaluation; the inverse (angle of a time) is never needed.
/// Angle 0 is the first edge. Reusable: assign() keeps capacity, so no allocation per record
/// once it has seen the longest edge list.
class ShaftAngle {
 public:
  /// edges: sample positions (fractional), strictly increasing; edges_per_rev of the tacho shaft;
  /// analysed_revs_per_tacho_rev converts tacho-shaft revolutions into revolutions of the shaft
  /// the angle is expressed in (1 when the tacho is on that shaft).
  /// Returns the reason when the edges are unusable: fewer than one revolution, non-finite or
  /// non-increasing positions, or an edge interval outside [0.5, 1.5] x the median of the nine
  /// intervals around it (a missed or spurious edge; ±5 % speed fluctuation and a run-up that
  /// doubles the speed over a record stay well inside).
  TachoCheck assign(std::span<const double> edges, int edges_per_rev, double analysed_revs_per_tacho_rev);

  /// Revolutions covered from the first to the last edge.
  double total_revolutions() const noexcept { return total_revs_; }
  /// Sample position of the given angle (revolutions since the first edge), 0 <= revs <= total.
  double time_at(double revs) const;
  /// out[k] = time_at((first + k) * step) for every k, the same arithmetic without a call per sample.
  void times_at(double step, std::size_t first, std::span<double> out) const;
  /// Speed (revolutions per second) averaged over each whole revolution.
  void speed_per_revolution(double sample_rate_hz, std::vector<double>& out) const;

 private:
  /// The spline at u knot intervals from the first knot (time_at's and times_at's one evaluation).
  double spline_at(double u) const;

  std::vector<double> times_;        // knot values (sample positions)
  std::vector<double> second_deriv_; // spline second derivatives at the knots
  std::vector<double> scratch_;
  double knot_spacing_ = 1.0;        // revolutions between knots
  double total_revs_ = 0.0;
  friend class AngularResampler;
};

/// How much of a sinusoidal deviation of a shaft's angle, at `ratio` times the shaft's speed, the
/// angle from one tacho edge per revolution (ShaftAngle's spline) leaves in the tracked signal: the
/// amplitude of the tracked angle's error at that frequency over the deviation's. Near 0 for slow
/// deviations (the spline follows them), 1 at ratio 1 (every edge sees the deviation at the same
/// phase, so the spline sees none of it). Measured on synthetic edges, 400 revolutions (a deviation
/// whose ratio is not a simple fraction meets the edges at every phase). Above 1 the edges hold only
/// an alias of the deviation and the share is 1 (within 5e-4 up to 16). Throws std::invalid_argument
/// for a ratio outside (0, 16].
double tracking_residual_share(double ratio);

/// The signed component at `at` shaft orders of the tracked angle's error (tracked angle minus the
/// true one, as tracking_residual_share measures it) for a deviation sin(2π·ratio·θ) of unit
/// amplitude, measured the same way on synthetic edges: a sine's coefficient, so at `at` = ratio it
/// is ± tracking_residual_share. One edge a revolution samples the deviation, so the spline also
/// carries its images at k ± ratio (k whole): the tracked signal is phase-modulated there too.
/// Throws std::invalid_argument for a ratio or `at` outside (0, 16].
double tracking_error_component(double ratio, double at);

/// Band-limited interpolation of a uniformly sampled signal at arbitrary positions: a Kaiser-windowed
/// sinc with `zero_crossings` lobes each side, tabulated at `phases` fractional offsets with linear
/// interpolation between adjacent phase rows. When the output is sparser than the input the
/// cutoff is lowered (anti-aliasing) and the kernel widened accordingly. The table and the
/// products are single precision (the samples are float already; the sum of <= 200 products
/// keeps ~1e-6 relative accuracy, well under the kernel's 1e-4 pass-band ripple), accumulated in
/// four lanes.
class BandLimitedInterpolator {
 public:
  explicit BandLimitedInterpolator(int zero_crossings = 16, int phases = 512, double kaiser_beta = 8.0);
  /// cutoff: fraction of the input Nyquist frequency kept, in (0, 1]. Rebuilds the table only
  /// when it changes.
  void set_cutoff(double cutoff);
  double cutoff() const noexcept { return cutoff_; }
  int taps() const noexcept { return taps_; }
  /// Value at fractional sample position t; samples outside [0, n) count as zero.
  double operator()(std::span<const float> x, double t) const;
  /// out[k] = (*this)(x, t[k]): the same arithmetic (the same products, summed in the same
  /// order), four positions at a time so their sums run side by side.
  void interpolate(std::span<const float> x, std::span<const double> t, std::span<double> out) const;

 private:
  /// Where position t reads: the first of its taps_ samples, the table's lower phase row and the
  /// weight between it and the next (operator()'s and interpolate()'s one position arithmetic).
  struct Position {
    std::ptrdiff_t first = 0;
    const float* row0 = nullptr;
    double w = 0;
  };
  Position locate(double t) const;

  int zero_crossings_;
  int phases_;
  double beta_;
  double cutoff_ = 0.0;
  int taps_ = 0;
  /// (phases_ + 1) rows x taps_ (taps_ a multiple of 4), shared by every interpolator with the
  /// same parameters (built once per process).
  std::shared_ptr<const std::vector<float>> table_;
};

/// Resamples a record to a fixed number of samples per revolution of the analysed shaft.
class AngularResampler {
 public:
  /// Writes revolutions * samples_per_rev samples of x at angles j / samples_per_rev (j = 0..) of
  /// the resampled shaft, measured from the first tacho edge. One revolution of the resampled
  /// shaft is `angle_revs_per_rev` revolutions of the ShaftAngle's shaft (1 for that shaft itself,
  /// z_gear/z_pinion to resample onto the output shaft with an input-shaft angle). The
  /// interpolator's cutoff is set from the largest output sample spacing (in input samples) so
  /// the resampled signal is not aliased.
  void resample(std::span<const float> x, const ShaftAngle& angle, std::size_t samples_per_rev,
                std::size_t revolutions, std::span<double> out, double angle_revs_per_rev = 1.0);
  const BandLimitedInterpolator& interpolator() const noexcept { return interpolator_; }

 private:
  BandLimitedInterpolator interpolator_;
  std::vector<double> times_;  // one block of output positions
};

}  // namespace gearwatch::dsp
