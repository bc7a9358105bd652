// `gearwatch simulate`: one rig capture (`--out FILE`), or a wear campaign (`--campaign ... --out
// DIR`): records in cycle order and truth.json, made by the rig simulator (rig/).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <vector>

#include <nlohmann/json.hpp>

#include "capture_writer.hpp"
#include "cli_common.hpp"
#include "decoder_setup.hpp"
#include "model_thread.hpp"
#include "prognosis_scoring.hpp"
#include "gearwatch/config/twin_config.hpp"
#include "gearwatch/rig/campaign.hpp"
#include "gearwatch/rig/rig_simulator.hpp"
#include "gearwatch/twin/simulation.hpp"

namespace gearwatch::cli {
namespace {

namespace fs = std::filesystem;

/// A rig record as a capture: its channels and the input shaft's encoder (one edge per revolution).
class RigCaptureSignal final : public daemon::CaptureSignal {
 public:
  explicit RigCaptureSignal(rig::RigRecord r) : r_(std::move(r)) {}
  int channels() const override { return static_cast<int>(r_.acceleration.size()); }
  double sample_rate_hz() const override { return r_.sample_rate_hz; }
  double input_revolutions_at(double t) const override {
    // Each encoder edge completes a revolution (the daemon adds the edges after a life-counter
    // frame to its value), so the odometer's whole part is the number of edges passed.
    const auto& e = r_.tacho_edges;
    const double pos = t * r_.sample_rate_hz;
    const auto k = static_cast<std::size_t>(std::upper_bound(e.begin(), e.end(), pos) - e.begin());
    if (e.empty()) return 0.0;
    if (k == 0) return std::clamp(pos / e.front(), 0.0, 0.999999);
    if (k == e.size()) return static_cast<double>(k);
    return static_cast<double>(k) + (pos - e[k - 1]) / (e[k] - e[k - 1]);
  }
  void generate(std::uint64_t first, std::size_t count, std::vector<std::vector<double>>& out) override {
    out.resize(r_.acceleration.size());
    for (std::size_t c = 0; c < r_.acceleration.size(); ++c) {
      out[c].resize(count);
      for (std::size_t i = 0; i < count; ++i) {
        const std::uint64_t k = first + i;
        out[c][i] = k < r_.acceleration[c].size() ? r_.acceleration[c][k] : 0.0;
      }
    }
  }
  std::vector<double> tacho_edges(double from, double to, int epr) const override {
    if (epr != 1) throw std::runtime_error("the rig simulator's encoder gives one edge per revolution: set edges_per_rev = 1");
    return {std::lower_bound(r_.tacho_edges.begin(), r_.tacho_edges.end(), from),
            std::lower_bound(r_.tacho_edges.begin(), r_.tacho_edges.end(), to)};
  }

