// The MQTT publisher end to end with a real broker (docs/mqtt.md): mosquitto started by the test on
// 127.0.0.1 with a password file, a libmosquitto subscriber with a persistent session, and
// `gearwatch replay` as a child process. What the subscriber receives is compared message by
// message with the outbox rows, the records and the alert events of the local database.
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "command_runner.hpp"
#include "gearwatch/config/config.hpp"
#include "gearwatch/storage/outbox.hpp"
#include "gearwatch/storage/schema.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/storage/writer.hpp"
#include "mqtt/mqtt_broker.hpp"
#include "mqtt_sender.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using gearwatch::storage::Database;
using gearwatch::storage::Statement;
using namespace gearwatch::testing;
using nlohmann::json;
using namespace std::chrono_literals;

namespace {

const std::string kUser = "gearbox7", kPassword = "s3cret:colon";

struct OutboxRow {
  std::int64_t id = 0;
  std::string topic, payload;
  bool delivered = false;
};

std::vector<OutboxRow> outbox_rows(const fs::path& db) {
  Database d(db.string(), Database::Mode::read_only);
  Statement s(d, "SELECT id, topic, payload, delivered_at IS NOT NULL FROM outbox ORDER BY id");
  std::vector<OutboxRow> rows;
  while (s.step()) rows.push_back({s.get_int(0), s.get_text(1), s.get_text(2), s.get_int(3) == 1});
  return rows;
}

std::vector<std::int64_t> ids_of(const fs::path& db, const std::string& sql) {
  Database d(db.string(), Database::Mode::read_only);
  Statement s(d, sql);
  std::vector<std::int64_t> ids;
  while (s.step()) ids.push_back(s.is_null(0) ? -1 : s.get_int(0));
  return ids;
}

std::int64_t scalar(const fs::path& db, const std::string& sql) {
  Database d(db.string(), Database::Mode::read_only);
  Statement s(d, sql);
  return s.step() ? s.get_int(0) : -1;
}

// While a daemon is creating the database: -1 until the file and its tables are there.
std::int64_t scalar_when_ready(const fs::path& db, const std::string& sql) {
  if (!fs::exists(db)) return -1;
  try {
    return scalar(db, sql);
  } catch (const gearwatch::storage::SqliteError&) {
    return -1;
  }
}

// Two configured accelerometers, a capture with one: every run raises sensor_missing for channel 1,
// so the alert topic carries real alerts beside the records.
struct Setup {
  // Each step on stderr at once; the watchdog ends the test before its CTest TIMEOUT (600 s).
  StepLog step{Catch::getResultCapture().getCurrentTestName(), std::chrono::seconds(585)};
  TempDir dir{"mqtt"};
  MosquittoBroker broker{dir / "broker", kUser, kPassword};
  fs::path capture = dir / "cap.log", db = dir / "gw.db", config = dir / "gw.toml";
  // Destroyed first: a test that ends early stops its daemons before the broker.
  ChildrenGuard children;

