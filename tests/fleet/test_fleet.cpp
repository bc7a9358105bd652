// The fleet consumer end to end (docs/fleet.md): mosquitto and PostgreSQL started by the test on
// 127.0.0.1, `gearwatch replay` publishing as gearboxes and `gearwatch fleet ingest` as child
// processes. What lands in PostgreSQL is compared row by row with each gearbox's own SQLite
// database, which is the reference: the consumer never reads it.
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <thread>

#include <catch2/catch.hpp>
#include <pqxx/pqxx>

#include "command_runner.hpp"
#include "fleet_messages.hpp"
#include "fleet/fleet_page_fixture.hpp"
#include "fleet/postgres_server.hpp"
#include "gearwatch/report/fleet_page.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "mqtt/mqtt_broker.hpp"
#include "mqtt/test_ca.hpp"
#include "step_log.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using gearwatch::storage::Database;
using gearwatch::storage::Statement;
using namespace gearwatch::testing;
using namespace std::chrono_literals;

namespace {

const std::string kUser = "plant", kPassword = "fleet-pw";

std::string num(const std::optional<double>& v) {
  if (!v) return "null";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", *v);
  return buf;
}

// --- The local side: each gearbox's SQLite database, read directly. -------------------------------
using Rows = std::vector<std::string>;

Rows sqlite_rows(const fs::path& db, const std::string& sql) {
  Database d(db.string(), Database::Mode::read_only);
  Statement s(d, sql);
  Rows rows;
  while (s.step()) {
    std::string row;
    for (int c = 0; c < s.column_count(); ++c) {
      if (c) row += "|";
      if (s.is_null(c)) row += "null";
      else if (s.column_type(c) == gearwatch::storage::ColumnType::real) row += num(s.get_double(c));
      else row += s.get_text(c);
    }
    rows.push_back(row);
  }
  return rows;
}

// --- The fleet side: PostgreSQL, read directly. --------------------------------------------------
Rows pg_rows(const std::string& uri, const std::string& sql) {
  pqxx::connection c(uri);
  pqxx::nontransaction n(c);
  n.exec("SET statement_timeout = '60s'");  // a query that waits on a lock fails instead of hanging the test
  Rows rows;
  for (const auto& r : n.exec(sql)) {
    std::string row;
    for (int i = 0; i < static_cast<int>(r.size()); ++i) {
      if (i) row += "|";
      if (r[i].is_null()) row += "null";
      else if (r[i].type() == 701) row += num(r[i].as<double>());  // float8
      else if (r[i].type() == 16) row += r[i].as<bool>() ? "1" : "0";
      else row += r[i].c_str();
    }
    rows.push_back(row);
  }
  return rows;
}
long long pg_count(const std::string& uri, const std::string& sql) {
  try {
    return std::stoll(pg_rows(uri, sql).at(0));
  } catch (const std::exception&) {
    return -1;  // the schema may not exist yet
  }
}

Rows sorted(Rows r) {
  std::sort(r.begin(), r.end());
  return r;
}

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}
std::size_t occurrences(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// Broker, database server and captures of one test; everything under one temporary directory.
struct Fleet {
  // Each step on stderr at once; the watchdog ends the test before its CTest TIMEOUT (300 s).
  StepLog step{Catch::getResultCapture().getCurrentTestName(), std::chrono::seconds(285)};
  TempDir dir{"fleet"};
  std::optional<fs::path> pg_bin = postgres_bin_dir();
  MosquittoBroker broker{dir / "broker", kUser, kPassword};
  std::optional<PostgresServer> pg;
  std::string uri;

  bool start() {
    if (!pg_bin) return false;
    // libpq (the test's connections, psql, the consumers) gives up a connection after 30 s.
    ::setenv("PGCONNECT_TIMEOUT", "30", 1);
    step("initdb");
    pg.emplace(dir / "pg", *pg_bin);
    step("PostgreSQL start");
    pg->start();
    pg->create_database("fleet");
    uri = pg->uri("fleet");
    step("mosquitto start");
    broker.start();
    step("servers up: PostgreSQL on " + std::to_string(pg->port()) + ", mosquitto on " + std::to_string(broker.port()));
    std::ofstream(dir / "credentials") << kUser << ":" << kPassword << "\n";
    return true;
  }
  // One gearbox's capture: `simulate` with its seed and the given options.
  void simulate_gearbox(const std::string& name, int seed, const std::string& options) {
    step("simulate " + name);
    const auto r = run_command(std::string(GEARWATCH_BINARY) + " simulate --out " + (dir / (name + ".log")).string() + " " + options +
                               " --channels 1 --seed " + std::to_string(seed));
    INFO(r.err);
    REQUIRE(r.status == 0);
  }
  // The gearbox's config: two accelerometers configured (the captures carry one, so sensor_missing
  // is raised: alerts beside the records), `tables`, and [mqtt] publishing as plant1/<name>.
  void write_gearbox_config(const std::string& name, const std::string& tables) {
    std::ofstream(dir / (name + ".toml")) << "[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n"
                                             "[[channels]]\nnumber = 1\nname = \"casing_x\"\nscale = 0.01\n"
                                          << tables << "[daemon]\nhealth_interval_s = 0.5\n"
                                          << "[mqtt]\nenabled = true\nhost = \"127.0.0.1\"\nport = " << broker.port()
                                          << "\nprefix = \"gw\"\nsite = \"plant1\"\ngearbox = \"" << name << "\"\npassword_file = \""
                                          << (dir / "credentials").string()
                                          << "\"\nreconnect_initial_ms = 50\nreconnect_max_ms = 300\ndrain_timeout_s = 60\n";
  }
  // One gearbox: a simulated capture (its own seed), 0.25 s records, the model off.
  void make_gearbox(const std::string& name, int seed, int seconds) {
    simulate_gearbox(name, seed, "--duration " + std::to_string(seconds));
    write_gearbox_config(name, "[records]\nlength_s = 0.25\ninterval_s = 0.25\nmin_length_s = 0.1\n[model]\nenabled = false\n");
  }
  // One gearbox with the model on: a 4 s capture at 20 Hz and 40 kHz (the pitting band analysed), 1 s
  // records, so the daemon's model thread runs on every record and publishes each run on /model, and
  // the gap step (spectral only) reports once after 4 records on /gap.
  void make_model_gearbox(const std::string& name, int seed) {
    simulate_gearbox(name, seed, "--duration 4.0 --speed 20 --torque 16 --sample-rate 40000");
    write_gearbox_config(name, "[rig]\nsample_rate_hz = 40000\n"
                               "[records]\nlength_s = 1.0\ninterval_s = 1.0\nmin_length_s = 0.5\n"
                               "[model]\nforecast_horizon_cycles = 100000.0\ncommissioning_records = 0\n"
                               "[gap]\nenabled = true\nevery_records = 4\ntraining_records = 3\nheld_out_records = 1\nrerun_twin = false\n");
  }
  fs::path db(const std::string& name) const { return dir / (name + ".db"); }
  pid_t replay(const std::string& name) {
    step("replay " + name);
    return spawn({"replay", (dir / (name + ".log")).string(), "--db", db(name).string(), "--config", (dir / (name + ".toml")).string()},
                 dir / ("out-" + name), dir / ("err-" + name));
  }
  pid_t consumer(const std::string& tag, const std::vector<std::string>& extra = {}) {
    step("consumer " + tag);
    std::vector<std::string> args{"fleet", "ingest", "--broker", "mqtt://127.0.0.1:" + std::to_string(broker.port()), "--database", uri,
                                  "--prefix", "gw", "--client-id", "fleet-test", "--password-file", (dir / "credentials").string(),
                                  "--gearbox", "plant1/gbA", "--gearbox", "plant1/gbB"};
    args.insert(args.end(), extra.begin(), extra.end());
    return spawn(args, dir / ("out-" + tag), dir / ("err-" + tag));
  }
  // A consumer with the test hook: it writes `stall_after` messages, then holds what it receives.
  pid_t stalling_consumer(const std::string& tag, int stall_after) {
    ::setenv("GEARWATCH_FLEET_TEST_STALL_AFTER", std::to_string(stall_after).c_str(), 1);
    const pid_t pid = consumer(tag, {"--resend-interval-s", "1"});
    ::unsetenv("GEARWATCH_FLEET_TEST_STALL_AFTER");
    wait_ready();
    REQUIRE(wait_until([&] { return occurrences(read_all(dir / ("err-" + tag)), "ingesting") == 1; }, 10s));
    std::this_thread::sleep_for(500ms);
    return pid;
  }
  // Waits until the consumer has made the schema and its session is subscribed (its first log line
  // after the subscription is the connection count at stop; the schema is the visible part).
  void wait_ready() {
    step("waiting for the consumer's schema");
    REQUIRE(wait_until([&] { return pg_count(uri, "SELECT count(*) FROM fleet.gearboxes") >= 0; }, 30s));
  }
  std::string err(const std::string& tag) { return read_all(dir / ("err-" + tag)); }
  // A consumer started and subscribed: the schema made, "ingesting" logged, then time for the SUBACK.
  pid_t subscribed_consumer(const std::string& tag) {
    const pid_t pid = consumer(tag);
    wait_ready();
    REQUIRE(wait_until([&] { return occurrences(read_all(dir / ("err-" + tag)), "ingesting") == 1; }, 10s));
    std::this_thread::sleep_for(500ms);
    return pid;
  }
  long long outbox_rows(const std::string& name) const { return std::stoll(sqlite_rows(db(name), "SELECT count(*) FROM outbox").at(0)); }
  long long fleet_messages(const std::string& name) const {
    return pg_count(uri, "SELECT count(*) FROM fleet.messages m JOIN fleet.gearboxes g ON g.id = m.gearbox_id WHERE g.name = '" + name + "'");
  }
  // Last member: destroyed first, so a test that ends early stops its consumers and daemons
  // before the servers under them.
  ChildrenGuard children;
};

bool skipped_without_postgres(const Fleet& f) {
  if (f.pg_bin) return false;
  std::cout << "SKIPPED: no PostgreSQL server binaries under /usr/lib/postgresql/*/bin (Debian's postgresql package)" << std::endl;
  return true;
}

// Every record, indicator value, skipped indicator and alert transition of one gearbox: the same
// rows, with the same values to the last bit, in its SQLite database and in the fleet database.
void check_same_as_local(const Fleet& f, const std::string& name, std::size_t min_records = 20) {
  INFO("gearbox " << name);
  const std::string where = " JOIN fleet.gearboxes g ON g.id = x.gearbox_id WHERE g.name = '" + name + "'";
  const auto local_records = sqlite_rows(
      f.db(name), "SELECT id, start_index, duration_s, analysed, coalesce(reject_reason, ''), speed_hz, torque_nm, input_revolutions "
                  "FROM records ORDER BY id");
  REQUIRE(local_records.size() >= min_records);
  CHECK(pg_rows(f.uri, "SELECT record_id, start_index, duration_s, analysed, reject_reason, speed_hz, torque_nm, input_revolutions "
                       "FROM fleet.records x" + where + " ORDER BY record_id") == local_records);
  const auto local_values = sorted(sqlite_rows(f.db(name), "SELECT record_id, channel, name, value FROM indicator_values"));
  REQUIRE(local_values.size() >= 5 * local_records.size());
  CHECK(sorted(pg_rows(f.uri, "SELECT record_id, channel, x.name, value FROM fleet.indicator_values x" + where)) == local_values);
  CHECK(sorted(pg_rows(f.uri, "SELECT record_id, channel, x.name, reason FROM fleet.indicator_skips x" + where)) ==
        sorted(sqlite_rows(f.db(name), "SELECT record_id, channel, name, reason FROM indicator_skips")));
  const auto local_alerts = sqlite_rows(f.db(name), "SELECT record_id, transition, severity, kind, channel, coalesce(subject, ''), "
                                                    "coalesce(value, ''), message FROM alert_events ORDER BY id");
  REQUIRE(!local_alerts.empty());
  CHECK(pg_rows(f.uri, "SELECT record_id, transition, severity, kind, channel, subject, value, message FROM fleet.alert_events x" + where +
                           " ORDER BY message_id") == local_alerts);
  // Every message of the outbox exactly once, by topic.
  CHECK(pg_rows(f.uri, "SELECT topic, count(*) FROM fleet.messages x" + where + " GROUP BY topic ORDER BY topic") ==
        sqlite_rows(f.db(name), "SELECT topic, count(*) FROM outbox GROUP BY topic ORDER BY topic"));
}

}  // namespace

