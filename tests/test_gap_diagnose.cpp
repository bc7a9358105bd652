// `gearwatch gap diagnose` and what the periodic gap step keeps in the database (docs/gap.md,
// "Persistence"; docs/cli.md): the schedule keeps exactly the records a coming diagnosis uses and a
// schedule restored from the database continues as one that never stopped (against a reference that
// holds every record); kept records read back exactly; the command on captures from the independent
// generator (tests/capture_gen) prints, stores and pages the report and refuses bad input; and six
// records replayed one per process give the same stored report as the same six in one replay.
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "command_runner.hpp"
#include "gap_monitor.hpp"
#include "gearwatch/storage/gap_kept_records.hpp"
#include "gearwatch/storage/gap_reports.hpp"
#include "gearwatch/storage/schema.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "temp_dir.hpp"

namespace test_gap_diagnose {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// The schedule as it was before it kept only what a coming diagnosis uses: every record held, the
// newest training + held-out of them split at each due record.
struct ReferenceSchedule {
  std::size_t every, training, held_out, since = 0;
  std::deque<std::uint64_t> held;
  bool add(std::uint64_t position) {
    held.push_back(position);
    while (held.size() > training + held_out) held.pop_front();
    if (++since < every || held.size() < training + held_out) return false;
    since = 0;
    return true;
  }
};

// What the database holds of a schedule: its counters and kept rows, changed as the writer does.
struct StoredRows {
  std::uint64_t added = 0, since = 0;
  std::map<std::uint64_t, daemon::GapSample> rows;
  void apply(const daemon::GapSchedule& s, const daemon::GapSchedule::Step& step, const daemon::GapSample& sample) {
    added = s.records_added();
    since = s.since_diagnosis();
    rows.erase(rows.begin(), rows.upper_bound(step.drop_through_position));
    if (step.keep) rows[step.position] = sample;
  }
  daemon::GapSchedule restored(std::size_t every, std::size_t training, std::size_t held_out) const {
    daemon::GapSchedule s(every, training, held_out);
    std::vector<daemon::GapSample> kept;
    for (const auto& [position, sample] : rows) kept.push_back(sample);
    s.restore(added, since, kept);
    return s;
  }
};

std::vector<std::uint64_t> positions(const std::vector<const daemon::GapSample*>& list) {
  std::vector<std::uint64_t> out;
  for (const auto* s : list) out.push_back(s->position);
  return out;
}

daemon::GapSample sample_at(std::uint64_t i) {
  daemon::GapSample s;
  s.start_index = i;
  s.position = i;  // what add() sets: the restored rows carry it
  return s;
}

}  // namespace

TEST_CASE("gap schedule: it keeps exactly what a coming diagnosis uses, and restored from the database it continues unchanged",
          "[gap_diagnose][gap_schedule]") {
  for (std::size_t every = 1; every <= 8; ++every)
    for (std::size_t training = 1; training <= 3; ++training)
      for (std::size_t held_out = 1; held_out <= 3; ++held_out) {
        INFO("every " << every << ", training " << training << ", held out " << held_out);
        ReferenceSchedule reference{every, training, held_out, 0, {}};
        daemon::GapSchedule schedule(every, training, held_out);
        StoredRows db;
        for (std::uint64_t i = 1; i <= 30; ++i) {
          // A process that stops after record i - 1 and starts again from the database.
          daemon::GapSchedule restarted = db.restored(every, training, held_out);
          const bool due = reference.add(i);
          const auto step = schedule.add(sample_at(i));
          const auto restarted_step = restarted.add(sample_at(i));
          REQUIRE(step.due == due);
          REQUIRE(restarted_step.due == due);
          CHECK(restarted_step.keep == step.keep);
          CHECK(restarted_step.drop_through_position == step.drop_through_position);
          if (due) {
            const std::vector<std::uint64_t> window(reference.held.begin(), reference.held.end());
            const std::vector<std::uint64_t> want_training(window.begin(), window.end() - static_cast<std::ptrdiff_t>(held_out));
            const std::vector<std::uint64_t> want_held(window.end() - static_cast<std::ptrdiff_t>(held_out), window.end());
            for (const auto* s : {&schedule, &restarted}) {
              const auto [t, h] = s->split();
              CHECK(positions(t) == want_training);
              CHECK(positions(h) == want_held);
            }
          }
          db.apply(schedule, step, sample_at(i));
          // Never more rows than one diagnosis uses; none right after a diagnosis when the next one is
          // at least a window of records away.
          CHECK(db.rows.size() <= training + held_out);
          if (every >= training + held_out && due) CHECK(db.rows.empty());
        }
      }
}