  explicit Setup(const std::string& password = kPassword, double drain_timeout_s = 60.0, int capture_s = 8) {
    step("simulate");
    const auto r = run_command(std::string(GEARWATCH_BINARY) + " simulate --out " + capture.string() +
                               " --duration " + std::to_string(capture_s) + " --channels 1 --seed 11");
    INFO(r.err);
    REQUIRE(r.status == 0);
    std::ofstream(dir / "credentials") << kUser << ":" << password << "\n";
    std::ofstream(config) << "[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n"
                             "[[channels]]\nnumber = 1\nname = \"casing_x\"\nscale = 0.01\n"
                             "[records]\nlength_s = 0.25\ninterval_s = 0.25\nmin_length_s = 0.1\n"
                             "[model]\nenabled = false\n[daemon]\nhealth_interval_s = 0.5\n"
                             "[mqtt]\nenabled = true\nhost = \"127.0.0.1\"\nport = " << broker.port()
                          << "\nprefix = \"gw\"\nsite = \"plant1\"\ngearbox = \"gb7\"\npassword_file = \""
                          << (dir / "credentials").string() << "\"\nreconnect_initial_ms = 50\nreconnect_max_ms = 300\n"
                          << "drain_timeout_s = " << drain_timeout_s << "\n";
  }
  pid_t start_replay(const std::string& tag) {
    step("replay " + tag);
    return spawn({"replay", capture.string(), "--db", db.string(), "--config", config.string()}, dir / ("out-" + tag),
                 dir / ("err-" + tag));
  }
  std::string err(const std::string& tag) {
    std::ifstream in(dir / ("err-" + tag));
    return {std::istreambuf_iterator<char>(in), {}};
  }
};

// The first arrival of each message id, in arrival order (QoS 1 may repeat a message; the
// consumer removes repeats by message_id), without the retained status messages.
std::vector<json> first_arrivals(const std::vector<ReceivedMessage>& got) {
  std::vector<json> out;
  std::set<std::int64_t> seen;
  for (const auto& m : got) {
    if (m.topic.size() >= 7 && m.topic.substr(m.topic.size() - 7) == "/status") continue;
    const json j = json::parse(m.payload);
    if (seen.insert(j.at("message_id").get<std::int64_t>()).second) out.push_back(j);
  }
  return out;
}

// The retained status messages' states, in arrival order.
std::vector<std::string> status_states(const MqttSubscriber& sub) {
  std::vector<std::string> states;
  for (const auto& m : sub.messages())
    if (m.topic == "gw/plant1/gb7/status") states.push_back(json::parse(m.payload).at("state"));
  return states;
}

std::size_t distinct_data_messages(const MqttSubscriber& sub) { return first_arrivals(sub.messages()).size(); }

// Every outbox row delivered, received once at least, in id order, byte for byte; the record
// messages are exactly the database's records and the alert messages exactly its alert events.
void check_delivered_in_order(const fs::path& db, const MqttSubscriber& sub) {
  const auto rows = outbox_rows(db);
  REQUIRE(!rows.empty());
  REQUIRE(wait_until([&] { return distinct_data_messages(sub) >= rows.size(); }, 20s));
  const auto got = sub.messages();
  const auto first = first_arrivals(got);
  REQUIRE(first.size() == rows.size());
  std::map<std::int64_t, std::string> payload_of;
  for (const auto& m : got)
    if (m.topic.find("/status") == std::string::npos) payload_of.emplace(json::parse(m.payload).at("message_id").get<std::int64_t>(), m.payload);
  std::vector<std::int64_t> records, alerts;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    INFO("outbox row " << rows[i].id);
    CHECK(rows[i].delivered);
    CHECK(first[i].at("message_id") == rows[i].id);
    CHECK(payload_of.at(rows[i].id) == rows[i].payload);
    CHECK(first[i].at("gearbox") == "gb7");
    if (rows[i].topic == "record") records.push_back(first[i].at("record_id").get<std::int64_t>());
    if (rows[i].topic == "alert") alerts.push_back(first[i].at("record_id").is_null() ? -1 : first[i].at("record_id").get<std::int64_t>());
  }
  CHECK(records == ids_of(db, "SELECT id FROM records ORDER BY id"));
  CHECK(alerts == ids_of(db, "SELECT record_id FROM alert_events ORDER BY id"));
  CHECK(!alerts.empty());
  // Each message went to its own topic.
  for (const auto& m : got) {
    if (m.topic.find("/status") != std::string::npos) continue;
    CHECK(m.topic == "gw/plant1/gb7/" + json::parse(m.payload).at("topic").get<std::string>());
  }
}

// The documented schema of each topic (docs/mqtt/<topic>.schema.json): its required properties
// are present with the documented JSON types.
bool has_type(const json& v, const json& types) {
  auto one = [&](const std::string& t) {
    if (t == "null") return v.is_null();
    if (t == "string") return v.is_string();
    if (t == "integer") return v.is_number_integer();
    if (t == "number") return v.is_number();
    if (t == "boolean") return v.is_boolean();
    if (t == "array") return v.is_array();
    if (t == "object") return v.is_object();
    return false;
  };
  if (types.is_string()) return one(types.get<std::string>());
  for (const auto& t : types)
    if (one(t.get<std::string>())) return true;
  return false;
}

void check_against_schema(const json& payload, const std::string& topic) {
  std::ifstream in(std::string(GEARWATCH_SOURCE_DIR) + "/docs/mqtt/" + topic + ".schema.json");
  REQUIRE(in);
  const json schema = json::parse(in);
  INFO(topic << ": " << payload.dump());
  REQUIRE(schema.at("required").size() >= 6);
  for (const auto& name : schema.at("required")) {
    INFO("property " << name);
    REQUIRE(payload.contains(name.get<std::string>()));
    const json& property = schema.at("properties").at(name.get<std::string>());
    CHECK(has_type(payload.at(name.get<std::string>()), property.at("type")));
    if (property.contains("enum")) CHECK(std::count(property["enum"].begin(), property["enum"].end(), payload.at(name.get<std::string>())) == 1);
  }
  CHECK(payload.at("topic") == topic);
}

}  // namespace

