#include "mqtt_sender.hpp"

#include <mosquitto.h>
#include <mqtt_protocol.h>

#include <cerrno>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "gearwatch/storage/alert_history.hpp"
#include "gearwatch/storage/schema.hpp"
#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::daemon {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int kQos = 1;
constexpr auto kConnackWait = std::chrono::seconds(10);
constexpr auto kDropCheckInterval = std::chrono::seconds(1);
constexpr auto kRefusalLogInterval = std::chrono::seconds(60);
// The broker keeps this daemon's session (its resend subscription and the requests sent to it)
// this long while the daemon is away: a week of downtime is served when it comes back.
constexpr int kSessionExpiryS = 7 * 24 * 3600;
// Rows read for one pass of resend requests (memory bound); the consumer asks again for the rest.
constexpr std::size_t kResendRows = 5000;
constexpr auto kSubackWait = std::chrono::seconds(2);
// MQTT 5: a PUBACK reason code of 0x80 or more says the broker did not accept the message.
constexpr int kFirstFailureReason = 0x80;

std::string reason_text(int rc) {
  char hex[8];
  std::snprintf(hex, sizeof hex, "0x%02x", rc);
  return std::string(hex) + " " + mosquitto_reason_string(rc);
}

std::string client_id_of(const config::MqttSettings& s) {
  return s.client_id.empty() ? "gearwatch-" + s.site + "-" + s.gearbox : s.client_id;
}

// delivered_through: every message id up to it has had its answer from the broker, so a consumer
// also sees a missing tail as a hole (and not what is still on its way).
std::string status_payload(const config::MqttSettings& s, bool online, std::int64_t delivered_through) {
  return nlohmann::json{{"gearbox", s.gearbox}, {"site", s.site}, {"state", online ? "online" : "offline"},
                        {"version", GEARWATCH_APP_VERSION}, {"schema", storage::current_schema_version()},
                        {"delivered_through", delivered_through}}
      .dump();
}

void init_library_once() {
  static std::once_flag once;
  std::call_once(once, [] { mosquitto_lib_init(); });
}

}  // namespace

void add_mqtt_counters(const MqttCounters& m, storage::HealthSnapshot& s) {
  using C = storage::HealthCounter;
  const auto load = [](const std::atomic<std::uint64_t>& v) { return v.load(std::memory_order_relaxed); };
  s[C::mqtt_published] = load(m.published);
  s[C::mqtt_delivered] = load(m.delivered);
  s[C::mqtt_connects] = load(m.connects);
  s[C::mqtt_connect_failures] = load(m.connect_failures);
  s[C::mqtt_refused] = load(m.refused);
  s[C::mqtt_outbox_dropped] = load(m.outbox_dropped);
  s[C::mqtt_publish_refused] = load(m.publish_refused);
  s[C::mqtt_resend_requests] = load(m.resend_requests);
  s[C::mqtt_resent] = load(m.resent);
  s[C::mqtt_resend_gone] = load(m.resend_gone);
  s[C::mqtt_resend_ignored] = load(m.resend_ignored);
}

const char* to_string(ResendIgnored why) noexcept {
  switch (why) {
    case ResendIgnored::malformed: return "malformed";
    case ResendIgnored::other_gearbox: return "other_gearbox";
    case ResendIgnored::never_sent: return "never_sent";
  }
  return "malformed";
}

