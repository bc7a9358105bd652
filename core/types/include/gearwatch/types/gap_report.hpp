#pragma once
// Value types of the sim-to-real gap diagnosis: where the twin disagrees with the measured gearbox
// (families of spectral lines and bands), which candidate effect explains it, and how far the gap
// shrinks on held-out records once that effect is added. Plain values, shared by the diagnosis
// (core/gap), storage (gap_reports) and the report page, so every name that crosses into the
// schema comes from the enums below and nowhere else.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace gearwatch::gap {

/// A family of spectral content the twin's output and a measurement are compared on.
enum class FamilyKind : std::uint8_t {
  input_shaft_orders = 0,   ///< integer orders of the input (pinion) shaft other than mesh harmonics and their first sidebands
  output_shaft_orders = 1,  ///< integer orders of the output (gear) shaft other than the first sidebands
  mesh_harmonics = 2,       ///< n·GMF
  input_sidebands = 3,      ///< n·GMF ± 1 input order (m = 1..kSidebandOrders, spectra.hpp)
  output_sidebands = 4,     ///< n·GMF ± 1 output order
  fixed_frequency = 5,      ///< bands that stay in Hz across speeds (resonances); needs ≥ 2 speeds
  broadband = 6,            ///< what is left between the lines (noise floor, CS2 carriers)
};
const char* to_string(FamilyKind family) noexcept;
inline constexpr std::array kAllFamilyKinds{FamilyKind::input_shaft_orders, FamilyKind::output_shaft_orders,
                                            FamilyKind::mesh_harmonics,     FamilyKind::input_sidebands,
                                            FamilyKind::output_sidebands,   FamilyKind::fixed_frequency,
                                            FamilyKind::broadband};

/// A candidate unmodelled effect: a parametric addition to the twin's output with the families it
/// can explain. These are the diagnosis's own forms; they share names, not code, with the rig
/// simulator's truth effects.
enum class CandidateEffect : std::uint8_t {
  casing_mode = 0,        ///< foundation/casing modes driven by the bearing forces: fixed in Hz
  tooth_errors = 1,       ///< tooth-to-tooth spacing/profile errors: shaft-order lines and sidebands
  eccentricity = 2,       ///< shaft run-out: first-order modulation of the mesh
  tip_relief = 3,         ///< gradual engagement: a change of the mesh harmonics' amplitudes
  speed_fluctuation = 4,  ///< VFD speed ripple: phase modulation smearing lines in orders
  load_fluctuation = 5,   ///< brake torque ripple: low-frequency amplitude modulation of the mesh
  noise_floor = 6,        ///< sensor noise: an additive white floor
  mount_resonance = 7,    ///< accelerometer mounting resonance: a transmissibility peak, fixed in Hz
  misalignment = 8,       ///< face misalignment: mean mesh stiffness loss, harmonic balance change
  backlash = 9,           ///< contact loss: harmonics of the mesh raised non-linearly
};
const char* to_string(CandidateEffect effect) noexcept;
inline constexpr std::array kAllCandidateEffects{
    CandidateEffect::casing_mode,       CandidateEffect::tooth_errors,     CandidateEffect::eccentricity,
    CandidateEffect::tip_relief,        CandidateEffect::speed_fluctuation, CandidateEffect::load_fluctuation,
    CandidateEffect::noise_floor,       CandidateEffect::mount_resonance,  CandidateEffect::misalignment,
    CandidateEffect::backlash};

struct Interval {
  double low = 0;
  double high = 0;
};

/// How a feature's location moves with the speed across the records it was seen in (features.hpp
/// gives the rule): it stays at one order (a line or a modulation of a shaft), at one frequency
/// (a resonance, a tone from elsewhere), neither, or the records' speeds are too close to tell.
enum class FeatureMovement : std::uint8_t {
  fixed_in_orders = 0,
  fixed_in_hz = 1,
  neither = 2,
  undetermined = 3,
};
const char* to_string(FeatureMovement movement) noexcept;
inline constexpr std::array kAllFeatureMovements{FeatureMovement::fixed_in_orders, FeatureMovement::fixed_in_hz,
                                                 FeatureMovement::neither, FeatureMovement::undetermined};

/// The shaft whose orders a feature's order counts.
enum class FeatureShaft : std::uint8_t {
  input = 0,   ///< the pinion's (input) shaft
  output = 1,  ///< the gear's (output) shaft
};
const char* to_string(FeatureShaft shaft) noexcept;
inline constexpr std::array kAllFeatureShafts{FeatureShaft::input, FeatureShaft::output};

