#include "gearwatch/config/config.hpp"

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <set>
#include <limits>
#include <optional>
#include <sstream>

#include <toml++/toml.h>

#include "gearwatch/types/token.hpp"

namespace gearwatch::config {
namespace {

// A TOML number as a double. An integer is converted (toml++'s value<double>() refuses one that
// a double cannot hold exactly, e.g. 5100000200100002000, and that must read as a number, not
// abort the parse); anything else is not a number.
std::optional<double> number_of(const toml::node& n) {
  if (auto i = n.value_exact<std::int64_t>()) return static_cast<double>(*i);
  if (auto d = n.value_exact<double>()) return *d;
  return std::nullopt;
}

// Reads one TOML table, remembers which keys were used and refuses the others, so a typo
// ("lenght_s") is an error instead of a silently ignored setting.
class TableReader {
 public:
  TableReader(const toml::table* table, std::string prefix, const std::string& file)
      : table_(table), prefix_(std::move(prefix)), file_(file) {}

  [[noreturn]] void fail(const toml::node* node, const std::string& key, const std::string& why) const {
    std::ostringstream msg;
    msg << file_;
    if (node) msg << ":" << node->source().begin.line;
    else if (table_) msg << ":" << table_->source().begin.line;
    msg << ": key '" << prefix_ << key << "': " << why;
    throw ConfigError(msg.str());
  }

  const toml::node* node(const std::string& key) {
    used_.insert(key);
    return table_ ? table_->get(key) : nullptr;
  }

  void number(const std::string& key, double& out, double lo, double hi) {
    const toml::node* n = node(key);
    if (!n) return;
    const std::optional<double> parsed = number_of(*n);
    if (!parsed) fail(n, key, "expected a number");
    const double v = *parsed;
    if (!(v >= lo && v <= hi)) {
      std::ostringstream why;
      why << "value " << v << " is outside [" << lo << ", " << hi << "]";
      fail(n, key, why.str());
    }
    out = v;
  }