ResendRequest parse_resend_request(const config::MqttSettings& self, const std::string& payload) {
  ResendRequest r;
  auto ignored = [&](ResendIgnored why, std::string detail) {
    r.ranges.clear();
    r.ignored = why;
    r.detail = std::move(detail);
    return r;
  };
  const auto j = nlohmann::json::parse(payload, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return ignored(ResendIgnored::malformed, "not a JSON object");
  const auto site = j.find("site"), gearbox = j.find("gearbox"), ranges = j.find("ranges");
  if (site == j.end() || gearbox == j.end() || !site->is_string() || !gearbox->is_string())
    return ignored(ResendIgnored::malformed, "'site' and 'gearbox' must be strings");
  if (*site != self.site || *gearbox != self.gearbox)
    return ignored(ResendIgnored::other_gearbox, "the request names " + site->get<std::string>() + "/" + gearbox->get<std::string>() +
                                                     ", this is " + self.site + "/" + self.gearbox);
  if (ranges == j.end() || !ranges->is_array()) return ignored(ResendIgnored::malformed, "'ranges' must be an array");
  for (const auto& range : *ranges) {
    if (!range.is_array() || range.size() != 2 || !range[0].is_number_integer() || !range[1].is_number_integer())
      return ignored(ResendIgnored::malformed, "each range must be [from, to], two integers");
    const auto from = range[0].get<std::int64_t>(), to = range[1].get<std::int64_t>();
    if (from < 1 || from > to) return ignored(ResendIgnored::malformed, "each range must have 1 <= from <= to");
    r.ranges.emplace_back(from, to);
  }
  return r;
}

MqttCredentials read_mqtt_credentials(const std::string& password_file) {
  std::filesystem::path path(password_file);
  const char* credentials_dir = std::getenv("CREDENTIALS_DIRECTORY");
  if (path.is_relative() && credentials_dir && *credentials_dir) path = std::filesystem::path(credentials_dir) / path;
  std::ifstream in(path);
  std::string line;
  if (!in || !std::getline(in, line))
    throw std::runtime_error("mqtt.password_file " + path.string() + ": cannot be read (expected 'username:password' on its first line)");
  while (!line.empty() && (line.back() == '\r' || line.back() == '\n')) line.pop_back();
  const auto colon = line.find(':');
  if (colon == std::string::npos || colon == 0)
    throw std::runtime_error("mqtt.password_file " + path.string() + ": expected 'username:password' on its first line");
  return {line.substr(0, colon), line.substr(colon + 1)};
}

std::string mqtt_topic(const config::MqttSettings& s, const std::string& kind) {
  return s.prefix + "/" + s.site + "/" + s.gearbox + "/" + kind;
}

// One connection to the broker: a fresh libmosquitto client, its in-flight messages and the rows
// acknowledged but not yet marked. Destroyed at the first disconnect.
struct MqttSender::Session {
  mosquitto* client = nullptr;
  int connack = -1;                           // -1: no CONNACK yet
  bool lost = false;
  struct Sent {
    std::int64_t row = 0;
    storage::OutboxTopic topic = storage::OutboxTopic::record;
  };
  std::map<int, Sent> inflight;               // message id -> outbox row
  std::vector<std::int64_t> acknowledged;     // rows PUBACKed, not yet marked delivered
  std::vector<storage::OutboxRefusal> refused;          // rows the broker refused, not yet marked
  std::set<storage::OutboxTopic> accepted_topics;       // of the rows in `acknowledged`
  std::set<storage::OutboxTopic> refused_topics;        // of the rows in `refused`
  std::int64_t last_sent = 0;                 // newest row published in this session
  std::vector<std::string> resend_requests;   // payloads on the resend topic, not yet taken
  std::deque<storage::OutboxMessage> resends;  // rows asked for again, not yet published
  bool subscribed = false;                    // SUBACK of the resend topic seen
  int status_mid = -1;
  bool status_acknowledged = false;
  ~Session() {
    if (client) mosquitto_destroy(client);
  }
};

MqttSender::MqttSender(config::MqttSettings settings, std::string database, storage::StorageWriter& writer)
    : settings_(std::move(settings)), database_(std::move(database)), writer_(writer) {}

MqttSender::~MqttSender() {
  if (thread_.joinable()) stop();
}

void MqttSender::start() {
  init_library_once();
  if (!settings_.password_file.empty()) credentials_ = read_mqtt_credentials(settings_.password_file);
  db_ = std::make_unique<storage::Database>(database_, storage::Database::Mode::read_write);
  alerts_ = AlertTracker(storage::load_alert_states(
      *db_, {AlertKind::mqtt_refused, AlertKind::mqtt_outbox_full, AlertKind::mqtt_publish_refused}));
  const AlertState* refusal = alerts_.state(AlertKey{AlertKind::mqtt_publish_refused, -1});
  clear_on_any_accept_ = refusal && refusal->active;
  dropped_seen_ = storage::OutboxReader(*db_).dropped();
  counters_.outbox_dropped = static_cast<std::uint64_t>(dropped_seen_);
  thread_ = std::thread([this] { run(); });
}

void MqttSender::settle() {
  const auto limit = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(settings_.drain_timeout_s));
  const auto deadline = Clock::now() + std::min<Clock::duration>(std::chrono::seconds(5), limit);
  // Idle for longer than one pass of the session loop (mosquitto_loop waits up to 50 ms).
  int idle_checks = 0;
  while (Clock::now() < deadline && phase_.load() != Phase::backing_off) {
    idle_checks = phase_.load() == Phase::connected && idle_.load() ? idle_checks + 1 : 0;
    if (idle_checks >= 5) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

void MqttSender::close_alerts() {
  std::lock_guard lock(mutex_);
  alerts_open_ = false;
}

void MqttSender::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    drain_deadline_ = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(settings_.drain_timeout_s));
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (const auto asked = counters_.resend_requests.load(), ignored = counters_.resend_ignored.load(); asked + ignored > 0)
    spdlog::warn("mqtt: resend requests this run: {} taken, {} messages sent again, {} ids named gone, {} ignored", asked,
                 counters_.resent.load(), counters_.resend_gone.load(), ignored);
  if (const auto refused = counters_.publish_refused.load(); refused > 0)
    spdlog::warn("mqtt: {} messages refused by the broker this run ({} since the database was made); they stay in the outbox marked refused",
                 refused, storage::OutboxReader(*db_).refused());
}

