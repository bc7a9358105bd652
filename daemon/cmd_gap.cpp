// `gearwatch gap ...`: the sim-to-real gap (docs/gap-report.md). `gap report --db FILE --out DIR`
// writes the gap page DIR/index.html from the stored reports.
#include <filesystem>
#include <iostream>

#include "cli_common.hpp"
#include "gearwatch/report/gap_page.hpp"
#include "gearwatch/report/report_page.hpp"

namespace gearwatch::cli {

namespace fs = std::filesystem;

CLI::App* gap_command(CLI::App& app) {
  for (CLI::App* sub : app.get_subcommands([](CLI::App* a) { return a->get_name() == "gap"; })) return sub;
  auto* gap = app.add_subcommand("gap", "The sim-to-real gap: where the twin disagrees with the gearbox, and why");
  gap->require_subcommand(1);
  return gap;
}

void add_gap_report_command(CLI::App& app) {
  auto* cmd = gap_command(app)->add_subcommand(
      "report", "Write the newest stored gap report as a self-contained HTML page with plots (DIR/index.html)");
  auto opt = add_page_command_options(cmd);
  cmd->callback([opt] {
    const report::GapPageData data = load_page_data(opt->db, [&](storage::Database& db) {
      try {
        return report::load_gap_page_data(db, opt->db, report::utc_now_iso8601());
      } catch (const report::NoGapReports& e) {
        throw CommandError(std::string(e.what()) + "; no page written");
      }
    });
    write_page(opt->out, report::render_gap_report_html(data));
    const auto& newest = data.reports.back();
    std::size_t significant = 0;
    for (const auto& g : newest.report.before) significant += g.significant ? 1 : 0;
    std::cout << "wrote " << (fs::path(opt->out) / "index.html").string() << ": gap report #" << newest.id << " of "
              << data.total_reports << ", " << significant << " significant families, " << newest.report.chosen.size()
              << " chosen effects, " << newest.report.unexplained.size() << " unexplained\n";
  });
}

}  // namespace gearwatch::cli
