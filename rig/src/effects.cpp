#include "gearwatch/rig/effects.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "random.hpp"

namespace gearwatch::rig {
namespace {
// A phase spans one turn.
constexpr double kFullTurnRad = 2.0 * std::numbers::pi;

std::string format_value(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}
}  // namespace

const std::vector<Effect>& all_effects() {
  static const std::vector<Effect> list{Effect::casing,           Effect::tooth_errors,     Effect::eccentricity,
                                        Effect::tip_relief,       Effect::speed_fluctuation, Effect::load_fluctuation,
                                        Effect::noise,            Effect::mounting,         Effect::misalignment,
                                        Effect::backlash};
  return list;
}

const char* effect_name(Effect e) {
  switch (e) {
    case Effect::casing: return "casing";
    case Effect::tooth_errors: return "tooth_errors";
    case Effect::eccentricity: return "eccentricity";
    case Effect::tip_relief: return "tip_relief";
    case Effect::speed_fluctuation: return "speed_fluctuation";
    case Effect::load_fluctuation: return "load_fluctuation";
    case Effect::noise: return "noise";
    case Effect::mounting: return "mounting";
    case Effect::misalignment: return "misalignment";
    case Effect::backlash: return "backlash";
  }
  return "?";
}

Effect effect_from_name(const std::string& name) {
  for (Effect e : all_effects())
    if (name == effect_name(e)) return e;
  std::string known;
  for (Effect e : all_effects()) known += std::string(known.empty() ? "" : ", ") + effect_name(e);
  throw RigParameterError("unknown effect '" + name + "' (known: " + known + ")");
}

const std::vector<EffectParameter>& effect_parameter_table() {
  using E = Effect;
  static const std::vector<EffectParameter> table{
      {E::casing, "casing.mode1_hz", "Hz", 20, 5000, 688, true,
       "first casing/foundation mode (thesis Table 5.4 lists foundation modes at 13-1714 Hz)"},
      {E::casing, "casing.mode2_hz", "Hz", 20, 5000, 1714, true, "second casing/foundation mode"},
      {E::casing, "casing.damping_ratio", "-", 0.005, 0.1, 0.02, false, "modal damping ratio of both casing modes"},
      {E::casing, "casing.modal_mass_kg", "kg", 1, 100, 8, true,
       "modal mass the bearing forces drive (smaller = stronger transfer path)"},
      {E::tooth_errors, "tooth_errors.spacing_rms_um", "um", 0.5, 15, 4, false,
       "RMS of the single pitch (spacing) deviation per tooth, both gears (JIS grade 4: fpt ~ 5-9 um)"},
      {E::tooth_errors, "tooth_errors.profile_slope_rms_um", "um", 0.5, 15, 3, false,
       "RMS of the per-tooth profile slope deviation (tip relative to root), both gears"},
      {E::eccentricity, "eccentricity.pinion_um", "um", 0, 40, 10, false,
       "eccentricity of the pinion (input) shaft: run-out along the line of action"},
      {E::eccentricity, "eccentricity.pinion_phase_rad", "rad", 0, kFullTurnRad, 0, false,
       "angle of the pinion's eccentricity at zero input angle"},
      {E::eccentricity, "eccentricity.gear_um", "um", 0, 40, 8, false, "eccentricity of the gear (output) shaft"},
      {E::eccentricity, "eccentricity.gear_phase_rad", "rad", 0, kFullTurnRad, 0, false,
       "angle of the gear's eccentricity at zero output angle"},
      {E::tip_relief, "tip_relief.amount_um", "um", 1, 30, 8, false,
       "linear tip relief at the tip of both gears (material removed at the tip)"},
      {E::tip_relief, "tip_relief.length_fraction", "-", 0.05, 0.4, 0.2, false,
       "length of the relief, as a fraction of the active profile from the tip"},
      {E::speed_fluctuation, "speed_fluctuation.depth", "-", 0.001, 0.05, 0.01, true,
       "relative amplitude of the VFD's input speed ripple"},
      {E::speed_fluctuation, "speed_fluctuation.frequency_hz", "Hz", 0.2, 5, 1, true, "frequency of the speed ripple"},
      {E::speed_fluctuation, "speed_fluctuation.phase_rad", "rad", 0, kFullTurnRad, 0, false, "phase of the speed ripple at t = 0"},
      {E::load_fluctuation, "load_fluctuation.depth", "-", 0.01, 0.3, 0.05, true,
       "relative amplitude of the brake torque ripple"},
      {E::load_fluctuation, "load_fluctuation.frequency_hz", "Hz", 0.2, 15, 2, true, "frequency of the brake torque ripple"},
      {E::load_fluctuation, "load_fluctuation.speed_loop_hz", "Hz", 0.5, 5, 2, false,
       "bandwidth of the VFD speed loop that holds the speed against the ripple (PI, damping 0.7)"},
      {E::noise, "noise.psd", "(m/s2)^2/Hz", 1e-8, 1e-2, 4e-5, true,
       "one-sided PSD of the sensor's white noise floor (added after the mounting)"},
      {E::mounting, "mounting.frequency_hz", "Hz", 15000, 45000, 28000, false,
       "mounted resonance of the accelerometer (stud/adhesive on the casing)"},
      {E::mounting, "mounting.damping_ratio", "-", 0.01, 0.2, 0.05, true, "damping ratio of the mounted resonance"},
      {E::misalignment, "misalignment.angle_mrad", "mrad", 0.01, 0.5, 0.1, true,
       "angular misalignment across the face: the flanks separate by angle x face position"},
      {E::backlash, "backlash.clearance_um", "um", 20, 300, 80, true,
       "circumferential clearance along the line of action before the back flanks touch"},
  };
  return table;
}

const EffectParameter* find_effect_parameter(const std::string& name) {
  for (const auto& p : effect_parameter_table())
    if (name == p.name) return &p;
  return nullptr;
}

EffectSet EffectSet::parse(const std::string& list) {
  EffectSet set;
  if (list == "none" || list.empty()) return set;
  if (list == "all") {
    for (Effect e : all_effects()) set.enable(e);
    return set;
  }
  std::stringstream in(list);
  std::string item;
  while (std::getline(in, item, ',')) {
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (item.empty()) continue;
    set.enable(effect_from_name(item));
  }
  return set;
}

void EffectSet::enable(Effect e) { enabled_.insert(e); }
void EffectSet::disable(Effect e) { enabled_.erase(e); }

void EffectSet::set(const std::string& name, double value) {
  const EffectParameter* p = find_effect_parameter(name);
  if (!p) throw RigParameterError("unknown effect parameter '" + name + "'");
  if (!std::isfinite(value) || value < p->low || value > p->high)
    throw RigParameterError(std::string(p->name) + " = " + format_value(value) + " " + p->unit +
                            " is outside its documented range [" + format_value(p->low) + ", " + format_value(p->high) +
                            "]");
  values_[name] = value;
}

double EffectSet::get(const std::string& name) const {
  const auto it = values_.find(name);
  if (it != values_.end()) return it->second;
  const EffectParameter* p = find_effect_parameter(name);
  if (!p) throw RigParameterError("unknown effect parameter '" + name + "'");
  return p->default_value;
}

void EffectSet::randomise(std::uint64_t seed) {
  detail::Random rng(seed * 0x2545F4914F6CDD1Dull + 17);
  for (const auto& p : effect_parameter_table()) {
    // Draw every parameter whether enabled or not, so one effect's values do not depend on
    // which others are on.
    const double u = rng.uniform();
    if (!enabled(p.effect)) continue;
    values_[p.name] = p.log_uniform ? std::exp(std::log(p.low) + u * (std::log(p.high) - std::log(p.low)))
                                    : p.low + u * (p.high - p.low);
  }
  pattern_seed_ = seed;
  pattern_ = {};
}

void EffectSet::set_tooth_pattern(ToothErrorPattern pattern, int pinion_teeth, int gear_teeth) {
  auto check = [](const std::vector<double>& v, int n, const char* what) {
    if (v.size() != static_cast<std::size_t>(n))
      throw RigParameterError(std::string("tooth_errors.") + what + ": expected " + std::to_string(n) + " teeth, got " +
                              std::to_string(v.size()));
    for (double x : v)
      if (!std::isfinite(x) || std::abs(x) > 50e-6)
        throw RigParameterError(std::string("tooth_errors.") + what + ": each tooth's error must lie in [-50, 50] um");
  };
  check(pattern.pinion_spacing_m, pinion_teeth, "pinion_spacing");
  check(pattern.pinion_slope_m, pinion_teeth, "pinion_slope");
  check(pattern.gear_spacing_m, gear_teeth, "gear_spacing");
  check(pattern.gear_slope_m, gear_teeth, "gear_slope");
  pattern_ = std::move(pattern);
}

ToothErrorPattern EffectSet::tooth_pattern(int pinion_teeth, int gear_teeth) const {
  if (pattern_.pinion_spacing_m.size() == static_cast<std::size_t>(pinion_teeth) &&
      pattern_.gear_spacing_m.size() == static_cast<std::size_t>(gear_teeth))
    return pattern_;
  // Gaussian per tooth with the configured RMS, mean removed (a common offset is no error).
  detail::Random rng(pattern_seed_ * 0x9E3779B97F4A7C15ull + 5);
  auto draw = [&rng](int n, double rms) {
    std::vector<double> v(static_cast<std::size_t>(n));
    double mean = 0;
    for (auto& x : v) mean += (x = rng.gaussian());
    mean /= n;
    double ss = 0;
    for (auto& x : v) ss += (x - mean) * (x - mean);
    const double scale = ss > 0 ? rms / std::sqrt(ss / n) : 0.0;
    for (auto& x : v) x = (x - mean) * scale;
    return v;
  };
  const double spacing = get("tooth_errors.spacing_rms_um") * 1e-6, slope = get("tooth_errors.profile_slope_rms_um") * 1e-6;
  ToothErrorPattern p;
  p.pinion_spacing_m = draw(pinion_teeth, spacing);
  p.pinion_slope_m = draw(pinion_teeth, slope);
  p.gear_spacing_m = draw(gear_teeth, spacing);
  p.gear_slope_m = draw(gear_teeth, slope);
  return p;
}

std::map<std::string, double> EffectSet::active_parameters() const {
  std::map<std::string, double> out;
  for (const auto& p : effect_parameter_table())
    if (enabled(p.effect)) out[p.name] = get(p.name);
  return out;
}

}  // namespace gearwatch::rig
