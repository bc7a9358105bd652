#include "gearwatch/rig/campaign.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "gearwatch/types/token.hpp"

namespace gearwatch::rig {
namespace {

// The lubricated test's schedule, which the healthy reference keeps.
const char* kLubricatedSchedule = R"(max_cycles = 3250000
stop_interval_cycles = 100000
torque_nm = 20.0
measurement_speeds_hz = [10.0]
records = 20
seconds = 10.0
)";

// The end of both thesis campaigns: the thesis rig's sliding-signal gains and carrier bands, and
// the effects they enable.
const char* kThesisSlidingAndEffects = R"([sliding]
pitting_gain_m_s2 = 20.0
roughness_gain_m_s2 = 4.0
pitting_band_hz = [3000.0, 9000.0]
abrasion_band_hz = [22000.0, 34000.0]

[effects]
enabled = ["noise"]
)";

// The thesis's tests (Table 3.1), compressed to `records` measured stops. Values documented in
// docs/campaign-file.md.
const char* kLubricated = R"(# The thesis's lubricated test (Table 3.1, test 1): pre-roughened pair, 20 N m, 3.25 M cycles,
# stopped every 0.1 M cycles; fatigue pitting after the run-in.
[campaign]
name = "lubricated"
)";

const char* kLubricatedRest = R"(
[wear]
law = "archard"         # the project's Archard model, K in m^2/N
reference_torque_nm = 20.0
pitting_onset_cycles = 300000
k_pitting = 0.034
pitting_exponent = 1.5
max_pitting = 0.3
initial_roughness = 1.0
runin_cycles = 80000
roughness_per_um = 0.0

[[wear.phase]]          # run-in of the sandpaper-roughened flanks
from_cycles = 0
k_wear = 2.0e-16

[[wear.phase]]          # mild lubricated wear
from_cycles = 230000
k_wear = 3.0e-17

[[wear.phase]]          # wear debris in the oil
from_cycles = 2300000
k_wear = 6.0e-17

)";

const char* kDry = R"(# The thesis's dry test (Table 3.1, test 2): new pair, no lubricant, 5 N m, 38 000 cycles,
# stopped every 5 000 cycles; abrasive wear, rough flanks, no pitting.
[campaign]
name = "dry"
max_cycles = 38000
stop_interval_cycles = 5000
torque_nm = 5.0
measurement_speeds_hz = [10.0]
records = 8
seconds = 10.0

[wear]
law = "archard"
k_pitting = 0.0
initial_roughness = 0.05
runin_cycles = 5000
roughness_per_um = 0.12

[[wear.phase]]
from_cycles = 0
k_wear = 1.0e-13

)";

const char* kHealthy = R"(# A healthy reference: the lubricated test's schedule with no wear, no pitting, smooth flanks.
[campaign]
name = "healthy"
)";

const char* kHealthyRest = R"(
[wear]
k_pitting = 0.0
initial_roughness = 0.0

[sliding]
pitting_gain_m_s2 = 20.0
roughness_gain_m_s2 = 4.0

[effects]
enabled = ["noise"]
)";

/// Reads one table strictly: every key must be asked for; what is left is unknown.
class TableReader {
 public:
  TableReader(const toml::table& t, std::string prefix, std::string source)
      : t_(t), prefix_(std::move(prefix)), source_(std::move(source)) {}

