#include "model_thread.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <set>
#include <utility>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "gap_diagnoser.hpp"
#include "thread_cpu.hpp"
#include "gearwatch/config/twin_config.hpp"
#include "gearwatch/storage/alert_history.hpp"
#include "gearwatch/storage/gap_kept_records.hpp"
#include "gearwatch/storage/inspections.hpp"
#include "gearwatch/storage/model_history.hpp"
#include "gearwatch/storage/processing_history.hpp"
#include "gearwatch/storage/resume.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/twin/errors.hpp"
#include "gearwatch/types/gear_pair_boundary.hpp"
#include "gearwatch/types/indicator.hpp"
#include "gearwatch/types/log_rate.hpp"

namespace gearwatch::daemon {
namespace {

using nlohmann::json;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
/// The model thread's nice value when processing is lowered at all: the lowest priority Linux
/// gives, since the model is the least urgent work in the daemon.
constexpr int kModelThreadNice = 19;
/// Coalesced records are logged when their running count crosses a multiple of this (and the first time).
constexpr std::uint64_t kCoalescedLogEvery = 100;

json snapshot_json(const wear::LoopSnapshot& s) {
  return {{"cycles", s.state.cycles},
          {"next_step_cycles", s.next_step_cycles},
          {"pinion_depth_m", s.state.pinion_depth_m},
          {"gear_depth_m", s.state.gear_depth_m},
          {"pinion_pitting", s.state.pinion_pitting}};
}

wear::LoopSnapshot snapshot_from(const json& j) {
  wear::LoopSnapshot s;
  s.state.cycles = j.at("cycles").get<double>();
  s.next_step_cycles = j.at("next_step_cycles").get<double>();
  s.state.pinion_depth_m = j.at("pinion_depth_m").get<std::vector<double>>();
  s.state.gear_depth_m = j.at("gear_depth_m").get<std::vector<double>>();
  s.state.pinion_pitting = j.at("pinion_pitting").get<std::vector<double>>();
  return s;
}

json posterior_json(const wear::LogPosterior& p) {
  return {{"valid", p.valid}, {"mean", p.mean}, {"var", p.var}, {"cycles", p.cycles}};
}

// A state stored before the posterior existed has none: missing -> not valid (the model starts a prior).
wear::LogPosterior posterior_from(const json& j, const char* key) {
  wear::LogPosterior p;
  if (!j.contains(key)) return p;
  const json& o = j.at(key);
  p.valid = o.at("valid").get<bool>();
  p.mean = o.at("mean").get<double>();
  p.var = o.at("var").get<double>();
  p.cycles = o.at("cycles").get<double>();
  return p;
}

// Root -> tip at 11 points (the twin wear table's rows): what a prediction row keeps of the profile.
std::string profile_json(const wear::ModelRunReport& r, const wear::ModelMemory& m) {
  const auto& pit = m.current.state.pinion_pitting;
  const auto& comb = r.combined_depth_m;
  if (comb.size() < 2 || pit.size() != comb.size()) return {};
  json fraction = json::array(), depth = json::array(), pitting = json::array();
  for (int k = 0; k <= 10; ++k) {
    const auto i = static_cast<std::size_t>(std::lround(k / 10.0 * static_cast<double>(comb.size() - 1)));
    fraction.push_back(k / 10.0);
    depth.push_back(comb[i]);
    pitting.push_back(pit[i]);
  }
  return json{{"profile_fraction", fraction}, {"combined_depth_m", depth}, {"pinion_pitting", pitting}}.dump();
}

std::string forecast_json(const wear::Forecast& f) {
  if (!f.valid) return {};
  json curve = json::array();
  for (const auto& p : f.curve)
    curve.push_back({{"cycles", p.cycles}, {"max_depth_m", p.max_depth_m}, {"mean_depth_m", p.mean_depth_m}, {"mean_pitting", p.mean_pitting}});
  return curve.dump();
}

std::string cycles_text(const std::optional<double>& c) {
  if (!c) return "beyond the horizon";
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", *c);
  return b;
}

}  // namespace

int model_channel(const config::GearwatchConfig& c) {
  if (c.model.channel >= 0) return c.model.channel;
  return c.rig.channels.empty() ? 0 : c.rig.channels.front().number;
}

ModelInput model_input(const storage::RecordResult& record, const config::GearwatchConfig& config) {
  ModelInput in;
  in.stream_sequence = record.stream_sequence;
  in.start_index = record.start_index;
  auto& o = in.observation;
  o.cycles = record.input_revolutions.value_or(kNaN);
  o.speed_hz = record.speed_hz;
  o.torque_nm = record.torque_nm;
  const int channel = model_channel(config);
  for (const auto& ch : record.channels) {
    if (ch.channel != channel) continue;
    for (const auto& [name, v] : ch.values) {
      if (name == dsp::to_string(dsp::Indicator::rms_sa)) o.rms_sa = v;
      else if (name == dsp::to_string(dsp::Indicator::ics2_low_band)) o.ics2_low = v;
      else if (name == dsp::to_string(dsp::Indicator::input_speed_hz) && !std::isfinite(o.speed_hz)) o.speed_hz = v;
    }
  }
  return in;
}

std::deque<ModelInput> stored_backlog(const std::string& database_path, const config::GearwatchConfig& config) {
  storage::Database db(database_path, storage::Database::Mode::read_only);
  std::deque<ModelInput> backlog;
  const storage::GearPairInputs pair_inputs = storage::load_gear_pair_inputs(db);
  const GearPairHistory pairs = decide_gear_pairs(pair_inputs.records, pair_inputs.resets);
  std::set<std::int64_t> after_reset;  // the records a recorded reset came just before
  for (std::size_t i = 0; i < pairs.boundaries.size(); ++i)
    if (pairs.boundaries[i] == PairBoundary::life_counter_reset) after_reset.insert(pair_inputs.record_ids[i]);
  for (const auto& stored : storage::load_records_after_newest_model_run(db, model_channel(config))) {
    ModelInput in = model_input(stored.record, config);
    in.stored_record_id = stored.record_id;
    in.life_counter_reset_before = after_reset.count(stored.record_id) > 0;
    in.sample_rate_hz = stored.sample_rate_hz;  // as the processing thread gives it for a live record
    backlog.push_back(std::move(in));
  }
  return backlog;
}

twin::GearboxParameters model_twin_parameters(const config::GearwatchConfig& config) {
  std::error_code ec;
  return std::filesystem::is_regular_file(config.source_path, ec) ? config::load_twin_parameters(config.source_path)
                                                                  : twin::GearboxParameters{};
}

wear::ModelSettings model_settings(const config::GearwatchConfig& config) {
  const auto& m = config.model;
  wear::ModelSettings s;
  s.loop.k_wear_si = wear::k_wear_si_from_seed(m.initial_k_wear);
  s.loop.k_pitting = m.initial_k_pitting;
  s.loop.force_model = m.force_model;
  s.loop.simulation.sample_rate_hz = config.rig.sample_rate_hz;
  s.rms_threshold = m.update_threshold;
  s.convergence_tolerance = m.convergence_tolerance;
  s.max_wear_iterations = m.max_wear_iterations;
  s.k_wear_update = m.k_wear_update;
  s.pitting_growth_law = m.pitting_growth_law;
  s.pitting_exponent_from_inspections = m.pitting_exponent_from_inspections;
  s.min_wear_elasticity = m.min_wear_elasticity;
  s.commissioning_records = m.commissioning_records;
  s.pitting_reference_torque_nm = m.pitting_reference_torque_nm;
  s.correlation_threshold = m.correlation_threshold;
  s.pitting_interval_cycles = m.pitting_interval_cycles;
  s.min_torque_nm = m.min_torque_nm;
  s.max_torque_nm = m.max_torque_nm;
  s.min_speed_hz = config.rig.min_speed_hz;
  s.max_speed_hz = config.rig.max_speed_hz;
  // Tooth thickness on the pitch circle: π m / 2.
  s.wear_limit_m = m.wear_limit_fraction * 3.14159265358979323846 * config.rig.gears.module_m / 2.0;
  s.pitting_limit = m.pitting_limit;
  s.forecast_horizon_cycles = m.forecast_horizon_cycles;
  s.prior_log_k_wear_sd = m.prior_log_k_wear_sd;
  s.log_k_drift_per_million_cycles = m.log_k_drift_per_million_cycles;
  s.rms_sa_relative_sd_floor = m.rms_sa_relative_sd_floor;
  s.inspection_area_relative_sd = m.inspection_area_relative_sd;
  s.inspection_depth_relative_sd = m.inspection_depth_relative_sd;
  s.disagreement_records = m.disagreement_records;
  s.ics2_onset_records = m.ics2_onset_records;
  s.ics2_saturation = wear::ics2_saturation_level(config.processing.ics2_harmonics);   // the analyser's H
  return s;
}

namespace {
json gears_json(const GearPairSpec& g) {
  return {{"pinion_teeth", g.pinion_teeth}, {"gear_teeth", g.gear_teeth}, {"module_m", g.module_m},
          {"pressure_angle_deg", g.pressure_angle_deg}, {"face_width_m", g.face_width_m}, {"youngs_modulus_pa", g.youngs_modulus_pa},
          {"poisson_ratio", g.poisson_ratio}, {"density_kg_m3", g.density_kg_m3}, {"addendum_coefficient", g.addendum_coefficient},
          {"dedendum_coefficient", g.dedendum_coefficient}};
}

GearPairSpec gears_from(const json& j) {
  GearPairSpec g;
  g.pinion_teeth = j.at("pinion_teeth").get<int>();
  g.gear_teeth = j.at("gear_teeth").get<int>();
  g.module_m = j.at("module_m").get<double>();
  g.pressure_angle_deg = j.at("pressure_angle_deg").get<double>();
  g.face_width_m = j.at("face_width_m").get<double>();
  g.youngs_modulus_pa = j.at("youngs_modulus_pa").get<double>();
  g.poisson_ratio = j.at("poisson_ratio").get<double>();
  g.density_kg_m3 = j.at("density_kg_m3").get<double>();
  g.addendum_coefficient = j.at("addendum_coefficient").get<double>();
  g.dedendum_coefficient = j.at("dedendum_coefficient").get<double>();
  return g;
}
}  // namespace

std::string gear_pair_text(const GearPairSpec& g) {
  char b[160];
  std::snprintf(b, sizeof b, "%d/%d teeth, module %.4g mm, face %.4g mm, pressure angle %.4g deg", g.pinion_teeth, g.gear_teeth,
                g.module_m * 1e3, g.face_width_m * 1e3, g.pressure_angle_deg);
  return b;
}

bool same_gear_pair(const GearPairSpec& a, const GearPairSpec& b) { return gears_json(a) == gears_json(b); }

PairStart pair_start_from_json(const std::string& text) {
  try {
    const json j = json::parse(text);
    PairStart p;
    if (!j.contains("pair")) return p;
    const json& o = j.at("pair");
    p.origin_cycles = o.at("origin_cycles").get<double>();
    p.reason = o.at("reason").get<std::string>();
    if (o.contains("gears")) p.gears = gears_from(o.at("gears"));
    return p;
  } catch (const json::exception& e) {
    throw std::runtime_error(std::string("model state is not readable: ") + e.what());
  }
}

std::string memory_to_json(const wear::ModelMemory& m, const PairStart* pair) {
  json intervals = json::array();
  for (const auto& i : m.intervals) intervals.push_back({i.end_cycles, i.speed_hz, i.torque_nm, i.k_wear_si, i.k_pitting});
  json k_history = json::array();
  for (const auto& h : m.k_wear_history) k_history.push_back({h.end_cycles, h.k});
  json points = json::array();
  for (const auto& p : m.pitting_points) points.push_back({p.cycles, p.ics2, p.density});
  json ops = json::array();
  for (const auto& p : m.recent_operating_points) ops.push_back({p[0], p[1]});
  json residuals = json::array();
  json reference_records = json::array();
  for (const auto& r : m.rms_sa_reference_records) reference_records.push_back({r[0], r[1]});
  json depth_points = json::array();
  for (const auto& d : m.depth_ratio_points)
    depth_points.push_back({{"inspection_id", d.inspection_id}, {"cycles", d.cycles}, {"log_ratio", d.log_ratio}, {"var", d.var}, {"model_m", d.model_m}});
  for (const auto& r : m.rms_residuals) residuals.push_back({r[0], r[1]});
  json j{{"format", 1},
               {"started", m.started},
               {"current", snapshot_json(m.current)},
               {"wear_anchor", snapshot_json(m.wear_anchor)},
               {"pitting_anchor", snapshot_json(m.pitting_anchor)},
               {"k_wear_si", m.k_wear_si},
               {"k_pitting", m.k_pitting},
               {"intervals", intervals},
               {"k_wear_history", k_history},
               {"pitting_points", points},
               {"pitting_calibrated", m.pitting_calibrated},
               {"calibration_inspection_id", m.calibration_inspection_id},
               {"ics2_scale", {{"valid", m.ics2_scale_valid}, {"ics2", m.ics2_scale_ics2}, {"density", m.ics2_scale_density},
                               {"slope", m.ics2_scale_slope}, {"inspections", m.ics2_scale_inspections},
                               {"baseline_sd", m.ics2_scale_baseline_sd}, {"density_1", m.ics2_scale_density_1},
                               {"form", wear::to_string(m.ics2_scale_form)}, {"baseline", m.ics2_scale_baseline}}},
               {"k_wear_last_insensitive", m.k_wear_last_insensitive},
               {"k_wear_elasticity", m.k_wear_elasticity},
               {"k_wear_identified_si", m.k_wear_identified_si},
               {"profile_shape", {{"depth_ratio", m.shape_depth_ratio}, {"peak_ratio", m.shape_peak_ratio},
                                  {"depth_elasticity", m.shape_depth_elasticity}, {"cycles", m.shape_cycles}}},
               {"depth_ratio_points", depth_points},
               {"rms_sa_reference", {{"ratio", m.rms_sa_reference_ratio}, {"records", reference_records}, {"closed", m.rms_sa_reference_closed}}},
               {"log_k_wear", posterior_json(m.log_k_wear)},
               {"log_k_pitting", posterior_json(m.log_k_pitting)},
               {"rms_residuals", residuals},
               {"pitting_calibration_var", m.pitting_calibration_var},
               {"scale_residual", {{"sum_sq", m.scale_residual_sum_sq}, {"count", m.scale_residual_count}}},
               {"last_ics2_calibration_cycles", m.last_ics2_calibration_cycles},
               {"recent_k_wear", m.recent_k_wear},
               {"recent_k_pitting", m.recent_k_pitting},
               {"recent_operating_points", ops},
               {"records_used", m.records_used},
               {"k_wear_updates", m.k_wear_updates},
               {"k_pitting_updates", m.k_pitting_updates}};
  if (pair) {
    json& p = j["pair"] = {{"origin_cycles", pair->origin_cycles}, {"reason", pair->reason}};
    if (pair->gears) p["gears"] = gears_json(*pair->gears);
  }
  return j.dump();
}

wear::ModelMemory memory_from_json(const std::string& text) {
  try {
    const json j = json::parse(text);
    if (j.at("format").get<int>() != 1) throw std::runtime_error("unknown state format " + j.at("format").dump());
    wear::ModelMemory m;
    m.started = j.at("started").get<bool>();
    m.current = snapshot_from(j.at("current"));
    m.wear_anchor = snapshot_from(j.at("wear_anchor"));
    m.pitting_anchor = snapshot_from(j.at("pitting_anchor"));
    m.k_wear_si = j.at("k_wear_si").get<double>();
    m.k_pitting = j.at("k_pitting").get<double>();
    for (const auto& i : j.at("intervals"))
      m.intervals.push_back({i.at(0).get<double>(), i.at(1).get<double>(), i.at(2).get<double>(), i.at(3).get<double>(), i.at(4).get<double>()});
    // Added with the K_wear history: an older state has the intervals since the older anchor only.
    for (const auto& h : j.value("k_wear_history", json::array())) m.k_wear_history.push_back({h.at(0).get<double>(), h.at(1).get<double>()});
    for (const auto& p : j.at("pitting_points")) m.pitting_points.push_back({p.at(0).get<double>(), p.at(1).get<double>(), p.at(2).get<double>()});
    m.pitting_calibrated = j.at("pitting_calibrated").get<bool>();
    m.calibration_inspection_id = j.at("calibration_inspection_id").get<std::int64_t>();
    const json& sc = j.at("ics2_scale");
    m.ics2_scale_valid = sc.at("valid").get<bool>();
    m.ics2_scale_ics2 = sc.at("ics2").get<double>();
    m.ics2_scale_density = sc.at("density").get<double>();
    m.ics2_scale_slope = sc.at("slope").get<double>();
    // Fields added with the posterior (issue 34): an older state lacks them, and gets the defaults.
    m.ics2_scale_inspections = sc.value("inspections", m.ics2_scale_valid ? 2 : 0);
    m.ics2_scale_baseline_sd = sc.value("baseline_sd", 0.0);
    m.ics2_scale_density_1 = sc.value("density_1", 0.0);
    // Added with the square-root one-inspection scale: an older state's scale is linear.
    const auto form = wear::ics2_scale_form_from_string(sc.value("form", std::string("linear")));
    if (!form) throw std::runtime_error("unknown ICS2 scale form " + sc.at("form").dump());
    m.ics2_scale_form = *form;
    m.ics2_scale_baseline = sc.value("baseline", 0.0);
    m.k_wear_last_insensitive = j.value("k_wear_last_insensitive", false);
    m.k_wear_elasticity = j.value("k_wear_elasticity", 1.0);
    // Added with the upper-bound rule: an older state's K_wear is its last identified one.
    m.k_wear_identified_si = j.value("k_wear_identified_si", m.k_wear_si);
    // Added with the profile-shape term: an older state has none until its next kept K_wear update.
    if (j.contains("profile_shape")) {
      const json& ps = j.at("profile_shape");
      m.shape_depth_ratio = ps.at("depth_ratio").get<double>();
      m.shape_peak_ratio = ps.at("peak_ratio").get<double>();
      m.shape_depth_elasticity = ps.at("depth_elasticity").get<double>();
      m.shape_cycles = ps.at("cycles").get<double>();
    }
    // Added with the depth calibration: an older state has read no inspected depth.
    for (const json& d : j.value("depth_ratio_points", json::array()))
      m.depth_ratio_points.push_back({d.at("inspection_id").get<std::int64_t>(), d.at("cycles").get<double>(),
                                      d.at("log_ratio").get<double>(), d.at("var").get<double>(),
                                      d.value("model_m", 0.0)});   // added with the rate reading: older states read no rate
    // Added with the commissioning ratio: an older state has none (1, closed: its pair is past commissioning).
    if (j.contains("rms_sa_reference")) {
      const json& ref = j.at("rms_sa_reference");
      m.rms_sa_reference_ratio = ref.at("ratio").get<double>();
      for (const auto& r : ref.at("records")) m.rms_sa_reference_records.push_back({r.at(0).get<double>(), r.at(1).get<double>()});
      m.rms_sa_reference_closed = ref.at("closed").get<bool>();
    } else {
      m.rms_sa_reference_closed = m.started;
    }
    m.log_k_wear = posterior_from(j, "log_k_wear");
    m.log_k_pitting = posterior_from(j, "log_k_pitting");
    if (j.contains("rms_residuals"))
      for (const auto& r : j.at("rms_residuals")) m.rms_residuals.push_back({r.at(0).get<double>(), r.at(1).get<double>()});
    m.pitting_calibration_var = j.value("pitting_calibration_var", 0.0);
    if (j.contains("scale_residual")) {
      m.scale_residual_sum_sq = j.at("scale_residual").at("sum_sq").get<double>();
      m.scale_residual_count = j.at("scale_residual").at("count").get<std::uint64_t>();
    }
    m.last_ics2_calibration_cycles = j.value("last_ics2_calibration_cycles", -1.0);
    m.recent_k_wear = j.at("recent_k_wear").get<std::vector<double>>();
    m.recent_k_pitting = j.at("recent_k_pitting").get<std::vector<double>>();
    for (const auto& p : j.at("recent_operating_points")) m.recent_operating_points.push_back({p.at(0).get<double>(), p.at(1).get<double>()});
    m.records_used = j.at("records_used").get<std::uint64_t>();
    m.k_wear_updates = j.at("k_wear_updates").get<std::uint64_t>();
    m.k_pitting_updates = j.at("k_pitting_updates").get<std::uint64_t>();
    return m;
  } catch (const json::exception& e) {
    throw std::runtime_error(std::string("model state is not readable: ") + e.what());
  }
}

StoredModel load_model(const std::string& database_path) {
  StoredModel out;
  storage::Database db(database_path, storage::Database::Mode::read_only);
  if (const auto stored = storage::load_newest_model_state(db)) {
    out.gear_pair = stored->gear_pair;
    try {
      out.memory = memory_from_json(stored->state_json);
      out.pair = pair_start_from_json(stored->state_json);
      out.found = true;
    } catch (const std::exception& e) {
      out.problem = e.what();
    }
  } else {
    out.gear_pair = storage::count_life_counter_resets(db);
  }
  // The ICS2 series is not in the state (it only grows): the stored runs hold it, exactly.
  if (out.found) out.memory.ics2_series = storage::load_advanced_ics2_series(db, out.gear_pair);
  out.alerts = storage::load_alert_states(db, {AlertKind::remaining_life, AlertKind::twin_drift});
  return out;
}

wear::RmsSaSimulator rms_sa_simulator_at_record_rate(const twin::GearboxParameters& params, const config::GearwatchConfig& config,
                                                     const double& rate_hz) {
  return [params, rig = config.rig, processing = config.processing, revolutions = config.model.simulation_revolutions,
          &rate_hz](const wear::WearState& state, const twin::OperatingPoint& op) {
    GearboxSpec at_rate = rig;
    if (rate_hz > 0) at_rate.sample_rate_hz = rate_hz;
    return wear::twin_rms_sa_simulator(params, at_rate, processing, revolutions)(state, op);
  };
}

ModelThread::ModelThread(const config::GearwatchConfig& config, storage::StorageWriter& writer, bool lossless, GapHooks gap)
    : config_(config), writer_(writer), lossless_(lossless), gap_(std::move(gap)) {}

ModelThread::~ModelThread() {
  if (thread_.joinable()) stop();
}

void ModelThread::start() {
  params_ = model_twin_parameters(config_);
  settings_ = model_settings(config_);
  // Built for each record at its rate; built once here so a bad model.simulation_revolutions stops the start.
  (void)wear::twin_rms_sa_simulator(params_, config_.rig, config_.processing, config_.model.simulation_revolutions);
  simulator_ = rms_sa_simulator_at_record_rate(params_, config_, record_rate_hz_);
  const twin::GearboxParameters& params = params_;
  StoredModel stored = load_model(config_.storage.database);
  backlog_ = stored_backlog(config_.storage.database, config_);
  if (!backlog_.empty())
    spdlog::warn("model: {} stored records were not handled by the model before (a crash, or the model was off); handling them first",
                 backlog_.size());
  gear_pair_ = stored.gear_pair;
  pair_ = stored.pair;
  if (stored.found && !pair_.gears) pair_.gears = params_.gears;  // a state stored before the pair was kept: this configuration's
  alerts_ = AlertTracker(std::move(stored.alerts));
  if (!stored.problem.empty())
    spdlog::error("model: the stored state of gear pair {} cannot be used ({}); starting from an unworn pair", gear_pair_, stored.problem);
  try {
    model_ = std::make_unique<wear::TwinModel>(params_, settings_, simulator_, stored.found ? stored.memory : wear::ModelMemory{});
  } catch (const twin::TwinParameterError& e) {
    if (!stored.found) throw;
    spdlog::error("model: the stored state of gear pair {} does not fit this configuration ({}); starting from an unworn pair",
                  gear_pair_, e.what());
    stored.found = false;
    stored.problem = std::string("it does not fit this configuration: ") + e.what();
    model_ = std::make_unique<wear::TwinModel>(params_, settings_, simulator_);
  }
  plan_pair_start(stored);
  if (config_.gap.enabled) {
    if (!gap_.diagnose) gap_.diagnose = make_gap_diagnoser(config_, params);
    if (!gap_.diagnose)
      throw std::runtime_error("gap.enabled = true, but this build of gearwatch has no sim-to-real gap diagnosis to run");
    // The rerun is bound only with the configured counterpart: an injected twin brings its own (or none).
    if (!gap_.twin) {
      gap_.twin = make_twin_counterpart(params, config_);
      if (!gap_.rerun) gap_.rerun = make_twin_rerun(params, config_);
    }
    gap_schedule_.emplace(config_.gap.every_records, config_.gap.training_records, config_.gap.held_out_records);
    restore_gap_schedule();
  }
  if (stored.found && !pending_pair_)
    spdlog::info("model: gear pair {} continues at {:.6g} cycles (K_wear {:.4g} m²/N, K_pitting {:.4g})", gear_pair_,
                 model_->memory().current.state.cycles, model_->memory().k_wear_si, model_->memory().k_pitting);
  thread_ = std::thread([this] { run(); });
}

void ModelThread::plan_pair_start(const StoredModel& stored) {
  if (!stored.found && stored.problem.empty()) {
    // The thesis rig's life counter starts at 0 with its pair (the protocol): it counts that pair.
    // Another pair's counter (a DAQ's, a converted recording's) says nothing of the pair's past.
    const bool thesis_pair = same_gear_pair(params_.gears, GearPairSpec{});
    pending_pair_ = PendingPair{thesis_pair ? "the first gear pair of this database, the thesis rig's: its life counter counts its cycles"
                                            : "the first gear pair of this database; its count before this record is not known",
                                thesis_pair, false};
  } else if (!stored.found) {
    // Its number is kept, as before there was a pair start: the unusable state's row is replaced.
    pending_pair_ = PendingPair{"the stored state of gear pair " + std::to_string(gear_pair_) + " could not be used (" + stored.problem + ")",
                                false, false};
  } else if (stored.pair.gears && !same_gear_pair(*stored.pair.gears, params_.gears)) {
    // A changed [gears] is another gear pair: nothing the model knows of the stored one applies.
    pending_pair_ = PendingPair{"the configured gear pair (" + gear_pair_text(params_.gears) + ") is not the stored pair's (" +
                                    gear_pair_text(*stored.pair.gears) + ")",
                                false, true};
    model_ = std::make_unique<wear::TwinModel>(params_, settings_, simulator_);
  }
  if (pending_pair_ && pending_pair_->new_number)
    spdlog::warn("model: a new gear pair starts at the next record: {}", pending_pair_->reason);
}

std::string ModelThread::place_on_pair(wear::ModelObservation& obs, storage::ModelRunResult& msg) {
  if (!std::isfinite(obs.cycles) || obs.cycles < 0) return {};  // the model reports it as missing_cycles
  const wear::ModelMemory& m = model_->memory();
  const double counter = obs.cycles;
  // The previous count is the record the model last advanced to, on the counter's axis.
  const std::optional<double> previous = m.started ? std::optional(pair_.origin_cycles + m.current.state.cycles) : std::nullopt;
  const PairBoundary boundary = pair_boundary({previous, counter, std::exchange(reset_recorded_, false)});
  if (!pending_pair_ && boundary != PairBoundary::none) {
    char b[160];
    if (previous && counter < *previous)
      std::snprintf(b, sizeof b, "the life counter went backwards from %.0f to %.0f", *previous, counter);
    else
      std::snprintf(b, sizeof b, "a life-counter reset was recorded before this record (life counter %.0f)", counter);
    pending_pair_ = PendingPair{b, true, true};
  }
  std::string note;
  if (pending_pair_) {
    pair_ = PairStart{pending_pair_->counted_by_life_counter ? 0.0 : counter, pending_pair_->reason, params_.gears};
    model_ = std::make_unique<wear::TwinModel>(params_, settings_, simulator_);
    if (pending_pair_->new_number) {
      ++gear_pair_;
      // The records kept for the next diagnosis belong to the old pair's wear states.
      if (gap_schedule_) gap_schedule_.emplace(config_.gap.every_records, config_.gap.training_records, config_.gap.held_out_records);
      msg.alerts = alerts_.clear_all(AlertKind::remaining_life, "new gear pair: the remaining life belonged to the previous pair");
    }
    char b[200];
    std::snprintf(b, sizeof b, "gear pair %lld (%s) starts here, its cycle 0 at life counter %.0f: ", static_cast<long long>(gear_pair_),
                  gear_pair_text(params_.gears).c_str(), pair_.origin_cycles);
    note = b + pair_.reason;
    spdlog::info("model: {}", note);
    pending_pair_.reset();
  }
  obs.cycles = counter - pair_.origin_cycles;
  return note;
}

void ModelThread::submit(ModelInput input) {
  std::unique_lock lock(mutex_);
  ++counters_.received;
  const std::size_t capacity = config_.model.queue_capacity;
  if (queue_.size() >= capacity) {
    if (lossless_) {
      not_full_.wait(lock, [&] { return queue_.size() < capacity || terminate_; });
    } else {
      // Behind: coalesce to the newest record; the dropped ones are named in the next stored run.
      for (const auto& q : queue_) {
        input.life_counter_reset_before = input.life_counter_reset_before || q.life_counter_reset_before;  // the reset stays
        ++pending_skipped_;
        if (!pending_skipped_ids_.empty()) pending_skipped_ids_ += ",";
        pending_skipped_ids_ += std::to_string(q.stream_sequence) + ":" + std::to_string(q.start_index);
      }
      const auto dropped = counters_.coalesced.fetch_add(queue_.size()) + queue_.size();
      if (dropped == queue_.size() || dropped % kCoalescedLogEvery < queue_.size())
        spdlog::warn("model: behind the records; {} coalesced to the newest so far", dropped);
      queue_.clear();
    }
  }
  queue_.push_back(std::move(input));
  if (queue_.size() > counters_.queue_high_water) counters_.queue_high_water = queue_.size();
  lock.unlock();
  not_empty_.notify_one();
}

void ModelThread::stop() {
  {
    std::lock_guard lock(mutex_);
    terminate_ = true;
  }
  not_empty_.notify_all();
  not_full_.notify_all();
  if (thread_.joinable()) thread_.join();
  spdlog::info("model: {} records received, {} handled ({} of them stored before this start), {} coalesced, {} failed",
               counters_.received.load(), counters_.handled.load(), counters_.caught_up.load(), counters_.coalesced.load(),
               counters_.failures.load());
  if (gap_schedule_)
    spdlog::info("model: {} gap reports stored ({} without K_wear), {} gap diagnoses failed, {} records without the gap channel",
                 counters_.gap_reports.load(), counters_.gap_k_wear_skipped.load(), counters_.gap_failures.load(),
                 counters_.gap_records_without_channel.load());
}

void ModelThread::run() {
  // The model is the least urgent work in the daemon: it must never take the CPU from acquisition.
  if (config_.daemon.processing_nice > 0 && ::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), kModelThreadNice) != 0)
    spdlog::warn("model: could not lower the model thread's priority");
  // The stored backlog first, in storage order: it precedes everything submitted.
  for (; !backlog_.empty(); backlog_.pop_front()) {
    handle(backlog_.front(), 0, "");
    ++counters_.caught_up;
  }
  for (;;) {
    ModelInput in;
    std::uint64_t skipped = 0;
    std::string skipped_ids;
    {
      std::unique_lock lock(mutex_);
      not_empty_.wait(lock, [&] { return !queue_.empty() || terminate_; });
      if (queue_.empty()) break;  // terminate, drained
      in = std::move(queue_.front());
      queue_.pop_front();
      skipped = pending_skipped_;
      skipped_ids.swap(pending_skipped_ids_);
      pending_skipped_ = 0;
    }
    not_full_.notify_all();
    handle(in, skipped, skipped_ids);
  }
  counters_.cpu_ns = thread_cpu_ns();
}

