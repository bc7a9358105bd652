#pragma once
// Describing a feature (features.hpp) in a phenomenological form with parameters in physical units,
// whether or not a physical candidate explains it: the report can then say what the gap is
// ("a 15 % AM at the gear shaft's order") and not only where. Pure computation, no I/O.
//
// Forms (docs/gap.md, "Descriptions"), each predicting every cell's measured power from the twin's:
//  - resonance, fixed in Hz: power × (1 + (G − 1)·L(f)), L = (2ζr)²/((1 − r²)² + (2ζr)²), r = f/f_n:
//    the normalised second-order band-pass, 1 at f_n and ½ at its half-power points; f_n, ζ, G (dB);
//  - modulation of the mesh at one shaft's order: the first sidebands n·z ± 1 of that shaft. With
//    the lines' phases, per mesh harmonic n relative to its carrier, u + conj(l) = m·e^{iφ} (AM) and
//    u − conj(l) = n·β·e^{iψ} (PM of the mesh, n·β on harmonic n), the twin's own subtracted; m and β
//    are the carrier-power-weighted means over the harmonics (per record, then over records: a
//    record's zero angle of the gear is its own). Predicted with phases: every line of each
//    harmonic's modulated spectrum (Jacobi–Anger, the carrier's J0 loss and PM's lines beyond the
//    first). Without phases: one index from the sidebands' excess power (m²/4 of the carrier
//    each), AM or PM undecided;
//  - ghost line at a non-integer order / tone fixed in Hz: a non-synchronous tone as RecordSpectra
//    sees it (add_non_synchronous_tone), at one order (ghost) or one frequency (tone) in every
//    record, one amplitude; a ghost's order then refined from the lines beside it (the rectangular
//    window's interpolation) and a unit tone's record reduced by RecordSpectra, its power the
//    excess summed over the window against that unit's share (tone_as_measured); a tone within `supply_tolerance_orders` of a harmonic of 50 or 60 Hz is
//    supply pick-up, and tones at integer multiples of the lowest tone are its harmonics;
//  - floor change: the broadband bins × 10^((L + S·log10(f/1 kHz))/10), least squares over every
//    broadband bin above the comparison's floor; for a feature of the broadband floors
//    (FeatureFinder::floor_features) the same line fitted to the floors' g (compare_floors) over
//    the bands whose centre lies in its extent, the only form offered there (describe_floor);
//  - path tilt: every line and bin × 10^((c + T·log2(f/f_mesh))/10), f_mesh the first mesh harmonic,
//    least squares over the mesh harmonics (the path's strongest, cleanest lines).
// Rule: each form is judged on the feature's window (its extent widened by half its width, at least
// two input orders, in every record, in Hz for a feature fixed in Hz); it removes the feature's gap
// when the RMS of g − ĝ over the window's cells at or beyond the practical minimum falls under that
// minimum; of those, the least BIC = n·ln(max(RSS/n, resolution²)) + k·ln n. Ghost lines are not
// offered for a feature fixed in Hz, nor tones for one fixed in orders.
#include <complex>
#include <cstddef>
#include <functional>
#include <optional>
#include <vector>

#include "gearwatch/gap/features.hpp"
#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/types/gap_report.hpp"

namespace gearwatch::gap {

/// One record pair a description is fitted on (the pairs the features were found on).
struct DescribedRecord {
  const SpectralSummary* measured = nullptr;
  const SpectralSummary* twin = nullptr;
  double floor = 0;
  /// Complex synchronous lines (peak amplitude, phased on the tacho): input orders 1..K and output
  /// orders 1..M of the measured record and of the twin's. Empty: phases not known.
  std::vector<std::complex<double>> measured_input, measured_output, twin_input, twin_output;
};

struct DescriptionSettings {
  double min_feature_db = 3.0;          ///< the finder's practical minimum: a form must bring the feature under it
  double resolution_db = 0.05;          ///< RSS floor per cell in the criterion (differences below are not told apart)
  double supply_tolerance_orders = 0.1; ///< a tone this near k·50/60 Hz (in input orders at the top speed) is supply
  int max_supply_harmonic = 40;
  FloorSettings floor;                  ///< the broadband floors' bands, as the finder's (floor features)
  LocalPeakSettings local;              ///< the bins' neighbourhood, as the finder's (local_resonance)
  double min_speed_ratio = 1.05;        ///< the finder's (the diagnosis copies it): joined resonance flanks at speeds this far apart are fixed in Hz
};

class FeatureDescriber {
 public:
  /// Throws std::invalid_argument for a record without spectra.
  FeatureDescriber(const std::vector<DescribedRecord>& records, const GearPairSpec& gears, DescriptionSettings settings = {});
  /// The form the rule chooses for one feature (kind none: no form removes its gap).
  FeatureDescription describe(const GapFeature& feature) const;
  /// Every feature's description; features described as resonances seen at no common speed joined
  /// when one resonance over their joint window removes the gap there (join_resonance_flanks); then
  /// the tones' harmonics and supply pick-up over all of them.
  void describe_all(std::vector<GapFeature>& features) const;
  /// A feature of the broadband floors (FeatureFinder::floor_features): a floor change (level at
  /// 1 kHz, slope per decade) fitted to the floors' g over the bands whose centre lies in its extent
  /// in Hz, when it brings the bands at the practical minimum under it; else none.
  /// With the floor change, when the noise_floor candidate's form (a white PSD S added to every
  /// record, 2·S·speed per 1-order bin) brings the feature's bands at the practical minimum under
  /// it: `white_psd_m2_s4_per_hz` = S, (m/s²)²/Hz.
  FeatureDescription describe_floor(const GapFeature& f) const;
  /// The white PSD that explains a floor feature's bands (the rule of the forms), NaN when none does.
  /// With the step form's corner, its bands above the corner: the band the corner cuts is raised
  /// only over part of it, which white noise above a corner does, white noise everywhere does not.
  double white_floor_psd(const GapFeature& f, double corner_hz = 0.0) const;