TEST_CASE("storage: a kept gap record and its wear state read back exactly, and rows no coming diagnosis uses are deleted",
          "[gap_diagnose][storage]") {
  const testing::TempDir dir("gap-kept");
  storage::Database db((dir / "k.db").string());
  storage::open_and_migrate(db);
  CHECK(storage::has_gap_schedule_tables(db));
  CHECK(db.user_version() == storage::current_schema_version());
  storage::KeptGapRecord k;
  k.position = 3;
  k.stream_sequence = 2;
  Record& r = k.record;
  r.stream_id = 7;
  r.start_index = 4294967296ull + 5;
  r.sample_rate_hz = 24000;
  r.speed_hz = 11.0000001;
  r.torque_nm = std::numeric_limits<double>::quiet_NaN();
  r.input_revolutions = 123456.789;
  r.channel_numbers = {1};
  // Every float exactly: a denormal, the smallest step above 1, negative zero, the largest finite.
  r.channels = {{1.0f, std::nextafter(1.0f, 2.0f), -0.0f, 1e-42f, -3.4028235e38f, 0.1f}};
  r.tacho_edges[0] = {0.31415926535897931, 2181.8181818181815, 1.0 / 3.0};
  r.tacho_edges[2] = {5.5};
  k.state.cycles = 1e6 + 0.1;
  k.state.pinion_depth_m = {1e-6 / 3.0, 2.5e-7};
  k.state.gear_depth_m = {7e-8};
  k.state.pinion_pitting = {0.0, 0.01 / 7.0};
  storage::GapScheduleUpdate u;
  u.gear_pair = 1;
  u.counters = {3, 3};
  u.keep = k;
  {
    storage::Transaction tx(db);
    storage::write_gap_schedule_update(db, u, std::nullopt, std::nullopt);
    tx.commit();
  }
  auto stored = storage::load_gap_schedule(db, 1);
  REQUIRE(stored.found);
  CHECK(stored.counters.records_added == 3);
  CHECK(stored.counters.since_diagnosis == 3);
  REQUIRE(stored.kept.size() == 1);
  const auto& b = stored.kept[0];
  CHECK(b.position == 3);
  CHECK(b.stream_sequence == 2);
  CHECK(b.record.stream_id == 7);
  CHECK(b.record.start_index == r.start_index);
  CHECK(b.record.sample_rate_hz == 24000);
  CHECK(b.record.speed_hz == r.speed_hz);
  CHECK(std::isnan(b.record.torque_nm));
  CHECK(b.record.input_revolutions == r.input_revolutions);
  CHECK(b.record.channel_numbers == r.channel_numbers);
  REQUIRE(b.record.channels.size() == 1);
  REQUIRE(b.record.channels[0].size() == r.channels[0].size());
  for (std::size_t i = 0; i < r.channels[0].size(); ++i) {
    CHECK(b.record.channels[0][i] == r.channels[0][i]);
    CHECK(std::signbit(b.record.channels[0][i]) == std::signbit(r.channels[0][i]));
  }
  CHECK(b.record.tacho_edges == r.tacho_edges);
  CHECK(b.state.cycles == k.state.cycles);
  CHECK(b.state.pinion_depth_m == k.state.pinion_depth_m);
  CHECK(b.state.gear_depth_m == k.state.gear_depth_m);
  CHECK(b.state.pinion_pitting == k.state.pinion_pitting);
  // The next record: position 4 kept, everything at or before 3 dropped.
  u.counters = {4, 4};
  u.keep->position = 4;
  u.drop_through_position = 3;
  {
    storage::Transaction tx(db);
    storage::write_gap_schedule_update(db, u, std::nullopt, std::nullopt);
    tx.commit();
  }
  stored = storage::load_gap_schedule(db, 1);
  REQUIRE(stored.kept.size() == 1);
  CHECK(stored.kept[0].position == 4);
  // A new gear pair: the old pair's rows and counters go, whatever their positions.
  u.gear_pair = 2;
  u.counters = {1, 1};
  u.keep.reset();
  u.drop_through_position = 0;
  {
    storage::Transaction tx(db);
    storage::write_gap_schedule_update(db, u, std::nullopt, std::nullopt);
    tx.commit();
  }
  CHECK_FALSE(storage::load_gap_schedule(db, 1).found);
  storage::Statement rows(db, "SELECT count(*) FROM gap_kept_records");
  REQUIRE(rows.step());
  CHECK(rows.get_int(0) == 0);
}