void ModelThread::handle(const ModelInput& input, std::uint64_t skipped, const std::string& skipped_ids) {
  storage::ModelRunResult msg;
  wear::ModelObservation observation = input.observation;
  reset_recorded_ = reset_recorded_ || input.life_counter_reset_before;
  const std::string pair_note = place_on_pair(observation, msg);
  const std::vector<wear::Inspection> inspections = read_inspections();
  msg.stream_sequence = input.stream_sequence;
  msg.start_index = input.start_index;
  msg.stored_record_id = input.stored_record_id;
  msg.skipped_records = skipped;
  msg.skipped_record_ids = skipped_ids;
  record_rate_hz_ = input.sample_rate_hz;
  msg.report = observe(input, observation, inspections);
  ++counters_.handled;
  if (!pair_note.empty()) msg.report.detail = pair_note + (msg.report.detail.empty() ? "" : "; " + msg.report.detail);
  const wear::ModelRunReport& r = msg.report;
  log_report(r, input.observation.cycles);
  if (r.new_gear_pair) start_new_gear_pair(msg);
  msg.gear_pair = gear_pair_;
  if (r.advanced && r.forecast.valid) observe_remaining_life(r, msg);
  msg.alert_states = alerts_.take_changed();
  msg.profile_json = profile_json(r, model_->memory());
  msg.forecast_json = forecast_json(r.forecast);
  msg.store_state = r.advanced || r.new_gear_pair || !pair_note.empty();
  if (msg.store_state) msg.state_json = memory_to_json(model_->memory(), &pair_);
  // The twin's counterpart needs the wear state at this record: only a record the model advanced to has one.
  const bool gap_due = gap_schedule_ && input.samples && r.advanced && add_gap_sample(input, msg);
  writer_.submit(std::move(msg));
  if (gap_due) {
    const std::uint64_t start = thread_cpu_ns();
    diagnose_gap();
    counters_.gap_cpu_ns += thread_cpu_ns() - start;
  }
}