  enum class CellKind : std::uint8_t { input_line, output_line, broadband };
  struct Cell {
    CellKind kind;
    std::size_t index;  // order − 1 (lines), bin − 1 (broadband)
    double order;       // centre, input orders
    double hz;
    double twin, measured;  // power
  };
  /// A form's prediction: the measured power of cell `cell` of record `record`.
  using Prediction = std::function<double(std::size_t record, std::size_t cell)>;
  struct Fit {
    FeatureDescription description;
    Prediction predict;
    int complexity = 0;  ///< fitted parameters
  };
  /// The global forms (fitted over their whole domain once; exposed for tests).
  Fit floor_change() const;
  Fit path_tilt() const;
  Fit modulation(FeatureShaft shaft) const;

 private:
  struct RecordCells {
    const DescribedRecord* source;
    double speed_hz, floor;
    std::vector<Cell> cells;
  };
  using Window = std::vector<std::pair<std::size_t, std::size_t>>;  // (record, cell)
  Window window_of(const GapFeature& f) const;
  /// The window's gap (RMS of g; none when no cell reaches the practical minimum) and, of `fits`,
  /// the one the rule chooses (least BIC among those that bring the cells at the minimum under it).
  FeatureDescription chosen_form(const std::vector<Fit>& fits, const Window& w) const;
  /// A narrow resonance fixed in Hz between the mesh harmonics shows, at each speed, only on the
  /// few lines that fall on it (a mesh harmonic on one flank at one speed, on the other flank at
  /// another), further apart in Hz than the finder's joining reaches. Two features, each described as
  /// a resonance or seen at one speed only (a flank line alone may read as a tone), seen at no common
  /// speed and within an octave together, become one feature (fixed
  /// in Hz when its speeds are min_speed_ratio apart) when, over their joint window in Hz, the rule
  /// chooses one resonance among the resonance and the global forms; repeated while a pair joins.
  void join_resonance_flanks(std::vector<GapFeature>& features) const;
  double g_of(std::size_t r, std::size_t c, double measured) const;
  Fit resonance(const GapFeature& f, const Window& w) const;
  /// A feature whose cells all lie under the comparison's floor, found in its bins' local peaks
  /// (features.hpp): the resonance form fitted to the window's broadband bins against their
  /// neighbourhood's expectation (local_expectation) with no floor, kept when it brings the bins that
  /// rise by the practical minimum under it and lifts such bins in as many records as the finder asks
  /// of a local peak; else none. Only rises: the local test is one-sided, and a bin's dip under its
  /// neighbourhood is its own scatter, which no form lifts. Not for a feature fixed in orders.
  FeatureDescription local_resonance(const GapFeature& f, const Window& w, const FeatureDescription& none) const;
  /// Up to max_tones non-synchronous tones (one place and power each), found one at a time where the
  /// window's g is worst explained, each kept only if it lowers the BIC; powers refitted together.
  Fit tones(const GapFeature& f, const Window& w, bool fixed_in_hz, int max_tones) const;
  /// Unit-power responses of a tone at `place` (input order, or Hz in every record) on the window's cells.
  std::vector<double> tone_response(double place, bool in_hz, const Window& w) const;
  /// Unit-power responses of a tone at `place` (input order, or Hz in every record), through the
  /// measurement itself: a record of that tone alone at each record's speed and revolutions, reduced
  /// by RecordSpectra. Unlike tone_response it holds what the averages' subtraction leaves in the
  /// broadband blocks.
  std::vector<double> tone_as_measured(double place, bool in_hz, const Window& w) const;
  class ToneSearch;
  /// A prediction of `predicted[record][cell]` where that is finite, the twin's power elsewhere.
  Prediction twin_elsewhere(std::vector<std::vector<double>> predicted) const;
  std::vector<RecordCells> records_;
  std::vector<DescribedRecord> sources_;
  GearPairSpec gears_;
  DescriptionSettings settings_;
  Fit floor_, tilt_, modulation_input_, modulation_output_;
  double carrier_pm_index_ = 0;  ///< the PM index the mesh carriers' loss shows (bounds where the sidebands are read)
  std::vector<FloorComparison> floors_;  ///< each record's broadband floors (compare_floors)
  std::vector<std::vector<double>> local_;  ///< each record's broadband expectation from its neighbourhood (local_expectation)
};

/// A record of a unit-amplitude tone at input order `order` alone, at the speed and whole
/// revolutions of `like` (constant speed, one tacho edge a revolution, half a revolution after the
/// last), sampled at `samples_per_cycle` samples a cycle of order `top_order` + 4 (at most like's
/// rate): the reduction works in orders, the rate only sets how far up the spectra go and how
/// closely the angular resampler's interpolation follows the tone.
Record unit_tone_record(double order, double top_order, const SpectralSummary& like, double samples_per_cycle);

/// unit_tone_record reduced as any record is (RecordSpectra::of_tone: the tone's angle-domain
/// samples in closed form): what the measurement makes of a non-synchronous tone.
SpectralSummary unit_tone_spectra(double order, double top_order, const SpectralSummary& like, const GearPairSpec& gears,
                                  double samples_per_cycle);

}  // namespace gearwatch::gap