  [[noreturn]] void fail(const toml::node& n, const std::string& key, const std::string& why) const {
    throw CampaignError(source_ + " line " + std::to_string(n.source().begin.line) + ": " + prefix_ + key + " " + why);
  }
  const toml::node* get(const std::string& key) {
    seen_.insert(key);
    return t_.get(key);
  }
  double number(const std::string& key, double fallback, double low, double high) {
    const toml::node* n = get(key);
    if (!n) return fallback;
    if (!n->is_number()) fail(*n, key, "must be a number");
    const double v = n->is_integer() ? static_cast<double>(n->as_integer()->get()) : n->as_floating_point()->get();
    if (!std::isfinite(v) || v < low || v > high) {
      std::ostringstream o;
      o << "= " << v << " is impossible (allowed: " << low << " .. " << high << ")";
      fail(*n, key, o.str());
    }
    return v;
  }
  int integer(const std::string& key, int fallback, int low, int high) {
    const toml::node* n = get(key);
    if (!n) return fallback;
    if (!n->is_integer()) fail(*n, key, "must be an integer");
    const auto v = n->as_integer()->get();
    if (v < low || v > high)
      fail(*n, key, "= " + std::to_string(v) + " is impossible (allowed: " + std::to_string(low) + " .. " + std::to_string(high) + ")");
    return static_cast<int>(v);
  }
  std::string string(const std::string& key, const std::string& fallback) {
    const toml::node* n = get(key);
    if (!n) return fallback;
    if (!n->is_string()) fail(*n, key, "must be a string");
    return n->as_string()->get();
  }
  std::vector<double> numbers(const std::string& key, std::vector<double> fallback, double low, double high) {
    const toml::node* n = get(key);
    if (!n) return fallback;
    if (!n->is_array()) fail(*n, key, "must be an array of numbers");
    std::vector<double> out;
    for (const auto& e : *n->as_array()) {
      if (!e.is_number()) fail(*n, key, "must be an array of numbers");
      const double v = e.is_integer() ? static_cast<double>(e.as_integer()->get()) : e.as_floating_point()->get();
      if (!std::isfinite(v) || v < low || v > high) {
        std::ostringstream o;
        o << "holds " << v << ", impossible (allowed: " << low << " .. " << high << ")";
        fail(*n, key, o.str());
      }
      out.push_back(v);
    }
    if (out.empty()) fail(*n, key, "must not be empty");
    return out;
  }
  const toml::table* subtable(const std::string& key) {
    const toml::node* n = get(key);
    if (!n) return nullptr;
    if (!n->is_table()) fail(*n, key, "must be a table");
    return n->as_table();
  }
  void reject_unknown() const {
    for (auto&& [k, v] : t_) {
      const std::string key(k.str());
      if (!seen_.count(key)) fail(v, key, "is not a known key");
    }
  }

 private:
  const toml::table& t_;
  std::string prefix_, source_;
  std::set<std::string> seen_;
};

std::string pad(double v, int width) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%0*.0f", width, v);
  return buffer;
}

}  // namespace

const char* to_string(BuiltinCampaign campaign) noexcept {
  switch (campaign) {
    case BuiltinCampaign::lubricated: return "lubricated";
    case BuiltinCampaign::dry: return "dry";
    case BuiltinCampaign::healthy: return "healthy";
  }
  return "unknown";
}

// Each text is put together from its parts above: the head, the schedule, the rest, the end.
std::string builtin_campaign_text(BuiltinCampaign campaign) {
  switch (campaign) {
    case BuiltinCampaign::lubricated: return std::string(kLubricated) + kLubricatedSchedule + kLubricatedRest + kThesisSlidingAndEffects;
    case BuiltinCampaign::dry: return std::string(kDry) + kThesisSlidingAndEffects;
    case BuiltinCampaign::healthy: return std::string(kHealthy) + kLubricatedSchedule + kHealthyRest;
  }
  return {};
}

CampaignSpec builtin_campaign(BuiltinCampaign campaign) {
  return parse_campaign(builtin_campaign_text(campaign), std::string("built-in campaign ") + to_string(campaign));
}

namespace {

BuiltinCampaign builtin_campaign_named(const std::string& name) {
  if (const auto c = from_token(kAllBuiltinCampaigns, name)) return *c;
  throw CampaignError("unknown campaign '" + name + "' (built in: lubricated, dry, healthy; or a .toml file)");
}

}  // namespace

std::string builtin_campaign_text(const std::string& name) { return builtin_campaign_text(builtin_campaign_named(name)); }

CampaignSpec builtin_campaign(const std::string& name) { return builtin_campaign(builtin_campaign_named(name)); }

CampaignSpec load_campaign_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw CampaignError("cannot read campaign file " + path);
  std::stringstream text;
  text << in.rdbuf();
  return parse_campaign(text.str(), path);
}

