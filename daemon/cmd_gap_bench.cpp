// `gearwatch gap bench`: the withheld-effect check of the sim-to-real gap diagnosis. Rig-simulator
// scenarios with one (or two) truth effects on, drawn at random within their documented ranges and
// hidden from the diagnosis, are diagnosed against the twin at the same operating points; the
// attribution, localisation and held-out shrinkage are scored against the truth.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <map>
#include <numeric>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <tuple>

#include "cli_common.hpp"
#include "commands.hpp"
#include "gap_bench_independent.hpp"
#include "gap_bench_output.hpp"
#include "gap_bench_scores.hpp"
#include "gearwatch/gap/candidates.hpp"
#include "gearwatch/gap/diagnosis.hpp"
#include "gearwatch/rig/rig_simulator.hpp"
#include "gearwatch/rig/wear_truth.hpp"
#include "gearwatch/twin/simulation.hpp"

namespace gearwatch::cli {
namespace {

using gap::CandidateEffect;
using gap::FamilyKind;

CandidateEffect candidate_of(rig::Effect e) {
  switch (e) {
    case rig::Effect::casing: return CandidateEffect::casing_mode;
    case rig::Effect::tooth_errors: return CandidateEffect::tooth_errors;
    case rig::Effect::eccentricity: return CandidateEffect::eccentricity;
    case rig::Effect::tip_relief: return CandidateEffect::tip_relief;
    case rig::Effect::speed_fluctuation: return CandidateEffect::speed_fluctuation;
    case rig::Effect::load_fluctuation: return CandidateEffect::load_fluctuation;
    case rig::Effect::noise: return CandidateEffect::noise_floor;
    case rig::Effect::mounting: return CandidateEffect::mount_resonance;
    case rig::Effect::misalignment: return CandidateEffect::misalignment;
    case rig::Effect::backlash: return CandidateEffect::backlash;
  }
  throw std::logic_error("unmapped rig effect");
}

struct BenchOptions {
  int seeds = 30;
  int effects = 1;
  std::string format = "table";
  double sample_rate_hz = 50000;
  double seconds = 2.0;
  // The thesis's two test loads (20 N·m lubricated, 5 N·m dry, §3.2.1): every speed runs at each, so
  // effects that show only at a light load (a misaligned face loaded over part of its width) can.
  std::vector<double> torques_nm{20.0, 5.0};
  std::vector<double> training_speeds_hz{8.0, 14.0};
  std::vector<double> held_out_speeds_hz{11.0, 17.0};
  int no_effect_runs = -1;   // default: max(2, seeds / 5)
  std::uint64_t first_seed = 1;
  int bootstrap = 100;
  double floor_db = gap::DiagnosisSettings{}.floor_db;
  double min_gap_db = gap::DiagnosisSettings{}.min_gap_db;
  double min_residual_gap_db = gap::DiagnosisSettings{}.min_residual_gap_db;
  double wear_depth_um = 2;    // pinion wear depth at the sliding extremes, rig and twin alike
  double wear_cycles = 1e6;    // over which the known K_wear produced it
  std::string generator = "rig";  // rig: the rig simulator's effects; independent: gap_effects.py on the twin
  std::string generator_script = IndependentBenchOptions{}.script;
  std::string python;
  std::string config;
  int jobs = 1;  // independent generator: draws side by side
  bool sample_rate_given = false, seconds_given = false, bootstrap_given = false;
};

void run_independent(const BenchOptions& o) {
  IndependentBenchOptions io;
  io.seeds = o.seeds;
  io.first_seed = o.first_seed;
  io.format = o.format;
  io.config = o.config;
  io.python = o.python;
  io.script = o.generator_script;
  if (o.sample_rate_given) io.sample_rate_hz = o.sample_rate_hz;
  if (o.seconds_given) io.seconds = o.seconds;
  if (o.bootstrap_given) io.bootstrap = o.bootstrap;
  io.torques_nm = o.torques_nm;
  io.jobs = o.jobs;
  run_independent_bench(io);
}

/// RMS_SA(N) (thesis Eq. 7.1) from the diagnosis's own input-order lines, so the elasticity is read
/// the way the diagnosis reads RMS_SA.
double rms_sa_of(const Record& r, int harmonics) {
  const auto rms = gap::rms_sa_of_record(r, 0, GearPairSpec{}, harmonics);
  if (!rms) throw std::invalid_argument("gap bench: the twin's RMS_SA(" + std::to_string(harmonics) + ") is not positive");
  return *rms;
}

twin::ToothProfileDeviation scaled(twin::ToothProfileDeviation p, double factor) {
  for (auto& v : p.pinion) v *= factor;
  for (auto& v : p.gear) v *= factor;
  return p;
}

Record make_record(const std::vector<float>& x, const std::vector<double>& edges, double fs, double speed, double torque) {
  return single_channel_record(x, edges, fs, speed, torque);
}

/// The twin at an operating point and the true wear state (the same for every scenario there, so
/// simulated once).
class TwinCache {
 public:
  TwinCache(double fs, double seconds, twin::ToothProfileDeviation wear)
      : fs_(fs), seconds_(seconds), wear_(std::move(wear)) {}
  const Record& at(double speed, double torque, double wear_scale = 1.0) {
    const auto key = std::make_tuple(speed, torque, wear_scale);
    auto it = cache_.find(key);
    if (it != cache_.end()) return it->second;
    const auto s =
        twin::simulate_casing_signal(twin::GearboxParameters{}, scaled(wear_, wear_scale), {speed, torque}, seconds_, fs_);
    return cache_.emplace(key, make_record(s.acceleration, s.tacho_edges, fs_, speed, torque)).first->second;
  }
  /// The twin re-run with a candidate's addition (the diagnosis's TwinRerun), cached: every scenario
  /// at these operating points asks for the same grid.
  Record rerun(gap::CandidateEffect effect, const std::vector<double>& values, const Record& like, double duration_s) {
    const auto key = std::make_tuple(static_cast<int>(effect), values, like.speed_hz, like.torque_nm, duration_s);
    auto it = reruns_.find(key);
    if (it != reruns_.end()) return it->second;
    twin::SimulationOptions options;
    options.sample_rate_hz = fs_;
    twin::ToothProfileDeviation profile = wear_;
    gap::add_rerun_effect(effect, values, profile, options);
    const auto s = twin::simulate_casing_signal(twin::GearboxParameters{}, profile, {like.speed_hz, like.torque_nm}, duration_s,
                                                options);
    return reruns_.emplace(key, make_record(s.acceleration, s.tacho_edges, fs_, like.speed_hz, like.torque_nm))
        .first->second;
  }
  /// d ln RMS_SA / d ln K of the twin at the wear state: depth ∝ K (Archard, constant operating
  /// point), read by a central difference in log over wear depths ×0.8 and ×1.25.
  double elasticity(double speed, double torque, int harmonics) {
    const auto key = std::make_tuple(speed, torque, harmonics);
    auto it = elasticity_.find(key);
    if (it != elasticity_.end()) return it->second;
    const double e = gap::rms_sa_wear_elasticity(rms_sa_of(at(speed, torque, gap::kElasticityDepthLow), harmonics),
                                                 rms_sa_of(at(speed, torque, gap::kElasticityDepthHigh), harmonics));
    return elasticity_.emplace(key, e).first->second;
  }

