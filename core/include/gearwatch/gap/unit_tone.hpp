#pragma once
// A unit tone's reduction (RecordSpectra::of_tone on unit_tone_record) in closed form, cell by
// cell: the reduction is linear in the samples and the tone is a sum of two complex exponentials
// at constant speed, so each stage is a geometric series over the revolutions, the samples of a
// revolution or a block's Hann window. Only the cells asked for are computed.
#include <complex>
#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/gearbox_spec.hpp"

namespace gearwatch::gap {

/// The sample rate of a unit tone's record: `samples_per_cycle` samples a cycle of order
/// `top_order` + 4 at `like`'s speed, at most `like`'s rate.
double unit_tone_sample_rate(double top_order, const SpectralSummary& like, double samples_per_cycle) noexcept;

/// cos(2π·order·speed·i/fs) for i = 0 .. out.size() − 1 as unit_tone_record stores it (float): a
/// rotating phasor set exactly every 256 samples.
void unit_tone_samples(double order, double speed_hz, double sample_rate_hz, std::span<float> out);

namespace detail {
/// Σ_c amplitude_c · Σ_{i<N} e^{i2π(at_c − line)i/N} at integer lines: the lines UnitToneCells reads.
class DirichletSum {
 public:
  explicit DirichletSum(std::size_t count = 1);
  void add(double at, std::complex<double> amplitude);
  std::complex<double> at_line(double line) const;

 private:
  double n_;
  std::size_t count_;
  std::vector<double> at_;
  std::vector<std::complex<double>> amplitude_, lead_;
};
}  // namespace detail

/// What unit_tone_spectra gives, read a cell at a time. The reduction's stages:
///  - each shaft's angle grid holds the cosine itself; the input grid's leading samples, where the
///    resampler's kernel reads before the record's start, are the resampler's (computed on that
///    head only) and enter every stage as a short correction;
///  - the input shaft's tapered synchronous average (a geometric series per position, the taper's
///    ramps corrected sample by sample) and its harmonics (one transform of a revolution);
///  - the output-only signal (tone − that average) on the output grids, band-limited: the tone
///    exactly, the average by its harmonics (the output lines, O(revolution) per line); on the
///    output shaft's coarser grid the harmonics under the kernel's cutoff, evaluated on the grid
///    the gear ratio's fraction makes periodic (one inverse transform), the kernel's own values at
///    the grids' leading samples, where it reads before the start;
///  - the output shaft's tapered average of that and its harmonics, which the input lines and the
///    residual lose (the input average cancels from the broadband part: the same in every block);
///  - each line and Hann block bin as Dirichlet kernels of the components.
/// The result differs from the reduction's by the interpolation kernel's pass-band error on the
/// output-only signal (the reduction resamples it; here it is band-limited exactly).
/// When a grid's kernel would read past the record's end, the tone lies in the coarse output grid's
/// kernel transition band, or the gear ratio's fraction is too fine, the reduction itself is run
/// (exact() false) and its summary read. So it is when the cells to be read are given and the
/// closed form would cost more on them than the reduction: a line costs a term per component (about
/// a revolution's samples), a broadband bin a term per block and component in its reach, while the
/// reduction's cost follows the record's samples.
struct UnitToneReads {
  std::size_t lines = 0, broadband = 0;  // input and output lines together; broadband bins
};

class UnitToneCells {
 public:
  UnitToneCells(double order, double top_order, const SpectralSummary& like, const GearPairSpec& gears,
                double samples_per_cycle, std::optional<UnitToneReads> reads = std::nullopt);
  bool exact() const noexcept { return exact_; }
  /// Power of input line `index` + 1, output line `index` + 1 (0 on mesh orders), broadband bin
  /// [index + 1, index + 2); 0 beyond the reduction's lines and bins.
  double input_line(std::size_t index) const;
  double output_line(std::size_t index) const;
  double broadband(std::size_t index) const;

 private:
  bool set_up(const SpectralSummary& like, double top_order, double samples_per_cycle, const std::optional<UnitToneReads>& reads);
  bool grids_fit(std::size_t part_size) const;
  bool cheaper_than_reduction(const UnitToneReads& reads) const;
  void input_average();
  void output_average(const std::vector<float>& part);
  std::vector<double> grid_head(const std::vector<float>& part, std::size_t samples_per_rev, std::size_t harmonics_kept,
                                double tone) const;
  double half_bin_power(std::size_t j) const;

  double order_;
  GearPairSpec gears_;
  bool exact_ = false;
  SpectralSummary fallback_;
  double speed_ = 0, fs_ = 0, ratio_ = 1;
  std::size_t n_ = 0, revs_ = 0, out_revs_ = 0, spr_ = 0, spr_out_ = 0, k_in_ = 0, k_out_ = 0;
  std::vector<double> delta_in_;                // input grid's leading samples: resampler − cosine
  std::vector<double> tsa_in_;                  // input shaft's tapered average
  std::vector<std::complex<double>> t_;         // its harmonics 0 .. spr/2 − 1 (per sample: spectrum / spr)
  std::vector<double> delta_out_;               // output-line grid's leading samples: kernel − band-limited
  std::vector<std::complex<double>> o_;         // output shaft's average harmonics 0 .. spr/2 − 1 (non-shared only)
  detail::DirichletSum input_lines_, output_lines_;  // every component's share of each shaft's lines
  void set_lines();
};

}  // namespace gearwatch::gap