namespace {

const std::string kGenerator = std::string(GEARWATCH_SOURCE_DIR) + "/tests/capture_gen/rig_capture.py";

std::string sh(const fs::path& p) { return "'" + p.native() + "'"; }

// 0.5 s at 24 kHz (400 FD frames of 30 samples: one record, nothing left over), 20 N m, mesh
// harmonics and white noise: content the twin does not have, so the families differ from it. The
// speeds (18-30 Hz) give each record the two output revolutions a diagnosis needs in half a second.
const char* const kConfig =
    "[rig]\nsample_rate_hz = 24000\n"
    "[records]\nlength_s = 0.5\ninterval_s = 0.5\nmin_length_s = 0.5\n"
    "[gap]\nenabled = true\nevery_records = 6\ntraining_records = 4\nheld_out_records = 2\n"
    // The bootstrap's floor (20) and the spectral forms only (no twin re-runs) keep the test short.
    "bootstrap_resamples = 20\nrerun_twin = false\n"
    // The model's proportional K_wear update (one twin run a record) in place of the root find (a
    // dozen): K_wear and the wear states still change record by record, which is what the stored
    // reports must carry alike; the root find's own restart is held by the model-thread tests.
    "[model]\nk_wear_update = \"proportional\"\n";

fs::path generate(const testing::TempDir& dir, int i, double speed_hz, const std::string& extra = "") {
  const fs::path log = dir / ("c" + std::to_string(i) + ".log");
  const std::string cmd = std::string(GEARWATCH_PYTHON) + " " + sh(kGenerator) + " --out " + sh(log) +
                          " --duration 0.5 --sample-rate 24000 --speed " + std::to_string(speed_hz) +
                          " --torque 20 --gmf-harmonics 5,2.5 --white-noise 0.3 --stream-id " + std::to_string(i) +
                          " --start-revs " + std::to_string(1000 * i) + " --start-time " + std::to_string(1700000000 + 10 * i) +
                          " --seed " + std::to_string(i) + (extra.empty() ? " --channels 0" : " " + extra);
  const auto r = testing::run_command(cmd);
  INFO(r.err);
  REQUIRE(r.status == 0);
  return log;
}

// Six captures at six speeds (18–30 Hz), one record each.
std::vector<fs::path> six_captures(const testing::TempDir& dir) {
  std::vector<fs::path> out;
  int i = 0;
  for (double speed : {18.0, 22.0, 26.0, 30.0, 20.0, 28.0}) out.push_back(generate(dir, ++i, speed));
  return out;
}

fs::path write_config(const testing::TempDir& dir) {
  const fs::path p = dir / "gap.toml";
  std::ofstream(p) << kConfig;
  return p;
}

testing::CommandResult gw(const std::string& args) { return testing::run_command(std::string(GEARWATCH_BINARY) + " " + args); }

std::string joined(const std::vector<fs::path>& captures) {
  std::string out;
  for (const auto& c : captures) out += sh(c) + " ";
  return out;
}

std::int64_t scalar(const fs::path& db, const std::string& sql) {
  storage::Database d(db.string(), storage::Database::Mode::read_only);
  storage::Statement s(d, sql);
  REQUIRE(s.step());
  return s.get_int(0);
}

}  // namespace

