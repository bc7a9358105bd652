// `gearwatch gap bench --generator independent` (docs/gap-bench.md, "Independent bench scoring rules"): the twin's
// captures at every operating point, one effect per seed added by tests/capture_gen/gap_effects.py
// (a python3 subprocess: written apart from the rig and the diagnosis, from textbook forms), each
// draw diagnosed as `gap diagnose` diagnoses captures, and scored against the draw's truth.json.
#include "gap_bench_independent.hpp"

#include <stdlib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "capture_writer.hpp"
#include "cli_common.hpp"
#include "decoder_setup.hpp"
#include "gap_bench_output.hpp"
#include "gap_diagnose_captures.hpp"
#include "gap_diagnoser.hpp"
#include "gearwatch/config/twin_config.hpp"
#include "gearwatch/twin/simulation.hpp"

namespace gearwatch::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using gap::CandidateEffect;
using gap::DescriptionKind;
using gap::GapFeature;

// ---------------------------------------------------------------------------------------------
// Scoring: the rules of docs/gap-bench.md, written before any draw was looked at.

struct Place {
  double in_low, in_high;    // extent in input orders
  double out_low, out_high;  // extent in output orders (only meaningful for an output-shaft feature)
};

Place place_of(const GapFeature& f, double z1, double z2) {
  if (f.shaft == gap::FeatureShaft::output)
    return {f.order_low * z1 / z2, f.order_high * z1 / z2, f.order_low, f.order_high};
  return {f.order_low, f.order_high, f.order_low * z2 / z1, f.order_high * z2 / z1};
}

bool within(double x, double low, double high, double margin) { return x >= low - margin && x <= high + margin; }

bool near_ratio(double got, double want, double tolerance) {
  return std::isfinite(got) && std::abs(got - want) <= tolerance * std::abs(want);
}

/// Localisation: the feature sits where the true effect is, within the features' resolution
/// (half an order either side of its extent; one input order at the fastest speed in Hz).
bool localises(const json& t, const GapFeature& f, double top_speed_hz) {
  const std::string form = t["form"];
  const json& p = t["parameters"];
  const double z1 = t["pinion_teeth"], z2 = t["gear_teeth"];
  const Place at = place_of(f, z1, z2);
  if (form == "structural_resonance" || form == "mount_resonance") {
    const double fn = p["frequency_hz"], zeta = p["damping_ratio"];
    return within(fn, f.hz_low, f.hz_high, std::max(top_speed_hz, zeta * fn));
  }
  if (form == "supply_tones") {
    for (int h : p["harmonics"])
      if (within(h * p["frequency_hz"].get<double>(), f.hz_low, f.hz_high, top_speed_hz)) return true;
    return false;
  }
  if (form == "ghost_tone") return within(p["order"].get<double>(), at.in_low, at.in_high, 0.5);
  if (form == "amplitude_modulation" || form == "phase_modulation") {
    const bool input = p["shaft"] == "input";
    if (!input && f.shaft != gap::FeatureShaft::output) return false;
    const double mesh = input ? z1 : z2;  // the mesh order counted on the modulating shaft
    for (int n = 1; n <= 60; ++n)
      for (double sb : {n * mesh - 1, n * mesh + 1})
        if (input ? within(sb, at.in_low, at.in_high, 0.5) : within(sb, at.out_low, at.out_high, 0.5)) return true;
    return false;
  }
  if (form == "floor_step") return f.size_db > 0 && f.hz_high >= p["corner_hz"].get<double>() - top_speed_hz;
  if (form == "path_tilt") {
    const double expected = p["slope_db_per_octave"].get<double>() * std::log2(f.hz / p["reference_hz"].get<double>());
    return std::abs(expected) >= 1.5 && f.size_db * expected > 0;
  }
  return false;
}