// The installed pair's inspections on the pair's cycle axis; none this time if the database cannot be read.
std::vector<wear::Inspection> ModelThread::read_inspections() const {
  std::vector<wear::Inspection> inspections;
  try {
    storage::Database db(config_.storage.database, storage::Database::Mode::read_only);
    for (const auto& stored : storage::load_gear_pair_inspections(db, gear_pair_)) {
      wear::Inspection i;
      i.id = stored.id;
      i.cycles = stored.cycles - pair_.origin_cycles;  // inspections keep the life counter's cycles
      i.pitted_area = stored.pitted_area_fraction;
      i.wear_depth_m = stored.wear_depth_m;
      i.wear_depth_max_m = stored.wear_depth_max_m;
      i.wear_depth_relative_sd = stored.wear_depth_relative_sd;
      inspections.push_back(i);
    }
  } catch (const storage::SqliteError& e) {
    spdlog::warn("model: inspections not read this time: {}", e.what());
  }
  return inspections;
}

// The model's step on one record: observe() does not throw on bad data; anything else is logged and
// stored, and the model goes on.
wear::ModelRunReport ModelThread::observe(const ModelInput& input, const wear::ModelObservation& observation,
                                          const std::vector<wear::Inspection>& inspections) {
  try {
    return model_->observe(observation, inspections);
  } catch (const std::exception& e) {
    const auto n = ++counters_.failures;
    if (log_occurrence(n)) spdlog::error("model: record at {} cycles not handled ({} so far): {}", input.observation.cycles, n, e.what());
    wear::ModelRunReport failed;
    failed.observation = observation;
    failed.detail = std::string("not handled: ") + e.what();
    return failed;
  }
}

