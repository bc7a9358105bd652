#pragma once
// Which chosen candidate explains a feature (features.hpp): the one whose addition removes the
// feature's own gap on the held-out records, by the rule that says a description removes it
// (describe.hpp). Pure computation, no I/O.
//
// Rule (docs/gap.md, "Attribution"): a floor feature a white PSD explains on its own bands
// (`white_psd_m2_s4_per_hz`) is the noise floor's, chosen or not. Any other feature's held-out cells
// are the lines and bins of each held-out record it was seen in, inside its extent (in Hz for a
// feature fixed in Hz, else in orders), whose |g| against the twin alone is at least the practical
// minimum. With the twin plus the first k chosen effects (in the order they were chosen), the RMS of
// g over those cells; the candidate whose addition first brings it under the practical minimum
// explains the feature. A candidate that lowers a feature's gap only part way does not: a flexible
// form (per-line gains) lowers many gaps it does not make. A feature the held-out records do not
// show (a narrow resonance between the held-out speed's lines) is judged on its training cells the
// same way: the candidate was chosen on the held-out families, and where the feature is seen is the
// only evidence of whether that candidate makes it. When the cells name none, the family evidence
// (family_explaining_candidate) is asked; alone it named nothing for a feature whose own gap a
// chosen candidate removes while its family stays significant elsewhere.
#include <cstddef>
#include <optional>
#include <vector>

#include "gearwatch/gap/features.hpp"
#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/types/gap_report.hpp"

namespace gearwatch::gap {

/// One record (held out or training): the measured spectra, the twin's alone, and the twin with the
/// first k + 1 chosen effects for each k (`with_chosen[k]`), all with the comparison's floor F.
struct RecordModels {
  const SpectralSummary* measured = nullptr;
  const SpectralSummary* twin = nullptr;
  std::vector<const SpectralSummary*> with_chosen;
  double floor = 0;
};

/// The RMS of g = 10·log10((P_meas + F)/(P_model + F)) over the feature's cells in `records` (the
/// held-out set when `held_out`, else the training set: the sightings' records), with the model
/// `with_chosen[step]` (step −1: the twin alone). NaN when the feature has no cell there.
double feature_gap_db(const GapFeature& feature, const std::vector<RecordModels>& records, bool held_out, int step,
                      const GearPairSpec& gears, double min_feature_db);

/// The candidate that explains a feature (the rule above); `chosen` in the order chosen, one entry
/// per step of every record's `with_chosen`. None: no candidate does.
std::optional<CandidateEffect> explaining_candidate(const GapFeature& feature, const std::vector<RecordModels>& held_out,
                                                    const std::vector<RecordModels>& training,
                                                    const std::vector<CandidateEffect>& chosen, const GearPairSpec& gears,
                                                    double min_feature_db);

/// A structural resonance's casing mode, fitted on a feature's own cells (`casing_mode_for_resonance`).
struct CasingModeFit {
  double mode_hz = 0, damping_ratio = 0, modal_mass_kg = 0;  ///< one mode of casing_mode's form
  double residue_phase_rad = 0;  ///< its residue's phase at the sensor against the bearing-force path's
  double gap_before_db = 0, gap_after_db = 0;  ///< RMS of g over the judged cells, twin alone / with the mode
  bool held_out = true;                        ///< judged on held-out cells (else on the training cells)
  bool explains = false;                       ///< gap_after_db under the practical minimum, its window not made worse
};

/// A feature described as a resonance (fixed in Hz or seen at one speed) that no chosen candidate
/// explains is casing_mode's when one casing mode fitted on the training records' cells about it
/// removes its gap. A narrow mode (half-power band 2ζf_n of a few tens of Hz) lifts one line of a
/// record at most, often none, and the residual's bins under its band: a few cells among thousands,
/// which no family RMS shows, so the greedy choice never reaches it, and casing_mode's own fit spends
/// its second mode elsewhere. The mode is casing_mode's form with both modes at f_n and a complex
/// residue (CasingModeTerm: its phase at the sensor), ζ down to a steel casing's material damping,
/// each bin reading the gain averaged over its half-order bins (binned.hpp). It is fitted where the
/// training records show it: every line and bin within the feature's extent and two bins of the
/// fastest record each side when one of the feature's training cells rises by the minimum (a grid
/// over ζ, f_n, the mass and the phase, then compass searches from each ζ's best and from the
/// description's f_n and ζ); else their local cells (features.hpp: a bin's band against its local
/// expectation E, E times the gain), from the description's f_n and ζ. Judged as explaining_candidate
/// judges, on the cells of the same kind: the feature's held-out cells with |g| at the practical
/// minimum (its training cells when no held-out record shows it), RMS under the minimum with the
/// mode; and the RMS over the held-out records' window not made worse. Power cannot tell the mode from
/// its mirror (same f_n and ζ, another mass and phase, docs/gap.md): the fit reports one of the two.
/// Needs the twin's bearing-force path on the twin's spectra (none: nullopt).
std::optional<CasingModeFit> casing_mode_for_resonance(const GapFeature& feature, const std::vector<RecordModels>& held_out,
                                                       const std::vector<RecordModels>& training, const GearPairSpec& gears,
                                                       const FeatureSettings& settings);

/// The family evidence, asked when the feature's own cells name none: the first chosen candidate in
/// report.chosen whose families hold the family the feature's place belongs to (a modulation's: its
/// shaft's sidebands; fixed in Hz: fixed_frequency; else its line's, or broadband off the integer
/// orders), unless that family stays significant after the choice. None: no candidate does.
std::optional<CandidateEffect> family_explaining_candidate(const GapReport& report, const GapFeature& feature,
                                                           const GearPairSpec& gears);

}  // namespace gearwatch::gap