namespace {

// [campaign]: the schedule, the operating point and the recording.
void read_campaign_table(const toml::table& campaign, const std::string& source, CampaignSpec& c) {
  TableReader r(campaign, "campaign.", source);
  c.name = r.string("name", "campaign");
  c.max_cycles = r.number("max_cycles", 0, 1, 1e12);
  if (!campaign.get("max_cycles")) throw CampaignError(source + ": campaign.max_cycles is required");
  c.stop_interval_cycles = r.number("stop_interval_cycles", c.max_cycles, 1, 1e12);
  c.torque_nm = r.number("torque_nm", 20, 0, 200);
  c.measurement_speeds_hz = r.numbers("measurement_speeds_hz", {10.0}, 0.5, 60);
  c.records = r.integer("records", 20, 1, 100000);
  c.seconds = r.number("seconds", 10, 0.1, 3600);
  c.sample_rate_hz = r.number("sample_rate_hz", 100000, 1000, 1000000);
  c.channels = r.integer("channels", 2, 1, 2);
  c.integration_rate_hz = r.number("integration_rate_hz", kDefaultIntegrationRateHz, 50000, 2000000);
  r.reject_unknown();
  if (c.stop_interval_cycles > c.max_cycles) {
    const toml::node* n = campaign.get("stop_interval_cycles");
    throw CampaignError(source + " line " + std::to_string(n ? n->source().begin.line : 0) +
                        ": campaign.stop_interval_cycles is larger than campaign.max_cycles");
  }
}

// [wear] and its [[wear.phase]] entries: the built-in wear truth.
void read_wear_table(const toml::table& wear, const std::string& source, CampaignSpec& c) {
  TableReader r(wear, "wear.", source);
  const std::string law = r.string("law", "linear");
  if (law == "archard") {
    c.wear.law = WearLaw::archard;
  } else if (law != "linear") {
    r.fail(*wear.get("law"), "law", "must be \"linear\" or \"archard\" (the other forms: --campaign random)");
  }
  c.wear.reference_torque_nm = r.number("reference_torque_nm", 20, 0.01, 1000);
  c.wear.pitting_onset_cycles = r.number("pitting_onset_cycles", 0, 0, 1e12);
  c.wear.k_pitting = r.number("k_pitting", 0, 0, 10);
  c.wear.pitting_exponent = r.number("pitting_exponent", 1.5, 0.1, 10);
  c.wear.max_pitting = r.number("max_pitting", 0.3, 0, 1);
  c.wear.initial_roughness = r.number("initial_roughness", 0, 0, 100);
  c.wear.runin_cycles = r.number("runin_cycles", 1e5, 1, 1e12);
  c.wear.roughness_per_um = r.number("roughness_per_um", 0, 0, 100);
  if (const toml::node* phases = r.get("phase")) {
    if (!phases->is_array_of_tables()) r.fail(*phases, "phase", "must be an array of tables ([[wear.phase]])");
    for (const auto& p : *phases->as_array()) {
      TableReader pr(*p.as_table(), "wear.phase.", source);
      WearPhase w;
      w.from_cycles = pr.number("from_cycles", 0, 0, 1e12);
      w.k_wear = pr.number("k_wear", 0, 0, 1e-6);
      pr.reject_unknown();
      if (!c.wear.phases.empty() && w.from_cycles <= c.wear.phases.back().from_cycles)
        pr.fail(p.as_table()->get("from_cycles") ? *p.as_table()->get("from_cycles") : p, "from_cycles",
                "must increase from one phase to the next");
      c.wear.phases.push_back(w);
    }
  }
  r.reject_unknown();
}

// [sliding]: the sliding vibration's gains and carrier bands.
void read_sliding_table(const toml::table& sliding, const std::string& source, CampaignSpec& c) {
  TableReader r(sliding, "sliding.", source);
  c.pitting_gain_m_s2 = r.number("pitting_gain_m_s2", 0, 0, 1000);
  c.roughness_gain_m_s2 = r.number("roughness_gain_m_s2", 0, 0, 1000);
  for (auto [key, low, high] : {std::tuple{"pitting_band_hz", &c.bands.pitting_band_low_hz, &c.bands.pitting_band_high_hz},
                                std::tuple{"abrasion_band_hz", &c.bands.abrasion_band_low_hz, &c.bands.abrasion_band_high_hz}}) {
    const auto band = r.numbers(key, {*low, *high}, 1, 0.5 * c.sample_rate_hz * 0.98);
    if (band.size() != 2 || !(band[0] < band[1]))
      r.fail(*sliding.get(key), key, "must be [low, high] with low < high, below half the sample rate");
    *low = band[0];
    *high = band[1];
  }
  r.reject_unknown();
}

// [effects]: which rig effects are on and the parameters the file fixes.
void read_effects_table(const toml::table& effects, const std::string& source, CampaignSpec& c) {
  TableReader r(effects, "effects.", source);
  if (const toml::node* n = r.get("enabled")) {
    if (n->is_string()) {
      c.effects = n->as_string()->get();
    } else if (n->is_array()) {
      c.effects.clear();
      for (const auto& e : *n->as_array()) {
        if (!e.is_string()) r.fail(*n, "enabled", "must be \"all\", \"none\" or an array of effect names");
        c.effects += (c.effects.empty() ? "" : ",") + std::string(e.as_string()->get());
      }
      if (c.effects.empty()) c.effects = "none";
    } else {
      r.fail(*n, "enabled", "must be \"all\", \"none\" or an array of effect names");
    }
    try {
      EffectSet::parse(c.effects);
    } catch (const RigParameterError& e) {
      r.fail(*n, "enabled", std::string(": ") + e.what());
    }
  }
  for (Effect e : all_effects()) {
    const toml::table* t = r.subtable(effect_name(e));
    if (!t) continue;
    TableReader er(*t, std::string("effects.") + effect_name(e) + ".", source);
    for (const auto& p : effect_parameter_table()) {
      if (p.effect != e) continue;
      const std::string key = std::string(p.name).substr(std::string(effect_name(e)).size() + 1);
      if (const toml::node* n = t->get(key)) {
        const double v = er.number(key, 0, -1e300, 1e300);
        try {
          EffectSet probe;
          probe.set(p.name, v);
        } catch (const RigParameterError& ex) {
          er.fail(*n, key, std::string("refused: ") + ex.what());
        }
        c.effect_values[p.name] = v;
      }
    }
    er.reject_unknown();
  }
  r.reject_unknown();
}

}  // namespace

