// `gearwatch report --db FILE --out DIR`: the maintenance page DIR/index.html (docs/report.md).
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "cli_common.hpp"
#include "gearwatch/report/report_page.hpp"

namespace gearwatch::cli {

namespace {

namespace fs = std::filesystem;

// Written next to the target and renamed over it, so a browser (or a web server publishing DIR)
// never sees half a page.
void write_page(const fs::path& dir, const std::string& html) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw CommandError("cannot create output directory " + dir.string() + ": " + ec.message());
  if (!fs::is_directory(dir)) throw CommandError("--out " + dir.string() + " is not a directory");
  const fs::path target = dir / "index.html";
  const fs::path temporary = dir / "index.html.tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw CommandError("cannot write " + temporary.string() + ": " + std::strerror(errno));
    out << html;
    out.flush();
    if (!out) {
      const std::string reason = std::strerror(errno);
      fs::remove(temporary, ec);
      throw CommandError("cannot write " + temporary.string() + ": " + reason);
    }
  }
  fs::rename(temporary, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
    throw CommandError("cannot write " + target.string() + ": " + ec.message());
  }
}

}  // namespace

void register_report(CLI::App& app) {
  struct Options {
    std::string db, out;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("report", "Write a self-contained HTML status page of the gearbox (DIR/index.html)");
  cmd->add_option("--db", opt->db, "SQLite database (opened read-only)")->required();
  cmd->add_option("--out", opt->out, "Output directory (created if missing)")->required();
  cmd->callback([opt] {
    std::error_code ec;
    if (!fs::exists(opt->db, ec)) throw CommandError("no database at " + opt->db);
    if (fs::is_directory(opt->db, ec)) throw CommandError(opt->db + " is a directory, not a database");
    report::ReportData data;
    try {
      storage::Database db(opt->db, storage::Database::Mode::read_only);
      data = report::load_report_data(db, opt->db, report::utc_now_iso8601());
    } catch (const storage::SqliteError& e) {
      throw CommandError("cannot read " + opt->db + ": " + e.what());
    } catch (const std::runtime_error& e) {
      throw CommandError(e.what());
    }
    write_page(opt->out, report::render_report_html(data));
    std::cout << "wrote " << (fs::path(opt->out) / "index.html").string() << ": " << data.records.size() << " records of gear pair #"
              << data.gear_pair_number << ", " << data.channels.size() << " channels, " << data.total_alerts << " alerts\n";
  });
}

}  // namespace gearwatch::cli