void ModelThread::log_report(const wear::ModelRunReport& r, double cycles) {
  for (const auto issue : r.issues) {
    const auto n = ++issue_counts_[issue];  // each kind logged once, then every 1000th
    if (log_first_occurrence(n)) spdlog::warn("model: {} (record at {:.6g} cycles; {} so far): {}", wear::to_string(issue), cycles, n, r.detail);
  }
  for (const auto& u : r.updates)
    spdlog::info("model: {} {} ({}): {}", wear::to_string(u.kind), wear::to_string(u.outcome), wear::to_string(u.trigger), u.evidence);
}

void ModelThread::start_new_gear_pair(storage::ModelRunResult& msg) {
  // The model saw its cycles go backwards on the pair's axis (place_on_pair catches the counter's first).
  pair_ = PairStart{0.0, "the model's cycles went backwards", params_.gears};
  ++gear_pair_;
  // The records kept for the next diagnosis belong to the old pair's wear states.
  if (gap_schedule_) gap_schedule_.emplace(config_.gap.every_records, config_.gap.training_records, config_.gap.held_out_records);
  auto cleared = alerts_.clear_all(AlertKind::remaining_life, "new gear pair: the remaining life belonged to the previous pair");
  msg.alerts.insert(msg.alerts.end(), cleared.begin(), cleared.end());
}