/// One record a feature was seen in: where it sat there and how large it was.
struct FeatureSighting {
  bool held_out = false;      ///< the diagnosis's held-out set (else training)
  std::size_t record = 0;     ///< index in that set
  double speed_hz = 0;        ///< the record's input speed
  double torque_nm = 0;       ///< NaN: the record has none
  double order = 0;           ///< centre in input orders (|g|-weighted over the feature's lines/bins there)
  double hz = 0;              ///< the same in Hz
  double size_db = 0;         ///< the largest |g| of its lines/bins there, with its sign
};

/// The phenomenological form a feature is described by (describe.hpp gives the forms and the rule
/// that chooses one): what it is, whether or not a physical candidate explains it.
enum class DescriptionKind : std::uint8_t {
  none = 0,          ///< no form removes the feature's gap (or it was not described)
  resonance = 1,     ///< a resonance fixed in Hz: frequency_hz, damping_ratio, gain_db
  modulation = 2,    ///< a modulation of the mesh at a shaft's order: am_index, pm_index_rad, am_power_share (`shaft`)
  ghost_line = 3,    ///< a line at a non-integer order: order, amplitude_m_s2
  fixed_tone = 4,    ///< tones fixed in Hz: frequency_hz, amplitude_m_s2 (the lowest), fundamental_hz, harmonic, supply_hz, tones, tone_k_hz/_amplitude_m_s2/_harmonic
  floor_change = 5,  ///< a broadband floor change: level_db (at 1 kHz), slope_db_per_decade
  path_tilt = 6,     ///< a transfer-path tilt over the mesh harmonics: tilt_db_per_octave, level_db
};
const char* to_string(DescriptionKind kind) noexcept;
inline constexpr std::array kAllDescriptionKinds{DescriptionKind::none,       DescriptionKind::resonance,
                                                 DescriptionKind::modulation, DescriptionKind::ghost_line,
                                                 DescriptionKind::fixed_tone, DescriptionKind::floor_change,
                                                 DescriptionKind::path_tilt};

/// A feature described by one form with its parameters in physical units (the unit in each name's
/// suffix: _hz, _db, _rad, _m_s2 peak; none: a ratio or an order).
struct FeatureDescription {
  DescriptionKind kind = DescriptionKind::none;
  FeatureShaft shaft = FeatureShaft::input;  ///< modulation: whose order; ghost_line: whose orders
  std::vector<std::pair<std::string, double>> parameters;
  double gap_db = 0;       ///< RMS of g over the cells the form was judged on, twin alone
  double residual_db = 0;  ///< the same with the form added
  /// The parameter's value (NaN when the description has none by that name).
  double parameter(const std::string& name) const noexcept;
};
/// "a 15 % AM at the gear shaft's order (PM 0.002 rad)", "a resonance at 1100 Hz, ζ 0.011, +12.0 dB", ...
std::string describe(const FeatureDescription& description);

/// A gap at the resolution of a line or a band (features.hpp): adjacent lines/bins of one record
/// whose measured-vs-twin ratio is significant over all lines and bins (Benjamini–Hochberg) and at
/// least the practical minimum, joined across records where they sit at one order or one Hz.
struct GapFeature {
  FeatureMovement movement = FeatureMovement::undetermined;
  FeatureShaft shaft = FeatureShaft::input;  ///< whose orders `order` counts (the shaft of its largest line)
  double order = 0;                ///< centre, mean over the sightings, in `shaft`'s orders
  double order_low = 0, order_high = 0;  ///< extent of its lines/bins over the sightings, same orders
  double hz = 0;                   ///< centre, mean over the sightings, Hz
  double hz_low = 0, hz_high = 0;  ///< extent over the sightings, Hz
  double size_db = 0;              ///< mean over the sightings of their size_db: 10·log10(measured/twin)
  Interval size_interval_db;       ///< 90 %, from the records' bootstrap over revolutions
  double p_value = 1;              ///< the smallest per-bin p-value among its lines/bins (before BH)
  std::vector<FeatureSighting> seen_in;
  FeatureDescription description;  ///< what form it has (describe.hpp), explained or not
  /// The chosen candidate that explains it (attribution.hpp: explaining_candidate); none: no physical
  /// candidate does.
  std::optional<CandidateEffect> explained_by;
};
/// "not explained by a physical candidate; described as a 15 % AM at the gear shaft's order (PM
/// 0.002 rad)" or "explained by casing_mode; described as a resonance at ...".
std::string statement(const GapFeature& feature);
/// "input order 23.4, fixed in orders, +33.1 dB [32.9, 33.3]" (the place the movement points at).
std::string describe(const GapFeature& feature);

