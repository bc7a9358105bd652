// Fleet scale on one box (docs/fleet.md, "Scale"): N simulated gearboxes each publish one record
// message a second (a plant's rate is one every ~100 s: this is ~100x) through one mosquitto into one
// `gearwatch fleet ingest` and one PostgreSQL, all on this machine, started here on 127.0.0.1.
//   bench_fleet [--gearboxes 10,30,100] [--seconds 30]
// Per N: the rate offered and stored, the end-to-end lag (published -> in its database
// transaction) p50/p99, how long the backlog took to drain after the publishers stopped, and each
// part's resident memory at the end. The publishers are libmosquitto clients in this process (QoS 1,
// the record topic's JSON schema, docs/mqtt/record.schema.json): the daemons' own path to the
// broker is measured in the MQTT tests, not here.
#include <mosquitto.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "fleet/postgres_server.hpp"
#include "gearwatch/storage/fleet_overview.hpp"
#include "mqtt/mqtt_broker.hpp"
#include "temp_dir.hpp"

namespace {

using namespace gearwatch::testing;
using Clock = std::chrono::system_clock;

std::string iso_ms(Clock::time_point t) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count();
  const std::time_t s = static_cast<std::time_t>(ms / 1000);
  std::tm tm{};
  gmtime_r(&s, &tm);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min,
                tm.tm_sec, static_cast<int>(ms % 1000));
  return buf;
}

// One record message as a daemon publishes it: two channels of 20 indicators each.
std::string record_payload(const std::string& gearbox, long id, Clock::time_point now) {
  std::ostringstream o;
  o << R"({"gearbox":")" << gearbox << R"(","site":"bench","message_id":)" << id << R"(,"topic":"record","record_id":)" << id
    << R"(,"record_time":")" << iso_ms(now) << R"(","stream_sequence":1,"start_index":)" << id * 1000000
    << R"(,"duration_s":10.0,"analysed":true,"reject_reason":"","speed_hz":25.0,"torque_nm":20.0,"input_revolutions":)" << id * 250
    << R"(,"channels":[)";
  for (int c = 0; c < 2; ++c) {
    o << (c ? "," : "") << R"({"channel":)" << c << R"(,"indicators":{)";
    for (int i = 0; i < 20; ++i) o << (i ? "," : "") << "\"indicator_" << i << "\":" << 1.0 + 0.001 * (id % 97) + i;
    o << R"(},"skipped":[]})";
  }
  o << "]}";
  return o.str();
}

long rss_kib_of(const std::string& process_name) {
  const auto r = run_command("ps -o rss= -C " + process_name);
  long sum = 0;
  std::istringstream in(r.out);
  for (long v; in >> v;) sum += v;
  return sum;
}

struct Publishers {
  std::vector<mosquitto*> clients;
  Publishers(int n, int port, const std::string& user, const std::string& password, const std::string& tag) {
    for (int g = 0; g < n; ++g) {
      auto* c = mosquitto_new(("bench-" + tag + "-" + std::to_string(g)).c_str(), true, nullptr);
      mosquitto_username_pw_set(c, user.c_str(), password.c_str());
      mosquitto_max_inflight_messages_set(c, 100);
      if (mosquitto_connect(c, "127.0.0.1", port, 30) != MOSQ_ERR_SUCCESS) throw std::runtime_error("publisher cannot connect");
      mosquitto_loop_start(c);
      clients.push_back(c);
    }
  }
  ~Publishers() {
    for (auto* c : clients) {
      mosquitto_disconnect(c);
      mosquitto_loop_stop(c, false);
      mosquitto_destroy(c);
    }
  }
};

struct Row {
  int gearboxes = 0;
  double offered = 0, stored_in_window = 0, p50 = 0, p99 = 0, drain_s = 0;
  long expected = 0, stored = 0, consumer_kib = 0, broker_kib = 0, postgres_kib = 0;
};

long count_stored(const std::string& uri) {
  const auto lag = gearwatch::storage::fleet::load_arrival_lag(uri);
  return lag ? static_cast<long>(lag->messages) : -1;
}

