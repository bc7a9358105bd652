#pragma once
// Gaps at the resolution of a line or a band: every line and broadband bin of every record compared
// with the twin on its own, so that one line 40 dB off or one resonance 12 dB up is found however
// many bins its family holds (a family's RMS dilutes it below the family's minimum).
//
// Method (docs/gap.md, "Features"):
//  - cells: each record's input-order lines, output-order lines (the mesh orders counted on the input
//    side) and 1-order broadband bins, at the spectra's own resolution; g = 10·log10((P_meas + F)/
//    (P_twin + F)) with the comparison's floor F, as the families use;
//  - per-cell p-value: two-sided Student t with (draws − 1) degrees of freedom, t = g / sd, sd the
//    spread of g over the record's bootstrap draws over revolutions (the same draws as the families'
//    intervals): the spread is itself an estimate, and with a normal tail its error alone raised a
//    rejection in a third of no-effect tests at 50 draws. A parametric tail and not the draws' own ranks: Benjamini–Hochberg over tens of thousands of cells needs p-values far below
//    1/(draws + 1). A test over records per line would not do: a resonance fixed in Hz sits on
//    different lines at different speeds;
//  - Benjamini–Hochberg at q over all cells of all records; a cell counts when it is rejected and
//    its |g| is at least the practical minimum (min_feature_db);
//  - in each record, counted cells whose extents (in input orders) touch are one cluster; clusters
//    whose extents overlap within half a bin in orders, or in Hz, are one feature: the grouping seen
//    in the most records first (join_clusters);
//  - movement: the sightings' centres in orders and in Hz at speeds ≥ min_speed_ratio apart; spread
//    within one order and beyond one bin in Hz: fixed in orders; within one bin in Hz (one input order
//    at the fastest sighting) and beyond one order: fixed in Hz; beyond both: neither; within both
//    (or one speed): undetermined;
//  - size: per sighting the largest |g| with its sign, the mean over sightings; its interval the
//    normal 90 % interval from the cells' bootstrap spreads (records independent);
//  - broadband floors: each record's floor per band (compare_floors) is one more cell per band in
//    the same test; floor bands cluster and join among themselves (floor_features());
//  - broadband peaks: each band of band_bins bins once more against its neighbourhood
//    (local_expectation), g = 10·log10(ΣM / ΣE) without the comparison's floor, in the same test,
//    one-sided (rising only), p from the χ² law of the record's Welch bins (LocalPeakLaw); their own
//    layer, a feature only where seen in half the records and no line or bin feature overlaps it in Hz.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/types/gap_report.hpp"