TEST_CASE("mqtt: a replay's records and alerts reach a real broker in order, exactly the database's rows", "[mqtt]") {
  Setup s;
  s.broker.start();
  MqttSubscriber sub(s.broker.port(), kUser, kPassword, "gw/#");
  const pid_t pid = s.start_replay("a");
  REQUIRE(wait_bounded(pid, 120s) == 0);
  check_delivered_in_order(s.db, sub);
  CHECK(scalar(s.db, "SELECT count(*) FROM outbox WHERE delivered_at IS NULL") == 0);
  // The retained status: online while it ran, offline when it stopped.
  const auto states = status_states(sub);
  REQUIRE(states.size() >= 2);
  CHECK(states.front() == "online");
  CHECK(states.back() == "offline");
  // Every topic's payloads carry the documented required fields.
  std::set<std::string> topics;
  for (const auto& row : outbox_rows(s.db)) {
    check_against_schema(json::parse(row.payload), row.topic);
    topics.insert(row.topic);
  }
  CHECK(topics == std::set<std::string>{"alert", "health", "record", "wear"});
}

TEST_CASE("mqtt: the broker stopped during a replay and restarted: nothing lost, nothing reordered", "[mqtt]") {
  // 480 records: the replay goes on for seconds after the first delivery, also on a loaded machine
  // (the broker must go away while records are still being stored).
  Setup s(kPassword, 60.0, 120);
  s.broker.start();
  MqttSubscriber sub(s.broker.port(), kUser, kPassword, "gw/#");
  const pid_t pid = s.start_replay("b");
  REQUIRE(wait_until([&] { return distinct_data_messages(sub) >= 1; }, 60s));
  s.broker.stop();
  // Data keeps coming into the outbox while the broker is away.
  const auto before = outbox_rows(s.db).size();
  REQUIRE(wait_until([&] { return outbox_rows(s.db).size() >= before + 5; }, 60s));
  s.broker.start();
  REQUIRE(wait_bounded(pid, 120s) == 0);
  check_delivered_in_order(s.db, sub);
  // The outage was bridged by the same process, not avoided: it lost its connection once (one
  // warning line), and the rows stored while the broker was away were delivered above, which only a
  // second connection of this process could do (it is the only publisher).
  const std::string err = s.err("b");
  INFO(err);
  std::size_t lost = 0;
  for (auto at = err.find("mqtt: connection to"); at != std::string::npos; at = err.find("mqtt: connection to", at + 1)) ++lost;
  CHECK(lost == 1);
}

TEST_CASE("mqtt: the daemon killed -9 with undelivered messages delivers them after its restart", "[mqtt]") {
  Setup s;
  // No broker yet: everything the replay stores waits in the outbox.
  const pid_t first = s.start_replay("c1");
  REQUIRE(wait_until([&] { return scalar_when_ready(s.db, "SELECT count(*) FROM runs WHERE ended_at IS NOT NULL") == 1; }, 120s));
  const auto waiting = scalar(s.db, "SELECT count(*) FROM outbox WHERE delivered_at IS NULL");
  REQUIRE(waiting > 10);
  ::kill(first, SIGKILL);
  REQUIRE(wait_bounded(first, 10s) == 128 + SIGKILL);
  s.broker.start();
  MqttSubscriber sub(s.broker.port(), kUser, kPassword, "gw/#");
  // The same capture again: its records are all stored already; the sender delivers the backlog.
  const pid_t second = s.start_replay("c2");
  REQUIRE(wait_bounded(second, 120s) == 0);
  check_delivered_in_order(s.db, sub);
}

