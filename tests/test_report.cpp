// The maintenance report (docs/report.md): the plot arithmetic against hand-computed values, and
// `gearwatch report` end to end on a database made by replaying captures of known layout.
#include "gearwatch/report/report_page.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>

#include <catch2/catch.hpp>

#include "command_runner.hpp"
#include "gearwatch/storage/schema.hpp"
#include "temp_dir.hpp"

namespace test_report {  // this file's own: the test files compile together (unity build)

namespace fs = std::filesystem;
using namespace gearwatch::report;
using gearwatch::testing::run_command;

namespace {

std::size_t count_of(const std::string& text, const std::string& needle) {
  std::size_t n = 0;
  for (auto pos = text.find(needle); pos != std::string::npos; pos = text.find(needle, pos + needle.size())) ++n;
  return n;
}

/// The text from `open` up to and including the next `close`; empty if `open` is absent.
std::string element(const std::string& text, const std::string& open, const std::string& close) {
  const auto start = text.find(open);
  if (start == std::string::npos) return {};
  const auto end = text.find(close, start);
  return end == std::string::npos ? std::string{} : text.substr(start, end + close.size() - start);
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string gearwatch_cli(const std::string& args) { return std::string(GEARWATCH_BINARY) + " " + args; }

std::int64_t count_rows(const fs::path& db_path, const std::string& sql) {
  gearwatch::storage::Database db(db_path.string(), gearwatch::storage::Database::Mode::read_only);
  gearwatch::storage::Statement s(db, sql);
  REQUIRE(s.step());
  return s.get_int(0);
}

}  // namespace

TEST_CASE("report: Heckbert's nice numbers", "[report]") {
  // round = false: the smallest of {1, 2, 5, 10} x 10^k not below x.
  CHECK(nice_number(0.87, false) == Approx(1.0).epsilon(1e-15));
  CHECK(nice_number(0.003, false) == Approx(0.005).epsilon(1e-15));
  CHECK(nice_number(120, false) == Approx(200).epsilon(1e-15));
  CHECK(nice_number(2, false) == Approx(2).epsilon(1e-15));
  // round = true: the nearest, with the thresholds 1.5, 3 and 7.
  CHECK(nice_number(0.25, true) == Approx(0.2).epsilon(1e-15));
  CHECK(nice_number(1.49, true) == Approx(1).epsilon(1e-15));
  CHECK(nice_number(1.5, true) == Approx(2).epsilon(1e-15));
  CHECK(nice_number(6.9, true) == Approx(5).epsilon(1e-15));
  CHECK(nice_number(7, true) == Approx(10).epsilon(1e-15));
  CHECK_THROWS(nice_number(0, true));
}

TEST_CASE("report: linear ticks are exact multiples of a nice step inside the range", "[report]") {
  // 0–0.87, about 5 ticks: 0.87 / 4 = 0.2175 -> step 0.2; multiples inside: 0 … 0.8.
  const auto a = linear_ticks(0, 0.87);
  CHECK(a.step == 0.2);
  CHECK(a.values == std::vector<double>{0, 0.2, 0.4, 0.6, 0.8});  // exactly the doubles of the literals
  CHECK(a.decimals == 1);
  CHECK(format_linear_tick(0.6, a) == "0.6");
  CHECK(format_linear_tick(0, a) == "0");
  // 3.12–3.17 (a kurtosis): 0.05 / 4 = 0.0125 -> step 0.01; both ends are ticks.
  const auto b = linear_ticks(3.12, 3.17);
  CHECK(b.values == std::vector<double>{3.12, 3.13, 3.14, 3.15, 3.16, 3.17});
  CHECK(format_linear_tick(3.15, b) == "3.15");
  // -7.5–12: 19.5 / 4 = 4.875 -> step 5.
  CHECK(linear_ticks(-7.5, 12).values == std::vector<double>{-5, 0, 5, 10});
  // 0–220 input revolutions: 55 -> step 50.
  CHECK(linear_ticks(0, 220).values == std::vector<double>{0, 50, 100, 150, 200});
  // 10 756–19 000 Hz: 2061 -> step 2000; ticks reach 10 000, so labels in k.
  const auto c = linear_ticks(10756, 19000);
  CHECK(c.values == std::vector<double>{12000, 14000, 16000, 18000});
  CHECK(format_linear_tick(12000, c) == "12k");
  // 0–2.2 million revolutions: 550 000 -> step 500 000, labels in M with one decimal.
  const auto d = linear_ticks(0, 2.2e6);
  CHECK(d.values == std::vector<double>{0, 5e5, 1e6, 1.5e6, 2e6});
  CHECK(format_linear_tick(5e5, d) == "0.5M");
  CHECK(format_linear_tick(2e6, d) == "2.0M");
  CHECK(format_linear_tick(0, d) == "0");
}

TEST_CASE("report: log ticks are the decades inside the range, the log axis is chosen past two decades", "[report]") {
  const auto t = log_ticks(1e-4, 0.3);
  CHECK(t == std::vector<double>{1e-4, 1e-3, 1e-2, 1e-1});
  CHECK(format_log_tick(1e-4) == "1e-4");
  CHECK(format_log_tick(1e-3) == "0.001");
  CHECK(format_log_tick(1e-1) == "0.1");
  CHECK(format_log_tick(1e6) == "1e6");
  // 19 decades with at most 8 labels: every third one.
  CHECK(log_ticks(1e-12, 1e6) == std::vector<double>{1e-12, 1e-9, 1e-6, 1e-3, 1, 1e3, 1e6});

  // 1e-4–0.3 spans 3.48 decades: log, padded by 5 % of them at each end.
  const auto ics2 = fit_axis({0.3, 1e-4, std::numeric_limits<double>::quiet_NaN(), 0.02}, "ICS2", true);
  CHECK(ics2.scale == AxisScale::log);
  const double decades = std::log10(0.3) + 4;
  CHECK(std::log10(ics2.lo) == Approx(-4 - 0.05 * decades).epsilon(1e-12));
  CHECK(std::log10(ics2.hi) == Approx(std::log10(0.3) + 0.05 * decades).epsilon(1e-12));
  CHECK(fit_axis({1e-4, 0.3}, "no log", false).scale == AxisScale::linear);
  CHECK(fit_axis({0.01, 0.9}, "1.95 decades", true).scale == AxisScale::linear);
  CHECK(fit_axis({0, 0.3, 1e-4}, "has a zero", true).scale == AxisScale::linear);
  // Linear: 5 % of the span each side.
  const auto lin = fit_axis({2, 12}, "x", true);
  CHECK(lin.lo == 1.5);
  CHECK(lin.hi == 12.5);
}

TEST_CASE("report: SvgPlot maps data to pixels exactly and breaks lines at gaps", "[report]") {
  // Plot area: x 70 … 584 (514 px), y 42 … 234 (192 px) with the default margins.
  const SvgPlot::Layout layout;
  REQUIRE(layout.width - layout.left - layout.right == 514);
  REQUIRE(layout.height - layout.top - layout.bottom == 192);
  SvgPlot plot("a <b> plot", Axis{0, 257, AxisScale::linear, "input revolutions"}, Axis{-1, 1, AxisScale::linear, "m/s²"});
  CHECK(plot.x_to_px(0) == 70);
  CHECK(plot.x_to_px(257) == 584);
  CHECK(plot.x_to_px(128.5) == 327);
  CHECK(plot.x_to_px(50) == 170);
  CHECK(plot.y_to_px(-1) == 234);
  CHECK(plot.y_to_px(1) == 42);
  CHECK(plot.y_to_px(0) == 138);
  CHECK(plot.y_to_px(0.5) == 90);

  const SvgPlot log_plot("log", Axis{0, 257, AxisScale::linear, "x"}, Axis{1e-3, 1e3, AxisScale::log, "y"});
  CHECK(log_plot.y_to_px(1) == Approx(138).epsilon(1e-12));
  CHECK(log_plot.y_to_px(1e3) == Approx(42).epsilon(1e-12));
  CHECK(log_plot.y_to_px(10) == Approx(42 + 192 * (1 - 4.0 / 6)).epsilon(1e-12));

  const double gap = std::numeric_limits<double>::quiet_NaN();
  plot.add_series({"rms_sa", "RMS_SA", "#123456", {{0, 0, "p0"}, {128.5, 0.5, "p1"}, {150, gap, ""}, {200, -1, "p3"}, {257, 1, "<p4>"}}});
  plot.add_event({128.5, "raised-warning", "#ef6c00", "raised & more"});
  const std::string svg = plot.render("plot-test");
  CHECK(count_of(svg, "<polyline") == 2);
  CHECK(svg.find("points=\"70.00,138.00 327.00,90.00\"") != std::string::npos);
  // 200 -> 70 + 200/257 × 514 = 470
  CHECK(svg.find("points=\"470.00,234.00 584.00,42.00\"") != std::string::npos);
  CHECK(count_of(svg, "<circle class=\"pt\"") == 4);
  CHECK(svg.find("<line class=\"ev raised-warning\" x1=\"327.00\" y1=\"42.00\" x2=\"327.00\" y2=\"234.00\"") != std::string::npos);
  CHECK(svg.find("<title>raised &amp; more</title>") != std::string::npos);
  CHECK(svg.find("<title>&lt;p4&gt;</title>") != std::string::npos);
  CHECK(svg.find("a &lt;b&gt; plot") != std::string::npos);
  // x ticks 0, 50, … 250 (step 50 for 257 / 4 = 64); the tick at 50 sits at 170 px.
  CHECK(svg.find("<text class=\"tick\" x=\"170.00\" y=\"249.00\" text-anchor=\"middle\">50</text>") != std::string::npos);
  CHECK(count_of(element(svg, "<g class=\"x-axis\">", "</g>"), "<text class=\"tick\"") == 6);
  // y ticks -1 … 1 by 0.5 (2 / 4); 0.5 sits at 90 px (+4 to centre the text on the line).
  CHECK(svg.find("y=\"94.00\" text-anchor=\"end\">0.5</text>") != std::string::npos);
  CHECK(count_of(element(svg, "<g class=\"y-axis\">", "</g>"), "<text class=\"tick\"") == 5);
}

TEST_CASE("report: HTML escaping", "[report]") {
  CHECK(html_escape("<a href=\"x\">Tom & 'Jerry'</a>") == "&lt;a href=&quot;x&quot;&gt;Tom &amp; &#39;Jerry&#39;&lt;/a&gt;");
  CHECK(html_escape("plain µm – text") == "plain µm – text");
  CHECK(html_escape("&amp;") == "&amp;amp;");
}

TEST_CASE("report: end to end on replayed captures (plots, points, gaps, alerts, inspections, no external URL)", "[report][cli]") {
  const gearwatch::testing::TempDir dir("report");
  // Records of 1 s, 20 rev/s: captures of 3.3 s make three analysed records and a 0.3 s tail that
  // is too short to analyse (a gap in every line). Torque 30 instead of 20 scales the simulated
  // vibration by 1.5: with a baseline of the first 3 records, rms_raw and rms_sa thresholds are
  // raised in B (second record), cleared in C (third record below) and raised again in D.
  std::ofstream(dir / "c.toml") << "[records]\nlength_s = 1.0\ninterval_s = 1.0\nmin_length_s = 0.5\n"
                                    "[alerts]\nbaseline_records = 3\nwatched_indicators = [\"rms_raw\", \"rms_sa\"]\n";
  struct Capture {
    const char* name;
    const char* args;
  };
  const Capture captures[] = {{"a", "--duration 3.3 --torque 20 --start-revs 0"},
                              {"b", "--duration 3.3 --torque 30 --start-revs 70"},
                              {"c", "--duration 3 --torque 20 --start-revs 140"},
                              {"d", "--duration 2 --torque 30 --start-revs 200"}};
  const fs::path db = dir / "plant.db";
  for (const auto& c : captures) {
    const std::string cap = (dir / (std::string(c.name) + ".log")).string();
    REQUIRE(run_command(gearwatch_cli("simulate --out " + cap + " --speed 20 " + c.args)).status == 0);
    const auto r = run_command(gearwatch_cli("replay " + cap + " --db " + db.string() + " --config " + (dir / "c.toml").string()));
    INFO(r.err);
    REQUIRE(r.status == 0);
  }
  REQUIRE(run_command(gearwatch_cli("inspect --db " + db.string() + " --cycles 100 --pitted-area 0.02 --note '<b>tooth & 3</b>'")).status == 0);

  // What the database holds, independently of the report.
  const auto analysed = count_rows(db, "SELECT count(*) FROM records WHERE analysed = 1");
  const auto total = count_rows(db, "SELECT count(*) FROM records");
  REQUIRE(analysed == 11);
  REQUIRE(total == 13);
  const auto alerts = count_rows(db, "SELECT count(*) FROM alerts");
  const auto raised_ch0 = count_rows(db, "SELECT count(*) FROM alerts WHERE channel = 0 AND transition = 'raised'");
  const auto cleared_ch0 = count_rows(db, "SELECT count(*) FROM alerts WHERE channel = 0 AND transition = 'cleared'");
  REQUIRE(alerts == 12);  // 2 indicators x 2 channels x (raised, cleared, raised)
  REQUIRE(raised_ch0 == 4);
  REQUIRE(cleared_ch0 == 2);
  REQUIRE(count_rows(db, "SELECT count(*) FROM active_alerts") == 4);

  const fs::path out = dir / "report";
  const auto r = run_command(gearwatch_cli("report --db " + db.string() + " --out " + out.string()));
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(r.err.empty());
  const std::string page = read_file(out / "index.html");
  CHECK_FALSE(fs::exists(out / "index.html.tmp"));

  // One SVG per plot family and channel: ICS2, RMS_SA, rms_raw, kurtosis_raw, mean carrier.
  CHECK(count_of(page, "<svg class=\"plot\"") == 10);
  for (const int channel : {0, 1}) {
    for (const std::string family : {"ics2", "rms_sa", "rms_raw", "kurtosis_raw", "mean_carrier"}) {
      const std::string id = "plot-" + family + "-ch" + std::to_string(channel);
      INFO(id);
      const std::string svg = element(page, "<svg class=\"plot\" id=\"" + id + "\"", "</svg>");
      REQUIRE_FALSE(svg.empty());
      // Every series: a point per analysed record that has the value, lines broken at the two
      // 0.3 s records (3 runs: records 1–3, 5–7, 9–13).
      std::size_t series = 0;
      for (std::size_t pos = svg.find("<g class=\"series\" data-name=\""); pos != std::string::npos;
           pos = svg.find("<g class=\"series\" data-name=\"", pos + 1)) {
        const auto name_start = pos + std::string("<g class=\"series\" data-name=\"").size();
        const std::string name = svg.substr(name_start, svg.find('"', name_start) - name_start);
        const std::string group = svg.substr(pos, svg.find("</g>", pos) - pos);
        const auto expected = count_rows(db, "SELECT count(*) FROM indicators WHERE channel = " + std::to_string(channel) + " AND name = '" +
                                                 name + "' AND value IS NOT NULL");
        INFO(name);
        CHECK(expected == analysed);
        CHECK(static_cast<std::int64_t>(count_of(group, "<circle class=\"pt\"")) == expected);
        CHECK(count_of(group, "<polyline") == 3);
        ++series;
      }
      const std::size_t expected_series = family == "ics2" ? 3 : family == "mean_carrier" ? 2 : 1;
      CHECK(series == expected_series);
      if (channel == 0) {
        CHECK(static_cast<std::int64_t>(count_of(svg, "class=\"ev raised-warning\"")) == raised_ch0);
        CHECK(static_cast<std::int64_t>(count_of(svg, "class=\"ev cleared\"")) == cleared_ch0);
        CHECK(count_of(svg, "class=\"ev inspection\"") == 1);
      }
    }
  }
  CHECK(element(page, "id=\"plot-ics2-ch0\"", "</svg>").find("(log scale)") != std::string::npos);
  // x tooltips carry the record time.
  const std::string first_created = [&] {
    gearwatch::storage::Database conn(db.string(), gearwatch::storage::Database::Mode::read_only);
    gearwatch::storage::Statement s(conn, "SELECT created_at FROM records WHERE id = 1");
    REQUIRE(s.step());
    return s.get_text(0);
  }();
  CHECK(page.find("<title>record 1 · " + first_created + " · 0 input revolutions · rms_sa = ") != std::string::npos);

  // Header, tables.
  CHECK(page.find("220 input revolutions</strong> now (record 13") != std::string::npos);
  CHECK(static_cast<std::int64_t>(count_of(page, "<tr class=\"alert-row")) == alerts);
  CHECK(count_of(page, "<tr class=\"alert-row sev-warning trans-raised\">") == 8);
  CHECK(count_of(page, "<tr class=\"alert-row sev-info trans-cleared\">") == 4);
  CHECK(count_of(page, "<li class=\"sev-warning\">") == 4);
  CHECK(count_of(page, "<tr class=\"health-row\">") == 4);  // one per replay
  CHECK(count_of(page, "class=\"badge verdict-none\"") == 2);
  CHECK(page.find("&lt;b&gt;tooth &amp; 3&lt;/b&gt;") != std::string::npos);
  CHECK(page.find("<b>tooth") == std::string::npos);
  // Schema v4 has the model's views: their sections are there (rows or "no rows yet").
  CHECK(page.find("k_updates: not available in this database.") == std::string::npos);
  CHECK(page.find("predictions: not available in this database.") == std::string::npos);

  // Self-contained: no scheme, no external reference of any kind, no script.
  CHECK(page.find("://") == std::string::npos);
  CHECK(page.find("<script") == std::string::npos);
  CHECK(page.find("<link") == std::string::npos);
  CHECK(page.find("@import") == std::string::npos);
  CHECK(page.find("url(") == std::string::npos);
  CHECK(page.find("href=") == std::string::npos);
  for (std::size_t pos = page.find("src="); pos != std::string::npos; pos = page.find("src=", pos + 1))
    CHECK(page.compare(pos, 10, "src=\"data:") == 0);

  // A model table is listed generically as stored, escaped (the view replaced by a table of
  // known content).
  {
    gearwatch::storage::Database rw(db.string(), gearwatch::storage::Database::Mode::read_write);
    rw.exec("DROP VIEW k_updates; CREATE TABLE k_updates (id INTEGER PRIMARY KEY, cycles REAL, k_scale REAL, note TEXT);"
            "INSERT INTO k_updates (cycles, k_scale, note) VALUES (100, 0.97, 'first'), (200, 0.93, '<i>second</i>');");
  }
  REQUIRE(run_command(gearwatch_cli("report --db " + db.string() + " --out " + out.string())).status == 0);
  const std::string with_model = read_file(out / "index.html");
  CHECK(with_model.find("k_updates: not available") == std::string::npos);
  const std::string table = element(with_model, "<table class=\"model\">", "</table>");
  CHECK(table.find("<th>id</th><th>cycles</th><th>k_scale</th><th>note</th>") != std::string::npos);
  CHECK(count_of(table, "<tr>") == 3);  // header + 2 rows
  // Newest first; reals as %.6g.
  CHECK(table.find("<tr><td>2</td><td>200</td><td>0.93</td><td>&lt;i&gt;second&lt;/i&gt;</td></tr>") <
        table.find("<tr><td>1</td><td>100</td><td>0.97</td><td>first</td></tr>"));
  CHECK(with_model.find("predictions: not available in this database.") == std::string::npos);
}

TEST_CASE("report: bad input gets a one-line error and a non-zero exit, a database without records a page that says so", "[report][cli]") {
  const gearwatch::testing::TempDir dir("report-bad");
  auto one_line = [](const std::string& err) { return !err.empty() && err.back() == '\n' && count_of(err, "\n") == 1; };

  const auto missing = run_command(gearwatch_cli("report --db " + (dir / "none.db").string() + " --out " + (dir / "o1").string()));
  CHECK(missing.status == 1);
  CHECK(missing.err == "gearwatch: no database at " + (dir / "none.db").string() + " (only `run` and `replay` create one)\n");
  CHECK_FALSE(fs::exists(dir / "o1"));

  std::ofstream(dir / "text.db") << "not a database\n";
  const auto garbage = run_command(gearwatch_cli("report --db " + (dir / "text.db").string() + " --out " + (dir / "o2").string()));
  CHECK(garbage.status == 1);
  CHECK(one_line(garbage.err));
  CHECK(garbage.err.find("file is not a database") != std::string::npos);

  // A gearwatch database before its first record: a page that says so.
  {
    gearwatch::storage::Database fresh((dir / "fresh.db").string());
    gearwatch::storage::open_and_migrate(fresh);
  }
  {
    const fs::path out = dir / "fresh.db-out";
    const auto r = run_command(gearwatch_cli("report --db " + (dir / "fresh.db").string() + " --out " + out.string()));
    CHECK(r.status == 0);
    const std::string page = read_file(out / "index.html");
    CHECK(page.find("<p class=\"notice\" id=\"no-records\">This database has no records") != std::string::npos);
    CHECK(count_of(page, "<svg") == 0);
    CHECK(page.find("k_updates: no rows yet.") != std::string::npos);  // the model's views exist, empty
  }
  // A zero-byte file holds no history: refused, nothing written (issue 33, item 5).
  std::ofstream(dir / "zero.db").close();
  const auto zero = run_command(gearwatch_cli("report --db " + (dir / "zero.db").string() + " --out " + (dir / "zero-out").string()));
  CHECK(zero.status == 1);
  CHECK(one_line(zero.err));
  CHECK_FALSE(fs::exists(dir / "zero-out"));
  CHECK(fs::file_size(dir / "zero.db") == 0);  // read-only: not even initialised

  // A database of someone else's: refused.
  {
    gearwatch::storage::Database other((dir / "other.db").string());
    other.exec("CREATE TABLE t (x)");
  }
  const auto foreign = run_command(gearwatch_cli("report --db " + (dir / "other.db").string() + " --out " + (dir / "o3").string()));
  CHECK(foreign.status == 1);
  CHECK(foreign.err == "gearwatch: " + (dir / "other.db").string() +
                           " is not a gearwatch database (application_id 0, user_version 0, 1 tables, views, indexes and triggers); "
                           "left untouched\n");

  // An --out that cannot be a directory (below a regular file: fails for root too).
  std::ofstream(dir / "file").close();
  const auto unwritable = run_command(gearwatch_cli("report --db " + (dir / "fresh.db").string() + " --out " + (dir / "file" / "sub").string()));
  CHECK(unwritable.status == 1);
  CHECK(one_line(unwritable.err));
  CHECK(unwritable.err.rfind("gearwatch: cannot create output directory " + (dir / "file" / "sub").string() + ": ", 0) == 0);
  const auto onto_file = run_command(gearwatch_cli("report --db " + (dir / "fresh.db").string() + " --out " + (dir / "file").string()));
  CHECK(onto_file.status == 1);
  CHECK(one_line(onto_file.err));
  CHECK(onto_file.err.rfind("gearwatch: cannot create output directory " + (dir / "file").string() + ": ", 0) == 0);
}

TEST_CASE("report: record ids as runs of consecutive ids", "[report]") {
  CHECK(record_ranges({}).empty());
  CHECK(record_ranges({7}) == "7");
  CHECK(record_ranges({1, 2, 3, 5, 9, 10}) == "1\u20133, 5, 9\u201310");
  CHECK(record_ranges({4, 6, 8}) == "4, 6, 8");
}

TEST_CASE("report: skips of one reason in the same records make one row, caveats after skips", "[report]") {
  using gearwatch::dsp::IndicatorNote;
  using gearwatch::dsp::SkipReason;
  ReportData d;
  // Channel 0: two indicators above Nyquist in records 1–3, a third only in record 2 (its own
  // row), no tacho in record 5 with two different details; channel 1: a trimmed band.
  for (const std::int64_t r : {1, 2, 3}) {
    d.skips.push_back({r, 0, "ics2_high_band", SkipReason::band_above_nyquist, "20000-37000 Hz"});
    d.skips.push_back({r, 0, "mean_carrier_hz_0_50000", SkipReason::band_above_nyquist, ""});
  }
  d.skips.push_back({2, 0, "rms_sa", SkipReason::band_above_nyquist, ""});
  d.skips.push_back({5, 0, "rms_sa", SkipReason::no_tacho, "first"});
  d.skips.push_back({5, 0, "ics2_low_band", SkipReason::no_tacho, "second"});
  d.caveats.push_back({1, 1, "ics2_low_band", IndicatorNote::band_trimmed, "2000-11520 Hz"});
  d.caveats.push_back({3, 1, "ics2_low_band", IndicatorNote::band_trimmed, "2000-11520 Hz"});
  d.skips.push_back({3, 1, "rms_sa", SkipReason::flat_line, ""});

  const auto g = reason_groups(d);
  REQUIRE(g.size() == 5);
  // Channel 0, enum order: no_tacho (5) before band_above_nyquist (11); within a reason by first record.
  CHECK(g[0].channel == 0);
  CHECK(std::get<SkipReason>(g[0].reason) == SkipReason::no_tacho);
  CHECK(g[0].indicators == std::vector<std::string>{"ics2_low_band", "rms_sa"});
  CHECK(g[0].records == std::vector<std::int64_t>{5});
  CHECK(g[0].details == std::vector<std::string>{"second", "first"});  // by indicator name, then record
  CHECK(std::string(to_string(g[1].reason)) == "band_above_nyquist");
  CHECK(g[1].indicators == std::vector<std::string>{"ics2_high_band", "mean_carrier_hz_0_50000"});
  CHECK(g[1].records == std::vector<std::int64_t>{1, 2, 3});
  CHECK(g[1].details == std::vector<std::string>{"20000-37000 Hz"});
  CHECK(g[2].indicators == std::vector<std::string>{"rms_sa"});
  CHECK(g[2].records == std::vector<std::int64_t>{2});
  // Channel 1: the skip, then the caveat.
  CHECK(std::get<SkipReason>(g[3].reason) == SkipReason::flat_line);
  CHECK(std::get<IndicatorNote>(g[4].reason) == IndicatorNote::band_trimmed);
  CHECK(g[4].records == std::vector<std::int64_t>{1, 3});
  CHECK(g[4].details == std::vector<std::string>{"2000-11520 Hz"});

  // Beyond kMaxReasonDetails distinct details, the rest are counted.
  ReportData many;
  for (std::int64_t r = 1; r <= 5; ++r) many.skips.push_back({r, 0, "rms_sa", SkipReason::analysis_error, "error " + std::to_string(r)});
  const auto m = reason_groups(many);
  REQUIRE(m.size() == 1);
  CHECK(m[0].details.size() == kMaxReasonDetails);
  CHECK(m[0].more_details == 5 - kMaxReasonDetails);

  // Labels: the configured name when a run named the channel.
  d.channel_names.push_back({0, "casing_y", {"acc0"}});
  CHECK(channel_label(d, 0) == "casing_y (channel 0)");
  CHECK(channel_label(d, 1) == "channel 1");
}

TEST_CASE("report: configured channel names, skip reasons with their records and the verdict's unseen band (25.6 kHz capture)", "[report][cli]") {
  const gearwatch::testing::TempDir dir("report-why");
  // At fs = 25.6 kHz the carrier bands reach 0.45 fs = 11 520 Hz: the abrasion band (20–37 kHz)
  // lies wholly above it (skipped, band_above_nyquist, and the verdict cannot see abrasion), the
  // pitting band (2–13 kHz) keeps 9 520 of its 11 000 Hz (trimmed, band_trimmed), and both
  // mean-carrier ranges (0–30 kHz, 0–50 kHz) end above the record's Nyquist, 12.8 kHz (skipped).
  // 1 s records of a 3.3 s capture: records 1–3 analysed, record 4 (0.3 s) ends the stream short.
  std::ofstream(dir / "c.toml") << "[records]\nlength_s = 1.0\ninterval_s = 1.0\nmin_length_s = 0.5\n"
                                    "[[channels]]\nnumber = 0\nname = \"pinion_end_y\"\nscale = 0.01\n"
                                    "[[channels]]\nnumber = 1\nname = \"<motor & side>\"\nscale = 0.01\n";
  const fs::path db = dir / "plant.db", cap = dir / "slow.log";
  REQUIRE(run_command(gearwatch_cli("simulate --out " + cap.string() + " --sample-rate 25600 --speed 20 --torque 20 --duration 3.3 --start-revs 0"
                                    " --config " + (dir / "c.toml").string())).status == 0);
  const auto replay = run_command(gearwatch_cli("replay " + cap.string() + " --db " + db.string() + " --config " + (dir / "c.toml").string()));
  INFO(replay.err);
  REQUIRE(replay.status == 0);

  // What the database holds, read directly: the known answer above.
  REQUIRE(count_rows(db, "SELECT count(*) FROM records WHERE analysed = 1") == 3);
  REQUIRE(count_rows(db, "SELECT count(*) FROM records WHERE analysed = 0 AND id = 4 AND end_reason = 'stream_end'") == 1);
  for (const int channel : {0, 1}) {
    const std::string ch = " AND channel = " + std::to_string(channel);
    CHECK(count_rows(db, "SELECT count(*) FROM indicator_skips WHERE reason = 'band_above_nyquist'" + ch) == 3 * 3);
    CHECK(count_rows(db, "SELECT count(*) FROM indicator_skips WHERE reason <> 'band_above_nyquist'" + ch) == 0);
    CHECK(count_rows(db, "SELECT count(*) FROM indicator_notes WHERE note = 'band_trimmed' AND name = 'ics2_low_band'" + ch) == 3);
  }
  CHECK(count_rows(db, "SELECT count(*) FROM run_channels WHERE channel = 0 AND name = 'pinion_end_y'") == 1);

  const fs::path out = dir / "report";
  const auto r = run_command(gearwatch_cli("report --db " + db.string() + " --out " + out.string()));
  INFO(r.err);
  REQUIRE(r.status == 0);
  const std::string page = read_file(out / "index.html");

  // The configured names, escaped, wherever a channel is named; never a bare "Channel 0".
  CHECK(page.find("<h3>pinion_end_y (channel 0)</h3>") != std::string::npos);
  CHECK(page.find("<h3>&lt;motor &amp; side&gt; (channel 1)</h3>") != std::string::npos);
  CHECK(page.find("<motor") == std::string::npos);
  CHECK(page.find("Channel 0") == std::string::npos);
  CHECK(page.find("RMS_SA (mesh harmonics) — pinion_end_y (channel 0)") != std::string::npos);

  // Per channel: one row for the three indicators above Nyquist in records 1–3, one for the
  // trimmed pitting band, with their exact counts, records and details.
  for (const std::string label : {"pinion_end_y (channel 0)", "&lt;motor &amp; side&gt; (channel 1)"}) {
    INFO(label);
    const auto at = page.find("\">" + label + "</h3>\n<div class=\"scroll\"><table class=\"why\">");
    REQUIRE(at != std::string::npos);
    const std::string table = element(page.substr(at), "<table class=\"why\">", "</table>");
    CHECK(count_of(table, "<tr class=\"skip-row\"") == 1);
    CHECK(count_of(table, "<tr class=\"caveat-row\"") == 1);
    CHECK(table.find("<tr class=\"skip-row\" data-reason=\"band_above_nyquist\"><td><code>band_above_nyquist</code></td>"
                     "<td class=\"names\">ics2_high_band, mean_carrier_hz_0_30000, mean_carrier_hz_0_50000</td>"
                     "<td class=\"num\">3</td><td>1\u20133</td><td class=\"detail\">20000-37000 Hz: 0 % of it below 11520 Hz</td></tr>") !=
          std::string::npos);
    CHECK(table.find("<tr class=\"caveat-row\" data-reason=\"band_trimmed\"><td><code>band_trimmed</code> <span class=\"muted\">(computed)</span></td>"
                     "<td class=\"names\">ics2_low_band</td><td class=\"num\">3</td><td>1\u20133</td>"
                     "<td class=\"detail\">2000-11520 Hz analysed of 2000-13000 Hz</td></tr>") != std::string::npos);
  }
  // The record not analysed, by how it ended.
  CHECK(page.find("<tr class=\"unanalysed-row\"><td><code>stream_end</code> (shorter than records.min_length_s)</td>"
                  "<td class=\"num\">1</td><td>4</td></tr>") != std::string::npos);
  CHECK(page.find("Shaft angle of the analysed records from: <code>tacho</code> 3.") != std::string::npos);
  // The verdict says what it cannot see, per channel.
  for (const int channel : {0, 1}) {
    const std::string note = element(page, "<p class=\"cannot-see\" id=\"cannot-see-ch" + std::to_string(channel) + "\">", "</p>");
    INFO(note);
    CHECK(note.find("cannot see the abrasion band</strong> (<code>unseen_band = abrasion</code>)") != std::string::npos);
    CHECK(note.find("<code>abrasive_wear</code> cannot be identified") != std::string::npos);
  }
}

TEST_CASE("report: the current gear pair follows the gear-pair rule (a recorded reset and a count going back)", "[report][gear_pair]") {
  gearwatch::testing::TempDir dir("report-gear-pair");
  gearwatch::storage::Database db((dir / "pairs.db").string());
  gearwatch::storage::open_and_migrate(db);
  db.exec("INSERT INTO runs(id, kind, source) VALUES (1, 'replay', 'test.log')");
  db.exec("INSERT INTO streams(id, run_id, sequence, stream_id, sample_rate_hz, channel_count) VALUES (1, 1, 1, 7, 25600, 1)");
  auto add_record = [&](int id, double revolutions) {
    db.exec("INSERT INTO records(id, stream_key, start_index, sample_count, duration_s, end_reason, analysed, input_revolutions, created_at)"
            " VALUES (" + std::to_string(id) + ", 1, " + std::to_string(id * 1000) + ", 1000, 1.0, 'complete', 1, " +
            std::to_string(revolutions) + ", '2026-01-0" + std::to_string(id) + "T00:00:00Z')");
  };
  for (int id = 1; id <= 3; ++id) add_record(id, 100.0 * id);
  ReportData one = load_report_data(db, "pairs.db", "now");
  CHECK(one.gear_pair_number == 1);
  CHECK(one.records.size() == 3);
  // A reset inside record 2 with the counts still rising: record 3 begins pair 2.
  db.exec("INSERT INTO life_counter_events(stream_key, sample_index, previous_revolutions, revolutions) VALUES (1, 2500, 250, 0)");
  ReportData reset = load_report_data(db, "pairs.db", "now");
  CHECK(reset.gear_pair_number == 2);
  REQUIRE(reset.records.size() == 1);
  CHECK(reset.records.front().id == 3);
  CHECK(reset.gear_pair_started_at == std::string("2026-01-03T00:00:00Z"));
  // Record 4's count below record 3's with no reset recorded: pair 3, its only record.
  add_record(4, 50.0);
  ReportData back = load_report_data(db, "pairs.db", "now");
  CHECK(back.gear_pair_number == 3);
  REQUIRE(back.records.size() == 1);
  CHECK(back.records.front().id == 4);
  CHECK(back.total_records == 4);
}

}  // namespace test_report
