#include "gearwatch/report/gap_page.hpp"

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include <CLI/CLI.hpp>
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "command_runner.hpp"
#include "commands.hpp"
#include "gap_report_fixture.hpp"
#include "gearwatch/storage/schema.hpp"
#include "temp_dir.hpp"

namespace test_gap_page {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;

namespace {

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto pos = text.find(what); pos != std::string::npos; pos = text.find(what, pos + what.size())) ++n;
  return n;
}

report::GapPageData page_data(const gap::GapReport& r) {
  report::GapPageData d;
  d.database = "plant.db";
  d.generated_at = "2026-11-23T12:00:00Z";
  storage::StoredGapReport s;
  s.id = 7;
  s.created_at = "2026-11-23T11:00:00.000Z";
  s.context.gear_pair = 2;
  s.report = r;
  d.reports = {s};
  d.total_reports = 1;
  return d;
}

// The points of the polyline of series `name` inside the plot with id `plot_id`.
std::size_t polyline_points(const std::string& html, const std::string& plot_id, const std::string& name) {
  const auto plot = html.find("id=\"" + plot_id + "\"");
  REQUIRE(plot != std::string::npos);
  const auto series = html.find("data-name=\"" + name + "\"", plot);
  REQUIRE(series != std::string::npos);
  const auto points = html.find("points=\"", series);
  const auto end = html.find('"', points + 8);
  const std::string list = html.substr(points + 8, end - points - 8);
  return static_cast<std::size_t>(std::count(list.begin(), list.end(), ' ')) + 1;
}

}  // namespace

TEST_CASE("gap page: the families before and after with intervals, in a table and as bars with whiskers", "[gap_page][report]") {
  const std::string html = report::render_gap_report_html(page_data(testing::known_gap_report()));
  CHECK(count(html, "<tr class=\"family-row") == 7);
  CHECK(count(html, "<tr class=\"family-row significant\"") == 3);
  // Output sidebands: before and after with their intervals, left unexplained.
  CHECK(html.find("<td class=\"num\">4.75 dB</td><td class=\"num\">[3.50, 6.00]</td><td class=\"num\">11.0 %</td><td><b>yes</b></td>"
                  "<td class=\"num\">4.50 dB</td><td class=\"num\">[3.25, 5.75]</td><td class=\"num\">45.0 %</td><td><b>yes</b></td>"
                  "<td class=\"num\">-5.3 %</td>") != std::string::npos);
  CHECK(html.find("unexplained: no candidate explains it") != std::string::npos);
  // Fixed frequency: 12.625 -> 1.5 dB (-88.1 %), attributed to the chosen casing mode.
  CHECK(html.find("<td class=\"num\">1.50 dB</td><td class=\"num\">[0.75, 2.25]</td><td class=\"num\">10.0 %</td><td>no</td>"
                  "<td class=\"num\">-88.1 %</td><td>casing_mode</td>") != std::string::npos);
  CHECK(html.find("not resolved: records shorter than 8 output revolutions") != std::string::npos);
  // Bars for the six resolved families, each with its whisker; a star per significant gap (3 before, 1 after).
  CHECK(count(html, "<svg class=\"plot gap-bars\"") == 1);
  CHECK(count(html, "<rect class=\"bar before\"") == 6);
  CHECK(count(html, "<rect class=\"bar after\"") == 6);
  CHECK(count(html, "<path class=\"whisker\"") == 12);
  CHECK(count(html, "<text class=\"sig\"") == 4);
  CHECK(html.find("<title>fixed_frequency, twin alone: 12.62 dB [10.50, 14.75], significant</title>") != std::string::npos);
  // K_wear with the twin alone and with the effect: 3.0/4.25 - 1 = -29.4 %.
  CHECK(html.find("4.25e-17 m²/N with the twin alone → 3e-17 m²/N with the chosen effects (-29.4 %)") != std::string::npos);
  CHECK(html.find("<script") == std::string::npos);
  CHECK(html.find("Content-Security-Policy\" content=\"default-src 'none'") != std::string::npos);
}