namespace gearwatch::gap {

/// The per-capture broadband floor (compare_floors).
struct FloorSettings {
  double lowest_hz = 10;           ///< bands start here
  double bands_per_octave = 6;     ///< band edges (a band takes whole bins; narrower ones join the next)
  std::size_t min_bins = 8;        ///< bins per band at least: a median over fewer is not a floor
  /// The acquisition's own floor is this quantile of the bands' excess over the twin: the floor a
  /// capture shows over most of its band is its own, not a gap (assumption: white, and a floor
  /// change leaves at least this share of the bands alone).
  double acquisition_quantile = 0.1;
  /// A band informs the acquisition's floor when its measured floor is this many times the twin's
  /// (elsewhere the twin's own floor hides it, and the excess is a difference of two large numbers).
  double excess_ratio = 2;
};

/// One band of the broadband floors: the median power per 1-order bin over its bins (the median
/// passes over non-synchronous tones and what leaks from lines).
struct FloorBand {
  double hz_low = 0, hz_high = 0;    ///< the band's bins' extent, Hz
  std::size_t first = 0, count = 0;  ///< broadband bins [first, first + count) (index k − 1 for orders [k, k+1))
  double measured = 0, twin = 0;
};

/// A record pair's broadband floors band by band, and the measured capture's own floor per bin
/// (its acquisition: quantisation, sensor noise) that the twin lacks. A floor change lies where the
/// measured floor departs from the twin's plus the acquisition's: g = 10·log10(M / (T + A)). This
/// sees a floor step however far it lies under the comparison's fixed floor (floor_db), which is set
/// by what a rig shows against the twin and not by the capture. A change over the whole band is
/// the capture's own floor to this comparison: it cannot be told from the acquisition's.
struct FloorComparison {
  std::vector<FloorBand> bands;
  double acquisition = 0;
  double gap_db(std::size_t band) const;
};
/// Throws nothing: spectra without broadband bins give no bands.
FloorComparison compare_floors(const SpectralSummary& measured, const SpectralSummary& twin, const FloorSettings& settings = {});

/// Each broadband bin against its own neighbourhood (local_expectation): a peak a few bins wide
/// (a narrow resonance between the lines, where no line falls on it) is seen however far under the
/// comparison's floor it lies, as long as it stands over the capture's own floor beside it.
struct LocalPeakSettings {
  /// On: the cells' p-values come from the χ² law of the record's Welch bins (local_peak_cells),
  /// and a local peak counts only where it persists over records (min_record_share).
  bool enabled = true;
  /// The reference bins lie this many bins and more away on either side: a peak whose half-width
  /// is under it leaves its reference alone; anything broader is a floor change (the floors' bands).
  std::size_t inner_bins = 4;
  std::size_t outer_bins = 24;      ///< and at most this many: the neighbourhood stays local
  std::size_t min_reference = 8;    ///< bins the reference's medians need at least (half each side)
  /// Bins a local cell sums (centred): a peak a few bins wide falls into it whole, and the sum's χ²
  /// has this many times one bin's degrees of freedom, so a short record's scatter stays far under
  /// the practical minimum.
  std::size_t band_bins = 3;
  /// A local peak is a feature only when seen in this share of the records, and in 2 at least: a
  /// resonance of the machine is in every record whose band holds it, while the chance peaks that
  /// Benjamini–Hochberg admits (a share q of its rejections, more of them the more a real effect
  /// rejects) fall at places of their own in each record, two of which can meet by chance.
  double min_record_share = 0.5;
  /// The records of `records` a local peak must be seen in: min_record_share of them, 2 at least.
  std::size_t records_needed(std::size_t records) const {
    return std::max<std::size_t>(2, static_cast<std::size_t>(std::ceil(min_record_share * static_cast<double>(records) - 1e-9)));
  }
  /// The χ² law (local_peak_law) needs this many input revolutions: over fewer blocks the cells'
  /// tail is heavier than two moments give (gap.md), and a shorter record has no local cells.
  std::size_t min_revolutions = 20;
};

/// The measured broadband's expectation per bin from its neighbourhood: (T_k + A)·max(median_j r_j
/// below k, above k), r_j = M_j / (T_j + A) over the bins j at inner_bins..outer_bins from k on each
/// side (the higher side: a floor's edge is not a peak), A the
/// capture's acquisition floor (compare_floors): with no effect the measurement is the twin plus
/// its own floor, and any change smooth over the neighbourhood (a floor step, a tilt) is in the
/// median. NaN where the reference is short or T_k + A is 0.
std::vector<double> local_expectation(const SpectralSummary& measured, const SpectralSummary& twin, double acquisition,
                                      const LocalPeakSettings& settings);

/// Equivalent χ² degrees of freedom (Satterthwaite: 2·mean²/variance) of `half_bins` adjacent
/// half-order bins of the broadband part summed, averaged over `blocks` independent-mean Hann
/// blocks of 2 revolutions at 50 % overlap, for Gaussian noise flat over them: the power of a
/// complex Gaussian bin covaries with another's as |their covariance|², which the window sets.
double welch_dof(std::size_t half_bins, double blocks);

/// The law of a local cell's ratio ΣM/ΣE under no peak (local_expectation): ΣM is its bins' mean
/// times χ²_ν/ν (ν = welch_dof of the cell's half-order bins over the record's B − 1 blocks); E
/// is that mean times the larger of two sides' medians of the reference ratios, each ratio
/// χ²_ν1/ν1 (one bin's ν1), the median's law that of the middle order statistic of the side's
/// bins (their count divided by 1 + 2ρ, ρ the correlation of adjacent bins' powers). P(ratio ≥ s)
/// integrates the χ² tail over the medians' law. Empty under min_revolutions.
struct LocalPeakLaw {
  double cell_dof = 0, bin_dof = 0;
  std::vector<double> reference, weight;  ///< the larger median's values and their probability weights
  bool valid() const { return !reference.empty(); }
  double p_value(double ratio) const;
};
LocalPeakLaw local_peak_law(std::size_t input_revolutions, const LocalPeakSettings& settings);

/// A local cell centred on one broadband bin: its bins' sum over their expectation
/// (local_expectation), dB, and its one-sided p-value by the record's LocalPeakLaw; NaN where the
/// cell has no expectation, p NaN too where the law is empty (under min_revolutions, or not given).
struct LocalPeakCell {
  double gain_db;
  double p;
};
/// [k]: the cell centred on broadband bin k. The one computation of a local cell, for the
/// comparison of the spectra and for each bootstrap draw (there with an empty law).
std::vector<LocalPeakCell> local_peak_cells(const SpectralSummary& measured, const SpectralSummary& twin, double acquisition,
                                            const LocalPeakSettings& settings, const LocalPeakLaw& law);

struct FeatureSettings {
  double false_discovery_rate = 0.05;  ///< Benjamini–Hochberg q over all cells
  /// The practical minimum of a feature's cells, dB: a factor of two in power, the half-power
  /// criterion that bounds a resonance's band. A lumped model is not asked to hold each single line
  /// closer than that; the families (RMS over many lines) keep their own, smaller minima.
  double min_feature_db = 3.0;
  double min_speed_ratio = 1.05;       ///< sightings at speeds this far apart can tell orders from Hz
  double coverage = 0.90;              ///< of the size's interval
  FloorSettings floor;                 ///< the broadband floors' bands (floor features)
  LocalPeakSettings local;             ///< the broadband bins against their neighbourhood (broadband_peak cells)
};

/// One record pair the features are read from: its spectra over all revolutions and the floor.
struct FeaturePair {
  const SpectralSummary* measured = nullptr;
  const SpectralSummary* model = nullptr;
  double floor = 0;
  bool held_out = false;     ///< where it sits in the diagnosis (reported with each sighting)
  std::size_t record = 0;
};

/// Collects the cells' bootstrap spreads draw by draw (Welford), then finds the features.
class FeatureFinder {
 public:
  FeatureFinder(const std::vector<FeaturePair>& pairs, const GearPairSpec& gears, FeatureSettings settings = {});
  /// One bootstrap draw of pair `pair`: its measured and model summaries over the same redrawn
  /// revolutions as the families' (sizes as the full summaries').
  void add_draw(std::size_t pair, const SpectralSummary& measured, const SpectralSummary& model);
  /// The features, largest |size| first. Needs ≥ 2 draws of every pair (a pair without its spread
  /// has no p-values and no cells counted).
  std::vector<GapFeature> features() const;
  /// The features of the broadband floors (compare_floors: one cell per band, in the same
  /// Benjamini–Hochberg test as the lines and bins), found and joined as features() finds its own;
  /// largest |size| first.
  std::vector<GapFeature> floor_features() const;
  /// Cells rejected by Benjamini–Hochberg (before the practical minimum), for tests.
  std::size_t rejected_cells() const;