void MqttSender::run() {
  auto backoff = std::chrono::milliseconds(settings_.reconnect_initial_ms);
  for (;;) {
    try {
      Session session;
      phase_ = Phase::connecting;
      if (open_session(session)) {
        phase_ = Phase::connected;
        backoff = std::chrono::milliseconds(settings_.reconnect_initial_ms);
        run_session(session);
      }
      idle_ = false;
      phase_ = Phase::backing_off;
      if (drained(session)) return;
      check_dropped();
    } catch (const std::exception& e) {
      phase_ = Phase::backing_off;
      spdlog::error("mqtt: {} — retrying in {} ms", e.what(), backoff.count());
    }
    if (!wait_backoff(backoff)) {
      const auto left = storage::OutboxReader(*db_).undelivered_count();
      spdlog::warn("mqtt: stopping with {} messages undelivered; they stay in the outbox for the next start", left);
      return;
    }
    backoff = std::min(backoff * 2, std::chrono::milliseconds(settings_.reconnect_max_ms));
  }
}

bool MqttSender::open_session(Session& s) {
  s.client = mosquitto_new(client_id_of(settings_).c_str(), false, &s);
  if (!s.client) throw std::runtime_error("cannot create an MQTT client");
  // MQTT 5, for its PUBACK reason codes: under 3.1.1 a broker acknowledges a publish its ACL
  // denies like any other and drops it, and the sender would mark it delivered.
  mosquitto_int_option(s.client, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V5);
  if (!settings_.password_file.empty())
    mosquitto_username_pw_set(s.client, credentials_.username.c_str(), credentials_.password.c_str());
  if (!settings_.ca_file.empty()) {
    const char* cert = settings_.cert_file.empty() ? nullptr : settings_.cert_file.c_str();
    const char* key = settings_.key_file.empty() ? nullptr : settings_.key_file.c_str();
    if (const int rc = mosquitto_tls_set(s.client, settings_.ca_file.c_str(), nullptr, cert, key, nullptr); rc != MOSQ_ERR_SUCCESS)
      throw std::runtime_error("TLS files (mqtt.ca_file, cert_file, key_file): " + std::string(mosquitto_strerror(rc)));
  }
  const std::string offline = status_payload(settings_, false, storage::OutboxReader(*db_).delivered_through());
  const std::string status = mqtt_topic(settings_, "status");
  mosquitto_will_set(s.client, status.c_str(), static_cast<int>(offline.size()), offline.data(), kQos, true);
  mosquitto_connect_callback_set(s.client, [](mosquitto*, void* obj, int rc) { static_cast<Session*>(obj)->connack = rc; });
  mosquitto_disconnect_callback_set(s.client, [](mosquitto*, void* obj, int) { static_cast<Session*>(obj)->lost = true; });
  mosquitto_message_callback_set(s.client, [](mosquitto*, void* obj, const mosquitto_message* m) {
    static_cast<Session*>(obj)->resend_requests.emplace_back(static_cast<const char*>(m->payload), static_cast<std::size_t>(m->payloadlen));
  });
  mosquitto_publish_v5_callback_set(s.client, [](mosquitto*, void* obj, int mid, int reason, const mosquitto_property*) {
    auto* session = static_cast<Session*>(obj);
    if (mid == session->status_mid) session->status_acknowledged = true;
    const auto it = session->inflight.find(mid);
    if (it == session->inflight.end()) return;
    if (reason >= kFirstFailureReason) {
      session->refused.push_back({it->second.row, reason_text(reason)});
      session->refused_topics.insert(it->second.topic);
    } else {
      session->acknowledged.push_back(it->second.row);
      session->accepted_topics.insert(it->second.topic);
    }
    session->inflight.erase(it);
  });
  const std::string where = settings_.host + ":" + std::to_string(settings_.port);
  mosquitto_property* connect_properties = nullptr;
  mosquitto_property_add_int32(&connect_properties, MQTT_PROP_SESSION_EXPIRY_INTERVAL, kSessionExpiryS);
  const int connected = mosquitto_connect_bind_v5(s.client, settings_.host.c_str(), static_cast<int>(settings_.port),
                                                  static_cast<int>(settings_.keepalive_s), nullptr, connect_properties);
  mosquitto_property_free_all(&connect_properties);
  if (const int rc = connected; rc != MOSQ_ERR_SUCCESS) {
    if (counters_.connect_failures.fetch_add(1) % 20 == 0)
      spdlog::warn("mqtt: broker {} unreachable: {}; messages wait in the outbox", where, rc == MOSQ_ERR_ERRNO ? std::strerror(errno) : mosquitto_strerror(rc));
    return false;
  }
  const auto deadline = Clock::now() + kConnackWait;
  while (s.connack < 0 && !s.lost && Clock::now() < deadline)
    if (mosquitto_loop(s.client, 100, 1) != MOSQ_ERR_SUCCESS) s.lost = true;
  if (s.connack == 0) {
    on_accepted();
    // Subscribed again each session (harmless on a resumed one); a broker whose ACL denies it only
    // leaves this gearbox without resends.
    // The broker hands over what its session kept before the SUBACK: once it is here, requests
    // sent while the daemon was away are in hand, and a short run's stop cannot miss them.
    const std::string resend = mqtt_topic(settings_, "resend");
    mosquitto_subscribe_callback_set(s.client, [](mosquitto*, void* obj, int, int, const int*) { static_cast<Session*>(obj)->subscribed = true; });
    if (mosquitto_subscribe(s.client, nullptr, resend.c_str(), kQos) == MOSQ_ERR_SUCCESS) {
      const auto until = Clock::now() + kSubackWait;
      while (!s.subscribed && !s.lost && Clock::now() < until)
        if (mosquitto_loop(s.client, 50, 1) != MOSQ_ERR_SUCCESS) s.lost = true;
    }
    return true;
  }
  if (s.connack > 0) on_refusal(s.connack);
  else counters_.connect_failures.fetch_add(1);
  return false;
}

