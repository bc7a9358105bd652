// `gearwatch report --db FILE --out DIR`: the maintenance page DIR/index.html (docs/report.md).
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "cli_common.hpp"
#include "gearwatch/report/report_page.hpp"

namespace gearwatch::cli {

namespace fs = std::filesystem;

void register_report(CLI::App& app) {
  auto* cmd = app.add_subcommand("report", "Write a self-contained HTML status page of the gearbox (DIR/index.html)");
  auto opt = add_page_command_options(cmd);
  cmd->callback([opt] {
    const report::ReportData data = load_page_data(
        opt->db, [&](storage::Database& db) { return report::load_report_data(db, opt->db, report::utc_now_iso8601()); });
    write_page(opt->out, report::render_report_html(data));
    std::cout << "wrote " << (fs::path(opt->out) / "index.html").string() << ": " << data.records.size() << " records of gear pair #"
              << data.gear_pair_number << ", " << data.channels.size() << " channels, " << data.total_alerts << " alerts\n";
  });
}

}  // namespace gearwatch::cli