  /// A peak of a feature in one record (a cell no cell of the feature within one order of it
  /// stands over), where it stands: a piece of the feature's movement (movement_of_pieces).
  struct Piece {
    double speed_hz, order, hz;
  };
  enum class CellKind : std::uint8_t { input_line, output_line, broadband, floor_band, broadband_peak };
  struct Cell {
    CellKind kind;
    std::size_t index;      // order − 1 (lines), bin − 1 (broadband), band (floor_band)
    double low, high;       // extent in input orders
    double centre;          // input orders
    double g;               // dB
    double n = 0, mean = 0, m2 = 0;  // Welford over the draws
    double law_p = std::numeric_limits<double>::quiet_NaN();  // a local cell's p from its χ² law
    double sd() const;
  };

 private:
  struct RecordCells {
    FeaturePair pair;
    double speed_hz, torque_nm;
    std::vector<Cell> cells;
  };
  /// A run of touching counted cells of one record, with its extent in input orders (floor bands
  /// and lines/bins cluster apart: a floor band spans many lines).
  struct Cluster {
    std::size_t record;
    std::vector<std::size_t> cells;
    double low, high;
  };
  enum class Layer : std::uint8_t { lines_and_bins, floor_bands, local_peaks };
  std::vector<GapFeature> layer_features(Layer layer) const;
  std::vector<Piece> pieces_of(const std::vector<Cluster>& clusters, const std::vector<std::size_t>& group) const;
  GapFeature feature_of(const std::vector<Cluster>& clusters, const std::vector<std::size_t>& group,
                        const std::vector<std::vector<double>>& cell_p) const;
  /// The clusters joined into features: repeatedly, of the groups of clusters whose extents overlap
  /// within half a bin in orders, and of those that overlap so in Hz, the one seen in the most
  /// records (then the largest Σ|g|) is a feature, and its clusters leave. A line fixed in orders
  /// meets another harmonic's line at the same Hz at some pair of speeds; joining on either axis at
  /// once would chain them.
  std::vector<std::vector<std::size_t>> join_clusters(const std::vector<Cluster>& clusters) const;
  std::vector<double> p_values(std::vector<std::pair<std::size_t, std::size_t>>& where) const;
  std::vector<char> counted(std::size_t& rejected) const;
  std::vector<RecordCells> records_;

  void add_local_cells(std::vector<Cell>& cells, const SpectralSummary& measured, const SpectralSummary& model,
                       double acquisition, std::map<std::size_t, LocalPeakLaw>& laws) const;
  GearPairSpec gears_;
  FeatureSettings settings_;
};

/// Two features as one (describe.hpp joins a resonance's flanks seen at different speeds): the
/// sightings of both, the extents' union, the smaller p-value, the size the mean over all sightings
/// with its interval from both intervals' spreads (records independent), the shaft of the larger
/// feature; the movement as the movement rule reads the joint sightings.
GapFeature joined_features(const GapFeature& a, const GapFeature& b, const GearPairSpec& gears, double min_speed_ratio);

/// The Benjamini–Hochberg rejections at level q of the given p-values (step-up: the largest k with
/// p_(k) ≤ q·k/m, and every p at or below it).
std::vector<char> benjamini_hochberg(const std::vector<double>& p, double q);

}  // namespace gearwatch::gap