// Remaining-life alerts on both limits, with the configured hysteresis.
void ModelThread::observe_remaining_life(const wear::ModelRunReport& r, storage::ModelRunResult& msg) {
  const AlertHysteresis h{config_.model.remaining_life_raise_after_records, config_.model.remaining_life_clear_after_records};
  const double threshold = config_.model.remaining_life_alert_cycles;
  auto observe_limit = [&](const char* subject, const wear::LimitForecast& lf, const char* what, double scale, const char* unit) {
    // Near: the nominal forecast, or a limit the measured ICS2 estimate has reached already.
    const bool reached = &lf == &r.forecast.pitting &&
                         std::count(r.forecast.flags.begin(), r.forecast.flags.end(), wear::ForecastFlag::pitting_limit_reached_by_ics2) > 0;
    const bool near = (lf.cycles_left && *lf.cycles_left < threshold) || reached;
    char text[400];
    std::snprintf(text, sizeof text, "%s limit %.4g %s: %s cycles left (%.0f %% interval %s to %s) at %.3g Hz, %.3g N m; alert below %.4g",
                  what, lf.limit * scale, unit, cycles_text(lf.cycles_left).c_str(), 100 * r.forecast.coverage,
                  cycles_text(lf.cycles_left_low).c_str(), cycles_text(lf.cycles_left_high).c_str(), r.forecast.speed_hz,
                  r.forecast.torque_nm, threshold);
    // The value is the limit, not the cycles left: those change at every record, and a changed
    // value would be raised again each time.
    char value[48];
    std::snprintf(value, sizeof value, "%.4g %s", lf.limit * scale, unit);
    if (auto e = alerts_.observe(AlertKey{AlertKind::remaining_life, -1, subject}, near, value, text, h))
      msg.alerts.push_back(std::move(*e));
  };
  observe_limit("wear_depth", r.forecast.wear, "wear depth", 1e3, "mm");
  observe_limit("pitting_density", r.forecast.pitting, "pitting density", 100.0, "%");
}