TEST_CASE("gap diagnose through the binary: the report printed, stored with --db and read back by gap report, the page written",
          "[gap_diagnose][cli]") {
  const testing::TempDir dir("gap-diagnose");
  const auto captures = six_captures(dir);
  const fs::path config = write_config(dir);
  // An existing history: one capture replayed (the model's state is then stored).
  const fs::path db = dir / "h.db";
  REQUIRE(gw("replay " + sh(captures[0]) + " --db " + sh(db) + " --config " + sh(config)).status == 0);
  const auto r = gw("gap diagnose " + joined(captures) + "--config " + sh(config) + " --db " + sh(db) + " --out " +
                           sh(dir / "page") + " --format json");
  INFO(r.err);
  REQUIRE(r.status == 0);
  const json printed = json::parse(r.out);
  // The records and the split: the newest two held out, as the periodic step holds them out.
  REQUIRE(printed["records"].size() == 6);
  const std::vector<double> speeds{18, 22, 26, 30, 20, 28};
  for (std::size_t i = 0; i < 6; ++i) {
    CHECK(printed["records"][i]["speed_hz"].get<double>() == speeds[i]);
    CHECK(printed["records"][i]["torque_nm"].get<double>() == 20.0);
    CHECK(printed["records"][i]["sample_rate_hz"].get<double>() == 24000.0);
    CHECK(printed["records"][i]["set"] == (i < 4 ? "training" : "held_out"));
  }
  CHECK(printed["wear_state"].get<std::string>().find("the model's newest stored state") != std::string::npos);
  const json& report = printed["report"];
  CHECK(report["training_records"] == 4);
  CHECK(report["held_out_records"] == 2);
  CHECK(report["speeds_hz"].get<std::vector<double>>() == std::vector<double>{18, 20, 22, 26, 28, 30});
  CHECK(report["input_revolutions"].get<double>() == Approx(6000).margin(20));  // the newest record's life position
  CHECK(report["before"].size() == 7);
  CHECK(report["id"] == 1);
  // The mesh harmonics carry 5 and 2.5 m/s² where the twin has its own: far beyond any interval.
  for (const auto& f : report["before"])
    if (f["family"] == "mesh_harmonics") CHECK(f["significant"] == true);
  // Stored: `gap report` prints the same report, every field (doubles written with round-trip
  // precision, so equal means equal).
  const auto back = gw("gap report --db " + sh(db) + " --format json");
  REQUIRE(back.status == 0);
  CHECK(json::parse(back.out) == report);
  CHECK(scalar(db, "SELECT count(*) FROM gap_report_runs") == 1);
  // The page: the same page as `gap report --out`.
  const auto page = gw("gap report --db " + sh(db) + " --out " + sh(dir / "page2"));
  REQUIRE(page.status == 0);
  std::ifstream a(dir / "page" / "index.html"), b(dir / "page2" / "index.html");
  const std::string html_a{std::istreambuf_iterator<char>(a), {}}, html_b{std::istreambuf_iterator<char>(b), {}};
  REQUIRE_FALSE(html_a.empty());
  CHECK(html_a.find("<svg") != std::string::npos);
  // Both pages hold the same report; only the time each was generated differs.
  CHECK(html_a.size() == html_b.size());

  SECTION("the table holds the JSON's figures") {
    const auto table = gw("gap report --db " + sh(db) + " --format table");
    REQUIRE(table.status == 0);
    for (const auto& f : report["before"]) {
      char cell[64];
      std::snprintf(cell, sizeof cell, "%.2f [%.2f, %.2f]", f["distance_db"].get<double>(), f["interval_db"][0].get<double>(),
                    f["interval_db"][1].get<double>());
      CHECK(table.out.find(f["family"].get<std::string>() + std::string(21 - f["family"].get<std::string>().size(), ' ') + cell) !=
            std::string::npos);
    }
  }
}

