// `gearwatch gap ...`: the sim-to-real gap (docs/gap-report.md). `gap report --db FILE [--out DIR]
// [--format table|json]` prints the newest stored gap report and/or writes the gap page
// DIR/index.html from the stored reports.
#include <filesystem>
#include <iostream>

#include <nlohmann/json.hpp>

#include "cli_common.hpp"
#include "gap_print.hpp"
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
  struct Options {
    std::string db, out, format;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = gap_command(app)->add_subcommand(
      "report", "Print the newest stored gap report (--format) and/or write it as a self-contained HTML page with plots (--out DIR)");
  cmd->add_option("--db", opt->db, "SQLite database (opened read-only)")->required();
  auto* out = cmd->add_option("--out", opt->out, "Output directory of the page (created if missing)");
  auto* format = cmd->add_option("--format", opt->format, "Print the newest report in this format")->check(CLI::IsMember({"table", "json"}));
  cmd->callback([opt, out, format] {
    if (out->count() == 0 && format->count() == 0) throw CLI::RequiredError("gap report needs --out DIR and/or --format table|json");
    const report::GapPageData data = load_page_data(opt->db, [&](storage::Database& db) {
      try {
        return report::load_gap_page_data(db, opt->db, report::utc_now_iso8601());
      } catch (const report::NoGapReports& e) {
        throw CommandError(std::string(e.what()) + (opt->out.empty() ? "" : "; no page written"));
      }
    });
    const auto& newest = data.reports.back();
    if (!opt->format.empty()) print_gap_report(newest, opt->format, true);
    if (opt->out.empty()) return;
    write_page(opt->out, report::render_gap_report_html(data));
    std::size_t significant = 0;
    for (const auto& g : newest.report.before) significant += g.significant ? 1 : 0;
    // With --format json the document alone goes to standard output, the summary to standard error.
    std::ostream& summary = opt->format == "json" ? std::cerr : std::cout;
    summary << "wrote " << (fs::path(opt->out) / "index.html").string() << ": gap report #" << newest.id << " of "
            << data.total_reports << ", " << significant << " significant families, " << newest.report.chosen.size()
            << " chosen effects, " << newest.report.unexplained.size() << " unexplained, " << newest.report.features.size()
            << " features\n";
  });
}

}  // namespace gearwatch::cli