void MqttSender::run_session(Session& s) {
  publish_status(s, true);
  for (;;) {
    if (mosquitto_loop(s.client, 50, 1) != MOSQ_ERR_SUCCESS || s.lost) {
      mark_acknowledged(s);
      spdlog::warn("mqtt: connection to {}:{} lost with {} messages unacknowledged; they will be sent again", settings_.host,
                   settings_.port, s.inflight.size());
      return;
    }
    mark_acknowledged(s);
    take_resend_requests(s);
    fill_window(s);
    fill_resends(s);
    check_dropped();
    std::unique_lock lock(mutex_);
    if (!stopping_) continue;
    const bool past_deadline = Clock::now() >= drain_deadline_;
    lock.unlock();
    if (past_deadline || drained(s)) break;
  }
  publish_status(s, false);
  const auto deadline = Clock::now() + std::chrono::seconds(1);
  while (!s.status_acknowledged && !s.lost && Clock::now() < deadline)
    if (mosquitto_loop(s.client, 50, 1) != MOSQ_ERR_SUCCESS) break;
  mark_acknowledged(s);
  mosquitto_disconnect(s.client);
}

void MqttSender::fill_window(Session& s) {
  if (s.inflight.size() >= settings_.inflight) {
    idle_ = false;
    return;
  }
  storage::OutboxReader reader(*db_);
  const auto rows = reader.undelivered_after(s.last_sent, settings_.inflight - s.inflight.size());
  idle_ = rows.empty() && s.inflight.empty() && s.resends.empty();
  for (const auto& m : rows) {
    if (!publish_row(s, m)) return;  // the loop sees the disconnect; the row goes again in the next session
    s.last_sent = m.id;
  }
}

