// `gearwatch fleet ingest --broker mqtt[s]://HOST[:PORT] --database postgresql://… [--prefix P]
//  [--client-id ID] [--password-file F] [--ca-file F [--cert-file F --key-file F]]
//  [--gearbox SITE/NAME]... [--log-level L]` and
// `gearwatch fleet report --database postgresql://… --out DIR [--indicator NAME] [--channel N]
//  [--points N]` (docs/fleet.md).
#include <pthread.h>
#include <signal.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fleet_consumer.hpp"
#include "gearwatch/report/fleet_page.hpp"
#include "gearwatch/report/report_page.hpp"
#include "gearwatch/storage/fleet_overview.hpp"
#include "logging.hpp"

namespace gearwatch::cli {

namespace {

struct BrokerAddress {
  std::string host;
  int port = 1883;
  bool tls = false;
};

// mqtt://HOST[:PORT] (1883) or mqtts://HOST[:PORT] (TLS, 8883).
BrokerAddress parse_broker(const std::string& url) {
  const std::string usage = "--broker " + url + ": expected mqtt://HOST[:PORT] or mqtts://HOST[:PORT]";
  BrokerAddress a;
  std::string rest;
  if (url.rfind("mqtt://", 0) == 0) {
    rest = url.substr(7);
  } else if (url.rfind("mqtts://", 0) == 0) {
    rest = url.substr(8);
    a.tls = true;
    a.port = 8883;
  } else {
    throw CommandError(usage, 64);
  }
  if (!rest.empty() && rest.back() == '/') rest.pop_back();
  const auto colon = rest.rfind(':');
  a.host = rest.substr(0, colon);
  if (colon != std::string::npos) {
    const std::string port = rest.substr(colon + 1);
    try {
      std::size_t used = 0;
      a.port = std::stoi(port, &used);
      if (used != port.size() || a.port < 1 || a.port > 65535) throw std::out_of_range(port);
    } catch (const std::exception&) {
      throw CommandError("--broker " + url + ": port '" + port + "' is not 1..65535", 64);
    }
  }
  if (a.host.empty() || a.host.find('/') != std::string::npos) throw CommandError(usage, 64);
  return a;
}

// Blocked before any thread starts, so every thread inherits the mask and only sigwait sees them.
sigset_t stop_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  return set;
}

int wait_for_stop_signal(const sigset_t& set) {
  int signal = 0;
  sigwait(&set, &signal);
  return signal;
}

struct IngestOptions {
  std::string broker, database, prefix = "gearwatch", client_id = "gearwatch-fleet", password_file, log_level = "info";
  std::string ca_file, cert_file, key_file;
  std::vector<std::string> gearboxes;
  double resend_interval_s = 60;
  std::int64_t resend_give_up_s = 7 * 24 * 3600;
};

void add_ingest_options(CLI::App* cmd, IngestOptions& o) {
  cmd->add_option("--broker", o.broker, "MQTT broker: mqtt://HOST[:PORT] (port 1883) or mqtts://HOST[:PORT] (TLS, port 8883)")->required();
  cmd->add_option("--database", o.database, "PostgreSQL: a postgresql:// URI or a libpq connection string")->required();
  cmd->add_option("--prefix", o.prefix, "Topic prefix the gearboxes publish under (mqtt.prefix)")->capture_default_str();
  cmd->add_option("--client-id", o.client_id,
                  "MQTT client id of the persistent session: keep it, so a restarted consumer gets what arrived while it was away")->capture_default_str();
  cmd->add_option("--password-file", o.password_file,
                  "File whose first line is username:password (a relative name is read from $CREDENTIALS_DIRECTORY)");
  cmd->add_option("--ca-file", o.ca_file, "TLS: the CA certificate that signed the broker's (needed by mqtts://)")->check(CLI::ExistingFile);
  cmd->add_option("--cert-file", o.cert_file, "TLS: this consumer's client certificate (with --key-file)")->check(CLI::ExistingFile);
  cmd->add_option("--key-file", o.key_file, "TLS: the client certificate's private key (with --cert-file)")->check(CLI::ExistingFile);
  cmd->add_option("--gearbox", o.gearboxes, "Accept only these gearboxes, SITE/NAME (repeatable); without it, every gearbox");
  cmd->add_option("--resend-interval-s", o.resend_interval_s,
                  "How often, while caught up, missing message ids are looked for and asked for again")
      ->capture_default_str()->check(CLI::Range(0.1, 86400.0));
  cmd->add_option("--resend-give-up-s", o.resend_give_up_s,
                  "Missing ids asked for this long without an answer are recorded lost (no_answer); the default is how long "
                  "the broker keeps a stopped daemon's session")
      ->capture_default_str()->check(CLI::Range(std::int64_t{1}, std::int64_t{365} * 24 * 3600));
  cmd->add_option("--log-level", o.log_level, "spdlog level: trace, debug, info, warn, error")->capture_default_str()
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
}

// The command line's words as the consumer's settings; a malformed one is a CommandError (exit 64).
daemon::FleetIngestSettings ingest_settings(const IngestOptions& o) {
  daemon::FleetIngestSettings s;
  const auto broker = parse_broker(o.broker);
  s.host = broker.host;
  s.port = broker.port;
  if (broker.tls != !o.ca_file.empty())
    throw CommandError(broker.tls ? "--broker " + o.broker + ": mqtts:// needs --ca-file" : "--ca-file needs an mqtts:// broker", 64);
  if (o.cert_file.empty() != o.key_file.empty()) throw CommandError("--cert-file and --key-file go together", 64);
  s.ca_file = o.ca_file;
  s.cert_file = o.cert_file;
  s.key_file = o.key_file;
  s.database = o.database;
  s.client_id = o.client_id;
  s.accept.prefix = o.prefix;
  s.resend_interval = std::chrono::milliseconds(static_cast<std::int64_t>(o.resend_interval_s * 1000));
  s.resend_give_up = std::chrono::seconds(o.resend_give_up_s);
  // The kill -9 test's hook (docs/fleet.md): only this command reads it.
  if (const char* stall = std::getenv("GEARWATCH_FLEET_TEST_STALL_AFTER"); stall && *stall) s.stall_after = std::stoull(stall);
  for (const auto& g : o.gearboxes) {
    const auto slash = g.find('/');
    if (slash == std::string::npos || slash == 0 || slash + 1 == g.size() || g.find('/', slash + 1) != std::string::npos)
      throw CommandError("--gearbox " + g + ": expected SITE/NAME", 64);
    s.accept.gearboxes.insert(g);
  }
  if (!o.password_file.empty()) {
    try {
      s.credentials = daemon::read_mqtt_credentials(o.password_file);
    } catch (const std::exception& e) {
      throw CommandError(e.what());
    }
  }
  return s;
}

// Runs the consumer until SIGINT or SIGTERM.
void run_ingest(const daemon::FleetIngestSettings& s) {
  const sigset_t signals = stop_signals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  daemon::FleetConsumer consumer(s);
  try {
    consumer.start();
  } catch (const storage::fleet::FleetConnectionError& e) {
    throw CommandError(e.what());
  } catch (const storage::fleet::FleetRefusedError& e) {
    throw CommandError(std::string("fleet database: ") + e.what());
  } catch (const std::runtime_error& e) {
    throw CommandError(e.what());
  }
  spdlog::info("fleet: ingesting {}/# from {}:{}{} into the fleet database (schema version {})", s.accept.prefix, s.host, s.port,
               s.ca_file.empty() ? "" : " over TLS",
               storage::fleet::current_fleet_schema_version());
  const int signal = wait_for_stop_signal(signals);
  spdlog::info("fleet: {} received, stopping", signal == SIGINT ? "SIGINT" : "SIGTERM");
  consumer.stop();
  spdlog::info("fleet: {}", daemon::to_string(consumer.counters()));
}

void add_ingest_command(CLI::App* fleet_cmd) {
  auto opt = std::make_shared<IngestOptions>();
  auto* cmd = fleet_cmd->add_subcommand("ingest", "Subscribe to every gearbox under the MQTT prefix and store into PostgreSQL, until SIGINT or SIGTERM");
  add_ingest_options(cmd, *opt);
  cmd->callback([opt] {
    logging::setup(logging::running_under_journald() ? logging::Sink::journald : logging::Sink::stderr_only, opt->log_level);
    run_ingest(ingest_settings(*opt));
  });
}

// A connection as the page may show it: a URI's password and a key=value string's password= removed.
std::string without_password(const std::string& connection) {
  std::string out = connection;
  const auto scheme = out.find("://");
  if (scheme != std::string::npos) {
    const auto at = out.find('@', scheme + 3);
    const auto colon = out.find(':', scheme + 3);
    if (at != std::string::npos && colon != std::string::npos && colon < at) out.erase(colon, at - colon);
  }
  for (auto key = out.find("password="); key != std::string::npos; key = out.find("password=")) {
    auto end = out.find_first_of(" &", key);
    if (end == std::string::npos) end = out.size();
    else ++end;
    out.erase(key, end - key);
  }
  while (!out.empty() && (out.back() == ' ' || out.back() == '&' || out.back() == '?')) out.pop_back();
  return out;
}

void add_report_command(CLI::App* fleet_cmd) {
  struct Options {
    std::string database, out;
    storage::fleet::OverviewRequest trend;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = fleet_cmd->add_subcommand("report", "Write the fleet page: every gearbox with its verdict, active alerts, remaining life and a trend, worst first");
  cmd->add_option("--database", opt->database, "PostgreSQL: a postgresql:// URI or a libpq connection string")->required();
  cmd->add_option("--out", opt->out, "Output directory of the page, DIR/index.html (created if missing)")->required();
  cmd->add_option("--indicator", opt->trend.trend_indicator, "Indicator of the trend column (names in docs/dsp.md)")->capture_default_str();
  cmd->add_option("--channel", opt->trend.trend_channel, "Channel of the trend column")->capture_default_str()->check(CLI::NonNegativeNumber);
  cmd->add_option("--points", opt->trend.trend_points, "Newest records in the trend column")->capture_default_str()->check(CLI::Range(2, 10000));
  cmd->callback([opt] {
    report::FleetPageData data;
    data.database = without_password(opt->database);
    data.generated_at = report::utc_now_iso8601();
    data.trend = opt->trend;
    try {
      data.gearboxes = storage::fleet::load_fleet_overview(opt->database, opt->trend);
    } catch (const storage::fleet::FleetConnectionError& e) {
      throw CommandError(e.what());
    } catch (const storage::fleet::FleetRefusedError& e) {
      throw CommandError(e.what());
    }
    write_page(opt->out, report::render_fleet_page_html(data));
    std::cout << "wrote " << (std::filesystem::path(opt->out) / "index.html").string() << ": " << data.gearboxes.size()
              << " gearboxes, worst first\n";
  });
}

}  // namespace

void register_fleet(CLI::App& app) {
  auto* fleet_cmd = app.add_subcommand("fleet", "The plant's view: every gearbox's published messages in PostgreSQL");
  fleet_cmd->require_subcommand(1);
  add_ingest_command(fleet_cmd);
  add_report_command(fleet_cmd);
}

}  // namespace gearwatch::cli