  template <typename Int>
  void integer(const std::string& key, Int& out, std::int64_t lo, std::int64_t hi) {
    const toml::node* n = node(key);
    if (!n) return;
    auto i = n->value_exact<std::int64_t>();
    if (!i) fail(n, key, "expected an integer");
    if (*i < lo || *i > hi) fail(n, key, "value " + std::to_string(*i) + " is outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    out = static_cast<Int>(*i);
  }

  void string(const std::string& key, std::string& out, bool allow_empty = false) {
    const toml::node* n = node(key);
    if (!n) return;
    auto s = n->value_exact<std::string>();
    if (!s) fail(n, key, "expected a string");
    if (!allow_empty && s->empty()) fail(n, key, "must not be empty");
    out = *s;
  }

  void boolean(const std::string& key, bool& out) {
    const toml::node* n = node(key);
    if (!n) return;
    auto b = n->value_exact<bool>();
    if (!b) fail(n, key, "expected true or false");
    out = *b;
  }

  // A string naming one value of an enum (one of `all`'s to_string tokens).
  template <typename Enum, std::size_t N>
  void token(const std::string& key, Enum& out, const std::array<Enum, N>& all, const std::string& expected) {
    const toml::node* n = node(key);
    if (!n) return;
    const auto text = n->value_exact<std::string>();
    const std::optional<Enum> value = text ? from_token(all, *text) : std::nullopt;
    if (!value) fail(n, key, expected);
    out = *value;
  }

  // The same, read as text first: a non-string or an empty value keeps the string reader's
  // message, and an unknown word fails with `expected(word)`.
  template <typename Enum, std::size_t N, typename Expected>
  void text_token(const std::string& key, Enum& out, const std::array<Enum, N>& all, Expected expected) {
    std::string text = to_string(out);
    string(key, text);
    const std::optional<Enum> value = from_token(all, text);
    if (!value) fail(node(key), key, expected(text));
    out = *value;
  }

  void reject_unknown() const {
    if (!table_) return;
    for (const auto& [k, v] : *table_) {
      const std::string key{k.str()};
      if (!used_.count(key)) fail(&v, key, "unknown key");
    }
  }

 private:
  const toml::table* table_;
  std::string prefix_;
  const std::string& file_;
  std::set<std::string> used_;
};

const toml::table* sub_table(const toml::table& root, const std::string& name, const std::string& file) {
  const toml::node* n = root.get(name);
  if (!n) return nullptr;
  if (!n->is_table()) {
    throw ConfigError(file + ":" + std::to_string(n->source().begin.line) + ": key '" + name + "': expected a table [" + name + "]");
  }
  return n->as_table();
}

const toml::array* array_of_tables(const toml::table& root, const std::string& name, const std::string& file) {
  const toml::node* n = root.get(name);
  if (!n) return nullptr;
  if (!n->is_array_of_tables()) {
    throw ConfigError(file + ":" + std::to_string(n->source().begin.line) + ": key '" + name + "': expected [[" + name + "]] tables");
  }
  return n->as_array();
}

void read_mqtt(TableReader t, MqttSettings& m) {
  t.boolean("enabled", m.enabled);
  t.token("sender", m.sender, kAllMqttSenders, "expected daemon or publisher");
  t.string("host", m.host);
  t.integer("port", m.port, 1, 65535);
  t.string("prefix", m.prefix);
  t.string("site", m.site);
  t.string("gearbox", m.gearbox);
  const std::pair<const char*, const std::string*> levels[] = {{"prefix", &m.prefix}, {"site", &m.site}, {"gearbox", &m.gearbox}};
  for (const auto& [key, value] : levels)
    if (value->find_first_of("+#/") != std::string::npos) t.fail(t.node(key), key, "must not contain '/', '+' or '#' (one topic level)");
  t.string("client_id", m.client_id, true);
  t.integer("keepalive_s", m.keepalive_s, 5, 3600);
  t.string("password_file", m.password_file, true);
  t.string("ca_file", m.ca_file, true);
  t.string("cert_file", m.cert_file, true);
  t.string("key_file", m.key_file, true);
  if (m.cert_file.empty() != m.key_file.empty()) t.fail(t.node(m.cert_file.empty() ? "key_file" : "cert_file"), m.cert_file.empty() ? "key_file" : "cert_file", "cert_file and key_file go together");
  if (!m.cert_file.empty() && m.ca_file.empty()) t.fail(t.node("cert_file"), "cert_file", "a client certificate needs TLS: set ca_file");
  t.integer("outbox_limit", m.outbox_limit, 100, std::int64_t{1} << 40);
  t.integer("inflight", m.inflight, 1, 1000);
  t.integer("reconnect_initial_ms", m.reconnect_initial_ms, 10, 600000);
  t.integer("reconnect_max_ms", m.reconnect_max_ms, 10, 3600000);
  t.number("drain_timeout_s", m.drain_timeout_s, 0.0, 3600.0);
  t.reject_unknown();
}

void read_rig(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  TableReader t(sub_table(root, "rig", file), "rig.", file);
  t.number("sample_rate_hz", cfg.rig.sample_rate_hz, 100.0, 10e6);
  t.number("min_speed_hz", cfg.rig.min_speed_hz, 0.0, 1000.0);
  t.number("max_speed_hz", cfg.rig.max_speed_hz, 0.0, 1000.0);
  if (cfg.rig.max_speed_hz <= cfg.rig.min_speed_hz) t.fail(t.node("max_speed_hz"), "max_speed_hz", "must be above min_speed_hz");
  t.reject_unknown();
}

void read_gears(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  TableReader t(sub_table(root, "gears", file), "gears.", file);
  auto& g = cfg.rig.gears;
  t.integer("pinion_teeth", g.pinion_teeth, 5, 500);
  t.integer("gear_teeth", g.gear_teeth, 5, 1000);
  double module_mm = g.module_m * 1e3, face_mm = g.face_width_m * 1e3, e_gpa = g.youngs_modulus_pa / 1e9;
  t.number("module_mm", module_mm, 0.1, 100.0);
  t.number("pressure_angle_deg", g.pressure_angle_deg, 10.0, 35.0);
  t.number("face_width_mm", face_mm, 0.5, 2000.0);
  t.number("youngs_modulus_gpa", e_gpa, 1.0, 1000.0);
  t.number("poisson_ratio", g.poisson_ratio, 0.0, 0.5);
  t.number("density_kg_m3", g.density_kg_m3, 100.0, 30000.0);
  g.module_m = module_mm * 1e-3;
  g.face_width_m = face_mm * 1e-3;
  g.youngs_modulus_pa = e_gpa * 1e9;
  t.reject_unknown();
}

/// An array of tables of numbered entries ([[channels]], [[tachos]]): its key, the key of the
/// entry's number with its range, the word a duplicate's message names an entry by, and whether the
/// array, when present, must hold one entry at least.
struct NumberedEntries {
  std::string key, id_key;
  int id_max;
  std::string id_word;
  bool at_least_one;
};

/// Reads the entries of `e` into `out` (replacing the defaults when the array is present): each
/// entry's number (`Spec::*id`, required, unique), then its other fields by `read_fields`.
template <class Spec, class ReadFields>
void read_numbered_entries(const toml::table& root, const std::string& file, const NumberedEntries& e, int Spec::*id,
                           std::vector<Spec>& out, ReadFields read_fields) {
  const auto* arr = array_of_tables(root, e.key, file);
  if (!arr) return;
  out.clear();
  std::set<int> seen;
  for (const auto& node : *arr) {
    const auto* tbl = node.as_table();
    TableReader t(tbl, e.key + ".", file);
    Spec spec;
    if (!tbl->get(e.id_key))
      t.fail(tbl, e.id_key, "every [[" + e.key + "]] entry needs a " + e.id_key + " (0.." + std::to_string(e.id_max) + ")");
    t.integer(e.id_key, spec.*id, 0, e.id_max);
    read_fields(t, spec);
    if (!seen.insert(spec.*id).second)
      t.fail(tbl->get(e.id_key), e.id_key, e.id_word + " " + std::to_string(spec.*id) + " configured twice");
    t.reject_unknown();
    out.push_back(spec);
  }
  if (e.at_least_one && out.empty())
    throw ConfigError(file + ": key '" + e.key + "': at least one [[" + e.key + "]] entry is needed");
}

void read_channels(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  read_numbered_entries(root, file, {"channels", "number", 7, "channel", true}, &ChannelSpec::number, cfg.rig.channels,
                        [](TableReader& t, ChannelSpec& ch) {
                          t.string("name", ch.name);
                          t.number("scale", ch.scale_m_s2_per_lsb, 1e-12, 1e6);
                        });
}

void read_tachos(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  read_numbered_entries(root, file, {"tachos", "shaft", 3, "shaft", false}, &TachoSpec::shaft, cfg.rig.tachos,
                        [](TableReader& t, TachoSpec& tacho) {
                          t.string("name", tacho.name);
                          t.integer("edges_per_rev", tacho.edges_per_rev, 1, 100000);
                          t.number("ratio_to_input", tacho.ratio_to_input, 1e-6, 1e6);
                        });
}

void read_records(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  TableReader t(sub_table(root, "records", file), "records.", file);
  auto& s = cfg.rig.schedule;
  t.number("length_s", s.length_s, 0.01, 3600.0);
  t.number("interval_s", s.interval_s, 0.01, 30.0 * 86400.0);
  if (t.node("min_length_s")) t.number("min_length_s", s.min_length_s, 0.0, 3600.0);
  else s.min_length_s = std::min(s.min_length_s, s.length_s);  // the default never exceeds a short length
  if (s.interval_s < s.length_s) t.fail(t.node("interval_s"), "interval_s", "must be at least length_s (records do not overlap)");
  if (s.min_length_s > s.length_s) t.fail(t.node("min_length_s"), "min_length_s", "must not exceed length_s");
  t.reject_unknown();
}

void read_protocol(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  TableReader t(sub_table(root, "protocol", file), "protocol.", file);
  auto& p = cfg.protocol;
  t.integer("vibration_base_id", p.vibration_base_id, 0, 0x7FF - 7);
  t.integer("tacho_base_id", p.tacho_base_id, 0, 0x7FF - 3);
  t.integer("stream_header_id", p.stream_header_id, 0, 0x7FF);
  t.integer("operating_condition_id", p.operating_condition_id, 0, 0x7FF);
  t.integer("life_counter_id", p.life_counter_id, 0, 0x7FF);
  t.reject_unknown();
}

void read_acquisition(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  TableReader t(sub_table(root, "acquisition", file), "acquisition.", file);
  auto& a = cfg.acquisition;
  t.text_token("source", a.source, kAllSourceKinds,
                [](const std::string& got) { return "expected \"socketcan\" or \"candump\", got \"" + got + "\""; });
  t.string("interface", a.interface);
  t.string("capture", a.capture, true);
  t.integer("ring_capacity_samples", a.ring_capacity_samples, 1024, std::int64_t{1} << 32);
  t.integer("receive_buffer_bytes", a.receive_buffer_bytes, 4096, std::int64_t{1} << 30);  // the kernel's own cap
  t.integer("reopen_initial_ms", a.reopen_initial_ms, 1, 600000);
  t.integer("reopen_max_ms", a.reopen_max_ms, 1, 3600000);
  t.reject_unknown();
}

void read_storage(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  TableReader t(sub_table(root, "storage", file), "storage.", file);
  auto& s = cfg.storage;
  t.string("database", s.database);
  t.integer("busy_timeout_ms", s.busy_timeout_ms, 0, 600000);
  t.integer("queue_capacity", s.queue_capacity, 1, 1000000);
  t.integer("retry_initial_ms", s.retry_initial_ms, 1, 600000);
  t.integer("retry_max_ms", s.retry_max_ms, 1, 3600000);
  t.reject_unknown();
}

void read_logging(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  TableReader t(sub_table(root, "logging", file), "logging.", file);
  auto& l = cfg.logging;
  t.text_token("level", l.level, kAllLogLevels,
                [](const std::string&) { return "expected one of trace, debug, info, warn, error, critical, off"; });
  t.token("sink", l.sink, kAllLogSinks, "expected auto, journald or stderr");
  t.number("rate_limit_s", l.rate_limit_s, 0.0, 86400.0);
  t.reject_unknown();
}

void read_daemon(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  TableReader t(sub_table(root, "daemon", file), "daemon.", file);
  t.number("health_interval_s", cfg.daemon.health_interval_s, 0.1, 86400.0);
  t.number("watchdog_margin", cfg.daemon.watchdog_margin, 0.05, 0.95);
  t.integer("processing_nice", cfg.daemon.processing_nice, 0, 19);
  t.integer("channel_workers", cfg.daemon.channel_workers, 0, 64);
  t.reject_unknown();
}

void read_alerts(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  TableReader t(sub_table(root, "alerts", file), "alerts.", file);
  t.integer("wear_clear_after_records", cfg.alerts.wear_clear_after_records, 1, 100000);
  t.integer("sensor_clear_after_records", cfg.alerts.sensor_clear_after_records, 1, 100000);
  t.integer("baseline_records", cfg.alerts.baseline_records, 3, 100000);
  t.number("threshold_sigma", cfg.alerts.threshold_sigma, 1.0, 1000.0);
  t.integer("threshold_raise_after_records", cfg.alerts.threshold_raise_after_records, 1, 100000);
  t.integer("threshold_clear_after_records", cfg.alerts.threshold_clear_after_records, 1, 100000);
  if (const toml::node* n = t.node("watched_indicators")) {
    const toml::array* a = n->as_array();
    if (!a) t.fail(n, "watched_indicators", "expected a list of indicator names");
    cfg.alerts.watched_indicators.clear();
    for (const auto& item : *a) {
      const auto name = item.value<std::string>();
      if (!name || name->empty()) t.fail(&item, "watched_indicators", "expected indicator names (strings)");
      cfg.alerts.watched_indicators.push_back(*name);
    }
  }
  t.reject_unknown();
}

void read_processing(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  const toml::table* tbl = sub_table(root, "processing", file);
  TableReader t(tbl, "processing.", file);
  auto& p = cfg.processing;
  t.integer("samples_per_revolution", p.samples_per_revolution, 0, 1 << 20);
  t.integer("rms_sa_harmonics", p.rms_sa_harmonics, 1, 100);
  t.integer("stored_gmf_harmonics", p.stored_gmf_harmonics, 1, 100);
  t.integer("ics2_harmonics", p.ics2_harmonics, 1, 100);
  t.integer("ics2_tolerance_bins", p.ics2_tolerance_bins, 0, 100);
  // A band is written [low_hz, high_hz]; errors point at the node's line.
  auto read_band = [&](const toml::node& n, const std::string& key, const char* expected) {
    const toml::array* a = n.as_array();
    const std::optional<double> low = a && a->size() == 2 ? number_of((*a)[0]) : std::nullopt;
    const std::optional<double> high = a && a->size() == 2 ? number_of((*a)[1]) : std::nullopt;
    if (!low || !high) t.fail(&n, key, expected);
    const dsp::FrequencyBand b{*low, *high};
    if (!(b.low_hz >= 0 && b.high_hz > b.low_hz)) t.fail(&n, key, "needs 0 <= low_hz < high_hz");
    return b;
  };
  if (const toml::node* n = t.node("pitting_band_hz")) p.pitting_band = read_band(*n, "pitting_band_hz", "expected [low_hz, high_hz]");
  if (const toml::node* n = t.node("abrasion_band_hz")) p.abrasion_band = read_band(*n, "abrasion_band_hz", "expected [low_hz, high_hz]");
  t.integer("filter_bank_levels", p.filter_bank_levels, 1, 12);
  t.boolean("kurtogram_band_selection", p.kurtogram_band_selection);
  if (const toml::node* n = t.node("mean_carrier_ranges_hz")) {
    const toml::array* a = n->as_array();
    if (!a || a->empty()) t.fail(n, "mean_carrier_ranges_hz", "expected a list of [low_hz, high_hz] pairs");
    p.mean_carrier_ranges.clear();
    for (const auto& item : *a)
      p.mean_carrier_ranges.push_back(read_band(item, "mean_carrier_ranges_hz", "expected [low_hz, high_hz] pairs"));
  }
  t.number("min_revolutions_for_tsa", p.min_revolutions_for_tsa, 1.0, 1e6);
  t.number("max_clipped_fraction", p.max_clipped_fraction, 0.0, 1.0);
  t.number("flat_line_max_std_lsb", p.flat_line_max_std_lsb, 0.0, 1000.0);
  t.number("residual_rms_floor", p.residual_rms_floor, 0.0, 0.999);
  t.boolean("remove_residual_lines", p.remove_residual_lines);
  t.number("band_energy_floor_db", p.band_energy_floor_db, -300.0, 0.0);
  t.number("trend_significance", p.trend_significance, 1e-6, 0.5);
  t.number("wear_min_band_share", p.wear_min_band_share, 0.0, 1.0);
  t.integer("wear_baseline_records", p.wear_baseline_records, 0, 200);
  t.integer("trend_window_records", p.trend_window_records, 3, 1000000);
  t.integer("band_jump_persistence_records", p.band_jump_persistence_records, 1, 1000);
  t.number("band_jump_sigma", p.band_jump_sigma, 0.0, 1000.0);
  t.reject_unknown();
  try {
    p.validate(cfg.rig);
  } catch (const std::invalid_argument& e) {
    throw ConfigError(file + (tbl ? ":" + std::to_string(tbl->source().begin.line) : std::string{}) +
                      ": [processing]: " + e.what());
  }
}

void read_model(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  TableReader t(sub_table(root, "model", file), "model.", file);
  auto& m = cfg.model;
  t.boolean("enabled", m.enabled);
  t.integer("channel", m.channel, -1, 7);
  if (m.channel >= 0 && std::none_of(cfg.rig.channels.begin(), cfg.rig.channels.end(),
                                     [&](const ChannelSpec& c) { return c.number == m.channel; }))
    t.fail(t.node("channel"), "channel", "channel " + std::to_string(m.channel) + " is not a configured [[channels]] entry");
  t.number("initial_k_wear", m.initial_k_wear, 1e-16, 1e-3);
  t.number("initial_k_pitting", m.initial_k_pitting, 0.0, 1e300);
  t.number("update_threshold", m.update_threshold, 1e-4, 0.9);
  t.number("convergence_tolerance", m.convergence_tolerance, 1e-5, 0.9);
  if (m.convergence_tolerance > m.update_threshold)
    t.fail(t.node("convergence_tolerance"), "convergence_tolerance", "must not exceed update_threshold");
  t.integer("max_wear_iterations", m.max_wear_iterations, 1, 100);
  t.token("k_wear_update", m.k_wear_update, wear::kAllKWearUpdateRules, "expected \"root_find\" or \"proportional\"");
  t.boolean("pitting_growth_law", m.pitting_growth_law);
  t.boolean("pitting_exponent_from_inspections", m.pitting_exponent_from_inspections);
  t.number("min_wear_elasticity", m.min_wear_elasticity, 0.0, 0.99);
  t.integer("commissioning_records", m.commissioning_records, 0, 100);
  t.number("pitting_reference_torque_nm", m.pitting_reference_torque_nm, 1e-3, 1e5);
  t.number("correlation_threshold", m.correlation_threshold, 0.01, 0.9999);
  t.number("pitting_interval_cycles", m.pitting_interval_cycles, 1.0, 1e10);
  t.number("simulation_revolutions", m.simulation_revolutions, 2.0, 1000.0);
  if (m.simulation_revolutions < cfg.processing.min_revolutions_for_tsa)
    t.fail(t.node("simulation_revolutions"), "simulation_revolutions", "must be at least processing.min_revolutions_for_tsa");
  t.number("min_torque_nm", m.min_torque_nm, 1e-3, 1e5);
  t.number("max_torque_nm", m.max_torque_nm, 1e-3, 1e5);
  if (m.max_torque_nm <= m.min_torque_nm) t.fail(t.node("max_torque_nm"), "max_torque_nm", "must be above min_torque_nm");
  t.number("wear_limit_fraction", m.wear_limit_fraction, 1e-4, 0.15);
  t.number("pitting_limit", m.pitting_limit, 1e-4, 0.99);
  t.number("forecast_horizon_cycles", m.forecast_horizon_cycles, 1.0, 1e11);
  t.number("remaining_life_alert_cycles", m.remaining_life_alert_cycles, 0.0, 1e11);
  t.integer("remaining_life_raise_after_records", m.remaining_life_raise_after_records, 1, 100000);
  t.integer("remaining_life_clear_after_records", m.remaining_life_clear_after_records, 1, 100000);
  t.integer("queue_capacity", m.queue_capacity, 1, 10000);
  t.number("prior_log_k_wear_sd", m.prior_log_k_wear_sd, 1e-3, 50.0);
  t.number("log_k_drift_per_million_cycles", m.log_k_drift_per_million_cycles, 0.0, 50.0);
  t.number("rms_sa_relative_sd_floor", m.rms_sa_relative_sd_floor, 1e-5, 0.9);
  t.number("inspection_area_relative_sd", m.inspection_area_relative_sd, 1e-4, 0.9);
  t.number("inspection_depth_relative_sd", m.inspection_depth_relative_sd, 1e-4, 0.9);
  t.integer("disagreement_records", m.disagreement_records, 1, 64);
  t.integer("ics2_onset_records", m.ics2_onset_records, 1, 1000);
  t.token("force_model", m.force_model, wear::kAllForceModels, "expected \"quasi-static\" or \"dynamic\"");
  t.reject_unknown();
}

void read_gap(const toml::table& root, const std::string& file, GearwatchConfig& cfg) {
  TableReader t(sub_table(root, "gap", file), "gap.", file);
  auto& g = cfg.gap;
  t.boolean("enabled", g.enabled);
  t.integer("every_records", g.every_records, 1, 1000000);
  t.integer("training_records", g.training_records, 1, 64);
  t.integer("held_out_records", g.held_out_records, 1, 64);
  t.integer("channel", g.channel, -1, 7);
  if (g.channel >= 0 && std::none_of(cfg.rig.channels.begin(), cfg.rig.channels.end(),
                                     [&](const ChannelSpec& c) { return c.number == g.channel; }))
    t.fail(t.node("channel"), "channel", "channel " + std::to_string(g.channel) + " is not a configured [[channels]] entry");
  t.integer("bootstrap_resamples", g.bootstrap_resamples, 20, 100000);
  t.integer("seed", g.seed, 0, std::numeric_limits<std::int64_t>::max());
  t.boolean("rerun_twin", g.rerun_twin);
  t.integer("drift_raise_after_reports", g.drift_raise_after_reports, 1, 1000);
  t.integer("drift_clear_after_reports", g.drift_clear_after_reports, 1, 1000);
  if (g.enabled && !cfg.model.enabled)
    t.fail(t.node("enabled"), "enabled", "the gap diagnosis runs in the model thread: it needs [model] enabled = true");
  t.reject_unknown();
}

GearwatchConfig from_table(const toml::table& root, const std::string& file) {
  GearwatchConfig cfg;
  static const std::set<std::string> known{"rig", "gears", "channels", "tachos", "records", "protocol",
                                           "acquisition", "storage", "logging", "daemon", "processing", "twin",
                                           "alerts", "model", "gap", "mqtt"};
  for (const auto& [k, v] : root) {
    if (!known.count(std::string{k.str()})) {
      throw ConfigError(file + ":" + std::to_string(v.source().begin.line) + ": key '" + std::string{k.str()} + "': unknown table or key");
    }
  }

  read_rig(root, file, cfg);
  read_gears(root, file, cfg);
  read_channels(root, file, cfg);
  read_tachos(root, file, cfg);
  read_records(root, file, cfg);
  read_protocol(root, file, cfg);
  read_acquisition(root, file, cfg);
  read_storage(root, file, cfg);
  read_mqtt(TableReader(sub_table(root, "mqtt", file), "mqtt.", file), cfg.mqtt);
  read_logging(root, file, cfg);
  read_daemon(root, file, cfg);
  read_alerts(root, file, cfg);
  read_processing(root, file, cfg);
  read_model(root, file, cfg);
  read_gap(root, file, cfg);
  // [twin] is read by the twin's own loader (twin_config).
  if (cfg.rig.tachos.empty()) throw ConfigError(file + ": key 'tachos': at least one [[tachos]] entry is needed");
  return cfg;
}

}  // namespace

const char* to_string(SourceKind kind) noexcept {
  switch (kind) {
    case SourceKind::socketcan: return "socketcan";
    case SourceKind::candump: return "candump";
  }
  return "?";
}

GearwatchConfig parse_config(const std::string& text, const std::string& name) {
  try {
    toml::table root = toml::parse(text, name);
    return from_table(root, name);
  } catch (const toml::parse_error& e) {
    std::ostringstream msg;
    msg << name << ":" << e.source().begin.line << ": " << e.description();
    throw ConfigError(msg.str());
  }
}

GearwatchConfig load_config(const std::string& path) {
  // A directory opens as a stream that reads nothing, which would parse as the built-in defaults.
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw ConfigError(path + ": is a directory, not a configuration file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path + ": cannot open config file");
  std::ostringstream buf;
  buf << in.rdbuf();
  if (in.bad()) throw ConfigError(path + ": read error");
  GearwatchConfig cfg = parse_config(buf.str(), path);
  cfg.source_path = path;  // only a file read here can be read again (SIGHUP)
  return cfg;
}

}  // namespace gearwatch::config