// One outbox row onto its topic, in flight until its PUBACK. False when the client could not send.
bool MqttSender::publish_row(Session& s, const storage::OutboxMessage& m) {
  int mid = 0;
  const std::string topic = mqtt_topic(settings_, storage::to_string(m.topic));
  if (mosquitto_publish(s.client, &mid, topic.c_str(), static_cast<int>(m.payload.size()), m.payload.data(), kQos, false) !=
      MOSQ_ERR_SUCCESS)
    return false;
  s.inflight[mid] = {m.id, m.topic};
  counters_.published.fetch_add(1, std::memory_order_relaxed);
  return true;
}

// The requests that arrived, merged: the part above the newest id was never sent (ignored,
// counted); of the rest, what the outbox cannot serve is named on resend_gone at once and the held
// rows (up to kResendRows a pass; the consumer asks again for the rest) wait for room in the window.
void MqttSender::take_resend_requests(Session& s) {
  if (s.resend_requests.empty()) return;
  std::vector<std::string> payloads;
  payloads.swap(s.resend_requests);
  storage::OutboxReader reader(*db_);
  const std::int64_t newest = reader.newest_id();
  std::map<std::int64_t, std::int64_t> wanted;  // from -> to, merged below
  for (const auto& payload : payloads) {
    const ResendRequest request = parse_resend_request(settings_, payload);
    if (request.ignored) {
      ignore_resend(*request.ignored, request.detail);
      continue;
    }
    counters_.resend_requests.fetch_add(1);
    for (auto [from, to] : request.ranges) {
      if (to > newest)
        ignore_resend(ResendIgnored::never_sent, "ids " + std::to_string(std::max(from, newest + 1)) + ".." + std::to_string(to) +
                                                     " were never sent (the newest is " + std::to_string(newest) + ")");
      to = std::min(to, newest);
      if (from <= to) wanted[from] = std::max(wanted[from], to);
    }
  }
  std::vector<std::pair<std::int64_t, std::int64_t>> merged;
  for (const auto& [from, to] : wanted) {
    if (!merged.empty() && from <= merged.back().second + 1) merged.back().second = std::max(merged.back().second, to);
    else merged.emplace_back(from, to);
  }
  if (merged.empty()) return;
  auto found = reader.resend(merged, kResendRows);
  if (!found.gone.empty()) publish_gone(s, found.gone);
  for (auto& m : found.rows) s.resends.push_back(std::move(m));
}

