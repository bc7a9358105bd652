#include "gearwatch/types/gap_report.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

namespace gearwatch::gap {

const char* to_string(FamilyKind family) noexcept {
  switch (family) {
    case FamilyKind::input_shaft_orders: return "input_shaft_orders";
    case FamilyKind::output_shaft_orders: return "output_shaft_orders";
    case FamilyKind::mesh_harmonics: return "mesh_harmonics";
    case FamilyKind::input_sidebands: return "input_sidebands";
    case FamilyKind::output_sidebands: return "output_sidebands";
    case FamilyKind::fixed_frequency: return "fixed_frequency";
    case FamilyKind::broadband: return "broadband";
  }
  return "unknown";
}

const char* to_string(CandidateEffect effect) noexcept {
  switch (effect) {
    case CandidateEffect::casing_mode: return "casing_mode";
    case CandidateEffect::tooth_errors: return "tooth_errors";
    case CandidateEffect::eccentricity: return "eccentricity";
    case CandidateEffect::tip_relief: return "tip_relief";
    case CandidateEffect::speed_fluctuation: return "speed_fluctuation";
    case CandidateEffect::load_fluctuation: return "load_fluctuation";
    case CandidateEffect::noise_floor: return "noise_floor";
    case CandidateEffect::mount_resonance: return "mount_resonance";
    case CandidateEffect::misalignment: return "misalignment";
    case CandidateEffect::backlash: return "backlash";
  }
  return "unknown";
}


const char* to_string(FeatureMovement movement) noexcept {
  switch (movement) {
    case FeatureMovement::fixed_in_orders: return "fixed_in_orders";
    case FeatureMovement::fixed_in_hz: return "fixed_in_hz";
    case FeatureMovement::neither: return "neither";
    case FeatureMovement::undetermined: return "undetermined";
  }
  return "unknown";
}

const char* to_string(FeatureShaft shaft) noexcept {
  switch (shaft) {
    case FeatureShaft::input: return "input";
    case FeatureShaft::output: return "output";
  }
  return "unknown";
}

namespace {
std::string format(const char* fmt, double a, double b = 0, double c = 0) {
  char buf[160];
  std::snprintf(buf, sizeof buf, fmt, a, b, c);
  return buf;
}
}  // namespace

std::string describe(const GapFeature& f) {
  const std::string order = std::string(to_string(f.shaft)) + format(" order %.2f", f.order);
  const std::string hz = format("%.1f Hz (band %.1f-%.1f Hz)", f.hz, f.hz_low, f.hz_high);
  std::string where;
  switch (f.movement) {
    case FeatureMovement::fixed_in_orders: where = order + ", fixed in orders"; break;
    case FeatureMovement::fixed_in_hz: where = hz + ", fixed in Hz"; break;
    case FeatureMovement::neither: where = order + " / " + hz + ", moves with neither"; break;
    case FeatureMovement::undetermined: where = order + " / " + hz + ", speeds too close to tell"; break;
  }
  return where + format(", %+.1f dB [%+.1f, %+.1f]", f.size_db, f.size_interval_db.low, f.size_interval_db.high) +
         ", seen in " + std::to_string(f.seen_in.size()) + (f.seen_in.size() == 1 ? " record" : " records");
}

namespace {
bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() > tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}
}  // namespace

BoundReading reading_of(const ParameterBound& b) {
  // The name's unit suffix gives the unit; the rest, in words, the quantity.
  struct Unit {
    const char* suffix;
    const char* unit;
    double scale;
  };
  static const Unit units[] = {{"_m", "µm", 1e6}, {"_rad", "mrad", 1e3}, {"_db", "dB", 1}, {"_hz", "Hz", 1},
                               {"_nm", "N·m", 1}, {"_per_hz", "per Hz", 1}};
  BoundReading r{b.bound, "", b.name};
  for (const auto& u : units)
    if (ends_with(b.name, u.suffix)) {
      r.quantity = b.name.substr(0, b.name.size() - std::string(u.suffix).size());
      r.unit = u.unit;
      r.value = b.bound * u.scale;
      // Metres at a millimetre and beyond read in mm.
      if (r.unit == "µm" && std::abs(b.bound) >= 1e-3) r.unit = "mm", r.value = b.bound * 1e3;
      break;
    }
  for (char& c : r.quantity)
    if (c == '_') c = ' ';
  if (const auto at = r.quantity.find("run out"); at != std::string::npos) r.quantity.replace(at, 7, "run-out");
  return r;
}

std::string describe(CandidateEffect effect, const ParameterBound& b) {
  const BoundReading r = reading_of(b);
  return std::string(to_string(effect)) + " would need " + (b.upper ? "> " : "< ") + format("%.4g", r.value) +
         (r.unit.empty() ? "" : " " + r.unit) + " " + r.quantity + " (" + b.name + " at the " + (b.upper ? "top" : "bottom") +
         " of its range)";
}

const char* to_string(DescriptionKind kind) noexcept {
  switch (kind) {
    case DescriptionKind::none: return "none";
    case DescriptionKind::resonance: return "resonance";
    case DescriptionKind::modulation: return "modulation";
    case DescriptionKind::ghost_line: return "ghost_line";
    case DescriptionKind::fixed_tone: return "fixed_tone";
    case DescriptionKind::floor_change: return "floor_change";
    case DescriptionKind::path_tilt: return "path_tilt";
  }
  return "unknown";
}