/// Description: the right form, its main parameter within 10 %.
bool describes(const json& t, const GapFeature& f) {
  const std::string form = t["form"];
  const json& p = t["parameters"];
  const auto& d = f.description;
  if (form == "structural_resonance" || form == "mount_resonance")
    return d.kind == DescriptionKind::resonance && near_ratio(d.parameter("frequency_hz"), p["frequency_hz"], 0.10);
  if (form == "ghost_tone")
    return d.kind == DescriptionKind::ghost_line && near_ratio(d.parameter("amplitude_m_s2"), p["amplitude_m_s2"], 0.10);
  if (form == "supply_tones")
    return d.kind == DescriptionKind::fixed_tone && d.parameter("supply_hz") == p["frequency_hz"].get<double>();
  if (form == "amplitude_modulation" || form == "phase_modulation") {
    const bool shaft_right = (p["shaft"] == "input") == (d.shaft == gap::FeatureShaft::input);
    const bool am = form == "amplitude_modulation";
    return d.kind == DescriptionKind::modulation && shaft_right &&
           near_ratio(d.parameter(am ? "am_index" : "pm_index_rad"), p[am ? "index" : "index_rad"], 0.10);
  }
  if (form == "floor_step") {
    const double at_centre = d.parameter("level_db") + d.parameter("slope_db_per_decade") * std::log10(f.hz / 1000.0);
    return d.kind == DescriptionKind::floor_change && near_ratio(at_centre, p["step_db"], 0.10);
  }
  if (form == "path_tilt")
    return d.kind == DescriptionKind::path_tilt && near_ratio(d.parameter("tilt_db_per_octave"), p["slope_db_per_octave"], 0.10);
  return false;
}

/// The physical candidates that stand for a form (empty: no physical candidate applies).
std::vector<CandidateEffect> physical_candidates(const std::string& form) {
  if (form == "structural_resonance") return {CandidateEffect::casing_mode};
  if (form == "mount_resonance") return {CandidateEffect::mount_resonance};
  if (form == "floor_step") return {CandidateEffect::noise_floor};
  // A pure AM at a shaft's order is the mesh force rising and falling once a revolution: the load
  // ripple locked to that shaft's order (load_fluctuation), or a run-out whose AM a·e carries it.
  if (form == "amplitude_modulation") return {CandidateEffect::eccentricity, CandidateEffect::load_fluctuation};
  if (form == "phase_modulation") return {CandidateEffect::eccentricity, CandidateEffect::speed_fluctuation};
  return {};
}

json feature_json(const GapFeature& f) {
  json params = json::object();
  for (const auto& [k, v] : f.description.parameters) params[k] = v;
  return {{"where", gap::describe(f)},
          {"movement", gap::to_string(f.movement)},
          {"hz", f.hz},
          {"hz_low", f.hz_low},
          {"hz_high", f.hz_high},
          {"size_db", f.size_db},
          {"described_as", gap::to_string(f.description.kind)},
          {"description", params},
          {"explained_by", f.explained_by ? json(gap::to_string(*f.explained_by)) : json(nullptr)}};
}

}  // namespace

DrawScore score_draw(const json& truth, const gap::GapReport& report, double top_speed_hz, double /*sample_rate_hz*/) {
  DrawScore s;
  s.form = truth["form"];
  s.effect = s.form != "none";
  for (const auto& g : report.before) s.any_finding = s.any_finding || g.significant;
  s.any_finding = s.any_finding || !report.features.empty();
  const auto expected = physical_candidates(s.form);
  s.attribution_applies = !expected.empty();
  json features = json::array();
  for (const auto& f : report.features) {
    json fj = feature_json(f);
    const bool here = s.effect && localises(truth, f, top_speed_hz);
    fj["localised"] = here;
    features.push_back(fj);
    if (!here) continue;
    s.localised = true;
    s.described = s.described || describes(truth, f);
    if (f.explained_by && std::find(expected.begin(), expected.end(), *f.explained_by) != expected.end()) s.attributed = true;
  }
  json chosen = json::array();
  for (auto c : report.chosen) chosen.push_back(gap::to_string(c));
  json families = json::array();
  for (const auto& g : report.before)
    if (g.significant) families.push_back(gap::to_string(g.family));
  json unexplained = json::array();
  for (auto f : report.unexplained) unexplained.push_back(gap::to_string(f));
  // Each candidate's held-out score, so a draw's attribution can be traced from the bench's output.
  json candidates = json::array();
  for (const auto& c : report.candidates) {
    json params = json::object(), bounds = json::array();
    for (const auto& [k, v] : c.parameters) params[k] = v;
    for (const auto& b : c.at_bounds) bounds.push_back(b.name + (b.upper ? " > " : " < ") + std::to_string(b.bound));
    candidates.push_back({{"effect", gap::to_string(c.effect)}, {"ic", c.information_criterion}, {"shrinkage", c.shrinkage},
                          {"worsens_other_family", c.worsens_other_family}, {"at_bounds", bounds}, {"parameters", params}});
  }
  json before = json::object(), after = json::object();
  for (const auto& g : report.before) before[gap::to_string(g.family)] = g.distance_db;
  for (const auto& g : report.after) after[gap::to_string(g.family)] = g.distance_db;
  s.detail = {{"seed", truth["seed"]}, {"form", s.form},  {"parameters", truth["parameters"]}, {"localised", s.localised},
              {"described", s.described}, {"attribution_applies", s.attribution_applies}, {"attributed", s.attributed},
              {"any_finding", s.any_finding}, {"significant_families", families}, {"chosen", chosen},
              {"unexplained", unexplained},
              {"distance_db_before", before}, {"distance_db_after", after}, {"candidates", candidates},
              {"features", features}};
  return s;
}