TEST_CASE("mqtt: a wrong password is refused, counted, said in one line and raised as an alert", "[mqtt]") {
  Setup s("wrong-password", 1.0);
  s.broker.start();
  const pid_t pid = s.start_replay("d");
  REQUIRE(wait_bounded(pid, 120s) == 0);
  const std::string err = s.err("d");
  INFO(err);
  std::size_t refused_lines = 0;
  for (std::size_t at = err.find("refused client"); at != std::string::npos; at = err.find("refused client", at + 1)) ++refused_lines;
  CHECK(refused_lines == 1);
  CHECK(err.find("0x87 Not authorized") != std::string::npos);  // the MQTT 5 CONNACK reason
  CHECK(scalar(s.db, "SELECT mqtt_refused FROM health_snapshots WHERE final = 1 ORDER BY id DESC LIMIT 1") >= 1);
  CHECK(scalar(s.db, "SELECT count(*) FROM alert_events WHERE kind = 'mqtt_refused' AND transition = 'raised'") == 1);
  // Nothing was delivered: every message, the refusal's alert among them, waits in the outbox.
  CHECK(scalar(s.db, "SELECT count(*) FROM outbox WHERE delivered_at IS NOT NULL") == 0);
  CHECK(scalar(s.db, "SELECT count(*) FROM outbox WHERE topic = 'alert' AND payload LIKE '%mqtt_refused%'") == 1);
}