CampaignSpec parse_campaign(const std::string& text, const std::string& source) {
  toml::table root;
  try {
    root = toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    throw CampaignError(source + " line " + std::to_string(e.source().begin.line) + ": " + std::string(e.description()));
  }
  CampaignSpec c;
  TableReader top(root, "", source);
  const toml::table* campaign = top.subtable("campaign");
  if (!campaign) throw CampaignError(source + ": the [campaign] table is missing");
  read_campaign_table(*campaign, source, c);
  c.wear.torque_nm = c.torque_nm;
  if (const toml::table* wear = top.subtable("wear")) read_wear_table(*wear, source, c);
  if (const toml::table* sliding = top.subtable("sliding")) read_sliding_table(*sliding, source, c);
  if (c.bands.abrasion_band_high_hz >= 0.5 * c.sample_rate_hz && c.roughness_gain_m_s2 > 0)
    throw CampaignError(source + ": sliding.abrasion_band_hz reaches above half of campaign.sample_rate_hz");
  if (const toml::table* effects = top.subtable("effects")) read_effects_table(*effects, source, c);
  top.reject_unknown();
  return c;
}

std::vector<PlannedRecord> plan_records(const CampaignSpec& c) {
  std::vector<double> cycles;
  const auto stops = static_cast<long long>(std::floor(c.max_cycles / c.stop_interval_cycles + 1e-9)) + 1;
  if (c.records == 1) {
    cycles.push_back(0);
  } else if (c.records <= stops) {
    for (int k = 0; k < c.records; ++k) {
      const auto stop = std::llround(static_cast<double>(k) * static_cast<double>(stops - 1) / (c.records - 1));
      cycles.push_back(static_cast<double>(stop) * c.stop_interval_cycles);
    }
  } else {
    for (int k = 0; k < c.records; ++k) cycles.push_back(std::round(c.max_cycles * k / (c.records - 1)));
  }
  std::vector<PlannedRecord> out;
  for (double n : cycles)
    for (double speed : c.measurement_speeds_hz) {
      PlannedRecord p;
      p.index = static_cast<int>(out.size());
      p.cycles = n;
      p.speed_hz = speed;
      p.torque_nm = c.torque_schedule().at(n);
      char speed_text[32];
      std::snprintf(speed_text, sizeof speed_text, "%gHz", speed);
      p.file_name = "rec_" + pad(p.index, 5) + "_c" + pad(n, 12) + "_" + speed_text + ".log";
      out.push_back(p);
    }
  return out;
}