void ModelThread::restore_gap_schedule() {
  storage::Database db(config_.storage.database, storage::Database::Mode::read_only);
  storage::StoredGapSchedule stored = storage::load_gap_schedule(db, gear_pair_);
  if (!stored.found) return;
  std::vector<GapSample> kept;
  for (auto& k : stored.kept) {
    GapSample s{std::make_shared<const Record>(std::move(k.record)), std::move(k.state), k.stream_sequence, 0, k.position};
    s.start_index = s.measured->start_index;
    kept.push_back(std::move(s));
  }
  gap_schedule_->restore(stored.counters.records_added, stored.counters.since_diagnosis, std::move(kept));
  spdlog::info("gap: gear pair {} continues its schedule: {} records since the last diagnosis, {} kept for the next", gear_pair_,
               gap_schedule_->since_diagnosis(), gap_schedule_->held());
}

bool ModelThread::add_gap_sample(const ModelInput& input, storage::ModelRunResult& msg) {
  std::optional<Record> kept = kept_gap_record(*input.samples, gap_channel(config_));
  if (!kept) {
    const auto n = ++counters_.gap_records_without_channel;
    if (log_occurrence(n))
      spdlog::warn("gap: record at {:.6g} cycles does not carry channel {}: not used by the gap step ({} so far)",
                   input.observation.cycles, gap_channel(config_), n);
    return false;
  }
  auto record = std::make_shared<const Record>(std::move(*kept));
  const wear::WearState& state = model_->memory().current.state;
  const GapSchedule::Step step = gap_schedule_->add(GapSample{record, state, input.stream_sequence, input.start_index, 0});
  storage::GapScheduleUpdate update;
  update.gear_pair = gear_pair_;
  update.counters = {gap_schedule_->records_added(), gap_schedule_->since_diagnosis()};
  update.drop_through_position = step.drop_through_position;
  if (step.keep) update.keep = storage::KeptGapRecord{step.position, input.stream_sequence, *record, state};
  msg.gap = std::move(update);
  return step.due;
}