namespace {

// ---------------------------------------------------------------------------------------------
// The generator as a subprocess.

std::string quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string python_of(const IndependentBenchOptions& o) {
  if (!o.python.empty()) return o.python;
  if (const char* env = std::getenv("GEARWATCH_PYTHON"); env && *env) return env;
  std::error_code ec;
  return fs::exists("/usr/bin/python3", ec) ? "/usr/bin/python3" : "python3";
}

void require_generator(const std::string& python, const std::string& script) {
  std::error_code ec;
  if (!fs::is_regular_file(script, ec))
    throw CommandError("gap bench --generator independent: the generator " + script +
                       " is not there (run from the source tree or give --generator-script)");
  const std::string probe = quoted(python) + " -c 'import numpy, scipy' >/dev/null 2>&1";
  if (std::system(probe.c_str()) != 0)
    throw CommandError("gap bench --generator independent: " + python +
                       " cannot import numpy and scipy (tools/install-deps.sh --test installs python3-numpy and python3-scipy)");
}

json run_generator(const std::string& python, const std::string& script, const std::vector<std::string>& inputs,
                   const fs::path& out_dir, std::uint64_t seed, const GearboxSpec& rig) {
  std::string cmd = quoted(python) + " " + quoted(script) + " --seed " + std::to_string(seed) + " --out-dir " +
                    quoted(out_dir.string()) + " --pinion-teeth " + std::to_string(rig.gears.pinion_teeth) +
                    " --gear-teeth " + std::to_string(rig.gears.gear_teeth) + " --scale " +
                    std::to_string(rig.channels.front().scale_m_s2_per_lsb) + " --in";
  for (const auto& in : inputs) cmd += " " + quoted(in);
  const fs::path err = out_dir.string() + ".stderr";
  cmd += " 2>" + quoted(err.string());
  if (std::system(cmd.c_str()) != 0) {
    std::ifstream e(err);
    std::string line;
    std::getline(e, line);
    throw CommandError("gap bench: the generator failed on seed " + std::to_string(seed) + ": " + line);
  }
  std::ifstream in(out_dir / "truth.json");
  return json::parse(in);
}

// ---------------------------------------------------------------------------------------------
// The bench.

struct Tally {
  int draws = 0, localised = 0, described = 0, applies = 0, attributed = 0, findings = 0;
  void add(const DrawScore& s) {
    ++draws;
    localised += s.localised;
    described += s.described;
    applies += s.attribution_applies;
    attributed += s.attribution_applies && s.attributed;
    findings += s.any_finding;
  }
};

/// The draws tallied: those with an effect, those without, and per form.
struct Tallies {
  Tally effects, none;
  std::map<std::string, Tally> per_form;
  explicit Tallies(const std::vector<DrawScore>& scores) {
    for (const auto& s : scores) {
      (s.effect ? effects : none).add(s);
      per_form[s.form].add(s);
    }
  }
};

struct OperatingCapture {
  double speed, torque;
  std::string path;
};

class IndependentBench {
 public:
  explicit IndependentBench(const IndependentBenchOptions& o)
      : o_(o), cfg_(load_config_or_defaults(o.config)), printer_(o.format) {
    if (o_.bootstrap >= 0) cfg_.gap.bootstrap_resamples = o_.bootstrap;
  }
  void run();

 private:
  void check_options() const;
  void make_workspace();
  void write_twin_captures();
  std::vector<DrawScore> run_draws();
  DrawScore run_draw(std::uint64_t seed);
  void print(const std::vector<DrawScore>& scores, double wall) const;
  json document(const std::vector<DrawScore>& scores, const Tallies& t, double wall) const;
  BenchTable table(const Tallies& t, double wall) const;

