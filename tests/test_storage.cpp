#include "gearwatch/storage/writer.hpp"

#include <sys/mount.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <fstream>
#include <thread>

#include <catch2/catch.hpp>

#include "gearwatch/dsp/speed_estimation.hpp"

#include "temp_dir.hpp"

#include "gearwatch/storage/schema.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/types/skip_reason.hpp"

namespace test_storage {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::storage;
namespace fs = std::filesystem;

namespace {


std::int64_t count(Database& db, const std::string& sql) {
  Statement s(db, sql);
  REQUIRE(s.step());
  return s.get_int(0);
}

RecordResult make_record(std::uint64_t start, int values) {
  RecordResult r;
  r.stream_sequence = 1;
  r.start_index = start;
  r.sample_count = 1000;
  r.duration_s = 1.0;
  r.end_reason = gearwatch::RecordEnd::complete;
  r.analysed = true;
  r.torque_nm = 20;
  r.speed_hz = 10;
  r.input_revolutions = static_cast<double>(start) / 100.0;
  ChannelResult ch;
  ch.channel = 0;
  for (int i = 0; i < values; ++i) ch.values.emplace_back(std::string("value_") += std::to_string(i), i * 0.5);
  ch.skipped.push_back({"ics2_high_band", "band_above_nyquist", ""});
  r.channels.push_back(ch);
  return r;
}

void submit_run(StorageWriter& w) {
  w.submit(RunStarted{"replay", "test", "", "", {}});
  w.submit(StreamStarted{1, 1, 100000, 2});
}

// A writer started on a new database a.db in a new temporary directory, with one run submitted;
// `adjust` changes the options first.
struct WriterWithRun {
  explicit WriterWithRun(const char* dir_name, const std::function<void(WriterOptions&)>& adjust = {})
      : dir(dir_name), path((dir / "a.db").string()), writer(options(path, adjust)) {
    writer.start();
    submit_run(writer);
  }
  static WriterOptions options(const std::string& database, const std::function<void(WriterOptions&)>& adjust) {
    WriterOptions o;
    o.database = database;
    if (adjust) adjust(o);
    return o;
  }
  const gearwatch::testing::TempDir dir;
  const std::string path;
  StorageWriter writer;
};

}  // namespace

TEST_CASE("storage: a new database is migrated to the current schema with its views", "[storage]") {
  const gearwatch::testing::TempDir dir("schema");
  const auto path = (dir / "a.db").string();
  {
    Database db(path);
    open_and_migrate(db);
    CHECK(db.user_version() == current_schema_version());
    for (const char* name : {"indicators", "alerts", "acquisition_health", "record_status"})  // docs/storage.md
      CHECK(count(db, std::string("SELECT count(*) FROM sqlite_master WHERE type = 'view' AND name = '") + name + "'") == 1);
    Statement mode(db, "PRAGMA journal_mode");
    REQUIRE(mode.step());
    CHECK(mode.get_text(0) == "wal");
  }
  {
    Database db(path);
    open_and_migrate(db);  // idempotent on an up-to-date file
    CHECK(db.user_version() == current_schema_version());
  }
  {
    Database db(path);
    db.set_user_version(current_schema_version() + 1);
    CHECK_THROWS_AS(open_and_migrate(db), SqliteError);  // never touch a newer schema
  }
}

TEST_CASE("storage: a transaction rolls back unless committed", "[storage]") {
  const gearwatch::testing::TempDir dir("tx");
  Database db((dir / "a.db").string());
  open_and_migrate(db);
  {
    Transaction tx(db);
    db.exec("INSERT INTO inspections(cycles, wear_depth_m) VALUES (1, 2e-6)");
  }
  CHECK(count(db, "SELECT count(*) FROM inspections") == 0);
  {
    Transaction tx(db);
    db.exec("INSERT INTO inspections(cycles, wear_depth_m) VALUES (1, 2e-6)");
    tx.commit();
  }
  CHECK(count(db, "SELECT count(*) FROM inspections") == 1);
}

TEST_CASE("storage: the writer commits everything submitted, in batches", "[storage]") {
  WriterWithRun run("writer", [](WriterOptions& o) { o.queue_capacity = 8; });  // small: exercises the waiting producer
  const auto& path = run.path;
  auto& w = run.writer;
  for (int i = 0; i < 300; ++i) w.submit(make_record(static_cast<std::uint64_t>(i) * 1000, 5));
  HealthSnapshot health;
  health.final = true;
  health[HealthCounter::frames] = 42;
  health[HealthCounter::samples] = 7;
  w.submit(health);
  w.stop();
  CHECK(w.counters().messages_committed == 303);
  CHECK(w.counters().lost_at_exit == 0);
  Database db(path, Database::Mode::read_only);
  CHECK(count(db, "SELECT count(*) FROM records") == 300);
  CHECK(count(db, "SELECT count(*) FROM indicators") == 1500);
  CHECK(count(db, "SELECT count(*) FROM indicator_skips") == 300);
  CHECK(count(db, "SELECT cycles * 100 FROM indicators WHERE record_id = 300 LIMIT 1") == 299000);
  CHECK(count(db, "SELECT frames FROM acquisition_health") == 42);
}

TEST_CASE("storage: each health counter is one column of health_snapshots and is stored there", "[storage]") {
  WriterWithRun run("health");
  const auto& path = run.path;
  auto& w = run.writer;
  HealthSnapshot health;  // counter i holds 1000 + i: a value no other counter has
  for (std::size_t i = 0; i < kAllHealthCounters.size(); ++i) health[kAllHealthCounters[i]] = 1000 + i;
  w.submit(health);
  w.stop();
  REQUIRE(w.counters().lost_at_exit == 0);
  Database db(path, Database::Mode::read_only);
  // The table's columns are id, run_id, taken_at, final and exactly the counters.
  CHECK(count(db, "SELECT count(*) FROM pragma_table_info('health_snapshots')") ==
        static_cast<std::int64_t>(kAllHealthCounters.size()) + 4);
  for (std::size_t i = 0; i < kAllHealthCounters.size(); ++i) {
    const std::string column = to_string(kAllHealthCounters[i]);
    INFO(column);
    CHECK(count(db, "SELECT count(*) FROM pragma_table_info('health_snapshots') WHERE name = '" + column + "'") == 1);
    CHECK(count(db, "SELECT " + column + " FROM health_snapshots") == static_cast<std::int64_t>(1000 + i));
  }
}

TEST_CASE("storage: a locked database delays the writer but loses nothing", "[storage]") {
  const gearwatch::testing::TempDir dir("locked");
  const auto path = (dir / "a.db").string();
  {
    Database db(path);
    open_and_migrate(db);
  }
  WriterOptions o;
  o.database = path;
  o.busy_timeout_ms = 50;
  o.retry_initial_ms = 20;
  StorageWriter w(o);
  w.start();
  Database locker(path);
  locker.exec("BEGIN EXCLUSIVE");
  submit_run(w);
  for (int i = 0; i < 20; ++i) w.submit(make_record(static_cast<std::uint64_t>(i), 3));
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  CHECK(w.counters().messages_committed == 0);
  CHECK(w.counters().retries >= 2);
  locker.exec("COMMIT");
  w.stop();
  CHECK(w.counters().messages_committed == 22);
  Database db(path, Database::Mode::read_only);
  CHECK(count(db, "SELECT count(*) FROM records") == 20);
}

TEST_CASE("storage: a full disk delays the writer but loses nothing", "[storage]") {
  // A real full filesystem: a 1 MiB tmpfs. Mounting needs root, which CI has.
  if (::geteuid() != 0) {
    if (std::getenv("CI")) FAIL("this test needs root to mount a tmpfs, and CI runs as root");
    WARN("not root: full-disk test not run");
    return;
  }
  const gearwatch::testing::TempDir dir("full");
  REQUIRE(::mount("tmpfs", dir.path().c_str(), "tmpfs", 0, "size=1m") == 0);
  struct Unmount {
    const fs::path& at;
    ~Unmount() { ::umount(at.c_str()); }  // before the TempDir goes, even when a check fails
  } unmount{dir.path()};
  const auto path = (dir / "a.db").string();
  const auto filler = dir / "filler";
  WriterOptions o;
  o.database = path;
  o.retry_initial_ms = 20;
  o.retry_max_ms = 100;
  {
    StorageWriter w(o);
    w.start();
    submit_run(w);
    w.submit(make_record(0, 3));
    // Fill what is left of the filesystem.
    {
      std::ofstream f(filler, std::ios::binary);
      std::string block(4096, 'x');
      while (f.write(block.data(), static_cast<std::streamsize>(block.size()))) f.flush();
    }
    for (int i = 1; i <= 200; ++i) w.submit(make_record(static_cast<std::uint64_t>(i), 40));
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (w.counters().retries == 0 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    CHECK(w.counters().retries > 0);  // SQLITE_FULL seen and retried
    fs::remove(filler);                // the operator frees space
    w.stop();
    CHECK(w.counters().lost_at_exit == 0);
  }
  {
    Database db(path, Database::Mode::read_only);
    CHECK(count(db, "SELECT count(*) FROM records") == 201);
    CHECK(count(db, "SELECT count(*) FROM indicator_values") == 3 + 200 * 40);
  }
}

TEST_CASE("storage: an unusable database path is an error at start", "[storage]") {
  WriterOptions o;
  o.database = "/nonexistent-dir/a.db";
  StorageWriter w(o);
  CHECK_THROWS_AS(w.start(), SqliteError);
}

TEST_CASE("storage: readers query while the writer commits (WAL)", "[storage]") {
  WriterWithRun run("readers", [](WriterOptions& o) { o.busy_timeout_ms = 50; });
  const auto& path = run.path;
  auto& w = run.writer;
  w.submit(make_record(0, 2));
  while (w.counters().messages_committed < 3) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  // A staff member's long query: a read transaction held open across the writer's commits.
  Database reader(path, Database::Mode::read_only);
  reader.exec("BEGIN");
  CHECK(count(reader, "SELECT count(*) FROM records") == 1);
  for (int i = 1; i <= 50; ++i) w.submit(make_record(static_cast<std::uint64_t>(i), 2));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (w.counters().messages_committed < 53 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  CHECK(w.counters().messages_committed == 53);  // the writer was not held up by the reader
  CHECK(w.counters().retries == 0);
  CHECK(count(reader, "SELECT count(*) FROM records") == 1);  // the reader's snapshot is stable
  reader.exec("COMMIT");
  CHECK(count(reader, "SELECT count(*) FROM records") == 51);  // and sees the new rows afterwards
  w.stop();
}

TEST_CASE("storage: a message that can never be written is dropped alone, not with its batch", "[storage]") {
  WriterWithRun run("poison");
  const auto& path = run.path;
  auto& w = run.writer;
  for (int i = 0; i < 40; ++i) {
    RecordResult r = make_record(static_cast<std::uint64_t>(i), 2);
    if (i == 17) r.stream_sequence = 99;  // a stream that was never started
    w.submit(std::move(r));
  }
  w.stop();
  CHECK(w.counters().lost_at_exit == 1);
  CHECK(w.counters().messages_committed == 41);
  Database db(path, Database::Mode::read_only);
  CHECK(count(db, "SELECT count(*) FROM records") == 39);
  CHECK(count(db, "SELECT count(*) FROM records WHERE start_index = 17") == 0);
}

namespace {

// The tokens of an `IN (...)` list that follows `column` in a table's CREATE statement.
std::vector<std::string> check_list(Database& db, const std::string& table, const std::string& column) {
  Statement s(db, "SELECT sql FROM sqlite_master WHERE type = 'table' AND name = ?");
  s.bind(1, table);
  REQUIRE(s.step());
  const std::string sql = s.get_text(0);
  const auto at = sql.find("CHECK (" + column + " IN (");
  REQUIRE(at != std::string::npos);
  const auto open = sql.find('(', sql.find(" IN ", at));
  const auto close = sql.find(')', open);
  std::vector<std::string> out;
  std::string list = sql.substr(open + 1, close - open - 1);
  for (std::size_t q = list.find('\''); q != std::string::npos; q = list.find('\'', list.find('\'', q + 1) + 1))
    out.push_back(list.substr(q + 1, list.find('\'', q + 1) - q - 1));
  return out;
}

std::vector<std::string> vocabulary(Database& db, const std::string& domain) {
  Statement s(db, "SELECT token FROM vocabulary WHERE domain = ? ORDER BY token");
  s.bind(1, domain);
  std::vector<std::string> out;
  while (s.step()) out.push_back(s.get_text(0));
  return out;
}

template <class All>
std::vector<std::string> sorted_tokens(const All& all) {
  std::vector<std::string> out;
  for (auto v : all) out.emplace_back(to_string(v));
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

TEST_CASE("storage: every enumerated value has one source of truth: the enum", "[storage][vocabulary]") {
  const gearwatch::testing::TempDir dir("vocabulary");
  Database db((dir / "a.db").string());
  open_and_migrate(db, {{"gap_cause", {"protocol", "ring_overflow"}}});
  // The vocabulary table is the enums' to_string over their kAll lists...
  CHECK(vocabulary(db, "wear_mechanism") == sorted_tokens(gearwatch::dsp::kAllWearMechanisms));
  CHECK(vocabulary(db, "record_end_reason") == sorted_tokens(gearwatch::kAllRecordEnds));
  CHECK(vocabulary(db, "alert_kind") == sorted_tokens(gearwatch::kAllAlertKinds));
  CHECK(vocabulary(db, "alert_severity") == sorted_tokens(gearwatch::kAllAlertSeverities));
  CHECK(vocabulary(db, "alert_transition") == sorted_tokens(gearwatch::kAllAlertTransitions));
  CHECK(vocabulary(db, "skip_reason") == sorted_tokens(gearwatch::dsp::kAllSkipReasons));
  CHECK(vocabulary(db, "gap_cause") == std::vector<std::string>{"protocol", "ring_overflow"});
  // ...and the CHECK lists of older schema versions say the same, in the enum's order.
  std::vector<std::string> mechanisms, ends;
  for (auto m : gearwatch::dsp::kAllWearMechanisms) mechanisms.emplace_back(gearwatch::dsp::to_string(m));
  for (auto e : gearwatch::kAllRecordEnds) ends.emplace_back(gearwatch::to_string(e));
  CHECK(check_list(db, "wear_mechanism_assessments", "mechanism") == mechanisms);
  CHECK(check_list(db, "records", "end_reason") == ends);
  // The triggers refuse what is not in the vocabulary and accept what is.
  CHECK_THROWS_AS(db.exec("INSERT INTO alert_events(severity, kind, transition, message) VALUES ('warning', 'fatigue pitting', 'raised', 'x')"),
                  SqliteError);
  CHECK_THROWS_AS(db.exec("INSERT INTO alert_events(severity, kind, transition, message) VALUES ('loud', 'wear_mechanism', 'raised', 'x')"),
                  SqliteError);
  db.exec("INSERT INTO alert_events(severity, kind, transition, message) VALUES ('warning', 'wear_mechanism', 'raised', 'x')");
  CHECK(count(db, "SELECT count(*) FROM alerts WHERE kind = 'wear_mechanism' AND transition = 'raised'") == 1);
  // A domain nobody filled is not checked (the layer above core did not say).
  db.exec("INSERT INTO runs(kind, source) VALUES ('replay', 'test')");
  db.exec("INSERT INTO rejected_frames(run_id, kind, reason, frame) VALUES (1, 'anything', 'r', 'f')");
  CHECK(count(db, "SELECT count(*) FROM rejected_frames") == 1);
}

TEST_CASE("storage: a record's speed source, indicator notes and unseen band are vocabulary-checked (schema 7)",
          "[storage][vocabulary]") {
  const gearwatch::testing::TempDir dir("speed-source");
  Database db((dir / "a.db").string());
  open_and_migrate(db);
  CHECK(vocabulary(db, "speed_source") == sorted_tokens(gearwatch::dsp::kAllSpeedSources));
  CHECK(vocabulary(db, "indicator_note") == sorted_tokens(gearwatch::dsp::kAllIndicatorNotes));
  CHECK(vocabulary(db, "carrier_band") == sorted_tokens(gearwatch::dsp::kAllCarrierBands));
  db.exec("INSERT INTO runs(kind, source) VALUES ('replay', 'test')");
  db.exec("INSERT INTO streams(run_id, sequence, stream_id, sample_rate_hz, channel_count) VALUES (1, 1, 1, 25600, 1)");
  const char* record = "INSERT INTO records(stream_key, start_index, sample_count, duration_s, end_reason, analysed, speed_source)"
                       " VALUES (1, 0, 10, 1.0, 'complete', 1, ";
  CHECK_THROWS_AS(db.exec(std::string(record) + "'signal estimate')"), SqliteError);
  db.exec(std::string(record) + "'signal_estimate')");
  db.exec(std::string(record) + "NULL)");  // neither tacho nor estimate
  CHECK_THROWS_AS(db.exec("INSERT INTO indicator_notes(record_id, channel, name, note) VALUES (1, 0, 'ics2_low_band', 'trimmed')"),
                  SqliteError);
  db.exec("INSERT INTO indicator_notes(record_id, channel, name, note, detail) VALUES (1, 0, 'ics2_low_band', 'band_trimmed', 'd')");
  CHECK(count(db, "SELECT count(*) FROM record_status WHERE speed_source = 'signal_estimate' AND notes = '0 ics2_low_band: band_trimmed (d)'") == 1);
  CHECK_THROWS_AS(db.exec("INSERT INTO wear_mechanism_assessments(record_id, channel, mechanism, points, band_jumps, evidence, unseen_band)"
                          " VALUES (1, 0, 'none', 5, 0, 'e', 'high')"),
                  SqliteError);
  db.exec("INSERT INTO wear_mechanism_assessments(record_id, channel, mechanism, points, band_jumps, evidence, unseen_band)"
          " VALUES (1, 0, 'none', 5, 0, 'e', 'abrasion')");
  CHECK(count(db, "SELECT count(*) FROM wear_mechanism WHERE unseen_band = 'abrasion'") == 1);
}

TEST_CASE("storage: every wear verdict and alert value is stored, a refused part loses nothing else", "[storage][vocabulary]") {
  WriterWithRun run("verdicts");
  const auto& path = run.path;
  auto& w = run.writer;
  std::uint64_t start = 0;
  for (auto mechanism : gearwatch::dsp::kAllWearMechanisms) {
    auto r = make_record(start += 1000, 3);
    r.assessments.push_back({0, mechanism, 10, 0.01, 0.5, 0.9, 0.1, 0, "evidence", std::nullopt});
    gearwatch::AlertEvent e;
    e.key = {gearwatch::AlertKind::wear_mechanism, 0};
    e.value = gearwatch::dsp::to_string(mechanism);
    r.alerts.push_back(e);
    r.alert_states.push_back({e.key, gearwatch::AlertState{true, e.value, 1, 0, 0.0}});
    w.submit(std::move(r));
  }
  // A record with an alert kind outside the enum (what a bug would produce): the alert is
  // refused and counted, the record, its indicators and its assessment are stored.
  auto bad = make_record(start += 1000, 3);
  bad.assessments.push_back({0, gearwatch::dsp::WearMechanism::both, 10, 0.01, 0.01, 0.9, 0.9, 0, "evidence", std::nullopt});
  gearwatch::AlertEvent wrong;
  wrong.key = {static_cast<gearwatch::AlertKind>(200), 0};
  bad.alerts.push_back(wrong);
  w.submit(std::move(bad));
  w.stop();
  CHECK(w.counters().lost_at_exit == 0);
  CHECK(w.counters().rows_rejected == 1);
  Database db(path, Database::Mode::read_only);
  const auto n = static_cast<std::int64_t>(gearwatch::dsp::kAllWearMechanisms.size());
  CHECK(count(db, "SELECT count(*) FROM records") == n + 1);
  CHECK(count(db, "SELECT count(*) FROM indicators") == 3 * (n + 1));
  CHECK(count(db, "SELECT count(*) FROM wear_mechanism") == n + 1);
  CHECK(count(db, "SELECT count(*) FROM wear_mechanism WHERE mechanism = 'fatigue_pitting'") == 1);
  CHECK(count(db, "SELECT count(*) FROM alerts WHERE kind = 'wear_mechanism'") == n);
  CHECK(count(db, "SELECT count(*) FROM alerts WHERE value = 'abrasive_wear' AND channel = 0 AND transition = 'raised'") == 1);
  CHECK(count(db, "SELECT count(*) FROM alert_state WHERE kind = 'wear_mechanism' AND active = 1 AND value = 'undetermined'") == 1);
  CHECK(count(db, "SELECT count(*) FROM active_alerts") == 1);
}

}  // namespace test_storage
