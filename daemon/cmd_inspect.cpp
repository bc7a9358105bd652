// `gearwatch inspect --db FILE --cycles N [--pitted-area F] [--wear-depth M] [--note T]`:
// staff record what an inspection found; the model uses it to scale its pitting coefficient.
#include <iostream>

#include "cli_common.hpp"
#include "vocabulary.hpp"
#include "gearwatch/storage/schema.hpp"

namespace gearwatch::cli {

void register_inspect(CLI::App& app) {
  struct Options {
    std::string db, note;
    double cycles = -1;
    std::optional<double> pitted_area, wear_depth;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("inspect", "Record an inspection (pitted area, wear depth) at a cycle count");
  cmd->add_option("--db", opt->db, "SQLite database")->required();
  cmd->add_option("--cycles", opt->cycles, "Input-shaft revolutions at the inspection")->required()->check(CLI::NonNegativeNumber);
  cmd->add_option("--pitted-area", opt->pitted_area, "Pitted area as a fraction of the flank area (0..1)")->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--wear-depth", opt->wear_depth, "Mean wear depth in metres (e.g. 12e-6)")->check(CLI::Range(0.0, 0.01));
  cmd->add_option("--note", opt->note, "Free text");
  cmd->callback([opt] {
    if (!opt->pitted_area && !opt->wear_depth) throw CommandError("give --pitted-area and/or --wear-depth");
    try {
      storage::Database db(opt->db);
      storage::open_and_migrate(db, daemon::acquisition_vocabulary());
      storage::Statement s(db, "INSERT INTO inspections(cycles, pitted_area_fraction, wear_depth_m, note) VALUES (?, ?, ?, ?)");
      s.bind(1, opt->cycles).bind(2, opt->pitted_area).bind(3, opt->wear_depth);
      if (opt->note.empty()) s.bind_null(4);
      else s.bind(4, opt->note);
      s.run();
      std::cout << "inspection " << db.last_insert_rowid() << " recorded at " << opt->cycles << " cycles\n";
    } catch (const storage::SqliteError& e) {
      throw CommandError(e.what());
    }
  });
}

}  // namespace gearwatch::cli
