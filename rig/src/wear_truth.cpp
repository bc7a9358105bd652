#include "gearwatch/rig/wear_truth.hpp"

#include <algorithm>
#include <cmath>

#include "gearwatch/rig/effects.hpp"
#include "gearwatch/twin/gear_geometry.hpp"

namespace gearwatch::rig {

BuiltinWearTruth::BuiltinWearTruth(const WearModelSettings& settings, const GearPairSpec& gears)
    : s_(settings), gears_(gears) {
  for (std::size_t i = 0; i < s_.phases.size(); ++i) {
    if (!(s_.phases[i].k_wear >= 0) || !std::isfinite(s_.phases[i].k_wear))
      throw RigParameterError("wear phase k_wear must be finite and >= 0");
    if (!(s_.phases[i].from_cycles >= 0)) throw RigParameterError("wear phase from_cycles must be >= 0");
    if (i > 0 && s_.phases[i].from_cycles <= s_.phases[i - 1].from_cycles)
      throw RigParameterError("wear phases must be in increasing from_cycles");
  }
  if (!(s_.k_pitting >= 0) || !(s_.pitting_exponent > 0) || !(s_.max_pitting >= 0 && s_.max_pitting <= 1) ||
      !(s_.pitting_onset_cycles >= 0))
    throw RigParameterError("pitting: k_pitting >= 0, exponent > 0, 0 <= max <= 1, onset >= 0 required");
  if (!(s_.initial_roughness >= 0) || !(s_.runin_cycles > 0) || !(s_.roughness_per_um >= 0))
    throw RigParameterError("roughness: initial >= 0, runin_cycles > 0, roughness_per_um >= 0 required");
  if (!(s_.torque_nm >= 0) || !(s_.reference_torque_nm > 0)) throw RigParameterError("wear torque must be >= 0");
  if (s_.profile_points < 2) throw RigParameterError("wear profile needs at least 2 points");
  const auto g = twin::GearGeometry::from_spec(gears);
  // The pitch point on the line of action sits at r_b1 tan(α) from T1.
  const double s_pitch = g.base_radius_pinion * std::tan(g.pressure_angle_rad);
  pitch_fraction_pinion_ = g.profile_fraction_pinion(s_pitch);
  pitch_fraction_gear_ = g.profile_fraction_gear(s_pitch);
}

WearState BuiltinWearTruth::at(double cycles) const {
  WearState w;
  w.cycles = cycles;
  double amplitude = 0;  // Σ K_i ΔN_i
  for (std::size_t i = 0; i < s_.phases.size(); ++i) {
    const double begin = s_.phases[i].from_cycles;
    const double end = i + 1 < s_.phases.size() ? s_.phases[i + 1].from_cycles : INFINITY;
    if (cycles > begin) amplitude += s_.phases[i].k_wear * (std::min(cycles, end) - begin);
    if (cycles >= begin) w.k_wear = s_.phases[i].k_wear;
  }
  amplitude *= s_.torque_nm / s_.reference_torque_nm;
  const int n = s_.profile_points;
  auto shape = [n](double pitch) {
    std::vector<double> v(static_cast<std::size_t>(n));
    const double span = std::max(pitch, 1.0 - pitch);
    for (int i = 0; i < n; ++i) v[static_cast<std::size_t>(i)] = std::abs(static_cast<double>(i) / (n - 1) - pitch) / span;
    return v;
  };
  w.profile.pinion = shape(pitch_fraction_pinion_);
  w.profile.gear = shape(pitch_fraction_gear_);
  const double ratio = static_cast<double>(gears_.pinion_teeth) / gears_.gear_teeth;
  double mean = 0;
  for (auto& d : w.profile.pinion) mean += (d *= amplitude);
  for (auto& d : w.profile.gear) d *= amplitude * ratio;
  // Mean over the profile by the trapezoid rule on the uniform grid.
  mean -= 0.5 * (w.profile.pinion.front() + w.profile.pinion.back());
  w.mean_wear_depth_m = mean / (n - 1);
  w.combined_mean_wear_depth_m = w.mean_wear_depth_m * (1.0 + ratio);
  if (amplitude == 0) w.profile = {};

  w.k_pitting = cycles >= s_.pitting_onset_cycles ? s_.k_pitting : 0.0;
  if (cycles > s_.pitting_onset_cycles && s_.k_pitting > 0)
    w.pitting_density =
        std::min(s_.max_pitting, s_.k_pitting * std::pow((cycles - s_.pitting_onset_cycles) / 1e6, s_.pitting_exponent));
  w.roughness = s_.initial_roughness * std::exp(-cycles / s_.runin_cycles) + s_.roughness_per_um * w.mean_wear_depth_m * 1e6;
  return w;
}

namespace {
WearModelSettings without_wear(WearModelSettings s) {
  s.phases.clear();
  s.roughness_per_um = 0;
  return s;
}
}  // namespace

ArchardWearTruth::ArchardWearTruth(const WearModelSettings& settings, const twin::GearboxParameters& params, double speed_hz)
    : s_(settings), surface_(without_wear(settings), params.gears), params_(params) {
  BuiltinWearTruth(settings, params.gears);  // the same validation of phases and coefficients
  options_.operating_point.input_speed_hz = speed_hz;
  options_.operating_point.input_torque_nm = s_.torque_nm;
  options_.force_model = wear::ForceModel::quasi_static;
  options_.k_pitting = 0;
  try {
    options_.validate();
  } catch (const std::exception& e) {
    throw RigParameterError(std::string("archard wear truth: ") + e.what());
  }
}

WearState ArchardWearTruth::at(double cycles) const {
  auto k_at = [this](double n) {
    double k = 0;
    for (const auto& p : s_.phases)
      if (n >= p.from_cycles) k = p.k_wear;
    return k;
  };
  if (!loop_ || loop_->state().cycles > cycles) {
    auto options = options_;
    options.k_wear_si = k_at(0.0);
    loop_ = std::make_unique<wear::BlueLoop>(params_, options);
  }
  // Run phase by phase: K changes exactly at each phase's first cycle.
  for (;;) {
    const double now = loop_->state().cycles;
    if (k_at(now) != loop_->options().k_wear_si) loop_->set_coefficients(k_at(now), 0.0);
    double boundary = INFINITY;
    for (const auto& p : s_.phases)
      if (p.from_cycles > now) boundary = std::min(boundary, p.from_cycles);
    const double target = std::min(cycles, boundary);
    if (target > now && !loop_->run_until(target))
      throw RigParameterError("archard wear truth: a flank passes the wear loop's depth limit before " +
                              std::to_string(target) + " cycles");
    if (target >= cycles) break;
  }
  WearState w = surface_.at(cycles);
  const auto& state = loop_->state();
  w.profile = wear::to_profile_deviation(state);
  const auto summary = wear::summarise(state);
  w.mean_wear_depth_m = summary.pinion_mean_depth_m;
  w.combined_mean_wear_depth_m = summary.combined_mean_depth_m;
  w.k_wear = k_at(cycles);
  w.roughness += s_.roughness_per_um * w.mean_wear_depth_m * 1e6;
  return w;
}

const char* to_string(WearLaw law) {
  switch (law) {
    case WearLaw::linear: return "linear";
    case WearLaw::archard: return "archard";
    case WearLaw::forms: return "forms";
  }
  return "?";
}

std::unique_ptr<WearTruth> make_wear_truth(const WearModelSettings& settings, const twin::GearboxParameters& params,
                                           double speed_hz) {
  if (settings.law == WearLaw::forms)
    return std::make_unique<FormsWearTruth>(settings.forms, settings.torque_schedule(), settings.reference_torque_nm,
                                            settings.profile_points, params.gears, speed_hz);
  if (settings.load_change_cycles >= 0)
    throw RigParameterError(std::string("a load change needs the forms wear law (law is ") + to_string(settings.law) + ")");
  if (settings.law == WearLaw::archard) return std::make_unique<ArchardWearTruth>(settings, params, speed_hz);
  return std::make_unique<BuiltinWearTruth>(settings, params.gears);
}

}  // namespace gearwatch::rig
