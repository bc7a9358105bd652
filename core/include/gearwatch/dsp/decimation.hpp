#pragma once
// What a data-acquisition front-end does between the analogue sensor and the samples it hands
// on: it takes the signal at `factor` times the output rate and runs a linear-phase low-pass FIR
// (flat to 0.45 of the output rate, 100 dB down from 0.55 of it) before keeping every factor-th
// sample, as an oversampling converter's decimation filter does. A simulator that read its
// continuous output at the record's rate instead would fold everything above half that rate onto
// the band: the twin's mesh force steps wherever a tooth pair enters or leaves, so its lines reach
// far beyond 50 kHz, and at 8 Hz and 100 kHz the 658th mesh harmonic (100.016 kHz) lands on the
// input shaft's second order.
#include <cstddef>
#include <span>
#include <vector>

namespace gearwatch::dsp {

/// The rate the simulators' front-ends read their model at, at least. What still folds is what
/// the mesh puts near this rate, and that must stay under the gap diagnosis's comparison floor
/// (`gap::DiagnosisSettings::floor_db` under the total): read at only 4 × a low record rate the
/// folded lines beside the first mesh harmonic's sidebands rise above that floor, read this fast
/// they stay well under it (docs/twin.md "Sensor front-end").
inline constexpr double kFrontEndMinimumFineRateHz = 400000.0;

/// The oversampling a simulated front-end uses at a record rate: the smallest factor ≥ 4 that reads
/// the model at kFrontEndMinimumFineRateHz or faster (4 at 100 kHz, 8 at 50 kHz, 20 at 20 kHz).
/// Throws std::invalid_argument for a rate that is not positive and finite.
int front_end_oversampling(double sample_rate_hz);

/// A windowed-sinc (Kaiser) decimation filter for one factor: built once, used for any number of
/// records without allocating. Copyable (its only state is the taps).
class AntiAliasDecimator {
 public:
  /// factor ≥ 2; 0 < pass_fraction < stop_fraction ≤ 1 - pass_fraction (fractions of the output
  /// rate; the band between them may fold onto itself above pass_fraction, never below it);
  /// stop_db > 20. Throws std::invalid_argument otherwise.
  explicit AntiAliasDecimator(int factor, double pass_fraction = 0.45, double stop_fraction = 0.55, double stop_db = 100);

  int factor() const noexcept { return factor_; }
  /// The taps (odd length, symmetric, unit sum), centred on taps()[taps().size() / 2].
  std::span<const double> taps() const noexcept { return taps_; }
  /// Output samples' worth of fine samples the filter reaches on each side of an output sample:
  /// a record of n outputs needs (n + 2·padding_outputs())·factor fine samples.
  std::size_t padding_outputs() const noexcept { return padding_; }
  /// out[j] is the filter centred on fine sample (padding_outputs() + j)·factor, for
  /// j < out.size() = fine.size() / factor − 2·padding_outputs(); other sizes throw
  /// std::invalid_argument. No allocation.
  void decimate(std::span<const double> fine, std::span<float> out) const;
  void decimate(std::span<const double> fine, std::span<double> out) const;
  /// The number of outputs `fine_count` fine samples give (0 when too few).
  std::size_t outputs_for(std::size_t fine_count) const noexcept;

 private:
  template <class T>
  void run(std::span<const double> fine, std::span<T> out) const;
  int factor_;
  std::size_t padding_ = 0;
  std::vector<double> taps_;
};

}  // namespace gearwatch::dsp