 private:
  double fs_, seconds_;
  twin::ToothProfileDeviation wear_;
  std::map<std::tuple<double, double, double>, Record> cache_;
  std::map<std::tuple<int, std::vector<double>, double, double, double>, Record> reruns_;
  std::map<std::tuple<double, double, int>, double> elasticity_;
};

/// One record of the rig (one channel) at an operating point, with the given effects.
Record rig_record(const BenchOptions& o, const rig::EffectSet& effects, const rig::WearState& wear, double speed,
                  double torque, std::uint64_t seed) {
  rig::RigRunSettings run;
  run.speed_hz = speed;
  run.torque_nm = torque;
  run.duration_s = o.seconds;
  run.sample_rate_hz = o.sample_rate_hz;
  run.channels = 1;
  run.seed = seed;
  // The default 10 µs steps' error beats with the mesh; at 11.174 and 15.479 Hz, two of the
  // no-effect runs' speeds, it lands on the gear's first sidebands and raised a false gap there.
  run.min_ode_rate_hz = rig::kFineOdeRateHz;
  const auto r = rig::simulate_record(twin::GearboxParameters{}, effects, wear, {}, run);
  return make_record(r.acceleration[0], r.tacho_edges, o.sample_rate_hz, speed, torque);
}

/// The rig without any effect at an operating point (deterministic, so simulated once): what a
/// scenario's records would be had the drawn effect been off.
class RigBaselineCache {
 public:
  RigBaselineCache(const BenchOptions& o, rig::WearState wear) : o_(o), wear_(std::move(wear)) {}
  const Record& at(double speed, double torque) {
    const auto key = std::make_pair(speed, torque);
    auto it = cache_.find(key);
    if (it != cache_.end()) return it->second;
    // Without effects the rig is deterministic: the seed changes nothing.
    return cache_.emplace(key, rig_record(o_, rig::EffectSet{}, wear_, speed, torque, 1)).first->second;
  }