TEST_CASE("fleet: two gearboxes' replays land in PostgreSQL exactly as in their own databases", "[fleet]") {
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  f.make_gearbox("gbA", 21, 8);
  f.make_gearbox("gbB", 22, 8);
  // The consumer's session exists before the gearboxes publish; it is away while they do, so the
  // broker queues everything and the second start ingests a known backlog (the throughput figure).
  const pid_t first = f.subscribed_consumer("c1");
  ::kill(first, SIGTERM);
  REQUIRE(wait_bounded(first, 30s) == 0);
  const pid_t a = f.replay("gbA"), b = f.replay("gbB");
  REQUIRE(wait_bounded(a, 120s) == 0);
  REQUIRE(wait_bounded(b, 120s) == 0);
  const long long total = f.outbox_rows("gbA") + f.outbox_rows("gbB");
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t second = f.consumer("c2");
  std::optional<std::chrono::steady_clock::time_point> ready;
  REQUIRE(wait_until([&] {
    if (!ready && occurrences(read_all(f.dir / "err-c2"), "ingesting") == 1) ready = std::chrono::steady_clock::now();
    return f.fleet_messages("gbA") + f.fleet_messages("gbB") == total;
  }, 60s));
  const auto t1 = std::chrono::steady_clock::now();
  const double seconds = std::chrono::duration<double>(t1 - t0).count();
  if (ready) std::cout << "fleet figure: consumer ready (schema checked) after " << std::chrono::duration<double>(*ready - t0).count() << " s" << std::endl;
  std::cout << "fleet figure: " << total << " messages of 2 gearboxes ingested from the broker's backlog in " << seconds << " s ("
            << total / seconds << " messages/s, consumer start included)" << std::endl;
  ::kill(second, SIGTERM);
  REQUIRE(wait_bounded(second, 30s) == 0);
  check_same_as_local(f, "gbA");
  check_same_as_local(f, "gbB");
  // Both gearboxes said online then offline (the retained status), as the daemons last did.
  CHECK(pg_rows(f.uri, "SELECT name, state, schema_version IS NOT NULL FROM fleet.gearboxes ORDER BY name") ==
        Rows{"gbA|offline|1", "gbB|offline|1"});
  INFO(f.err("c2"));
  CHECK(f.err("c2").find("stored " + std::to_string(total) + ",") != std::string::npos);
}

TEST_CASE("fleet: a consumer stopped mid-replay and restarted catches up, nothing twice", "[fleet]") {
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  f.make_gearbox("gbA", 23, 20);
  // A second capture of the same gearbox, replayed into the same database while the consumer is away.
  const auto r = run_command(std::string(GEARWATCH_BINARY) + " simulate --out " + (f.dir / "later.log").string() +
                             " --duration 8 --channels 1 --seed 24");
  REQUIRE(r.status == 0);
  const pid_t first = f.subscribed_consumer("c1");
  const pid_t replay = f.replay("gbA");
  // Stopped while messages arrive: what it acknowledged to the broker it stores before it exits.
  REQUIRE(wait_until([&] { return pg_count(f.uri, "SELECT count(*) FROM fleet.records") >= 5; }, 60s));
  ::kill(first, SIGTERM);
  REQUIRE(wait_bounded(first, 30s) == 0);
  const long long at_stop = pg_count(f.uri, "SELECT count(*) FROM fleet.messages");
  REQUIRE(wait_bounded(replay, 120s) == 0);
  const long long after_first_replay = f.outbox_rows("gbA");
  const pid_t later = spawn({"replay", (f.dir / "later.log").string(), "--db", f.db("gbA").string(), "--config", (f.dir / "gbA.toml").string()},
                            f.dir / "out-later", f.dir / "err-later");
  REQUIRE(wait_bounded(later, 120s) == 0);
  const long long total = f.outbox_rows("gbA");
  REQUIRE(total > after_first_replay);  // published while the consumer was away, for sure
  CHECK(pg_count(f.uri, "SELECT count(*) FROM fleet.messages") == at_stop);
  const pid_t second = f.consumer("c2");
  REQUIRE(wait_until([&] { return f.fleet_messages("gbA") == total; }, 60s));
  ::kill(second, SIGTERM);
  REQUIRE(wait_bounded(second, 30s) == 0);
  check_same_as_local(f, "gbA");
  // Each message stored by exactly one of the two runs: the counts add up to the outbox.
  auto stored_by = [&](const std::string& tag) {
    const std::string e = f.err(tag);
    const auto at = e.rfind("stored ");
    REQUIRE(at != std::string::npos);
    return std::stoll(e.substr(at + 7));
  };
  const long long s1 = stored_by("c1"), s2 = stored_by("c2");
  CHECK(s1 == at_stop);
  CHECK(s1 + s2 == total);
  CHECK(s2 >= total - after_first_replay);
}

