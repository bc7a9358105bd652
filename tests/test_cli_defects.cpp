// Issue 33: the command line as a new user and as an adversary meet it — refusals of files that
// are not gearwatch's history, malformed times, JSON on any bytes, one-line parse errors.
// Each test drives the real binary where the user meets the defect.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "command_runner.hpp"
#include "commands.hpp"
#include "gearwatch/storage/schema.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "temp_dir.hpp"
#include "utc_time.hpp"

namespace test_cli_defects {  // this file's own: the test files compile together (unity build)

namespace fs = std::filesystem;
using gearwatch::testing::CommandResult;
using gearwatch::testing::TempDir;

namespace {

CommandResult run(const std::string& args) { return gearwatch::testing::run_command(std::string(GEARWATCH_BINARY) + " " + args); }

std::string quoted(const fs::path& p) { return "'" + p.string() + "'"; }

std::string bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

bool one_error_line(const CommandResult& r) {
  return r.status != 0 && r.out.empty() && r.err.rfind("gearwatch: ", 0) == 0 && r.err.find('\n') == r.err.size() - 1;
}

std::int64_t integer(const fs::path& db, const std::string& sql) {
  gearwatch::storage::Database d(db.string(), gearwatch::storage::Database::Mode::read_only);
  gearwatch::storage::Statement s(d, sql);
  REQUIRE(s.step());
  return s.get_int(0);
}

std::string text(const fs::path& db, const std::string& sql) {
  gearwatch::storage::Database d(db.string(), gearwatch::storage::Database::Mode::read_only);
  gearwatch::storage::Statement s(d, sql);
  REQUIRE(s.step());
  return s.get_text(0);
}

// A 2.5 s synthetic capture: one stream_end record with indicators.
fs::path simulated_capture(const TempDir& dir) {
  const auto cap = dir / "cap.log";
  REQUIRE(run("simulate --out " + quoted(cap) + " --duration 2.5 --speed 12 --torque 15 --sample-rate 20000 --start-revs 120000").status == 0);
  return cap;
}

// The model thread has its own tests; these do not need it.
fs::path no_model_config(const TempDir& dir) {
  const auto path = dir / "no-model.toml";
  std::ofstream(path) << "[model]\nenabled = false\n";
  return path;
}

fs::path replayed_database(const TempDir& dir) {
  const auto db = dir / "a.db";
  const auto r = run("replay " + quoted(simulated_capture(dir)) + " --db " + quoted(db) + " --config " + quoted(no_model_config(dir)));
  INFO(r.err);
  REQUIRE(r.status == 0);
  return db;
}

// Every command that reads an existing history, up to its --db.
std::vector<std::string> reading_commands(const TempDir& dir) {
  return {"inspect --cycles 10 --wear-depth 1e-6 --db ", "query alerts --db ", "report --out " + quoted(dir / "page") + " --db ",
          "twin state --db ", "gap report --out " + quoted(dir / "gap") + " --db "};
}

}  // namespace

TEST_CASE("defects #4: another application's SQLite database is refused untouched by replay", "[cli][defects]") {
  const TempDir dir("d4-foreign");
  const auto cap = simulated_capture(dir);
  const auto db = dir / "o.db";
  {
    gearwatch::storage::Database d(db.string());
    d.exec("CREATE TABLE customers(id)");
    d.exec("INSERT INTO customers VALUES (7)");
  }
  const std::string before = bytes_of(db);
  const auto r = run("replay " + quoted(cap) + " --db " + quoted(db));
  CHECK(one_error_line(r));
  CHECK(r.err.find(db.string() + " is not a gearwatch database (application_id 0, user_version 0, 1 tables, views, indexes and "
                   "triggers); left untouched\n") != std::string::npos);
  CHECK(bytes_of(db) == before);  // byte for byte: no tables, no user_version, no WAL mode
  CHECK_FALSE(fs::exists(dir / "o.db-wal"));
  CHECK(integer(db, "SELECT count(*) FROM sqlite_master") == 1);

  // Another application that sets its own application_id, even with gearwatch-like tables.
  const auto other = dir / "other.db";
  {
    gearwatch::storage::Database d(other.string());
    d.exec("PRAGMA application_id = 1234");
    d.exec("CREATE TABLE runs(id); CREATE TABLE records(id)");
  }
  const std::string other_before = bytes_of(other);
  const auto r2 = run("replay " + quoted(cap) + " --db " + quoted(other));
  CHECK(one_error_line(r2));
  CHECK(r2.err.find("application_id 1234") != std::string::npos);
  CHECK(bytes_of(other) == other_before);
}

TEST_CASE("defects #4: a gearwatch database written before application_id is recognised, accepted and marked", "[cli][defects]") {
  const TempDir dir("d4-older");
  const auto db = replayed_database(dir);
  CHECK(integer(db, "PRAGMA application_id") == gearwatch::storage::kApplicationId);
  CHECK(integer(db, "PRAGMA application_id") == 0x47574348);  // "GWCH"
  {
    // What every database written before this release looks like: gearwatch's schema, id 0.
    gearwatch::storage::Database d(db.string());
    d.exec("PRAGMA application_id = 0");
    const auto identity = gearwatch::storage::identify_database(d);
    CHECK(identity.kind == gearwatch::storage::DatabaseKind::gearwatch_before_application_id);
    CHECK(identity.user_version == gearwatch::storage::current_schema_version());
  }
  CHECK(run("query records --db " + quoted(db) + " --format json").status == 0);  // readers accept it as it is
  CHECK(integer(db, "PRAGMA application_id") == 0);
  const auto r = run("replay " + quoted(dir / "cap.log") + " --db " + quoted(db) + " --config " + quoted(dir / "no-model.toml"));
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(integer(db, "PRAGMA application_id") == gearwatch::storage::kApplicationId);
  CHECK(integer(db, "SELECT count(*) FROM runs") == 2);  // its history continued, nothing lost
  CHECK(integer(db, "SELECT count(*) FROM records") == 1);  // the same capture again: no record stored twice
}

TEST_CASE("defects #4: identify_database tells empty, gearwatch and foreign files apart", "[storage][defects]") {
  using gearwatch::storage::DatabaseKind;
  const TempDir dir("d4-identify");
  auto kind_of = [&](const std::string& name, const std::string& sql) {
    gearwatch::storage::Database d((dir / name).string());
    if (!sql.empty()) d.exec(sql);
    return gearwatch::storage::identify_database(d).kind;
  };
  CHECK(kind_of("empty.db", "") == DatabaseKind::empty);
  CHECK(kind_of("versioned.db", "PRAGMA user_version = 3") == DatabaseKind::foreign);  // a version but none of our tables
  CHECK(kind_of("table.db", "CREATE TABLE runs(id)") == DatabaseKind::foreign);
  CHECK(kind_of("ours.db", "PRAGMA application_id = 1196901192") == DatabaseKind::gearwatch);
  {
    gearwatch::storage::Database d((dir / "newer.db").string());
    gearwatch::storage::open_and_migrate(d);
    d.exec("PRAGMA application_id = 0");
    d.set_user_version(gearwatch::storage::current_schema_version() + 1);  // not one this build knows
    CHECK(gearwatch::storage::identify_database(d).kind == DatabaseKind::foreign);
  }
}

TEST_CASE("defects #5: commands that read a history refuse a missing path and create nothing", "[cli][defects]") {
  const TempDir dir("d5-missing");
  const auto db = dir / "mistyped.db";
  const std::string expected = "gearwatch: no database at " + db.string() + " (only `run` and `replay` create one)\n";
  for (const std::string& command : reading_commands(dir)) {
    INFO(command);
    const auto r = run(command + quoted(db));
    CHECK(one_error_line(r));
    CHECK(r.err == expected);
    CHECK_FALSE(fs::exists(db));
  }
  CHECK_FALSE(fs::exists(dir / "page"));
  CHECK_FALSE(fs::exists(dir / "gap"));
}

TEST_CASE("defects #5: commands that read a history refuse an empty file or database, and change nothing", "[cli][defects]") {
  const TempDir dir("d5-empty");
  const auto zero = dir / "zero.db";
  std::ofstream(zero).close();
  const auto blank = dir / "blank.db";
  { gearwatch::storage::Database d(blank.string()); d.exec("CREATE TABLE t(x); DROP TABLE t"); }  // pages, no schema
  REQUIRE(fs::file_size(blank) > 0);
  for (const std::string& command : reading_commands(dir)) {
    INFO(command);
    const auto r0 = run(command + quoted(zero));
    CHECK(one_error_line(r0));
    CHECK(r0.err == "gearwatch: " + zero.string() + " is empty: no gearwatch history in it (only `run` and `replay` create one)\n");
    CHECK(fs::file_size(zero) == 0);
    const auto rb = run(command + quoted(blank));
    CHECK(one_error_line(rb));
    CHECK(rb.err == "gearwatch: " + blank.string() +
                        " is an empty database: no gearwatch history in it (only `run` and `replay` create one)\n");
    CHECK(integer(blank, "SELECT count(*) FROM sqlite_master") == 0);
  }
  CHECK_FALSE(fs::exists(dir / "page" / "index.html"));  // `report` on a 0-byte file wrote an empty page
}

TEST_CASE("defects #5: a reading command refuses another application's database too", "[cli][defects]") {
  const TempDir dir("d5-foreign");
  const auto db = dir / "o.db";
  { gearwatch::storage::Database d(db.string()); d.exec("CREATE TABLE customers(id)"); }
  const auto r = run("query alerts --db " + quoted(db));
  CHECK(one_error_line(r));
  CHECK(r.err.find(" is not a gearwatch database (") != std::string::npos);
}

TEST_CASE("defects #6: a directory given as --config is refused with the path and why", "[cli][defects]") {
  const TempDir dir("d6");
  const auto cap = simulated_capture(dir);
  const auto confdir = dir / "conf.d";
  fs::create_directories(confdir);
  const std::string expected = "gearwatch: " + confdir.string() + ": is a directory, not a configuration file\n";
  const auto replay = run("replay " + quoted(cap) + " --db " + quoted(dir / "a.db") + " --config " + quoted(confdir));
  CHECK(one_error_line(replay));
  CHECK(replay.err == expected);
  CHECK_FALSE(fs::exists(dir / "a.db"));
  const auto daemon = run("run --db " + quoted(dir / "b.db") + " --config " + quoted(confdir));
  CHECK(daemon.err == expected);
  CHECK_FALSE(fs::exists(dir / "b.db"));
}

TEST_CASE("defects #8: parse_utc_time gives the stored form and refuses impossible times", "[cli][defects]") {
  using gearwatch::cli::parse_utc_time;
  CHECK(parse_utc_time("2026-11-01", "--since") == "2026-11-01T00:00:00.000Z");
  CHECK(parse_utc_time("2026-11-01T08:05", "--since") == "2026-11-01T08:05:00.000Z");
  CHECK(parse_utc_time("2026-11-01 08:05:07", "--since") == "2026-11-01T08:05:07.000Z");
  CHECK(parse_utc_time("2026-11-01T08:05:07.25Z", "--since") == "2026-11-01T08:05:07.250Z");
  CHECK(parse_utc_time("2024-02-29", "--since") == "2024-02-29T00:00:00.000Z");  // a leap year
  for (const char* bad : {"2026-13-45", "yesterday", "2026-02-29", "2026-04-31", "2026-11-01T24:00", "2026-11-01T08:60",
                          "2026-11-01T08:00:00.1234", "2026-11-01+01:00", "26-11-01", ""}) {
    INFO(bad);
    CHECK_THROWS_AS(parse_utc_time(bad, "--since"), gearwatch::cli::CommandError);
  }
}

TEST_CASE("defects #8: query refuses a malformed --since/--until with the accepted forms instead of printing no rows", "[cli][defects]") {
  const TempDir dir("d8");
  const auto db = replayed_database(dir);
  for (const std::string bad : {"2026-13-45", "yesterday"}) {
    const auto r = run("query alerts --db " + quoted(db) + " --since " + bad);
    CHECK(one_error_line(r));
    CHECK(r.err == std::string("gearwatch: --since ") + bad + ": " + (bad == "yesterday" ? "not a time" : "no such date") +
                       "; accepted forms: " + gearwatch::cli::kAcceptedTimeForms + "\n");
  }
  CHECK(one_error_line(run("query records --db " + quoted(db) + " --until 2026-11-01T25:00")));
  // The accepted forms filter: the one record was stored after 2000 and before 2999.
  auto rows = [&](const std::string& filter) {
    const auto r = run("query records --db " + quoted(db) + " --format json " + filter);
    INFO(filter << "\n" << r.err);
    REQUIRE(r.status == 0);
    return nlohmann::json::parse(r.out).size();
  };
  CHECK(rows("--since 2000-01-01") == 1);
  CHECK(rows("--since '2999-01-01 00:00'") == 0);
  CHECK(rows("--until 2999-01-01T00:00:00Z") == 1);
  CHECK(rows("--until 2000-01-01T00:00:00.5") == 0);
}

TEST_CASE("defects #12: JSON output stays valid JSON on a file name that is not UTF-8, and replay's exit is true", "[cli][defects]") {
  const TempDir dir("d12-name");
  const auto cap = dir / "cap\xff\xfe.log";  // Latin-1 bytes in a file name
  fs::copy_file(simulated_capture(dir), cap);
  const auto db = dir / "a.db";
  const auto r = run("replay " + quoted(cap) + " --db " + quoted(db) + " --config " + quoted(no_model_config(dir)) + " --format json");
  INFO(r.err);
  CHECK(r.status == 0);
  const std::string replaced = (dir / "cap\xEF\xBF\xBD\xEF\xBF\xBD.log").string();  // each invalid byte -> U+FFFD
  const auto j = nlohmann::json::parse(r.out);
  CHECK(j["capture"] == replaced);
  CHECK(j["records"] == 1);
  CHECK(j["end_reason"] == "end of capture");  // as runs.end_reason stores it
  const auto health = run("query health --db " + quoted(db) + " --format json");
  CHECK(health.status == 0);
  const auto h = nlohmann::json::parse(health.out);
  REQUIRE(h.size() == 1);
  CHECK(h[0]["source"] == replaced);
  CHECK(text(db, "SELECT source FROM runs") == cap.string());  // the database keeps the bytes as they were
}

TEST_CASE("defects #12: query rejected: valid JSON on non-UTF-8 capture lines, control characters escaped in the table",
          "[cli][defects]") {
  const TempDir dir("d12-rejected");
  const auto cap = simulated_capture(dir);
  {
    std::ofstream out(cap, std::ios::app | std::ios::binary);
    out << "(1700000099.000000) can0 1F0#\x1b[31mred\xff\n";  // an escape sequence and an invalid byte
  }
  const auto db = dir / "a.db";
  const auto rep = run("replay " + quoted(cap) + " --db " + quoted(db) + " --config " + quoted(no_model_config(dir)));
  INFO(rep.err);
  REQUIRE(rep.status == 0);
  REQUIRE(integer(db, "SELECT count(*) FROM rejected_frames WHERE instr(frame, char(27)) > 0") == 1);
  const auto json = run("query rejected --db " + quoted(db) + " --format json");
  CHECK(json.status == 0);
  const auto j = nlohmann::json::parse(json.out);
  REQUIRE(j.size() == 1);
  const std::string frame = j[0]["frame"];
  CHECK(frame.find("\x1b[31mred\xEF\xBF\xBD") != std::string::npos);  // the ESC escaped by JSON itself, 0xFF -> U+FFFD
  const auto table = run("query rejected --db " + quoted(db));
  CHECK(table.status == 0);
  CHECK(table.out.find('\x1b') == std::string::npos);
  CHECK(table.out.find("\\x1b[31mred") != std::string::npos);
}

TEST_CASE("defects (smaller): parse errors are one line `gearwatch: <reason>` with exit 64 and --version exists", "[cli][defects]") {
  const TempDir dir("d-parse");
  const auto unknown_view = run("query customers --db x.db");
  CHECK(unknown_view.status == 64);
  CHECK(one_error_line(unknown_view));
  CHECK(unknown_view.err.find("customers") != std::string::npos);
  const auto missing = run("replay");
  CHECK(missing.status == 64);
  CHECK(one_error_line(missing));
  const auto stray = run("report --db a.db --out d --colour");
  CHECK(stray.status == 64);
  CHECK(one_error_line(stray));
  const auto limit = run("query alerts --db " + quoted(dir / "a.db") + " --limit 0");
  CHECK(one_error_line(limit));
  CHECK(limit.err == "gearwatch: --limit 0: give 1 or more rows\n");
  const auto version = run("--version");
  CHECK(version.status == 0);
  CHECK(version.out == std::string("gearwatch ") + GEARWATCH_VERSION + " (database schema version " +
                           std::to_string(gearwatch::storage::current_schema_version()) + ")\n");
}

TEST_CASE("defects (smaller): --format offers exactly what each command prints", "[cli][defects]") {
  const TempDir dir("d-format");
  const auto db = replayed_database(dir);
  const auto csv = run("replay " + quoted(dir / "cap.log") + " --db " + quoted(db) + " --format csv");
  CHECK(csv.status == 64);
  CHECK(one_error_line(csv));
  const auto help = run("twin state --help");
  CHECK(help.status == 0);
  CHECK(help.out.find("{table,json}") != std::string::npos);
  CHECK(help.out.find("csv") == std::string::npos);
  CHECK(run("twin state --db " + quoted(db) + " --format csv").status == 64);
}

TEST_CASE("defects (smaller): docs/cli.md names every subcommand and option the help offers for twin", "[cli][defects]") {
  const std::string doc = bytes_of(fs::path(GEARWATCH_SOURCE_DIR) / "docs" / "cli.md");
  CHECK(doc.find("`gearwatch twin wear --k-wear") != std::string::npos);
  // A command's entry: its list item, from "- `gearwatch …" to the next item, its wrapped lines
  // joined with single spaces as Markdown reads them.
  const auto entry_of = [&](const std::string& start) {
    const auto at = doc.find(start);
    REQUIRE(at != std::string::npos);
    const auto end = std::min(doc.find("\n- ", at), doc.find("\n\n", at));
    std::string entry;
    for (const char c : doc.substr(at, end - at)) {
      if (c == '\n' || (c == ' ' && !entry.empty() && entry.back() == ' ')) {
        if (entry.empty() || entry.back() != ' ') entry += ' ';
        continue;
      }
      entry += c;
    }
    return entry;
  };
  const std::string simulate = entry_of("- `gearwatch twin simulate");
  CHECK(simulate.find("--config FILE") != std::string::npos);
  CHECK(simulate.find("--sample-rate HZ") != std::string::npos);
  CHECK(entry_of("- `gearwatch twin state").find("csv") == std::string::npos);
  CHECK(entry_of("- `gearwatch replay").find("csv") == std::string::npos);
}

TEST_CASE("defects (smaller): a replay without --config warns nothing and records why its run ended", "[cli][defects]") {
  const TempDir dir("d-defaults");
  const auto cap = simulated_capture(dir);
  const auto db = dir / "a.db";
  const auto r = run("replay " + quoted(cap) + " --db " + quoted(db));
  CHECK(r.status == 0);
  // Was: "cannot read (built-in defaults) again to remember it; a reload will report every key as changed".
  CHECK(r.err.find("built-in defaults") == std::string::npos);
  CHECK(r.err.find("reload") == std::string::npos);
  CHECK(text(db, "SELECT end_reason FROM runs") == "end of capture");
}

TEST_CASE("defects (smaller): [acquisition] source = candump without capture is refused by run only", "[cli][defects]") {
  const TempDir dir("d-candump");
  const auto cap = simulated_capture(dir);
  const auto config = dir / "candump.toml";
  std::ofstream(config) << "[acquisition]\nsource = \"candump\"\n[model]\nenabled = false\n";
  const auto replay = run("replay " + quoted(cap) + " --db " + quoted(dir / "a.db") + " --config " + quoted(config));
  INFO(replay.err);
  CHECK(replay.status == 0);
  const auto daemon = run("run --db " + quoted(dir / "b.db") + " --config " + quoted(config));
  CHECK(one_error_line(daemon));
  CHECK(daemon.err == "gearwatch: " + config.string() +
                          ": [acquisition] source = \"candump\" needs capture = FILE for `run` (`gearwatch replay CAPTURE` takes it "
                          "on the command line)\n");
  CHECK_FALSE(fs::exists(dir / "b.db"));
}

TEST_CASE("defects (smaller): the replay summary says how many records had every indicator skipped, and why",
          "[cli][defects]") {
  // tests/capture_gen with no signal component: both channels are exactly zero, a flat line.
  const TempDir dir("d-skipped");
  const auto cap = dir / "flat.log";
  const auto gen = gearwatch::testing::run_command(std::string(GEARWATCH_PYTHON) + " " + GEARWATCH_SOURCE_DIR +
                                                   "/tests/capture_gen/rig_capture.py --out " + quoted(cap) + " --duration 2 --sample-rate 20000");
  INFO(gen.err);
  REQUIRE(gen.status == 0);
  const auto json = run("replay " + quoted(cap) + " --db " + quoted(dir / "a.db") + " --config " + quoted(no_model_config(dir)) +
                        " --format json");
  INFO(json.err);
  REQUIRE(json.status == 0);
  const auto j = nlohmann::json::parse(json.out);
  CHECK(j["records"] == 1);
  CHECK(j["records_without_indicators"]["records"] == 1);
  CHECK(j["records_without_indicators"]["skip_reasons"] == nlohmann::json{{"flat_line", 1}});
  const auto table = run("replay " + quoted(cap) + " --db " + quoted(dir / "b.db") + " --config " + quoted(dir / "no-model.toml"));
  REQUIRE(table.status == 0);
  CHECK(table.out.find("1 records (1 analysed, every indicator skipped in 1 of them (flat_line in 1))") != std::string::npos);
}

}  // namespace test_cli_defects