TEST_CASE("mqtt: the mqtt config table is off by default and names its bad keys", "[mqtt][config]") {
  TempDir dir("mqtt-config");
  auto load = [&](const std::string& text) {
    std::ofstream(dir / "c.toml") << text;
    return gearwatch::config::load_config((dir / "c.toml").string());
  };
  const auto defaults = load("");
  CHECK_FALSE(defaults.mqtt.enabled);
  CHECK(defaults.mqtt.port == 1883);
  const auto c = load("[mqtt]\nenabled = true\nhost = \"broker.plant\"\nport = 8883\nprefix = \"gw\"\nsite = \"hall2\"\n"
                      "gearbox = \"gb-17\"\noutbox_limit = 500\nca_file = \"/etc/ca.pem\"\n");
  CHECK(c.mqtt.enabled);
  CHECK(c.mqtt.host == "broker.plant");
  CHECK(c.mqtt.port == 8883);
  CHECK(c.mqtt.outbox_limit == 500);
  CHECK(gearwatch::daemon::mqtt_topic(c.mqtt, "alert") == "gw/hall2/gb-17/alert");
  auto error_of = [&](const std::string& text) {
    try {
      load(text);
    } catch (const gearwatch::config::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  CHECK(error_of("[mqtt]\ngearbox = \"a/b\"\n") == (dir / "c.toml").string() + ":2: key 'mqtt.gearbox': must not contain '/', '+' or '#' (one topic level)");
  CHECK(error_of("[mqtt]\ncert_file = \"c.pem\"\nkey_file = \"k.pem\"\n") ==
        (dir / "c.toml").string() + ":2: key 'mqtt.cert_file': a client certificate needs TLS: set ca_file");
  CHECK(error_of("[mqtt]\npassword = \"x\"\n") == (dir / "c.toml").string() + ":2: key 'mqtt.password': unknown key");
}

TEST_CASE("mqtt: credentials come from a file, or from the systemd credentials directory", "[mqtt]") {
  TempDir dir("mqtt-credentials");
  std::ofstream(dir / "pw") << "gearbox7:pa:ss word\r\n";
  const auto direct = gearwatch::daemon::read_mqtt_credentials((dir / "pw").string());
  CHECK(direct.username == "gearbox7");
  CHECK(direct.password == "pa:ss word");
  ::setenv("CREDENTIALS_DIRECTORY", dir.path().c_str(), 1);
  const auto credential = gearwatch::daemon::read_mqtt_credentials("pw");
  ::unsetenv("CREDENTIALS_DIRECTORY");
  CHECK(credential.password == "pa:ss word");
  std::ofstream(dir / "bad") << "no colon here\n";
  CHECK_THROWS_WITH(gearwatch::daemon::read_mqtt_credentials((dir / "bad").string()),
                    "mqtt.password_file " + (dir / "bad").string() + ": expected 'username:password' on its first line");
}

TEST_CASE("mqtt: the outbox keeps its limit by dropping the oldest undelivered messages, and counts them", "[mqtt][storage]") {
  TempDir dir("mqtt-outbox-limit");
  const auto db = dir / "o.db";
  gearwatch::storage::WriterOptions o;
  o.database = db.string();
  o.outbox = gearwatch::storage::OutboxIdentity{"plant1", "gb7", 100};
  {
    gearwatch::storage::StorageWriter w(o);
    w.start();
    w.submit(gearwatch::storage::RunStarted{"replay", "x", "", "", {}});
    for (std::uint64_t i = 0; i < 130; ++i) {
      gearwatch::storage::HealthSnapshot h;
      h[gearwatch::storage::HealthCounter::frames] = i;
      w.submit(h);
    }
    w.stop();
  }
  const auto rows = outbox_rows(db);
  REQUIRE(rows.size() == 100);
  // The newest 100 snapshots are kept: frames 30 .. 129, in order.
  for (std::size_t i = 0; i < rows.size(); ++i) CHECK(json::parse(rows[i].payload).at("counters").at("frames") == 30 + i);
  CHECK(scalar(db, "SELECT value FROM outbox_counters WHERE name = 'dropped'") == 30);
  gearwatch::storage::Database d(db.string(), Database::Mode::read_write);
  gearwatch::storage::OutboxReader reader(d);
  CHECK(reader.dropped() == 30);
  CHECK(reader.undelivered_count() == 100);
  const auto first = reader.undelivered_after(0, 3);
  REQUIRE(first.size() == 3);
  reader.mark_delivered({first[0].id, first[1].id});
  CHECK(reader.undelivered_count() == 98);
  CHECK(reader.undelivered_after(0, 1).at(0).id == first[2].id);
}

TEST_CASE("mqtt: a schema 11 outbox migrates to the current schema, and a refused row is kept, never sent again and counted once", "[mqtt][storage]") {
  TempDir dir("mqtt-outbox-migration");
  const auto path = dir / "v11.db";
  {
    Database d(path.string(), Database::Mode::read_write_create);
    gearwatch::storage::migrate_to_version(d, 11);
    REQUIRE(d.user_version() == 11);
    // As a schema 11 daemon left it: row 1 delivered, rows 2, 3 and 4 waiting.
    Statement add(d, "INSERT INTO outbox(id, topic, payload, delivered_at) VALUES (?, 'health', '{}', ?)");
    add.bind(1, 1).bind(2, "2026-01-01T00:00:00.000Z").run();
    for (int id : {2, 3, 4}) add.bind(1, id).bind_null(2).run();
  }
  Database d(path.string(), Database::Mode::read_write);
  gearwatch::storage::open_and_migrate(d);
  CHECK(d.user_version() == gearwatch::storage::current_schema_version());
  CHECK(scalar(path, "SELECT count(*) FROM outbox") == 4);
  // Version 15: the publisher's own counters, the same mqtt_* columns as health_snapshots'.
  CHECK(scalar(path, "SELECT count(*) FROM pragma_table_info('publisher_health') p JOIN pragma_table_info('health_snapshots') h"
                     " ON p.name = h.name WHERE p.name LIKE 'mqtt_%'") == 11);
  CHECK(scalar(path, "SELECT count(*) FROM pragma_table_info('health_snapshots') WHERE name = 'mqtt_publish_refused'") == 1);
  // Version 13: the resend counters.
  CHECK(scalar(path, "SELECT count(*) FROM pragma_table_info('health_snapshots') WHERE name IN "
                     "('mqtt_resend_requests', 'mqtt_resent', 'mqtt_resend_gone', 'mqtt_resend_ignored')") == 4);
  CHECK(scalar(path, "SELECT count(*) FROM outbox WHERE refused_at IS NOT NULL OR refused_reason IS NOT NULL") == 0);
  gearwatch::storage::OutboxReader reader(d);
  CHECK(reader.refused() == 0);
  CHECK(reader.undelivered_count() == 3);
  const auto ids_waiting = [&] {
    std::vector<std::int64_t> ids;
    for (const auto& m : reader.undelivered_after(0, 10)) ids.push_back(m.id);
    return ids;
  };
  CHECK(ids_waiting() == std::vector<std::int64_t>{2, 3, 4});
  reader.mark_refused({{3, "0x87 Not authorized"}});
  reader.mark_refused({{3, "0x87 Not authorized"}, {1, "0x87 Not authorized"}});  // again, and a delivered row: no effect
  reader.mark_delivered({3});                                                       // a refused row stays refused
  CHECK(reader.refused() == 1);
  CHECK(reader.undelivered_count() == 2);
  CHECK(ids_waiting() == std::vector<std::int64_t>{2, 4});
  CHECK(ids_of(path, "SELECT id FROM outbox WHERE refused_reason = '0x87 Not authorized' AND refused_at IS NOT NULL "
                     "AND delivered_at IS NULL") == std::vector<std::int64_t>{3});
  CHECK(ids_of(path, "SELECT id FROM outbox WHERE delivered_at IS NOT NULL") == std::vector<std::int64_t>{1});
}

TEST_CASE("mqtt: a resend finds the rows it holds and names the ids it cannot serve with why", "[mqtt][storage]") {
  // Rows 1..12 as a daemon leaves them (written directly, so every state is known): 3 and 4 pruned,
  // 7 refused, 9 waiting, the others delivered.
  TempDir dir("mqtt-outbox-resend");
  const auto path = dir / "r.db";
  Database d(path.string(), Database::Mode::read_write_create);
  gearwatch::storage::open_and_migrate(d);
  {
    Statement add(d, "INSERT INTO outbox(id, topic, payload, delivered_at, refused_at, refused_reason) VALUES (?, 'record', ?, ?, ?, ?)");
    for (int id = 1; id <= 12; ++id) {
      if (id == 3 || id == 4) continue;
      add.bind(1, id).bind(2, "{\"message_id\":" + std::to_string(id) + "}");
      if (id == 9) add.bind_null(3);
      else add.bind(3, "2026-01-01T00:00:00.000Z");
      if (id == 7) add.bind(4, "2026-01-01T00:00:00.000Z").bind(5, "0x87 Not authorized");
      else add.bind_null(4).bind_null(5);
      add.run();
    }
  }
  gearwatch::storage::OutboxReader reader(d);
  CHECK(reader.newest_id() == 12);
  CHECK(reader.delivered_through() == 8);  // 9 still waits
  const auto found = reader.resend({{2, 8}, {10, 12}}, 100);
  std::vector<std::int64_t> ids;
  for (const auto& m : found.rows) ids.push_back(m.id);
  CHECK(ids == std::vector<std::int64_t>{2, 5, 6, 8, 10, 11, 12});
  REQUIRE(found.gone.size() == 2);
  CHECK(found.gone[0].from == 3);
  CHECK(found.gone[0].to == 4);
  CHECK(found.gone[0].reason == gearwatch::storage::OutboxGoneReason::not_held);
  CHECK(found.gone[1].from == 7);
  CHECK(found.gone[1].to == 7);
  CHECK(found.gone[1].reason == gearwatch::storage::OutboxGoneReason::refused);
  CHECK(found.rows.front().payload == "{\"message_id\":2}");
  // The row limit bounds what one pass reads; the gone runs are all named whatever the limit.
  const auto two = reader.resend({{1, 12}}, 2);
  CHECK(two.rows.size() == 2);
  CHECK(two.rows.back().id == 2);
  CHECK(two.gone.size() == 2);
  // A range wholly beyond what is kept (pruned below row 1 here: none) and a range of one held id.
  CHECK(reader.resend({{9, 9}}, 10).rows.size() == 1);
  CHECK(reader.resend({{9, 9}}, 10).gone.empty());
}

TEST_CASE("mqtt: a resend request is read only when it names this gearbox with well-formed ranges", "[mqtt]") {
  gearwatch::config::MqttSettings self;
  self.site = "plant1";
  self.gearbox = "gbA";
  using gearwatch::daemon::ResendIgnored;
  const auto ok = gearwatch::daemon::parse_resend_request(self, R"({"site":"plant1","gearbox":"gbA","ranges":[[3,5],[9,9]]})");
  CHECK(!ok.ignored);
  CHECK(ok.ranges == std::vector<std::pair<std::int64_t, std::int64_t>>{{3, 5}, {9, 9}});
  auto why = [&](const std::string& payload) { return gearwatch::daemon::parse_resend_request(self, payload).ignored; };
  CHECK(why(R"({"site":"plant1","gearbox":"gbB","ranges":[[3,5]]})") == ResendIgnored::other_gearbox);
  CHECK(why(R"({"site":"plant2","gearbox":"gbA","ranges":[[3,5]]})") == ResendIgnored::other_gearbox);
  CHECK(why("not json") == ResendIgnored::malformed);
  CHECK(why(R"([1,2])") == ResendIgnored::malformed);
  CHECK(why(R"({"site":"plant1","gearbox":"gbA"})") == ResendIgnored::malformed);
  CHECK(why(R"({"site":"plant1","gearbox":"gbA","ranges":[[5,3]]})") == ResendIgnored::malformed);
  CHECK(why(R"({"site":"plant1","gearbox":"gbA","ranges":[[0,3]]})") == ResendIgnored::malformed);
  CHECK(why(R"({"site":"plant1","gearbox":"gbA","ranges":[[1,"3"]]})") == ResendIgnored::malformed);
  CHECK(why(R"({"site":"plant1","gearbox":"gbA","ranges":[[1,2,3]]})") == ResendIgnored::malformed);
}

TEST_CASE("mqtt: with sender = publisher the daemon only fills the outbox and gearwatch publish delivers it in order with its own counters", "[mqtt]") {
  Setup s;
  std::ofstream(s.config, std::ios::app) << "sender = \"publisher\"\n";
  s.broker.start();
  MqttSubscriber sub(s.broker.port(), kUser, kPassword, "gw/#");
  // The publisher comes up before the daemon has created the database, and waits for it.
  const pid_t publisher = spawn({"publish", "--config", s.config.string(), "--db", s.db.string()}, s.dir / "out-pub",
                                s.dir / "err-pub");
  const pid_t replay = s.start_replay("p");
  REQUIRE(wait_bounded(replay, 120s) == 0);
  // The daemon sent nothing itself: its counters stay 0, and every row is the publisher's to deliver.
  CHECK(scalar(s.db, "SELECT mqtt_published + mqtt_connects FROM health_snapshots WHERE final = 1 ORDER BY id DESC LIMIT 1") == 0);
  REQUIRE(wait_until([&] { return scalar(s.db, "SELECT count(*) FROM outbox WHERE delivered_at IS NULL") == 0; }, 30s));

  // A second publisher on the same database is refused in one line: every message would go twice.
  const auto second = run_command(std::string(GEARWATCH_BINARY) + " publish --config " + s.config.string() + " --db " + s.db.string());
  CHECK(second.status == 1);
  CHECK(second.err.find("gearwatch: another `gearwatch publish` (pid " + std::to_string(publisher) + ") delivers") == 0);
  CHECK(std::count(second.err.begin(), second.err.end(), '\n') == 1);

  ::kill(publisher, SIGTERM);
  REQUIRE(wait_bounded(publisher, 30s) == 0);
  check_delivered_in_order(s.db, sub);
  // Its counters: one session, every outbox row delivered once, the last row final.
  const auto rows = static_cast<std::int64_t>(outbox_rows(s.db).size());
  CHECK(scalar(s.db, "SELECT final FROM mqtt_publisher") == 1);
  CHECK(scalar(s.db, "SELECT mqtt_connects FROM mqtt_publisher") == 1);
  CHECK(scalar(s.db, "SELECT mqtt_delivered FROM mqtt_publisher") == rows);
  CHECK(scalar(s.db, "SELECT mqtt_published FROM mqtt_publisher") == rows);
  // The retained status is the publisher's: online while it ran, offline when it stopped.
  const auto states = status_states(sub);
  REQUIRE(states.size() >= 2);
  CHECK(states.front() == "online");
  CHECK(states.back() == "offline");
}

TEST_CASE("mqtt: gearwatch publish refuses a config whose daemon sends itself or that has mqtt off", "[mqtt]") {
  TempDir dir("mqtt-publish-refusals");
  const auto refused = [&](const std::string& toml) {
    std::ofstream(dir / "c.toml") << toml;
    return run_command(std::string(GEARWATCH_BINARY) + " publish --config " + (dir / "c.toml").string() + " --db " + (dir / "gw.db").string());
  };
  const auto daemon_sends = refused("[mqtt]\nenabled = true\n");
  CHECK(daemon_sends.status == 1);
  CHECK(daemon_sends.err == "gearwatch: [mqtt] sender = \"daemon\": the daemon delivers the outbox itself; set sender = \"publisher\" for `gearwatch publish`\n");
  const auto off = refused("[mqtt]\nsender = \"publisher\"\n");
  CHECK(off.status == 1);
  CHECK(off.err == "gearwatch: [mqtt] enabled = false: there is nothing to publish\n");
  const auto typo = refused("[mqtt]\nenabled = true\nsender = \"publish\"\n");
  CHECK(typo.status != 0);
  CHECK(typo.err.find("expected daemon or publisher") != std::string::npos);
  CHECK_FALSE(fs::exists(dir / "gw.db"));  // none of them created a database
}