TEST_CASE("fleet: bad input is counted, kept in fleet.rejects, logged once per kind, and the consumer goes on", "[fleet]") {
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  const pid_t consumer = f.subscribed_consumer("c");
  const std::string alert =
      R"({"gearbox":"gbA","site":"plant1","message_id":7,"topic":"alert","record_id":null,"record_time":"2026-11-29T10:00:00.000Z",)"
      R"("transition":"raised","severity":"alarm","kind":"sensor_missing","channel":1,"subject":"","value":"no signal","message":"m"})";
  std::string unknown_gearbox = alert;
  unknown_gearbox.replace(unknown_gearbox.find("gbA"), 3, "gbZ");
  const std::string wrong_schema = R"({"gearbox":"gbA","site":"plant1","message_id":8,"topic":"alert","record_id":null,)"
                                   R"("record_time":"2026-11-29T10:00:00.000Z","transition":"raised"})";
  const std::string not_utf8 = "{\"gearbox\":\"gb\xff\"}";
  struct Sent {
    std::string topic, payload;
  };
  const std::vector<Sent> bad{{"gw/plant1/gbA/record", "{not json"},
                              {"gw/plant1/gbA/record", "[1, 2"},
                              {"gw/plant1/gbA/record", ""},
                              {"gw/plant1/gbA/alert", wrong_schema},
                              {"gw/plant1/gbZ/alert", unknown_gearbox},
                              {"gw/plant1/gbA/alert", not_utf8},
                              {"gw/plant1/gbA/bogus", "{}"}};
  auto publish = [&](const Sent& s) {
    std::ofstream(f.dir / "payload", std::ios::binary) << s.payload;
    const auto r = run_command("mosquitto_pub -h 127.0.0.1 -p " + std::to_string(f.broker.port()) + " -u " + kUser + " -P " + kPassword +
                               " -q 1 -t " + s.topic + " -f " + (f.dir / "payload").string());
    REQUIRE(r.status == 0);
  };
  for (const auto& s : bad) publish(s);
  // A good message after the bad ones, twice (a QoS 1 repeat): stored once.
  publish({"gw/plant1/gbA/alert", alert});
  publish({"gw/plant1/gbA/alert", alert});
  REQUIRE(wait_until([&] { return pg_count(f.uri, "SELECT count(*) FROM fleet.alert_events") == 1 &&
                                  pg_count(f.uri, "SELECT count(*) FROM fleet.messages") == 1 &&
                                  pg_count(f.uri, "SELECT count(*) FROM fleet.rejects") == 7; },
                     30s));
  CHECK(::waitpid(consumer, nullptr, WNOHANG) == 0);  // still running
  // Each reject with its reason and its payload byte for byte.
  pqxx::connection c(f.uri);
  pqxx::nontransaction n(c);
  const auto rows = n.exec("SELECT topic, reason, payload FROM fleet.rejects ORDER BY id");
  REQUIRE(rows.size() == bad.size());
  const std::vector<std::string> reasons{"malformed_json", "malformed_json", "malformed_json", "wrong_schema",
                                         "unknown_gearbox", "not_utf8",      "unknown_topic"};
  for (std::size_t i = 0; i < bad.size(); ++i) {
    INFO("reject " << i);
    CHECK(rows[static_cast<int>(i)][0].as<std::string>() == bad[i].topic);
    CHECK(rows[static_cast<int>(i)][1].as<std::string>() == reasons[i]);
    CHECK(pqxx::binarystring(rows[static_cast<int>(i)][2]).str() == bad[i].payload);
  }
  CHECK(pg_rows(f.uri, "SELECT gearbox, kind, channel, value FROM fleet.active_alerts") == Rows{"gbA|sensor_missing|1|no signal"});
  ::kill(consumer, SIGTERM);
  REQUIRE(wait_bounded(consumer, 30s) == 0);
  const std::string err = f.err("c");
  INFO(err);
  CHECK(err.find("received 9, stored 1, duplicates 1, statuses 0, rejected 7 (not_utf8 1, malformed_json 3, wrong_schema 1, "
                 "unknown_topic 1, unknown_gearbox 1)") != std::string::npos);
  // Rate-limited: one line for the three malformed payloads (they came within the interval).
  CHECK(occurrences(err, "malformed_json: ") == 1);
  CHECK(occurrences(err, "wrong_schema: alert: missing required field 'severity'") == 1);
}

TEST_CASE("fleet: model runs and gap summaries land in their tables and in the latest views", "[fleet]") {
  // The replays above run with the model off (cheap); these payloads follow docs/mqtt/model.schema.json
  // and gap.schema.json field for field.
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  const pid_t consumer = f.subscribed_consumer("c");
  auto model = [](int message_id, int run, const std::string& k_wear) {
    return R"({"gearbox":"gbB","site":"plant1","message_id":)" + std::to_string(message_id) +
           R"(,"topic":"model","record_id":12,"record_time":"2026-11-29T10:00:00.000Z","model_run_id":)" + std::to_string(run) +
           R"(,"gear_pair":0,"advanced":true,"cycles":1.5e6,"k_wear":)" + k_wear +
           R"(,"k_pitting":null,"wear_mean_depth_m":1.25e-6,"wear_max_depth_m":3.5e-6,"pitting_mean":0.0125,)"
           R"("forecast":{"valid":true,"wear":{"limit":2e-5,"cycles_left":4.5e7,"cycles_left_low":3e7,"cycles_left_high":6e7},)"
           R"("pitting":{"limit":0.04,"cycles_left":null,"cycles_left_low":null,"cycles_left_high":null},"failure":"wear"}})";
  };
  const std::string gap = R"({"gearbox":"gbB","site":"plant1","message_id":5,"topic":"gap","record_id":12,)"
                          R"("record_time":"2026-11-29T10:00:00.000Z","gap_report_id":3,"gear_pair":0,"input_revolutions":1.5e6,)"
                          R"("significant_families":[{"family":"mesh_harmonics","distance_db":4.25}],"chosen_effects":["mesh_stiffness"],)"
                          R"("unexplained_families":[]})";
  auto publish = [&](const std::string& topic, const std::string& payload) {
    std::ofstream(f.dir / "payload", std::ios::binary) << payload;
    REQUIRE(run_command("mosquitto_pub -h 127.0.0.1 -p " + std::to_string(f.broker.port()) + " -u " + kUser + " -P " + kPassword +
                        " -q 1 -t " + topic + " -f " + (f.dir / "payload").string())
                .status == 0);
  };
  publish("gw/plant1/gbB/model", model(3, 1, "1.0000000000000002e-17"));
  publish("gw/plant1/gbB/model", model(4, 2, "2.5e-17"));
  publish("gw/plant1/gbB/model", model(4, 2, "2.5e-17"));  // a repeat
  publish("gw/plant1/gbB/gap", gap);
  // Well-formed JSON of the right shape, but a time PostgreSQL cannot read: refused by the database
  // alone (its savepoint), kept in the rejects; the messages around it are stored.
  std::string bad_time = model(6, 3, "3e-17");
  bad_time.replace(bad_time.find("2026-11-29T10:00:00.000Z"), 24, "the 32nd of Nevember");
  publish("gw/plant1/gbB/model", bad_time);
  REQUIRE(wait_until([&] { return pg_count(f.uri, "SELECT count(*) FROM fleet.messages") == 3 &&
                                  pg_count(f.uri, "SELECT count(*) FROM fleet.rejects WHERE reason = 'database_refused'") == 1; },
                     30s));
  CHECK(pg_rows(f.uri, "SELECT model_run_id, k_wear, cycles, wear_max_depth_m, k_pitting FROM fleet.model_states ORDER BY model_run_id") ==
        Rows{"1|" + num(1.0000000000000002e-17) + "|1500000|" + num(3.5e-6) + "|null", "2|" + num(2.5e-17) + "|1500000|" + num(3.5e-6) + "|null"});
  CHECK(pg_rows(f.uri, "SELECT gearbox, model_run_id, forecast->'wear'->>'cycles_left', forecast->>'failure' FROM fleet.latest_model") ==
        Rows{"gbB|2|45000000.0|wear"});  // the forecast as the consumer re-serialised it
  CHECK(pg_rows(f.uri, "SELECT gearbox, gap_report_id, significant_families->0->>'family', chosen_effects->>0 FROM fleet.latest_gap") ==
        Rows{"gbB|3|mesh_harmonics|mesh_stiffness"});
  ::kill(consumer, SIGTERM);
  REQUIRE(wait_bounded(consumer, 30s) == 0);
  INFO(f.err("c"));
  CHECK(f.err("c").find("received 5, stored 3, duplicates 1, statuses 0, rejected 1 (database_refused 1)") != std::string::npos);
}

TEST_CASE("fleet: ingest's command line: help, a malformed broker or gearbox, TLS options, an unreachable database", "[fleet][cli]") {
  const std::string bin = GEARWATCH_BINARY;
  const auto help = run_command(bin + " fleet ingest --help");
  CHECK(help.status == 0);
  CHECK(help.out.find("--database") != std::string::npos);
  const auto scheme = run_command(bin + " fleet ingest --broker tcp://h:1 --database postgresql://x@127.0.0.1:1/fleet");
  CHECK(scheme.status == 64);
  CHECK(scheme.err == "gearwatch: --broker tcp://h:1: expected mqtt://HOST[:PORT] or mqtts://HOST[:PORT]\n");
  // TLS wants the CA that signed the broker's certificate, and a client certificate its key.
  const auto no_ca = run_command(bin + " fleet ingest --broker mqtts://h --database postgresql://x@127.0.0.1:1/fleet");
  CHECK(no_ca.status == 64);
  CHECK(no_ca.err == "gearwatch: --broker mqtts://h: mqtts:// needs --ca-file\n");
  const auto ca_without_tls = run_command(bin + " fleet ingest --broker mqtt://h --ca-file " + bin + " --database postgresql://x@127.0.0.1:1/fleet");
  CHECK(ca_without_tls.status == 64);
  CHECK(ca_without_tls.err == "gearwatch: --ca-file needs an mqtts:// broker\n");
  const auto lone_cert = run_command(bin + " fleet ingest --broker mqtts://h --ca-file " + bin + " --cert-file " + bin +
                                     " --database postgresql://x@127.0.0.1:1/fleet");
  CHECK(lone_cert.status == 64);
  CHECK(lone_cert.err == "gearwatch: --cert-file and --key-file go together\n");
  const auto port = run_command(bin + " fleet ingest --broker mqtt://h:99999 --database postgresql://x@127.0.0.1:1/fleet");
  CHECK(port.status == 64);
  CHECK(port.err == "gearwatch: --broker mqtt://h:99999: port '99999' is not 1..65535\n");
  const auto gearbox = run_command(bin + " fleet ingest --broker mqtt://h --database postgresql://x@127.0.0.1:1/fleet --gearbox a/b/c");
  CHECK(gearbox.status == 64);
  CHECK(gearbox.err == "gearwatch: --gearbox a/b/c: expected SITE/NAME\n");
  // Nothing listens on the port: refused at start in one line, before any MQTT session exists.
  const int closed = free_loopback_port();
  const auto db = run_command(bin + " fleet ingest --broker mqtt://127.0.0.1:1 --database postgresql://x@127.0.0.1:" + std::to_string(closed) + "/fleet");
  CHECK(db.status == 1);
  CHECK(db.err.rfind("gearwatch: fleet database: cannot connect: ", 0) == 0);
  CHECK(occurrences(db.err, "\n") == 1);
}