void ModelThread::diagnose_gap() {
  const auto [training_samples, held_out_samples] = gap_schedule_->split();
  const GapSample& newest = gap_schedule_->newest();
  storage::GapReportResult msg;
  try {
    GapRun run = run_gap_diagnosis(gap_, training_samples, held_out_samples, model_->memory().k_wear_si, config_.rig.gears,
                                   config_.processing.rms_sa_harmonics);
    if (!run.k_wear_skipped.empty()) {
      const auto n = ++counters_.gap_k_wear_skipped;
      if (log_occurrence(n)) spdlog::warn("gap: report without K_wear ({} so far): {}", n, run.k_wear_skipped);
    }
    msg.report = std::move(run.report);
  } catch (const std::exception& e) {
    const auto n = ++counters_.gap_failures;
    if (log_occurrence(n))
      spdlog::error("gap: no diagnosis at {:.6g} cycles ({} failed so far): {}", newest.measured->input_revolutions.value_or(kNaN), n, e.what());
    return;
  }
  ++counters_.gap_reports;
  msg.stream_sequence = newest.stream_sequence;
  msg.start_index = newest.start_index;
  msg.gear_pair = gear_pair_;
  const AlertHysteresis h{config_.gap.drift_raise_after_reports, config_.gap.drift_clear_after_reports};
  msg.alerts = observe_twin_drift(alerts_, msg.report, h);
  msg.alert_states = alerts_.take_changed();
  std::string significant, chosen;
  for (const auto& g : msg.report.before)
    if (g.significant) significant += (significant.empty() ? "" : ", ") + std::string(gap::to_string(g.family));
  for (const auto e : msg.report.chosen) chosen += (chosen.empty() ? "" : ", ") + std::string(gap::to_string(e));
  spdlog::info("gap: report at {:.6g} cycles: significant {}; chosen {}; {} unexplained", msg.report.input_revolutions,
               significant.empty() ? "none" : significant, chosen.empty() ? "none" : chosen, msg.report.unexplained.size());
  for (const auto& e : msg.alerts) spdlog::warn("gap: twin_drift {} {}: {}", to_string(e.transition), e.key.subject, e.message);
  writer_.submit(std::move(msg));
}

}  // namespace gearwatch::daemon