Row run_one(int n, int seconds, MosquittoBroker& broker, PostgresServer& pg, const TempDir& dir) {
  const std::string db = "fleet" + std::to_string(n), prefix = "bench" + std::to_string(n);
  pg.create_database(db);
  const std::string uri = pg.uri(db);
  std::ofstream(dir / "credentials") << "bench:bench-pw\n";
  const pid_t consumer = spawn({"fleet", "ingest", "--broker", "mqtt://127.0.0.1:" + std::to_string(broker.port()), "--database", uri, "--prefix",
                                prefix, "--client-id", "bench-consumer-" + std::to_string(n), "--password-file", (dir / "credentials").string(),
                                "--log-level", "warn"},
                               dir / ("consumer-" + std::to_string(n) + ".out"), dir / ("consumer-" + std::to_string(n) + ".err"));
  if (!wait_until([&] { return count_stored(uri) >= 0; }, std::chrono::seconds(30))) throw std::runtime_error("the consumer made no schema");
  std::this_thread::sleep_for(std::chrono::seconds(1));  // its subscription
  Row row;
  row.gearboxes = n;
  {
    Publishers pub(n, broker.port(), "bench", "bench-pw", std::to_string(n));
    const auto start = std::chrono::steady_clock::now();
    for (int s = 0; s < seconds; ++s) {
      for (int g = 0; g < n; ++g) {
        const std::string gearbox = "gb" + std::to_string(g), topic = prefix + "/bench/" + gearbox + "/record";
        const std::string payload = record_payload(gearbox, s + 1, Clock::now());
        mosquitto_publish(pub.clients[static_cast<std::size_t>(g)], nullptr, topic.c_str(), static_cast<int>(payload.size()), payload.data(), 1, false);
      }
      std::this_thread::sleep_until(start + std::chrono::seconds(s + 1));
    }
    row.expected = static_cast<long>(n) * seconds;
    const long at_end = count_stored(uri);
    row.stored_in_window = static_cast<double>(at_end) / seconds;
    const auto drain_start = std::chrono::steady_clock::now();
    wait_until([&] { return count_stored(uri) >= row.expected; }, std::chrono::seconds(180));
    row.drain_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - drain_start).count();
  }
  row.offered = n;
  row.consumer_kib = std::stol("0" + run_command("ps -o rss= -p " + std::to_string(consumer)).out);
  row.broker_kib = rss_kib_of("mosquitto");
  row.postgres_kib = rss_kib_of("postgres");
  ::kill(consumer, SIGTERM);
  wait_exit(consumer);
  const auto lag = gearwatch::storage::fleet::load_arrival_lag(uri).value();
  row.stored = static_cast<long>(lag.messages);
  row.p50 = lag.p50_s.value_or(0);
  row.p99 = lag.p99_s.value_or(0);
  return row;
}

std::vector<int> parse_list(const std::string& text) {
  std::vector<int> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) out.push_back(std::stoi(item));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> sizes{10, 30, 100};
  int seconds = 30;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--gearboxes") sizes = parse_list(argv[i + 1]);
    else if (a == "--seconds") seconds = std::stoi(argv[i + 1]);
    else {
      std::cerr << "usage: bench_fleet [--gearboxes 10,30,100] [--seconds 30]\n";
      return 2;
    }
  }
  const auto bin = postgres_bin_dir();
  if (!bin) {
    std::cerr << "bench_fleet: no PostgreSQL server binaries under /usr/lib/postgresql/*/bin\n";
    return 77;
  }
  mosquitto_lib_init();
  TempDir dir{"bench-fleet"};
  MosquittoBroker broker(dir / "broker", "bench", "bench-pw");
  broker.start();
  PostgresServer pg(dir / "pg", *bin);
  pg.start();
  std::printf("| gearboxes | offered msg/s | stored msg/s while publishing | stored / expected | lag p50 s | lag p99 s | drain after stop s | "
              "consumer RSS MiB | mosquitto RSS MiB | PostgreSQL RSS MiB (all processes) |\n|---|---|---|---|---|---|---|---|---|---|\n");
  Row last;
  for (const int n : sizes) {
    const Row r = run_one(n, seconds, broker, pg, dir);
    last = r;
    std::printf("| %d | %.0f | %.1f | %ld / %ld | %.3f | %.3f | %.1f | %.1f | %.1f | %.1f |\n", r.gearboxes, r.offered, r.stored_in_window,
                r.stored, r.expected, r.p50, r.p99, r.drain_s, r.consumer_kib / 1024.0, r.broker_kib / 1024.0, r.postgres_kib / 1024.0);
    std::fflush(stdout);
  }
  mosquitto_lib_cleanup();
  // Sustained: everything published stored, and the backlog at the publishers' stop gone within 2 s.
  const bool met = last.stored == last.expected && last.drain_s <= 2.0;
  std::printf("BENCH name=fleet_drain_after_stop_%d_gearboxes figure=%.2f unit=s target=2 cmp=le met=%d\n", last.gearboxes, last.drain_s,
              met ? 1 : 0);
  return 0;
}