TEST_CASE("gap page: the attribution with its evidence: candidates ranked, shrinkage, IC, worsens flag, parameters", "[gap_page][report]") {
  const std::string html = report::render_gap_report_html(page_data(testing::known_gap_report()));
  CHECK(count(html, "<tr class=\"candidate-row") == 3);
  CHECK(html.find("<tr class=\"candidate-row chosen\" data-effect=\"casing_mode\"><td class=\"num\">1</td><td>casing_mode</td>"
                  "<td>fixed_frequency, input_sidebands</td><td class=\"num\">87.5 %</td><td class=\"num\">-42.5</td><td>no</td>"
                  "<td>frequency_hz = 2400.14; damping_ratio = 0.05; gain = 3.75</td><td>step 1</td></tr>") != std::string::npos);
  // The mount resonance helps the fixed frequency (76.2 %) but pushes the mesh harmonics from 1.25 to 3.5 dB.
  CHECK(html.find("<td class=\"num\">76.2 %</td><td class=\"num\">-30.12</td><td><b class=\"worse\">yes</b> "
                  "(mesh_harmonics 1.25 dB → 3.50 dB)</td>") != std::string::npos);
  CHECK(html.find("<td>level_m_s2_per_sqrt_hz = 0.00015</td><td>—</td>") != std::string::npos);
  // Text from the database is escaped.
  gap::GapReport odd = testing::known_gap_report();
  odd.candidates[0].parameters[0].first = "f<sub>0</sub> & \"Q\"";
  const std::string escaped = report::render_gap_report_html(page_data(odd));
  CHECK(escaped.find("f&lt;sub&gt;0&lt;/sub&gt; &amp; &quot;Q&quot; = 2400.14") != std::string::npos);
}

TEST_CASE("gap page: measured, twin and corrected spectra in orders and in Hz with the families shaded", "[gap_page][report]") {
  const std::string html = report::render_gap_report_html(page_data(testing::known_gap_report()));
  CHECK(count(html, "<svg class=\"plot\" id=\"spectrum-orders\"") == 1);
  CHECK(count(html, "<svg class=\"plot\" id=\"spectrum-hz\"") == 1);
  // Three continuous curves per plot, 400 points each, no point markers on dense curves.
  CHECK(count(html, "<polyline") == 6);
  CHECK(count(html, "<circle class=\"pt\"") == 0);  // one report: no trend plot either
  for (const char* plot : {"spectrum-orders", "spectrum-hz"})
    for (const char* series : {"measured", "twin", "twin_after"}) CHECK(polyline_points(html, plot, series) == 400);
  // Every band lies inside its axis: 3 shaded in orders, 3 in Hz.
  CHECK(count(html, "<rect class=\"band family ") == 6);
  CHECK(html.find("<title>fixed_frequency: 2280 to 2520 Hz</title>") != std::string::npos);
  CHECK(html.find("<title>mesh_harmonics: 21.5 to 22.5 orders</title>") != std::string::npos);
  // The band of the fixed frequency in Hz sits where the axis puts 2280..2520 Hz: the axis runs
  // 7.5..3000 Hz over 1180 - 70 - 16 = 1094 px from x = 70.
  const double x0 = 70 + (2280 - 7.5) / (3000 - 7.5) * 1094, x1 = 70 + (2520 - 7.5) / (3000 - 7.5) * 1094;
  char expected[128];
  std::snprintf(expected, sizeof expected, "<rect class=\"band family fixed_frequency\" x=\"%.2f\" y=\"42.00\" width=\"%.2f\"", x0, x1 - x0);
  CHECK(html.find(expected) != std::string::npos);
}

