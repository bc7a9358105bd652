// `gearwatch inspect --db FILE --cycles N [--pitted-area F] [--wear-depth M] [--wear-depth-max M]
// [--depth-sd F] [--note T]`:
// staff record what an inspection found. The model (docs/model.md) calibrates K_pitting and the
// ICS2 <-> pitting-density scale from pitted areas, and its depth and the deepest point's ratio to
// the mean from the wear depths (docs/model.md).
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>

#include "cli_common.hpp"
#include "gearwatch/storage/inspections.hpp"

namespace gearwatch::cli {

namespace {
std::string number(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.10g", v);
  return b;
}

}  // namespace

void register_inspect(CLI::App& app) {
  struct Options {
    std::string db, note;
    double cycles = -1;
    std::optional<double> pitted_area, wear_depth, wear_depth_max, depth_sd;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("inspect", "Record an inspection (pitted area, wear depth) at a cycle count");
  cmd->add_option("--db", opt->db, "SQLite database written by `run` or `replay`")->required();
  cmd->add_option("--cycles", opt->cycles, "Input-shaft revolutions at the inspection")->required();
  cmd->add_option("--pitted-area", opt->pitted_area, "Pitted area as a fraction of the flank area (0..1)");
  cmd->add_option("--wear-depth", opt->wear_depth, "Combined mean wear depth (pinion mean + gear mean, as the model gives it) in metres (e.g. 12e-6)");
  cmd->add_option("--wear-depth-max", opt->wear_depth_max,
                  "Deepest wear depth on the flank (from a mould's profile) in metres; needs --wear-depth");
  cmd->add_option("--depth-sd", opt->depth_sd,
                  "Relative SD of this inspection's wear depths (e.g. 0.05); default: [model] inspection_depth_relative_sd");
  cmd->add_option("--note", opt->note, "Free text");
  cmd->callback([opt] {
    if (!opt->pitted_area && !opt->wear_depth) throw CommandError("give --pitted-area and/or --wear-depth");
    if (!std::isfinite(opt->cycles) || opt->cycles < 0) throw CommandError("--cycles must be a finite, non-negative number");
    if (opt->pitted_area && !(*opt->pitted_area >= 0 && *opt->pitted_area <= 1))
      throw CommandError("--pitted-area is a fraction of the flank area: " + number(*opt->pitted_area) + " is outside [0, 1]");
    if (opt->wear_depth && !(*opt->wear_depth >= 0 && *opt->wear_depth <= 0.01))
      throw CommandError("--wear-depth is in metres: " + number(*opt->wear_depth) + " is outside [0, 0.01] (negative, or not a wear depth)");
    if (opt->wear_depth_max && !opt->wear_depth)
      throw CommandError("--wear-depth-max needs --wear-depth: the deepest point is read against the same inspection's mean");
    if (opt->wear_depth_max && !(*opt->wear_depth_max >= 0 && *opt->wear_depth_max <= 0.01))
      throw CommandError("--wear-depth-max is in metres: " + number(*opt->wear_depth_max) + " is outside [0, 0.01] (negative, or not a wear depth)");
    if (opt->depth_sd && !opt->wear_depth) throw CommandError("--depth-sd needs --wear-depth");
    if (opt->depth_sd && !(*opt->depth_sd > 0 && *opt->depth_sd < 1))
      throw CommandError("--depth-sd is a relative SD: " + number(*opt->depth_sd) + " is outside (0, 1)");
    try {
      // An inspection belongs to an existing history, never to a new file.
      WritableHistory opened = open_history_for_writing(opt->db, "inspect");
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
          storage::insert_inspection(db, {opt->cycles, opt->pitted_area, opt->wear_depth, opt->note, at.gear_pair,
                                          opt->wear_depth_max, opt->depth_sd});
      std::cout << "inspection " << id << " recorded at " << opt->cycles << " cycles\n";
    } catch (const CommandError&) {
      throw;
    } catch (const std::runtime_error& e) {  // SQLite's errors, the lock file's
      throw CommandError(e.what());
    }
  });
}

}  // namespace gearwatch::cli
