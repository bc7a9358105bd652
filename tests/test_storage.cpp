#include "gearwatch/storage/writer.hpp"

#include <sys/mount.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include <catch2/catch.hpp>

#include "temp_dir.hpp"

#include "gearwatch/storage/schema.hpp"
#include "gearwatch/storage/sqlite.hpp"

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
  r.end_reason = "complete";
  r.analysed = true;
  r.torque_nm = 20;
  r.speed_hz = 10;
  r.input_revolutions = static_cast<double>(start) / 100.0;
  ChannelResult ch;
  ch.channel = 0;
  for (int i = 0; i < values; ++i) ch.values.emplace_back(std::string("value_") += std::to_string(i), i * 0.5);
  ch.skipped.emplace_back("ics2_high_band", "band_above_nyquist");
  r.channels.push_back(ch);
  return r;
}

void submit_run(StorageWriter& w) {
  w.submit(RunStarted{"replay", "test", ""});
  w.submit(StreamStarted{1, 1, 100000, 2});
}

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
  const gearwatch::testing::TempDir dir("writer");
  const auto path = (dir / "a.db").string();
  WriterOptions o;
  o.database = path;
  o.queue_capacity = 8;  // small: exercises the waiting producer
  StorageWriter w(o);
  w.start();
  submit_run(w);
  for (int i = 0; i < 300; ++i) w.submit(make_record(static_cast<std::uint64_t>(i) * 1000, 5));
  w.submit(HealthSnapshot{true, {{"frames", 42}, {"samples", 7}}});
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
  const gearwatch::testing::TempDir dir("readers");
  const auto path = (dir / "a.db").string();
  WriterOptions o;
  o.database = path;
  o.busy_timeout_ms = 50;
  StorageWriter w(o);
  w.start();
  submit_run(w);
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
  const gearwatch::testing::TempDir dir("poison");
  const auto path = (dir / "a.db").string();
  WriterOptions o;
  o.database = path;
  StorageWriter w(o);
  w.start();
  submit_run(w);
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
