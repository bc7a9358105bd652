// Data neither lost nor stored twice (docs/storage.md, "One writer per database" and "Resuming"):
// the model's work survives kill -9, two processes never write one database, and a capture is
// recognised by what it is rather than by the spelling of its path. Each drives the real binary.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <thread>
#include <vector>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "command_runner.hpp"
#include "gearwatch/storage/database_lock.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "temp_dir.hpp"

namespace test_integrity {  // this file's own: the test files compile together (unity build)

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using gearwatch::storage::Database;
using gearwatch::storage::Statement;
using gearwatch::testing::run_command;
using gearwatch::testing::spawn;
using gearwatch::testing::wait_exit;

namespace {

std::string gw(const std::string& args) { return std::string(GEARWATCH_BINARY) + " " + args; }


// A count read the way staff read; 0 while the database is not there or not migrated yet.
std::int64_t count(const fs::path& db, const std::string& table) {
  std::error_code ec;
  if (!fs::exists(db, ec)) return 0;
  try {
    Database rd(db.string(), Database::Mode::read_only, 1000);
    Statement s(rd, "SELECT count(*) FROM " + table);
    return s.step() ? s.get_int(0) : 0;
  } catch (const std::exception&) {
    return 0;
  }
}

std::string text(const fs::path& db, const std::string& sql) {
  Database rd(db.string(), Database::Mode::read_only);
  Statement s(rd, sql);
  REQUIRE(s.step());
  return s.is_null(0) ? std::string("NULL") : s.get_text(0);
}

// Every row of `sql`, doubles to the last bit, leaving out the columns in `ignored` (row ids and
// timestamps, which differ between two databases holding the same history).
std::string dump(const fs::path& db, const std::string& sql, const std::set<std::string>& ignored) {
  Database rd(db.string(), Database::Mode::read_only);
  Statement s(rd, sql);
  std::ostringstream out;
  out.precision(17);
  while (s.step()) {
    for (int i = 0; i < s.column_count(); ++i) {
      if (ignored.count(s.column_name(i))) continue;
      out << s.column_name(i) << "=";
      if (s.is_null(i)) out << "NULL";
      else if (s.column_type(i) == gearwatch::storage::ColumnType::real) out << s.get_double(i);
      else out << s.get_text(i);
      out << "|";
    }
    out << "\n";
  }
  return out.str();
}

// 40 kHz, so the model's pitting band is analysed; 1 s records, a record every second.
fs::path model_config(const fs::path& dir, const std::string& model_table) {
  const auto path = dir / "model.toml";
  std::ofstream(path) << "[rig]\nsample_rate_hz = 40000\n[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n"
                         "[records]\nlength_s = 1.0\ninterval_s = 1.0\nmin_length_s = 0.5\n"
                         "[model]\ncommissioning_records = 0\n"   // absolute: K_wear updates to resume
                      << model_table;
  return path;
}

void simulate(const fs::path& out, const std::string& args) {
  const auto r = run_command(gw("simulate --out " + out.string() + " " + args));
  INFO(r.err);
  REQUIRE(r.status == 0);
}

// What the model made of the history, row by row, with each row's record named by its start index.
struct ModelHistory {
  std::string runs, issues, state, updates, predictions;
};
ModelHistory model_history(const fs::path& db) {
  const std::set<std::string> ids{"id", "run_id", "created_at", "updated_at", "record_id"};
  return {dump(db, "SELECT r.start_index AS record_start, m.* FROM model_runs m LEFT JOIN records r ON r.id = m.record_id ORDER BY m.id", ids),
          dump(db, "SELECT r.start_index AS record_start, i.issue FROM model_run_issues i JOIN model_runs m ON m.id = i.run_id"
                   " LEFT JOIN records r ON r.id = m.record_id ORDER BY m.id, i.issue", ids),
          dump(db, "SELECT r.start_index AS record_start, s.* FROM model_state s LEFT JOIN records r ON r.id = s.record_id ORDER BY s.gear_pair", ids),
          dump(db, "SELECT * FROM k_update_log ORDER BY id", ids),
          dump(db, "SELECT * FROM predictions ORDER BY run_id", ids)};
}

}  // namespace

TEST_CASE("defects #1: kill -9 while the model lags the committed records, then resume: the model's history equals the uninterrupted one",
          "[integrity][model][faults]") {
  const gearwatch::testing::TempDir dir("defect1");
  const auto cap = dir / "cap.log", cfg = model_config(dir.path(), "forecast_horizon_cycles = 100000.0\n");
  // Six records of one second at 20 Hz, 16 N m, the life counter starting at 0. The claim is the
  // equality of the two histories, whatever their length: six records hold K_wear's calibration
  // and its later root-found updates (each a dozen twin runs), and leave room for a kill after the
  // second record and before the last. (Each record costs the model seconds of twin runs, twice.)
  constexpr int kRecords = 6;
  simulate(cap, "--duration 6.0 --speed 20 --torque 16 --sample-rate 40000 --channels 1 --seed 7 --start-revs 0");
  const auto whole = dir / "whole.db";
  const auto r = run_command(gw("replay " + cap.string() + " --db " + whole.string() + " --config " + cfg.string()));
  INFO(r.err);
  REQUIRE(r.status == 0);
  REQUIRE(count(whole, "records WHERE analysed = 1") == kRecords);
  REQUIRE(count(whole, "model_runs") == kRecords);
  REQUIRE(count(whole, "model_runs WHERE advanced = 1") == kRecords);
  REQUIRE(count(whole, "k_update_log") >= 1);  // the model learnt something worth comparing

  // The model thread runs at the lowest priority behind the writer: kill the replay at a moment
  // when records are committed that the model has not handled yet. Kill timing depends on the
  // scheduler, so a kill that found the model caught up is tried again on a fresh database.
  fs::path crashed;
  std::int64_t records_at_kill = 0, runs_at_kill = 0;
  for (int attempt = 0; attempt < 8 && !(runs_at_kill < records_at_kill && records_at_kill < kRecords); ++attempt) {
    crashed = dir / ("crashed" + std::to_string(attempt) + ".db");
    const pid_t pid = spawn({"replay", cap.string(), "--db", crashed.string(), "--config", cfg.string()}, dir / "out.txt",
                            dir / "err.txt");
    REQUIRE(pid > 0);
    for (int i = 0; i < 40000; ++i) {
      const auto records = count(crashed, "records"), runs = count(crashed, "model_runs");
      if (records >= 2 && runs < records) break;
      if (records >= kRecords) break;
      std::this_thread::sleep_for(200us);
    }
    ::kill(pid, SIGKILL);
    CHECK(wait_exit(pid) == 128 + SIGKILL);
    records_at_kill = count(crashed, "records");
    runs_at_kill = count(crashed, "model_runs");
  }
  INFO("at the kill: " << records_at_kill << " records, " << runs_at_kill << " model runs");
  REQUIRE(records_at_kill < kRecords);
  REQUIRE(runs_at_kill < records_at_kill);  // the model did lag: these records were committed without its work

  // Resume: the committed records are not stored again, and the model catches up on them first.
  const auto resumed = run_command(gw("replay " + cap.string() + " --db " + crashed.string() + " --config " + cfg.string() +
                                      " --format json"));
  INFO(resumed.err);
  REQUIRE(resumed.status == 0);
  const auto summary = nlohmann::json::parse(resumed.out);
  CHECK(summary["records_already_stored"] == records_at_kill);
  CHECK(count(crashed, "records") == kRecords);
  CHECK(count(crashed, "model_runs") == kRecords);
  CHECK(count(crashed, "(SELECT DISTINCT record_id FROM model_runs WHERE record_id IS NOT NULL)") == kRecords);

  const ModelHistory a = model_history(whole), b = model_history(crashed);
  CHECK(b.runs == a.runs);
  CHECK(b.issues == a.issues);
  CHECK(b.state == a.state);
  CHECK(b.updates == a.updates);
  CHECK(b.predictions == a.predictions);
  CHECK(text(crashed, "SELECT state FROM model_state") == text(whole, "SELECT state FROM model_state"));
}

TEST_CASE("defects #1: with the model disabled, kill -9 and resume store every record once and no model run",
          "[integrity][faults]") {
  const gearwatch::testing::TempDir dir("defect1-off");
  const auto cap = dir / "cap.log", cfg = model_config(dir.path(), "enabled = false\n");
  simulate(cap, "--duration 12.0 --speed 20 --torque 16 --sample-rate 40000 --channels 1 --seed 7 --start-revs 0");
  const auto db = dir / "off.db";
  const pid_t pid = spawn({"replay", cap.string(), "--db", db.string(), "--config", cfg.string()}, dir / "out.txt", dir / "err.txt");
  for (int i = 0; i < 40000 && count(db, "records") < 2; ++i) std::this_thread::sleep_for(200us);
  ::kill(pid, SIGKILL);
  wait_exit(pid);
  const auto at_kill = count(db, "records");
  REQUIRE(at_kill >= 2);
  const auto again = run_command(gw("replay " + cap.string() + " --db " + db.string() + " --config " + cfg.string() + " --format json"));
  INFO(again.err);
  REQUIRE(again.status == 0);
  CHECK(nlohmann::json::parse(again.out)["records_already_stored"] == at_kill);
  CHECK(count(db, "records") == 12);
  CHECK(count(db, "(SELECT DISTINCT start_index FROM records)") == 12);
  CHECK(count(db, "model_runs") == 0);
}

TEST_CASE("defects #2: a second writer on one database is refused with the holder's pid and inspect never creates a held database",
          "[integrity][cli]") {
  const gearwatch::testing::TempDir dir("defect2");
  const auto cap = dir / "cap.log", cfg = dir / "plant.toml";
  std::ofstream(cfg) << "[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n"
                        "[records]\nlength_s = 10.0\ninterval_s = 10.0\n[model]\nenabled = false\n";
  simulate(cap, "--duration 1200 --sample-rate 5000 --channels 1 --seed 11");  // 120 records
  const auto db = dir / "c.db";
  const std::vector<std::string> replay{"replay", cap.string(), "--db", db.string(), "--config", cfg.string()};
  const pid_t first = spawn(replay, dir / "out1.txt", dir / "err1.txt");
  REQUIRE(first > 0);
  for (int i = 0; i < 40000 && count(db, "records") < 1; ++i) std::this_thread::sleep_for(200us);
  REQUIRE(count(db, "records") >= 1);
  REQUIRE(count(db, "records") < 120);  // the first one is mid-way: it holds the database

  // The second writer, in run and replay alike, is refused at once with one line naming the first.
  const std::string holder = "pid " + std::to_string(first) + ")";
  const auto second = run_command(gw("replay " + cap.string() + " --db " + db.string() + " --config " + cfg.string()));
  CHECK(second.status != 0);
  CHECK(second.err.rfind("gearwatch: database " + db.string() + " is in use by another gearwatch (" + holder, 0) == 0);
  CHECK(std::count(second.err.begin(), second.err.end(), '\n') == 1);
  // (Bounded: were it not refused, `run` would wait for its CAN interface.)
  const auto live = run_command("timeout 20 " + gw("run --config " + cfg.string() + " --db " + db.string()));
  CHECK(live.status != 0);
  // The daemon logs its start first (at info level); the refusal is its one `gearwatch:` line.
  const auto refusal = live.err.find("\ngearwatch: database " + db.string() + " is in use by another gearwatch (" + holder);
  CHECK(refusal != std::string::npos);
  CHECK(live.err.find('\n', refusal + 1) == live.err.size() - 1);
  // Staff may still enter an inspection into the database the daemon writes (one row, no records).
  const auto inspection = run_command(gw("inspect --db " + db.string() + " --cycles 0 --wear-depth 1e-6"));
  INFO(inspection.err);
  CHECK(inspection.status == 0);

  REQUIRE(wait_exit(first) == 0);
  CHECK(count(db, "records") == 120);
  CHECK(count(db, "(SELECT DISTINCT start_index FROM records)") == 120);
  CHECK(count(db, "runs") == 1);
  CHECK(count(db, "inspections") == 1);

  // The lock is the process's: once it has ended (kill -9 included) the next writer gets it.
  auto lock = gearwatch::storage::DatabaseLock::acquire(db.string());
  // inspect never creates a database (item 5 of the same issue), held or not.
  const auto fresh = dir / "fresh.db";
  auto held = gearwatch::storage::DatabaseLock::acquire(fresh.string());
  const auto missing = run_command(gw("inspect --db " + fresh.string() + " --cycles 0 --wear-depth 1e-6"));
  CHECK(missing.status != 0);
  CHECK(std::count(missing.err.begin(), missing.err.end(), '\n') == 1);
  CHECK_FALSE(fs::exists(fresh));
  // Nor does it migrate a database another process holds: a copy of this history set back to
  // schema version 5 is refused with the holder's pid and left at version 5.
  const auto older = dir / "older.db";
  fs::copy_file(db, older);
  {
    Database w(older.string(), Database::Mode::read_write);
    w.set_user_version(5);
  }
  auto held_older = gearwatch::storage::DatabaseLock::acquire(older.string());
  const auto refused = run_command(gw("inspect --db " + older.string() + " --cycles 0 --wear-depth 1e-6"));
  CHECK(refused.status != 0);
  CHECK(refused.err.find("pid " + std::to_string(::getpid()) + ")") != std::string::npos);
  CHECK(std::count(refused.err.begin(), refused.err.end(), '\n') == 1);
  {
    Database rd(older.string(), Database::Mode::read_only);
    CHECK(rd.user_version() == 5);
  }
  CHECK(count(older, "inspections") == 1);
}

TEST_CASE("defects #3: the same capture by another relative path or a symlink is not stored again but new content at the path is",
          "[integrity][cli]") {
  const gearwatch::testing::TempDir dir("defect3");
  const auto cfg = dir / "plant.toml";
  std::ofstream(cfg) << "[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n"
                        "[records]\nlength_s = 10.0\ninterval_s = 10.0\n[model]\nenabled = false\n";
  simulate(dir / "cap.log", "--duration 60 --sample-rate 5000 --channels 1 --seed 3");  // 6 records
  fs::create_directories(dir / "sub");
  fs::create_symlink(dir / "cap.log", dir / "sub" / "link.log");
  auto replay = [&](const std::string& where, const std::string& capture, const std::string& database) {
    const auto r = run_command("cd " + where + " && " + gw("replay " + capture + " --db " + database + " --config " + cfg.string() +
                                                           " --format json"));
    INFO(r.err);
    REQUIRE(r.status == 0);
    return nlohmann::json::parse(r.out);
  };
  const auto first = replay(dir.path().string(), "cap.log", "d.db");
  CHECK(first["records"] == 6);
  const auto db = dir / "d.db";
  const auto relative = replay((dir / "sub").string(), "../cap.log", "../d.db");
  CHECK(relative["records"] == 0);
  CHECK(relative["records_already_stored"] == 6);
  const auto linked = replay((dir / "sub").string(), "link.log", "../d.db");
  CHECK(linked["records"] == 0);
  CHECK(linked["records_already_stored"] == 6);
  CHECK(count(db, "records") == 6);
  // Every run shows the capture by its canonical absolute path, however it was given.
  const std::string canonical = fs::canonical(dir / "cap.log").string();
  CHECK(count(db, "runs") == 3);
  CHECK(count(db, "runs WHERE source = '" + canonical + "'") == 3);
  CHECK(count(db, "(SELECT DISTINCT capture_id FROM runs)") == 1);

  // A different recording written later to the same path is a different capture: stored.
  simulate(dir / "cap.log", "--duration 60 --sample-rate 5000 --channels 1 --seed 4");
  const auto other = replay(dir.path().string(), "cap.log", "d.db");
  CHECK(other["records"] == 6);
  CHECK(other["records_already_stored"] == 0);
  CHECK(count(db, "records") == 12);
  CHECK(count(db, "(SELECT DISTINCT capture_id FROM runs)") == 2);

  // A run stored before runs had a capture_id (schema 5) is matched by its stored path.
  const auto old_db = dir / "old.db";
  CHECK(replay(dir.path().string(), "cap.log", "old.db")["records"] == 6);
  {
    Database w(old_db.string(), Database::Mode::read_write);
    w.exec("UPDATE runs SET capture_id = NULL");
  }
  const auto by_path = replay((dir / "sub").string(), "link.log", "../old.db");
  CHECK(by_path["records"] == 0);
  CHECK(by_path["records_already_stored"] == 6);
}

}  // namespace test_integrity
