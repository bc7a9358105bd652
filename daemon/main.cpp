// gearwatch: vibration-based gear wear monitoring daemon and its tools.
// The command forms are a stable contract (docs/cli.md).
#include <cstdio>
#include <exception>

#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "logging.hpp"

int main(int argc, char** argv) {
  CLI::App app{"gearwatch: vibration-based gear wear monitoring"};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Show help for every subcommand");
  gearwatch::cli::register_run(app);
  gearwatch::cli::register_replay(app);
  gearwatch::cli::register_simulate(app);
  gearwatch::cli::register_query(app);
  gearwatch::cli::register_inspect(app);
  gearwatch::cli::register_twin(app);
  gearwatch::cli::register_report(app);
  gearwatch::cli::register_gap(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const gearwatch::cli::CommandError& e) {
    std::fprintf(stderr, "gearwatch: %s\n", e.what());
    return e.exit_status;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gearwatch: %s\n", e.what());
    return 1;
  }
  return 0;
}
