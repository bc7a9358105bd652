// `gearwatch gap diagnose CAPTURE... [--held-out CAPTURE...] [--config F] [--db F] [--format table|json]
// [--out DIR]`: the sim-to-real gap diagnosis on captures a user brings (docs/gap.md, docs/cli.md).
// Each capture is cut into records as a replay cuts it; each record is compared with the twin at its
// own speed, torque and sample rate, at the model's newest stored wear state (--db) or unworn; the
// report is printed, stored with --db and written as the gap page with --out.
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "cli_common.hpp"
#include "decoder_setup.hpp"
#include "gap_diagnose_captures.hpp"
#include "gap_diagnoser.hpp"
#include "gap_monitor.hpp"
#include "gap_print.hpp"
#include "gearwatch/acquisition/candump_log.hpp"
#include "gearwatch/acquisition/candump_source.hpp"
#include "gearwatch/acquisition/record_assembler.hpp"
#include "capture_records.hpp"
#include "gearwatch/config/twin_config.hpp"
#include "gearwatch/report/gap_page.hpp"
#include "gearwatch/report/report_page.hpp"
#include "gearwatch/storage/gap_reports.hpp"
#include "logging.hpp"
#include "model_thread.hpp"

namespace gearwatch::cli {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct DiagnoseOptions {
  std::vector<std::string> captures, held_out;
  std::string config, db, format = "table", out;
};

/// One record as the diagnosis reads it (the compared channel only) and where it came from.
struct InputRecord {
  std::string capture;
  std::vector<int> channels;  ///< the channels the whole record carried
  Record record;
  bool held_out = false;
};

std::string channels_text(const std::vector<int>& channels) {
  std::string out;
  for (int c : channels) out += (out.empty() ? "" : ",") + std::to_string(c);
  return out.empty() ? "none" : out;
}

// The analysable records of one capture, decoded and cut as a replay cuts them ([records]).
std::vector<InputRecord> read_capture(const std::string& capture, const config::GearwatchConfig& cfg, int channel) {
  std::vector<Record> records;
  try {
    records = daemon::read_capture_records(capture, cfg);
  } catch (const std::exception& e) {
    throw CommandError(e.what());
  }
  std::vector<InputRecord> out;
  for (Record& r : records) {
    std::optional<Record> kept = daemon::kept_gap_record(r, channel);
    if (!kept)
      throw CommandError(capture + ": the record at sample " + std::to_string(r.start_index) + " carries channels " +
                         channels_text(r.channel_numbers) + ", not the compared channel " + std::to_string(channel) +
                         " ([gap] channel, else [model] channel)");
    if (!std::isfinite(kept->speed_hz) || !std::isfinite(kept->torque_nm))
      throw CommandError(capture + ": the record at sample " + std::to_string(r.start_index) +
                         " has no operating-condition frame (speed and torque): the twin cannot be run at it");
    out.push_back({capture, r.channel_numbers, std::move(*kept), false});
  }
  return out;
}

// Every record carries the same channels: a diagnosis compares like with like.
void require_same_channels(const std::vector<InputRecord>& records) {
  for (const auto& r : records)
    if (r.channels != records.front().channels)
      throw CommandError("mismatched channels: " + records.front().capture + " carries channels " +
                         channels_text(records.front().channels) + ", " + r.capture + " channels " + channels_text(r.channels));
}

// The split: --held-out's records, else the periodic step's rule (the newest held_out_records).
std::string split_records(std::vector<InputRecord>& records, std::size_t given_held_out, std::size_t held_out_records) {
  if (given_held_out > 0) {
    if (given_held_out == records.size()) throw CommandError("no training record: give the training captures before --held-out");
    return "held out: the " + std::to_string(given_held_out) + " records of --held-out; training: the " +
           std::to_string(records.size() - given_held_out) + " records of the other captures";
  }
  if (records.size() <= held_out_records)
    throw CommandError(std::to_string(records.size()) + " records: the newest " + std::to_string(held_out_records) +
                       " are held out ([gap] held_out_records), so none is left for training; give more captures or --held-out");
  for (std::size_t i = records.size() - held_out_records; i < records.size(); ++i) records[i].held_out = true;
  return "held out: the newest " + std::to_string(held_out_records) +
         " records in the order given ([gap] held_out_records, the periodic step's rule); training: the " +
         std::to_string(records.size() - held_out_records) + " records before them";
}

/// The wear state the twin is run at and the K_wear it came from (0: none to infer from).
struct WearBasis {
  wear::WearState state;
  double k_wear = 0;
  std::int64_t gear_pair = 0;
  std::string text;
};

WearBasis wear_basis(const std::string& db) {
  WearBasis b;
  if (db.empty()) {
    b.text = "unworn (no --db): K_wear not inferred";
    return b;
  }
  daemon::StoredModel stored;
  try {
    require_history(db);
    stored = daemon::load_model(db);
  } catch (const CommandError&) {
    throw;
  } catch (const std::exception& e) {
    throw CommandError("cannot read " + db + ": " + e.what());
  }
  b.gear_pair = stored.gear_pair;
  if (!stored.found) {
    b.text = "unworn: " + db + " holds no model state for gear pair " + std::to_string(stored.gear_pair) +
             (stored.problem.empty() ? "" : " (" + stored.problem + ")") + "; K_wear not inferred";
    return b;
  }
  b.state = stored.memory.current.state;
  b.k_wear = stored.memory.k_wear_si;
  char text[256];
  std::snprintf(text, sizeof text, "the model's newest stored state in %s: gear pair %lld at %.6g cycles, mean wear depth %.4g um; K_wear %.4g m^2/N",
                db.c_str(), static_cast<long long>(stored.gear_pair), b.state.cycles,
                wear::summarise(b.state).combined_mean_depth_m * 1e6, b.k_wear);
  b.text = text;
  return b;
}

std::vector<InputRecord> read_inputs(const DiagnoseOptions& o, const config::GearwatchConfig& cfg, int channel) {
  std::vector<InputRecord> records;
  for (const auto* list : {&o.captures, &o.held_out})
    for (const auto& capture : *list)
      for (auto& r : read_capture(capture, cfg, channel)) {
        r.held_out = list == &o.held_out;
        records.push_back(std::move(r));
      }
  require_same_channels(records);
  return records;
}

gap::GapReport diagnose_records(const std::vector<InputRecord>& records, const config::GearwatchConfig& cfg, const WearBasis& basis,
                                std::string& k_wear_note, std::shared_ptr<daemon::SharedTwinRuns> twin_runs = {}) {
  std::error_code ec;
  const twin::GearboxParameters params =
      fs::is_regular_file(cfg.source_path, ec) ? config::load_twin_parameters(cfg.source_path) : twin::GearboxParameters{};
  std::vector<daemon::GapSample> samples;
  for (std::size_t i = 0; i < records.size(); ++i)
    samples.push_back({std::make_shared<const Record>(records[i].record), basis.state, 0, records[i].record.start_index, i + 1});
  // Records at one operating point, rate and length share their twin runs (one wear state for all).
  const auto shared = twin_runs ? std::move(twin_runs) : daemon::share_twin_runs(samples);
  daemon::GapHooks hooks{daemon::make_gap_diagnoser(cfg, params), daemon::make_twin_counterpart(params, cfg, shared),
                         daemon::make_twin_rerun(params, cfg, shared)};
  std::vector<const daemon::GapSample*> training, held_out;
  for (std::size_t i = 0; i < records.size(); ++i) (records[i].held_out ? held_out : training).push_back(&samples[i]);
  try {
    daemon::GapRun run = daemon::run_gap_diagnosis(hooks, training, held_out, basis.k_wear, cfg.rig.gears, cfg.processing.rms_sa_harmonics);
    if (!run.k_wear_skipped.empty()) k_wear_note = "K_wear not inferred: " + run.k_wear_skipped;
    return run.report;
  } catch (const std::exception& e) {
    throw CommandError(std::string("gap diagnose: ") + e.what());
  }
}

// Stored through storage's writer of gap reports, under the gate of every command that adds rows
// to an existing history; read back, so what is printed is what was stored.
storage::StoredGapReport store_report(const std::string& db_path, const gap::GapReport& report, std::int64_t gear_pair) {
  try {
    WritableHistory opened = open_history_for_writing(db_path, "gap diagnose");
    storage::Transaction tx(opened.db);
    const std::int64_t id = storage::insert_gap_report(opened.db, report, storage::GapReportContext{std::nullopt, gear_pair});
    tx.commit();
    for (auto& s : storage::load_gap_reports(opened.db, 10))
      if (s.id == id) return s;
    throw CommandError("gap report " + std::to_string(id) + " was stored in " + db_path + " but cannot be read back");
  } catch (const CommandError&) {
    throw;
  } catch (const std::exception& e) {
    throw CommandError("cannot store the gap report in " + db_path + ": " + e.what());
  }
}

void write_report_page(const DiagnoseOptions& o, const storage::StoredGapReport& report, bool stored) {
  report::GapPageData data;
  if (stored) {
    data = load_page_data(o.db, [&](storage::Database& db) { return report::load_gap_page_data(db, o.db, report::utc_now_iso8601()); });
  } else {
    data.database = "gap diagnose of " + std::to_string(o.captures.size() + o.held_out.size()) + " captures (not stored)";
    data.generated_at = report::utc_now_iso8601();
    data.reports = {report};
    data.total_reports = 1;
  }
  write_page(o.out, report::render_gap_report_html(data));
}

json inputs_json(const std::vector<InputRecord>& records) {
  json a = json::array();
  for (const auto& r : records)
    a.push_back({{"capture", r.capture},
                 {"start_index", r.record.start_index},
                 {"set", r.held_out ? "held_out" : "training"},
                 {"speed_hz", r.record.speed_hz},
                 {"torque_nm", r.record.torque_nm},
                 {"sample_rate_hz", r.record.sample_rate_hz},
                 {"seconds", r.record.duration_s()},
                 {"input_revolutions", r.record.input_revolutions ? json(*r.record.input_revolutions) : json(nullptr)}});
  return a;
}

void run_diagnose(const DiagnoseOptions& o) {
  auto cfg = load_config_or_defaults(o.config);
  logging::setup(logging::Sink::stderr_only, logging::summary_command_level(cfg.logging.level));
  const int channel = daemon::gap_channel(cfg);
  std::vector<InputRecord> records = read_inputs(o, cfg, channel);
  std::size_t given_held_out = 0;
  for (const auto& r : records) given_held_out += r.held_out ? 1 : 0;
  const std::string split = split_records(records, given_held_out, cfg.gap.held_out_records);
  const WearBasis basis = wear_basis(o.db);
  std::string k_wear_note;
  storage::StoredGapReport report{0, "", {std::nullopt, basis.gear_pair}, diagnose_records(records, cfg, basis, k_wear_note)};
  const bool stored = !o.db.empty();
  if (stored) report = store_report(o.db, report.report, basis.gear_pair);
  if (!o.out.empty()) write_report_page(o, report, stored);
  if (o.format == "json") {
    std::cout << dump_json({{"records", inputs_json(records)},
                            {"split", split},
                            {"channel", channel},
                            {"wear_state", basis.text},
                            {"k_wear_note", k_wear_note.empty() ? json(nullptr) : json(k_wear_note)},
                            {"database", stored ? json(o.db) : json(nullptr)},
                            {"page", o.out.empty() ? json(nullptr) : json((fs::path(o.out) / "index.html").string())},
                            {"report", gap_report_json(report, stored)}})
              << "\n";
    return;
  }
  std::cout << "gap diagnose: " << records.size() << " records from " << o.captures.size() + o.held_out.size()
            << " captures, channel " << channel << "\n"
            << split << "\nwear state: " << basis.text << "\n";
  if (!k_wear_note.empty()) std::cout << k_wear_note << "\n";
  print_gap_report(report, "table", stored);
  if (stored) std::cout << "stored in " << o.db << " as gap report #" << report.id << "\n";
  if (!o.out.empty()) std::cout << "wrote " << (fs::path(o.out) / "index.html").string() << "\n";
}

}  // namespace