TEST_CASE("fleet: a message's topic, bytes and fields decide what it is", "[fleet][parse]") {
  using gearwatch::daemon::FleetRejection;
  using gearwatch::daemon::is_utf8;
  using gearwatch::storage::fleet::RejectReason;
  // RFC 3629: overlong forms, UTF-16 surrogates and code points past U+10FFFF are not UTF-8.
  CHECK(is_utf8("gr\xc3\xbc\xc3\x9f" "e \xe2\x82\xac \xf0\x9f\x94\xa7"));
  CHECK_FALSE(is_utf8("\xc0\xaf"));          // overlong '/'
  CHECK_FALSE(is_utf8("\xed\xa0\x80"));      // U+D800
  CHECK_FALSE(is_utf8("\xf4\x90\x80\x80"));  // U+110000
  CHECK_FALSE(is_utf8("\xe2\x82"));          // cut short
  CHECK(gearwatch::daemon::utf8_or_replaced("a\xff" "b\xc3\xbc") == "a?b\xc3\xbc");
  const gearwatch::daemon::FleetAcceptance accept{"plant/gw", {"s1/g1"}};
  auto reason = [&](const std::string& topic, const std::string& payload) -> std::optional<RejectReason> {
    const auto r = gearwatch::daemon::parse_fleet_message(accept, topic, payload);
    if (const auto* j = std::get_if<FleetRejection>(&r)) return j->reason;
    return std::nullopt;
  };
  const std::string status = R"({"gearbox":"g1","site":"s1","state":"online","version":"0.1.0","schema":11})";
  CHECK(reason("plant/gw/s1/g1/status", status) == std::nullopt);  // a prefix of two levels
  CHECK(reason("plant/gw/s1/g1/status/x", status) == RejectReason::unknown_topic);
  CHECK(reason("gw/s1/g1/status", status) == RejectReason::unknown_topic);
  CHECK(reason("plant/gw/s1/g2/status", status) == RejectReason::unknown_gearbox);
  // The payload speaks for another gearbox than its topic's: refused, never stored under either.
  CHECK(reason("plant/gw/s1/g1/status", R"({"gearbox":"g2","site":"s1","state":"online","version":"0.1.0","schema":11})") ==
        RejectReason::wrong_schema);
  CHECK(reason("plant/gw/s1/g1/status", R"({"gearbox":"g1","site":"s1","state":"asleep","version":"0.1.0","schema":11})") ==
        RejectReason::wrong_schema);
  CHECK(reason("plant/gw/s1/g1/status", R"({"gearbox":"g1","site":"s1","state":"online","version":"0.1.0","schema":"11"})") ==
        RejectReason::wrong_schema);
  CHECK(reason("plant/gw/s1/g1/status", "null") == RejectReason::wrong_schema);
}

TEST_CASE("fleet: the database stopped under a running consumer: the message is held and stored once it is back", "[fleet]") {
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  const pid_t consumer = f.subscribed_consumer("c");
  f.pg->stop();
  const std::string alert =
      R"({"gearbox":"gbA","site":"plant1","message_id":1,"topic":"alert","record_id":null,"record_time":"2026-11-29T10:00:00.000Z",)"
      R"("transition":"event","severity":"info","kind":"sensor_missing","channel":null,"subject":"","value":"","message":"m"})";
  std::ofstream(f.dir / "payload", std::ios::binary) << alert;
  REQUIRE(run_command("mosquitto_pub -h 127.0.0.1 -p " + std::to_string(f.broker.port()) + " -u " + kUser + " -P " + kPassword +
                      " -q 1 -t gw/plant1/gbA/alert -f " + (f.dir / "payload").string())
              .status == 0);
  REQUIRE(wait_until([&] { return occurrences(read_all(f.dir / "err-c"), "holding the message and retrying") >= 1; }, 20s));
  f.pg->start();
  REQUIRE(wait_until([&] { return pg_count(f.uri, "SELECT count(*) FROM fleet.alert_events") == 1; }, 30s));
  CHECK(::waitpid(consumer, nullptr, WNOHANG) == 0);
  ::kill(consumer, SIGTERM);
  REQUIRE(wait_bounded(consumer, 30s) == 0);
  const std::string err = f.err("c");
  INFO(err);
  CHECK(err.find("received 1, stored 1, duplicates 0, statuses 0, rejected 0, database retries ") != std::string::npos);
  CHECK(err.find("database retries 0") == std::string::npos);
}

TEST_CASE("fleet: over TLS with client certificates and a per-gearbox ACL, a gearbox lands as in its own database and another's topics stay out", "[fleet]") {
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  f.step("stopping the plain broker");
  f.broker.stop();  // this test's broker speaks TLS and has an ACL
  f.step("test CA and certificates (openssl)");
  MosquittoBroker tls(f.dir / "tls-broker", "fleet", "fleet-pw");
  const auto certs = make_test_certificates(f.dir / "tls-broker" / "ca");
  tls.add_user("gbA", "gbA-pw");
  // Each gearbox writes under its own topics only; the consumer reads everything under the prefix.
  tls.use_tls_and_acl(certs.ca, certs.server_cert, certs.server_key,
                      "user fleet\ntopic read gw/#\n\nuser gbA\ntopic readwrite gw/plant1/gbA/#\n");
  f.step("TLS broker start");
  tls.start();
  f.step("TLS broker on " + std::to_string(tls.port()) + "; simulating gbA and gbX");
  std::ofstream(f.dir / "gbA-credentials") << "gbA:gbA-pw\n";
  std::ofstream(f.dir / "fleet-credentials") << "fleet:fleet-pw\n";
  const std::string tls_keys = "ca_file = \"" + certs.ca.string() + "\"\ncert_file = \"" + certs.client_cert.string() + "\"\nkey_file = \"" +
                               certs.client_key.string() + "\"\n";
  // gbA publishes as itself; "gbX" holds gbA's credentials but publishes under gw/plant1/gbX/…,
  // which the ACL does not give gbA.
  for (const auto& [name, seed] : {std::pair<std::string, int>{"gbA", 21}, {"gbX", 22}}) {
    const auto r = run_command(std::string(GEARWATCH_BINARY) + " simulate --out " + (f.dir / (name + ".log")).string() +
                               " --duration 8 --channels 1 --seed " + std::to_string(seed));
    REQUIRE(r.status == 0);
    // Channel 1 is configured but not in the capture: its sensor_missing alert is among what must arrive.
    std::ofstream(f.dir / (name + ".toml")) << "[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n"
                                               "[[channels]]\nnumber = 1\nname = \"casing_x\"\nscale = 0.01\n"
                                               "[records]\nlength_s = 0.25\ninterval_s = 0.25\nmin_length_s = 0.1\n"
                                               "[model]\nenabled = false\n[daemon]\nhealth_interval_s = 0.5\n"
                                               "[mqtt]\nenabled = true\nhost = \"127.0.0.1\"\nport = "
                                            << tls.port() << "\nprefix = \"gw\"\nsite = \"plant1\"\ngearbox = \"" << name
                                            << "\"\npassword_file = \"" << (f.dir / "gbA-credentials").string() << "\"\n" << tls_keys
                                            << "reconnect_initial_ms = 50\nreconnect_max_ms = 300\ndrain_timeout_s = 60\n";
  }
  const auto consumer_args = [&](const std::string& tag, bool client_certificate) {
    std::vector<std::string> args{"fleet", "ingest", "--broker", "mqtts://127.0.0.1:" + std::to_string(tls.port()), "--database", f.uri,
                                  "--prefix", "gw", "--client-id", "fleet-tls-" + tag, "--password-file", (f.dir / "fleet-credentials").string(),
                                  "--ca-file", certs.ca.string()};
    if (client_certificate) args.insert(args.end(), {"--cert-file", certs.client_cert.string(), "--key-file", certs.client_key.string()});
    args.insert(args.end(), {"--resend-interval-s", "1"});
    return spawn(args, f.dir / ("out-" + tag), f.dir / ("err-" + tag));
  };
  // Without a client certificate the broker refuses the TLS session: nothing is subscribed.
  f.step("consumer without a client certificate");
  const pid_t no_cert = consumer_args("nocert", false);
  f.wait_ready();
  std::this_thread::sleep_for(2s);
  f.step("stopping the consumer without a certificate");
  ::kill(no_cert, SIGTERM);
  REQUIRE(wait_bounded(no_cert, 30s) == 0);
  CHECK(read_all(f.dir / "err-nocert").find("over TLS") != std::string::npos);
  CHECK(pg_count(f.uri, "SELECT count(*) FROM fleet.messages") == 0);

  f.step("consumer with a client certificate, waiting for 'ingesting'");
  const pid_t consumer = consumer_args("tls", true);
  REQUIRE(wait_until([&] { return occurrences(read_all(f.dir / "err-tls"), "ingesting") == 1; }, 30s));
  std::this_thread::sleep_for(1s);
  f.step("replay gbA over TLS");
  const pid_t a = spawn({"replay", (f.dir / "gbA.log").string(), "--db", f.db("gbA").string(), "--config", (f.dir / "gbA.toml").string()},
                        f.dir / "out-gbA", f.dir / "err-gbA");
  REQUIRE(wait_bounded(a, 120s) == 0);
  f.step("replay gbX over TLS (refused by the ACL)");
  const pid_t x = spawn({"replay", (f.dir / "gbX.log").string(), "--db", f.db("gbX").string(), "--config", (f.dir / "gbX.toml").string()},
                        f.dir / "out-gbX", f.dir / "err-gbX");
  REQUIRE(wait_bounded(x, 120s) == 0);
  // The broker refused every one of gbX's messages (MQTT 5 PUBACK 0x87): each outbox row is marked
  // refused with that reason, none delivered, none waiting; the run counted each once, said so in
  // one line, and raised one alert (its own message refused too, so counted among them).
  f.step("checking gbX's outbox");
  const auto gbx_count = [&](const std::string& sql) { return std::stoll(sqlite_rows(f.db("gbX"), sql).at(0)); };
  const long long gbx_messages = gbx_count("SELECT count(*) FROM outbox");
  CHECK(gbx_count("SELECT count(*) FROM outbox WHERE topic = 'record'") == gbx_count("SELECT count(*) FROM records"));
  CHECK(gbx_count("SELECT count(*) FROM outbox WHERE refused_reason = '0x87 Not authorized' AND refused_at IS NOT NULL") == gbx_messages);
  CHECK(gbx_count("SELECT count(*) FROM outbox WHERE delivered_at IS NOT NULL") == 0);
  CHECK(gbx_count("SELECT value FROM outbox_counters WHERE name = 'refused'") == gbx_messages);
  const std::string gbx_err = read_all(f.dir / "err-gbX");
  INFO(gbx_err);
  CHECK(gbx_err.find("mqtt: " + std::to_string(gbx_messages) + " messages refused by the broker this run") != std::string::npos);
  CHECK(occurrences(gbx_err, "check the broker's ACL") == 1);
  CHECK(gbx_count("SELECT count(*) FROM alert_events WHERE kind = 'mqtt_publish_refused' AND transition = 'raised' "
                  "AND value = '0x87 Not authorized' AND severity = 'alarm'") == 1);
  CHECK(gbx_count("SELECT count(*) FROM alert_events WHERE kind = 'mqtt_publish_refused'") == 1);
  CHECK(gbx_count("SELECT count(*) FROM outbox WHERE topic = 'alert' AND payload LIKE '%mqtt_publish_refused%'") == 1);
  // gbA's messages, all accepted: none refused, no alert.
  CHECK(std::stoll(sqlite_rows(f.db("gbA"), "SELECT count(*) FROM outbox WHERE refused_at IS NOT NULL").at(0)) == 0);
  CHECK(std::stoll(sqlite_rows(f.db("gbA"), "SELECT count(*) FROM alert_events WHERE kind = 'mqtt_publish_refused'").at(0)) == 0);
  const long long expected = f.outbox_rows("gbA");
  f.step("waiting for gbA's " + std::to_string(expected) + " messages in the fleet database");
  REQUIRE(wait_until([&] { return f.fleet_messages("gbA") == expected; }, 60s));
  // A hole made by the test (a message four ids beyond the newest): the consumer asks for the ids
  // between, and the broker refuses the request (its ACL gives the consumer read only): counted and
  // said in one line, the consumer goes on.
  const std::string beyond = std::to_string(expected + 5);
  f.step("a hole made by the test; waiting for the refused resend request");
  pg_rows(f.uri, "INSERT INTO fleet.messages (gearbox_id, message_id, topic, record_time) SELECT id, " + beyond +
                     ", 'health', now() FROM fleet.gearboxes WHERE name = 'gbA' RETURNING message_id");
  REQUIRE(wait_until([&] { return f.err("tls").find("the broker refused a resend request: Not authorized") != std::string::npos; }, 30s));
  f.step("stopping the consumer");
  ::kill(consumer, SIGTERM);
  REQUIRE(wait_bounded(consumer, 30s) == 0);
  f.step("comparing gbA with its own database");
  pg_rows(f.uri, "DELETE FROM fleet.messages WHERE message_id = " + beyond + " RETURNING message_id");
  INFO(f.err("tls"));
  // Every request refused (the same hole is asked again after ten intervals, so one or two).
  const std::string tls_err = f.err("tls");
  const auto asked_at = tls_err.rfind("resend requests ");
  REQUIRE(asked_at != std::string::npos);
  const long long asked = std::stoll(tls_err.substr(asked_at + 16));
  CHECK(asked >= 1);
  CHECK(tls_err.find("resend requests " + std::to_string(asked) + " (refused " + std::to_string(asked) + "), lost 0 messages in 0 ranges") !=
        std::string::npos);
  CHECK(static_cast<long long>(occurrences(tls_err, "the broker refused a resend request")) <= asked);  // rate-limited: one line per 10 s
  check_same_as_local(f, "gbA");
  CHECK(pg_count(f.uri, "SELECT count(*) FROM fleet.gearboxes WHERE name = 'gbX'") == 0);
  CHECK(pg_count(f.uri, "SELECT count(*) FROM fleet.rejects") == 0);
  f.step("done");
}