TEST_CASE("gap page: loading needs a stored report, and gap report says so and writes nothing", "[gap_page][report][cli]") {
  const testing::TempDir dir("gap-page");
  const auto path = (dir / "a.db").string();
  {
    storage::Database db(path);
    storage::open_and_migrate(db);
    CHECK_THROWS_AS(report::load_gap_page_data(db, "a.db", "now"), report::NoGapReports);
  }
  const auto none = testing::run_command(std::string(GEARWATCH_BINARY) + " gap report --db " + path + " --out " + (dir / "out").string());
  CHECK(none.status == 1);
  CHECK(none.err.find("has no gap reports yet") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir / "out" / "index.html"));
  {
    storage::Database db(path);
    storage::open_and_migrate(db);
    storage::Transaction tx(db);
    for (int i = 0; i < 3; ++i) {
      gap::GapReport r = testing::known_gap_report();
      r.input_revolutions = 1000.0 * (i + 1);
      storage::insert_gap_report(db, r, {std::nullopt, 0});
    }
    tx.commit();
    const auto d = report::load_gap_page_data(db, "a.db", "now", 2);
    CHECK(d.total_reports == 3);
    REQUIRE(d.reports.size() == 2);
    CHECK(d.reports.back().report.input_revolutions == 3000.0);
    const std::string html = report::render_gap_report_html(d);
    CHECK(count(html, "<tr class=\"history-row\">") == 2);
    // The trend over life: the six resolved families, one point per report shown.
    CHECK(count(html, "<svg class=\"plot\" id=\"gap-trend\"") == 1);
    CHECK(count(html, "<circle class=\"pt\"") == 12);
    CHECK(html.find("<title>fixed_frequency at 3000 cycles: 12.62 dB [10.50, 14.75], significant</title>") != std::string::npos);
    CHECK(html.find("data-name=\"output_shaft_orders\"") == std::string::npos);
    CHECK(html.find("The newest 2 of 3 reports.") != std::string::npos);
  }
  // A raised twin_drift alert is shown with its value and message; none raised says so.
  {
    storage::Database db(path);
    const auto quiet = report::load_gap_page_data(db, "a.db", "now");
    CHECK(quiet.active_drift.empty());
    CHECK(report::render_gap_report_html(quiet).find("No twin_drift alert is raised.") != std::string::npos);
    db.exec("INSERT INTO alert_events(severity, kind, transition, value, message, subject) VALUES ('warning', 'twin_drift', 'raised',"
            " '12.6 dB', 'differ in fixed_frequency <by> 12.6 dB', 'fixed_frequency')");
    db.exec("INSERT INTO alert_state(kind, channel, subject, active, value, consecutive_present, consecutive_absent)"
            " VALUES ('twin_drift', -1, 'fixed_frequency', 1, '12.6 dB', 1, 0)");
    const auto raised = report::load_gap_page_data(db, "a.db", "now");
    REQUIRE(raised.active_drift.size() == 1);
    const std::string html = report::render_gap_report_html(raised);
    CHECK(count(html, "<li class=\"sev-warning drift-alert\"><b>fixed_frequency</b> 12.6 dB since ") == 1);
    CHECK(html.find(": differ in fixed_frequency &lt;by&gt; 12.6 dB</li>") != std::string::npos);
  }
  const auto ok = testing::run_command(std::string(GEARWATCH_BINARY) + " gap report --format table --db " + path + " --out " +
                                       (dir / "out").string());
  CHECK(ok.status == 0);
  CHECK(ok.out.find("gap report #3 of 3, 3 significant families, 1 chosen effects, 1 unexplained") != std::string::npos);
  std::ifstream page(dir / "out" / "index.html");
  std::stringstream text;
  text << page.rdbuf();
  CHECK(count(text.str(), "<tr class=\"history-row\">") == 3);
  // The newest report printed with its features and bounds: a table before the summary, or JSON
  // alone on standard output (the summary then on standard error).
  CHECK(ok.out.find(", 2 features") != std::string::npos);
  CHECK(ok.out.find("fixed_in_hz      input       240.33     2403.1    2385.0-2425.0        +11.75 [+11.50, +12.00] 2") !=
        std::string::npos);
  CHECK(ok.out.find("fitted at a bound: mount_resonance would need > 2450 Hz frequency (frequency_hz at the top of its range)") != std::string::npos);
  // Each feature's statement: which candidate explains it, and what form it has either way.
  CHECK(ok.out.find("feature 1: explained by casing_mode; described as a resonance at 2403.5 Hz, damping ratio 0.0125, +11.8 dB at its peak") !=
        std::string::npos);
  CHECK(ok.out.find("feature 2: not explained by a physical candidate; described as a 15 % modulation (AM or PM: no phases) at the gear "
                    "shaft's order") != std::string::npos);
  const auto json_run =
      testing::run_command(std::string(GEARWATCH_BINARY) + " gap report --format json --db " + path + " --out " + (dir / "out").string());
  CHECK(json_run.status == 0);
  CHECK(json_run.err.find(", 2 features") != std::string::npos);
  const auto doc = nlohmann::json::parse(json_run.out);
  CHECK(doc.at("id") == 3);
  REQUIRE(doc.at("features").size() == 2);
  CHECK(doc["features"][0]["movement"] == "fixed_in_hz");
  CHECK(doc["features"][0]["hz"] == 2403.125);
  CHECK(doc["features"][0]["seen_in"].size() == 2);
  CHECK(doc["features"][1]["shaft"] == "output");
  CHECK(doc["features"][1]["seen_in"][0]["torque_nm"].is_null());
  REQUIRE(doc.at("at_bounds").size() == 1);
  CHECK(doc["at_bounds"][0]["effect"] == "mount_resonance");
  CHECK(doc["at_bounds"][0]["side"] == "upper");
  CHECK(doc["at_bounds"][0]["value"] == 2450.0);
  CHECK(doc["at_bounds"][0]["unit"] == "Hz");
  CHECK(doc["at_bounds"][0]["description"] == "mount_resonance would need > 2450 Hz frequency (frequency_hz at the top of its range)");
  CHECK(doc["features"][0]["explained_by"] == "casing_mode");
  CHECK(doc["features"][0]["described_as"]["kind"] == "resonance");
  CHECK(doc["features"][0]["described_as"]["parameters"][0][1] == 2403.5);
  CHECK(doc["features"][1]["explained_by"].is_null());
  CHECK(doc["features"][1]["described_as"]["kind"] == "modulation");
  CHECK(doc["features"][1]["described_as"]["parameters"][1][1].is_null());
  const auto bad = testing::run_command(std::string(GEARWATCH_BINARY) + " gap report --db " + (dir / "missing.db").string() + " --out " +
                                        (dir / "out").string());
  CHECK(bad.status == 1);
  CHECK(bad.err.find("no database at") != std::string::npos);
}