TEST_CASE("gap diagnose refuses bad input with one line and stores nothing", "[gap_diagnose][cli]") {
  const testing::TempDir dir("gap-diagnose-bad");
  const fs::path config = write_config(dir);
  const fs::path good = generate(dir, 1, 20.0);
  const fs::path db = dir / "h.db";
  REQUIRE(gw("replay " + sh(good) + " --db " + sh(db) + " --config " + sh(config)).status == 0);
  auto refused = [&](const std::string& args, int status, const std::string& says, const fs::path& into) {
    const auto r = gw("gap diagnose " + args + " --config " + sh(config) + " --db " + sh(into));
    INFO(args << ": " << r.err);
    CHECK(r.status == status);
    CHECK(r.out.empty());
    CHECK(r.err.find(says) != std::string::npos);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  };
  // A missing capture is refused by the parser (64); the others by the command (1).
  refused(sh(good) + " " + sh(dir / "missing.log"), 64, "missing.log", db);
  refused(sh(good) + " /dev/zero", 1, "is a device", db);
  const fs::path short_capture = dir / "short.log";
  {
    const auto r = testing::run_command(std::string(GEARWATCH_PYTHON) + " " + sh(kGenerator) + " --out " + sh(short_capture) +
                                        " --duration 0.3 --sample-rate 24000 --channels 0");
    REQUIRE(r.status == 0);
  }
  refused(sh(good) + " " + sh(short_capture), 1, "no complete record", db);
  const fs::path two_channels = generate(dir, 2, 24.0, "--channels 0,1");
  refused(sh(good) + " " + sh(two_channels), 1, "mismatched channels", db);
  refused(sh(good), 1, "none is left for training", db);
  refused(sh(good) + " --held-out " + sh(good), 1, "no database at", dir / "none.db");
  CHECK(scalar(db, "SELECT count(*) FROM gap_report_runs") == 0);
  CHECK_FALSE(fs::exists(dir / "none.db"));
}

TEST_CASE("periodic gap step: six records replayed one per process give the same stored report as the same six in one replay",
          "[gap_diagnose][gap_monitor][pipeline]") {
  const testing::TempDir dir("gap-per-process");
  const auto captures = six_captures(dir);
  const fs::path config = write_config(dir);
  const fs::path one_file = dir / "all.log";
  {
    std::ofstream all(one_file, std::ios::binary);
    for (const auto& c : captures) all << std::ifstream(c, std::ios::binary).rdbuf();
  }
  const fs::path per_process = dir / "a.db", one_replay = dir / "b.db";
  for (std::size_t i = 0; i < captures.size(); ++i) {
    const auto r = gw("replay " + sh(captures[i]) + " --db " + sh(per_process) + " --config " + sh(config));
    INFO(r.err);
    REQUIRE(r.status == 0);
    if (i == 4) {
      // Five records: no report yet, all five kept for the report the sixth completes.
      CHECK(scalar(per_process, "SELECT count(*) FROM gap_report_runs") == 0);
      CHECK(scalar(per_process, "SELECT count(*) FROM gap_kept_records") == 5);
      CHECK(scalar(per_process, "SELECT since_diagnosis FROM gap_schedule") == 5);
    }
  }
  // Diagnosed: nothing is kept (the next report uses records 7–12).
  CHECK(scalar(per_process, "SELECT count(*) FROM gap_kept_records") == 0);
  CHECK(scalar(per_process, "SELECT records_added FROM gap_schedule") == 6);
  REQUIRE(gw("replay " + sh(one_file) + " --db " + sh(one_replay) + " --config " + sh(config)).status == 0);
  const auto a = gw("gap report --db " + sh(per_process) + " --format json");
  const auto b = gw("gap report --db " + sh(one_replay) + " --format json");
  REQUIRE(a.status == 0);
  REQUIRE(b.status == 0);
  json ja = json::parse(a.out), jb = json::parse(b.out);
  // The time each was stored differs; every other field, every double included, is identical: the
  // same records (floats exact), the same wear states (doubles exact) and the same seed.
  ja.erase("created_at");
  jb.erase("created_at");
  CHECK(ja == jb);
  CHECK(ja["training_records"] == 4);
  CHECK(ja["held_out_records"] == 2);
  CHECK(scalar(per_process, "SELECT count(*) FROM gap_report_runs") == 1);
  CHECK(scalar(one_replay, "SELECT count(*) FROM gap_report_runs") == 1);
}

}  // namespace test_gap_diagnose