// --- The fleet page (docs/fleet.md, "Fleet page") -------------------------------------------------

namespace {

// The data-gearbox attributes of the page's rows, in page order (unescaped back for comparison).
std::vector<std::string> page_order(const std::string& html) {
  std::vector<std::string> out;
  const std::string key = "data-gearbox=\"";
  for (auto at = html.find(key); at != std::string::npos; at = html.find(key, at + 1)) {
    std::string name = html.substr(at + key.size(), html.find('"', at + key.size()) - at - key.size());
    for (const auto& [entity, ch] : std::vector<std::pair<std::string, std::string>>{{"&lt;", "<"}, {"&gt;", ">"}, {"&amp;", "&"}})
      for (auto e = name.find(entity); e != std::string::npos; e = name.find(entity)) name.replace(e, entity.size(), ch);
    out.push_back(name);
  }
  return out;
}

// The row of one gearbox (from its <tr to its </tr>).
std::string page_row(const std::string& html, const std::string& escaped_name) {
  const auto at = html.find("data-gearbox=\"" + escaped_name + "\"");
  REQUIRE(at != std::string::npos);
  return html.substr(at, html.find("</tr>", at) - at);
}

}  // namespace

TEST_CASE("fleet report: the page lists every gearbox worst first with its verdict, active alerts and remaining life", "[fleet]") {
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  {
    gearwatch::storage::fleet::FleetStore store(f.uri);
    store.migrate();
    write_known_fleet(store);
  }
  // A password in the connection (ignored by the test server's trust authentication) never reaches the page.
  const std::string with_password = "postgresql://gw:s3cret-pw@127.0.0.1:" + std::to_string(f.pg->port()) + "/fleet";
  const auto out = f.dir / "page";
  const auto r = run_command(std::string(GEARWATCH_BINARY) + " fleet report --database " + with_password + " --out " + out.string() +
                             " --points 3");
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(r.out == "wrote " + (out / "index.html").string() + ": 5 gearboxes, worst first\n");
  const std::string html = read_all(out / "index.html");
  CHECK(page_order(html) == kFleetWorstFirst);
  CHECK(html.find("s3cret-pw") == std::string::npos);
  CHECK(html.find("postgresql://gw@127.0.0.1:" + std::to_string(f.pg->port()) + "/fleet") != std::string::npos);
  CHECK(html.find("5 · 2 with a warning or alarm · 2 with wear under way · 1 offline · 2 with messages missing or lost") !=
        std::string::npos);
  // The name is escaped wherever it appears; the raw bytes never reach the page.
  CHECK(html.find("gbWarn<&>") == std::string::npos);

  const std::string pit = page_row(html, "plant2/gbPit");
  CHECK(html.find("<tr class=\"gearbox-row sev-alarm\" data-gearbox=\"plant2/gbPit\">") != std::string::npos);
  CHECK(occurrences(pit, "<li class=\"sev-alarm\"") == 1);
  CHECK(pit.find("<span class=\"mech-wear\">fatigue_pitting</span>") != std::string::npos);
  CHECK(pit.find("pitting: <b>2 M</b> cycles <span class=\"muted\">(1.5 M – 2.6 M)</span>") != std::string::npos);
  CHECK(pit.find("depth 4.20 µm · pitting 5.0 %") != std::string::npos);

  // Only the alert still raised is listed: the info alert was raised, then cleared.
  const std::string warn = page_row(html, "plant2/gbWarn&lt;&amp;&gt;");
  CHECK(occurrences(warn, "<li class=") == 1);
  CHECK(occurrences(warn, "<li class=\"sev-warning\"") == 1);
  CHECK(warn.find("no model run") != std::string::npos);
  // Ids 6-8 answered gone; nothing is missing below its newest id.
  CHECK(warn.find("<span class=\"lost\">lost 3 messages in 1 range (not_held)</span>") != std::string::npos);
  CHECK(warn.find("missing") == std::string::npos);

  const std::string life = page_row(html, "plant1/gbLife");
  CHECK(life.find("none active") != std::string::npos);
  CHECK(life.find("pitting: <b>800 k</b> cycles <span class=\"muted\">(600 k – 1.1 M)</span>") != std::string::npos);

  // The trend: the newest 3 of gbQuiet's 4 records on channel 0, at their cycles (records 2–4).
  const std::string quiet = page_row(html, "plant1/gbQuiet");
  CHECK(occurrences(quiet, "<circle class=\"pt\"") == 3);
  CHECK(quiet.find("record 1<") == std::string::npos);
  CHECK(occurrences(quiet, "<title>record ") == 3);
  CHECK(quiet.find("wear: <b>9 M</b> cycles</div>") != std::string::npos);

  const std::string off = page_row(html, "plant1/gbOff");
  CHECK(off.find("<span class=\"state-offline\">offline</span>") != std::string::npos);
  CHECK(off.find("no model run") != std::string::npos);
  // Its status says ids up to 3 were sent and none arrived: 1-3 are asked for again, none lost.
  CHECK(off.find("<span class=\"missing\">missing 3 messages in 1 range, asked for again</span>") != std::string::npos);
  CHECK(off.find("lost") == std::string::npos);
  for (const auto* whole : {"plant2/gbPit", "plant1/gbLife", "plant1/gbQuiet"}) {
    const std::string row = page_row(html, whole);
    CHECK(row.find("class=\"missing\"") == std::string::npos);
    CHECK(row.find("class=\"lost\"") == std::string::npos);
  }
}

