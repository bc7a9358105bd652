#include "gearwatch/wear/wear_loop.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "gearwatch/twin/errors.hpp"
#include "gearwatch/wear/load_sharing.hpp"

namespace gearwatch::wear {

namespace {
void require(bool ok, const std::string& what) {
  if (!ok) throw twin::TwinParameterError("wear loop: " + what);
}

double mean(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

// Linear interpolation in a root → tip table at profile fraction u ∈ [0, 1].
double sample(const std::vector<double>& table, double u) {
  if (table.empty()) return 0.0;
  if (table.size() == 1) return table[0];
  u = std::clamp(u, 0.0, 1.0) * static_cast<double>(table.size() - 1);
  const std::size_t i = std::min(static_cast<std::size_t>(u), table.size() - 2);
  return table[i] + (u - static_cast<double>(i)) * (table[i + 1] - table[i]);
}

// A pitted tooth keeps at least this share of the face width, so its pressure stays finite.
constexpr double kMinWidthFactor = 0.05;
}  // namespace

double pitted_width_factor(const WearState& state) {
  // The thesis's Eq. 7.12 (§7.3.2, p. 152): B(N_{i+1}) = B_initial (1 − D(N_i)), B "the designed
  // gear tooth width". Unlike Eqs. 7.3–7.11, whose every term carries the contact position θ,
  // Eq. 7.12 has one B for the tooth and D(N_i) without θ: the tooth's pitting density, the
  // quantity §7.3.3 compares with the pitted area of a mould image (here the mean over the
  // profile, as summarise() reports it). The "effective contact width" of §7.4.1 is likewise one.
  return std::max(kMinWidthFactor, 1.0 - mean(state.pinion_pitting));
}

void WearLoopOptions::validate() const {
  require(std::isfinite(k_wear_si) && k_wear_si >= 0, "K_wear must be finite and non-negative");
  require(std::isfinite(k_pitting) && k_pitting >= 0, "K_pitting must be finite and non-negative");
  material.validate();
  require(std::isfinite(operating_point.input_speed_hz) && operating_point.input_speed_hz > 0,
          "input speed must be finite and positive");
  require(std::isfinite(operating_point.input_torque_nm) && operating_point.input_torque_nm > 0,
          "input torque must be finite and positive");
  require(profile_points >= 2 && profile_points <= 10001, "profile points must lie in [2, 10001]");
  require(std::isfinite(min_step_cycles) && min_step_cycles > 0, "minimum step must be positive");
  require(std::isfinite(max_step_cycles) && max_step_cycles >= min_step_cycles, "maximum step must be ≥ the minimum");
  require(std::isfinite(initial_step_cycles) && initial_step_cycles >= min_step_cycles &&
              initial_step_cycles <= max_step_cycles,
          "initial step must lie between the minimum and maximum step");
  require(std::isfinite(force_tolerance) && force_tolerance > 0, "force tolerance must be positive");
  require(std::isfinite(depth_limit_m) && depth_limit_m > 0 && depth_limit_m < 1e-3,
          "depth limit must lie in (0, 1 mm) (the GTE tables accept up to 1 mm)");
}

twin::ToothProfileDeviation to_profile_deviation(const WearState& state) {
  twin::ToothProfileDeviation d;
  d.pinion = state.pinion_depth_m;
  d.gear = state.gear_depth_m;
  return d;
}

WearSummary summarise(const WearState& state) {
  WearSummary s;
  s.cycles = state.cycles;
  s.pinion_mean_depth_m = mean(state.pinion_depth_m);
  s.gear_mean_depth_m = mean(state.gear_depth_m);
  s.combined_mean_depth_m = s.pinion_mean_depth_m + s.gear_mean_depth_m;
  s.pinion_share = s.combined_mean_depth_m > 0 ? s.pinion_mean_depth_m / s.combined_mean_depth_m : 0.0;
  s.mean_pitting_density = mean(state.pinion_pitting);
  if (!state.pinion_pitting.empty()) {
    const auto it = std::max_element(state.pinion_pitting.begin(), state.pinion_pitting.end());
    s.max_pitting_density = *it;
    s.max_pitting_fraction = state.pinion_pitting.size() > 1 ? static_cast<double>(it - state.pinion_pitting.begin()) /
                                                                    static_cast<double>(state.pinion_pitting.size() - 1)
                                                              : 0.0;
  }
  return s;
}

std::vector<double> combined_profile(const WearState& state) {
  const std::size_t n = state.pinion_depth_m.size();
  std::vector<double> c(n);
  for (std::size_t j = 0; j < n; ++j) {
    const double u = n > 1 ? static_cast<double>(j) / static_cast<double>(n - 1) : 0.0;
    c[j] = state.pinion_depth_m[j] + sample(state.gear_depth_m, 1.0 - u);
  }
  return c;
}

BlueLoop::BlueLoop(twin::GearboxParameters params, WearLoopOptions options)
    : params_(std::move(params)),
      options_(std::move(options)),
      geometry_((params_.validate(), options_.validate(), twin::GearGeometry::from_spec(params_.gears))),
      mesh_(geometry_, twin::MeshStiffnessOptions{params_.mesh_stiffness_scale, twin::kIsoSinglePairStiffness,
                                                  params_.engagement_ramp_fraction, 1025}),
      next_step_(options_.initial_step_cycles) {
  const auto n = static_cast<std::size_t>(options_.profile_points);
  state_.pinion_depth_m.assign(n, 0.0);
  state_.gear_depth_m.assign(n, 0.0);
  state_.pinion_pitting.assign(n, 0.0);
  load_ = load_for(state_);
}

void BlueLoop::set_coefficients(double k_wear_si, double k_pitting) {
  WearLoopOptions updated = options_;
  updated.k_wear_si = k_wear_si;
  updated.k_pitting = k_pitting;
  updated.validate();
  options_ = updated;
}

void BlueLoop::set_operating_point(const twin::OperatingPoint& op) {
  WearLoopOptions updated = options_;
  updated.operating_point = op;
  updated.validate();
  options_ = updated;
  load_ = load_for(state_);
}

void BlueLoop::restore(const WearState& state, double next_step_cycles) {
  const auto n = static_cast<std::size_t>(options_.profile_points);
  require(state.pinion_depth_m.size() == n && state.gear_depth_m.size() == n && state.pinion_pitting.size() == n,
          "restored state must have profile_points entries per table");
  require(std::isfinite(state.cycles) && state.cycles >= 0, "restored cycles must be finite and ≥ 0");
  for (std::size_t j = 0; j < n; ++j)
    require(std::isfinite(state.pinion_depth_m[j]) && std::isfinite(state.gear_depth_m[j]) &&
                std::isfinite(state.pinion_pitting[j]) && state.pinion_pitting[j] >= 0 && state.pinion_pitting[j] <= 1,
            "restored profiles must be finite (pitting density in [0, 1])");
  require(std::isfinite(next_step_cycles) && next_step_cycles >= options_.min_step_cycles &&
              next_step_cycles <= options_.max_step_cycles,
          "restored step must lie between the minimum and maximum step");
  state_ = state;
  next_step_ = next_step_cycles;
  load_ = load_for(state_);
}

std::vector<double> BlueLoop::pitting_rates(double k_pitting) const {
  const auto n = static_cast<std::size_t>(options_.profile_points);
  std::vector<double> rate(n, 0.0);
  if (!(k_pitting > 0)) return rate;
  const twin::GearGeometry& g = geometry_;
  const double width_factor = pitted_width_factor(state_);
  for (std::size_t j = 0; j < n; ++j) {
    const double u = static_cast<double>(j) / static_cast<double>(n - 1);
    const double s = g.contact_start + u * g.active_length();
    const double rho1 = s, rho2 = g.line_of_action_length - s;
    const double reduced = rho1 * rho2 / (rho1 + rho2);
    const double width = g.spec.face_width_m * width_factor;  // Eq. 7.12: the tooth's width, not the point's
    const LineContact c = line_contact(std::max(0.0, load_.force_at(s)) / width, reduced, g.effective_modulus);
    rate[j] = survival_rate(k_pitting, lundberg_palmgren_terms(c.max_pressure_pa, c.half_width_m, reduced), options_.material);
  }
  return rate;
}

PassLoad BlueLoop::load_for(const WearState& s) {
  ++force_evaluations_;
  const twin::ToothProfileDeviation deviation = to_profile_deviation(s);
  if (options_.force_model == ForceModel::dynamic)
    return dynamic_pass_load(params_, deviation, options_.operating_point, options_.simulation);
  const twin::GeometricTransmissionError gte(geometry_, deviation);
  return quasi_static_pass_load(mesh_, gte, options_.operating_point.input_torque_nm, 1025);
}

std::vector<double> BlueLoop::pass_positions() const {
  std::vector<double> s(257);
  for (std::size_t i = 0; i < s.size(); ++i)
    s[i] = geometry_.contact_start + geometry_.active_length() * static_cast<double>(i) / static_cast<double>(s.size() - 1);
  return s;
}

StepReport BlueLoop::step(double until_cycles) {
  StepReport report;
  const double remaining = until_cycles - state_.cycles;
  if (!(remaining > 0)) return report;
  const auto n = static_cast<std::size_t>(options_.profile_points);
  const double ratio = static_cast<double>(geometry_.spec.pinion_teeth) / geometry_.spec.gear_teeth;
  const double static_force = options_.operating_point.input_torque_nm / geometry_.base_radius_pinion;

  // Rates at the start of the step, from the current load and the tooth's pitted width (Eq. 7.12).
  const WearState start = state_;
  const double width_factor = pitted_width_factor(start);
  const PassWear per_pass = pass_wear(geometry_, load_, options_.k_wear_si, options_.profile_points,
                                      [width_factor](double) { return width_factor; });
  const std::vector<double> rate = pitting_rates(options_.k_pitting);

  const std::vector<double> positions = pass_positions();
  double dn = std::min(next_step_, remaining);
  for (;;) {
    WearState trial = start;
    for (std::size_t j = 0; j < n; ++j) {
      trial.pinion_depth_m[j] += dn * per_pass.pinion_m[j];
      trial.gear_depth_m[j] += dn * ratio * per_pass.gear_m[j];  // z1/z2 passes per gear tooth per cycle
      trial.pinion_pitting[j] = pitting_density_step(start.pinion_pitting[j], rate[j], start.cycles, dn, options_.material);
    }
    trial.cycles = dn == remaining ? until_cycles : start.cycles + dn;
    const double deepest = std::max(*std::max_element(trial.pinion_depth_m.begin(), trial.pinion_depth_m.end()),
                                    *std::max_element(trial.gear_depth_m.begin(), trial.gear_depth_m.end()));
    double change = 0;
    PassLoad trial_load;
    const bool too_deep = deepest > options_.depth_limit_m;
    if (!too_deep) {
      trial_load = load_for(trial);
      // RMS over the pass, not the maximum: the dynamic force's impact spikes shift a little with
      // every profile change, and a maximum would chase them down to the minimum step.
      for (double s : positions) {
        const double d = trial_load.force_at(s) - load_.force_at(s);
        change += d * d;
      }
      change = std::sqrt(change / static_cast<double>(positions.size())) / static_force;
    }
    if ((too_deep || change > options_.force_tolerance) && dn > options_.min_step_cycles) {
      dn = std::max(options_.min_step_cycles, 0.5 * dn);
      ++report.rejected;
      ++rejections_;
      continue;
    }
    if (too_deep) return report;  // even the smallest step passes the limit: run_until reports it
    state_ = std::move(trial);
    load_ = std::move(trial_load);
    report.step_cycles = dn;
    report.force_change = change;
    ++steps_;
    // Grow only after a quiet step that was not cut short by the end of the run.
    if (change < 0.5 * options_.force_tolerance && dn >= next_step_)
      next_step_ = std::min(options_.max_step_cycles, 2.0 * dn);
    else if (dn < next_step_ && report.rejected > 0)
      next_step_ = dn;
    return report;
  }
}

bool BlueLoop::run_until(double cycles) {
  if (!std::isfinite(cycles) || cycles < 0) throw twin::TwinParameterError("wear loop: cycles must be finite and ≥ 0");
  while (state_.cycles < cycles) {
    const StepReport r = step(cycles);
    if (r.step_cycles <= 0) return false;
  }
  return true;
}

}  // namespace gearwatch::wear