/// A fitted parameter at an end of its candidate's range: the fit would go further if it could.
struct ParameterBound {
  std::string name;        ///< the parameter's name (SI unit in its suffix)
  double bound = 0;        ///< the end it sits at
  bool upper = true;       ///< true: it would need more than `bound`; false: less
};
/// A bound in the unit people read it in: the value, its unit and the quantity's words
/// ("gear_run_out_m" at 3e-4: 300, "µm", "gear run-out").
struct BoundReading {
  double value = 0;
  std::string unit;
  std::string quantity;
};
BoundReading reading_of(const ParameterBound& bound);
/// "eccentricity would need > 300 µm gear run-out (gear_run_out_m at the top of its range)".
std::string describe(CandidateEffect effect, const ParameterBound& bound);

/// The gap in one family between a measurement and the twin (or the twin plus candidate effects).
struct FamilyGap {
  FamilyKind family = FamilyKind::broadband;
  bool resolved = true;                ///< false when the records cannot separate this family
  std::string unresolved_reason;       ///< why not (e.g. "fixed_frequency needs records at >= 2 speeds")
  double distance_db = 0;              ///< RMS over the family's lines/bins of 10·log10(P_measured / P_model)
  Interval distance_interval_db;       ///< block bootstrap over revolutions (90 %)
  double energy_share = 0;             ///< this family's share of the measured-vs-model energy difference
  bool significant = false;            ///< distance beyond what the bootstrap allows for no gap
};

/// One candidate effect fitted on the training records and scored on the held-out ones.
struct CandidateScore {
  CandidateEffect effect = CandidateEffect::noise_floor;
  std::vector<std::pair<std::string, double>> parameters;  ///< fitted values, name → value (SI units)
  std::vector<FamilyKind> explains;                        ///< the families this effect can act on
  std::vector<FamilyGap> held_out_after;                   ///< every family, held out, with this effect
  double shrinkage = 0;                 ///< 1 − after/before of the distance in its own families (held out)
  double information_criterion = 0;     ///< held-out fit quality penalised by the parameter count; lower is better
  /// Helps its own families but pushes another beyond its interval (held out, alone). The greedy
  /// choice adopts no candidate that does so at its step: its families stay unexplained.
  bool worsens_other_family = false;
  /// Fitted values at an end of their range: the physics this candidate stands for would need a
  /// value beyond it (reported, so a bounded fit is not read as a fit that failed silently).
  std::vector<ParameterBound> at_bounds;
};

/// One diagnosis: held-out gaps before, the ranked candidates, the greedy choice, gaps after.
struct GapReport {
  double input_revolutions = 0;               ///< life position of the newest record used
  std::vector<double> speeds_hz;              ///< the operating speeds the records cover
  std::size_t training_records = 0;
  std::size_t held_out_records = 0;
  std::vector<FamilyGap> before;              ///< held out, twin alone
  std::vector<CandidateScore> candidates;     ///< best first
  std::vector<CandidateEffect> chosen;        ///< greedy addition, in order
  std::vector<FamilyGap> after;               ///< held out, twin plus the chosen effects
  std::vector<FamilyKind> unexplained;        ///< significant families no candidate explains
  /// Gaps at the resolution of a line or a band (every record, training and held out, against the
  /// twin alone), largest |size| first; the families above are their summary.
  std::vector<GapFeature> features;
  /// K_wear inferred from the held-out records' RMS_SA (per-record ratios combined by least squares in the log)
  /// with the twin alone and with the chosen effects added; empty unless the caller gave the
  /// twin's reference K_wear (DiagnosisSettings::reference_k_wear).
  std::optional<double> k_wear_before;
  std::optional<double> k_wear_after;
  /// Spectra for plots (one held-out record): order axis (input orders) and Hz axis, in dB.
  std::vector<double> order_axis, measured_order_db, twin_order_db, twin_after_order_db;
  std::vector<double> hz_axis, measured_hz_db, twin_hz_db, twin_after_hz_db;
  /// Where each family lies on those axes, for shading.
  std::vector<std::pair<FamilyKind, Interval>> order_bands, hz_bands;
};

}  // namespace gearwatch::gap