TEST_CASE("fleet report: a database without the fleet schema or out of reach is refused in one line", "[fleet]") {
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  const auto page = f.dir / "page";
  const auto empty = run_command(std::string(GEARWATCH_BINARY) + " fleet report --database " + f.uri + " --out " + page.string());
  CHECK(empty.status == 1);
  CHECK(empty.err == "gearwatch: fleet database: it holds no fleet schema (`gearwatch fleet ingest` creates it)\n");
  CHECK_FALSE(fs::exists(page / "index.html"));
  f.pg->stop();
  const auto away = run_command(std::string(GEARWATCH_BINARY) + " fleet report --database " + f.uri + " --out " + page.string());
  CHECK(away.status == 1);
  CHECK(away.err.rfind("gearwatch: fleet database: cannot connect: ", 0) == 0);
  CHECK(std::count(away.err.begin(), away.err.end(), '\n') == 1);
  CHECK_FALSE(fs::exists(page / "index.html"));
}

TEST_CASE("fleet report: cycles are written as staff read them and the order follows the urgency fields in turn", "[fleet]") {
  using gearwatch::report::format_cycles;
  CHECK(format_cycles(0) == "0");
  CHECK(format_cycles(9999) == "9999");
  CHECK(format_cycles(12345) == "12.3 k");
  CHECK(format_cycles(2.35e6) == "2.35 M");
  CHECK(format_cycles(1.2e9) == "1.2 G");
  gearwatch::storage::fleet::GearboxOverview healthy, offline, short_life, wearing, info_only;
  healthy.gearbox = "healthy";
  healthy.forecast_valid = true;
  healthy.cycles = 1.0;
  healthy.pitting.cycles_left = 5e6;
  offline = healthy;
  offline.gearbox = "offline";
  offline.state = "offline";
  short_life = healthy;
  short_life.gearbox = "short";
  short_life.wear.cycles_left = 1e5;
  wearing = healthy;
  wearing.gearbox = "wearing";
  wearing.verdicts = {{0, "abrasive_wear", ""}};
  info_only = healthy;
  info_only.gearbox = "info";
  info_only.active_alerts = {{"life_counter_reset", "info", "", "0", "", "", std::nullopt}};
  auto warned = healthy;
  warned.gearbox = "warned";
  warned.active_alerts = {{"sensor_flat_line", "warning", "", "", "", "", 0}};
  // An invalid forecast's cycles do not count as remaining life.
  auto invalid = short_life;
  invalid.gearbox = "invalid";
  invalid.forecast_valid = false;
  // An info alert alone does not move a gearbox up: it is listed among the healthy ones in their order.
  const auto order = gearwatch::report::worst_first({healthy, invalid, info_only, offline, short_life, wearing, warned});
  std::vector<std::string> names;
  for (const auto& g : order) names.push_back(g.gearbox);
  CHECK(names == std::vector<std::string>{"warned", "wearing", "short", "offline", "healthy", "info", "invalid"});
}

namespace {

// The newest "holding K received messages uncommitted" of the test hook's lines, or -1.
long long held_by_hook(const std::string& err) {
  const std::string mark = "holding ";
  const auto at = err.rfind(mark);
  return at == std::string::npos ? -1 : std::stoll(err.substr(at + mark.size()));
}

long long sqlite_scalar(const fs::path& db, const std::string& sql) { return std::stoll(sqlite_rows(db, sql).at(0)); }

// The kill -9 scene of the resend tests: gbA replayed while a consumer that stores only
// `stall_after` messages holds the rest; the consumer killed -9 once it holds every data message
// the daemon published (the daemon's offline status comes last). Returns the newest id stored.
long long replay_into_stalled_consumer_and_kill(Fleet& f, int stall_after) {
  const pid_t first = f.stalling_consumer("c1", stall_after);
  const pid_t replay = f.replay("gbA");
  REQUIRE(wait_bounded(replay, 120s) == 0);
  const long long newest = sqlite_scalar(f.db("gbA"), "SELECT max(id) FROM outbox");
  const bool all_held = wait_until([&] {
    const long long stored = pg_count(f.uri, "SELECT count(*) FROM fleet.messages");
    return stored >= 0 && held_by_hook(f.err("c1")) >= newest - stored + 1;
  }, 30s);
  INFO("newest " << newest << ", stored " << pg_count(f.uri, "SELECT count(*) FROM fleet.messages") << ", held "
                 << held_by_hook(f.err("c1")));
  REQUIRE(all_held);
  std::this_thread::sleep_for(300ms);
  ::kill(first, SIGKILL);
  ::waitpid(first, nullptr, 0);
  const long long stored_newest = pg_count(f.uri, "SELECT coalesce(max(message_id), 0) FROM fleet.messages");
  // Messages were received (and acknowledged to the broker) but not stored: lost without a resend.
  REQUIRE(pg_count(f.uri, "SELECT count(*) FROM fleet.messages") == stored_newest);
  REQUIRE(stored_newest < newest);
  return stored_newest;
}

void publish_as_plant(Fleet& f, const std::string& topic, const std::string& payload) {
  std::ofstream(f.dir / "payload", std::ios::binary) << payload;
  REQUIRE(run_command("mosquitto_pub -h 127.0.0.1 -p " + std::to_string(f.broker.port()) + " -u " + kUser + " -P " + kPassword +
                      " -q 1 -t " + topic + " -f " + (f.dir / "payload").string())
              .status == 0);
}

}  // namespace

TEST_CASE("fleet: a consumer killed -9 with messages received and not stored asks for them again and holds each once", "[fleet]") {
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  f.make_gearbox("gbA", 41, 8);
  const long long stored_before = replay_into_stalled_consumer_and_kill(f, 12);
  // Requests the daemon must not serve, waiting in its persistent session: another gearbox's, ids
  // never sent, not JSON. Counted and ignored, the daemon goes on.
  publish_as_plant(f, "gw/plant1/gbA/resend", R"({"site":"plant1","gearbox":"gbB","ranges":[[1,3]]})");
  publish_as_plant(f, "gw/plant1/gbA/resend", R"({"site":"plant1","gearbox":"gbA","ranges":[[100000,100005]]})");
  publish_as_plant(f, "gw/plant1/gbA/resend", "{resend everything");
  // Restarted: the retained status says what the daemon delivered, the hole is asked for while
  // the daemon is away; the daemon's next run (the same capture: nothing new to process) serves it.
  const pid_t second = f.consumer("c2", {"--resend-interval-s", "1"});
  REQUIRE(wait_until([&] { return f.err("c2").find("asked plant1/gbA to send") != std::string::npos; }, 30s));
  CHECK(f.err("c2").find("(first " + std::to_string(stored_before + 1) + "..") != std::string::npos);
  const long long sent_first_run = f.outbox_rows("gbA");
  const pid_t again = spawn({"replay", (f.dir / "gbA.log").string(), "--db", f.db("gbA").string(), "--config", (f.dir / "gbA.toml").string()},
                            f.dir / "out-again", f.dir / "err-again");
  REQUIRE(wait_bounded(again, 120s) == 0);
  const long long total = f.outbox_rows("gbA");
  REQUIRE(wait_until([&] { return f.fleet_messages("gbA") == total; }, 60s));
  ::kill(second, SIGTERM);
  REQUIRE(wait_bounded(second, 30s) == 0);
  // Every message once: the ids, then the data row by row.
  Rows local_ids = sqlite_rows(f.db("gbA"), "SELECT id, topic FROM outbox ORDER BY id");
  CHECK(pg_rows(f.uri, "SELECT message_id, topic FROM fleet.messages ORDER BY message_id") == local_ids);
  check_same_as_local(f, "gbA");
  CHECK(pg_count(f.uri, "SELECT count(*) FROM fleet.lost_messages") == 0);
  CHECK(pg_count(f.uri, "SELECT count(*) FROM fleet.rejects") == 0);
  const std::string daemon_err = read_all(f.dir / "err-again");
  INFO(daemon_err);
  CHECK(daemon_err.find("ids named gone, 3 ignored") != std::string::npos);
  CHECK(daemon_err.find(" 0 ids named gone") != std::string::npos);
  CHECK(occurrences(daemon_err, "ignored a resend request") == 1);  // one line, then at most one a minute
  // The run's final health snapshot carries the resend counters. It is taken once the sender has
  // settled, so the three requests waiting in the session are in it; the consumer, asking every
  // second, may still send one after it, which only the stop line counts.
  const std::string final_snapshot = " FROM health_snapshots WHERE final = 1 ORDER BY id DESC LIMIT 1";
  CHECK(sqlite_scalar(f.db("gbA"), "SELECT mqtt_resend_ignored" + final_snapshot) == 3);
  CHECK(sqlite_scalar(f.db("gbA"), "SELECT mqtt_resend_gone" + final_snapshot) == 0);
  const auto stop_line_at = daemon_err.find("resend requests this run: ");
  REQUIRE(stop_line_at != std::string::npos);
  const long long taken = std::stoll(daemon_err.substr(stop_line_at + 26));
  const long long snapshot_taken = sqlite_scalar(f.db("gbA"), "SELECT mqtt_resend_requests" + final_snapshot);
  CHECK(snapshot_taken >= 1);
  CHECK(snapshot_taken <= taken);
  // The hole's ids (up to the first run's newest) were sent again, at least once each.
  CHECK(sqlite_scalar(f.db("gbA"), "SELECT mqtt_resent" + final_snapshot) >= sent_first_run - stored_before);
  INFO(f.err("c2"));
  CHECK(f.err("c2").find("lost 0 messages in 0 ranges") != std::string::npos);
}