std::uint64_t estimated_capture_bytes(double seconds, double fs, int channels, double speed_hz) {
  // An FD frame of 30 samples: "(1700000000.000000) can0 100##1" + 8 hex index + 120 hex samples
  // + newline = 160 bytes; tacho frames ~45 bytes per edge; header, condition, life counter ~150
  // bytes a second.
  const double samples = seconds * fs;
  return static_cast<std::uint64_t>(std::ceil(samples / 30.0) * 160.0 * channels + seconds * (speed_hz * 45.0 + 150.0) + 4096);
}

EffectSet campaign_effects(const CampaignSpec& spec, bool seeded, std::uint64_t seed) {
  EffectSet fx = EffectSet::parse(spec.effects);
  if (seeded) fx.randomise(seed);
  for (const auto& [name, value] : spec.effect_values) fx.set(name, value);
  return fx;
}

RecordTruth record_truth(const CampaignSpec& spec, const PlannedRecord& plan, const WearState& wear) {
  RecordTruth t;
  t.plan = plan;
  t.wear = wear;
  t.sliding = spec.bands;
  t.sliding.pitting_rms_m_s2 = spec.pitting_gain_m_s2 * wear.pitting_density;
  t.sliding.abrasion_rms_m_s2 = spec.roughness_gain_m_s2 * wear.roughness;
  t.life_counter = static_cast<std::uint64_t>(std::llround(plan.cycles));
  return t;
}

RigRunSettings record_run_settings(const CampaignSpec& spec, const PlannedRecord& plan, std::uint64_t seed) {
  RigRunSettings run;
  run.speed_hz = plan.speed_hz;
  run.torque_nm = plan.torque_nm;
  run.duration_s = spec.seconds;
  run.sample_rate_hz = spec.sample_rate_hz;
  run.channels = spec.channels;
  run.min_ode_rate_hz = spec.integration_rate_hz;
  run.seed = seed * 1000003ull + static_cast<std::uint64_t>(plan.index);
  return run;
}

namespace {

/// truth.json's "truth_forms": every drawn form and parameter of a `forms` campaign.
nlohmann::json truth_forms_json(const CampaignSpec& c) {
  using nlohmann::json;
  const auto& f = c.wear.forms;
  json j;
  j["wear_coefficient_form"] = to_string(f.wear);
  j["k0_m_per_cycle"] = f.k0;
  j["k_unit"] = "m of depth per pinion cycle at the pinion's sliding extreme, at the reference torque";
  j["reference_torque_nm"] = c.wear.reference_torque_nm;
  j["lubricant"] = {{"viscosity_pa_s", f.film.viscosity_pa_s}, {"pressure_viscosity_per_pa", f.film.pressure_viscosity_per_pa}};
  j["roughness"] = {{"initial_um", f.roughness.initial_um},
                    {"final_um", f.roughness.final_um},
                    {"runin_cycles", f.roughness.runin_cycles},
                    {"index_floor", f.roughness.index_floor},
                    {"index_per_um_wear", f.roughness.index_per_um_wear}};
  j["contamination"] = f.contamination.on() ? json{{"from_cycles", f.contamination.from_cycles},
                                                   {"wear_factor", f.contamination.wear_factor},
                                                   {"pitting_growth_factor", f.contamination.pitting_growth_factor}}
                                            : json(nullptr);
  j["load_change"] = c.load_change_cycles >= 0
                         ? json{{"from_cycles", c.load_change_cycles}, {"torque_before_nm", c.torque_nm}, {"torque_after_nm", c.torque_after_nm}}
                         : json(nullptr);
  j["pitting_form"] = to_string(f.pitting);
  if (f.pitting == PittingForm::weibull) {
    const auto& w = f.weibull;
    j["pitting"] = {{"shape", w.shape},
                    {"characteristic_life_cycles", w.characteristic_life_cycles},
                    {"location_cycles", w.location_cycles},
                    {"sites", w.sites},
                    {"initial_area_mm2", w.initial_area_m2 * 1e6},
                    {"max_area_mm2", w.max_area_m2 * 1e6},
                    {"growth_per_cycle", w.growth_per_cycle},
                    {"pit_growth", to_string(w.growth)},
                    {"pit_growth_power", w.growth_power},
                    {"reference_torque_nm", w.reference_torque_nm},
                    {"load_life_exponent", w.load_life_exponent},
                    {"max_density", w.max_density},
                    {"seed", w.seed},
                    {"k_pitting_meaning", "the pit growth rate in force, 1/cycle"}};
  }
  if (c.random.drawn)
    j["random"] = {{"seed", c.random.seed},
                   {"regime", to_string(c.random.regime)},
                   {"final_depth_target_um", c.random.final_depth_target_um},
                   {"final_density_target", c.random.final_density_target},
                   {"pit_site_oversupply", c.random.pit_site_oversupply},
                   {"pit_growth_cycles", c.random.pit_growth_cycles}};
  return j;
}

}  // namespace

