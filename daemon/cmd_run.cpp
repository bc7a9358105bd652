// `gearwatch run --config FILE`: the daemon (systemd runs this).
#include <spdlog/spdlog.h>

#include "cli_common.hpp"
#include "logging.hpp"
#include "pipeline.hpp"

namespace gearwatch::cli {

void register_run(CLI::App& app) {
  struct Options {
    std::string config, db;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("run", "Run the monitoring daemon (acquisition, processing, storage)");
  cmd->add_option("--config", opt->config, "Configuration file (TOML)")->required();
  cmd->add_option("--db", opt->db, "Override storage.database");
  cmd->callback([opt] {
    auto cfg = load_config_or_defaults(opt->config);
    // Asked here, not by the config parser: `replay` takes its capture on the command line.
    if (cfg.acquisition.source == config::SourceKind::candump && cfg.acquisition.capture.empty())
      throw CommandError(opt->config + ": [acquisition] source = \"candump\" needs capture = FILE for `run` "
                         "(`gearwatch replay CAPTURE` takes it on the command line)");
    if (!opt->db.empty()) cfg.storage.database = opt->db;
    logging::setup(logging::service_sink(cfg.logging.sink), cfg.logging.level);
    spdlog::info("gearwatch starting: config {}, database {}", opt->config, cfg.storage.database);
    daemon::PipelineResult r;
    try {
      r = daemon::run_pipeline(cfg, daemon::PipelineMode::live);
    } catch (const std::exception& e) {
      throw CommandError(e.what());
    }
    spdlog::info("gearwatch stopped: {} records ({} analysed), {} frames, {} samples, {} samples lost, {} frames dropped by the kernel",
                 r.records, r.records_analysed, r.frames, r.samples, r.lost_samples, r.kernel_dropped_frames);
    if (r.exit_status != 0) throw CommandError("stopped with an error: " + (r.end_reason.empty() ? "storage failure" : r.end_reason), r.exit_status);
  });
}

}  // namespace gearwatch::cli
