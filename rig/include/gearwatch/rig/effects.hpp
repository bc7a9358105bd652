#pragma once
// The effects the rig simulator (the "truth" gearbox) adds to the 21-DOF model, each switchable,
// with its parameters, documented ranges and physical meaning (docs/rig-simulator.md). The
// digital twin has none of them; the sim-to-real gap diagnosis must find them.
#include <cstdint>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace gearwatch::rig {

/// A parameter outside its documented range, an unknown effect or parameter name. The message
/// names the parameter.
struct RigParameterError : std::invalid_argument {
  explicit RigParameterError(const std::string& what) : std::invalid_argument(what) {}
};

enum class Effect {
  casing,             ///< foundation/casing modes: transfer path from bearing forces to the sensor
  tooth_errors,       ///< tooth-to-tooth spacing and profile-slope errors, per tooth, both gears
  eccentricity,       ///< eccentric pinion and/or gear shaft: transmission error at that shaft's order
  tip_relief,         ///< tip relief on both gears: gradual engagement instead of the stiffness step
  speed_fluctuation,  ///< motor/VFD speed ripple imposed on the drive
  load_fluctuation,   ///< brake torque ripple, held by the VFD's speed loop
  noise,              ///< sensor noise floor (white, one-sided PSD)
  mounting,           ///< accelerometer mounting resonance
  misalignment,       ///< angular misalignment of the shafts: load over part of the face width
  backlash,           ///< clearance: contact loss and back-flank impacts
};

const std::vector<Effect>& all_effects();
const char* effect_name(Effect e);
/// Throws RigParameterError for an unknown name.
Effect effect_from_name(const std::string& name);

/// One parameter of one effect, in the units of `unit`.
struct EffectParameter {
  Effect effect;
  const char* name;      ///< "effect.key", e.g. "casing.mode1_hz"
  const char* unit;
  double low, high;      ///< documented range (inclusive)
  double default_value;
  bool log_uniform;      ///< random draws uniform in log (ranges spanning decades)
  const char* meaning;
};

const std::vector<EffectParameter>& effect_parameter_table();
/// nullptr when unknown.
const EffectParameter* find_effect_parameter(const std::string& name);

/// Per-tooth errors (m): spacing (the whole flank early/late, + = material removed) and profile
/// slope (root → tip linear deviation, value at the tip relative to the root, + = tip removed).
struct ToothErrorPattern {
  std::vector<double> pinion_spacing_m, pinion_slope_m;  ///< z1 entries each
  std::vector<double> gear_spacing_m, gear_slope_m;      ///< z2 entries each
};

/// Which effects are on, with which parameters. Values are checked against the table on entry.
class EffectSet {
 public:
  EffectSet() = default;

  /// "all", "none" or a comma-separated list of effect names; parameters take their defaults.
  static EffectSet parse(const std::string& list);
  /// Every enabled effect's parameters drawn uniformly (log-uniform where marked) within their
  /// ranges; the tooth-error pattern drawn too. Deterministic for a seed.
  void randomise(std::uint64_t seed);

  void enable(Effect e);
  void disable(Effect e);
  bool enabled(Effect e) const { return enabled_.count(e) != 0; }
  std::vector<Effect> enabled_effects() const { return {enabled_.begin(), enabled_.end()}; }

  /// Throws RigParameterError naming the parameter when unknown or outside its range.
  void set(const std::string& name, double value);
  double get(const std::string& name) const;

  /// The per-tooth pattern; drawn by randomise() or, when none was set, from the rms values with
  /// a fixed seed. Explicit patterns are checked (sizes, |error| ≤ 50 µm).
  void set_tooth_pattern(ToothErrorPattern pattern, int pinion_teeth, int gear_teeth);
  ToothErrorPattern tooth_pattern(int pinion_teeth, int gear_teeth) const;

  /// Parameters of the enabled effects only: name → value.
  std::map<std::string, double> active_parameters() const;

 private:
  std::set<Effect> enabled_;
  std::map<std::string, double> values_;
  ToothErrorPattern pattern_;
  std::uint64_t pattern_seed_ = 1;
};

}  // namespace gearwatch::rig
