// `gearwatch gap ...`: the sim-to-real gap (docs/gap-report.md). `gap report --db FILE --out DIR`
// writes the gap page DIR/index.html from the stored reports and prints the newest report's
// features and bounded fits (--format table|json).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include <nlohmann/json.hpp>

#include "cli_common.hpp"
#include "gearwatch/report/gap_page.hpp"
#include "gearwatch/report/report_page.hpp"

namespace gearwatch::cli {

namespace fs = std::filesystem;

namespace {

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

/// The newest report's features, largest first, and the candidates fitted at a bound of their range.
nlohmann::json features_json(const storage::StoredGapReport& s) {
  nlohmann::json features = nlohmann::json::array(), bounds = nlohmann::json::array();
  for (const auto& f : s.report.features) {
    nlohmann::json seen = nlohmann::json::array();
    for (const auto& w : f.seen_in)
      seen.push_back({{"set", w.held_out ? "held_out" : "training"}, {"record", w.record}, {"speed_hz", number(w.speed_hz)},
                      {"torque_nm", number(w.torque_nm)}, {"order", number(w.order)}, {"hz", number(w.hz)},
                      {"size_db", number(w.size_db)}});
    features.push_back({{"movement", gap::to_string(f.movement)}, {"shaft", gap::to_string(f.shaft)}, {"order", number(f.order)},
                        {"order_low", number(f.order_low)}, {"order_high", number(f.order_high)}, {"hz", number(f.hz)},
                        {"hz_low", number(f.hz_low)}, {"hz_high", number(f.hz_high)}, {"size_db", number(f.size_db)},
                        {"size_interval_db", {number(f.size_interval_db.low), number(f.size_interval_db.high)}},
                        {"p_value", number(f.p_value)}, {"description", gap::describe(f)}, {"seen_in", seen}});
  }
  for (const auto& c : s.report.candidates)
    for (const auto& b : c.at_bounds)
      bounds.push_back({{"effect", gap::to_string(c.effect)}, {"parameter", b.name}, {"bound", number(b.bound)},
                        {"side", b.upper ? "upper" : "lower"}, {"description", gap::describe(b)}});
  return {{"report", s.id}, {"features", features}, {"at_bounds", bounds}};
}

void print_table(const storage::StoredGapReport& s) {
  const auto& r = s.report;
  std::cout << "features (" << r.features.size() << "):\n";
  if (r.features.empty()) std::cout << "  none: no line or band off the twin beyond its noise and the practical minimum\n";
  char line[256];
  std::snprintf(line, sizeof line, "  %-16s %-7s %10s %10s %-21s %8s %-17s %s\n", "movement", "shaft", "order", "Hz", "band Hz",
                "size dB", "interval dB", "records");
  if (!r.features.empty()) std::cout << line;
  for (const auto& f : r.features) {
    std::snprintf(line, sizeof line, "  %-16s %-7s %10.2f %10.1f %9.1f-%-11.1f %+8.2f [%+6.2f, %+6.2f] %zu\n", gap::to_string(f.movement),
                  gap::to_string(f.shaft), f.order, f.hz, f.hz_low, f.hz_high, f.size_db, f.size_interval_db.low,
                  f.size_interval_db.high, f.seen_in.size());
    std::cout << line;
  }
  for (const auto& c : r.candidates)
    for (const auto& b : c.at_bounds) std::cout << "fitted at a bound: " << gap::to_string(c.effect) << ": " << gap::describe(b) << "\n";
}

}  // namespace

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
  auto format = std::make_shared<std::string>("table");
  add_format_option(cmd, *format, "table", {"table", "json"});
  cmd->callback([opt, format] {
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
    // With --format json the document alone goes to standard output, the summary to standard error.
    std::ostream& summary = *format == "json" ? std::cerr : std::cout;
    summary << "wrote " << (fs::path(opt->out) / "index.html").string() << ": gap report #" << newest.id << " of "
            << data.total_reports << ", " << significant << " significant families, " << newest.report.chosen.size()
            << " chosen effects, " << newest.report.unexplained.size() << " unexplained, " << newest.report.features.size()
            << " features\n";
    if (*format == "json") std::cout << features_json(newest).dump(2) << "\n";
    else print_table(newest);
  });
}

}  // namespace gearwatch::cli
