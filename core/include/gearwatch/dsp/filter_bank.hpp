#pragma once
// The 1/3-binary tree filter bank of Antoni's fast kurtogram (MSSP 21 (2007) 108-124), with the
// band criterion pluggable: kurtosis reproduces the kurtogram (checked against an independent
// implementation), ICS2 is the thesis's band selection (§4.3.2). Conventions (filters, decimation
// phases, transient trimming, row/column layout) follow the reference's README exactly; see
// docs/dsp.md.
#include <array>
#include <optional>
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "gearwatch/dsp/envelope.hpp"
#include "gearwatch/dsp/fft.hpp"
#include "gearwatch/types/indicator.hpp"

namespace gearwatch::dsp {

/// Raw sums over a node's samples c (after the trim), taken by the bank in one pass for the
/// criteria that read them (band power and kurtosis), so that neither passes over the band again.
struct NodeMoments {
  std::size_t count = 0;
  Complex sum{};        ///< sum c
  double sum2 = 0.0;    ///< sum |c|^2
  double sum4 = 0.0;    ///< sum |c|^4
  Complex sum2c{};      ///< sum |c|^2 c
  Complex sum_sq{};     ///< sum c^2
};

/// The sums of NodeMoments over c in one pass (vectorised, several independent chains).
NodeMoments node_moments(std::span<const Complex> c);

/// One band of the tree as seen by a criterion.
struct FilterBankNode {
  int row = 0;                 ///< 0 whole signal; 2k-1 binary depth k; 2k ternary split of depth k-1
  double level = 0.0;          ///< k, or k + log2(3) - 1 for ternary rows
  int band_index = 0;          ///< in increasing frequency within the row
  int band_count = 1;
  int decimation = 1;          ///< input samples per node sample
  bool real = false;           ///< only row 0: the raw (mean-removed) real signal
  std::span<const Complex> samples;  ///< after the transient trim (real parts only when `real`)
  const NodeMoments* moments = nullptr;  ///< node_moments(samples), when a criterion reads them
};

/// Which bands a selection may pick (BandMap::optimum's rule, applied while the tree runs): the
/// gated criteria are not evaluated on the others, whose map entries are NaN ("not computed";
/// optimum never picks a NaN). The power criterion itself is never gated.
struct BandGate {
  std::size_t power_criterion = 0;  ///< index of the BandPowerCriterion among the criteria
  double max_high_fraction = 0.5;
  double min_power_fraction = 0.0;
};

class BandCriterion {
 public:
  virtual ~BandCriterion() = default;
  virtual const char* name() const noexcept = 0;
  virtual double evaluate(const FilterBankNode& node) = 0;
  /// True when evaluate reads node.moments (the bank then takes them once per node).
  virtual bool reads_moments() const noexcept { return false; }
};

/// Antoni's kurt2: K = mean|c|^4 / (mean|c|^2)^2 - 2 (- 3 for a real signal), after removing the
/// complex mean; 0 for an all-zero or sub-epsilon-power segment. The central moments come from
/// the node's raw sums (node.moments, or its samples when none are given); where the mean is not
/// small against the spread, from a second pass about the mean instead (the raw sums would cancel).
class KurtosisCriterion final : public BandCriterion {
 public:
  const char* name() const noexcept override { return to_string(BandSelectionCriterion::kurtosis); }
  double evaluate(const FilterBankNode& node) override;
  bool reads_moments() const noexcept override { return true; }
};

/// Power of the real signal within the band: mean x^2 for row 0 (mean removed by the bank),
/// 2 mean|c|^2 for a complex node (its filters have unit pass-band gain and keep only the
/// positive frequencies, half of a real signal's power). Used to keep band selection away from
/// bands too weak to be trusted.
class BandPowerCriterion final : public BandCriterion {
 public:
  const char* name() const noexcept override { return "power"; }
  double evaluate(const FilterBankNode& node) override;
  bool reads_moments() const noexcept override { return true; }
};

/// ICS2 of the band's squared envelope, on the largest whole-revolution stretch of the trimmed
/// node (for a ternary node a multiple of 3 revolutions, so the gear-mesh order stays on a bin).
/// Harmonics above a node's cyclic Nyquist are not counted. Row 0 (the real signal) is band-passed
/// by FFT and so tapered first (kEnvelopeTaperFraction); the complex nodes come from linear
/// (not circular) filters and need no taper.
class Ics2Criterion final : public BandCriterion {
 public:
  Ics2Criterion(SquaredEnvelopeAnalyzer& envelope, FftPlanCache& plans, std::size_t samples_per_rev,
                Ics2Parameters parameters)
      : envelope_(&envelope), plans_(&plans), samples_per_rev_(samples_per_rev), parameters_(parameters) {}
  const char* name() const noexcept override { return to_string(BandSelectionCriterion::ics2); }
  double evaluate(const FilterBankNode& node) override;
  /// Row 0 (the whole real signal) is the full-band ICS2 its caller usually has already; giving
  /// it here skips recomputing it (three transforms of the whole record).
  void set_whole_signal_value(double value) { whole_signal_value_ = value; }