 private:
  const BenchOptions& o_;
  rig::WearState wear_;
  std::map<std::pair<double, double>, Record> cache_;
};

struct ScenarioResult {
  std::vector<rig::Effect> truth;
  std::vector<CandidateEffect> ranked;      // chosen first, then the other candidates by score
  std::vector<CandidateEffect> chosen;
  bool detected = false;                    // any significant family before
  bool localised = false;                   // a significant family is one the true effect explains
  // The effect's own signature: the rig with the effect against the same rig without it, held out,
  // judged by the diagnosis's significance test. No method can attribute an effect without one.
  bool identifiable = false;
  std::vector<rig::Effect> identifiable_effects;  // each true effect with a signature of its own
  std::vector<std::string> signature_families;
  double shrinkage = std::numeric_limits<double>::quiet_NaN();
  double collateral_db = 0;                 // largest rise of a family the true effects do not explain
  bool collateral_beyond_interval = false;
  std::map<std::string, double> parameters;
  nlohmann::json families;                  // before/after per family
  nlohmann::json candidates;                // each candidate alone: score, shrinkage, parameters
  double k_ratio_before = std::numeric_limits<double>::quiet_NaN();  // K inferred / K true, twin alone
  double k_ratio_after = std::numeric_limits<double>::quiet_NaN();   // … with the chosen effects
  std::vector<double> elasticities;  // per held-out record
  double seconds = 0;
};

// The held-out records' seeds start this far after the training records' (scenario_inputs).
constexpr std::uint64_t kHeldOutSalt = 50;

/// A scenario's records at each torque and speed: the rig with the effects against the twin.
std::vector<gap::DiagnosisInput> scenario_inputs(const BenchOptions& o, const rig::EffectSet& effects,
                                                 const rig::WearState& wear, TwinCache& twins,
                                                 const std::vector<double>& speeds, std::uint64_t seed,
                                                 std::uint64_t salt) {
  std::vector<gap::DiagnosisInput> in;
  for (double torque : o.torques_nm)
    for (double speed : speeds)
      in.push_back({rig_record(o, effects, wear, speed, torque, seed * 101 + salt++), twins.at(speed, torque)});
  return in;
}

/// The diagnosis's settings for a scenario: the bench's, each held-out record's RMS_SA elasticity,
/// the twin re-run from the cache, and the true K_wear as the reference.
gap::DiagnosisSettings scenario_settings(const BenchOptions& o, double k_true, TwinCache& twins,
                                         const std::vector<gap::DiagnosisInput>& held_out, std::uint64_t seed) {
  gap::DiagnosisSettings ds;
  ds.bootstrap_resamples = o.bootstrap;
  ds.seed = seed;
  ds.floor_db = o.floor_db;
  ds.min_gap_db = o.min_gap_db;
  ds.min_residual_gap_db = o.min_residual_gap_db;
  // The rig bench scores the families and the chosen effects (docs/gap-bench.md: features count in
  // none of its figures), so the features would be found, described and dropped. Their bootstrap
  // draws are fixed by their keys, so leaving them out changes nothing else in the report.
  ds.find_features = false;
  for (const auto& in : held_out)
    ds.rms_sa_wear_elasticities.push_back(twins.elasticity(in.twin.speed_hz, in.twin.torque_nm, ds.rms_sa_harmonics));
  ds.rerun_twin = [&twins](gap::CandidateEffect c, const std::vector<double>& values, const Record& like, double duration_s) {
    return twins.rerun(c, values, like, duration_s);
  };
  // The twin runs at the true wear state, so the K it was simulated with is the truth.
  ds.reference_k_wear = k_true;
  return ds;
}

/// What a scenario's signature check needs: the truth and how its held-out records were drawn.
struct SignatureContext {
  const BenchOptions& options;
  const rig::EffectSet& effects;
  const rig::WearState& wear;
  TwinCache& twins;
  RigBaselineCache& baseline;
  const std::vector<double>& held_speeds;
  const std::vector<gap::DiagnosisInput>& held_out;
  std::uint64_t seed;
};

/// The significant families of the held-out records against `reference` (records at the same
/// operating points), by the diagnosis's significance test alone (no attribution, no K_wear, no
/// reruns).
std::vector<std::string> significant_against(const std::vector<gap::DiagnosisInput>& held_out,
                                             const std::vector<Record>& reference, const gap::DiagnosisSettings& ds) {
  std::vector<gap::DiagnosisInput> signature;
  for (std::size_t k = 0; k < held_out.size(); ++k) signature.push_back({held_out[k].measured, reference[k]});
  auto localise = ds;
  localise.attribute = false;
  localise.reference_k_wear.reset();
  localise.rerun_twin = nullptr;
  // Only the families' significance before any candidate is read here; the features (found and
  // described after it) would be computed and dropped.
  localise.find_features = false;
  std::vector<std::string> families;
  for (const auto& g : gap::diagnose(signature, signature, GearPairSpec{}, localise).before)
    if (g.significant) families.push_back(gap::to_string(g.family));
  return families;
}

/// What the held-out records would be without `off`: the rig without effects (one true effect),
/// else the rig with the other true effects, drawn with the held-out records' own seeds.
std::vector<Record> held_out_without(const SignatureContext& c, rig::Effect off) {
  std::vector<Record> reference;
  if (c.effects.enabled_effects().size() == 1) {
    for (const auto& in : c.held_out) reference.push_back(c.baseline.at(in.measured.speed_hz, in.measured.torque_nm));
    return reference;
  }
  rig::EffectSet others = c.effects;
  others.disable(off);
  for (auto& in : scenario_inputs(c.options, others, c.wear, c.twins, c.held_speeds, c.seed, kHeldOutSalt))
    reference.push_back(std::move(in.measured));
  return reference;
}

/// Each true effect's own signature, from the truth alone: the held-out records against the same
/// rig without that effect (docs/gap-bench.md, "What the records can show"). An effect without one
/// cannot be attributed by any method reading these records.
void find_signature(const SignatureContext& c, const gap::DiagnosisSettings& ds, ScenarioResult& res) {
  for (rig::Effect e : c.effects.enabled_effects()) {
    const auto families = significant_against(c.held_out, held_out_without(c, e), ds);
    if (families.empty()) continue;
    res.identifiable_effects.push_back(e);
    for (const auto& f : families)
      if (std::find(res.signature_families.begin(), res.signature_families.end(), f) == res.signature_families.end())
        res.signature_families.push_back(f);
  }
  res.identifiable = !res.identifiable_effects.empty();
}

/// What the report says: K_wear against the truth, the candidates, the families before and after,
/// and the ranking (chosen first, then the others in the report's order).
void take_report(const gap::GapReport& report, double k_true, ScenarioResult& res) {
  if (report.k_wear_before) res.k_ratio_before = *report.k_wear_before / k_true;
  if (report.k_wear_after) res.k_ratio_after = *report.k_wear_after / k_true;
  res.chosen = report.chosen;
  res.candidates = nlohmann::json::array();
  for (const auto& c : report.candidates) {
    nlohmann::json p;
    for (const auto& [k, v] : c.parameters) p[k] = v;
    res.candidates.push_back({{"effect", gap::to_string(c.effect)}, {"ic", c.information_criterion},
                              {"shrinkage", c.shrinkage}, {"worsens", c.worsens_other_family}, {"parameters", p}});
  }
  for (std::size_t f = 0; f < report.before.size(); ++f) {
    const auto& b = report.before[f];
    const auto& a = report.after[f];
    if (!b.resolved) continue;
    res.families[gap::to_string(b.family)] = {{"before_db", b.distance_db},
                                              {"before_interval_db", {b.distance_interval_db.low, b.distance_interval_db.high}},
                                              {"significant", b.significant},
                                              {"after_db", a.distance_db}};
  }
  res.ranked = report.chosen;
  for (const auto& c : report.candidates)
    if (std::find(res.ranked.begin(), res.ranked.end(), c.effect) == res.ranked.end()) res.ranked.push_back(c.effect);
}

/// The families the true effects explain.
std::vector<FamilyKind> true_families(const std::vector<rig::Effect>& truth, double sample_rate_hz) {
  std::vector<FamilyKind> own;
  for (auto e : truth)
    for (auto f : gap::candidate_form(candidate_of(e), sample_rate_hz).explains)
      if (std::find(own.begin(), own.end(), f) == own.end()) own.push_back(f);
  return own;
}

/// The report against the truth: detected, localised on the true effects' families, how much of
/// their gap the chosen effects took away, and how much the other families rose.
void score_against_truth(const gap::GapReport& report, double sample_rate_hz, ScenarioResult& res) {
  const std::vector<FamilyKind> own = true_families(res.truth, sample_rate_hz);
  for (const auto& g : report.before) {
    if (!g.significant) continue;
    res.detected = true;
    if (std::find(own.begin(), own.end(), g.family) != own.end()) res.localised = true;
  }
  const double before = gap::families_distance_db(report.before, own);
  if (res.detected && before > 0) res.shrinkage = 1.0 - gap::families_distance_db(report.after, own) / before;
  for (std::size_t f = 0; f < report.before.size(); ++f) {
    const auto& b = report.before[f];
    const auto& a = report.after[f];
    if (!b.resolved || std::find(own.begin(), own.end(), b.family) != own.end()) continue;
    res.collateral_db = std::max(res.collateral_db, a.distance_db - b.distance_db);
    if (a.distance_db > b.distance_interval_db.high) res.collateral_beyond_interval = true;
  }
}

ScenarioResult run_scenario(const BenchOptions& o, const rig::EffectSet& effects, const rig::WearState& wear,
                            double k_true, TwinCache& twins, RigBaselineCache& baseline,
                            const std::vector<double>& training_speeds, const std::vector<double>& held_speeds,
                            std::uint64_t seed) {
  const auto t0 = std::chrono::steady_clock::now();
  ScenarioResult res;
  res.truth = effects.enabled_effects();
  res.parameters = effects.active_parameters();
  const auto training = scenario_inputs(o, effects, wear, twins, training_speeds, seed, 0);
  const auto held_out = scenario_inputs(o, effects, wear, twins, held_speeds, seed, kHeldOutSalt);
  const gap::DiagnosisSettings ds = scenario_settings(o, k_true, twins, held_out, seed);
  res.elasticities = ds.rms_sa_wear_elasticities;
  const auto report = gap::diagnose(training, held_out, GearPairSpec{}, ds);
  if (!res.truth.empty()) find_signature({o, effects, wear, twins, baseline, held_speeds, held_out, seed}, ds, res);
  take_report(report, k_true, res);
  score_against_truth(report, o.sample_rate_hz, res);
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

double median(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

bool in_truth(const ScenarioResult& r, CandidateEffect c) {
  return std::any_of(r.truth.begin(), r.truth.end(), [&](rig::Effect e) { return candidate_of(e) == c; });
}

/// The scoring rule of attribution (docs/gap-bench.md): one true effect is in the first k ranked;
/// two: top-1 names one of them first, top-2 names both in the first two.
bool top(const ScenarioResult& r, std::size_t k) {
  if (!r.detected || r.chosen.empty()) return false;
  if (r.truth.size() == 1) {
    for (std::size_t j = 0; j < std::min(k, r.ranked.size()); ++j)
      if (in_truth(r, r.ranked[j])) return true;
    return false;
  }
  if (k == 1) return in_truth(r, r.ranked[0]);
  int hits = 0;
  for (std::size_t j = 0; j < std::min<std::size_t>(2, r.ranked.size()); ++j) hits += in_truth(r, r.ranked[j]);
  return hits == 2;
}

/// The scores of a group of scenarios (one effect's, or all).
struct ScoreRow {
  int runs = 0, detected = 0, top1 = 0, top2 = 0, localised = 0, collateral = 0;
  int identifiable = 0, top1_identifiable = 0;
  std::vector<double> shrink, shrink_identifiable, k_bias_before, k_bias_after;
  void add(const ScenarioResult& r) {
    ++runs;
    detected += r.detected;
    top1 += top(r, 1);
    top2 += top(r, 2);
    localised += r.localised;
    collateral += r.collateral_beyond_interval;
    k_bias_before.push_back(std::abs(r.k_ratio_before - 1.0));
    k_bias_after.push_back(std::abs(r.k_ratio_after - 1.0));
    shrink.push_back(r.shrinkage);
    if (r.identifiable) {
      ++identifiable;
      top1_identifiable += top(r, 1);
      shrink_identifiable.push_back(r.shrinkage);
    }
  }
};

/// K_wear bias: median over the scenarios of |K inferred / K true − 1|.
double k_bias(const std::vector<ScenarioResult>& rs, double ScenarioResult::*ratio) {
  std::vector<double> v;
  for (const auto& r : rs) v.push_back(std::abs(r.*ratio - 1.0));
  return median(v);
}

/// |K − K_true| / K_true cannot exceed 1 for an underestimate however bad; the factor error
/// |ln(K / K_true)| treats ×10 and ÷10 alike.
double k_log_bias(const std::vector<ScenarioResult>& rs, double ScenarioResult::*ratio) {
  std::vector<double> v;
  for (const auto& r : rs) v.push_back(std::abs(std::log(r.*ratio)));
  return median(v);
}

nlohmann::json effect_names(const std::vector<rig::Effect>& effects) {
  nlohmann::json names = nlohmann::json::array();
  for (auto e : effects) names.push_back(rig::effect_name(e));
  return names;
}

nlohmann::json outcome_json_names(const std::vector<CandidateEffect>& effects) {
  nlohmann::json names = nlohmann::json::array();
  for (auto e : effects) names.push_back(gap::to_string(e));
  return names;
}

/// What a scenario's progress line says: the truth, which of it leaves a trace, what was named.
std::string progress_line(const ScenarioResult& r) {
  return "truth " + effect_names(r.truth).dump() + " identifiable " + effect_names(r.identifiable_effects).dump() +
         " detected " + (r.detected ? "yes" : "no") + " chosen " + outcome_json_names(r.chosen).dump() + " shrinkage " +
         (std::isfinite(r.shrinkage) ? std::to_string(r.shrinkage) : std::string("none"));
}

/// A scenario as the headline scores read it (gap_bench_scores.hpp).
RigOutcome outcome_of(const ScenarioResult& r) {
  RigOutcome o;
  for (auto e : r.truth) o.truth.push_back(candidate_of(e));
  for (auto e : r.identifiable_effects) o.identifiable.push_back(candidate_of(e));
  o.chosen = r.chosen;
  o.detected = r.detected;
  o.shrinkage = r.shrinkage;
  return o;
}

nlohmann::json scenario_json(const ScenarioResult& r) {
  nlohmann::json t = nlohmann::json::array(), c = nlohmann::json::array(), rk = nlohmann::json::array();
  for (auto e : r.truth) t.push_back(rig::effect_name(e));
  for (auto e : r.chosen) c.push_back(gap::to_string(e));
  for (std::size_t k = 0; k < std::min<std::size_t>(3, r.ranked.size()); ++k) rk.push_back(gap::to_string(r.ranked[k]));
  const double mean_elasticity =  // over the held-out records
      r.elasticities.empty() ? std::numeric_limits<double>::quiet_NaN()
                             : std::accumulate(r.elasticities.begin(), r.elasticities.end(), 0.0) /
                                   static_cast<double>(r.elasticities.size());
  return {{"truth", t}, {"parameters", r.parameters}, {"chosen", c}, {"ranked", rk}, {"detected", r.detected},
          {"identifiable", r.identifiable}, {"identifiable_effects", effect_names(r.identifiable_effects)},
          {"signature_families", r.signature_families},
          {"shrinkage", number_or_null(r.shrinkage)}, {"collateral_db", r.collateral_db}, {"families", r.families},
          {"candidates", r.candidates}, {"k_wear_ratio_before", number_or_null(r.k_ratio_before)},
          {"k_wear_ratio_after", number_or_null(r.k_ratio_after)}, {"rms_sa_elasticity", number_or_null(mean_elasticity)},
          {"rms_sa_elasticities", r.elasticities}, {"seconds", r.seconds}};
}

/// `gap bench` with the rig simulator's effects: the known wear state, the effect scenarios and
/// the no-effect runs, their scores, and the report.
class RigBench {
 public:
  explicit RigBench(const BenchOptions& o) : o_(o), printer_(o.format) {}
  void run();

 private:
  void check_options() const;
  void make_wear_truth();
  rig::EffectSet draw_effects(std::uint64_t seed) const;
  void run_effect_scenarios();
  void run_no_effect_scenarios();
  void score();
  nlohmann::json document(double wall) const;
  BenchTable table(double wall) const;

  const BenchOptions& o_;
  BenchPrinter printer_;
  double k_true_ = 0;
  rig::WearState wear_;
  std::unique_ptr<TwinCache> twins_;
  std::unique_ptr<RigBaselineCache> baseline_;
  std::vector<ScenarioResult> runs_, quiet_;
  int none_runs_ = 0;
  std::map<std::string, ScoreRow> rows_;  ///< by the first true effect's name
  ScoreRow total_;
  int false_alarms_ = 0;
  std::vector<ScoreFigure> scores_;  ///< the headline figures with their targets
};

void RigBench::check_options() const {
  if (o_.seeds < 1) throw CommandError("--seeds must be at least 1");
  if (o_.effects != 1 && o_.effects != 2) throw CommandError("--effects must be 1 or 2");
  if (!(o_.min_gap_db >= 0) || !std::isfinite(o_.min_gap_db) || !(o_.min_residual_gap_db >= 0) ||
      !std::isfinite(o_.min_residual_gap_db))
    throw CommandError("--min-gap-db and --min-residual-gap-db must be finite and >= 0");
  if (!(o_.wear_depth_um > 0) || !(o_.wear_cycles > 0)) throw CommandError("--wear-depth-um and --wear-cycles must be > 0");
  if (o_.torques_nm.empty() || std::any_of(o_.torques_nm.begin(), o_.torques_nm.end(), [](double t) { return !(t > 0); }))
    throw CommandError("--torques must list loads > 0 N m");
}

// A known wear state: the rig's linear law, one K over the cycles, giving the asked depth at the
// sliding extremes at the first load. Rig and twin share the profile at every operating point;
// only the effects differ.
void RigBench::make_wear_truth() {
  rig::WearModelSettings wm;
  wm.torque_nm = o_.torques_nm.front();
  k_true_ = o_.wear_depth_um * 1e-6 / o_.wear_cycles * (wm.reference_torque_nm / wm.torque_nm);
  wm.phases = {{0.0, k_true_}};
  wear_ = rig::BuiltinWearTruth(wm, GearPairSpec{}).at(o_.wear_cycles);
  twins_ = std::make_unique<TwinCache>(o_.sample_rate_hz, o_.seconds, wear_.profile);
  baseline_ = std::make_unique<RigBaselineCache>(o_, wear_);
}

// Every effect equally often: seed s takes effect (s − 1) mod 10 (the second, if any, drawn at
// random), so a scenario is reproduced by its seed alone.
rig::EffectSet RigBench::draw_effects(std::uint64_t seed) const {
  const auto& all = rig::all_effects();
  std::mt19937_64 rng(seed * 2654435761u);
  rig::EffectSet fx;
  const rig::Effect first = all[static_cast<std::size_t>((seed - 1) % all.size())];
  fx.enable(first);
  if (o_.effects == 2) {
    rig::Effect second = first;
    while (second == first) second = all[std::uniform_int_distribution<std::size_t>(0, all.size() - 1)(rng)];
    fx.enable(second);
  }
  fx.randomise(seed);
  return fx;
}

void RigBench::run_effect_scenarios() {
  for (int i = 0; i < o_.seeds; ++i) {
    const std::uint64_t seed = o_.first_seed + static_cast<std::uint64_t>(i);
    const rig::EffectSet fx = draw_effects(seed);
    try {
      runs_.push_back(run_scenario(o_, fx, wear_, k_true_, *twins_, *baseline_, o_.training_speeds_hz, o_.held_out_speeds_hz, seed));
    } catch (const std::exception& e) {
      throw CommandError("gap bench seed " + std::to_string(seed) + ": " + e.what());
    }
    printer_.progress(seed, progress_line(runs_.back()), runs_.back().seconds);
  }
}

// The rig without effects is deterministic, so each no-effect run is at other operating points
// (speeds scaled 0.9–1.1, its own twin records).
void RigBench::run_no_effect_scenarios() {
  none_runs_ = o_.no_effect_runs >= 0 ? o_.no_effect_runs : std::max(2, o_.seeds / 5);
  for (int i = 0; i < none_runs_; ++i) {
    const double scale = none_runs_ == 1 ? 1.0 : 0.9 + 0.2 * i / (none_runs_ - 1);
    auto scaled = [&](const std::vector<double>& v) {
      std::vector<double> s;
      for (double x : v) s.push_back(std::round(x * scale * 1000) / 1000);
      return s;
    };
    quiet_.push_back(run_scenario(o_, rig::EffectSet{}, wear_, k_true_, *twins_, *baseline_, scaled(o_.training_speeds_hz),
                                  scaled(o_.held_out_speeds_hz), o_.first_seed + 100000 + static_cast<std::uint64_t>(i)));
    printer_.progress(o_.first_seed + 100000 + static_cast<std::uint64_t>(i), progress_line(quiet_.back()), quiet_.back().seconds);
  }
}

void RigBench::score() {
  for (const auto& r : runs_) {
    total_.add(r);
    rows_[rig::effect_name(r.truth.front())].add(r);
  }
  for (const auto& q : quiet_) false_alarms_ += q.detected;
  std::vector<RigOutcome> scenarios, no_effect;
  for (const auto& r : runs_) scenarios.push_back(outcome_of(r));
  for (const auto& q : quiet_) no_effect.push_back(outcome_of(q));
  scores_ = score_rig_outcomes(scenarios, no_effect);
}

nlohmann::json RigBench::document(double wall) const {
  nlohmann::json j = bench_document({o_.seeds, o_.sample_rate_hz, o_.seconds, o_.torques_nm, wall});
  j["effects_per_scenario"] = o_.effects;
  j["training_speeds_hz"] = o_.training_speeds_hz;
  j["held_out_speeds_hz"] = o_.held_out_speeds_hz;
  j["min_gap_db"] = o_.min_gap_db;
  j["min_residual_gap_db"] = o_.min_residual_gap_db;
  // The headline figures (docs/gap-bench.md, "What the records can show"); the keys after them
  // are the detail behind them.
  j["scores"] = scores_json(scores_);
  j["top1_accuracy"] = number_or_null(fraction(total_.top1, total_.runs));
  j["top2_accuracy"] = number_or_null(fraction(total_.top2, total_.runs));
  j["detection_rate"] = number_or_null(fraction(total_.detected, total_.runs));
  j["top1_accuracy_when_detected"] = number_or_null(fraction(total_.top1, total_.detected));
  j["localisation_rate"] = number_or_null(fraction(total_.localised, total_.runs));
  // Scenarios whose effect leaves a signature at these operating points (the rig with it against
  // the rig without it): attribution is possible only there.
  j["identifiable_rate"] = number_or_null(fraction(total_.identifiable, total_.runs));
  j["top1_accuracy_identifiable"] = number_or_null(fraction(total_.top1_identifiable, total_.identifiable));
  j["median_shrinkage_identifiable"] = number_or_null(median(total_.shrink_identifiable));
  j["median_shrinkage"] = number_or_null(median(total_.shrink));
  j["collateral_beyond_interval_rate"] = number_or_null(fraction(total_.collateral, total_.runs));
  j["no_effect_runs"] = none_runs_;
  j["false_alarm_rate"] = number_or_null(fraction(false_alarms_, none_runs_));
  // The effect scenarios, twin alone (before) and with the chosen effects (after); the no-effect
  // runs give the floor of the method.
  j["k_wear_bias_before"] = number_or_null(k_bias(runs_, &ScenarioResult::k_ratio_before));
  j["k_wear_bias_after"] = number_or_null(k_bias(runs_, &ScenarioResult::k_ratio_after));
  j["k_wear_bias_no_effect"] = number_or_null(k_bias(quiet_, &ScenarioResult::k_ratio_before));
  j["k_wear_log_bias_before"] = number_or_null(k_log_bias(runs_, &ScenarioResult::k_ratio_before));
  j["k_wear_log_bias_after"] = number_or_null(k_log_bias(runs_, &ScenarioResult::k_ratio_after));
  // Most effects leave the first mesh harmonics alone, so the medians over all scenarios say little
  // about the ones that do: the same over the scenarios whose effect moves K_wear by > 5 %.
  std::vector<ScenarioResult> affected;
  for (const auto& r : runs_)
    if (std::abs(std::log(r.k_ratio_before)) > std::log(1.05)) affected.push_back(r);
  j["k_wear_affected_scenarios"] = affected.size();
  j["k_wear_bias_before_affected"] = number_or_null(k_bias(affected, &ScenarioResult::k_ratio_before));
  j["k_wear_bias_after_affected"] = number_or_null(k_bias(affected, &ScenarioResult::k_ratio_after));
  j["k_wear_log_bias_before_affected"] = number_or_null(k_log_bias(affected, &ScenarioResult::k_ratio_before));
  j["k_wear_log_bias_after_affected"] = number_or_null(k_log_bias(affected, &ScenarioResult::k_ratio_after));
  j["k_wear_true"] = k_true_;
  j["wear_depth_um"] = o_.wear_depth_um;
  j["wear_cycles"] = o_.wear_cycles;
  nlohmann::json per = nlohmann::json::array();
  for (const auto& [name, row] : rows_)
    per.push_back({{"effect", name},
                   {"runs", row.runs},
                   {"detected", row.detected},
                   {"identifiable", row.identifiable},
                   {"top1_accuracy_identifiable", number_or_null(fraction(row.top1_identifiable, row.identifiable))},
                   {"top1_accuracy", number_or_null(fraction(row.top1, row.runs))},
                   {"top2_accuracy", number_or_null(fraction(row.top2, row.runs))},
                   {"localisation_rate", number_or_null(fraction(row.localised, row.runs))},
                   {"median_shrinkage", number_or_null(median(row.shrink))},
                   {"k_wear_bias_before", number_or_null(median(row.k_bias_before))},
                   {"k_wear_bias_after", number_or_null(median(row.k_bias_after))}});
  j["per_effect"] = per;
  nlohmann::json scen = nlohmann::json::array();
  for (const auto& r : runs_) scen.push_back(scenario_json(r));
  j["scenarios"] = scen;
  nlohmann::json qs = nlohmann::json::array();
  for (const auto& q : quiet_)
    qs.push_back({{"detected", q.detected}, {"chosen", outcome_json_names(q.chosen)}, {"families", q.families}, {"k_wear_ratio_before", number_or_null(q.k_ratio_before)},
                  {"k_wear_ratio_after", number_or_null(q.k_ratio_after)}});
  j["no_effect_scenarios"] = qs;
  return j;
}

BenchTable RigBench::table(double wall) const {
  BenchTable table;
  auto heading = table_stream();
  heading << "gap bench: " << o_.seeds << " scenarios with " << o_.effects << " effect(s), " << none_runs_ << " without; "
          << o_.sample_rate_hz << " Hz, " << o_.seconds << " s records; " << wall << " s";
  table.heading = heading.str();
  table.columns = "effect              runs identifiable detected top1 top2 localised median_shrinkage";
  for (const auto& [name, row] : rows_) {
    auto line = table_stream();
    line << std::left << std::setw(20) << name << std::right << std::setw(4) << row.runs << std::setw(13) << row.identifiable
         << std::setw(9) << row.detected << std::setw(5) << fraction(row.top1, row.runs) << std::setw(5)
         << fraction(row.top2, row.runs) << std::setw(10) << fraction(row.localised, row.runs) << std::setw(17)
         << median(row.shrink);
    table.rows.push_back(line.str());
  }
  auto line = [](auto&&... parts) {
    auto s = table_stream();
    (s << ... << parts);
    return s.str();
  };
  table.summary = scores_lines(scores_);
  const std::vector<std::string> detail = {
      line("top1_accuracy ", fraction(total_.top1, total_.runs)),
      line("identifiable_rate ", fraction(total_.identifiable, total_.runs), ", top1 among them ",
           fraction(total_.top1_identifiable, total_.identifiable)),
      line("top2_accuracy ", fraction(total_.top2, total_.runs)),
      line("median_shrinkage ", median(total_.shrink), " (all detected scenarios)"),
      line("k_wear_bias_before ", k_bias(runs_, &ScenarioResult::k_ratio_before), " after ",
           k_bias(runs_, &ScenarioResult::k_ratio_after), " (median |K inferred / K true - 1|; target: after <= before / 2)")};
  table.summary.insert(table.summary.end(), detail.begin(), detail.end());
  return table;
}

void RigBench::run() {
  check_options();
  const auto wall0 = std::chrono::steady_clock::now();
  make_wear_truth();
  run_effect_scenarios();
  run_no_effect_scenarios();
  score();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  printer_.print(document(wall), table(wall));
}

}  // namespace

void add_gap_bench_command(CLI::App& app) {
  auto opt = std::make_shared<BenchOptions>();
  auto* cmd = gap_command(app)->add_subcommand("bench", "Withheld-effect check: rig scenarios with hidden effects, diagnosed and scored");
  cmd->add_option("--seeds", opt->seeds, "Scenarios with effects (each effect equally often)")->required();
  cmd->add_option("--effects", opt->effects, "Effects on per scenario: 1 or 2");
  add_format_option(cmd, opt->format, "table", {"table", "json"});
  cmd->add_option("--sample-rate", opt->sample_rate_hz, "Sample rate of the simulated records, Hz");
  cmd->add_option("--seconds", opt->seconds, "Length of each simulated record, s");
  cmd->add_option("--torques", opt->torques_nm, "Input torques: every speed runs at each, N m (comma-separated)")
      ->delimiter(',');
  cmd->add_option("--no-effect-runs", opt->no_effect_runs, "Scenarios without effects (default max(2, seeds/5))");
  cmd->add_option("--first-seed,--seed", opt->first_seed, "Seed of the first scenario (draw)");
  cmd->add_option("--bootstrap", opt->bootstrap, "Bootstrap resamples per diagnosis");
  cmd->add_option("--generator", opt->generator,
                  "rig: the rig simulator's effects (default); independent: tests/capture_gen/gap_effects.py on the twin's captures")
      ->check(CLI::IsMember({"rig", "independent"}));
  cmd->add_option("--generator-script", opt->generator_script, "The independent generator (default relative to the source tree)");
  cmd->add_option("--python", opt->python, "Python 3 with numpy and scipy (default $GEARWATCH_PYTHON, /usr/bin/python3, python3)");
  cmd->add_option("--config", opt->config, "Configuration (independent generator: [gap], [records], [twin]; default built-in)");
  cmd->add_option("--jobs", opt->jobs, "Draws diagnosed in parallel threads (--generator independent)")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  cmd->add_option("--floor-db", opt->floor_db, "Diagnosis floor, dB re the twin's total line power");
  cmd->add_option("--min-gap-db", opt->min_gap_db, "Smallest line-family gap the diagnosis calls significant, dB");
  cmd->add_option("--min-residual-gap-db", opt->min_residual_gap_db,
                  "Smallest broadband or fixed-frequency gap the diagnosis calls significant, dB");
  cmd->add_option("--wear-depth-um", opt->wear_depth_um, "Known wear depth at the sliding extremes (rig and twin), um");
  cmd->add_option("--wear-cycles", opt->wear_cycles, "Cycles over which the known K_wear produced that depth");
  cmd->callback([opt, cmd] {
    opt->sample_rate_given = cmd->count("--sample-rate") > 0;
    opt->seconds_given = cmd->count("--seconds") > 0;
    opt->bootstrap_given = cmd->count("--bootstrap") > 0;
    if (opt->generator == "independent") return run_independent(*opt);
    // The rig bench's twin and rig caches are filled as scenarios go, by one thread.
    if (opt->jobs != 1) throw CommandError("--jobs applies to --generator independent; the rig bench runs its scenarios one by one");
    RigBench(*opt).run();
  });
}

void register_gap(CLI::App& app) {
  add_gap_report_command(app);
  add_gap_diagnose_command(app);
  add_gap_bench_command(app);
}

}  // namespace gearwatch::cli