double FeatureDescription::parameter(const std::string& name) const noexcept {
  for (const auto& [n, v] : parameters)
    if (n == name) return v;
  return std::numeric_limits<double>::quiet_NaN();
}

namespace {
const char* shaft_words(FeatureShaft shaft) { return shaft == FeatureShaft::output ? "the gear shaft's" : "the pinion shaft's"; }

std::string tone_words(const FeatureDescription& d) {
  const double f = d.parameter("frequency_hz"), base = d.parameter("fundamental_hz"), k = d.parameter("harmonic"),
               supply = d.parameter("supply_hz"), amplitude = d.parameter("amplitude_m_s2"), count = d.parameter("tones");
  if (count >= 2) {  // "tones fixed in Hz at 50.0, 100.1 Hz (0.03, 0.02 m/s² peak): supply pick-up, harmonics 1, 2 of 50 Hz"
    std::string at, amplitudes, harmonics;
    for (int i = 1; i <= static_cast<int>(count); ++i) {
      const std::string name = "tone_" + std::to_string(i);
      const std::string sep = i > 1 ? ", " : "";
      at += sep + format("%.1f", d.parameter(name + "_hz"));
      amplitudes += sep + format("%.3g", d.parameter(name + "_amplitude_m_s2"));
      const double h = d.parameter(name + "_harmonic");
      harmonics += sep + (h >= 1 ? format("%.0f", h) : std::string("-"));
    }
    const std::string s = "tones fixed in Hz at " + at + " Hz (" + amplitudes + " m/s² peak)";
    if (supply > 0) return s + ": supply pick-up, harmonics " + harmonics + format(" of %.0f Hz", supply);
    if (base > 0) return s + ": harmonics " + harmonics + format(" of %.1f Hz (a fan or another machine)", base);
    return s + " (a fan or another machine)";
  }
  std::string s = format("a tone at %.1f Hz fixed in Hz, %.3g m/s² peak", f, amplitude);
  if (supply > 0) s += format(": supply pick-up, harmonic %.0f of %.0f Hz", k, supply);
  else if (k > 1) s += format(": harmonic %.0f of %.1f Hz (a fan or another machine)", k, base);
  else s += " (a fan or another machine)";
  return s;
}
}  // namespace

std::string describe(const FeatureDescription& d) {
  switch (d.kind) {
    case DescriptionKind::none: return "no descriptive form removes its gap";
    case DescriptionKind::resonance:
      return format("a resonance at %.1f Hz, damping ratio %.3g, %+.1f dB at its peak", d.parameter("frequency_hz"),
                    d.parameter("damping_ratio"), d.parameter("gain_db"));
    case DescriptionKind::modulation: {
      const double am = d.parameter("am_index"), pm = d.parameter("pm_index_rad");
      const std::string at = std::string(" at ") + shaft_words(d.shaft) + " order";
      if (!std::isfinite(pm)) return format("a %.3g %% modulation (AM or PM: no phases)", 100 * am) + at;
      // Which one dominates: the AM's share of the first sidebands' power (descriptions stored before
      // it was kept: AM against PM's small-index sidebands, m against β).
      const double share = d.parameter("am_power_share");
      const double am_share = std::isfinite(share) ? share : (am * am + pm * pm > 0 ? am * am / (am * am + pm * pm) : 1.0);
      // Mixed when the lesser carries a tenth of the sidebands' power or more (10 dB under the other).
      if (am_share >= 0.1 && am_share <= 0.9)
        return format("AM %.3g %% and PM %.3g rad", 100 * am, pm) + at +
               (am_share >= 0.5 ? ", AM" : ", PM") + format(" dominant (%.0f %% of the sidebands' power)", 100 * std::max(am_share, 1 - am_share));
      return am_share > 0.5 ? format("a %.3g %% AM", 100 * am) + at + format(" (PM %.2g rad)", pm)
                            : format("a %.3g rad PM", pm) + at + format(" (AM %.2g %%)", 100 * am);
    }
    case DescriptionKind::ghost_line:
      return std::string("a ghost line at ") + (d.shaft == FeatureShaft::output ? "gear" : "pinion") + " order " + format("%.2f", d.parameter("order")) +
             format(", %.3g m/s² peak", d.parameter("amplitude_m_s2"));
    case DescriptionKind::fixed_tone: return tone_words(d);
    case DescriptionKind::floor_change:
      return format("a broadband floor change of %+.1f dB at 1 kHz, %+.1f dB/decade", d.parameter("level_db"),
                    d.parameter("slope_db_per_decade")) +
             (std::isfinite(d.parameter("corner_hz")) ? format(" above %.0f Hz", d.parameter("corner_hz")) : std::string());
    case DescriptionKind::path_tilt:
      return format("a transfer-path tilt of %+.2f dB/octave over the mesh harmonics (%+.1f dB at the first)",
                    d.parameter("tilt_db_per_octave"), d.parameter("level_db"));
  }
  return "unknown";
}

std::string statement(const GapFeature& f) {
  const std::string who = f.explained_by ? std::string("explained by ") + to_string(*f.explained_by)
                                         : std::string("not explained by a physical candidate");
  if (f.description.kind == DescriptionKind::none) return who + "; " + describe(f.description);
  return who + "; described as " + describe(f.description);
}

}  // namespace gearwatch::gap
