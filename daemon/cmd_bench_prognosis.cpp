// `gearwatch bench prognosis`: how good the model's prognosis is against the rig simulator's wear
// truth (docs/model.md, "Prognosis benchmark"). Each campaign is run end to end in this process,
// without files: the truth at every measured stop, the rig's record of it, the daemon's record
// processing and model on that record (the same construction as the daemon's threads), the
// engineer's inspections, and the scores against the truth (prognosis_scoring.hpp).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <thread>

#include <time.h>

#include <nlohmann/json.hpp>

#include "cli_common.hpp"
#include "commands.hpp"
#include "model_thread.hpp"
#include "prognosis_scoring.hpp"
#include "record_processing.hpp"
#include "gearwatch/rig/campaign.hpp"
#include "gearwatch/rig/rig_simulator.hpp"
#include "gearwatch/wear/updating.hpp"

namespace gearwatch::cli {
namespace {

namespace pg = daemon::prognosis;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// CPU time of the calling thread, s.
double thread_cpu_seconds() {
  timespec t{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// Where the campaigns come from: random campaigns (rig::random_campaign, wear truths in forms the
/// model does not share: regime-dependent K, Weibull pitting, contamination, a load change) or
/// the built-in ones (lubricated for odd seeds, dry for even ones, whose wear depth is the
/// project's own Archard model: a comparison, not a test of the model).
enum class CampaignSet : std::uint8_t { random, builtin };
const char* to_string(CampaignSet set) { return set == CampaignSet::random ? "random" : "builtin"; }

struct PrognosisOptions {
  int campaigns = 20;
  std::uint64_t seed = 1;
  int records = 0;           // 0: the campaign's own
  double seconds = 2.0;      // the indicators need 5 revolutions of the output shaft: 1.4 s at 10 Hz
  int jobs = 1;
  std::string config;
  std::string format = "table";
  double inspection_sd = 0.10;
  /// Relative SD of an inspection's combined mean wear depth (the thesis's mould, its LSCM profile):
  /// the truth's depth is measured with it, and the model is told it (the engineer states it).
  double inspection_depth_sd = 0.05;
  /// The wear limit (deepest flank point) of the model and of the scores. The random campaigns'
  /// truths are drawn to the thesis's depths, 10–40 µm combined mean at their last record, whose
  /// deepest point (the closed-form Archard shape, 3.6 times the mean) ends at 35–142 µm: the
  /// daemon's scrapping limit of 314 µm (10 % of the tooth thickness) is beyond every campaign, so
  /// half of it, where the wear forecasts are scored, is never reached and the score has no data.
  /// 100 µm lies inside the drawn range: a scenario for the score, not a target.
  double wear_limit_um = 100.0;
  CampaignSet campaign_set = CampaignSet::random;
};

/// The targets (issue 34): depth within 5 % after the first two K_wear updates, cycles left
/// within 20 %, the nominal 90 % interval holding the truth in ≥ 85 % of forecasts, and no interval
/// that excludes a limit already reached.
constexpr double kDepthTarget = 0.05;
constexpr double kCyclesTarget = 0.20;
constexpr double kCoverageTarget = 0.85;
/// The engineer inspects at the first stop past 1 % pitted area, then at the first later one past 4 %.
const std::vector<double> kInspectionLevels{0.01, 0.04};
/// A maintenance plan also inspects for wear: at the first stop whose deepest flank point passes a
/// quarter of the wear limit, then at the first later one past half of it (a plan's rule, stated
/// before the fresh-seed run; campaigns that never pit are inspected too). These inspections take
/// the wear depths only: the pitting levels stay the pitted-area calibration points.
const std::vector<double> kWearInspectionFractions{0.25, 0.5};
/// Forecasts are scored from the first record where the truth's pitting density passes 5 % (resp.
/// its deepest flank point half the wear limit).
constexpr double kPittingScoreFrom = 0.05;
constexpr double kWearScoreFromFraction = 0.5;

/// What every campaign is measured with: the daemon's processing and model settings.
struct BenchSetup {
  config::GearwatchConfig config;
  twin::GearboxParameters params;
  wear::ModelSettings settings;
  int channel = 0;           // the model's accelerometer (protocol channel = the rig's channel index)
  PrognosisOptions options;
};

/// One campaign: its spec, its records in cycle order and the rig's effects.
struct CampaignCase {
  std::uint64_t seed = 0;
  rig::CampaignSpec spec;
  std::vector<rig::PlannedRecord> plan;
  rig::EffectSet effects;
};


/// The campaign of a seed; the seed also draws the effects' parameters and the noise.
CampaignCase make_campaign_case(std::uint64_t seed, int records, double seconds, CampaignSet set) {
  CampaignCase c;
  c.seed = seed;
  c.spec = set == CampaignSet::random ? rig::random_campaign(seed) : rig::builtin_campaign(seed % 2 == 1 ? rig::BuiltinCampaign::lubricated : rig::BuiltinCampaign::dry);
  if (records > 0) c.spec.records = records;
  c.spec.seconds = seconds;
  c.plan = rig::plan_records(c.spec);
  c.effects = rig::campaign_effects(c.spec, true, seed);
  return c;
}

double max_depth(const rig::WearState& w) {
  double m = 0;
  for (double d : w.profile.pinion) m = std::max(m, d);
  for (double d : w.profile.gear) m = std::max(m, d);
  return m;
}

struct StageSeconds {
  double truth = 0, simulate = 0, analyse = 0, observe = 0, score = 0;
};

struct CampaignResult {
  std::uint64_t seed = 0;
  std::string name;
  std::string failure;                    // "" = ran
  std::size_t records = 0;
  std::size_t k_wear_updates = 0;         // updates that changed K_wear
  std::size_t k_wear_update_attempts = 0; // every K_wear update the model started
  std::size_t inspections = 0;
  std::size_t depth_from_record = 0;      // first record whose depth is scored
  std::vector<double> depth_errors;
  std::size_t depth_interval_scored = 0;  // scored depth records with a depth interval
  std::size_t depth_interval_covered = 0; // of those, whose interval holds the truth's mean depth
  pg::LimitScore pitting, wear;
  std::optional<double> pitting_crossing, wear_crossing;   // the truth's, cycles
  StageSeconds stages;
  double seconds = 0;
  double cpu_seconds = 0;                 // of the thread that ran it (the wall time includes waiting for a core)
  nlohmann::json trace = nlohmann::json::array();   // per record: truth and model side by side
};

/// One campaign run through the daemon's processing and model, and scored.
class CampaignBench {
 public:
  CampaignBench(const BenchSetup& setup, CampaignCase c)
      : setup_(setup),
        case_(std::move(c)),
        processor_(setup.config),
        model_(setup.params, setup.settings,
               daemon::rms_sa_simulator_at_record_rate(setup.params, setup.config, record_rate_hz_)) {}

  CampaignResult run() {
    const auto t0 = Clock::now();
    const double cpu0 = thread_cpu_seconds();
    result_.seed = case_.seed;
    result_.name = case_.spec.name;
    plan();
    for (std::size_t i = 0; i < case_.plan.size(); ++i) {
      const Record record = simulate_record(i);
      observe(i, analyse(record));
    }
    score();
    trace();
    result_.seconds = seconds_since(t0);
    result_.cpu_seconds = thread_cpu_seconds() - cpu0;
    return std::move(result_);
  }

 private:
  /// The truth at every stop, and the engineer's inspections from it.
  void plan() {
    const auto t0 = Clock::now();
    auto truth = make_truth();
    std::vector<double> density;
    for (const auto& p : case_.plan) {
      states_.push_back(truth->at(p.cycles));
      density.push_back(states_.back().pitting_density);
    }
    // The pitted area, the combined mean wear depth and the deepest flank point measured with
    // relative errors of inspection_sd and inspection_depth_sd (normal), each from its own stream
    // seeded by the campaign; the inspection states the depths' SD.
    std::vector<double> deepest;
    for (const auto& st : states_) deepest.push_back(max_depth(st));
    std::vector<double> wear_levels;
    for (const double f : kWearInspectionFractions) wear_levels.push_back(f * setup_.settings.wear_limit_m);
    const std::vector<std::size_t> pitting_stops = pg::inspection_stops(density, kInspectionLevels);
    std::vector<std::size_t> stops = pitting_stops;
    for (const std::size_t stop : pg::inspection_stops(deepest, wear_levels)) stops.push_back(stop);
    std::sort(stops.begin(), stops.end());
    stops.erase(std::unique(stops.begin(), stops.end()), stops.end());
    std::mt19937_64 rng(case_.seed * 7919u + 17u), depth_rng(case_.seed * 7919u + 29u), deepest_rng(case_.seed * 7919u + 41u);
    const double depth_sd = setup_.options.inspection_depth_sd;
    std::normal_distribution<double> error(0.0, setup_.options.inspection_sd), depth_error(0.0, depth_sd);
    for (const std::size_t stop : stops) {
      wear::Inspection in;
      in.id = static_cast<std::int64_t>(inspections_.size() + 1);
      in.cycles = case_.plan[stop].cycles;
      if (std::find(pitting_stops.begin(), pitting_stops.end(), stop) != pitting_stops.end())
        in.pitted_area = std::clamp(density[stop] * (1.0 + error(rng)), 0.0, 1.0);
      in.wear_depth_m = std::max(0.0, states_[stop].combined_mean_wear_depth_m * (1.0 + depth_error(depth_rng)));
      in.wear_depth_max_m = std::max(0.0, deepest[stop] * (1.0 + depth_error(deepest_rng)));
      in.wear_depth_relative_sd = depth_sd;
      inspections_.push_back({stop, in});
    }
    result_.inspections = inspections_.size();
    result_.stages.truth += seconds_since(t0);
  }

  std::unique_ptr<rig::WearTruth> make_truth() const {
    return rig::make_wear_truth(case_.spec.wear, setup_.params, case_.spec.measurement_speeds_hz.front());
  }

  /// The rig's record at stop i, as the daemon's record assembler gives it from the capture: the
  /// model's channel in the capture's i16 steps, the encoder's edges, the front-end's speed and
  /// torque (floats), and the life counter.
  Record simulate_record(std::size_t i) {
    const auto t0 = Clock::now();
    const auto& p = case_.plan[i];
    const rig::RecordTruth truth = rig::record_truth(case_.spec, p, states_[i]);
    const rig::RigRunSettings run = rig::record_run_settings(case_.spec, p, case_.seed);
    rig::RigRecord rr = rig::simulate_record(setup_.params, case_.effects, truth.wear, truth.sliding, run);
    const auto channel = static_cast<std::size_t>(setup_.channel);
    if (channel >= rr.acceleration.size()) throw CommandError("the model's channel is not one the rig simulates");
    std::vector<float> samples = std::move(rr.acceleration[channel]);
    double lsb = setup_.config.rig.channels.front().scale_m_s2_per_lsb;
    for (const auto& c : setup_.config.rig.channels)
      if (c.number == setup_.channel) lsb = c.scale_m_s2_per_lsb;
    for (auto& x : samples) x = static_cast<float>(std::clamp(std::round(x / lsb), -32767.0, 32767.0) * lsb);
    Record r = single_channel_record(std::move(samples), std::move(rr.tacho_edges), rr.sample_rate_hz,
                                     static_cast<float>(run.speed_hz), static_cast<float>(run.torque_nm), setup_.channel);
    r.input_revolutions = static_cast<double>(truth.life_counter);
    result_.stages.simulate += seconds_since(t0);
    return r;
  }

  /// The daemon's record processing and the model's input built from it (daemon::model_input).
  daemon::ModelInput analyse(const Record& record) {
    const auto t0 = Clock::now();
    daemon::ModelInput in = daemon::model_input(processor_.process(record, true, 0), setup_.config);
    in.sample_rate_hz = record.sample_rate_hz;
    result_.stages.analyse += seconds_since(t0);
    return in;
  }

  /// The model on the record, with the inspections taken so far (one at this stop included).
  void observe(std::size_t i, const daemon::ModelInput& in) {
    const auto t0 = Clock::now();
    std::vector<wear::Inspection> taken;
    for (const auto& [stop, inspection] : inspections_)
      if (stop <= i) taken.push_back(inspection);
    record_rate_hz_ = in.sample_rate_hz;
    reports_.push_back(model_.observe(in.observation, taken));
    result_.stages.observe += seconds_since(t0);
  }

  void score() {
    const auto t0 = Clock::now();
    result_.records = reports_.size();
    score_depth();
    const double wear_limit = setup_.settings.wear_limit_m;
    std::vector<double> density, depth;
    for (const auto& s : states_) density.push_back(s.pitting_density), depth.push_back(max_depth(s));
    result_.pitting = score_limit(density, kPittingScoreFrom, setup_.settings.pitting_limit, true, result_.pitting_crossing);
    result_.wear = score_limit(depth, kWearScoreFromFraction * wear_limit, wear_limit, false, result_.wear_crossing);
    result_.stages.score += seconds_since(t0);
  }

  /// Depth error per record from the model's second K_wear update on (the record of that update
  /// included: its depth is the updated one); all records when the model made fewer than two. A
  /// record whose truth has no depth yet (the first stop) has no relative error.
  void score_depth() {
    std::size_t changed = 0, from = 0;
    for (std::size_t i = 0; i < reports_.size(); ++i)
      for (const auto& u : reports_[i].updates) {
        if (u.kind != wear::UpdateKind::k_wear) continue;
        ++result_.k_wear_update_attempts;
        if (u.new_value != u.old_value && ++changed == 2) from = i;
      }
    result_.k_wear_updates = changed;
    result_.depth_from_record = changed >= 2 ? from : 0;
    for (std::size_t i = result_.depth_from_record; i < reports_.size(); ++i) {
      const double truth = states_[i].combined_mean_wear_depth_m;
      if (!(truth > 0)) continue;
      // The model's depth estimate: the forecast's (calibrated by inspected depths where there are
      // any; the model state's otherwise).
      const wear::Forecast& f = reports_[i].forecast;
      const double estimate = f.valid && f.depth_mean_m > 0 ? f.depth_mean_m : reports_[i].summary.combined_mean_depth_m;
      result_.depth_errors.push_back(pg::relative_error(estimate, truth));
      if (!f.valid || !(f.depth_high_m > 0)) continue;
      ++result_.depth_interval_scored;
      if (f.depth_low_m <= truth && truth <= f.depth_high_m) ++result_.depth_interval_covered;
    }
  }

  /// Per record, the truth and the model side by side (JSON only: what a reader checks a score with).
  void trace() {
    auto opt = [](const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(); };
    for (std::size_t i = 0; i < reports_.size(); ++i) {
      const auto& r = reports_[i];
      const auto& t = states_[i];
      nlohmann::json updates = nlohmann::json::array();
      for (const auto& u : r.updates)
        updates.push_back({{"kind", wear::to_string(u.kind)}, {"outcome", wear::to_string(u.outcome)}, {"old", u.old_value},
                           {"new", u.new_value}, {"evidence", u.evidence}});
      nlohmann::json flags = nlohmann::json::array();
      for (const auto f : r.forecast.flags) flags.push_back(wear::to_string(f));
      result_.trace.push_back(
          {{"cycles", case_.plan[i].cycles},
           {"truth", {{"combined_mean_depth_m", t.combined_mean_wear_depth_m}, {"max_depth_m", max_depth(t)},
                      {"pitting_density", t.pitting_density}, {"k_wear", t.k_wear}}},
           {"model", {{"advanced", r.advanced}, {"combined_mean_depth_m", r.summary.combined_mean_depth_m},
                      {"max_depth_m", r.max_depth_m}, {"pitting_density", r.summary.mean_pitting_density},
                      {"k_wear", r.k_wear_si}, {"rms_sa_measured", opt(r.observation.rms_sa)},
                      {"rms_sa_simulated", opt(r.rms_sa_simulated)}, {"ics2_low", opt(r.observation.ics2_low)},
                      {"ics2_density_estimate", opt(r.ics2_density_estimate)}, {"k_pitting", r.k_pitting},
                      {"updates", updates}}},
           {"forecast", {{"valid", r.forecast.valid},
                         {"pitting_cycles_left", {opt(r.forecast.pitting.cycles_left_low), opt(r.forecast.pitting.cycles_left),
                                                  opt(r.forecast.pitting.cycles_left_high)}},
                         {"wear_cycles_left", {opt(r.forecast.wear.cycles_left_low), opt(r.forecast.wear.cycles_left),
                                               opt(r.forecast.wear.cycles_left_high)}},
                         {"combined_mean_depth_m", {r.forecast.depth_low_m, r.forecast.depth_mean_m, r.forecast.depth_high_m}},
                         {"shape_depth_ratio", r.forecast.shape_depth_ratio},
                         {"depth_ratio", r.forecast.depth_ratio}, {"depth_ratio_log_sd", r.forecast.depth_ratio_log_sd},
                         {"peak_ratio", r.forecast.peak_ratio}, {"peak_ratio_log_sd", r.forecast.peak_ratio_log_sd},
                         {"flags", flags}, {"evidence", r.forecast.evidence}}}});
    }
  }

  /// One limit's forecasts from the first record whose truth passes `from_level`, against the
  /// truth's crossing of `limit` (found on a fresh truth, continued past the campaign's end by the
  /// model's forecast horizon).
  pg::LimitScore score_limit(const std::vector<double>& truth, double from_level, double limit, bool pitting,
                             std::optional<double>& crossing) const {
    const auto start = pg::first_above(truth, from_level);
    if (!start) return {};
    crossing = truth_crossing(limit, pitting);
    std::vector<pg::ForecastAt> forecasts;
    for (std::size_t i = *start; i < reports_.size(); ++i) {
      const wear::Forecast& f = reports_[i].forecast;
      const wear::LimitForecast& lf = pitting ? f.pitting : f.wear;
      pg::ForecastAt at;
      at.cycles = case_.plan[i].cycles;
      at.left.valid = f.valid;
      at.left.nominal = lf.cycles_left.value_or(pg::kInfinity);
      at.left.low = lf.cycles_left_low.value_or(pg::kInfinity);
      at.left.high = lf.cycles_left_high.value_or(pg::kInfinity);
      forecasts.push_back(at);
    }
    return pg::score_limit(forecasts, crossing.value_or(pg::kInfinity));
  }

  std::optional<double> truth_crossing(double limit, bool pitting) const {
    const auto truth = make_truth();
    const pg::TruthCurve curve = [&](double n) {
      const rig::WearState w = truth->at(n);
      return pitting ? w.pitting_density : max_depth(w);
    };
    const double last = case_.plan.back().cycles;
    // Steps of the campaign's stop spacing; the crossing to 1/1024 of a step.
    const double step = case_.plan.size() > 1 ? last / static_cast<double>(case_.plan.size() - 1)
                                              : setup_.settings.forecast_horizon_cycles / 20.0;
    try {
      return pg::first_crossing(curve, limit, 0.0, last + setup_.settings.forecast_horizon_cycles, step, step / 1024.0);
    } catch (const rig::RigParameterError&) {
      return std::nullopt;  // the truth's own loop stops (a flank worn through) before it reaches the limit
    }
  }

  const BenchSetup& setup_;
  CampaignCase case_;
  daemon::RecordProcessor processor_;
  double record_rate_hz_ = 0;   // read by the model's RMS_SA simulator at each call
  wear::TwinModel model_;
  std::vector<rig::WearState> states_;
  std::vector<std::pair<std::size_t, wear::Inspection>> inspections_;
  std::vector<wear::ModelRunReport> reports_;
  CampaignResult result_;
};

CampaignResult run_campaign(const BenchSetup& setup, std::uint64_t seed) {
  CampaignResult failed;
  try {
    CampaignBench bench(setup, make_campaign_case(seed, setup.options.records, setup.options.seconds, setup.options.campaign_set));
    return bench.run();
  } catch (const std::exception& e) {
    failed.seed = seed;
    failed.failure = e.what();
  }
  return failed;
}

/// The campaigns on `jobs` threads (each campaign on one), in seed order in the result.
std::vector<CampaignResult> run_campaigns(const BenchSetup& setup) {
  const auto n = static_cast<std::size_t>(setup.options.campaigns);
  std::vector<CampaignResult> results(n);
  std::atomic<std::size_t> next{0};
  std::mutex progress;
  auto worker = [&] {
    for (std::size_t k; (k = next++) < n;) {
      results[k] = run_campaign(setup, setup.options.seed + k);
      std::lock_guard lock(progress);
      const auto& r = results[k];
      std::fprintf(stderr, "bench prognosis: campaign seed %llu (%s) %s in %.1f s\n", static_cast<unsigned long long>(r.seed),
                   r.name.c_str(), r.failure.empty() ? "done" : ("failed: " + r.failure).c_str(), r.seconds);
    }
  };
  std::vector<std::thread> threads;
  for (int j = 1; j < setup.options.jobs; ++j) threads.emplace_back(worker);
  worker();
  for (auto& t : threads) t.join();
  return results;
}


/// One target of the summary: its value against the target, met or missed (nullopt: nothing to score).
struct TargetRow {
  std::string name;
  double value = 0;
  std::string comparison;   // "<=" or ">="
  double target = 0;
  std::size_t count = 0;    // scored forecasts or records
  std::optional<bool> met;
};

struct Summary {
  pg::ErrorSummary depth, pitting_cycles, wear_cycles;
  std::size_t depth_interval_scored = 0, depth_interval_covered = 0;
  pg::LimitScore pitting, wear, limits;
  std::vector<TargetRow> targets;
  std::size_t failed = 0;
  double mean_campaign_seconds = 0, mean_campaign_cpu_seconds = 0;
  StageSeconds mean_stages;
};

TargetRow at_most(std::string name, double value, double target, std::size_t count) {
  return {std::move(name), value, "<=", target, count, count ? std::optional<bool>(value <= target) : std::nullopt};
}

Summary summarise(const std::vector<CampaignResult>& results) {
  Summary s;
  std::vector<double> depth;
  std::vector<pg::LimitScore> pitting, wear;
  std::size_t ran = 0;
  for (const auto& r : results) {
    if (!r.failure.empty()) {
      ++s.failed;
      continue;
    }
    ++ran;
    depth.insert(depth.end(), r.depth_errors.begin(), r.depth_errors.end());
    s.depth_interval_scored += r.depth_interval_scored;
    s.depth_interval_covered += r.depth_interval_covered;
    pitting.push_back(r.pitting);
    wear.push_back(r.wear);
    s.mean_campaign_seconds += r.seconds;
    s.mean_campaign_cpu_seconds += r.cpu_seconds;
    s.mean_stages.truth += r.stages.truth, s.mean_stages.simulate += r.stages.simulate;
    s.mean_stages.analyse += r.stages.analyse, s.mean_stages.observe += r.stages.observe, s.mean_stages.score += r.stages.score;
  }
  if (ran) {
    const double n = static_cast<double>(ran);
    s.mean_campaign_seconds /= n;
    s.mean_campaign_cpu_seconds /= n;
    for (double* v : {&s.mean_stages.truth, &s.mean_stages.simulate, &s.mean_stages.analyse, &s.mean_stages.observe,
                      &s.mean_stages.score})
      *v /= n;
  }
  s.pitting = pg::combine(pitting);
  s.wear = pg::combine(wear);
  s.limits = pg::combine({s.pitting, s.wear});
  s.depth = pg::summarise_errors(depth, kDepthTarget);
  s.pitting_cycles = pg::summarise_errors(s.pitting.errors, kCyclesTarget);
  s.wear_cycles = pg::summarise_errors(s.wear.errors, kCyclesTarget);
  s.targets.push_back(at_most("depth_error_max", s.depth.max_abs, kDepthTarget, s.depth.count));
  s.targets.push_back(at_most("pitting_cycles_left_error_max", s.pitting_cycles.max_abs, kCyclesTarget, s.pitting_cycles.count));
  s.targets.push_back(at_most("wear_cycles_left_error_max", s.wear_cycles.max_abs, kCyclesTarget, s.wear_cycles.count));
  const double cov = pg::coverage(s.limits);
  s.targets.push_back({"interval_coverage", cov, ">=", kCoverageTarget, s.limits.forecasts,
                       s.limits.forecasts ? std::optional<bool>(cov >= kCoverageTarget) : std::nullopt});
  s.targets.push_back(at_most("intervals_excluding_a_reached_limit", static_cast<double>(s.limits.excluded_reached), 0.0,
                              s.limits.reached));
  return s;
}

/// A number; "inf" for an infinite one (a forecast beyond the horizon, or none: JSON has no
/// infinity), null for NaN (nothing to score).
nlohmann::json number_or_null(double v) {
  if (std::isnan(v)) return nlohmann::json();
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

nlohmann::json errors_json(const pg::ErrorSummary& e) {
  return {{"count", e.count}, {"within_target", e.within}, {"max_abs", number_or_null(e.max_abs)},
          {"median_abs", number_or_null(e.median_abs)}};
}

/// The depth interval's share of scored records holding the truth's combined mean depth.
nlohmann::json depth_interval_json(std::size_t scored, std::size_t covered) {
  return {{"scored", scored}, {"covered", covered},
          {"coverage", number_or_null(scored ? static_cast<double>(covered) / static_cast<double>(scored) : std::nan(""))}};
}

nlohmann::json limit_json(const pg::LimitScore& l, const std::optional<double>& crossing, bool with_crossing) {
  nlohmann::json errors = nlohmann::json::array();
  for (double e : l.errors) errors.push_back(number_or_null(e));
  nlohmann::json j{{"forecasts", l.forecasts},      {"missing", l.missing},     {"covered", l.covered},
                   {"coverage", number_or_null(pg::coverage(l))}, {"reached", l.reached},
                   {"excluded_reached", l.excluded_reached},      {"truth_beyond_search", l.truth_beyond},
                   {"errors", errors},              {"error_summary", errors_json(pg::summarise_errors(l.errors, kCyclesTarget))}};
  if (with_crossing) j["truth_crossing_cycles"] = crossing ? nlohmann::json(*crossing) : nlohmann::json();
  return j;
}

nlohmann::json stages_json(const StageSeconds& s) {
  return {{"truth", s.truth}, {"simulate", s.simulate}, {"analyse", s.analyse}, {"observe", s.observe}, {"score", s.score}};
}

nlohmann::json campaign_json(const CampaignResult& r) {
  nlohmann::json j{{"seed", r.seed}, {"campaign", r.name}, {"seconds", r.seconds}, {"cpu_seconds", r.cpu_seconds}};
  if (!r.failure.empty()) {
    j["failure"] = r.failure;
    return j;
  }
  nlohmann::json depth = nlohmann::json::array();
  for (double e : r.depth_errors) depth.push_back(number_or_null(e));
  j.update({{"records", r.records},
            {"k_wear_updates", r.k_wear_updates},
            {"k_wear_update_attempts", r.k_wear_update_attempts},
            {"inspections", r.inspections},
            {"depth_scored_from_record", r.depth_from_record},
            {"depth_errors", depth},
            {"depth", errors_json(pg::summarise_errors(r.depth_errors, kDepthTarget))},
            {"depth_interval", depth_interval_json(r.depth_interval_scored, r.depth_interval_covered)},
            {"pitting", limit_json(r.pitting, r.pitting_crossing, true)},
            {"wear", limit_json(r.wear, r.wear_crossing, true)},
            {"stage_seconds", stages_json(r.stages)},
            {"records_trace", r.trace}});
  return j;
}

nlohmann::json report_json(const BenchSetup& setup, const std::vector<CampaignResult>& results, const Summary& s, double wall) {
  const auto& o = setup.options;
  nlohmann::json targets = nlohmann::json::array();
  for (const auto& t : s.targets)
    targets.push_back({{"name", t.name}, {"value", number_or_null(t.value)}, {"comparison", t.comparison}, {"target", t.target},
                       {"count", t.count}, {"met", t.met ? nlohmann::json(*t.met) : nlohmann::json()}});
  nlohmann::json campaigns = nlohmann::json::array();
  for (const auto& r : results) campaigns.push_back(campaign_json(r));
  return {{"settings", {{"campaigns", o.campaigns}, {"first_seed", o.seed}, {"records", o.records}, {"seconds", o.seconds},
                        {"jobs", o.jobs}, {"inspection_relative_sd", o.inspection_sd},
                        {"inspection_depth_relative_sd", o.inspection_depth_sd}, {"inspection_levels", kInspectionLevels},
                        {"wear_inspection_limit_fractions", kWearInspectionFractions},
                        {"wear_limit_m", setup.settings.wear_limit_m}, {"pitting_limit", setup.settings.pitting_limit},
                        {"config", o.config.empty() ? "built-in defaults (the demo's)" : o.config}}},
          {"campaigns", campaigns},
          {"summary", {{"depth", errors_json(s.depth)},
                       {"depth_interval", depth_interval_json(s.depth_interval_scored, s.depth_interval_covered)},
                       {"pitting", limit_json(s.pitting, std::nullopt, false)},
                       {"wear", limit_json(s.wear, std::nullopt, false)},
                       {"failed_campaigns", s.failed},
                       {"targets", targets}}},
          {"cost", {{"wall_seconds", wall}, {"mean_campaign_seconds", s.mean_campaign_seconds},
                    {"mean_campaign_cpu_seconds", s.mean_campaign_cpu_seconds},
                    {"mean_stage_seconds", stages_json(s.mean_stages)}}}};
}

std::string percent(double v) {
  if (std::isnan(v)) return "-";
  if (std::isinf(v)) return "inf";
  char b[32];
  std::snprintf(b, sizeof b, "%.1f%%", 100.0 * v);
  return b;
}

std::string limit_cells(const pg::LimitScore& l) {
  const auto e = pg::summarise_errors(l.errors, kCyclesTarget);
  char b[96];
  std::snprintf(b, sizeof b, "%4zu %8s %8s %3zu", l.forecasts, percent(e.max_abs).c_str(), percent(pg::coverage(l)).c_str(),
                l.excluded_reached);
  return b;
}

void print_table(const std::vector<CampaignResult>& results, const Summary& s, double wall, int jobs) {
  std::printf("%6s %-10s %4s %4s %4s %8s %8s | %4s %8s %8s %3s | %4s %8s %8s %3s | %7s\n", "seed", "campaign", "recs", "Kw",
              "insp", "depth", "depth", "pit", "pit", "pit", "pit", "wear", "wear", "wear", "wr", "seconds");
  std::printf("%6s %-10s %4s %4s %4s %8s %8s | %4s %8s %8s %3s | %4s %8s %8s %3s | %7s\n", "", "", "", "upd", "", "max|e|",
              "med|e|", "fc", "max|e|", "cover", "exc", "fc", "max|e|", "cover", "exc", "");
  for (const auto& r : results) {
    if (!r.failure.empty()) {
      std::printf("%6llu failed: %s\n", static_cast<unsigned long long>(r.seed), r.failure.c_str());
      continue;
    }
    const auto d = pg::summarise_errors(r.depth_errors, kDepthTarget);
    std::printf("%6llu %-10s %4zu %4zu %4zu %8s %8s | %s | %s | %7.1f\n", static_cast<unsigned long long>(r.seed), r.name.c_str(),
                r.records, r.k_wear_updates, r.inspections, percent(d.max_abs).c_str(), percent(d.median_abs).c_str(),
                limit_cells(r.pitting).c_str(), limit_cells(r.wear).c_str(), r.seconds);
  }
  std::printf("\nsummary over %zu campaigns (%zu failed): depth median |error| %s over %zu records; cycles left median |error| "
              "pitting %s (%zu), wear %s (%zu)\n",
              results.size(), s.failed, percent(s.depth.median_abs).c_str(), s.depth.count, percent(s.pitting_cycles.median_abs).c_str(),
              s.pitting_cycles.count, percent(s.wear_cycles.median_abs).c_str(), s.wear_cycles.count);
  std::printf("depth interval (nominal %.0f%%) holds the truth's mean depth in %s of %zu scored records\n", 100 * wear::kNominalCoverage,
              percent(s.depth_interval_scored ? static_cast<double>(s.depth_interval_covered) / static_cast<double>(s.depth_interval_scored)
                                              : std::nan(""))
                  .c_str(),
              s.depth_interval_scored);
  for (const auto& t : s.targets) {
    const bool count_only = t.name == "intervals_excluding_a_reached_limit";
    const std::string value = count_only ? std::to_string(static_cast<long>(t.value)) : percent(t.value);
    const std::string target = count_only ? "0" : percent(t.target);
    std::printf("  %-38s %8s  target %s %-6s  (%zu scored)  %s\n", t.name.c_str(), value.c_str(), t.comparison.c_str(),
                target.c_str(), t.count, t.met ? (*t.met ? "met" : "MISSED") : "no data");
  }
  std::printf("cost: %.1f s per campaign, %.1f s of CPU (wall: truth %.1f, rig %.1f, processing %.1f, model %.1f, scoring %.1f); "
              "%.1f s wall with %d job(s)\n",
              s.mean_campaign_seconds, s.mean_campaign_cpu_seconds, s.mean_stages.truth, s.mean_stages.simulate, s.mean_stages.analyse, s.mean_stages.observe,
              s.mean_stages.score, wall, jobs);
}

BenchSetup make_setup(const PrognosisOptions& o) {
  BenchSetup setup;
  setup.options = o;
  setup.config = load_config_or_defaults(o.config);
  try {
    setup.params = daemon::model_twin_parameters(setup.config);
    setup.settings = daemon::model_settings(setup.config);
    if (o.wear_limit_um > 0) setup.settings.wear_limit_m = o.wear_limit_um * 1e-6;
    setup.settings.inspection_depth_relative_sd = o.inspection_depth_sd;
    setup.settings.validate();
  } catch (const std::exception& e) {
    throw CommandError(std::string("the model's settings: ") + e.what());
  }
  setup.channel = daemon::model_channel(setup.config);
  return setup;
}

void run_prognosis_bench(const PrognosisOptions& o) {
  const BenchSetup setup = make_setup(o);
  const auto t0 = Clock::now();
  const auto results = run_campaigns(setup);
  const double wall = seconds_since(t0);
  const Summary s = summarise(results);
  if (o.format == "json") std::cout << dump_json(report_json(setup, results, s, wall), 2) << "\n";
  else print_table(results, s, wall, o.jobs);
  if (s.failed == results.size()) throw CommandError("no campaign ran");
}

}  // namespace

CLI::App* bench_command(CLI::App& app) {
  for (CLI::App* sub : app.get_subcommands([](CLI::App* a) { return a->get_name() == "bench"; })) return sub;
  auto* bench = app.add_subcommand("bench", "Benchmarks of gearwatch's answers against the rig simulator's truth");
  bench->require_subcommand(1);
  return bench;
}

void add_bench_prognosis_command(CLI::App& app) {
  auto opt = std::make_shared<PrognosisOptions>();
  auto* cmd = bench_command(app)->add_subcommand(
      "prognosis", "Wear depth and remaining life against the rig simulator's wear truth, over simulated campaigns");
  cmd->add_option("--campaigns", opt->campaigns, "Campaigns (one per seed)")->check(CLI::Range(1, 100000))->capture_default_str();
  cmd->add_option("--seed", opt->seed, "Seed of the first campaign")->capture_default_str();
  cmd->add_option("--records", opt->records, "Measured stops per campaign (default: the campaign's)")->check(CLI::Range(2, 100000));
  cmd->add_option("--seconds", opt->seconds, "Length of each record, s")->check(CLI::Range(0.5, 3600.0))->capture_default_str();
  cmd->add_option("--jobs", opt->jobs, "Campaigns run in parallel threads")->check(CLI::Range(1, 256))->capture_default_str();
  cmd->add_option("--config", opt->config, "Processing and model settings (default: the built-in ones, which the demo uses)");
  cmd->add_option("--campaign-set", opt->campaign_set,
                  "random: wear truths in forms the model does not share (default); builtin: lubricated and dry, alternating")
      ->transform(CLI::CheckedTransformer(std::map<std::string, CampaignSet>{{"random", CampaignSet::random},
                                                                             {"builtin", CampaignSet::builtin}}))
      ->capture_default_str();
  cmd->add_option("--inspection-sd", opt->inspection_sd, "Relative standard deviation of an inspection's pitted area")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--inspection-depth-sd", opt->inspection_depth_sd,
                  "Relative standard deviation of an inspection's combined mean wear depth and deepest point (stated to the model)")
      ->check(CLI::Range(1e-4, 0.9))
      ->capture_default_str();
  cmd->add_option("--wear-limit-um", opt->wear_limit_um,
                  "Wear limit (deepest flank point) of the model and the scores, um; 0: the configured one")
      ->check(CLI::Range(0.0, 499.0))
      ->capture_default_str();
  add_format_option(cmd, opt->format, "table", {"table", "json"});
  cmd->callback([opt] { run_prognosis_bench(*opt); });
}

void register_bench(CLI::App& app) { add_bench_prognosis_command(app); }

}  // namespace gearwatch::cli