 private:
  std::optional<double> whole_signal_value_;
  SquaredEnvelopeAnalyzer* envelope_;
  FftPlanCache* plans_;
  std::size_t samples_per_rev_;
  Ics2Parameters parameters_;
  RealBuffer real_;
  ComplexBuffer spectrum_;
};

/// The criterion over all bands: rows x columns as in the reference kurtogram
/// (2*levels rows, 3*2^levels columns, each band's value repeated over its columns).
struct BandMap {
  int levels = 0;
  std::string criterion;
  std::vector<double> values;  ///< row-major
  std::size_t rows() const noexcept { return static_cast<std::size_t>(2 * levels); }
  std::size_t columns() const noexcept { return static_cast<std::size_t>(3) << levels; }
  double at(std::size_t row, std::size_t column) const { return values[row * columns() + column]; }

  struct Optimum {
    bool found = false;               ///< false when no band is eligible
    int row = 0;
    std::size_t first_column = 0;
    double level = 0.0;
    double centre_fraction = 0.0;     ///< band centre / sample rate
    double bandwidth_fraction = 0.0;  ///< bandwidth / sample rate
    double value = 0.0;
  };
  /// First maximum in row-major order (the reference's convention), among the bands whose upper
  /// edge is at most max_high_fraction of the sample rate (an angle-domain signal may be sampled
  /// faster than the acquisition: bands above the acquisition's Nyquist hold only interpolation
  /// residue and must not be selected).
  /// With `power` (a BandPowerCriterion map of the same bank), bands whose power is below
  /// min_power_fraction x power.at(0, 0) (the whole signal's) are not eligible either.
  Optimum optimum(double max_high_fraction = 0.5, const BandMap* power = nullptr, double min_power_fraction = 0.0) const;
  /// Upper edge (fraction of the sample rate) of the band at (row, column).
  double band_high_fraction(std::size_t row, std::size_t column) const;
};

/// Level of a row: 0, 1, 1.585, 2, 2.585, ...
double filter_bank_row_level(int row);

class OneThirdBinaryFilterBank {
 public:
  OneThirdBinaryFilterBank();

  /// Decomposes x to `levels` binary depths (ternary splits down to depth levels-2) and evaluates
  /// every criterion on every band; maps[i] receives criteria[i]'s map. Reuses its buffers.
  /// Throws std::invalid_argument when levels < 1 or x is too short for the deepest level.
  /// With a gate, the other criteria run only on the bands the gate lets through.
  void analyse(std::span<const double> x, int levels, std::span<BandCriterion* const> criteria,
               std::span<BandMap> maps, const std::optional<BandGate>& gate = std::nullopt);

  /// The filters as built (reference: filters.csv): binary low (17 taps), binary high (16),
  /// ternary 1..3 (25 each).
  std::span<const Complex> low() const noexcept { return low_; }
  std::span<const Complex> high() const noexcept { return high_; }
  std::span<const Complex> ternary(int i) const { return ternary_.at(static_cast<std::size_t>(i)); }

 private:
  void visit(int depth, int band, std::span<const Complex> node, std::size_t depth_length);
  /// Evaluates the criteria on one band; `moments` are its NodeMoments when the split took them.
  void evaluate(int row, int band, int band_count, int decimation, bool real, std::span<const Complex> trimmed,
                const NodeMoments* moments);

  std::vector<Complex> low_, high_;
  std::array<std::vector<Complex>, 3> ternary_;
  int levels_ = 0;
  std::span<BandCriterion* const> criteria_;
  std::span<BandMap> maps_;
  std::optional<BandGate> gate_;
  double gate_min_power_ = 0.0;
  ComplexBuffer root_;
  std::vector<ComplexBuffer> low_children_, high_children_;
  ComplexBuffer ternary_scratch_;
  bool moments_read_ = false;
};

/// scipy.signal.firwin(taps, cutoff) for a low-pass with the default Hamming window and unit DC
/// gain (cutoff relative to Nyquist) = MATLAB fir1(taps-1, cutoff).
std::vector<double> firwin_lowpass(int taps, double cutoff);

}  // namespace gearwatch::dsp