std::string truth_json(const CampaignSpec& c, const EffectSet& effects, std::uint64_t seed, bool seeded,
                       const std::vector<RecordTruth>& records, int pinion_teeth, int gear_teeth) {
  using nlohmann::json;
  json j;
  j["campaign"] = {{"name", c.name},
                   {"max_cycles", c.max_cycles},
                   {"stop_interval_cycles", c.stop_interval_cycles},
                   {"torque_nm", c.torque_nm},
                   {"load_change_cycles", c.load_change_cycles >= 0 ? json(c.load_change_cycles) : json(nullptr)},
                   {"torque_after_nm", c.load_change_cycles >= 0 ? json(c.torque_after_nm) : json(nullptr)},
                   {"measurement_speeds_hz", c.measurement_speeds_hz},
                   {"records", records.size()},
                   {"seconds", c.seconds},
                   {"sample_rate_hz", c.sample_rate_hz},
                   {"channels", c.channels},
                   {"integration_rate_hz", c.integration_rate_hz},
                   {"wear_law", to_string(c.wear.law)}};
  if (c.wear.law == WearLaw::forms) j["truth_forms"] = truth_forms_json(c);
  j["seed"] = seed;
  j["effect_parameters_drawn_at_random"] = seeded;
  json fx;
  fx["enabled"] = json::array();
  for (Effect e : effects.enabled_effects()) fx["enabled"].push_back(effect_name(e));
  fx["parameters"] = json::object();
  for (const auto& [name, value] : effects.active_parameters()) {
    const auto* info = find_effect_parameter(name);
    fx["parameters"][name] = {{"value", value}, {"unit", info ? info->unit : ""}};
  }
  if (effects.enabled(Effect::tooth_errors)) {
    const auto p = effects.tooth_pattern(pinion_teeth, gear_teeth);
    auto um = [](const std::vector<double>& v) {
      std::vector<double> out;
      for (double x : v) out.push_back(x * 1e6);
      return out;
    };
    fx["tooth_pattern_um"] = {{"pinion_spacing", um(p.pinion_spacing_m)},
                              {"pinion_slope", um(p.pinion_slope_m)},
                              {"gear_spacing", um(p.gear_spacing_m)},
                              {"gear_slope", um(p.gear_slope_m)}};
  }
  j["effects"] = fx;
  json list = json::array();
  for (const auto& r : records) {
    std::vector<double> pinion_um, gear_um;
    for (double d : r.wear.profile.pinion) pinion_um.push_back(d * 1e6);
    for (double d : r.wear.profile.gear) gear_um.push_back(d * 1e6);
    list.push_back({{"file", r.plan.file_name},
                    {"index", r.plan.index},
                    {"cycles", r.plan.cycles},
                    {"life_counter_revolutions", r.life_counter},
                    {"speed_hz", r.plan.speed_hz},
                    {"torque_nm", r.plan.torque_nm},
                    {"mean_wear_depth_um", r.wear.mean_wear_depth_m * 1e6},
                    {"combined_mean_wear_depth_um", r.wear.combined_mean_wear_depth_m * 1e6},
                    {"wear_profile_pinion_um_root_to_tip", pinion_um},
                    {"wear_profile_gear_um_root_to_tip", gear_um},
                    {"pitting_density", r.wear.pitting_density},
                    {"roughness", r.wear.roughness},
                    {"k_wear", r.wear.k_wear},
                    {"k_pitting", r.wear.k_pitting},
                    {"sliding_pitting_rms_m_s2", r.sliding.pitting_rms_m_s2},
                    {"sliding_abrasion_rms_m_s2", r.sliding.abrasion_rms_m_s2}});
  }
  j["records"] = list;
  return j.dump(2) + "\n";
}

}  // namespace gearwatch::rig