  IndependentBenchOptions o_;
  config::GearwatchConfig cfg_;
  BenchPrinter printer_;
  std::string python_;
  fs::path dir_;
  std::vector<OperatingCapture> twin_;
  // Every draw rewrites the same captures' samples only, so the twin's counterpart of each record
  // is the same in every draw: simulated once, by whichever draw asks first.
  std::shared_ptr<daemon::SharedTwinRuns> twin_runs_ = daemon::share_twin_counterparts_across_diagnoses();
};

void IndependentBench::check_options() const {
  if (o_.seeds < 1) throw CommandError("--seeds must be at least 1");
  if (o_.jobs < 1) throw CommandError("--jobs must be at least 1");
  if (o_.speeds_hz.size() < 2 ||
      std::count(o_.speeds_hz.begin(), o_.speeds_hz.end(), o_.held_out_speed_hz) != 1)
    throw CommandError("gap bench --generator independent: the held-out speed must be one of at least two speeds");
  if (!(o_.seconds >= cfg_.rig.schedule.min_length_s))
    throw CommandError("--seconds must be at least [records] min_length_s");
}

void IndependentBench::make_workspace() {
  std::string pattern = (fs::temp_directory_path() / "gearwatch-gap-bench-XXXXXX").string();
  if (!mkdtemp(pattern.data())) throw CommandError("gap bench: cannot make a temporary directory");
  dir_ = pattern;
}

// The twin's own records as captures, as `simulate --physics twin` writes them.
void IndependentBench::write_twin_captures() {
  std::error_code ec;
  const auto params = fs::is_regular_file(cfg_.source_path, ec) ? config::load_twin_parameters(cfg_.source_path)
                                                                 : twin::GearboxParameters{};
  for (double torque : o_.torques_nm)
    for (double speed : o_.speeds_hz) {
      daemon::CaptureSettings cs;
      cs.signal.speed_hz = speed;
      cs.signal.torque_nm = torque;
      cs.signal.sample_rate_hz = o_.sample_rate_hz;
      cs.signal.channels = 1;
      cs.signal.pinion_teeth = cfg_.rig.gears.pinion_teeth;
      cs.duration_s = o_.seconds;
      cs.scale_m_s2_per_lsb = cfg_.rig.channels.front().scale_m_s2_per_lsb;
      cs.ids = daemon::protocol_ids(cfg_);
      auto y6 = twin::simulate_casing_signal(params, twin::ToothProfileDeviation{}, twin::OperatingPoint{speed, torque},
                                             o_.seconds, o_.sample_rate_hz);
      auto signal = daemon::sampled_capture_signal(y6.sample_rate_hz, std::move(y6.acceleration), std::move(y6.tacho_edges));
      std::ostringstream name;
      name << "twin_" << std::fixed << std::setprecision(2) << speed << "hz_" << torque << "nm.log";
      const std::string path = (dir_ / "twin" / name.str()).string();
      fs::create_directories(dir_ / "twin");
      daemon::write_capture(cs, *signal, path);
      twin_.push_back({speed, torque, path});
    }
}

DrawScore IndependentBench::run_draw(std::uint64_t seed) {
  const fs::path out = dir_ / ("seed_" + std::to_string(seed));
  std::vector<std::string> inputs;
  for (const auto& c : twin_) inputs.push_back(c.path);
  const json truth = run_generator(python_, o_.script, inputs, out, seed, cfg_.rig);
  std::vector<std::string> training, held_out;
  for (const auto& r : truth["records"])
    (r["speed_hz"].get<double>() == o_.held_out_speed_hz ? held_out : training).push_back(r["capture"]);
  const gap::GapReport report = diagnose_capture_files(training, held_out, cfg_, twin_runs_);
  const double top = *std::max_element(o_.speeds_hz.begin(), o_.speeds_hz.end());
  DrawScore s = score_draw(truth, report, top, o_.sample_rate_hz);
  fs::remove_all(out);
  return s;
}

json IndependentBench::document(const std::vector<DrawScore>& scores, const Tallies& t, double wall) const {
  json j = bench_document({o_.seeds, o_.sample_rate_hz, o_.seconds, o_.torques_nm, wall});
  j["generator"] = "independent";
  j["first_seed"] = o_.first_seed;
  j["speeds_hz"] = o_.speeds_hz;
  j["held_out_speed_hz"] = o_.held_out_speed_hz;
  j["bootstrap_resamples"] = cfg_.gap.bootstrap_resamples;
  j["jobs"] = o_.jobs;
  j["effect_draws"] = t.effects.draws;
  j["no_effect_draws"] = t.none.draws;
  j["localisation_rate"] = number_or_null(fraction(t.effects.localised, t.effects.draws));
  j["description_rate"] = number_or_null(fraction(t.effects.described, t.effects.draws));
  j["attribution_draws"] = t.effects.applies;
  j["attribution_rate"] = number_or_null(fraction(t.effects.attributed, t.effects.applies));
  j["no_effect_finding_rate"] = number_or_null(fraction(t.none.findings, t.none.draws));
  json rows = json::array();
  for (const auto& [form, f] : t.per_form)
    rows.push_back({{"form", form}, {"draws", f.draws}, {"localised", f.localised}, {"described", f.described},
                    {"attribution_draws", f.applies}, {"attributed", f.attributed}, {"any_finding", f.findings}});
  j["per_form"] = rows;
  json draws = json::array();
  for (const auto& s : scores) draws.push_back(s.detail);
  j["draws"] = draws;
  return j;
}

BenchTable IndependentBench::table(const Tallies& t, double wall) const {
  BenchTable table;
  auto heading = table_stream();
  heading << "gap bench (independent generator): " << o_.seeds << " draws from seed " << o_.first_seed << " ("
          << t.effects.draws << " with an effect, " << t.none.draws << " without); " << o_.sample_rate_hz << " Hz, "
          << o_.seconds << " s records; " << wall << " s on " << o_.jobs << " job(s)";
  table.heading = heading.str();
  table.columns = "form                  draws localised described attribution findings";
  for (const auto& [form, f] : t.per_form) {
    auto row = table_stream();
    row << std::left << std::setw(22) << form << std::right << std::setw(5) << f.draws << std::setw(10) << f.localised
        << std::setw(10) << f.described << std::setw(9) << f.attributed << "/" << f.applies << std::setw(9) << f.findings;
    table.rows.push_back(row.str());
  }
  auto line = [](auto&&... parts) {
    auto s = table_stream();
    (s << ... << parts);
    return s.str();
  };
  const Tally& e = t.effects;
  table.summary = {line("localisation_rate ", fraction(e.localised, e.draws), " (target >= 0.95)"),
                   line("description_rate ", fraction(e.described, e.draws), " (target >= 0.90)"),
                   line("attribution_rate ", fraction(e.attributed, e.applies), " over ", e.applies,
                        " draws where one applies (target >= 0.90)"),
                   line("no_effect_finding_rate ", fraction(t.none.findings, t.none.draws), " (target <= 0.05)")};
  return table;
}

void IndependentBench::print(const std::vector<DrawScore>& scores, double wall) const {
  const Tallies t(scores);
  printer_.print(document(scores, t, wall), table(t, wall));
}

/// The draws on `jobs` threads, each draw on one: a draw's report depends on its seed and captures
/// alone, so the scores are those of one thread, kept in seed order whatever order they finish in.
/// The first failure (in seed order) is thrown once the draws under way have finished; no new one starts.
std::vector<DrawScore> IndependentBench::run_draws() {
  const auto n = static_cast<std::size_t>(o_.seeds);
  std::vector<DrawScore> scores(n);
  std::vector<std::exception_ptr> failures(n);
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex output;
  auto worker = [&] {
    for (std::size_t k; !failed && (k = next++) < n;) {
      const std::uint64_t seed = o_.first_seed + k;
      const auto t0 = std::chrono::steady_clock::now();
      try {
        scores[k] = run_draw(seed);
      } catch (...) {
        failures[k] = std::current_exception();
        failed = true;
        continue;
      }
      std::lock_guard lock(output);
      printer_.progress(seed, scores[k].form, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      // The draw's scored detail as one line too, so a run stopped early still gives the draws it finished.
      std::cerr << "draw " << scores[k].detail.dump() << std::endl;
    }
  };
  std::vector<std::thread> threads;
  for (int j = 1; j < std::min<int>(o_.jobs, o_.seeds); ++j) threads.emplace_back(worker);
  worker();
  for (auto& t : threads) t.join();
  for (const auto& f : failures)
    if (f) std::rethrow_exception(f);
  return scores;
}

void IndependentBench::run() {
  check_options();
  python_ = python_of(o_);
  require_generator(python_, o_.script);
  const auto wall0 = std::chrono::steady_clock::now();
  make_workspace();
  std::vector<DrawScore> scores;
  try {
    write_twin_captures();
    scores = run_draws();
  } catch (...) {
    std::error_code ec;
    fs::remove_all(dir_, ec);
    throw;
  }
  std::error_code ec;
  fs::remove_all(dir_, ec);
  print(scores, std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count());
}

}  // namespace

void run_independent_bench(const IndependentBenchOptions& options) { IndependentBench(options).run(); }

}  // namespace gearwatch::cli