TEST_CASE("fleet: ids the daemon no longer holds are recorded once in fleet.lost_messages with their range and reason", "[fleet]") {
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  f.make_gearbox("gbA", 42, 8);
  const long long stored_before = replay_into_stalled_consumer_and_kill(f, 6);
  // The outbox prunes delivered rows beyond its newest 2 x outbox_limit ids; done here by the
  // test with the outbox's own rule (a window of 20), so the ids gone are known exactly.
  const long long newest_sent = sqlite_scalar(f.db("gbA"), "SELECT max(id) FROM outbox");
  REQUIRE(newest_sent - 20 > stored_before);
  {
    Database d(f.db("gbA").string(), Database::Mode::read_write);
    Statement(d, "DELETE FROM outbox WHERE delivered_at IS NOT NULL AND id <= (SELECT max(id) FROM outbox) - 20").run();
  }
  const pid_t second = f.consumer("c2", {"--resend-interval-s", "1"});
  REQUIRE(wait_until([&] { return f.err("c2").find("asked plant1/gbA to send") != std::string::npos; }, 30s));
  const pid_t again = spawn({"replay", (f.dir / "gbA.log").string(), "--db", f.db("gbA").string(), "--config", (f.dir / "gbA.toml").string()},
                            f.dir / "out-again", f.dir / "err-again");
  REQUIRE(wait_bounded(again, 120s) == 0);
  const long long newest = sqlite_scalar(f.db("gbA"), "SELECT max(id) FROM outbox");
  // Every id is accounted for: stored, or inside the lost range.
  const std::string lost_ids = "SELECT coalesce(sum(to_id - from_id + 1), 0) FROM fleet.lost_messages";
  REQUIRE(wait_until([&] { return f.fleet_messages("gbA") + pg_count(f.uri, lost_ids) == newest; }, 60s));
  ::kill(second, SIGTERM);
  REQUIRE(wait_bounded(second, 30s) == 0);
  const Rows lost = pg_rows(f.uri, "SELECT from_id, to_id, reason FROM fleet.lost_messages");
  REQUIRE(lost.size() == 1);
  // From the first id the killed consumer did not store to the newest id pruned.
  const long long from = stored_before + 1, to = newest_sent - 20;
  CHECK(lost[0] == std::to_string(from) + "|" + std::to_string(to) + "|not_held");
  // Those ids are indeed gone from the daemon's outbox; every id above them is stored, once.
  CHECK(sqlite_scalar(f.db("gbA"), "SELECT count(*) FROM outbox WHERE id BETWEEN " + std::to_string(from) + " AND " + std::to_string(to)) == 0);
  CHECK(pg_count(f.uri, "SELECT count(*) FROM fleet.messages WHERE message_id BETWEEN " + std::to_string(from) + " AND " + std::to_string(to)) == 0);
  CHECK(pg_count(f.uri, "SELECT count(DISTINCT message_id) FROM fleet.messages") == newest - (to - from + 1));
  CHECK(pg_rows(f.uri, "SELECT message_id, topic FROM fleet.messages WHERE message_id > " + std::to_string(to) + " ORDER BY message_id") ==
        sqlite_rows(f.db("gbA"), "SELECT id, topic FROM outbox WHERE id > " + std::to_string(to) + " ORDER BY id"));
  CHECK(pg_rows(f.uri, "SELECT gearbox, lost_messages FROM fleet.gearbox_status") == Rows{"gbA|" + std::to_string(to - from + 1)});
  const std::string err = f.err("c2");
  INFO(err);
  CHECK(err.find("lost " + std::to_string(to - from + 1) + " messages in 1 ranges") != std::string::npos);
  CHECK(occurrences(err, "cannot send " + std::to_string(to - from + 1) + " messages again") == 1);
  CHECK(read_all(f.dir / "err-again").find(std::to_string(to - from + 1) + " ids named gone, 0 ignored") != std::string::npos);
}

TEST_CASE("fleet: a hole its daemon does not answer within the give-up time is recorded lost once and its ids still land when the daemon returns", "[fleet]") {
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  f.make_gearbox("gbA", 44, 8);
  const long long stored_before = replay_into_stalled_consumer_and_kill(f, 6);
  // The daemon stays away: the hole is asked for, then given up after 2 s.
  const pid_t second = f.consumer("c2", {"--resend-interval-s", "1", "--resend-give-up-s", "2"});
  const std::string lost_rows = "SELECT from_id, to_id, reason FROM fleet.lost_messages";
  REQUIRE(wait_until([&] { return !pg_rows(f.uri, lost_rows).empty(); }, 60s));
  const long long sent = pg_count(f.uri, "SELECT delivered_through FROM fleet.gearboxes WHERE name = 'gbA'");
  CHECK(sent == f.outbox_rows("gbA"));
  const long long gap = sent - stored_before;
  CHECK(pg_rows(f.uri, lost_rows) == Rows{std::to_string(stored_before + 1) + "|" + std::to_string(sent) + "|no_answer"});
  CHECK(pg_rows(f.uri, "SELECT gearbox, lost_messages FROM fleet.gearbox_status") == Rows{"gbA|" + std::to_string(gap)});
  // The daemon's next run serves the request it was sent while away: every id lands, none lost now.
  const pid_t again = spawn({"replay", (f.dir / "gbA.log").string(), "--db", f.db("gbA").string(), "--config", (f.dir / "gbA.toml").string()},
                            f.dir / "out-again", f.dir / "err-again");
  REQUIRE(wait_bounded(again, 120s) == 0);
  const long long total = f.outbox_rows("gbA");  // the second run's own messages too
  REQUIRE(wait_until([&] { return f.fleet_messages("gbA") == total; }, 60s));
  ::kill(second, SIGTERM);
  REQUIRE(wait_bounded(second, 30s) == 0);
  CHECK(pg_rows(f.uri, "SELECT message_id, topic FROM fleet.messages ORDER BY message_id") ==
        sqlite_rows(f.db("gbA"), "SELECT id, topic FROM outbox ORDER BY id"));
  CHECK(pg_rows(f.uri, "SELECT gearbox, lost_messages FROM fleet.gearbox_status") == Rows{"gbA|0"});
  const std::string err = f.err("c2");
  INFO(err);
  CHECK(occurrences(err, "has not answered requests for " + std::to_string(gap) + " missing messages") == 1);
  CHECK(err.find("lost " + std::to_string(gap) + " messages in 1 ranges") != std::string::npos);
}

TEST_CASE("fleet: the schema 1 fleet database migrates to the current schema with its rows, and its holes are found", "[fleet]") {
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  {
    gearwatch::storage::fleet::FleetStore store(f.uri);
    CHECK(store.migrate_to(1) == 0);
  }
  {
    pqxx::connection c(f.uri);
    pqxx::work w(c);
    w.exec("INSERT INTO fleet.gearboxes (site, name) VALUES ('plant1', 'gbA')");
    for (int id : {1, 2, 5, 9})
      w.exec("INSERT INTO fleet.messages (gearbox_id, message_id, topic, record_time) SELECT id, " + std::to_string(id) +
             ", 'health', now() FROM fleet.gearboxes");
    w.exec("INSERT INTO fleet.rejects (topic, payload, reason, detail) VALUES ('gw/x', 'x', 'malformed_json', 'd')");
    w.commit();
  }
  gearwatch::storage::fleet::FleetStore store(f.uri);
  CHECK(store.migrate() == 1);
  CHECK(pg_rows(f.uri, "SELECT version FROM fleet.schema_version") == Rows{"3"});
  CHECK(pg_count(f.uri, "SELECT count(*) FROM fleet.messages") == 4);
  CHECK(pg_rows(f.uri, "SELECT reason, gearbox_id, message_id FROM fleet.rejects") == Rows{"malformed_json|null|null"});
  auto holes = [&] {
    Rows out;
    for (const auto& h : store.holes()) out.push_back(h.gearbox + "|" + std::to_string(h.from) + "|" + std::to_string(h.to));
    return out;
  };
  CHECK(holes() == Rows{"gbA|3|4", "gbA|6|8"});
  // A lost range, a reject with its id and the status's delivered_through close and open holes.
  using namespace gearwatch::storage::fleet;
  const auto out = store.write_batch({GoneMessage{"plant1", "gbA", {{3, 4, OutboxGoneReason::not_held}}},
                                      StatusMessage{"plant1", "gbA", "offline", "x", 12, 12}});
  CHECK(out.at(0).written == WriteOutcome::stored);
  MessageHeader h{"plant1", "gbA", 7, std::nullopt, "2026-01-01T00:00:00Z"};
  store.write(Reject{"gw/plant1/gbA/alert", "{}", RejectReason::database_refused, "d", h});
  CHECK(holes() == Rows{"gbA|6|6", "gbA|8|8", "gbA|10|12"});
  // The same answer again adds nothing.
  CHECK(store.write_batch({GoneMessage{"plant1", "gbA", {{3, 4, OutboxGoneReason::not_held}}}}).at(0).written == WriteOutcome::duplicate);
  CHECK(pg_rows(f.uri, "SELECT gearbox, lost_messages FROM fleet.gearbox_status") == Rows{"gbA|2"});
}

