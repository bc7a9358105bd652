// `gearwatch publish --config FILE [--db FILE]`: the MQTT sender in a unit of its own
// (gearwatch-publisher.service; [mqtt] sender = "publisher", docs/mqtt.md).
#include <spdlog/spdlog.h>

#include "cli_common.hpp"
#include "commands.hpp"
#include "logging.hpp"
#include "publisher.hpp"

namespace gearwatch::cli {

void register_publish(CLI::App& app) {
  struct Options {
    std::string config, db;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("publish", "Deliver the database's MQTT outbox to the broker ([mqtt] sender = \"publisher\")");
  cmd->add_option("--config", opt->config, "Configuration file (TOML), the daemon's")->required();
  cmd->add_option("--db", opt->db, "Override storage.database");
  cmd->callback([opt] {
    auto cfg = load_config_or_defaults(opt->config);
    if (!opt->db.empty()) cfg.storage.database = opt->db;
    logging::setup(logging::service_sink(cfg.logging.sink), cfg.logging.level);
    try {
      daemon::Publisher publisher(cfg);
      publisher.run();
    } catch (const std::exception& e) {
      throw CommandError(e.what());
    }
  });
}

}  // namespace gearwatch::cli