TEST_CASE("gap command: one `gap` parent for every child, in any order of registration, each with --help", "[gap_page][cli]") {
  CLI::App app{"test"};
  CLI::App* first = cli::gap_command(app);
  cli::add_gap_report_command(app);
  CHECK(cli::gap_command(app) == first);
  // A second child registered later (as `gap bench` will be) joins the same parent.
  first->add_subcommand("other", "another gap child");
  CHECK(app.get_subcommands({}).size() == 1);
  CHECK(first->get_subcommands({}).size() == 2);
  for (const char* args : {" gap --help", " gap report --help"}) {
    const auto r = testing::run_command(std::string(GEARWATCH_BINARY) + args);
    CHECK(r.status == 0);
    CHECK(r.out.find("Usage") != std::string::npos);
  }
  const auto bare = testing::run_command(std::string(GEARWATCH_BINARY) + " gap");
  CHECK(bare.status != 0);
}

TEST_CASE("gap page: the features are listed with where, movement, size, records and what they are, and marked on both spectra",
          "[gap_page][report][gap_features]") {
  const std::string html = report::render_gap_report_html(page_data(testing::known_gap_report()));
  CHECK(count(html, "<tr class=\"feature-row\"") == 2);
  // The band fixed in Hz: where in Hz, its band and size, the two records it was seen in.
  CHECK(html.find("<tr class=\"feature-row\" data-movement=\"fixed_in_hz\"><td>F1</td><td>2403.1 Hz</td><td>fixed_in_hz</td>"
                  "<td class=\"num\">240.33 (input)</td><td class=\"num\">2403.1</td><td class=\"num\">2385.0–2425.0</td>"
                  "<td class=\"num\">+11.75 dB</td><td class=\"num\">[11.50, 12.00]</td>"
                  "<td>held-out 0 (10.00 Hz, +11.5 dB), training 1 (8.00 Hz, +12.0 dB)</td>"
                  "<td class=\"what\">explained by casing_mode; described as a resonance at 2403.5 Hz, damping ratio 0.0125, +11.8 dB at "
                  "its peak</td></tr>") != std::string::npos);
  // The ghost: no candidate explains it; a 15 % modulation at the gear shaft's order describes it.
  CHECK(html.find("<td class=\"what\">not explained by a physical candidate; described as a 15 % modulation (AM or PM: no phases) "
                  "at the gear shaft&#39;s order</td></tr>") != std::string::npos);
  // The ghost line, at an output order, seen in one record (so its movement is undetermined).
  CHECK(html.find("<td>F2</td><td>output order 2.50</td><td>undetermined</td>") != std::string::npos);
  // Marked on each spectrum: the plotted record turns at 10 Hz (7.5 Hz over 0.75 orders), so the band
  // sits at 2403.125 Hz = order 240.3125, the ghost at its 10 Hz sighting (order 0.9125, 9.125 Hz).
  CHECK(count(html, "<line class=\"ev feature\"") == 4);
  CHECK(html.find("<title>F1: 2403.1 Hz (band 2385.0-2425.0 Hz), fixed in Hz, +11.8 dB [+11.5, +12.0], seen in 2 records; "
                  "explained by casing_mode; described as a resonance at 2403.5 Hz, damping ratio 0.0125, +11.8 dB at its peak</title>") !=
        std::string::npos);
  // A candidate fitted at a bound says what it would need.
  CHECK(html.find("at a bound: mount_resonance would need &gt; 2450 Hz frequency (frequency_hz at the top of its range)") != std::string::npos);
}

}  // namespace test_gap_page