void MqttSender::publish_gone(Session& s, const std::vector<storage::OutboxGone>& gone) {
  nlohmann::json ranges = nlohmann::json::array();
  std::int64_t ids = 0;
  for (const auto& g : gone) {
    ranges.push_back({{"from", g.from}, {"to", g.to}, {"reason", storage::to_string(g.reason)}});
    ids += g.to - g.from + 1;
  }
  counters_.resend_gone.fetch_add(static_cast<std::uint64_t>(ids));
  const std::string payload = nlohmann::json{{"gearbox", settings_.gearbox}, {"site", settings_.site}, {"ranges", ranges}}.dump();
  const std::string topic = mqtt_topic(settings_, "resend_gone");
  spdlog::warn("mqtt: asked to send {} messages again that the outbox no longer holds or the broker refused; named on {}", ids, topic);
  mosquitto_publish(s.client, nullptr, topic.c_str(), static_cast<int>(payload.size()), payload.data(), kQos, false);
}

// Rows asked for again go out after the undelivered ones, in the room the window leaves.
void MqttSender::fill_resends(Session& s) {
  while (!s.resends.empty() && s.inflight.size() < settings_.inflight) {
    if (!publish_row(s, s.resends.front())) return;  // the loop sees the disconnect; the consumer asks again
    counters_.resent.fetch_add(1, std::memory_order_relaxed);
    s.resends.pop_front();
  }
}

void MqttSender::ignore_resend(ResendIgnored why, const std::string& detail) {
  counters_.resend_ignored.fetch_add(1);
  if (const auto now = Clock::now(); now >= next_ignored_log_) {
    spdlog::error("mqtt: ignored a resend request on {}: {}: {} ({} ignored this run)", mqtt_topic(settings_, "resend"), to_string(why),
                  detail, counters_.resend_ignored.load());
    next_ignored_log_ = now + kRefusalLogInterval;
  }
}

void MqttSender::mark_acknowledged(Session& s) {
  on_publish_refusals(s);
  if (s.acknowledged.empty()) return;
  storage::OutboxReader(*db_).mark_delivered(s.acknowledged);
  counters_.delivered.fetch_add(s.acknowledged.size(), std::memory_order_relaxed);
  s.acknowledged.clear();
  on_publish_accepted(s);
}

// The broker refused these rows: marked refused with its reason (kept, never sent again — a
// refusal is the broker's configuration, not a transient fault), counted, logged at the first and
// then at most once a minute, and raised. The alert's own message may be refused too: it only adds
// to the count, since the alert is already raised with the same value.
void MqttSender::on_publish_refusals(Session& s) {
  if (s.refused.empty()) return;
  storage::OutboxReader(*db_).mark_refused(s.refused);
  const auto n = counters_.publish_refused.fetch_add(s.refused.size()) + s.refused.size();
  refusals_unlogged_ += s.refused.size();
  const std::string reason = s.refused.back().reason;
  std::string topics;
  for (const auto t : s.refused_topics) {
    topics += (topics.empty() ? "" : ", ") + mqtt_topic(settings_, storage::to_string(t));
    refused_topics_.insert(t);
  }
  s.refused.clear();
  s.refused_topics.clear();
  if (const auto now = Clock::now(); now >= next_refusal_log_) {
    spdlog::error("mqtt: broker {}:{} refused {} message(s) as user '{}' on {}: {} ({} this run); they stay in the outbox "
                  "marked refused — check the broker's ACL",
                  settings_.host, settings_.port, refusals_unlogged_, credentials_.username, topics, reason, n);
    refusals_unlogged_ = 0;
    next_refusal_log_ = now + kRefusalLogInterval;
  }
  raise(AlertKind::mqtt_publish_refused, true, reason,
        "the MQTT broker refuses this gearbox's messages on " + topics + ": " + reason + " (" + std::to_string(n) +
            " refused so far this run, kept in the local outbox marked refused)");
}

// A topic that was refused is accepted again (the ACL was fixed): the alert clears.
void MqttSender::on_publish_accepted(Session& s) {
  bool again = clear_on_any_accept_ && !s.accepted_topics.empty();
  for (const auto t : s.accepted_topics) again = again || refused_topics_.count(t) > 0;
  s.accepted_topics.clear();
  if (!again) return;
  refused_topics_.clear();
  clear_on_any_accept_ = false;
  raise(AlertKind::mqtt_publish_refused, false, "",
        "the MQTT broker accepts this gearbox's messages again (" + std::to_string(counters_.publish_refused.load()) +
            " refused this run)");
}

