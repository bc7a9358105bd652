// `gearwatch replay CAPTURE --db FILE [--config FILE]`: a candump log through the whole
// pipeline as fast as possible. Several replays into one database continue its history.
#include <iostream>
#include <string>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "cli_common.hpp"
#include "gearwatch/acquisition/candump_source.hpp"
#include "gearwatch/acquisition/daq_file.hpp"
#include "logging.hpp"
#include "pipeline.hpp"

namespace gearwatch::cli {

namespace {

// ", every indicator skipped in 2 of them (flat_line in 2)": what "analysed" does not say.
std::string without_indicators_text(const daemon::RecordsWithoutIndicators& w) {
  if (w.records == 0) return "";
  std::string text = ", every indicator skipped in " + std::to_string(w.records) + " of them (";
  bool first = true;
  for (const auto& [reason, records] : w.reasons) {
    text += (first ? "" : ", ") + std::string(dsp::to_string(reason)) + " in " + std::to_string(records);
    first = false;
  }
  return text + ")";
}

nlohmann::json without_indicators_json(const daemon::RecordsWithoutIndicators& w) {
  nlohmann::json reasons = nlohmann::json::object();
  for (const auto& [reason, records] : w.reasons) reasons[dsp::to_string(reason)] = records;
  return {{"records", w.records}, {"skip_reasons", reasons}};
}

}  // namespace

void register_replay(CLI::App& app) {
  struct Options {
    std::string capture, db, config, format = "table";
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("replay", "Process a candump -L capture into the database, then exit");
  cmd->add_option("capture", opt->capture, "Capture file (candump -L format)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--db", opt->db, "SQLite database (created if missing)")->required();
  cmd->add_option("--config", opt->config, "Configuration file (TOML); built-in defaults otherwise");
  add_format_option(cmd, opt->format, "table", {"table", "json"});
  cmd->callback([opt] {
    auto cfg = load_config_or_defaults(opt->config);
    cfg.acquisition.source = config::SourceKind::candump;
    cfg.acquisition.capture = opt->capture;
    cfg.storage.database = opt->db;
    logging::setup(logging::Sink::stderr_only, logging::summary_command_level(cfg.logging.level));
    daemon::PipelineResult r;
    try {
      // A recording given for a capture would only fill the database with malformed lines.
      if (const auto daq = acquisition::sniff_daq_recording(opt->capture))
        throw CommandError(opt->capture + " is a " + std::string(acquisition::to_string(*daq)) +
                           " recording, not a capture: turn it into one with `gearwatch import " + opt->capture +
                           " --out CAPTURE --torque NM`; nothing stored");
      acquisition::require_capture_file(opt->capture);  // before the database is touched
      r = daemon::run_pipeline(cfg, daemon::PipelineMode::replay);
    } catch (const CommandError&) {
      throw;
    } catch (const std::exception& e) {
      throw CommandError(e.what());
    }
    if (opt->format == "json") {
      nlohmann::json j{{"capture", opt->capture}, {"database", opt->db}, {"run_id", r.run_id},
                       {"records", r.records}, {"records_analysed", r.records_analysed}, {"frames", r.frames},
                       {"samples", r.samples}, {"lost_samples", r.lost_samples}, {"end_reason", r.run_end_reason},
                       {"records_already_stored", r.records_already_stored},
                       {"records_without_indicators", without_indicators_json(r.records_without_indicators)}};
      std::cout << dump_json(j) << "\n";
    } else if (r.exit_status == 0) {
      std::cout << "replayed " << opt->capture << " into " << opt->db << " (run " << r.run_id << "): " << r.frames
                << " frames, " << r.samples << " samples, " << r.records << " records (" << r.records_analysed
                << " analysed" << without_indicators_text(r.records_without_indicators) << "), " << r.lost_samples
                << " samples lost";
      if (r.records_already_stored > 0) std::cout << "; " << r.records_already_stored << " records already stored by an earlier replay of it, skipped";
      std::cout << "\n";
    }
    // A replay that failed says so, and only so: what it stored before failing is in the message.
    if (r.exit_status != 0)
      throw CommandError("replay of " + opt->capture + " failed: " + (r.end_reason.empty() ? "storage failure" : r.end_reason) +
                             " (" + std::to_string(r.records) + " records from " + std::to_string(r.frames) +
                             " frames stored before it, run " + std::to_string(r.run_id) + ")",
                         r.exit_status);
  });
}

}  // namespace gearwatch::cli