 private:
  rig::RigRecord r_;
};

/// Where a single capture's signal comes from (--physics).
enum class CapturePhysics { synthetic, twin, rig };
const TokenTable<CapturePhysics> kCapturePhysicsTokens{
    {"synthetic", CapturePhysics::synthetic}, {"twin", CapturePhysics::twin}, {"rig", CapturePhysics::rig}};

struct Options {
  std::string out, config;
  daemon::CaptureSettings cs;
  bool classic = false, fd = false;
  std::string physics = "synthetic";   ///< a token of kCapturePhysicsTokens (checked by CLI11)
  CapturePhysics physics_kind() const { return value_of(kCapturePhysicsTokens, physics); }
  std::string campaign, effects;
  int records = 0;
  double seconds = 0;
};

rig::EffectSet make_effects(const std::string& list, bool seeded, std::uint64_t seed,
                            const std::map<std::string, double>& fixed) {
  rig::EffectSet fx = rig::EffectSet::parse(list);
  if (seeded) fx.randomise(seed);
  for (const auto& [name, value] : fixed) fx.set(name, value);
  return fx;
}

/// The words --campaign takes besides a file name: a built-in campaign, or one drawn from the seed.
enum class CampaignWord { lubricated, dry, healthy, random };
const TokenTable<CampaignWord> kCampaignWords{{rig::to_string(rig::BuiltinCampaign::lubricated), CampaignWord::lubricated},
                                              {rig::to_string(rig::BuiltinCampaign::dry), CampaignWord::dry},
                                              {rig::to_string(rig::BuiltinCampaign::healthy), CampaignWord::healthy},
                                              {"random", CampaignWord::random}};

/// The campaign named on the command line: built in, drawn at random from the seed, or a file.
rig::CampaignSpec campaign_spec(const Options& opt, bool seeded) {
  const auto word = find_value(kCampaignWords, opt.campaign);
  if (!word) return rig::load_campaign_file(opt.campaign);
  switch (*word) {
    case CampaignWord::lubricated: return rig::builtin_campaign(rig::BuiltinCampaign::lubricated);
    case CampaignWord::dry: return rig::builtin_campaign(rig::BuiltinCampaign::dry);
    case CampaignWord::healthy: return rig::builtin_campaign(rig::BuiltinCampaign::healthy);
    case CampaignWord::random: break;
  }
  if (!seeded) throw CommandError("--campaign random needs --seed N (the campaign is drawn from it)");
  return rig::random_campaign(opt.cs.signal.seed);
}

double deepest_flank_point(const rig::WearState& w) {
  double m = 0;
  for (double d : w.profile.pinion) m = std::max(m, d);
  for (double d : w.profile.gear) m = std::max(m, d);
  return m;
}

/// Where the truth crosses the model's limits (the configured wear and pitting limits), continued
/// past the campaign's last stop by the model's forecast horizon, so the forecasts a replay gives
/// can be held against the truth's cycles left. The search is the prognosis benchmark's (a stop
/// spacing forward, then bisection to 1/1024 of it); null where the truth does not get there.
nlohmann::json truth_limits(const rig::CampaignSpec& spec, const twin::GearboxParameters& params,
                            const config::GearwatchConfig& cfg) {
  const wear::ModelSettings s = daemon::model_settings(cfg);
  const auto truth = rig::make_wear_truth(spec.wear, params, spec.measurement_speeds_hz.front());
  const double step = spec.stop_interval_cycles > 0 ? spec.stop_interval_cycles : spec.max_cycles / 20.0;
  const double to = spec.max_cycles + s.forecast_horizon_cycles;
  nlohmann::json j{{"wear_limit_m", s.wear_limit_m}, {"pitting_limit", s.pitting_limit}, {"searched_to_cycles", to}};
  auto crossing = [&](const daemon::prognosis::TruthCurve& curve, double level) -> nlohmann::json {
    try {
      const auto c = daemon::prognosis::first_crossing(curve, level, 0.0, to, step, step / 1024.0);
      return c ? nlohmann::json(*c) : nlohmann::json();
    } catch (const std::exception& e) {
      return nlohmann::json(std::string("not computed: ") + e.what());
    }
  };
  j["wear_limit_cycles"] = crossing([&](double n) { return deepest_flank_point(truth->at(n)); }, s.wear_limit_m);
  j["pitting_limit_cycles"] = crossing([&](double n) { return truth->at(n).pitting_density; }, s.pitting_limit);
  return j;
}

/// The campaign asked for, with the command line's records, seconds, channels and effects over its own.
rig::CampaignSpec campaign_of(const Options& opt, bool seeded, bool channels_given, bool effects_given) {
  rig::CampaignSpec spec = campaign_spec(opt, seeded);
  if (opt.records > 0) spec.records = opt.records;
  if (opt.seconds > 0) spec.seconds = opt.seconds;
  if (channels_given) {
    if (opt.cs.signal.channels < 1 || opt.cs.signal.channels > 2) throw CommandError("--channels must be 1 or 2 for a campaign");
    spec.channels = opt.cs.signal.channels;
  }
  if (effects_given) spec.effects = opt.effects;
  return spec;
}

/// What a campaign takes from --config (the defaults without one): the captures' scaling, tacho and
/// protocol ids, and the gearbox the rig simulates.
struct CampaignSetup {
  daemon::CaptureSettings cs;
  twin::GearboxParameters params;
  config::GearwatchConfig cfg;
};

CampaignSetup campaign_setup(const Options& opt) {
  CampaignSetup setup;
  setup.cs.tacho = opt.cs.tacho;
  if (!opt.config.empty()) {
    setup.cfg = load_config_or_defaults(opt.config);
    setup.cs.scale_m_s2_per_lsb = setup.cfg.rig.channels.front().scale_m_s2_per_lsb;
    setup.cs.edges_per_rev = setup.cfg.rig.tachos.front().edges_per_rev;
    setup.cs.ids = daemon::protocol_ids(setup.cfg);
    setup.params = config::load_twin_parameters(opt.config);
  }
  if (setup.cs.edges_per_rev != 1) throw CommandError("the rig simulator's encoder gives one edge per revolution: set edges_per_rev = 1");
  return setup;
}

/// Refuses before writing anything when the records would not fit on the output's file system.
void refuse_without_space(const rig::CampaignSpec& spec, const std::vector<rig::PlannedRecord>& plan, const std::string& out_dir) {
  std::uint64_t needed = 65536;
  for (const auto& p : plan) needed += rig::estimated_capture_bytes(spec.seconds, spec.sample_rate_hz, spec.channels, p.speed_hz) + 8192;
  fs::path probe = fs::absolute(out_dir);
  while (!probe.empty() && !fs::exists(probe) && probe != probe.parent_path()) probe = probe.parent_path();
  std::error_code ec;
  const auto space = fs::space(probe, ec);
  if (!ec && needed > space.available)
    throw CommandError("campaign " + spec.name + " needs about " + std::to_string(needed / 1000000 + 1) + " MB (" +
                       std::to_string(plan.size()) + " records of " + std::to_string(spec.seconds) + " s) but " +
                       probe.string() + " has " + std::to_string(space.available / 1000000) + " MB free; nothing written");
}

/// The wear truth at every record, first: a campaign whose flanks wear through is refused before
/// anything is written.
std::vector<rig::WearState> wear_at_records(const rig::CampaignSpec& spec, const twin::GearboxParameters& params,
                                            const std::vector<rig::PlannedRecord>& plan) {
  std::vector<rig::WearState> wear_states;
  try {
    const auto truth = rig::make_wear_truth(spec.wear, params, spec.measurement_speeds_hz.front());
    for (const auto& p : plan) wear_states.push_back(truth->at(p.cycles));
  } catch (const rig::RigParameterError& e) {
    throw CommandError(std::string("campaign ") + spec.name + ": " + e.what() + "; nothing written");
  }
  return wear_states;
}

/// Simulates and writes one planned record of the campaign, printing its line; its truth.
rig::RecordTruth write_campaign_record(const Options& opt, const rig::CampaignSpec& spec, const CampaignSetup& setup,
                                       const rig::EffectSet& effects, std::uint64_t seed, const rig::PlannedRecord& p,
                                       const rig::WearState& wear) {
  rig::RecordTruth t = rig::record_truth(spec, p, wear);
  RigCaptureSignal signal(rig::simulate_record(setup.params, effects, t.wear, t.sliding, rig::record_run_settings(spec, p, seed)));
  daemon::CaptureSettings record = setup.cs;
  record.duration_s = spec.seconds;
  record.fd = true;
  record.signal.speed_hz = p.speed_hz;
  record.signal.torque_nm = p.torque_nm;
  record.signal.channels = spec.channels;
  record.start_revolutions = t.life_counter;
  record.stream_id = static_cast<std::uint16_t>(1 + p.index % 65535);
  record.start_time_s = 1700000000.0 + p.cycles / p.speed_hz;
  const auto s = daemon::write_capture(record, signal, (fs::path(opt.out) / p.file_name).string());
  std::cout << p.file_name << ": " << p.cycles << " cycles, " << p.speed_hz << " Hz, " << p.torque_nm << " N m, pitting " << t.wear.pitting_density
            << ", mean wear " << t.wear.mean_wear_depth_m * 1e6 << " um, " << s.frames << " frames, " << s.clipped_samples
            << " clipped samples\n";
  return t;
}

void write_campaign_truth(const Options& opt, const rig::CampaignSpec& spec, const CampaignSetup& setup,
                          const rig::EffectSet& effects, std::uint64_t seed, bool seeded,
                          const std::vector<rig::RecordTruth>& truths) {
  std::ofstream out(fs::path(opt.out) / "truth.json");
  nlohmann::json truth_doc = nlohmann::json::parse(
      rig::truth_json(spec, effects, seed, seeded, truths, setup.params.gears.pinion_teeth, setup.params.gears.gear_teeth));
  truth_doc["limits"] = truth_limits(spec, setup.params, setup.cfg);
  out << truth_doc.dump(2) << "\n";
  if (!out) throw CommandError("cannot write " + (fs::path(opt.out) / "truth.json").string());
}

void run_campaign(const Options& opt, bool seeded, bool channels_given, bool effects_given) {
  const rig::CampaignSpec spec = campaign_of(opt, seeded, channels_given, effects_given);
  const std::uint64_t seed = opt.cs.signal.seed;
  const rig::EffectSet effects = rig::campaign_effects(spec, seeded, seed);
  const CampaignSetup setup = campaign_setup(opt);
  const auto plan = rig::plan_records(spec);
  refuse_without_space(spec, plan, opt.out);
  const std::vector<rig::WearState> wear_states = wear_at_records(spec, setup.params, plan);
  fs::create_directories(opt.out);
  std::vector<rig::RecordTruth> truths;
  for (const auto& p : plan) truths.push_back(write_campaign_record(opt, spec, setup, effects, seed, p, wear_states[truths.size()]));
  write_campaign_truth(opt, spec, setup, effects, seed, seeded, truths);
  std::cout << "wrote " << plan.size() << " records and truth.json to " << opt.out << "\n";
}

/// The capture settings of a single capture: the command line's, with --config's scaling, tacho and ids.
daemon::CaptureSettings single_capture_settings(const Options& opt) {
  auto cs = opt.cs;
  cs.fd = !opt.classic;
  if (!opt.config.empty()) {
    const auto cfg = load_config_or_defaults(opt.config);
    cs.scale_m_s2_per_lsb = cfg.rig.channels.front().scale_m_s2_per_lsb;
    cs.edges_per_rev = cfg.rig.tachos.front().edges_per_rev;
    cs.signal.pinion_teeth = cfg.rig.gears.pinion_teeth;
    cs.ids = daemon::protocol_ids(cfg);
  }
  if (!cs.fd && cs.signal.sample_rate_hz * cs.signal.channels > 20000)
    std::cerr << "gearwatch: note: classic CAN carries ~10 kHz per channel at most; this capture is for bench replay only\n";
  return cs;
}

twin::GearboxParameters twin_parameters(const Options& opt) {
  return opt.config.empty() ? twin::GearboxParameters{} : config::load_twin_parameters(opt.config);
}

/// --physics twin: the twin's casing acceleration y6, one channel.
daemon::CaptureSummary write_twin_capture(const Options& opt, daemon::CaptureSettings& cs) {
  if (cs.edges_per_rev != 1) throw CommandError("--physics twin gives one tacho edge per revolution: set edges_per_rev = 1");
  auto y6 = twin::simulate_casing_signal(twin_parameters(opt), twin::ToothProfileDeviation{},
                                         twin::OperatingPoint{cs.signal.speed_hz, cs.signal.torque_nm}, cs.duration_s,
                                         cs.signal.sample_rate_hz);
  cs.signal.channels = 1;
  auto signal = daemon::sampled_capture_signal(y6.sample_rate_hz, std::move(y6.acceleration), std::move(y6.tacho_edges));
  return daemon::write_capture(cs, *signal, opt.out);
}

/// --physics rig: the rig simulator with the --effects (drawn from the seed when one is given), unworn.
daemon::CaptureSummary write_rig_capture(const Options& opt, const daemon::CaptureSettings& cs, bool seeded) {
  if (cs.edges_per_rev != 1) throw CommandError("--physics rig gives one tacho edge per revolution: set edges_per_rev = 1");
  if (cs.signal.channels > 2) throw CommandError("--physics rig has 1 or 2 channels");
  const auto params = twin_parameters(opt);
  const auto fx = make_effects(opt.effects.empty() ? "none" : opt.effects, seeded, cs.signal.seed, {});
  rig::RigRunSettings run;
  run.speed_hz = cs.signal.speed_hz;
  run.torque_nm = cs.signal.torque_nm;
  run.duration_s = cs.duration_s;
  run.sample_rate_hz = cs.signal.sample_rate_hz;
  run.channels = cs.signal.channels;
  run.seed = cs.signal.seed;
  RigCaptureSignal signal(rig::simulate_record(params, fx, {}, {}, run));
  return daemon::write_capture(cs, signal, opt.out);
}

/// One capture (`--out FILE`) of the chosen physics, and its one-line summary.
void run_single_capture(const Options& opt, bool seeded, bool effects_given) {
  if (effects_given && opt.physics_kind() != CapturePhysics::rig) throw CommandError("--effects needs --physics rig");
  auto cs = single_capture_settings(opt);
  daemon::CaptureSummary s;
  try {
    if (opt.physics_kind() == CapturePhysics::twin)
      s = write_twin_capture(opt, cs);
    else if (opt.physics_kind() == CapturePhysics::rig)
      s = write_rig_capture(opt, cs, seeded);
    else
      s = daemon::write_synthetic_capture(cs, opt.out);
  } catch (const CommandError&) {
    throw;
  } catch (const std::exception& e) {
    throw CommandError(e.what());
  }
  std::cout << "wrote " << opt.out << ": " << s.frames << " frames, " << s.samples_per_channel << " samples x "
            << cs.signal.channels << " channels, " << s.tacho_edges << " tacho edges, " << s.clipped_samples
            << " clipped samples\n";
}

/// A campaign (`--campaign ... --out DIR`), its errors as one-line command errors.
void run_campaign_command(const Options& opt, bool seeded, bool channels_given, bool effects_given, bool physics_given) {
  try {
    if (physics_given && opt.physics_kind() != CapturePhysics::rig) throw CommandError("a campaign is made by the rig simulator (--physics rig)");
    run_campaign(opt, seeded, channels_given, effects_given);
  } catch (const CommandError&) {
    throw;
  } catch (const std::exception& e) {
    throw CommandError(e.what());
  }
}

/// The options whose presence (not only their value) decides the run.
struct SimulateOptions {
  CLI::Option *seed = nullptr, *channels = nullptr, *effects = nullptr;
  std::vector<CLI::Option*> single_only;  // options a campaign excludes
};

/// The single capture's options: length, operating point, frames, signal and stream.
void add_capture_options(CLI::App* cmd, const std::shared_ptr<Options>& opt, SimulateOptions& given) {
  auto* duration = cmd->add_option("--duration", opt->cs.duration_s, "Seconds of signal")->check(CLI::Range(0.001, 86400.0))->capture_default_str();
  auto* speed = cmd->add_option("--speed", opt->cs.signal.speed_hz, "Input shaft speed, Hz")->check(CLI::Range(0.1, 1000.0))->capture_default_str();
  auto* torque = cmd->add_option("--torque", opt->cs.signal.torque_nm, "Input torque, N·m")->check(CLI::Range(0.0, 10000.0))->capture_default_str();
  auto* fd = cmd->add_flag("--fd", opt->fd, "CAN FD frames, 30 samples each (default)");
  auto* classic = cmd->add_flag("--classic", opt->classic, "Classic CAN frames, 2 samples each")->excludes(fd);
  given.channels = cmd->add_option("--channels", opt->cs.signal.channels, "Vibration channels (rig and campaigns: 1 or 2)")->check(CLI::Range(1, 8))->capture_default_str();
  cmd->add_option("--sample-rate", opt->cs.signal.sample_rate_hz, "Samples per second")->check(CLI::Range(100.0, 1e6))->capture_default_str();
  cmd->add_option("--speed-fluctuation", opt->cs.signal.speed_fluctuation, "Relative 0.5 Hz speed oscillation (synthetic physics)")->check(CLI::Range(0.0, 0.5));
  given.seed = cmd->add_option("--seed", opt->cs.signal.seed,
                               "Noise seed; with --physics rig or --campaign it also draws the effects' parameters at random, and --campaign random's campaign")
                   ->capture_default_str();
  cmd->add_option("--start-revs", opt->cs.start_revolutions, "Life counter at the first sample")->capture_default_str();
  cmd->add_option("--stream-id", opt->cs.stream_id, "Stream id in the header")->capture_default_str();
  cmd->add_option("--first-index", opt->cs.first_index, "Sample index of the first sample (u32)")->capture_default_str();
  cmd->add_option("--interface", opt->cs.interface, "Interface name written in the log")->capture_default_str();
  cmd->add_flag("--no-tacho", [opt](std::int64_t) { opt->cs.tacho = false; },
                "Send no tacho frames: an accelerometer alone (the daemon then estimates the speed from the signal)");
  given.single_only = {duration, speed, torque, classic};
}

/// Where the signal comes from: configuration, physics, rig effects, a campaign.
void add_source_options(CLI::App* cmd, const std::shared_ptr<Options>& opt, SimulateOptions& given) {
  cmd->add_option("--config", opt->config, "Take channel scaling, tacho edges/rev and the twin's [twin] parameters from this config");
  cmd->add_option("--physics", opt->physics,
                  "synthetic: gear-mesh harmonics, modulated resonance and noise of known amplitudes; "
                  "twin: the 21-DOF twin's casing acceleration y6 (one channel, no wear); "
                  "rig: the rig simulator (the twin plus the --effects, docs/rig-simulator.md)")
      ->check(CLI::IsMember(tokens_of(kCapturePhysicsTokens)))
      ->capture_default_str();
  given.effects = cmd->add_option("--effects", opt->effects,
                                  "Rig effects: all, none or a comma-separated list (docs/rig-simulator.md)");
  auto* campaign = cmd->add_option("--campaign", opt->campaign, "A wear campaign: lubricated, dry, healthy, random (drawn from --seed) or FILE.toml (docs/campaign-file.md)");
  auto* records = cmd->add_option("--records", opt->records, "Campaign: measured stops (default: the campaign's)")->check(CLI::Range(1, 100000));
  auto* seconds = cmd->add_option("--seconds", opt->seconds, "Campaign: seconds per record (default: the campaign's)")->check(CLI::Range(0.1, 3600.0));
  records->needs(campaign);
  seconds->needs(campaign);
  for (auto* o : given.single_only) o->excludes(campaign);
}

}  // namespace

void register_simulate(CLI::App& app) {
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("simulate", "Write a rig capture (protocol v1, candump -L log), or a wear campaign");
  cmd->add_option("--out", opt->out, "Output capture file (a directory with --campaign)")->required();
  SimulateOptions given;
  add_capture_options(cmd, opt, given);
  add_source_options(cmd, opt, given);
  cmd->callback([opt, given, cmd] {
    const bool seeded = given.seed->count() > 0;
    if (!opt->campaign.empty())
      run_campaign_command(*opt, seeded, given.channels->count() > 0, given.effects->count() > 0,
                           cmd->get_option("--physics")->count() > 0);
    else
      run_single_capture(*opt, seeded, given.effects->count() > 0);
  });
}

}  // namespace gearwatch::cli
