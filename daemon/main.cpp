// gearwatch: vibration-based gear wear monitoring daemon and its tools.
// The command forms are a stable contract (docs/cli.md).
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "gearwatch/storage/schema.hpp"
#include "logging.hpp"

namespace {

// A command line the parser refuses (EX_USAGE of sysexits.h): distinct from the statuses a
// command's own failures use.
constexpr int kUsageExitStatus = 64;

std::string version_text() {
  return std::string("gearwatch ") + GEARWATCH_VERSION + " (database schema version " +
         std::to_string(gearwatch::storage::current_schema_version()) + ")";
}

// The parser's messages may span lines; the contract is one line per error.
std::string one_line(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  for (char& c : text)
    if (c == '\n') c = ' ';
  return text;
}

// The gap diagnosis allocates and frees buffers of megabytes again and again (twin records, a unit
// tone reduced like a record per describer trial). By default glibc serves them by mmap, or trims
// them off the top of the arena when freed, so their pages are faulted in and zeroed afresh each
// time. A fixed mmap threshold (glibc's ceiling) and a trim threshold of a gibibyte keep the freed
// memory for the next allocation; the arithmetic is the same. GLIBC_TUNABLES may still set them.
void keep_freed_memory() {
#if defined(__GLIBC__)
  if (std::getenv("GLIBC_TUNABLES") != nullptr) return;
  mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024);
#endif
}

}  // namespace

int main(int argc, char** argv) {
  keep_freed_memory();
  CLI::App app{"gearwatch: vibration-based gear wear monitoring"};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Show help for every subcommand");
  gearwatch::cli::register_run(app);
  gearwatch::cli::register_replay(app);
  gearwatch::cli::register_simulate(app);
  gearwatch::cli::register_import(app);
  gearwatch::cli::register_query(app);
  gearwatch::cli::register_inspect(app);
  gearwatch::cli::register_twin(app);
  gearwatch::cli::register_report(app);
  gearwatch::cli::register_gap(app);
  gearwatch::cli::register_bench(app);
  gearwatch::cli::register_commission(app);
  gearwatch::cli::register_fleet(app);
  gearwatch::cli::register_publish(app);
  app.set_version_flag("--version", version_text(), "Print gearwatch's version and the database schema version it writes, and exit");
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --help-all, --version: their text on stdout, exit 0
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "gearwatch: %s; see --help\n", one_line(e.what()).c_str());
    return kUsageExitStatus;
  } catch (const gearwatch::cli::CommandError& e) {
    std::fprintf(stderr, "gearwatch: %s\n", e.what());
    return e.exit_status;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gearwatch: %s\n", e.what());
    return 1;
  }
  return 0;
}