gap::GapReport diagnose_capture_files(const std::vector<std::string>& training, const std::vector<std::string>& held_out,
                                      const config::GearwatchConfig& cfg, std::shared_ptr<daemon::SharedTwinRuns> twin_runs) {
  DiagnoseOptions o;
  o.captures = training;
  o.held_out = held_out;
  const int channel = daemon::gap_channel(cfg);
  std::vector<InputRecord> records = read_inputs(o, cfg, channel);
  split_records(records, held_out.empty() ? 0 : records.size() - std::count_if(records.begin(), records.end(), [](const InputRecord& r) { return !r.held_out; }),
                cfg.gap.held_out_records);
  std::string k_wear_note;
  return diagnose_records(records, cfg, wear_basis(""), k_wear_note, std::move(twin_runs));
}

void add_gap_diagnose_command(CLI::App& app) {
  auto opt = std::make_shared<DiagnoseOptions>();
  auto* cmd = gap_command(app)->add_subcommand(
      "diagnose", "The sim-to-real gap diagnosis on captures: each record against the twin at its own speed, torque and rate");
  cmd->add_option("captures", opt->captures, "Captures (candump -L); their records are the training set")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--held-out", opt->held_out, "Captures whose records are held out (default: the newest [gap] held_out_records)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--config", opt->config, "Configuration file (TOML); built-in defaults otherwise");
  cmd->add_option("--db", opt->db, "Existing gearwatch database: the wear state from its model; the report is stored in it");
  cmd->add_option("--out", opt->out, "Write the gap page DIR/index.html (created if missing)");
  add_format_option(cmd, opt->format, "table", {"table", "json"});
  cmd->callback([opt] { run_diagnose(*opt); });
}

}  // namespace gearwatch::cli