TEST_CASE("fleet: holes asked for past the give-up time are recorded lost as no_answer and ids that come later are not counted lost", "[fleet]") {
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  using namespace gearwatch::storage::fleet;
  FleetStore store(f.uri);
  store.migrate();
  // Ids 1, 2, 5 stored; the status says up to 9 were sent: holes 3..4 and 6..9.
  std::vector<Message> m;
  for (int id : {1, 2, 5}) m.push_back(HealthMessage{{"plant1", "gbA", id, std::nullopt, "2026-01-01T00:00:00Z"}, false, {}});
  m.push_back(StatusMessage{"plant1", "gbA", "offline", "x", 13, 9});
  for (const auto& o : store.write_batch(m)) REQUIRE(o.written);
  const auto names = [](const std::vector<MessageHole>& holes) {
    Rows out;
    for (const auto& h : holes) out.push_back(std::to_string(h.from) + ".." + std::to_string(h.to));
    return out;
  };
  // First look: both asked for, nothing given up; their first time is kept.
  auto look = store.check_holes(std::chrono::hours(1));
  CHECK(names(look.to_ask) == Rows{"3..4", "6..9"});
  CHECK(look.given_up.empty());
  const Rows first_asked = pg_rows(f.uri, "SELECT from_id, to_id, first_asked_at FROM fleet.asked_holes ORDER BY from_id");
  REQUIRE(first_asked.size() == 2);
  // Id 6 arrives: the hole 6..9 shrinks to 7..9 and keeps its first time.
  REQUIRE(store.write_batch({HealthMessage{{"plant1", "gbA", 6, std::nullopt, "2026-01-01T00:00:00Z"}, false, {}}}).at(0).written);
  look = store.check_holes(std::chrono::hours(1));
  CHECK(names(look.to_ask) == Rows{"3..4", "7..9"});
  const Rows after = pg_rows(f.uri, "SELECT from_id, to_id, first_asked_at FROM fleet.asked_holes ORDER BY from_id");
  REQUIRE(after.size() == 2);
  CHECK(after[0] == first_asked[0]);
  CHECK(after[1].substr(after[1].rfind('|')) == first_asked[1].substr(first_asked[1].rfind('|')));
  CHECK(after[1].rfind("7|9|", 0) == 0);
  // Past the give-up time: both recorded lost, no hole left to ask for.
  look = store.check_holes(std::chrono::seconds(0));
  CHECK(look.to_ask.empty());
  CHECK(names(look.given_up) == Rows{"3..4", "7..9"});
  CHECK(store.holes().empty());
  CHECK(pg_rows(f.uri, "SELECT from_id, to_id, reason FROM fleet.lost_messages ORDER BY from_id") == Rows{"3|4|no_answer", "7|9|no_answer"});
  CHECK(pg_count(f.uri, "SELECT count(*) FROM fleet.asked_holes") == 0);
  CHECK(pg_rows(f.uri, "SELECT gearbox, lost_messages FROM fleet.gearbox_status") == Rows{"gbA|5"});
  // The gearbox comes back and sends 8: stored, and no longer counted lost.
  REQUIRE(store.write_batch({HealthMessage{{"plant1", "gbA", 8, std::nullopt, "2026-01-01T00:00:00Z"}, false, {}}}).at(0).written ==
          WriteOutcome::stored);
  CHECK(pg_rows(f.uri, "SELECT gearbox, lost_messages FROM fleet.gearbox_status") == Rows{"gbA|4"});
  // Its own answer for 3..4 replaces the no_answer there.
  REQUIRE(store.write_batch({GoneMessage{"plant1", "gbA", {{3, 4, OutboxGoneReason::not_held}}}}).at(0).written == WriteOutcome::stored);
  CHECK(pg_rows(f.uri, "SELECT from_id, to_id, reason FROM fleet.lost_messages ORDER BY from_id") == Rows{"3|4|not_held", "7|9|no_answer"});
  CHECK(store.holes().empty());
}

TEST_CASE("fleet: a daemon's own model runs land in fleet.model_states as in its model_runs and the page shows the newest forecast",
          "[fleet][model]") {
  Fleet f;
  if (skipped_without_postgres(f)) return;
  REQUIRE(f.start());
  f.make_model_gearbox("gbA", 31);
  const pid_t consumer = f.subscribed_consumer("c");
  const pid_t replay = f.replay("gbA");
  REQUIRE(wait_bounded(replay, 240s) == 0);
  const long long total = f.outbox_rows("gbA");
  REQUIRE(wait_until([&] { return f.fleet_messages("gbA") == total; }, 60s));
  ::kill(consumer, SIGTERM);
  REQUIRE(wait_bounded(consumer, 30s) == 0);

  // Every run of the daemon's model, each value to the last bit, the forecast's too.
  const auto local = sqlite_rows(f.db("gbA"),
                                 "SELECT id, record_id, gear_pair, advanced, cycles, k_wear, k_pitting, wear_mean_m, wear_max_m, pitting_mean,"
                                 " wear_cycles_left, wear_cycles_left_low, wear_cycles_left_high, pitting_cycles_left,"
                                 " pitting_cycles_left_low, pitting_cycles_left_high, coalesce(forecast_failure, '') FROM model_runs ORDER BY id");
  REQUIRE(local.size() == 4);
  CHECK(std::stoll(sqlite_rows(f.db("gbA"), "SELECT count(*) FROM model_runs WHERE advanced = 1").at(0)) == 4);
  const std::string left = "(forecast->'wear'->>'cycles_left')::float8, (forecast->'wear'->>'cycles_left_low')::float8,"
                           " (forecast->'wear'->>'cycles_left_high')::float8, (forecast->'pitting'->>'cycles_left')::float8,"
                           " (forecast->'pitting'->>'cycles_left_low')::float8, (forecast->'pitting'->>'cycles_left_high')::float8";
  CHECK(pg_rows(f.uri, "SELECT model_run_id, record_id, gear_pair, advanced, cycles, k_wear, k_pitting, wear_mean_depth_m, wear_max_depth_m,"
                       " pitting_mean, " + left + ", forecast->>'failure' FROM fleet.model_states ORDER BY model_run_id") == local);
  CHECK(pg_rows(f.uri, "SELECT gearbox, model_run_id FROM fleet.latest_model") == Rows{"gbA|4"});
  check_same_as_local(f, "gbA", 4);
  // Its gap report (spectral only, after 4 records: 3 training, 1 held out): the families it found
  // significant with their distances, the effects chosen and the families left unexplained.
  REQUIRE(sqlite_rows(f.db("gbA"), "SELECT id, record_id, gear_pair, input_revolutions FROM gap_report_runs ORDER BY id") ==
          pg_rows(f.uri, "SELECT gap_report_id, record_id, gear_pair, input_revolutions FROM fleet.gap_summaries ORDER BY gap_report_id"));
  CHECK(pg_count(f.uri, "SELECT count(*) FROM fleet.gap_summaries") == 1);
  CHECK(pg_rows(f.uri, "SELECT e->>'family', (e->>'distance_db')::float8 FROM fleet.gap_summaries, jsonb_array_elements(significant_families)"
                       " WITH ORDINALITY AS a(e, n) ORDER BY n") ==
        sqlite_rows(f.db("gbA"), "SELECT family, before_distance_db FROM gap_report_families WHERE before_significant = 1 ORDER BY before_position"));
  CHECK(pg_rows(f.uri, "SELECT e FROM fleet.gap_summaries, jsonb_array_elements_text(chosen_effects) WITH ORDINALITY AS a(e, n) ORDER BY n") ==
        sqlite_rows(f.db("gbA"), "SELECT effect FROM gap_report_chosen ORDER BY step"));
  CHECK(pg_rows(f.uri, "SELECT e FROM fleet.gap_summaries, jsonb_array_elements_text(unexplained_families) WITH ORDINALITY AS a(e, n) ORDER BY n") ==
        sqlite_rows(f.db("gbA"), "SELECT family FROM gap_report_families WHERE unexplained_position IS NOT NULL ORDER BY unexplained_position"));

  // The fleet page's remaining life is the newest run's, as the local database holds it.
  Database local_db(f.db("gbA").string(), Database::Mode::read_only);
  Statement newest(local_db, "SELECT forecast_failure IS NULL, pitting_cycles_left, wear_cycles_left, wear_max_m FROM model_runs"
                             " ORDER BY id DESC LIMIT 1");
  REQUIRE(newest.step());
  REQUIRE(newest.get_int(0) == 1);  // a valid forecast
  auto life = [&](const char* mode, int column) {
    return std::string(mode) + ": " + (newest.is_null(column) ? "<span class=\"muted\">beyond the horizon</span>"
                                                              : "<b>" + gearwatch::report::format_cycles(newest.get_double(column)) + "</b> cycles");
  };
  char depth[64];
  std::snprintf(depth, sizeof depth, "depth %.2f µm", newest.get_double(3) * 1e6);
  const auto page = f.dir / "page";
  const auto r = run_command(std::string(GEARWATCH_BINARY) + " fleet report --database " + f.uri + " --out " + page.string());
  INFO(r.err);
  REQUIRE(r.status == 0);
  const std::string row = page_row(read_all(page / "index.html"), "plant1/gbA");
  INFO(row);
  CHECK(row.find(life("pitting", 1)) != std::string::npos);
  CHECK(row.find(life("wear", 2)) != std::string::npos);
  CHECK(row.find(depth) != std::string::npos);
}
