#include "gearwatch/wear/updating.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "gearwatch/dsp/record_analyzer.hpp"
#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/twin/errors.hpp"
#include "gearwatch/types/gear_pair_boundary.hpp"
#include "gearwatch/wear/profile_shape.hpp"

namespace gearwatch::wear {

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw twin::TwinParameterError("model: " + what);
}

std::string fmt(const char* f, double a) {
  char b[64];
  std::snprintf(b, sizeof b, f, a);
  return b;
}

double mean_of(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

double max_depth(const WearState& s) {
  double m = 0;
  for (double d : s.pinion_depth_m) m = std::max(m, d);
  for (double d : s.gear_depth_m) m = std::max(m, d);
  return m;
}

void add_issue(ModelRunReport& r, ModelIssue issue, const std::string& text) {
  r.issues.push_back(issue);
  if (!r.detail.empty()) r.detail += "; ";
  r.detail += std::string(to_string(issue)) + ": " + text;
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Twin runs the profile-shape reading may take (a secant on ln depth from the model's mean;
// RMS_SA is close to proportional to the depth, so it needs about three).
constexpr int kShapeMatchEvaluations = 8;

// "speed 90 Hz outside the model's [0.5, 60] Hz", the torque likewise, or both joined by
// "and"; empty when both lie inside their ranges. Only what is out of range is named.
std::string out_of_range_text(const ModelObservation& obs, const ModelSettings& s) {
  auto outside = [](const char* what, double v, double lo, double hi, const char* unit) {
    if (v >= lo && v <= hi) return std::string{};
    char b[160];
    std::snprintf(b, sizeof b, "%s %.4g %s outside the model's [%.4g, %.4g] %s", what, v, unit, lo, hi, unit);
    return std::string(b);
  };
  const std::string speed = outside("speed", obs.speed_hz, s.min_speed_hz, s.max_speed_hz, "Hz");
  const std::string torque = outside("torque", obs.torque_nm, s.min_torque_nm, s.max_torque_nm, "N m");
  if (!speed.empty() && !torque.empty()) return speed + " and " + torque;
  return speed + torque;
}

// One line of the report's detail about an inspection that was not used, and why.
void note_unused_inspection(ModelRunReport& report, std::int64_t id, const char* why) {
  if (!report.detail.empty()) report.detail += '\n';
  report.detail += fmt("inspection %.0f", static_cast<double>(id));
  report.detail += why;
}

}  // namespace

RmsSaSimulator twin_rms_sa_simulator(twin::GearboxParameters params, const GearboxSpec& rig,
                                     const dsp::SignalProcessingSettings& settings, double revolutions) {
  GearboxSpec sim_rig = rig;
  // One float channel without an i16 scale: the analyzer then has no full scale to call clipped.
  const int number = rig.channels.empty() ? 0 : rig.channels.front().number;
  sim_rig.channels = {ChannelSpec{number, "twin_y6", 0.0}};
  require(std::isfinite(revolutions) && revolutions >= settings.min_revolutions_for_tsa,
          "simulated revolutions must be at least processing.min_revolutions_for_tsa");
  return [params = std::move(params), sim_rig, settings, revolutions](const WearState& state, const twin::OperatingPoint& op) {
    // A few samples beyond the last whole revolution, so the final tacho edge falls inside.
    const double duration = (revolutions + 0.05) / op.input_speed_hz;
    return twin::simulated_rms_sa(params, to_profile_deviation(state), op, duration, sim_rig, settings);
  };
}

double PittingScale::cycles_to_reference(double k_pitting) const {
  if (!(k_pitting > 0)) return std::numeric_limits<double>::infinity();
  // Eq. 7.8 solved for N: K T N^m = −ln(1 − D_ref).
  return std::pow(-std::log1p(-reference_density) / (k_pitting * terms), 1.0 / material.m);
}

double PittingScale::k_pitting_for(double cycles) const {
  return -std::log1p(-reference_density) / (terms * std::pow(cycles, material.m));
}

std::string PittingScale::unit() const {
  char b[120];
  std::snprintf(b, sizeof b, "Pa^-%.4g m^%.4g cycle^-%.4g", material.c, material.h - 3.0, material.m);
  return b;
}

namespace {
// "(Pa^-10.33 m^-0.6667 cycle^-1.111; 10 % pitted at the unworn pair's most loaded point at
// 20 N m after 3.1e+06 -> 3.2e+06 cycles, Eq. 7.8)": the unit and the readable scale of a change.
std::string pitting_change_text(const PittingScale& scale, double old_k, double new_k) {
  auto cycles = [&](double k) { return k > 0 ? fmt("%.4g", scale.cycles_to_reference(k)) : std::string("never"); };
  char b[300];
  std::snprintf(b, sizeof b, "(%s; %.4g %% pitted at the unworn pair's most loaded point at %.4g N m after %s -> %s cycles, Eq. 7.8)",
                scale.unit().c_str(), 100 * scale.reference_density, scale.reference_torque_nm, cycles(old_k).c_str(),
                cycles(new_k).c_str());
  return b;
}
}  // namespace

std::string PittingScale::describe(double k_pitting) const {
  char b[300];
  if (!(k_pitting > 0)) {
    std::snprintf(b, sizeof b, "K_pitting 0 %s: no pitting", unit().c_str());
  } else {
    std::snprintf(b, sizeof b, "K_pitting %.5g %s: %.4g %% pitted at the unworn pair's most loaded point after %.4g cycles at %.4g N m (Eq. 7.8)",
                  k_pitting, unit().c_str(), 100 * reference_density, cycles_to_reference(k_pitting), reference_torque_nm);
  }
  return b;
}

PittingScale pitting_scale(const twin::GearboxParameters& params, const WearLoopOptions& loop, double reference_torque_nm,
                           double reference_density) {
  require(std::isfinite(reference_torque_nm) && reference_torque_nm > 0, "pitting reference torque must be positive");
  require(std::isfinite(reference_density) && reference_density > 0 && reference_density < 1,
          "pitting reference density must lie in (0, 1)");
  WearLoopOptions o = loop;
  // The quasi-static force of the unworn pair: the scale must not depend on the speed or on
  // the dynamic model's resonances, only on the geometry, the material exponents and the load.
  o.force_model = ForceModel::quasi_static;
  o.operating_point.input_torque_nm = reference_torque_nm;
  const BlueLoop unworn(params, o);
  const std::vector<double> unit_rates = unworn.pitting_rates(1.0);
  const double terms = *std::max_element(unit_rates.begin(), unit_rates.end());
  require(std::isfinite(terms) && terms > 0, "no contact pressure at the pitting reference torque");
  return PittingScale{reference_torque_nm, reference_density, terms, loop.material};
}

void ModelSettings::validate() const {
  loop.validate();
  require(std::isfinite(rms_threshold) && rms_threshold > 0 && rms_threshold < 1, "rms threshold must lie in (0, 1)");
  require(std::isfinite(convergence_tolerance) && convergence_tolerance > 0 && convergence_tolerance <= rms_threshold,
          "convergence tolerance must lie in (0, threshold]");
  require(max_wear_iterations >= 1 && max_wear_iterations <= 100, "K_wear iterations must lie in [1, 100]");
  require(commissioning_records >= 0 && commissioning_records <= 100, "commissioning records must lie in [0, 100]");
  require(std::isfinite(k_wear_min_si) && k_wear_min_si > 0 && k_wear_max_si > k_wear_min_si && std::isfinite(k_wear_max_si),
          "K_wear bounds must satisfy 0 < min < max");
  require(std::isfinite(correlation_threshold) && correlation_threshold > 0 && correlation_threshold < 1,
          "correlation threshold must lie in (0, 1)");
  require(std::isfinite(pitting_interval_cycles) && pitting_interval_cycles > 0, "pitting interval must be positive");
  require(max_pitting_evaluations >= 8 && max_pitting_evaluations <= 1000, "pitting evaluations must lie in [8, 1000]");
  require(std::isfinite(min_torque_nm) && min_torque_nm > 0 && max_torque_nm > min_torque_nm && std::isfinite(max_torque_nm),
          "torque range must satisfy 0 < min < max");
  require(std::isfinite(min_speed_hz) && min_speed_hz > 0 && max_speed_hz > min_speed_hz && std::isfinite(max_speed_hz),
          "speed range must satisfy 0 < min < max");
  require(std::isfinite(wear_limit_m) && wear_limit_m > 0 && wear_limit_m < loop.depth_limit_m,
          "wear-depth limit must lie in (0, the blue loop's depth limit)");
  require(std::isfinite(pitting_limit) && pitting_limit > 0 && pitting_limit < 1, "pitting limit must lie in (0, 1)");
  require(std::isfinite(forecast_horizon_cycles) && forecast_horizon_cycles > 0, "forecast horizon must be positive");
  require(forecast_points >= 1 && forecast_points <= 1000, "forecast points must lie in [1, 1000]");
  require(spread_updates >= 1 && spread_updates <= 1000, "spread updates must lie in [1, 1000]");
  require(operating_window_records >= 1 && operating_window_records <= 100000, "operating window must lie in [1, 100000]");
  require(max_intervals >= 4, "at least 4 intervals must be kept");
  require(std::isfinite(min_wear_elasticity) && min_wear_elasticity >= 0 && min_wear_elasticity < 1,
          "minimum K_wear elasticity must lie in [0, 1)");
  require(std::isfinite(pitting_reference_torque_nm) && pitting_reference_torque_nm > 0, "pitting reference torque must be positive");
  require(std::isfinite(pitting_reference_density) && pitting_reference_density > 0 && pitting_reference_density < 1,
          "pitting reference density must lie in (0, 1)");
  require(std::isfinite(prior_log_k_wear_sd) && prior_log_k_wear_sd > 0, "prior SD of ln K_wear must be positive");
  require(std::isfinite(log_k_drift_per_million_cycles) && log_k_drift_per_million_cycles >= 0, "ln K drift must be non-negative");
  require(std::isfinite(rms_sa_relative_sd_floor) && rms_sa_relative_sd_floor > 0 && rms_sa_relative_sd_floor < 1,
          "RMS_SA scatter floor must lie in (0, 1)");
  require(std::isfinite(inspection_depth_relative_sd) && inspection_depth_relative_sd > 0 && inspection_depth_relative_sd < 1,
          "inspection depth SD must lie in (0, 1)");
  require(std::isfinite(inspection_area_relative_sd) && inspection_area_relative_sd > 0 && inspection_area_relative_sd < 1,
          "inspection area SD must lie in (0, 1)");
  require(disagreement_records >= 1 && disagreement_records <= 1000, "disagreement records must lie in [1, 1000]");
  require(scatter_records >= disagreement_records && scatter_records <= 100000, "scatter records must lie in [disagreement records, 100000]");
  require(std::isfinite(innovation_gate_sd) && innovation_gate_sd > 0, "innovation gate must be positive");
  require(ics2_onset_records >= 1 && ics2_onset_records <= 1000, "ICS2 onset records must lie in [1, 1000]");
  require(ics2_trend_records >= 3 && ics2_trend_records <= 1000, "ICS2 trend records must lie in [3, 1000]");
  require(ics2_saturation > 0, "ICS2 saturation level must be positive (infinity: none)");
}

double pearson3(const std::array<double, 3>& x, const std::array<double, 3>& y) {
  const double mx = (x[0] + x[1] + x[2]) / 3.0, my = (y[0] + y[1] + y[2]) / 3.0;
  double sxy = 0, sxx = 0, syy = 0;
  for (int i = 0; i < 3; ++i) {
    sxy += (x[i] - mx) * (y[i] - my);
    sxx += (x[i] - mx) * (x[i] - mx);
    syy += (y[i] - my) * (y[i] - my);
  }
  // No spread (to rounding) in either triple: the correlation is undefined.
  const double scale_x = std::max({std::abs(x[0]), std::abs(x[1]), std::abs(x[2])});
  const double scale_y = std::max({std::abs(y[0]), std::abs(y[1]), std::abs(y[2])});
  if (!(sxx > 1e-24 * scale_x * scale_x) || !(syy > 1e-24 * scale_y * scale_y)) return kNaN;
  return sxy / std::sqrt(sxx * syy);
}

namespace {
WearLoopOptions loop_options(const ModelSettings& s) { return s.loop; }

// The prior of ln K_wear: about the given K (the configured initial guess), SD prior_log_k_wear_sd.
LogPosterior wear_prior(const ModelSettings& s, double k, double cycles) {
  return LogPosterior{true, std::log(std::max(k, s.k_wear_min_si)), s.prior_log_k_wear_sd * s.prior_log_k_wear_sd, cycles};
}

LoopSnapshot unworn_snapshot(const ModelSettings& s) {
  LoopSnapshot snap;
  const auto n = static_cast<std::size_t>(s.loop.profile_points);
  snap.state.pinion_depth_m.assign(n, 0.0);
  snap.state.gear_depth_m.assign(n, 0.0);
  snap.state.pinion_pitting.assign(n, 0.0);
  snap.next_step_cycles = s.loop.initial_step_cycles;
  return snap;
}
}  // namespace

TwinModel::TwinModel(twin::GearboxParameters params, ModelSettings settings, RmsSaSimulator simulator, ModelMemory memory)
    : params_(std::move(params)),
      settings_((settings.validate(), std::move(settings))),
      simulator_(std::move(simulator)),
      memory_(std::move(memory)),
      loop_(params_, loop_options(settings_)),
      pitting_scale_(wear::pitting_scale(params_, settings_.loop, settings_.pitting_reference_torque_nm,
                                         settings_.pitting_reference_density)) {
  if (!memory_.started) {
    start_new_pair();
  } else {
    loop_ = loop_at(memory_.current);
    // A state stored before the posterior existed: the prior about its K, from its cycles on.
    if (!memory_.log_k_wear.valid) memory_.log_k_wear = wear_prior(settings_, memory_.k_wear_si, memory_.current.state.cycles);
    // A state stored before the upper-bound rule: its K_wear is the last identified one.
    if (!(memory_.k_wear_identified_si > 0)) memory_.k_wear_identified_si = memory_.k_wear_si;
  }
}

void TwinModel::start_new_pair() {
  ModelMemory fresh;
  fresh.current = unworn_snapshot(settings_);
  fresh.wear_anchor = fresh.current;
  fresh.pitting_anchor = fresh.current;
  fresh.k_wear_si = settings_.loop.k_wear_si;
  fresh.k_wear_identified_si = fresh.k_wear_si;
  fresh.k_pitting = settings_.loop.k_pitting;
  fresh.log_k_wear = wear_prior(settings_, fresh.k_wear_si, 0.0);
  memory_ = std::move(fresh);
  loop_ = loop_at(memory_.current);
}

BlueLoop TwinModel::loop_at(const LoopSnapshot& from) const {
  BlueLoop loop(params_, loop_options(settings_));
  loop.restore(from.state, std::clamp(from.next_step_cycles, settings_.loop.min_step_cycles, settings_.loop.max_step_cycles));
  return loop;
}

bool TwinModel::rerun(const LoopSnapshot& from, const Override& o, LoopSnapshot& out, bool recapture_anchors) {
  BlueLoop loop = loop_at(from);
  double last_speed = -1, last_torque = -1;
  bool ok = true;
  auto capture = [&](LoopSnapshot& anchor) {
    if (recapture_anchors && anchor.state.cycles > from.state.cycles && loop.state().cycles == anchor.state.cycles)
      anchor = LoopSnapshot{loop.state(), loop.next_step_cycles()};
  };
  // The re-run's path at the records, for the inspected depths read against the path it replaces.
  std::vector<PathPoint> path{{from.state.cycles, summarise(from.state).combined_mean_depth_m}};
  for (const LifeInterval& in : memory_.intervals) {
    if (in.end_cycles <= from.state.cycles) continue;
    if (in.speed_hz != last_speed || in.torque_nm != last_torque) {
      loop.set_operating_point({in.speed_hz, in.torque_nm});
      last_speed = in.speed_hz;
      last_torque = in.torque_nm;
    }
    const bool overridden = in.end_cycles > o.from_cycles;
    loop.set_coefficients(overridden && o.k_wear ? *o.k_wear : in.k_wear_si,
                          overridden && o.k_pitting ? *o.k_pitting : in.k_pitting);
    if (!loop.run_until(in.end_cycles)) {
      ok = false;
      break;
    }
    capture(memory_.wear_anchor);
    capture(memory_.pitting_anchor);
    if (recapture_anchors) path.push_back({loop.state().cycles, summarise(loop.state()).combined_mean_depth_m});
  }
  out = LoopSnapshot{loop.state(), loop.next_step_cycles()};
  if (ok && recapture_anchors) reread_depth_points(path);
  return ok;
}

void TwinModel::reread_depth_points(const std::vector<PathPoint>& path) {
  // An inspected depth is a reading of the truth against the model's depth at its cycles. A re-run
  // from before it replaces the model's path there (a new K_wear from its anchor): ρ read against
  // the replaced path, applied to the new depth now, would count the re-run's change on top of the
  // measured depth (and the rate reading's increments would be the old path's).
  for (DepthRatioMeasurement& m : memory_.depth_ratio_points) {
    if (!(m.cycles > path.front().cycles)) continue;
    const double model = path_mean_at(path, m.cycles);
    if (model > 0) m = reread(m, model);
  }
}

void TwinModel::apply_k(bool wear, double value, double from_cycles) {
  for (LifeInterval& in : memory_.intervals)
    if (in.end_cycles > from_cycles) (wear ? in.k_wear_si : in.k_pitting) = value;
  if (wear) set_k_from(memory_.k_wear_history, from_cycles, value);
  (wear ? memory_.k_wear_si : memory_.k_pitting) = value;
  remember_k(wear ? memory_.recent_k_wear : memory_.recent_k_pitting, value);
}

void TwinModel::remember_k(std::vector<double>& recent, double k) const {
  recent.push_back(k);
  const auto n = static_cast<std::size_t>(settings_.spread_updates);
  if (recent.size() > n) recent.erase(recent.begin(), recent.end() - static_cast<std::ptrdiff_t>(n));
}

std::string TwinModel::learn(LogPosterior& posterior, double z, double r, double cycles) const {
  const LogPosterior prior = predict(posterior, cycles, settings_.log_k_q_per_cycle());
  const FilterStep step = filter_update(prior, z, r, settings_.innovation_gate_sd);
  posterior = step.posterior;
  char b[300];
  if (!prior.valid)
    std::snprintf(b, sizeof b, "; posterior ln K %.4f SD %.3g (the first measurement, SD %.3g)", posterior.mean, std::sqrt(posterior.var),
                  std::sqrt(r));
  else
    std::snprintf(b, sizeof b, "; posterior ln K %.4f SD %.3g -> %.4f SD %.3g (measurement SD %.3g, innovation %.2f SD%s)", prior.mean,
                  std::sqrt(prior.var), posterior.mean, std::sqrt(posterior.var), std::sqrt(r), step.innovation_sd,
                  step.inflated ? ": beyond the gate, prior variance raised to the innovation's" : "");
  return b;
}

double TwinModel::rms_scatter_sd() const {
  // Records without an update, older than the disagreement window (its check must not judge
  // the residuals by their own scatter).
  const auto& all = memory_.rms_residuals;
  const std::size_t window = static_cast<std::size_t>(settings_.disagreement_records);
  std::vector<double> quiet;
  for (std::size_t i = 0; i + window < all.size(); ++i)
    if (all[i][1] == 0.0) quiet.push_back(all[i][0]);
  return scatter_sd(quiet, settings_.rms_sa_relative_sd_floor);
}

double TwinModel::pitting_measurement_var() const {
  const double scatter = memory_.scale_residual_count ? memory_.scale_residual_sum_sq / static_cast<double>(memory_.scale_residual_count) : 0.0;
  return memory_.pitting_calibration_var + scatter;
}

void TwinModel::remember_residual(double log_residual, bool updated) {
  auto& r = memory_.rms_residuals;
  r.push_back({log_residual, updated ? 1.0 : 0.0});
  const auto n = static_cast<std::size_t>(settings_.scatter_records);
  if (r.size() > n) r.erase(r.begin(), r.end() - static_cast<std::ptrdiff_t>(n));
}

void TwinModel::prune_intervals() {
  const double oldest = std::min(memory_.wear_anchor.state.cycles, memory_.pitting_anchor.state.cycles);
  auto& iv = memory_.intervals;
  iv.erase(std::remove_if(iv.begin(), iv.end(), [&](const LifeInterval& in) { return in.end_cycles <= oldest; }), iv.end());
  // Beyond the cap, neighbours with the same coefficients become one interval at their
  // cycle-weighted operating point (a re-run then takes one stretch instead of two).
  while (iv.size() > settings_.max_intervals) {
    bool merged = false;
    double start = oldest;
    for (std::size_t i = 0; i + 1 < iv.size(); ++i) {
      LifeInterval& a = iv[i];
      const LifeInterval& b = iv[i + 1];
      if (a.k_wear_si == b.k_wear_si && a.k_pitting == b.k_pitting) {
        const double wa = a.end_cycles - start, wb = b.end_cycles - a.end_cycles;
        a.speed_hz = (a.speed_hz * wa + b.speed_hz * wb) / (wa + wb);
        a.torque_nm = (a.torque_nm * wa + b.torque_nm * wb) / (wa + wb);
        a.end_cycles = b.end_cycles;
        iv.erase(iv.begin() + static_cast<std::ptrdiff_t>(i + 1));
        merged = true;
        break;
      }
      start = a.end_cycles;
    }
    if (!merged) break;
  }
}

double TwinModel::ics2_at(double cycles) const {
  const auto& s = memory_.ics2_series;
  if (s.empty()) return kNaN;
  if (cycles <= s.front()[0]) return s.front()[1];
  if (cycles >= s.back()[0]) return s.back()[1];
  const auto it = std::lower_bound(s.begin(), s.end(), cycles, [](const std::array<double, 2>& p, double c) { return p[0] < c; });
  const auto& hi = *it;
  const auto& lo = *(it - 1);
  if (hi[0] == lo[0]) return hi[1];
  return lo[1] + (cycles - lo[0]) / (hi[0] - lo[0]) * (hi[1] - lo[1]);
}

std::array<double, 2> forecast_operating_point(const std::vector<std::array<double, 2>>& points, double step_fraction,
                                               double step_standard_errors) {
  const std::size_t n = points.size();
  if (n == 0) return {0.0, 0.0};
  auto mean = [&](std::size_t a, std::size_t b, int i) {
    double sum = 0;
    for (std::size_t k = a; k < b; ++k) sum += points[k][i];
    return sum / static_cast<double>(b - a);
  };
  // The record-to-record scatter from successive differences (a step moves one of them only):
  // σ = 1.4826 median |ΔT| / √2.
  std::vector<double> diffs;
  for (std::size_t k = 1; k < n; ++k) diffs.push_back(std::abs(points[k][1] - points[k - 1][1]));
  double sigma = 0;
  if (!diffs.empty()) {
    std::nth_element(diffs.begin(), diffs.begin() + static_cast<std::ptrdiff_t>(diffs.size() / 2), diffs.end());
    sigma = 1.4826 * diffs[diffs.size() / 2] / std::sqrt(2.0);
  }
  std::size_t from = 0;
  for (;;) {
    // The split of [from, n) whose sides' mean torques differ most.
    std::size_t best = 0;
    double best_d = 0;
    for (std::size_t k = from + 1; k < n; ++k) {
      const double d = std::abs(mean(k, n, 1) - mean(from, k, 1));
      if (d > best_d) best = k, best_d = d;
    }
    if (best == 0) break;
    const double se = sigma * std::sqrt(1.0 / static_cast<double>(best - from) + 1.0 / static_cast<double>(n - best));
    if (!(best_d >= step_fraction * std::abs(mean(best, n, 1)) && best_d >= step_standard_errors * se)) break;
    from = best;
  }
  return {mean(from, n, 0), mean(from, n, 1)};
}

namespace {
// The forecast's operating point is read from the newest `window` records (operating_window_records).
void remember_operating_point(std::vector<std::array<double, 2>>& points, const ModelObservation& obs, std::size_t window) {
  points.push_back({obs.speed_hz, obs.torque_nm});
  if (points.size() > window) points.erase(points.begin(), points.end() - static_cast<std::ptrdiff_t>(window));
}
}  // namespace

ModelRunReport TwinModel::observe(const ModelObservation& obs, const std::vector<Inspection>& inspections) {
  ModelRunReport report;
  report.observation = obs;
  auto finish = [&] {
    const WearState& s = memory_.current.state;
    report.summary = summarise(s);
    report.max_depth_m = max_depth(s);
    report.combined_depth_m = combined_profile(s);
    report.k_wear_si = memory_.k_wear_si;
    report.k_pitting = memory_.k_pitting;
    if (obs.ics2_low && memory_.ics2_scale_valid)
      report.ics2_density_estimate = ics2_scale().density_at(*obs.ics2_low);
  };
  // --- can this record be used at all?
  if (!std::isfinite(obs.cycles) || obs.cycles < 0) {
    add_issue(report, ModelIssue::missing_cycles, "the record has no life-counter position");
    finish();
    return report;
  }
  if (!std::isfinite(obs.speed_hz) || !std::isfinite(obs.torque_nm)) {
    add_issue(report, ModelIssue::missing_operating_point, "speed or torque unknown");
    finish();
    return report;
  }
  if (const std::string outside = out_of_range_text(obs, settings_); !outside.empty()) {
    add_issue(report, ModelIssue::operating_point_out_of_range, outside);
    finish();
    return report;
  }
  if (memory_.started && pair_boundary({memory_.current.state.cycles, obs.cycles}) == PairBoundary::count_went_backwards) {
    // The life counter went backwards: a new gear pair by the gear-pair rule (or a front-end fault; never merged).
    start_new_pair();
    report.new_gear_pair = true;
  } else if (memory_.started && obs.cycles == memory_.current.state.cycles) {
    add_issue(report, ModelIssue::cycles_not_increasing, "at the cycles of the model's previous record");
    finish();
    return report;
  }
  const double prev_cycles = memory_.current.state.cycles;
  const double prev_mean = summarise(memory_.current.state).combined_mean_depth_m;
  memory_.started = true;
  calibrated_pitting_here_.reset();
  ++memory_.records_used;
  report.advanced = true;
  const twin::OperatingPoint op{obs.speed_hz, obs.torque_nm};
  remember_operating_point(memory_.recent_operating_points, obs, static_cast<std::size_t>(settings_.operating_window_records));
  if (obs.ics2_low && std::isfinite(*obs.ics2_low)) memory_.ics2_series.push_back({obs.cycles, *obs.ics2_low});

  // --- blue loop to the record, at its speed and torque, with the current coefficients
  memory_.intervals.push_back({obs.cycles, obs.speed_hz, obs.torque_nm, memory_.k_wear_si, memory_.k_pitting});
  extend_k_history(memory_.k_wear_history, obs.cycles, memory_.k_wear_si);
  loop_.set_operating_point(op);
  loop_.set_coefficients(memory_.k_wear_si, memory_.k_pitting);
  bool within_limit = loop_.run_until(obs.cycles);
  memory_.current = LoopSnapshot{loop_.state(), loop_.next_step_cycles()};
  if (!within_limit) {
    add_issue(report, ModelIssue::depth_limit_reached,
              "the blue loop stopped at " + fmt("%.6g", loop_.state().cycles) + " cycles, before a flank passes " +
                  fmt("%.3g", settings_.loop.depth_limit_m * 1e3) + " mm; the state is held there");
    // Keep the intervals consistent with the state the loop reached.
    memory_.intervals.back().end_cycles = loop_.state().cycles;
    memory_.k_wear_history.back().end_cycles = loop_.state().cycles;
  }

  // --- purple loop: K_pitting first (its re-run starts at the last pitting point), then K_wear
  if (within_limit) {
    if (settings_.update_k_pitting) calibrate_pitting(inspections, obs.cycles, report);
    if (settings_.update_k_pitting) check_pitting(obs, report);
    if (!obs.ics2_low || !std::isfinite(*obs.ics2_low))
      add_issue(report, ModelIssue::missing_ics2, "no ICS2 in the low band: no pitting point from this record");
    check_k_wear(obs, report);
    accept_calibrated_state();
    read_depth_inspections(inspections, prev_cycles, prev_mean, report);
  }
  read_pitted_area_inspections(inspections, memory_.current.state.cycles);
  prune_intervals();
  report.forecast = forecast();
  finish();
  return report;
}

void TwinModel::hold_calibrated_pitting(LoopSnapshot& at_record) {
  if (!calibrated_pitting_here_) return;
  // The re-run replayed the stretch with the K_pitting of its time; at the record the inspections
  // set the profile. The re-run recaptured the pitting anchor (here) without it: it gets it back.
  at_record.state.pinion_pitting = *calibrated_pitting_here_;
  memory_.pitting_anchor = at_record;
}

void TwinModel::accept_calibrated_state() {
  if (!calibrated_pitting_here_) return;
  // Re-runs replay the life intervals with their stored K_pitting, which cannot reproduce a
  // profile the inspections set: from here on every re-run starts at this record.
  memory_.wear_anchor = memory_.current;
  memory_.pitting_anchor = memory_.current;
  calibrated_pitting_here_.reset();
}

void TwinModel::check_k_wear(const ModelObservation& obs, ModelRunReport& report) {
  const std::optional<double> simulated = simulate_record(obs, report);
  if (!simulated) return;
  const double measured = *obs.rms_sa;
  if (commission_rms_sa(obs, measured, *simulated, report)) return;
  // Wear is asked to explain only what the pair's offset at zero wear does not: the twin's RMS_SA
  // times the commissioning ratio is matched to the measurement, i.e. the twin's to `target`.
  const double ratio = memory_.rms_sa_reference_ratio;
  const double target = measured / ratio;
  const bool update = settings_.update_k_wear && std::abs(*simulated - target) / target > settings_.rms_threshold;
  remember_residual(std::log(target / *simulated), update);
  if (!update) return;

  KUpdate u;
  u.kind = UpdateKind::k_wear;
  u.trigger = UpdateTrigger::rms_sa_mismatch;
  u.cycles = obs.cycles;
  u.old_value = memory_.k_wear_si;
  u.applies_from_cycles = memory_.wear_anchor.state.cycles;
  u.measured = measured;
  u.simulated_before = *simulated;
  // A failed re-run must not leave recaptured anchors behind: every trial starts from `saved`.
  WearSearch search{memory_.wear_anchor, memory_, {obs.speed_hz, obs.torque_nm}, target, memory_.k_wear_si, *simulated, 0, std::nullopt, {}, false, std::numeric_limits<double>::quiet_NaN(), {}, {}};
  search_k_wear(search, u);
  const std::string why_of_search = search.why;
  const bool keep = keep_k_wear(search, u, *simulated);
  std::optional<KneeReading> knee;
  if (!keep && knee_applies(search, u, *simulated)) {
    const std::string why_of_keep = search.why;
    search.why = why_of_search;   // a knee replaces keep_k_wear's "left as it was"
    std::string no_knee;
    knee = read_knee(search, u, no_knee);
    if (!knee) search.why = why_of_keep + (why_of_keep.empty() ? "" : "; ") + no_knee;
  }
  u.iterations = search.evaluations;
  if (knee)
    apply_k_wear_bound(*knee, search, u, *simulated, report);
  else
    apply_k_wear_result(keep, search, u, *simulated, report);
  u.evidence = k_wear_evidence(search, u, ratio, *simulated);
  if (keep) {
    learn_k_wear(u, *simulated, obs.cycles);
    read_profile_shape(obs, u.simulated_after, u);
  }
  // Not identified: RMS_SA insensitive, no K reproduced the record, or only a bound (the interval then widens).
  memory_.k_wear_last_insensitive = u.outcome == UpdateOutcome::insensitive || !keep;
  report.updates.push_back(std::move(u));
}

std::optional<double> TwinModel::simulate_record(const ModelObservation& obs, ModelRunReport& report) {
  if (!obs.rms_sa || !std::isfinite(*obs.rms_sa) || *obs.rms_sa <= 0) {
    add_issue(report, ModelIssue::missing_rms_sa, "no positive RMS_SA: K_wear not checked");
    return std::nullopt;
  }
  double simulated = 0;
  try {
    simulated = simulator_(memory_.current.state, twin::OperatingPoint{obs.speed_hz, obs.torque_nm});
    if (!std::isfinite(simulated) || simulated <= 0) throw twin::TwinDivergenceError("simulated RMS_SA is not a positive number");
  } catch (const std::exception& e) {
    add_issue(report, ModelIssue::simulation_failed, std::string("K_wear not checked: ") + e.what());
    return std::nullopt;
  }
  report.rms_sa_simulated = simulated;
  return simulated;
}

void TwinModel::search_k_wear(WearSearch& search, KUpdate& u) {
  if (memory_.current.state.cycles <= search.anchor.state.cycles) {
    // No life between the wear anchor and the record: every K re-runs to the same state, so no
    // re-run can tell one K from another.
    u.outcome = UpdateOutcome::insensitive;
    search.why = "no cycles run since K_wear was last set (" + fmt("%.6g", search.anchor.state.cycles) +
                 " cycles): K_wear cannot change the twin's state at this record, so K_wear is left as it was";
  } else if (settings_.k_wear_update == KWearUpdateRule::proportional) {
    update_k_wear_proportional(search, u);
  } else {
    update_k_wear_root_find(search, u);
  }
}

bool TwinModel::keep_k_wear(WearSearch& search, const KUpdate& u, double simulated) const {
  const double target = search.measured;
  // Keep the best K found if it improved on the old one; otherwise nothing changes. An RMS_SA
  // insensitive to K_wear at the root changes nothing either: its K would follow the scatter.
  const bool insensitive_here = u.outcome == UpdateOutcome::insensitive;
  // A K whose RMS_SA still misses the measurement by more than the update threshold is no
  // measurement of K_wear: the twin's RMS_SA-wear relation does not reach the record from the
  // anchor (a model-form disagreement, e.g. the measured RMS_SA dipping deeper with wear than the
  // twin's can). Keeping the closest K anyway ratchets K_wear towards zero over records whose
  // measurement lies below everything the twin gives, and the depth with it.
  const bool reproduces = search.best && std::abs(search.best->sim - target) / target <= settings_.rms_threshold;
  // A K at an end of the configured range that ended the search there (no K crossed the
  // measurement) is the range's guard, not a value the record chose: RMS_SA is as close to the
  // measurement there as the twin can bring it, which bounds K_wear on one side only. Keeping the
  // lower end forecasts no wear until the next update (the upper one, wear at the guard's rate);
  // the last identified K_wear stays and the update counts as not identified.
  const bool guard_only = u.outcome == UpdateOutcome::bound_reached && search.best &&
                          (search.best->k <= settings_.k_wear_min_si * (1 + 1e-9) || search.best->k >= settings_.k_wear_max_si * (1 - 1e-9));   // exp(ln K) rounds
  const bool keep = !insensitive_here && reproduces && !guard_only && std::abs(search.best->sim - target) < std::abs(simulated - target);
  if (!insensitive_here && reproduces && guard_only)
    search.why += std::string(search.why.empty() ? "" : "; ") + "the closest K_wear, " + fmt("%.4g", search.best->k) +
                  " m^2/N (" + fmt("%+.3g", 100 * (search.best->sim - target) / target) +
                  " %), is an end of the configured range, not a value the record determines: K_wear left as it was";
  if (!keep && !insensitive_here && search.best && !reproduces)
    search.why += std::string(search.why.empty() ? "" : "; ") + "no K_wear tried reproduced the measurement within " +
                  fmt("%.3g", 100 * settings_.rms_threshold) + " % (closest " +
                  fmt("%+.3g", 100 * (search.best->sim - target) / target) + " % at K_wear " + fmt("%.4g", search.best->k) +
                  "): a model-form disagreement, not a measurement of K_wear; K_wear left as it was";
  return keep;
}

void TwinModel::apply_k_wear_result(bool keep, WearSearch& search, KUpdate& u, double simulated, ModelRunReport& report) {
  if (keep) {
    WearTrial& best = *search.best;
    memory_ = std::move(best.memory);
    memory_.current = best.state;
    apply_k(true, best.k, search.anchor.state.cycles);
    memory_.k_wear_identified_si = best.k;
    memory_.wear_anchor = memory_.current;
    loop_ = loop_at(memory_.current);
    ++memory_.k_wear_updates;
    u.new_value = best.k;
    u.simulated_after = best.sim;
    report.rms_sa_simulated = best.sim;
  } else {
    memory_ = search.saved;
    u.new_value = u.old_value;
    u.simulated_after = simulated;
    if (u.outcome == UpdateOutcome::converged) u.outcome = UpdateOutcome::not_monotone;
  }
}

std::string TwinModel::k_wear_evidence(const WearSearch& search, const KUpdate& u, double ratio, double simulated) const {
  const double measured = u.measured, target = search.measured;
  char b[500];
  const std::string against =
      ratio == 1.0 ? fmt("%.5g", measured) : fmt("%.5g", measured) + " / commissioning ratio " + fmt("%.4g", ratio) + " = " + fmt("%.5g", target);
  std::snprintf(b, sizeof b, "RMS_SA measured %s, simulated %.5g (%+.2f %%) -> %.5g (%+.2f %%) after %d %s, K_wear %.5g -> %.5g m^2/N",
                against.c_str(), simulated, 100 * (simulated - target) / target, u.simulated_after, 100 * (u.simulated_after - target) / target,
                u.iterations, settings_.k_wear_update == KWearUpdateRule::proportional ? "iteration(s) of Eq. 7.13" : "twin re-run(s)",
                u.old_value, u.new_value);
  std::string evidence = b;
  if (std::isfinite(u.elasticity)) evidence += "; elasticity d ln RMS_SA / d ln K_wear " + fmt("%.3g", u.elasticity);
  if (std::isfinite(search.root_elasticity)) evidence += " (at the root " + fmt("%.3g", search.root_elasticity) + ")";
  if (!search.why.empty()) evidence += "; " + search.why;
  return evidence;
}

void TwinModel::learn_k_wear(KUpdate& u, double simulated, double cycles) {
  // The update is a measurement of ln K_wear: ε / e with ε the RMS_SA's relative scatter and e
  // the elasticity between the old and the new K (the sensitivity read's when that is flat).
  double e = std::log(u.simulated_after / simulated) / std::log(u.new_value / u.old_value);
  if (!std::isfinite(e) || std::abs(e) < settings_.min_wear_elasticity) e = u.elasticity;
  if (!std::isfinite(e) || std::abs(e) < settings_.min_wear_elasticity) e = 1.0;   // the proportional rule's assumption
  memory_.k_wear_elasticity = e;
  const double sd = rms_scatter_sd() / std::abs(e);
  u.evidence += learn(memory_.log_k_wear, std::log(u.new_value), sd * sd, cycles);
}

void TwinModel::read_profile_shape(const ModelObservation& obs, double simulated, KUpdate& u) {
  // RMS_SA fixes a mean depth only for a given profile shape (docs/model.md, "Profile-shape term").
  // The other end of what the model's own Archard law can give: no load-sharing feedback, the
  // wear concentrated where the unworn pair's load and sliding put it. Its mean depth at the
  // RMS_SA the model's profile gives here (the model's, not the measured: only the shape differs).
  const double model_mean = summarise(memory_.current.state).combined_mean_depth_m;
  if (!(model_mean > 0) || !(simulated > 0)) return;
  WearLoopOptions o = settings_.loop;
  o.operating_point = {obs.speed_hz, obs.torque_nm};
  std::string note;
  try {
    const BlueLoop unworn(params_, o);
    const WearState unit = concentrated_wear_shape(unworn.geometry(), unworn.current_load(), o.profile_points);
    const double peak = peak_to_mean(unit);
    const twin::OperatingPoint op{obs.speed_hz, obs.torque_nm};
    auto rms = [&](const WearState& w) { return simulator_(w, op); };
    const ShapeDepthMatch m = match_shape_to_rms_sa(unit, simulated, model_mean, rms, settings_.convergence_tolerance,
                                                    kShapeMatchEvaluations, o.depth_limit_m / peak);
    if (!m.valid) {
      note = "profile shape: not read (" + m.why + "); the last reading kept";
    } else {
      memory_.shape_depth_ratio = m.mean_depth_m / model_mean;
      memory_.shape_peak_ratio = peak;
      memory_.shape_depth_elasticity =
          std::isfinite(m.depth_elasticity) && m.depth_elasticity > settings_.min_wear_elasticity ? m.depth_elasticity : 1.0;
      memory_.shape_cycles = obs.cycles;
      char b[300];
      std::snprintf(b, sizeof b, "profile shape: at RMS_SA %.5g the concentrated-wear shape (deepest point %.3g x its mean) has mean depth %.4g um, %.3g x the model's %.4g um (%d twin runs; d ln RMS_SA / d ln depth %.3g)",
                    simulated, peak, 1e6 * m.mean_depth_m, memory_.shape_depth_ratio, 1e6 * model_mean, m.evaluations,
                    memory_.shape_depth_elasticity);
      note = b;
    }
  } catch (const std::exception& e) {
    note = std::string("profile shape: not read (") + e.what() + "); the last reading kept";
  }
  u.evidence += (u.evidence.empty() ? "" : "; ") + note;
}

bool TwinModel::commission_rms_sa(const ModelObservation& obs, double measured, double simulated, ModelRunReport& report) {
  auto& refs = memory_.rms_sa_reference_records;
  if (memory_.rms_sa_reference_closed) return false;
  const twin::OperatingPoint op{obs.speed_hz, obs.torque_nm};
  if (refs.size() >= static_cast<std::size_t>(settings_.commissioning_records) || wear_can_move_rms_sa(simulated, op)) {
    // From here on a mismatch may be wear: the ratio (1 when no record qualified) stays as it is.
    memory_.rms_sa_reference_closed = true;
    return false;
  }
  // No K_wear in the configured range explains a mismatch here: it is the pair's offset at zero
  // wear (twin against this rig and sensor), a calibration matter, not a measurement of K_wear.
  refs.push_back({obs.cycles, std::log(measured / simulated)});
  std::vector<double> logs;
  for (const auto& r : refs) logs.push_back(r[1]);
  std::nth_element(logs.begin(), logs.begin() + static_cast<std::ptrdiff_t>(logs.size() / 2), logs.end());
  double median = logs[logs.size() / 2];
  if (logs.size() % 2 == 0) median = 0.5 * (median + *std::max_element(logs.begin(), logs.begin() + static_cast<std::ptrdiff_t>(logs.size() / 2)));
  memory_.rms_sa_reference_ratio = std::exp(median);
  char b[300];
  std::snprintf(b, sizeof b,
                "RMS_SA commissioning: measured %.5g, twin %.5g at %.6g cycles, where no K_wear from %.3g to %.3g m^2/N moves the twin's RMS_SA by %.3g %%: commissioning ratio %.4g (median of %zu record(s) from %.6g cycles); no K_wear update",
                measured, simulated, obs.cycles, settings_.k_wear_min_si, settings_.k_wear_max_si, 100 * settings_.rms_threshold,
                memory_.rms_sa_reference_ratio, refs.size(), refs.front()[0]);
  report.detail += (report.detail.empty() ? "" : "; ") + std::string(b);
  return true;
}

bool TwinModel::wear_can_move_rms_sa(double simulated, const twin::OperatingPoint& op) {
  // No life between the wear anchor and the record: every K re-runs to the same state.
  if (memory_.current.state.cycles <= memory_.wear_anchor.state.cycles) return false;
  const ModelMemory saved = memory_;
  bool moves = false;
  for (const double k : {settings_.k_wear_min_si, settings_.k_wear_max_si}) {
    LoopSnapshot out;
    if (!rerun(memory_.wear_anchor, Override{k, std::nullopt, memory_.wear_anchor.state.cycles}, out, false)) {
      moves = true;   // a flank past the depth limit: wear explains any mismatch
      break;
    }
    try {
      const double sim = simulator_(out.state, op);
      // No answer is no proof of an offset: treated as wear that may move RMS_SA.
      if (!std::isfinite(sim) || sim <= 0 || std::abs(std::log(sim / simulated)) >= settings_.rms_threshold) moves = true;
    } catch (const std::exception&) {
      moves = true;
    }
    if (moves) break;
  }
  memory_ = saved;
  return moves;
}

std::optional<TwinModel::WearTrial> TwinModel::wear_trial(double k, WearSearch& search, KUpdate& u) {
  ++search.evaluations;
  search.depth_limited = false;
  memory_ = search.saved;
  WearTrial t;
  t.k = k;
  if (!rerun(search.anchor, Override{k, std::nullopt, search.anchor.state.cycles}, t.state, true)) {
    search.points.push_back({std::log(k), std::numeric_limits<double>::infinity()});
    u.outcome = UpdateOutcome::bound_reached;
    search.depth_limited = true;
    search.why = "with K_wear = " + fmt("%.4g", k) + " a flank passes the depth limit before the record";
    return std::nullopt;
  }
  hold_calibrated_pitting(t.state);
  try {
    t.sim = simulator_(t.state.state, search.op);
    if (!std::isfinite(t.sim) || t.sim <= 0) throw twin::TwinDivergenceError("simulated RMS_SA is not a positive number");
  } catch (const std::exception& e) {
    u.outcome = UpdateOutcome::simulation_failed;
    search.why = std::string("simulation failed at K_wear = ") + fmt("%.4g", k) + ": " + e.what();
    return std::nullopt;
  }
  t.log_error = std::log(t.sim / search.measured);
  t.memory = memory_;
  search.points.push_back({std::log(k), t.log_error});
  search.trials.push_back(t);
  if (!search.best || std::abs(t.sim - search.measured) < std::abs(search.best->sim - search.measured)) search.best = t;
  return t;
}

bool TwinModel::wear_converged(const WearTrial& t, double measured) const {
  return std::abs(t.sim - measured) / measured <= settings_.convergence_tolerance;
}

void TwinModel::update_k_wear_proportional(WearSearch& search, KUpdate& u) {
  double k = search.k0, sim = search.sim0, last_error = (sim - search.measured) / search.measured;
  u.outcome = UpdateOutcome::iteration_limit;
  while (search.evaluations < settings_.max_wear_iterations) {
    // Eqs. 7.13–7.14: K ← K / G, G = RMS_SA,sim / RMS_SA,meas.
    double next = std::clamp(k * search.measured / sim, settings_.k_wear_min_si, settings_.k_wear_max_si);
    if (k <= 0) next = settings_.k_wear_min_si;
    if (next == k) {
      u.outcome = UpdateOutcome::bound_reached;
      search.why = "K_wear at its bound " + fmt("%.4g", k);
      return;
    }
    k = next;
    const std::optional<WearTrial> t = wear_trial(k, search, u);
    if (!t) return;
    sim = t->sim;
    const double err = (sim - search.measured) / search.measured;
    if (wear_converged(*t, search.measured)) {
      u.outcome = UpdateOutcome::converged;
      return;
    }
    if (std::abs(err) >= std::abs(last_error)) {
      u.outcome = UpdateOutcome::not_monotone;
      search.why = "the error grew from " + fmt("%.3g", 100 * last_error) + " % to " + fmt("%.3g", 100 * err) +
                   " %: RMS_SA does not rise with K_wear here";
      return;
    }
    last_error = err;
  }
  search.why = "no convergence to " + fmt("%.3g", 100 * settings_.convergence_tolerance) + " % in " +
               std::to_string(settings_.max_wear_iterations) + " iterations";
}

namespace {
// The tightest pair of points on either side of the root, if any: (low, high) with low.g < 0 < high.g.
std::optional<std::pair<LogKPoint, LogKPoint>> bracket_of(const std::vector<LogKPoint>& pts) {
  std::optional<std::pair<LogKPoint, LogKPoint>> best;
  for (const LogKPoint& a : pts)
    for (const LogKPoint& b : pts)
      if (a.g < 0 && b.g > 0 && (!best || std::abs(a.x - b.x) < std::abs(best->first.x - best->second.x))) best = std::pair{a, b};
  return best;
}

// The outermost point in direction dir (+1: largest ln K, −1: smallest) and its finite neighbour inwards.
std::pair<LogKPoint, std::optional<LogKPoint>> outermost(const std::vector<LogKPoint>& pts, int dir) {
  std::vector<LogKPoint> sorted = pts;
  std::sort(sorted.begin(), sorted.end(), [dir](const LogKPoint& a, const LogKPoint& b) { return dir * a.x > dir * b.x; });
  std::optional<LogKPoint> inner;
  if (sorted.size() > 1 && std::isfinite(sorted[1].g)) inner = sorted[1];
  return {sorted.front(), inner};
}

// Elasticity near x: the slope to the nearest finite point on the other side of the root (the
// nearest finite point when there is none).
double elasticity_near(const std::vector<LogKPoint>& pts, const LogKPoint& p) {
  std::optional<LogKPoint> across, any;
  for (const LogKPoint& q : pts) {
    if (!std::isfinite(q.g) || q.x == p.x) continue;
    if (!any || std::abs(q.x - p.x) < std::abs(any->x - p.x)) any = q;
    if (q.g * p.g <= 0 && (!across || std::abs(q.x - p.x) < std::abs(across->x - p.x))) across = q;
  }
  const std::optional<LogKPoint>& n = across ? across : any;
  return n ? (p.g - n->g) / (p.x - n->x) : std::numeric_limits<double>::quiet_NaN();
}

std::string k_of(double x) { return fmt("%.4g", std::exp(x)); }
}  // namespace

std::optional<double> TwinModel::wear_log_error(double x, WearSearch& search, KUpdate& u) {
  const std::optional<WearTrial> t = wear_trial(std::exp(x), search, u);
  if (t) return t->log_error;
  if (!search.depth_limited) return std::nullopt;   // the simulation failed: the search stops with its reason
  // The depth limit passed before the record: K is too large, a bracket's upper end.
  search.why.clear();
  u.outcome = UpdateOutcome::iteration_limit;
  return std::numeric_limits<double>::infinity();
}

void TwinModel::update_k_wear_root_find(WearSearch& search, KUpdate& u) {
  // The sensitivity read: one re-run at the step Eq. 7.13 would take (at least 5 % in K, so the
  // difference is not the blue loop's step-size noise); it is also the first candidate.
  const double lo = std::log(settings_.k_wear_min_si), hi = std::log(settings_.k_wear_max_si);
  const double x0 = std::log(std::max(search.k0, settings_.k_wear_min_si));
  const double g0 = std::log(search.sim0 / search.measured);
  const double h = std::abs(g0) < 0.05 ? std::copysign(0.05, -g0) : -g0;
  const double x1 = std::clamp(x0 + h, lo, hi);
  if (std::abs(x1 - x0) < 1e-12) {
    u.outcome = UpdateOutcome::bound_reached;
    search.why = "K_wear at its bound " + k_of(x0);
    return;
  }
  std::vector<LogKPoint> pts{{x0, g0}};
  const std::optional<double> g1 = wear_log_error(x1, search, u);
  if (!g1) return;
  pts.push_back({x1, *g1});
  if (std::isfinite(*g1)) u.elasticity = (*g1 - g0) / (x1 - x0);
  u.outcome = UpdateOutcome::iteration_limit;
  if (std::abs(std::expm1(*g1)) <= settings_.convergence_tolerance) {
    LogKPoint root = pts.back();
    if (seek_first_crossing(pts, root, search, u)) finish_root(root, pts, search, u);
    return;
  }
  // The first direction is where the read brought RMS_SA closer; the other is tried when that one
  // ends at a bound (RMS_SA need not be monotone in K: early in life it dips before it rises).
  const int toward = std::abs(*g1) < std::abs(g0) ? (x1 > x0 ? 1 : -1) : (x1 > x0 ? -1 : 1);
  std::optional<LogKPoint> converged;
  if (!bracket_of(pts) && !expand_bracket(pts, toward, search, u, converged)) return;
  if (!converged && !refine_bracket(pts, search, u, converged)) return;
  LogKPoint root = *converged;
  if (seek_first_crossing(pts, root, search, u)) finish_root(root, pts, search, u);
}

bool TwinModel::seek_first_crossing(std::vector<LogKPoint>& pts, LogKPoint& root, WearSearch& search, KUpdate& u) {
  // RMS_SA need not be monotone in the wear: it may fall as the profile wears, pass a minimum and
  // rise, so one measurement can meet it at two K. The wear only grows from the anchor, and the
  // twin at the anchor's state (the range's lower end) is where RMS_SA starts: the first K along
  // that path that meets the measurement needs the least wear, and a larger one assumes the pair
  // passed the minimum and came back to the same level between two records, which nothing in
  // the record says. The lower end on the other side of the measurement than the K just below
  // the root proves a crossing below it (continuity).
  const double lo = std::log(settings_.k_wear_min_si);
  std::optional<LogKPoint> below, at_lo;
  for (const LogKPoint& p : pts) {
    if (!std::isfinite(p.g) || p.x >= root.x) continue;
    if (!below || p.x > below->x) below = p;
    if (std::abs(p.x - lo) < 1e-12) at_lo = p;
  }
  if (!below || std::abs(root.x - lo) < 1e-12) return true;
  if (!at_lo) {
    std::optional<LogKPoint> converged;
    const PointResult r = evaluate_point(lo, pts, search, u, converged);
    if (r == PointResult::failed) return false;
    at_lo = pts.back();
  }
  if ((at_lo->g > 0) == (below->g > 0)) return true;   // no sign change below the root: it is the first
  std::vector<LogKPoint> lower;
  for (const LogKPoint& p : pts)
    if (p.x <= below->x) lower.push_back(p);
  std::optional<LogKPoint> converged;
  if (std::abs(std::expm1(at_lo->g)) <= settings_.convergence_tolerance) converged = *at_lo;
  const std::size_t known = lower.size();
  const bool found = converged || refine_bracket(lower, search, u, converged);
  pts.insert(pts.end(), lower.begin() + static_cast<std::ptrdiff_t>(known), lower.end());
  if (!found) return false;
  const double upper = root.x;
  root = *converged;
  for (const WearTrial& t : search.trials)
    if (std::abs(std::log(t.k) - root.x) < 1e-9) search.best = t;
  search.why += std::string(search.why.empty() ? "" : "; ") + "RMS_SA meets the measurement at K_wear " + k_of(root.x) + " and " +
                k_of(upper) + " m^2/N: the first crossing along the wear path from the anchor, the smaller, is taken";
  return true;
}

bool TwinModel::expand_bracket(std::vector<LogKPoint>& pts, int dir, WearSearch& search, KUpdate& u,
                               std::optional<LogKPoint>& converged) {
  // Steps of one decade doubling each time (1, 2, 4, 8 decades: the whole configured range within
  // a few re-runs), shorter where the secant through the outermost two points predicts the root.
  const double lo = std::log(settings_.k_wear_min_si), hi = std::log(settings_.k_wear_max_si);
  bool exhausted[2] = {false, false};
  double step = std::log(10.0);
  while (!bracket_of(pts)) {
    if (search.evaluations >= settings_.max_wear_iterations) {
      search.why = "no K_wear tried crossed the measurement in " + std::to_string(settings_.max_wear_iterations) +
                   " twin re-runs (iteration limit; tried K_wear " + k_of(outermost(pts, -1).first.x) + " to " +
                   k_of(outermost(pts, 1).first.x) + " m^2/N)";
      return false;
    }
    const auto [end, inner] = outermost(pts, dir);
    double x = end.x + dir * step;
    if (inner && std::isfinite(end.g) && end.g != inner->g) {
      const double towards_root = -end.g * (end.x - inner->x) / (end.g - inner->g) * dir;   // secant distance along dir
      if (towards_root > 0) x = end.x + dir * std::min(step, towards_root);
    }
    x = std::clamp(x, lo, hi);
    if (!std::isfinite(end.g) || std::abs(x - end.x) < 1e-12) {
      exhausted[dir > 0] = true;
      if (exhausted[dir < 0]) break;
      dir = -dir;
      step = std::log(10.0);
      continue;
    }
    const PointResult r = evaluate_point(x, pts, search, u, converged);
    if (r != PointResult::open) return r == PointResult::converged;
    step *= 2;
  }
  if (bracket_of(pts)) return true;
  if (refuse_flat(pts, search, u)) return false;
  u.outcome = UpdateOutcome::bound_reached;
  search.why = "no K_wear from " + k_of(outermost(pts, -1).first.x) + " to " + k_of(outermost(pts, 1).first.x) +
               " m^2/N reaches the measurement (bound: the configured K_wear range";
  search.why += std::isfinite(outermost(pts, 1).first.g) ? ")" : ", or a flank past the depth limit before the record)";
  return false;
}

TwinModel::PointResult TwinModel::evaluate_point(double x, std::vector<LogKPoint>& pts, WearSearch& search, KUpdate& u,
                                                 std::optional<LogKPoint>& converged) {
  const std::optional<double> g = wear_log_error(x, search, u);
  if (!g) return PointResult::failed;
  pts.push_back({x, *g});
  if (std::abs(std::expm1(*g)) > settings_.convergence_tolerance) return PointResult::open;
  converged = pts.back();
  return PointResult::converged;
}

bool TwinModel::refuse_flat(const std::vector<LogKPoint>& pts, WearSearch& search, KUpdate& u) const {
  double spread = 0;   // how far RMS_SA moved over the whole range tried
  for (const LogKPoint& p : pts)
    if (std::isfinite(p.g)) spread = std::max(spread, std::abs(p.g - pts.front().g));
  if (spread >= settings_.min_wear_elasticity * std::log(10.0)) return false;
  u.outcome = UpdateOutcome::insensitive;
  search.why = "RMS_SA moves by at most " + fmt("%.3g", 100 * std::expm1(spread)) + " % for K_wear from " +
               k_of(outermost(pts, -1).first.x) + " to " + k_of(outermost(pts, 1).first.x) +
               " m^2/N: it does not follow K_wear, so K_wear is left as it was";
  return true;
}

bool TwinModel::refine_bracket(std::vector<LogKPoint>& pts, WearSearch& search, KUpdate& u, std::optional<LogKPoint>& converged) {
  // Illinois (regula falsi that halves the weight of an end kept twice): superlinear, and the root
  // never leaves the bracket. Bisection while an end is past the depth limit (no value to interpolate).
  auto [a, b] = *bracket_of(pts);   // a.g < 0 < b.g
  int kept_end = 0;                 // −1: a kept last step, +1: b kept
  double wa = 1, wb = 1;            // Illinois weights of the kept ends
  while (search.evaluations < settings_.max_wear_iterations) {
    if (std::isfinite(a.g) && std::isfinite(b.g) && std::abs(b.x - a.x) <= std::log(10.0) &&
        std::abs((b.g - a.g) / (b.x - a.x)) < settings_.min_wear_elasticity) {
      u.outcome = UpdateOutcome::insensitive;
      search.why = "RMS_SA crosses the measurement between K_wear " + k_of(std::min(a.x, b.x)) + " and " +
                   k_of(std::max(a.x, b.x)) + " m^2/N with elasticity " + fmt("%.3g", (b.g - a.g) / (b.x - a.x)) +
                   ", below " + fmt("%.3g", settings_.min_wear_elasticity) + ": a mismatch within the " +
                   fmt("%.3g", 100 * settings_.rms_threshold) + " % threshold would move K_wear by a decade, so K_wear is left as it was";
      return false;
    }
    double x = 0.5 * (a.x + b.x);
    if (std::isfinite(b.g)) x = (a.x * wb * b.g - b.x * wa * a.g) / (wb * b.g - wa * a.g);
    if (std::abs(b.x - a.x) < 1e-9) break;
    const PointResult r = evaluate_point(x, pts, search, u, converged);
    if (r != PointResult::open) return r == PointResult::converged;
    if (pts.back().g < 0) {
      a = pts.back();
      wa = 1;
      wb = kept_end == 1 ? 0.5 * wb : 1;
      kept_end = 1;
    } else {
      b = pts.back();
      wb = 1;
      wa = kept_end == -1 ? 0.5 * wa : 1;
      kept_end = -1;
    }
  }
  // A bracket whose upper end is only the depth limit, over which RMS_SA never moved: no root.
  if (!std::isfinite(b.g) && refuse_flat(pts, search, u)) return false;
  search.why = std::abs(b.x - a.x) < 1e-9
                   ? "RMS_SA jumps across the measurement at K_wear " + k_of(a.x) + " m^2/N (no K within the tolerance)"
                   : "no convergence to " + fmt("%.3g", 100 * settings_.convergence_tolerance) + " % in " +
                         std::to_string(settings_.max_wear_iterations) + " twin re-runs (iteration limit; the root lies between K_wear " +
                         k_of(std::min(a.x, b.x)) + " and " + k_of(std::max(a.x, b.x)) + " m^2/N)";
  if (std::abs(b.x - a.x) < 1e-9) u.outcome = UpdateOutcome::not_monotone;
  return false;
}

void TwinModel::finish_root(const LogKPoint& root, const std::vector<LogKPoint>& pts, WearSearch& search, KUpdate& u) {
  // Identified only where RMS_SA follows K_wear at the root itself: the start's flatness says
  // nothing about the root four decades away, the root's does.
  const double e = elasticity_near(pts, root);
  search.root_elasticity = e;
  if (std::isfinite(e) && std::abs(e) < settings_.min_wear_elasticity) {
    u.outcome = UpdateOutcome::insensitive;
    search.why = "RMS_SA reaches the measurement at K_wear " + k_of(root.x) + " m^2/N but follows K_wear there with elasticity " +
                 fmt("%.3g", e) + ", below " + fmt("%.3g", settings_.min_wear_elasticity) + ": a mismatch within the " +
                 fmt("%.3g", 100 * settings_.rms_threshold) + " % threshold would move K_wear by more than a decade, so K_wear is left as it was";
    return;
  }
  u.outcome = UpdateOutcome::converged;
}

namespace {
// The knee's bisection stops when the bracket on ln K is this narrow: a tenth of a neper (about
// 10 % in K), far below the decades that separate a knee from the range's guard.
constexpr double kKneeLogTolerance = 0.1;
}  // namespace

bool TwinModel::knee_applies(const WearSearch& search, const KUpdate& u, double simulated) const {
  // Only a record that asks for less wear than the current K gives: the twin above the measurement.
  if (!search.best || !(simulated > search.measured)) return false;
  const double target = search.measured;
  if (std::abs(search.best->sim - target) / target > settings_.rms_threshold) return false;   // a model-form miss, no bound
  if (u.outcome == UpdateOutcome::insensitive) return !search.points.empty();
  return u.outcome == UpdateOutcome::bound_reached && search.best->k <= settings_.k_wear_min_si * (1 + 1e-9);
}

std::optional<TwinModel::KneeReading> TwinModel::read_knee(WearSearch& search, KUpdate& u, std::string& no_knee) {
  // The reference: the measurement, or where the twin cannot come down to it, the closest RMS_SA
  // it gives (its flat part's level). A K whose RMS_SA passes it by more than the convergence
  // tolerance gives more wear than the record shows.
  const double reference = std::max(search.measured, search.best->sim);
  const double level = std::log(reference * (1 + settings_.convergence_tolerance) / search.measured);
  auto matches = [level](const LogKPoint& p) { return std::isfinite(p.g) && p.g <= level; };
  std::optional<LogKPoint> a, b;
  for (const LogKPoint& p : search.points)
    if (matches(p) && (!a || p.x > a->x)) a = p;
  if (a)
    for (const LogKPoint& p : search.points)
      if (!matches(p) && p.x > a->x && (!b || p.x < b->x)) b = p;
  if (!a || !b) {
    no_knee = "no K_wear tried leaves the twin's flat part: no knee to bound K_wear";
    return std::nullopt;
  }
  // Bisection on ln K between the last matching and the first leaving point (the trials restore
  // the search's outcome and reason: they are not the search's).
  const UpdateOutcome outcome = u.outcome;
  const std::string why = search.why;
  const int before = search.evaluations;
  while (b->x - a->x > kKneeLogTolerance && search.evaluations < settings_.max_wear_iterations) {
    const double k = std::exp(0.5 * (a->x + b->x));
    const std::optional<WearTrial> t = wear_trial(k, search, u);
    if (!t && !search.depth_limited) break;   // the twin gave no value: the bracket as it is
    const LogKPoint p{std::log(k), t ? t->log_error : std::numeric_limits<double>::infinity()};
    (matches(p) ? a : b) = p;
  }
  u.outcome = outcome;
  search.why = why;
  search.depth_limited = false;
  if (a->x - std::log(settings_.k_wear_min_si) < kKneeLogTolerance) {
    no_knee = "the twin's RMS_SA leaves " + fmt("%.5g", reference) + " by " + fmt("%.3g", 100 * settings_.convergence_tolerance) +
              " % within " + fmt("%.2g", kKneeLogTolerance) + " in ln K of the range's lower end: no knee above the range's guard";
    return std::nullopt;
  }
  const auto trial = std::find_if(search.trials.begin(), search.trials.end(), [&](const WearTrial& t) { return std::log(t.k) == a->x; });
  if (trial == search.trials.end()) {
    no_knee = "the knee's trial was not kept";
    return std::nullopt;
  }
  return KneeReading{*trial, *b, reference, search.evaluations - before};
}

void TwinModel::apply_k_wear_bound(KneeReading& knee, WearSearch& search, KUpdate& u, double simulated, ModelRunReport& report) {
  const double bound = knee.match.k;
  const double identified = search.saved.k_wear_identified_si > 0 ? search.saved.k_wear_identified_si : search.saved.k_wear_si;
  u.outcome = UpdateOutcome::upper_bound;
  std::string text = "the measurement lies on the twin's flat part: its RMS_SA stays within " +
                     fmt("%.3g", 100 * settings_.convergence_tolerance) + " % of " + fmt("%.5g", knee.reference) + " up to K_wear " +
                     fmt("%.4g", bound) + " m^2/N and leaves it by " + k_of(knee.rejected.x) + " m^2/N (" +
                     std::to_string(knee.reruns) + " bisection re-run(s)): K_wear <= " + fmt("%.4g", bound) + " m^2/N (upper bound)";
  std::optional<WearTrial> chosen;
  if (identified < bound) {
    // The estimate lies within the bound: it stays (re-run only when a bound had replaced it).
    text += "; the last identified K_wear " + fmt("%.4g", identified) + " m^2/N lies below it and stays";
    if (identified != search.saved.k_wear_si) {
      const std::string why = search.why;
      chosen = wear_trial(identified, search, u);
      u.outcome = UpdateOutcome::upper_bound;
      search.why = why;
      if (!chosen) text += " (its re-run failed: K_wear left as it was)";
    }
  } else {
    text += "; the last identified K_wear " + fmt("%.4g", identified) + " m^2/N lies above it: K_wear set to the bound";
    chosen = knee.match;
  }
  u.iterations = search.evaluations;
  search.why += (search.why.empty() ? "" : "; ") + text;
  if (!chosen) {
    memory_ = search.saved;
    u.new_value = u.old_value;
    u.simulated_after = simulated;
    return;
  }
  memory_ = std::move(chosen->memory);
  memory_.current = chosen->state;
  apply_k(true, chosen->k, search.anchor.state.cycles);
  memory_.wear_anchor = memory_.current;
  loop_ = loop_at(memory_.current);
  ++memory_.k_wear_updates;
  u.new_value = chosen->k;
  u.simulated_after = chosen->sim;
  report.rms_sa_simulated = chosen->sim;
}

void TwinModel::read_depth_inspections(const std::vector<Inspection>& inspections, double prev_cycles, double prev_mean,
                                       ModelRunReport& report) {
  const double now = memory_.current.state.cycles, now_mean = summarise(memory_.current.state).combined_mean_depth_m;
  auto& points = memory_.depth_ratio_points;
  for (const Inspection& i : inspections) {
    if (!i.wear_depth_m || i.cycles > now) continue;   // no depth, or after the record: it waits
    if (std::any_of(points.begin(), points.end(), [&](const DepthRatioMeasurement& m) { return m.inspection_id == i.id; })) continue;
    const double model = model_mean_at(i.cycles, prev_cycles, prev_mean, now, now_mean);
    if (!(*i.wear_depth_m > 0) || !std::isfinite(*i.wear_depth_m) || !(model > 0)) {
      // Never a reading: a depth of 0 (or a model without wear there) gives no ratio.
      note_unused_inspection(report, i.id, ": wear depth not used for the depth calibration (measured or model depth not positive)");
      continue;
    }
    points.push_back(depth_ratio_measurement(i.id, i.cycles, *i.wear_depth_m, model, inspection_depth_sd(i)));
  }
  read_peak_inspections(inspections, prev_cycles, now, report);
}

void TwinModel::read_peak_inspections(const std::vector<Inspection>& inspections, double since, double now, ModelRunReport& report) {
  auto& peaks = memory_.peak_ratio_points;
  peaks.clear();
  for (const Inspection& i : inspections) {
    if (!i.wear_depth_max_m || i.cycles > now) continue;
    const bool usable = i.wear_depth_m && *i.wear_depth_m > 0 && std::isfinite(*i.wear_depth_m) && *i.wear_depth_max_m > 0 &&
                        std::isfinite(*i.wear_depth_max_m);
    if (!usable) {
      // The deepest point is read against the same mould's mean: without both there is no ratio.
      // Said once: at the first record at or after the inspection.
      if (i.cycles > since)
        note_unused_inspection(report, i.id, ": deepest wear point not used (it needs a positive mean wear depth from the same inspection)");
      continue;
    }
    peaks.push_back(peak_ratio_measurement(i.id, i.cycles, *i.wear_depth_max_m, *i.wear_depth_m, inspection_depth_sd(i)));
  }
}

double TwinModel::inspection_depth_sd(const Inspection& i) const {
  const bool own = i.wear_depth_relative_sd && std::isfinite(*i.wear_depth_relative_sd) && *i.wear_depth_relative_sd > 0 &&
                   *i.wear_depth_relative_sd < 1;
  return own ? *i.wear_depth_relative_sd : settings_.inspection_depth_relative_sd;
}

LogPosterior TwinModel::peak_ratio_now(double model_peak) const {
  if (memory_.peak_ratio_points.empty() || !(model_peak > 0)) return {};
  // The prior spans the profile-shape term's range: the model's own peak ratio to the
  // concentrated shape's (profile_shape.hpp).
  const LogPosterior prior = peak_ratio_prior(model_peak, memory_.shape_peak_ratio, kNominalCoverage, settings_.prior_log_k_wear_sd);
  return depth_ratio_posterior(prior, memory_.peak_ratio_points, settings_.log_k_q_per_cycle(), memory_.current.state.cycles,
                               settings_.innovation_gate_sd);
}

LogPosterior TwinModel::depth_ratio_prior() const {
  // The shape range the depth interval spans without inspections (profile_shape.hpp); without a
  // shape reading the depth is as unknown as K_wear (depth ∝ K along a path).
  const double log_sd = rms_scatter_sd() / std::max(std::abs(memory_.shape_depth_elasticity), settings_.min_wear_elasticity);
  return shape_range_prior(memory_.shape_depth_ratio, log_sd, kNominalCoverage, settings_.prior_log_k_wear_sd);
}

LogPosterior TwinModel::depth_ratio_now() const {
  if (memory_.depth_ratio_points.empty()) return {};
  // The prior is the shape range, a range and not a distribution of the truth: an inspection far
  // outside it widens it by the innovation rule (depth_ratio_posterior's gate) instead of being
  // pulled back toward the model's RMS_SA-derived depth.
  return depth_ratio_posterior(depth_ratio_prior(), memory_.depth_ratio_points, settings_.log_k_q_per_cycle(), memory_.current.state.cycles,
                               settings_.innovation_gate_sd);
}

namespace {
// The model's K_wear stretches, as cycle_mean_k reads them: the history from the pair's start; a
// state stored before it has only the intervals since the older anchor.
std::vector<KStretch> k_wear_stretches(const ModelMemory& memory) {
  if (!memory.k_wear_history.empty()) return memory.k_wear_history;
  std::vector<KStretch> stretches;
  for (const LifeInterval& in : memory.intervals) stretches.push_back({in.end_cycles, in.k_wear_si});
  return stretches;
}

// The level's posterior at `at` and the rate reading share the two inspections' errors: the
// covariance is Σ (the level's weight on z_i) var_i (∂κ/∂z_i).
double level_rate_covariance(const LogPosterior& prior, const std::vector<DepthRatioMeasurement>& points, double q,
                             double at, const RateReading& rate, double gate_sd) {
  double cov = 0;
  for (const DepthRatioMeasurement& m : points) {
    const double dk = m.inspection_id == rate.to_id ? rate.dk_dz_to : m.inspection_id == rate.from_id ? rate.dk_dz_from : 0.0;
    if (dk != 0.0) cov += posterior_weight(prior, points, q, at, m.inspection_id, gate_sd) * m.var * dk;
  }
  return cov;
}
}  // namespace

RateReading TwinModel::wear_rate_reading() const {
  const RateReading r = newest_rate_reading(memory_.depth_ratio_points);
  if (!r.valid) return r;
  // The readings are on the model's current path, whose increments between them ran at the K_wear
  // of their stretches; the forecast runs at today's: read against today's pace (a later K_wear
  // whose re-run started after the inspections would otherwise be counted twice, once in the
  // path's new pace, once in the ratio read against the old).
  const std::vector<KStretch> stretches = k_wear_stretches(memory_);
  return rate_at_pace(r, cycle_mean_k(stretches, r.from_cycles, r.to_cycles), memory_.k_wear_si);
}

CarriedDepth TwinModel::carried_depth_now() const {
  const auto& points = memory_.depth_ratio_points;
  const RateReading raw = newest_rate_reading(points);
  const double now = memory_.current.state.cycles;
  if (!raw.valid || !(now > raw.to_cycles)) return {};
  const auto b = std::find_if(points.begin(), points.end(), [&](const DepthRatioMeasurement& m) { return m.inspection_id == raw.to_id; });
  if (b == points.end()) return {};
  // Between b and now the model's path ran at its stretches' K_wear there; the reading is against
  // the path's pace between the two inspections (Archard's increment ∝ K).
  const std::vector<KStretch> stretches = k_wear_stretches(memory_);
  const RateReading y = rate_at_pace(raw, cycle_mean_k(stretches, raw.from_cycles, raw.to_cycles), cycle_mean_k(stretches, b->cycles, now));
  const LogPosterior prior = depth_ratio_prior();
  const double q = settings_.log_k_q_per_cycle();
  const double gate = settings_.innovation_gate_sd;
  const LogPosterior x_b = depth_ratio_posterior(prior, points, q, b->cycles, gate);
  const double cov = level_rate_covariance(prior, points, q, b->cycles, raw, gate);
  // The rate walks as ln K does from the newest inspection on (the level's own walk, docs/model.md).
  return rate_carried_depth(b->model_m, x_b.mean, x_b.var, y.log_mean, y.var, cov, q * (now - b->cycles),
                            summarise(memory_.current.state).combined_mean_depth_m, kNominalCoverage);
}

std::optional<LevelRate> TwinModel::level_and_rate(const LogPosterior& p, const LogPosterior& peak, double model_peak,
                                                   RateReading& rate) const {
  const auto& points = memory_.depth_ratio_points;
  rate = wear_rate_reading();
  if (!rate.valid) return std::nullopt;
  const LogPosterior prior = depth_ratio_prior();
  const double q = settings_.log_k_q_per_cycle(), now = memory_.current.state.cycles;
  const double cov = level_rate_covariance(prior, points, q, now, rate, settings_.innovation_gate_sd);
  // The level stays ρ's on the model's path, not the depth carried by the rate: a rate read over a
  // short baseline between two inspections would then move every crossing with its noise.
  LevelRate j{p.mean, p.var, rate.log_mean, rate.var, cov};
  if (peak.valid) {
    // The deepest point: the truth's is ρ P times the model's mean, its increments ρ_rate P times
    // the model's mean increments; both over the model's own deepest / mean. P is shared.
    const double shift = peak.mean - std::log(model_peak);
    j = {j.x_mean + shift, j.x_var + peak.var, j.y_mean + shift, j.y_var + peak.var, j.cov + peak.var};
  }
  return j;
}

bool TwinModel::wear_crossings_by_rate(Forecast& f, const LogPosterior& p, const LogPosterior& peak, double model_peak,
                                       const WearLoopOptions& deep) const {
  RateReading rate;
  const std::optional<LevelRate> j = level_and_rate(p, peak, model_peak, rate);
  if (!j) return false;
  // The model's path paces the wear from now on, its increments scaled by the rate read from the
  // inspections, its level now the calibrated one: the truth crosses where the model's deepest
  // point reaches T (truth_crossing_threshold). The rate reading measures the model's increments
  // against the truth's, so K_wear's own uncertainty is in it: the path keeps today's K_wear.
  const double d_now = max_depth(memory_.current.state), limit = settings_.wear_limit_m, tail = (1.0 - kNominalCoverage) / 2.0;
  // Each threshold is a quantile found by bisection over a numerical integral: computed once.
  const double t_mid = truth_crossing_threshold(*j, d_now, limit, 0.5), t_low = truth_crossing_threshold(*j, d_now, limit, tail),
               t_high = truth_crossing_threshold(*j, d_now, limit, 1.0 - tail);
  auto crossing = [&](double kp, double threshold) {
    return run_forecast(memory_.current, memory_.k_wear_si, kp, deep, nullptr, threshold).wear;
  };
  f.wear.cycles_left = crossing(memory_.k_pitting, t_mid);
  f.wear.cycles_left_low = crossing(f.k_pitting_high, t_low);
  f.wear.cycles_left_high = crossing(f.k_pitting_low, t_high);
  char b[400];
  std::snprintf(b, sizeof b, "wear rate: inspections %lld and %lld (%.4g to %.4g cycles) grew %.4g times the model's depth increment (ln SD %.3g, covariance with the level %.3g): wear crossings where the model's deepest point reaches %.4g um (ends %.4g to %.4g um)",
                static_cast<long long>(rate.from_id), static_cast<long long>(rate.to_id), rate.from_cycles, rate.to_cycles,
                std::exp(rate.log_mean), std::sqrt(rate.var), j->cov, 1e6 * t_mid, 1e6 * t_low, 1e6 * t_high);
  f.evidence += (f.evidence.empty() ? "" : "; ") + std::string(b);
  return true;
}

bool TwinModel::apply_depth_calibration(Forecast& f, const WearLoopOptions& o) const {
  const LogPosterior p = depth_ratio_now();
  if (!p.valid) return false;
  const WearState& now = memory_.current.state;
  const double mean = summarise(now).combined_mean_depth_m;
  const CalibratedDepth d = calibrated_depth(mean, p, kNominalCoverage);
  f.depth_mean_m = d.estimate_m;
  f.depth_low_m = d.low_m;
  f.depth_high_m = d.high_m;
  f.depth_inspections = static_cast<int>(memory_.depth_ratio_points.size());
  f.depth_ratio = d.ratio;
  f.depth_ratio_log_sd = std::sqrt(p.var);
  // Two inspected depths read the rate: past the newest the depth is carried from it by that rate,
  // not held at ρ on the model's path (which paces the truth only where their rates agree).
  const CarriedDepth carried = mean > 0 ? carried_depth_now() : CarriedDepth{};
  if (carried.valid) {
    f.depth_mean_m = carried.estimate_m;
    f.depth_low_m = carried.low_m;
    f.depth_high_m = carried.high_m;
    f.depth_ratio = carried.estimate_m / mean;
    f.depth_ratio_log_sd = std::sqrt(carried.log_var);
  }
  // The inspection measures the mean; the deepest point over the mean is still the shape's: the
  // model's own now, and the concentrated shape's where it was read (the ends take the farther).
  const double model_peak = mean > 0 ? max_depth(now) / mean : 1.0;
  const double c = memory_.shape_peak_ratio > 0 && model_peak > 0 ? memory_.shape_peak_ratio / model_peak : 1.0;
  const double limit = settings_.wear_limit_m;
  // The model's path only paces the wear: it runs past its own depth limit when ρ is small, up to
  // a bound beyond which the crossing counts as past the horizon.
  WearLoopOptions deep = o;
  deep.depth_limit_m = std::max(o.depth_limit_m, 4.0 * limit);
  auto crossing = [&](double kw, double kp, double factor) {
    return run_forecast(memory_.current, kw, kp, deep, nullptr, limit / factor).wear;
  };
  const LogPosterior peak = peak_ratio_now(model_peak);
  if (peak.valid) {
    f.peak_inspections = static_cast<int>(memory_.peak_ratio_points.size());
    f.peak_ratio_log_mean = peak.mean;
    f.peak_ratio = std::exp(peak.mean);
    f.peak_ratio_log_sd = std::sqrt(peak.var);
  }
  // Two inspected depths read the rate; one reads the level only ("ρ constant along the path").
  const bool by_rate = wear_crossings_by_rate(f, p, peak, model_peak, deep);
  if (!by_rate && peak.valid) {
    // Inspected profiles: the deepest point is ρ P times the model's mean, i.e. the model's deepest
    // times ρ P / its own peak ratio (held at today's along the path).
    const DeepestFactor k = deepest_point_factor(p, peak, model_peak, kNominalCoverage);
    f.wear.cycles_left = crossing(memory_.k_wear_si, memory_.k_pitting, k.nominal);
    f.wear.cycles_left_low = crossing(f.k_wear_high, f.k_pitting_high, k.high);
    f.wear.cycles_left_high = crossing(f.k_wear_low, f.k_pitting_low, k.low);
  } else if (!by_rate) {
    f.wear.cycles_left = crossing(memory_.k_wear_si, memory_.k_pitting, d.ratio);
    f.wear.cycles_left_low = crossing(f.k_wear_high, f.k_pitting_high, d.ratio_high * std::max(1.0, c));
    f.wear.cycles_left_high = crossing(f.k_wear_low, f.k_pitting_low, d.ratio_low * std::min(1.0, c));
  }
  char b[480];
  std::snprintf(b, sizeof b, "depth calibration: %zu inspected wear depths give rho %.4g (ln SD %.3g; prior from the shape range, rho_s %.3g): depth %.4g um, interval %.4g to %.4g um%s%s (ends: deepest point x %.3g of the model's shape)",
                memory_.depth_ratio_points.size(), f.depth_ratio, f.depth_ratio_log_sd, memory_.shape_depth_ratio, 1e6 * f.depth_mean_m,
                1e6 * f.depth_low_m, 1e6 * f.depth_high_m, carried.valid ? ", carried from the newest inspection by the rate" : "",
                by_rate ? "" : "; wear crossings at limit / rho", c);
  f.evidence += (f.evidence.empty() ? "" : "; ") + std::string(b);
  if (peak.valid) {
    std::snprintf(b, sizeof b, "%zu inspected deepest points give deepest / mean %.3g (ln SD %.3g; the model's %.3g): wear crossings at limit / (rho x that / the model's)",
                  memory_.peak_ratio_points.size(), f.peak_ratio, f.peak_ratio_log_sd, model_peak);
    f.evidence += "; " + std::string(b);
  }
  return true;
}

void TwinModel::calibrate_pitting(const std::vector<Inspection>& inspections, double cycles, ModelRunReport& report) {
  std::vector<Inspection> pitted;
  for (const Inspection& i : inspections)
    if (i.pitted_area && std::isfinite(*i.pitted_area) && *i.pitted_area >= 0 && *i.pitted_area <= 1 && std::isfinite(i.cycles) &&
        i.cycles >= 0 && i.cycles <= cycles)
      pitted.push_back(i);
  std::sort(pitted.begin(), pitted.end(), [](const Inspection& a, const Inspection& b) {
    return a.cycles != b.cycles ? a.cycles < b.cycles : a.id < b.id;
  });
  if (pitted.empty()) return;
  // The two newest inspections at distinct cycles.
  const Inspection second = pitted.back();
  std::optional<Inspection> first;
  for (auto it = pitted.rbegin() + 1; it != pitted.rend(); ++it)
    if (it->cycles < second.cycles) {
      first = *it;
      break;
    }
  if (!first) {
    if (!memory_.pitting_calibrated) calibrate_from_one_inspection(second, cycles, report);
    return;
  }
  const std::int64_t key = std::max(first->id, second.id);
  if (memory_.pitting_calibrated && key <= memory_.calibration_inspection_id) return;

  const CalibrationPoints c{first->cycles, *first->pitted_area, second.cycles, *second.pitted_area};
  KUpdate u;
  u.kind = UpdateKind::k_pitting;
  u.trigger = UpdateTrigger::inspection_calibration;
  u.cycles = cycles;
  u.old_value = memory_.k_pitting;
  u.applies_from_cycles = cycles;
  u.measured = c.a1;
  std::string why;
  int evaluations = 0;
  const double k_new = calibrate_k(c, cycles, u, why, evaluations);
  memory_.pitting_calibrated = true;
  memory_.calibration_inspection_id = key;
  const double i0 = ics2_at(c.n0), i1 = ics2_at(c.n1);
  memory_.pitting_points.clear();
  const bool scale = std::isfinite(i0) && std::isfinite(i1) && i1 > i0 && c.a1 > c.a0;
  if (std::isfinite(i0) && std::isfinite(i1)) memory_.pitting_points = {{c.n0, i0, c.a0}, {c.n1, i1, c.a1}};
  if (scale) {
    memory_.ics2_scale_valid = true;
    memory_.ics2_scale_inspections = 2;
    memory_.ics2_scale_ics2 = i0;
    memory_.ics2_scale_density = c.a0;
    memory_.ics2_scale_slope = (c.a1 - c.a0) / (i1 - i0);
    memory_.ics2_scale_form = Ics2ScaleForm::linear;
    memory_.ics2_scale_baseline = 0;
    memory_.ics2_scale_density_1 = c.a1;
    memory_.ics2_scale_baseline_sd = 0;
  } else {
    // A one-inspection scale, if any, stays: it is the only ICS2 reading of the density.
    if (!why.empty()) why += "; ";
    why += "no ICS2 <-> density scale (ICS2 " + fmt("%.4g", i0) + " at the first inspection, " + fmt("%.4g", i1) +
           " at the second: it must rise)";
  }
  u.new_value = k_new;
  u.iterations = evaluations;
  u.simulated_before = c.a0;
  u.correlation_before = i0;
  u.correlation_after = i1;
  char b[400];
  std::snprintf(b, sizeof b, "inspections: pitted area %.4g at %.6g cycles, %.4g at %.6g cycles (ICS2 %.4g, %.4g); model %.4g at the second; K_pitting %.5g -> %.5g",
                c.a0, c.n0, c.a1, c.n1, i0, i1, u.simulated_after, u.old_value, u.new_value);
  u.evidence = b;
  u.evidence += " " + pitting_change_text(pitting_scale_, u.old_value, u.new_value);
  if (!why.empty()) u.evidence += "; " + why;
  // A K at the bracket's end (bound_reached) did not reproduce the inspections: no measurement of ln K.
  if (k_new > 0 && u.outcome == UpdateOutcome::converged && c.a1 > c.a0 && c.a1 < 1) {
    const double sd = settings_.inspection_area_relative_sd;
    memory_.pitting_calibration_var = calibration_log_variance(c.a0, c.a1, sd, sd, 0.0);
    u.evidence += learn(memory_.log_k_pitting, std::log(k_new), pitting_measurement_var(), cycles);
  }
  report.updates.push_back(std::move(u));
}

double TwinModel::calibrate_k(const CalibrationPoints& c, double cycles, KUpdate& u, std::string& why, int& evaluations) {
  const twin::OperatingPoint op{memory_.recent_operating_points.back()[0], memory_.recent_operating_points.back()[1]};
  // Eq. 7.11 accumulates from the start of the pair's life (absolute N), so a candidate K is run
  // from 0 cycles, unpitted, on the current worn profile (held: K_wear = 0 in calibration runs).
  // At N0 its pitting profile is rescaled to the inspected mean (shape from the model, level from
  // the inspection); N0 -> N1 then decides K: the model must pit A1 by the second point.
  LoopSnapshot start = memory_.current;
  start.state.cycles = 0;
  std::fill(start.state.pinion_pitting.begin(), start.state.pinion_pitting.end(), 0.0);
  start.next_step_cycles = settings_.loop.initial_step_cycles;
  auto run_to = [&](double k, double until, BlueLoop* keep) {
    BlueLoop loop = loop_at(start);
    loop.set_operating_point(op);
    loop.set_coefficients(0.0, k);
    loop.run_until(c.n0);
    WearState at_n0 = loop.state();
    const double m0 = mean_of(at_n0.pinion_pitting);
    for (double& d : at_n0.pinion_pitting) d = m0 > 0 ? std::min(1.0, d * c.a0 / m0) : c.a0;
    loop.restore(at_n0, loop.next_step_cycles());
    loop.run_until(until);
    ++evaluations;
    const double d = mean_of(loop.state().pinion_pitting);
    if (keep) *keep = std::move(loop);
    return d;
  };
  double k_new = 0;
  u.outcome = UpdateOutcome::converged;
  if (!(c.a1 > c.a0)) {
    u.outcome = UpdateOutcome::set_to_zero;
    why = "the inspections show no pitting growth (" + fmt("%.4g", c.a0) + " then " + fmt("%.4g", c.a1) + ")";
  } else {
    // The scale of K: the K at which the most loaded point reaches A N1^m = 1.
    BlueLoop probe = loop_at(start);
    probe.set_operating_point(op);
    const std::vector<double> unit = probe.pitting_rates(1.0);
    const double top = *std::max_element(unit.begin(), unit.end());
    if (!(top > 0) || !std::isfinite(top)) {
      u.outcome = UpdateOutcome::bound_reached;
      why = "no contact pressure to pit under";
    } else {
      const double k_scale = 1.0 / (top * std::pow(c.n1, settings_.loop.material.m));
      // Bisection on ln K between "no pitting" and the scale (raised while still short).
      double lo = std::log(k_scale) - 30.0, hi = std::log(k_scale);
      double d_hi = run_to(std::exp(hi), c.n1, nullptr);
      for (int up = 0; up < 3 && d_hi < c.a1; ++up) {
        hi += std::log(10.0);
        d_hi = run_to(std::exp(hi), c.n1, nullptr);
      }
      if (d_hi < c.a1) {
        u.outcome = UpdateOutcome::bound_reached;
        why = "the model cannot pit " + fmt("%.4g", c.a1) + " by the second point (at most " + fmt("%.4g", d_hi) + ")";
        k_new = std::exp(hi);
      } else {
        while (hi - lo > 1e-4 && evaluations < 80) {
          const double mid = 0.5 * (lo + hi);
          if (run_to(std::exp(mid), c.n1, nullptr) < c.a1) lo = mid;
          else hi = mid;
        }
        k_new = std::exp(0.5 * (lo + hi));
      }
    }
  }
  // The state: the calibrated run continued to now gives the current pitting profile.
  BlueLoop calibrated = loop_at(start);
  u.simulated_after = run_to(k_new, c.n1, &calibrated);
  calibrated.run_until(cycles);
  memory_.current.state.pinion_pitting = calibrated.state().pinion_pitting;
  loop_ = loop_at(memory_.current);
  memory_.current = LoopSnapshot{loop_.state(), loop_.next_step_cycles()};
  apply_k(false, k_new, cycles);
  // The pitting anchor moves here; the wear anchor only after this record's K_wear check, which
  // re-runs from the last K_wear anchor with this profile set at the record (hold_calibrated_pitting).
  memory_.pitting_anchor = memory_.current;
  calibrated_pitting_here_ = memory_.current.state.pinion_pitting;
  ++memory_.k_pitting_updates;
  return k_new;
}

void TwinModel::calibrate_from_one_inspection(const Inspection& first, double cycles, ModelRunReport& report) {
  const double n0 = first.cycles, a0 = *first.pitted_area;
  // The onset baseline: the pair's first ICS2 values, all before the inspection.
  std::vector<double> onset;
  for (const auto& p : memory_.ics2_series)
    if (p[0] < n0 && onset.size() < static_cast<std::size_t>(settings_.ics2_onset_records)) onset.push_back(p[1]);
  if (onset.size() < static_cast<std::size_t>(settings_.ics2_onset_records)) return;
  // 3 baseline SDs: a rise the baseline's own scatter gives in 0.13 % of records.
  const std::optional<Ics2Scale> scale = one_inspection_scale(onset, ics2_at(n0), a0, 3.0);
  if (!scale) return;
  memory_.ics2_scale_valid = true;
  memory_.ics2_scale_inspections = 1;
  memory_.ics2_scale_ics2 = scale->ics2;
  memory_.ics2_scale_density = scale->density;
  memory_.ics2_scale_slope = scale->slope;
  memory_.ics2_scale_form = scale->form;
  memory_.ics2_scale_baseline = scale->baseline;
  memory_.ics2_scale_baseline_sd = scale->baseline_sd;
  memory_.ics2_scale_density_1 = 0;
  // The second point: the median ICS2 of the newest three records after the inspection, once a
  // pitting interval after it (and after the last such calibration).
  const double spacing = settings_.pitting_interval_cycles;
  if (cycles < n0 + spacing || (memory_.last_ics2_calibration_cycles >= 0 && cycles < memory_.last_ics2_calibration_cycles + spacing))
    return;
  std::vector<std::array<double, 2>> newest;   // (ICS2, cycles)
  for (auto it = memory_.ics2_series.rbegin(); it != memory_.ics2_series.rend() && newest.size() < 3 && (*it)[0] > n0; ++it)
    newest.push_back({(*it)[1], (*it)[0]});
  if (newest.size() < 3) return;
  std::sort(newest.begin(), newest.end());
  const double n1 = newest[1][1];   // the point sits at the median record's cycles
  const std::array<double, 2> recent{newest[1][0], n1};
  const double a1 = scale->density_at(recent[0]);
  // The median of three normal values has an SD of about 1.16 of one (the sample median's small-n factor).
  const double ics2_rel_sd = a1 > 0 ? scale->density_noise(a1, 1.16 * scale->baseline_sd) / a1 : 0.0;
  const double sd = settings_.inspection_area_relative_sd;
  // Growth beyond what the ICS2 scatter gives: otherwise no second point.
  if (!(a1 > a0 * (1.0 + 2.0 * ics2_rel_sd)) || !(a1 < 1)) return;
  memory_.last_ics2_calibration_cycles = cycles;
  KUpdate u;
  u.kind = UpdateKind::k_pitting;
  u.trigger = UpdateTrigger::ics2_one_inspection;
  u.cycles = cycles;
  u.old_value = memory_.k_pitting;
  u.applies_from_cycles = cycles;
  u.measured = a1;
  std::string why;
  int evaluations = 0;
  const CalibrationPoints c{n0, a0, n1, a1};
  u.new_value = calibrate_k(c, cycles, u, why, evaluations);
  u.iterations = evaluations;
  u.simulated_before = a0;
  u.correlation_before = scale->baseline;
  u.correlation_after = recent[0];
  char b[500];
  std::snprintf(b, sizeof b, "one inspection: pitted area %.4g at %.6g cycles; ICS2 onset baseline %.4g (SD %.3g, median of the first %d), %.4g at the inspection; "
                "scale D = %.4g sqrt((ICS2 - %.4g) / (%.4g - %.4g)); median ICS2 of the newest three %.4g -> density %.4g at %.6g cycles; model %.4g there; K_pitting %.5g -> %.5g",
                a0, n0, scale->baseline, scale->baseline_sd, settings_.ics2_onset_records, scale->ics2, a0, scale->baseline, scale->ics2,
                scale->baseline, recent[0], a1, n1, u.simulated_after, u.old_value, u.new_value);
  u.evidence = b;
  u.evidence += " " + pitting_change_text(pitting_scale_, u.old_value, u.new_value);
  if (!why.empty()) u.evidence += "; " + why;
  if (u.new_value > 0 && u.outcome == UpdateOutcome::converged) {
    // A0 scales the ICS2 estimate too: its error is shared (correlation), the ICS2 scatter is not.
    const double sd1 = std::hypot(sd, ics2_rel_sd);
    memory_.pitting_calibration_var = calibration_log_variance(a0, a1, sd, sd1, sd / sd1);
    u.evidence += learn(memory_.log_k_pitting, std::log(u.new_value), pitting_measurement_var(), cycles);
  }
  report.updates.push_back(std::move(u));
}

bool TwinModel::pitting_point_due(const ModelObservation& obs) const {
  if (!memory_.pitting_calibrated || !obs.ics2_low || !std::isfinite(*obs.ics2_low)) return false;
  const auto& points = memory_.pitting_points;
  if (!points.empty() && obs.cycles < points.back().cycles + settings_.pitting_interval_cycles) return false;
  return obs.cycles > memory_.pitting_anchor.state.cycles;
}

void TwinModel::record_scale_residual(double ics2, double density_now) {
  if (!memory_.ics2_scale_valid) return;
  // The scale's scatter: the ICS2-derived density against the model's at each new point, in ln K.
  const double d_scale = ics2_scale().density_at(ics2);
  if (d_scale > 0 && d_scale < 1 && density_now > 0) {
    const double gap = log_k_gap(d_scale, density_now);
    memory_.scale_residual_sum_sq += gap * gap;
    ++memory_.scale_residual_count;
  }
}

void TwinModel::push_pitting_point(double cycles, double ics2, double density) {
  auto& points = memory_.pitting_points;
  points.push_back({cycles, ics2, density});
  if (points.size() > 3) points.erase(points.begin(), points.end() - 3);
  memory_.pitting_anchor = memory_.current;
}

double TwinModel::PittingTriple::correlation(double density_now) const {
  return pearson3({density[0], density[1], density_now}, ics2);
}

double TwinModel::pitting_density_with(const ModelMemory& saved, double k, int& evaluations, LoopSnapshot* out) {
  memory_ = saved;
  LoopSnapshot s;
  rerun(saved.pitting_anchor, Override{std::nullopt, k, saved.pitting_anchor.state.cycles}, s, false);
  ++evaluations;
  if (out) *out = s;
  return mean_of(s.state.pinion_pitting);
}

TwinModel::PittingSearch TwinModel::search_k_pitting(const ModelMemory& saved, const PittingTriple& triple) {
  // Eqs. 7.16–7.17: K_pitting maximising C, re-running from the last pitting point.
  PittingSearch s;
  double k_ref = memory_.k_pitting;
  for (auto it = memory_.recent_k_pitting.rbegin(); !(k_ref > 0) && it != memory_.recent_k_pitting.rend(); ++it) k_ref = *it;
  const double c_zero = triple.correlation(pitting_density_with(saved, 0.0, s.evaluations, nullptr));
  s.best_c = std::isfinite(c_zero) ? c_zero : -2.0;
  if (!(k_ref > 0)) return s;
  auto f = [&](double x) {
    const double c = triple.correlation(pitting_density_with(saved, std::exp(x), s.evaluations, nullptr));
    return std::isfinite(c) ? c : -2.0;
  };
  // Bracket the maximum on ln K: walk uphill from the current K by decades.
  const double step = std::log(10.0);
  double x0 = std::log(k_ref), f0 = f(x0);
  double xl = x0 - step, fl = f(xl), xr = x0 + step, fr = f(xr);
  const int budget = settings_.max_pitting_evaluations;
  while (s.evaluations < budget / 2 && (fl > f0 || fr > f0)) {
    if (fr > f0 && fr >= fl) {
      xl = x0, fl = f0, x0 = xr, f0 = fr, xr = x0 + step, fr = f(xr);
    } else {
      xr = x0, fr = f0, x0 = xl, f0 = fl, xl = x0 - step, fl = f(xl);
    }
  }
  for (auto [x, v] : {std::pair{xl, fl}, std::pair{x0, f0}, std::pair{xr, fr}})
    if (v > s.best_c) s.best_c = v, s.best_k = std::exp(x);
  const LineSearchResult r = golden_section_maximise(f, xl, xr, 1e-3, std::max(4, budget - s.evaluations));
  if (r.value > s.best_c) s.best_c = r.value, s.best_k = std::exp(r.x);
  return s;
}

std::string TwinModel::judge_pitting_search(PittingSearch& search, double ics2, double last_ics2, KUpdate& u) const {
  if (search.best_c >= settings_.correlation_threshold && search.best_k > 0) {
    u.outcome = UpdateOutcome::converged;
    return {};
  }
  u.outcome = UpdateOutcome::set_to_zero;
  char b[300];
  std::snprintf(b, sizeof b, "the best correlation %.4f (K_pitting %.4g) stays below %.2f", search.best_c, search.best_k,
                settings_.correlation_threshold);
  std::string why = b;
  if (ics2 < last_ics2) why += ": ICS2 fell while the model's pitting density cannot decrease";
  search.best_k = 0;
  return why;
}

void TwinModel::apply_k_pitting_search(const ModelMemory& saved, const PittingTriple& triple, PittingSearch& search, KUpdate& u) {
  const LoopSnapshot anchor = saved.pitting_anchor;
  LoopSnapshot chosen;
  const double density_new = pitting_density_with(saved, search.best_k, search.evaluations, &chosen);
  memory_ = saved;
  // Re-run for real (anchors inside the stretch are recaptured this time).
  LoopSnapshot final_state;
  rerun(anchor, Override{std::nullopt, search.best_k, anchor.state.cycles}, final_state, true);
  memory_.current = final_state;
  loop_ = loop_at(memory_.current);
  apply_k(false, search.best_k, anchor.state.cycles);
  ++memory_.k_pitting_updates;
  u.new_value = search.best_k;
  u.simulated_after = density_new;
  u.correlation_after = triple.correlation(density_new);
  if (!std::isfinite(u.correlation_after)) u.correlation_after = 0.0;
  u.iterations = search.evaluations;
}

bool TwinModel::saturated_triple(const PittingTriple& triple, double cycles, double density_now, double c_now,
                                 ModelRunReport& report) {
  // At or above the saturation level an ICS2 reading bounds the density from below only
  // (Assumptions): it no longer grows in proportion to the pitted area, so Eq. 7.15's linearity
  // test fails there whatever K_pitting is, and Eqs. 7.16-7.17 would fit K to a flat reading
  // (K cut to a stall, or to 0). No search: K_pitting stays; the point is kept for the next triple.
  const double ics2_max = *std::max_element(triple.ics2.begin(), triple.ics2.end());
  if (!(ics2_max >= settings_.ics2_saturation)) return false;
  KUpdate u;
  u.kind = UpdateKind::k_pitting;
  u.trigger = UpdateTrigger::correlation_below_threshold;
  u.outcome = UpdateOutcome::insensitive;
  u.cycles = cycles;
  u.old_value = u.new_value = memory_.k_pitting;
  u.applies_from_cycles = memory_.pitting_anchor.state.cycles;
  u.correlation_before = u.correlation_after = std::isfinite(c_now) ? c_now : 0.0;
  u.measured = triple.ics2[2];
  u.simulated_before = u.simulated_after = density_now;
  char b[400];
  std::snprintf(b, sizeof b, "C of (ICS2 %.4g, %.4g, %.4g) and density (%.4g, %.4g, %.4g): %.4f below %.2f, but ICS2 %.4g is at or above its saturation level %.4g: a lower bound of the density, no test of K_pitting; K_pitting %.5g kept",
                triple.ics2[0], triple.ics2[1], triple.ics2[2], triple.density[0], triple.density[1], density_now,
                u.correlation_before, settings_.correlation_threshold, ics2_max, settings_.ics2_saturation, memory_.k_pitting);
  u.evidence = b;
  push_pitting_point(cycles, triple.ics2[2], density_now);
  report.updates.push_back(std::move(u));
  return true;
}

void TwinModel::check_pitting(const ModelObservation& obs, ModelRunReport& report) {
  if (!pitting_point_due(obs)) return;
  const double ics2 = *obs.ics2_low;
  const double density_now = mean_of(memory_.current.state.pinion_pitting);
  record_scale_residual(ics2, density_now);
  const auto& points = memory_.pitting_points;
  if (points.size() < 2) {
    push_pitting_point(obs.cycles, ics2, density_now);
    return;
  }
  const PittingTriple triple{{points[points.size() - 2].density, points.back().density},
                             {points[points.size() - 2].ics2, points.back().ics2, ics2}};
  const double c_now = triple.correlation(density_now);
  if (std::isfinite(c_now) && c_now >= settings_.correlation_threshold) {
    push_pitting_point(obs.cycles, ics2, density_now);
    return;
  }
  if (saturated_triple(triple, obs.cycles, density_now, c_now, report)) return;
  const ModelMemory saved = memory_;
  PittingSearch search = search_k_pitting(saved, triple);
  KUpdate u;
  u.kind = UpdateKind::k_pitting;
  u.trigger = UpdateTrigger::correlation_below_threshold;
  u.cycles = obs.cycles;
  u.old_value = saved.k_pitting;
  u.applies_from_cycles = saved.pitting_anchor.state.cycles;
  u.correlation_before = std::isfinite(c_now) ? c_now : 0.0;
  u.measured = ics2;
  u.simulated_before = density_now;
  const std::string why = judge_pitting_search(search, ics2, saved.pitting_points.back().ics2, u);
  if (search.best_k == 0 && saved.k_pitting == 0) {
    // Already 0 (§7.3.3: it stays 0 while the threshold cannot be reached): nothing changes.
    memory_ = saved;
    push_pitting_point(obs.cycles, ics2, density_now);
    return;
  }
  apply_k_pitting_search(saved, triple, search, u);
  char b[400];
  std::snprintf(b, sizeof b, "C of (ICS2 %.4g, %.4g, %.4g) and density (%.4g, %.4g, %.4g -> %.4g): %.4f -> %.4f; K_pitting %.5g -> %.5g",
                triple.ics2[0], triple.ics2[1], triple.ics2[2], triple.density[0], triple.density[1], density_now, u.simulated_after,
                u.correlation_before, u.correlation_after, u.old_value, u.new_value);
  u.evidence = b;
  u.evidence += " " + pitting_change_text(pitting_scale_, u.old_value, u.new_value);
  if (!why.empty()) u.evidence += "; " + why;
  // K = 0 (the thesis's rule) is no measurement of ln K: the posterior keeps the last one.
  if (search.best_k > 0) u.evidence += learn(memory_.log_k_pitting, std::log(search.best_k), pitting_measurement_var(), obs.cycles);
  push_pitting_point(obs.cycles, ics2, u.simulated_after);
  report.updates.push_back(std::move(u));
}

TwinModel::Crossing TwinModel::run_forecast(double kw, double kp, const WearLoopOptions& o, std::vector<ForecastPoint>* curve) const {
  return run_forecast(memory_.current, kw, kp, o, curve);
}

TwinModel::Crossing TwinModel::run_forecast(const LoopSnapshot& from, double kw, double kp, const WearLoopOptions& o,
                                            std::vector<ForecastPoint>* curve) const {
  return run_forecast(from, kw, kp, o, curve, settings_.wear_limit_m);
}

TwinModel::Crossing TwinModel::run_forecast(const LoopSnapshot& from, double kw, double kp, const WearLoopOptions& o,
                                            std::vector<ForecastPoint>* curve, double wear_limit) const {
  Crossing c;
  const double start = from.state.cycles;
  const double horizon = settings_.forecast_horizon_cycles;
  BlueLoop loop(params_, o);
  loop.restore(from.state, std::clamp(from.next_step_cycles, o.min_step_cycles, o.max_step_cycles));
  loop.set_coefficients(kw, kp);
  double prev_cycles = start, prev_depth = max_depth(loop.state()), prev_pit = mean_of(loop.state().pinion_pitting);
  auto check = [&] {
    const double cyc = loop.state().cycles, d = max_depth(loop.state()), p = mean_of(loop.state().pinion_pitting);
    auto cross = [&](std::optional<double>& out, double before, double after, double limit) {
      if (out || after < limit) return;
      const double frac = after > before ? (limit - before) / (after - before) : 0.0;
      out = std::max(0.0, prev_cycles + std::clamp(frac, 0.0, 1.0) * (cyc - prev_cycles) - start);
    };
    cross(c.wear, prev_depth, d, wear_limit);
    cross(c.pitting, prev_pit, p, settings_.pitting_limit);
    prev_cycles = cyc, prev_depth = d, prev_pit = p;
  };
  if (prev_depth >= wear_limit) c.wear = 0.0;
  if (prev_pit >= settings_.pitting_limit) c.pitting = 0.0;
  // Past both limits (or past the wear limit when nothing pits) the run has told its story.
  auto told = [&] { return c.wear && (c.pitting || !(kp > 0)); };
  for (int k = 1; k <= settings_.forecast_points; ++k) {
    const double target = start + horizon * k / settings_.forecast_points;
    bool stopped = false;
    while (loop.state().cycles < target) {
      if (loop.step(target).step_cycles <= 0) {
        stopped = true;
        break;
      }
      check();
      if (told()) break;
    }
    if (curve) {
      const WearSummary s = summarise(loop.state());
      curve->push_back({loop.state().cycles, max_depth(loop.state()), s.combined_mean_depth_m, s.mean_pitting_density});
    }
    if (stopped || told()) break;
  }
  return c;
}

namespace {
std::string interval_text(const char* what, const LogInterval& li, double widen) {
  char b[200];
  std::snprintf(b, sizeof b, "%s: ln K %.4f to %.4f (SD %.3g%s)", what, li.low, li.high, li.sd,
                widen > 1 ? (", widened x" + fmt("%.3g", widen)).c_str() : "");
  return b;
}
}  // namespace

double TwinModel::check_recent_residuals(Forecast& f) const {
  // The chi-square check of the recent RMS_SA residuals (before any update at their records).
  std::vector<double> recent;
  const auto& res = memory_.rms_residuals;
  for (std::size_t i = res.size() > static_cast<std::size_t>(settings_.disagreement_records) ? res.size() - settings_.disagreement_records : 0;
       i < res.size(); ++i)
    recent.push_back(res[i][0]);
  const double expected = rms_scatter_sd();
  const ScatterCheck chk = residual_scatter_check(recent, expected);
  if (!chk.exceeded) return 1.0;
  f.flags.push_back(ForecastFlag::rms_sa_residuals_exceed_scatter);
  char b[300];
  std::snprintf(b, sizeof b, "RMS_SA: the last %d ln(meas/sim) give chi-square %.3g > %.3g (5 %%) at the expected scatter %.3g: the K_wear interval widened x%.3g",
                chk.n, chk.statistic, chk.critical, expected, chk.ratio);
  f.evidence += (f.evidence.empty() ? "" : "; ") + std::string(b);
  return chk.ratio;
}

LogPosterior TwinModel::wear_posterior_now(Forecast& f) const {
  LogPosterior pw = predict(memory_.log_k_wear, memory_.current.state.cycles, settings_.log_k_q_per_cycle());
  if (!memory_.k_wear_last_insensitive || !pw.valid) return pw;
  // RMS_SA did not determine K_wear at the last update: the updates since the prior carry no
  // information the model can vouch for, so the interval is at least the prior's.
  const double prior_var = settings_.prior_log_k_wear_sd * settings_.prior_log_k_wear_sd;
  f.flags.push_back(ForecastFlag::k_wear_not_identified);
  char b[200];
  std::snprintf(b, sizeof b, "K_wear: the last update did not identify K_wear (RMS_SA insensitive, no K reproduced the record, or only an upper bound): ln K SD %.3g raised to the prior's %.3g",
                std::sqrt(pw.var), settings_.prior_log_k_wear_sd);
  f.evidence += (f.evidence.empty() ? "" : "; ") + std::string(b);
  pw.var = std::max(pw.var, prior_var);
  return pw;
}

ModelFormTerm TwinModel::rms_model_form(Forecast& f, const LogPosterior& pw) const {
  // What the twin's RMS_SA-wear relation does not reproduce over the stored records (model-form
  // error, measured against the scatter) goes into ln K_wear's variance through the elasticity.
  const double expected = rms_scatter_sd();
  std::vector<double> all_residuals;
  for (const auto& r : memory_.rms_residuals) all_residuals.push_back(r[0]);
  const double prior_var_w = settings_.prior_log_k_wear_sd * settings_.prior_log_k_wear_sd;
  const ModelFormTerm form =
      model_form_term(all_residuals, expected, memory_.k_wear_elasticity, settings_.min_wear_elasticity,
                      std::max(0.0, prior_var_w - pw.var));   // never beyond the prior's: no data leaves K less known
  if (form.exceeded && pw.valid) {
    f.flags.push_back(ForecastFlag::rms_sa_model_form_disagreement);
    char b[300];
    std::snprintf(b, sizeof b, "RMS_SA: %zu records' ln(meas/sim) exceed the scatter %.3g by a mean square %.3g: at elasticity %.3g the K_wear interval's variance gains %.3g (model-form term)",
                  all_residuals.size(), expected, form.excess_mean_square, memory_.k_wear_elasticity, form.log_k_var);
    f.evidence += (f.evidence.empty() ? "" : "; ") + std::string(b);
  }
  return form;
}

PittingMiss TwinModel::pitting_path_miss(Forecast& f, const LogPosterior& pp, const Ics2Evidence& ev) const {
  // The model's pitting path against the ICS2-derived density: a miss beyond 2 SD adds its gap².
  PittingMiss miss;
  // A saturated reading is a lower bound: a model at or above it has not missed it.
  if (ev.saturated && ev.model >= std::max(ev.trend, ev.latest)) return miss;
  if (ev.valid && pp.valid) miss = pitting_miss(ev.trend, ev.sd, ev.model, 2.0);
  if (!miss.missed) return miss;
  f.flags.push_back(ForecastFlag::pitting_path_missed_ics2);
  char b[300];
  std::snprintf(b, sizeof b, "pitting: the model's density %.4g against the ICS2-derived %.4g (SD %.3g) is a gap of %.3g in ln K (SD %.3g, beyond 2 SD): the K_pitting interval's variance gains %.3g",
                ev.model, ev.trend, ev.sd, miss.gap, miss.gap_sd, miss.extra_var);
  f.evidence += (f.evidence.empty() ? "" : "; ") + std::string(b);
  return miss;
}

void TwinModel::interval_ends(Forecast& f, const Crossing& nominal, const WearLoopOptions& o, const IntervalInputs& in,
                              LogInterval& lw, LogInterval& lp, std::vector<ForecastPoint>* fast_curve,
                              std::vector<ForecastPoint>* slow_curve) const {
  const double horizon = settings_.forecast_horizon_cycles, q = settings_.log_k_q_per_cycle();
  // The random walk accumulates to each end's own crossing: first to the nominal one, then once
  // more to the crossing the first pass gave (beyond the horizon: the horizon).
  auto until = [&](const std::optional<double>& c) { return c ? *c : horizon; };
  Crossing fast = nominal, slow = nominal;
  for (int pass = 0; pass < 2; ++pass) {
    const LogInterval w_fast = log_interval(in.wear, q, until(fast.wear), in.widen, in.wear_form_var),
                      w_slow = log_interval(in.wear, q, until(slow.wear), in.widen, in.wear_form_var);
    const LogInterval p_fast = log_interval(in.pitting, q, until(fast.pitting), 1.0, in.pitting_miss_var),
                      p_slow = log_interval(in.pitting, q, until(slow.pitting), 1.0, in.pitting_miss_var);
    lw = {w_slow.low, w_fast.high, std::max(w_fast.sd, w_slow.sd)};
    lp = {p_slow.low, p_fast.high, std::max(p_fast.sd, p_slow.sd)};
    // The working K lies inside the interval (the twin runs with the update's K, the posterior
    // mean may sit beside it; docs/model.md).
    const double kw = memory_.k_wear_si, kp = memory_.k_pitting;
    f.k_wear_low = std::min(std::exp(lw.low), kw);
    f.k_wear_high = std::max(std::exp(lw.high), kw);
    f.k_pitting_low = in.pitting.valid ? std::min(std::exp(lp.low), kp) : kp;
    f.k_pitting_high = in.pitting.valid ? std::max(std::exp(lp.high), kp) : kp;
    const bool last = pass == 1;
    if (last && fast_curve) fast_curve->clear();
    if (last && slow_curve) slow_curve->clear();
    fast = run_forecast(f.k_wear_high, f.k_pitting_high, o, last ? fast_curve : nullptr);
    slow = run_forecast(f.k_wear_low, f.k_pitting_low, o, last ? slow_curve : nullptr);
  }
  f.wear.cycles_left_low = fast.wear;
  f.wear.cycles_left_high = slow.wear;
  f.pitting.cycles_left_low = fast.pitting;
  f.pitting.cycles_left_high = slow.pitting;
}

void TwinModel::set_intervals(Forecast& f, const Crossing& nominal, const WearLoopOptions& o, const Ics2Evidence& ev) const {
  IntervalInputs in;
  in.widen = check_recent_residuals(f);
  in.wear = wear_posterior_now(f);
  in.pitting = predict(memory_.log_k_pitting, memory_.current.state.cycles, settings_.log_k_q_per_cycle());
  in.wear_form_var = rms_model_form(f, in.wear).log_k_var;
  in.pitting_miss_var = pitting_path_miss(f, in.pitting, ev).extra_var;
  LogInterval lw, lp;
  std::vector<ForecastPoint> fast_curve, slow_curve;
  interval_ends(f, nominal, o, in, lw, lp, &fast_curve, &slow_curve);
  f.log_sd_wear = lw.sd;
  f.log_sd_pitting = in.pitting.valid ? lp.sd : 0.0;
  hold_nominal(f);
  if (apply_depth_calibration(f, o)) hold_nominal(f);
  else apply_profile_shape(f, fast_curve, slow_curve);
  f.evidence += (f.evidence.empty() ? "" : "; ") + interval_text("K_wear", lw, in.widen);
  if (in.pitting.valid) f.evidence += "; " + interval_text("K_pitting", lp, 1.0);
}

void TwinModel::hold_nominal(Forecast& f) {
  // The interval holds the nominal forecast.
  for (LimitForecast* lf : {&f.wear, &f.pitting}) {
    if (lf->cycles_left && (!lf->cycles_left_low || *lf->cycles_left_low > *lf->cycles_left)) lf->cycles_left_low = lf->cycles_left;
    if (lf->cycles_left_high && (!lf->cycles_left || *lf->cycles_left_high < *lf->cycles_left)) lf->cycles_left_high = lf->cycles_left;
  }
}

void TwinModel::apply_profile_shape(Forecast& f, const std::vector<ForecastPoint>& fast, const std::vector<ForecastPoint>& slow) const {
  // The depth read from RMS_SA holds for the model's shape; the concentrated-wear shape at the same
  // RMS_SA has ρ times its mean (docs/model.md, "Profile-shape term"). Each shape's own interval
  // (the RMS_SA scatter through d ln RMS_SA / d ln depth) and their union is the depth interval.
  const double now = memory_.current.state.cycles, mean = summarise(memory_.current.state).combined_mean_depth_m;
  const double rho = memory_.shape_depth_ratio;
  const double log_sd = rms_scatter_sd() / std::max(std::abs(memory_.shape_depth_elasticity), settings_.min_wear_elasticity);
  const std::array<double, 2> depth = shape_depth_interval(mean, rho, log_sd, kNominalCoverage);
  f.depth_mean_m = mean;
  f.depth_low_m = depth[0];
  f.depth_high_m = depth[1];
  if (!(rho > 0) || !(memory_.shape_peak_ratio > 0)) return;
  f.shape_depth_ratio = rho;
  f.shape_peak_ratio = memory_.shape_peak_ratio;
  f.flags.push_back(ForecastFlag::wear_profile_shape_unidentified);
  // The concentrated shape keeps its form (no feedback moves it), so its deepest point is its peak
  // ratio times its mean, and its mean follows the model's path times ρ (the same K and operating
  // history, read through the other shape): its crossing along the fast, nominal and slow paths.
  const double factor = rho * memory_.shape_peak_ratio, limit = settings_.wear_limit_m;
  auto path = [&](const std::vector<ForecastPoint>& curve) {
    std::vector<std::array<double, 2>> p{{0.0, mean}};
    for (const ForecastPoint& q : curve) p.push_back({q.cycles - now, q.mean_depth_m});
    return p;
  };
  const std::optional<double> near = scaled_path_crossing(path(fast), factor, limit);
  const std::optional<double> at_nominal = scaled_path_crossing(path(f.curve), factor, limit);
  const std::optional<double> far = scaled_path_crossing(path(slow), factor, limit);
  // The slow run stops once it has told its story; a concentrated crossing not on its path is then
  // unknown, and the far end stays the model's.
  const bool slow_to_horizon = !slow.empty() && slow.back().cycles >= now + settings_.forecast_horizon_cycles * (1 - 1e-9);
  if (near && (!f.wear.cycles_left_low || *near < *f.wear.cycles_left_low)) f.wear.cycles_left_low = near;
  if (f.wear.cycles_left_high) {
    if (far && *far > *f.wear.cycles_left_high) f.wear.cycles_left_high = far;
    else if (!far && slow_to_horizon) f.wear.cycles_left_high.reset();
  }
  auto cycles_text = [](const std::optional<double>& c) { return c ? fmt("%.4g", *c) : std::string("beyond the horizon"); };
  char b[500];
  std::snprintf(b, sizeof b, "profile shape (read at %.4g cycles): RMS_SA cannot tell the worn profile's shape; the concentrated-wear shape at the same RMS_SA has %.3g x the model's mean depth and its deepest point %.3g x its mean: depth %.4g um, interval %.4g to %.4g um; its wear limit crossing %s / %s / %s cycles (fast / nominal / slow K) joins the wear interval",
                memory_.shape_cycles, rho, memory_.shape_peak_ratio, 1e6 * mean, 1e6 * depth[0], 1e6 * depth[1], cycles_text(near).c_str(),
                cycles_text(at_nominal).c_str(), cycles_text(far).c_str());
  f.evidence += (f.evidence.empty() ? "" : "; ") + std::string(b);
}

LoopSnapshot TwinModel::with_mean_pitting(double density) const {
  // The model's pitting profile (its shape along the flank) at the given mean, as the calibration
  // rescales it to an inspected area.
  LoopSnapshot s = memory_.current;
  const double mean = mean_of(s.state.pinion_pitting);
  for (double& d : s.state.pinion_pitting) d = mean > 0 ? std::min(1.0, d * density / mean) : density;
  return s;
}

void TwinModel::check_model_past_pitting_limit(Forecast& f, const WearLoopOptions& o, const Ics2Evidence& ev) const {
  const double limit = settings_.pitting_limit;
  if (!ev.valid || !(ev.model >= limit)) return;
  const double measured = std::max(ev.trend, ev.latest);
  if (measured >= limit) return;   // both at the limit: 0 left stands
  // A saturated reading bounds the density from below only: a model at the limit does not
  // contradict it (apply_ics2_lower_bound sets the interval).
  if (ev.saturated) return;
  // The model's state is at the limit and the measurement is not: the model's own path has run
  // ahead of what ICS2 reads (a model-form or K error the interval over K from this state cannot
  // show, since every K starts past the limit). Neither reading is discarded: the near end stays 0
  // (the model's), the nominal and the far end start from the measured density (its lower bound
  // for the far end, with the low K), the model's pitting shape kept.
  f.flags.push_back(ForecastFlag::pitting_limit_reached_by_model_only);
  const double z = normal_quantile(0.5 + kNominalCoverage / 2);
  const double low_density = std::max(0.0, measured - z * ev.sd);
  const std::optional<double> nominal = run_forecast(with_mean_pitting(measured), memory_.k_wear_si, memory_.k_pitting, o, nullptr).pitting;
  const std::optional<double> far = run_forecast(with_mean_pitting(low_density), f.k_wear_low, f.k_pitting_low, o, nullptr).pitting;
  f.pitting.cycles_left = nominal;
  f.pitting.cycles_left_low = 0.0;
  f.pitting.cycles_left_high = far;
  if (far && nominal && *far < *nominal) f.pitting.cycles_left_high = nominal;
  if (!far) f.pitting.cycles_left_high.reset();
  char b[400];
  std::snprintf(b, sizeof b, "pitting: the model's density %.4g is at the limit %.4g but the ICS2-derived %.4g (trend %.4g, latest %.4g, SD %.3g) is not: cycles left from the measured density (far end from %.4g at the low K), near end 0",
                ev.model, limit, measured, ev.trend, ev.latest, ev.sd, low_density);
  f.evidence += (f.evidence.empty() ? "" : "; ") + std::string(b);
}

std::vector<std::array<double, 2>> TwinModel::ics2_density_series(std::size_t newest) const {
  std::vector<std::array<double, 2>> out;
  if (!memory_.ics2_scale_valid) return out;
  const auto& s = memory_.ics2_series;
  const Ics2Scale scale = ics2_scale();
  for (std::size_t i = s.size() > newest ? s.size() - newest : 0; i < s.size(); ++i) out.push_back({s[i][0], scale.density_at(s[i][1])});
  return out;
}

Ics2Scale TwinModel::ics2_scale() const {
  Ics2Scale scale;
  scale.form = memory_.ics2_scale_form;
  scale.ics2 = memory_.ics2_scale_ics2;
  scale.density = memory_.ics2_scale_density;
  scale.slope = memory_.ics2_scale_slope;
  scale.baseline = memory_.ics2_scale_baseline;
  scale.baseline_sd = memory_.ics2_scale_baseline_sd;
  return scale;
}

double TwinModel::ics2_density_sd(double d) const {
  const double s = settings_.inspection_area_relative_sd;
  const double noise = ics2_scale().density_noise(d, memory_.ics2_scale_baseline_sd);
  const double a0 = memory_.ics2_scale_density, a1 = memory_.ics2_scale_density_1;
  if (memory_.ics2_scale_inspections == 2 && a1 > a0) {
    // Two inspections: D = (1 − t) A0 + t A1, t = (D − A0) / (A1 − A0) along the scale.
    return std::hypot(scale_density_sd(a0, a1, (d - a0) / (a1 - a0), s), noise);
  }
  // One inspection: D = A0 sqrt((ICS2 − baseline) / (ICS2_0 − baseline)): A0's relative error scales D.
  return std::hypot(s * d, noise);
}

TwinModel::Ics2Evidence TwinModel::ics2_evidence() const {
  Ics2Evidence ev;
  const auto series = ics2_density_series(static_cast<std::size_t>(settings_.ics2_trend_records));
  if (series.size() < 3) return ev;
  const double now = memory_.current.state.cycles;
  // Centred on now, so the intercept is the trend's density now.
  std::vector<std::array<double, 2>> centred;
  for (const auto& p : series) centred.push_back({p[0] - now, p[1]});
  const RobustLine line = theil_sen(centred);
  if (!line.valid) return ev;
  ev.valid = true;
  ev.trend = line.intercept;
  ev.latest = series.back()[1];
  ev.slope = line.slope;
  ev.records = series.size();
  ev.model = mean_of(memory_.current.state.pinion_pitting);
  ev.sd = ics2_density_sd(std::max(ev.trend, ev.latest));
  // The readings in ICS2: the latest, and the trend's density back through the scale.
  const Ics2Scale scale = ics2_scale();
  const double trend_ics2 = scale.form == Ics2ScaleForm::square_root || scale.slope > 0 ? scale.ics2_for(ev.trend)
                                                                                          : memory_.ics2_series.back()[1];
  ev.ics2 = std::max(memory_.ics2_series.back()[1], trend_ics2);
  ev.saturated = ev.ics2 >= settings_.ics2_saturation;
  return ev;
}

void TwinModel::check_ics2_trend(Forecast& f, const Ics2Evidence& ev) const {
  if (!ev.valid) return;
  const double limit = settings_.pitting_limit;
  const double d_trend = ev.trend, d_latest = ev.latest, d_model = ev.model, sd = ev.sd;
  const double d_high = std::max(d_trend, d_latest);
  char b[400];
  if (d_high >= limit) {
    // A limit the measured estimate has reached cannot be excluded by any interval.
    f.flags.push_back(ForecastFlag::pitting_limit_reached_by_ics2);
    f.pitting.cycles_left_low = 0.0;
    std::snprintf(b, sizeof b, "ICS2-derived density %.4g (trend) / %.4g (latest) at or above the limit %.4g: near end 0", d_trend, d_latest, limit);
  } else if (ev.saturated) {
    return;   // the upper end is unknown: apply_ics2_lower_bound
  } else if (limit_within_reach(d_high, sd, limit)) {
    // The limit lies inside the measured density's own interval: it may be reached already.
    f.flags.push_back(ForecastFlag::pitting_limit_within_ics2_uncertainty);
    f.pitting.cycles_left_low = 0.0;
    std::snprintf(b, sizeof b, "ICS2-derived density %.4g (trend) / %.4g (latest), SD %.3g: its %.0f %% upper bound %.4g reaches the limit %.4g: near end 0",
                  d_trend, d_latest, sd, 100 * (0.5 + kNominalCoverage / 2), d_high + normal_quantile(0.5 + kNominalCoverage / 2) * sd, limit);
  } else if (d_trend - d_model > 2.0 * sd && ev.slope > 0) {
    f.flags.push_back(ForecastFlag::ics2_density_ahead_of_model);
    const double trend_left = (limit - d_trend) / ev.slope;
    if (!f.pitting.cycles_left_low || trend_left < *f.pitting.cycles_left_low) f.pitting.cycles_left_low = trend_left;
    std::snprintf(b, sizeof b, "ICS2-derived density %.4g (Theil-Sen trend of the last %zu, %.3g per Mcycle) ahead of the model's %.4g by more than 2 SD (%.3g): the trend reaches %.4g in %.4g cycles",
                  d_trend, ev.records, ev.slope * 1e6, d_model, sd, limit, trend_left);
  } else {
    return;
  }
  f.evidence += (f.evidence.empty() ? "" : "; ") + std::string(b);
}

void TwinModel::apply_ics2_lower_bound(Forecast& f, const WearLoopOptions& o, const Ics2Evidence& ev) const {
  const double limit = settings_.pitting_limit;
  const double bound = std::max(ev.trend, ev.latest);
  if (!ev.valid || !ev.saturated || bound >= limit) return;   // at the limit: check_ics2_trend's near end 0
  f.flags.push_back(ForecastFlag::ics2_saturated_density_lower_bound);
  // The measurement says D >= bound and nothing about how far above: the density may already be at
  // the limit, so the near end is 0 (no reading rules the limit out; the model's own state cannot,
  // its path being a model of the truth, not a measurement of it). The nominal comes from the
  // model's state (from the bound where the model lies below it, which the measurement excludes),
  // the far end from the bound less its SD at the interval's level.
  const double z = normal_quantile(0.5 + kNominalCoverage / 2);
  const double far_start = std::max(0.0, bound - z * ev.sd);
  if (ev.model < bound) f.pitting.cycles_left = run_forecast(with_mean_pitting(bound), memory_.k_wear_si, memory_.k_pitting, o, nullptr).pitting;
  f.pitting.cycles_left_low = 0.0;
  // Always from there: below the model's density it widens the interval, above it the
  // measurement has excluded the model's lower state.
  f.pitting.cycles_left_high = run_forecast(with_mean_pitting(far_start), f.k_wear_low, f.k_pitting_low, o, nullptr).pitting;
  hold_nominal(f);
  char b[400];
  std::snprintf(b, sizeof b, "pitting: ICS2 %.4g at or above its saturation level %.4g: the ICS2-derived density %.4g (trend %.4g, latest %.4g, SD %.3g) is a lower bound, its upper end unknown: near end 0, nominal from %s %.4g, far end from %.4g at the low K",
                ev.ics2, settings_.ics2_saturation, bound, ev.trend, ev.latest, ev.sd, ev.model < bound ? "the bound" : "the model's", std::max(ev.model, bound),
                far_start);
  f.evidence += (f.evidence.empty() ? "" : "; ") + std::string(b);
}

void TwinModel::read_pitted_area_inspections(const std::vector<Inspection>& inspections, double now) {
  auto& points = memory_.pitted_area_points;
  points.clear();
  for (const Inspection& i : inspections)
    if (i.pitted_area && std::isfinite(*i.pitted_area) && *i.pitted_area > 0 && *i.pitted_area <= 1 && std::isfinite(i.cycles) &&
        i.cycles <= now)
      points.push_back({i.cycles, *i.pitted_area});
  std::sort(points.begin(), points.end());
}

std::vector<DensityReading> TwinModel::growth_law_readings() const {
  const double s = settings_.inspection_area_relative_sd;
  // The ICS2 scale goes through one or two inspections: their errors are common to every ICS2
  // reading and to the inspections' own readings (one error each, not two independent ones).
  const bool scale_valid = memory_.ics2_scale_valid;
  const bool two = scale_valid && memory_.ics2_scale_inspections == 2 && memory_.ics2_scale_density_1 > memory_.ics2_scale_density;
  const double a0 = memory_.ics2_scale_density, a1 = two ? memory_.ics2_scale_density_1 : -1.0;
  std::vector<DensityReading> r;
  std::array<bool, kGrowthSharedErrors> taken{};
  for (const auto& p : memory_.pitted_area_points) {
    DensityReading x{p[0], p[1], s, {}};
    const int j = !scale_valid ? -1 : (p[1] == a0 && !taken[0]) ? 0 : (p[1] == a1 && !taken[1]) ? 1 : -1;
    if (j >= 0) {
      taken[static_cast<std::size_t>(j)] = true;
      x.log_sd = 0.0;
      x.shared[static_cast<std::size_t>(j)] = s;
    }
    r.push_back(x);
  }
  if (!scale_valid) return r;
  // One reading per pitting interval: the records' ICS2 scatter is not independent evidence of the
  // curve's shape at the records' own spacing. Saturated readings are lower bounds only: left out.
  const Ics2Scale scale = ics2_scale();
  const double width = settings_.pitting_interval_cycles;
  std::vector<std::array<double, 2>> bin;
  auto flush = [&] {
    if (bin.empty()) return;
    std::vector<double> n, v;
    for (const auto& x : bin) n.push_back(x[0]), v.push_back(x[1]);
    std::sort(n.begin(), n.end());
    std::sort(v.begin(), v.end());
    const double cycles = n[n.size() / 2], ics2 = v[v.size() / 2];
    bin.clear();
    if (ics2 >= settings_.ics2_saturation) return;
    const double d = scale.density_at(ics2);
    if (!(d > 0 && d < 1)) return;
    // Own error: the ICS2 scatter through the scale, no smaller than an inspection's (ICS2 ∝ area is
    // itself an assumption, thesis Ch. 4). Common: D's change with each scale inspection's error.
    DensityReading x{cycles, d, std::max(s, scale.density_noise(d, memory_.ics2_scale_baseline_sd) / d), {}};
    if (two) {
      const double t = (d - a0) / (a1 - a0);
      x.shared = {s * (1.0 - t) * a0 / d, s * t * a1 / d};
    } else {
      x.shared = {s, 0.0};   // one inspection: D = A0 sqrt(…), A0's relative error scales D
    }
    r.push_back(x);
  };
  double bin_end = -1;
  for (const auto& p : memory_.ics2_series) {
    if (p[0] > bin_end) {
      flush();
      bin_end = p[0] + width;
    }
    bin.push_back(p);
  }
  flush();
  return r;
}

void TwinModel::apply_growth_law(Forecast& f) const {
  if (!settings_.pitting_growth_law || memory_.pitted_area_points.size() < 2) return;   // Lundberg–Palmgren alone (calibrated or not)
  const auto readings = growth_law_readings();
  GrowthLawSettings gs;
  gs.b_prior_mean = (settings_.loop.material.m - 1.0) / settings_.loop.material.m;   // Eq. 7.8 at small D: D ∝ N^m
  gs.coverage = kNominalCoverage;
  const double now = memory_.current.state.cycles, horizon = settings_.forecast_horizon_cycles;
  const GrowthLawFit fit = fit_growth_law(readings, settings_.pitting_limit, now, gs);
  if (!fit.valid) return;
  // A near end a measurement set to 0 (the limit reached or not ruled out) stays 0.
  const bool near_zero = f.pitting.cycles_left_low && *f.pitting.cycles_left_low == 0.0;
  auto within = [horizon](double c) { return std::isfinite(c) && c <= horizon ? std::optional<double>(c) : std::nullopt; };
  // b's posterior at a range end: the readings ask for a form the law lacks, so its interval is not
  // the whole uncertainty: the interval spans the law's and Eq. 7.8's (the twin's other form).
  const bool at_bound = fit.bound != GrowthExponentBound::inside;
  double low = fit.cycles_left_low, high = fit.cycles_left_high;
  if (at_bound) {
    low = std::min(low, f.pitting.cycles_left_low.value_or(low));
    high = std::max(high, f.pitting.cycles_left_high.value_or(std::numeric_limits<double>::infinity()));
  }
  f.pitting.cycles_left = within(fit.cycles_left);
  f.pitting.cycles_left_low = near_zero ? 0.0 : std::min(low, horizon);
  f.pitting.cycles_left_high = within(high);
  hold_nominal(f);
  const std::string pile_note =
      at_bound ? std::string(", piled at its ") + (fit.bound == GrowthExponentBound::at_upper ? "upper bound 1" : "lower bound 0") +
                     ": form not identified, interval joined with Eq. 7.8's"
               : "";
  char b[480];
  std::snprintf(b, sizeof b, "pitting growth law dD/dN = a D^b (1 - D) fitted to %d readings (%zu inspections, unsaturated ICS2, the scale's inspection errors common): b = %.3g (SD %.2g; prior %.3g from Eq. 7.8's m)%s, density now %.4g; cycles left %.4g (%.4g .. %.4g) replace Eq. 7.8's",
                fit.readings, memory_.pitted_area_points.size(), fit.b_mean, fit.b_sd, gs.b_prior_mean,
                pile_note.c_str(),
                fit.density_now, fit.cycles_left, low, high);
  f.evidence += (f.evidence.empty() ? "" : "; ") + std::string(b);
}

void TwinModel::apply_inspection_exponent(Forecast& f) const {
  const auto& points = memory_.pitted_area_points;   // sorted by cycles
  if (!settings_.pitting_exponent_from_inspections || points.size() < 2) return;
  // The two newest at distinct cycles.
  const std::array<double, 2> second = points.back();
  const std::array<double, 2>* first = nullptr;
  for (auto it = points.rbegin() + 1; it != points.rend(); ++it)
    if ((*it)[0] < second[0]) {
      first = &*it;
      break;
    }
  if (!first) return;
  const double s = settings_.inspection_area_relative_sd, now = memory_.current.state.cycles;
  const ExponentCrossing x = inspection_exponent_crossing((*first)[0], (*first)[1], second[0], second[1], s, s,
                                                          settings_.pitting_limit, now, kNominalCoverage);
  if (!x.valid) return;
  // Eq. 7.8 with the material's m runs on at the inspections' chord; a density that accelerates
  // (pits initiating over a Weibull life and growing) shows as a larger slope on the Weibull plot.
  // The nominal follows the readings' line; the twin's path is another form of the same law, so
  // the interval spans both (a near end a measurement set to 0 stays 0).
  const double horizon = settings_.forecast_horizon_cycles;
  auto within = [horizon](double c) { return std::isfinite(c) && c <= horizon ? std::optional<double>(c) : std::nullopt; };
  const bool near_zero = f.pitting.cycles_left_low && *f.pitting.cycles_left_low == 0.0;
  const double low = std::min(x.cycles_left_low, f.pitting.cycles_left_low.value_or(x.cycles_left_low));
  const double high = std::max(x.cycles_left_high, f.pitting.cycles_left_high.value_or(std::numeric_limits<double>::infinity()));
  f.pitting.cycles_left = within(x.cycles_left);
  f.pitting.cycles_left_low = near_zero ? 0.0 : std::min(low, horizon);
  f.pitting.cycles_left_high = within(high);
  hold_nominal(f);
  char b[480];
  std::snprintf(b, sizeof b, "pitting: inspections %.4g at %.6g and %.4g at %.6g cycles give Eq. 7.8's exponent %.3g (SD %.2g; the material's %.3g): the limit %.4g at %.6g cycles (ln SD %.3g from the inspections), %.4g left (%.4g .. %.4g) replace the path's; interval joined with it",
                (*first)[1], (*first)[0], second[1], second[0], x.exponent, x.exponent_sd, settings_.loop.material.m,
                settings_.pitting_limit, x.crossing_cycles, x.log_sd, x.cycles_left, x.cycles_left_low, x.cycles_left_high);
  f.evidence += (f.evidence.empty() ? "" : "; ") + std::string(b);
}

Forecast TwinModel::forecast() const {
  Forecast f;
  if (!memory_.started || memory_.recent_operating_points.empty()) {
    f.failure = "no record yet";
    return f;
  }
  // The newest records' mean since their last load step: the wear and pitting rates go as powers of
  // the torque, so a mean across a step would pace the future at a load the pair no longer runs at.
  // A step of 10 % moves an Archard rate by 10 % (more for Eq. 7.8's); 4 standard errors keep a
  // scattered load from being cut.
  const std::array<double, 2> point = forecast_operating_point(memory_.recent_operating_points, 0.1, 4.0);
  const double speed = point[0], torque = point[1];
  f.speed_hz = speed;
  f.torque_nm = torque;
  f.wear.limit = settings_.wear_limit_m;
  f.pitting.limit = settings_.pitting_limit;
  const double horizon = settings_.forecast_horizon_cycles;
  // Coarser steps than the monitoring loop: the force tolerance still bounds each one.
  WearLoopOptions o = settings_.loop;
  o.max_step_cycles = std::max(o.max_step_cycles, horizon / (4.0 * settings_.forecast_points));
  // docs/wear.md: a 0.2 force tolerance changes the dry pair's depth by 0.04 %, at a fraction of the steps.
  o.force_tolerance = std::max(o.force_tolerance, 0.2);
  o.operating_point = {speed, torque};
  try {
    const Crossing nominal = run_forecast(memory_.k_wear_si, memory_.k_pitting, o, &f.curve);
    f.wear.cycles_left = nominal.wear;
    f.pitting.cycles_left = nominal.pitting;
    const Ics2Evidence ev = ics2_evidence();
    set_intervals(f, nominal, o, ev);
    check_model_past_pitting_limit(f, o, ev);
    check_ics2_trend(f, ev);
    apply_ics2_lower_bound(f, o, ev);
    apply_inspection_exponent(f);
    apply_growth_law(f);
    f.valid = true;
  } catch (const std::exception& e) {
    f.failure = e.what();
  }
  return f;
}

}  // namespace gearwatch::wear