// True when stopping and nothing is left to deliver (or the deadline has passed).
bool MqttSender::drained(Session& s) {
  {
    std::lock_guard lock(mutex_);
    if (!stopping_) return false;
  }
  return s.inflight.empty() && s.resends.empty() && s.resend_requests.empty() && storage::OutboxReader(*db_).undelivered_count() == 0;
}

void MqttSender::publish_status(Session& s, bool online) {
  const std::string payload = status_payload(settings_, online, storage::OutboxReader(*db_).delivered_through());
  const std::string topic = mqtt_topic(settings_, "status");
  mosquitto_publish(s.client, &s.status_mid, topic.c_str(), static_cast<int>(payload.size()), payload.data(), kQos, true);
}

void MqttSender::on_refusal(int rc) {
  const auto n = counters_.refused.fetch_add(1) + 1;
  const std::string why = reason_text(rc);  // an MQTT 5 CONNACK reason code
  if (n == 1 || n % 100 == 0)
    spdlog::error("mqtt: broker {}:{} refused client '{}'{}: {} (refusal {}); check mqtt.password_file — messages wait in the outbox",
                  settings_.host, settings_.port, client_id_of(settings_),
                  credentials_.username.empty() ? std::string(" without credentials") : " as user '" + credentials_.username + "'", why, n);
  raise(AlertKind::mqtt_refused, true, why, "the MQTT broker refuses this gearbox: " + why);
}

void MqttSender::on_accepted() {
  counters_.connects.fetch_add(1);
  spdlog::info("mqtt: connected to {}:{} as '{}'", settings_.host, settings_.port, client_id_of(settings_));
  raise(AlertKind::mqtt_refused, false, "", "the MQTT broker accepts this gearbox again");
}

void MqttSender::check_dropped() {
  const auto now = Clock::now();
  if (now < next_drop_check_) return;
  next_drop_check_ = now + kDropCheckInterval;
  const std::int64_t dropped = storage::OutboxReader(*db_).dropped();
  counters_.outbox_dropped.store(static_cast<std::uint64_t>(dropped), std::memory_order_relaxed);
  if (dropped <= dropped_seen_) return;
  const std::string message = "the MQTT outbox reached its limit of " + std::to_string(settings_.outbox_limit) +
                              " undelivered messages: " + std::to_string(dropped - dropped_seen_) +
                              " of the oldest dropped (" + std::to_string(dropped) + " in all)";
  spdlog::error("mqtt: {}", message);
  dropped_seen_ = dropped;
  std::lock_guard lock(mutex_);
  if (!alerts_open_) return;
  const AlertEvent e = alerts_.occurrence(AlertKey{AlertKind::mqtt_outbox_full, -1}, std::to_string(dropped), message);
  writer_.submit(storage::AlertUpdate{{e}, alerts_.take_changed()});
}

void MqttSender::raise(AlertKind kind, bool present, const std::string& value, const std::string& message) {
  std::lock_guard lock(mutex_);
  if (!alerts_open_) return;
  const auto e = alerts_.observe(AlertKey{kind, -1}, present, value, message, AlertHysteresis{1, 1});
  if (e) writer_.submit(storage::AlertUpdate{{*e}, alerts_.take_changed()});
}

// Sleeps, or ends early when stopping; false when stopping and the drain deadline has passed
// (or the outbox is empty: nothing to wait for).
bool MqttSender::wait_backoff(std::chrono::milliseconds delay) {
  std::unique_lock lock(mutex_);
  wake_.wait_for(lock, delay, [&] { return stopping_; });
  if (!stopping_) return true;
  if (Clock::now() >= drain_deadline_) return false;
  lock.unlock();
  if (storage::OutboxReader(*db_).undelivered_count() == 0) return false;
  lock.lock();
  wake_.wait_until(lock, std::min(drain_deadline_, Clock::now() + delay));
  return Clock::now() < drain_deadline_;
}

}  // namespace gearwatch::daemon
