// `gearwatch inspect --db FILE --cycles N [--pitted-area F] [--wear-depth M] [--note T]`:
// staff record what an inspection found. The model (docs/model.md) calibrates K_pitting and the
// ICS2 <-> pitting-density scale from pitted areas, and shows wear depths against its prediction.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>

#include "cli_common.hpp"
#include "vocabulary.hpp"
#include "gearwatch/storage/database_lock.hpp"
#include "gearwatch/storage/inspections.hpp"
#include "gearwatch/storage/schema.hpp"

namespace gearwatch::cli {

namespace {
std::string number(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.10g", v);
  return b;
}

// An inspection is one row in one transaction and stores no records, so it may be entered while
// the daemon runs (the model reads the inspections at every record). With the writer lock free,
// inspect holds it while it may create or migrate the database; with it held by another process,
// inspect writes into that database only as that process left it: existing and at this build's
// schema version, never created or migrated under it.
struct InspectionDatabase {
  std::optional<storage::DatabaseLock> lock;  ///< held to the end of the command when it was free
  storage::Database db;
};

InspectionDatabase open_for_inspection(const std::string& path) {
  auto lock = storage::DatabaseLock::try_acquire(path);
  if (lock) {
    storage::Database db(path);
    storage::open_and_migrate(db, daemon::acquisition_vocabulary());
    return {std::move(lock), std::move(db)};
  }
  const pid_t holder = storage::DatabaseLock::holder(path);
  const std::string held = "database " + path + " is in use by another gearwatch (pid " +
                           (holder > 0 ? std::to_string(holder) : std::string("unknown")) + ")";
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw CommandError(held + " that has not created it yet; try again in a moment");
  storage::Database db(path, storage::Database::Mode::read_write);
  if (db.user_version() != storage::current_schema_version())
    throw CommandError(held + " at schema version " + std::to_string(db.user_version()) + ", not this gearwatch's " +
                       std::to_string(storage::current_schema_version()) + "; inspect does not migrate a database another process holds");
  db.exec("PRAGMA foreign_keys = ON");
  return {std::nullopt, std::move(db)};
}

}  // namespace

void register_inspect(CLI::App& app) {
  struct Options {
    std::string db, note;
    double cycles = -1;
    std::optional<double> pitted_area, wear_depth;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("inspect", "Record an inspection (pitted area, wear depth) at a cycle count");
  cmd->add_option("--db", opt->db, "SQLite database written by `run` or `replay`")->required();
  cmd->add_option("--cycles", opt->cycles, "Input-shaft revolutions at the inspection")->required();
  cmd->add_option("--pitted-area", opt->pitted_area, "Pitted area as a fraction of the flank area (0..1)");
  cmd->add_option("--wear-depth", opt->wear_depth, "Mean wear depth in metres (e.g. 12e-6)");
  cmd->add_option("--note", opt->note, "Free text");
  cmd->callback([opt] {
    if (!opt->pitted_area && !opt->wear_depth) throw CommandError("give --pitted-area and/or --wear-depth");
    if (!std::isfinite(opt->cycles) || opt->cycles < 0) throw CommandError("--cycles must be a finite, non-negative number");
    if (opt->pitted_area && !(*opt->pitted_area >= 0 && *opt->pitted_area <= 1))
      throw CommandError("--pitted-area is a fraction of the flank area: " + number(*opt->pitted_area) + " is outside [0, 1]");
    if (opt->wear_depth && !(*opt->wear_depth >= 0 && *opt->wear_depth <= 0.01))
      throw CommandError("--wear-depth is in metres: " + number(*opt->wear_depth) + " is outside [0, 0.01] (negative, or not a wear depth)");
    require_history(opt->db);  // an inspection belongs to an existing history, never to a new file
    try {
      InspectionDatabase opened = open_for_inspection(opt->db);
      storage::Database& db = opened.db;
      // The gear pair now installed: its records since the last life-counter reset.
      const storage::GearPairPosition at = storage::load_gear_pair_position(db);
      if (opt->cycles > at.newest_record_cycles)
        throw CommandError("--cycles " + number(opt->cycles) + " is beyond the newest record (" + number(at.newest_record_cycles) +
                           " cycles): an inspection cannot be in the future of the data");
      if (at.gear_pair > 0 && opt->cycles < at.reset_at_cycles)
        throw CommandError("--cycles " + number(opt->cycles) + " is before the last life-counter reset (" +
                           number(at.reset_at_cycles) + " cycles): that was the previous gear pair");
      const std::int64_t id =
          storage::insert_inspection(db, {opt->cycles, opt->pitted_area, opt->wear_depth, opt->note, at.gear_pair});
      std::cout << "inspection " << id << " recorded at " << opt->cycles << " cycles\n";
    } catch (const CommandError&) {
      throw;
    } catch (const std::runtime_error& e) {  // SQLite's errors, the lock file's
      throw CommandError(e.what());
    }
  });
}

}  // namespace gearwatch::cli
