// The fleet store in PostgreSQL (docs/fleet.md): schema, migrations and the typed writers.
#include "gearwatch/storage/fleet_store.hpp"

#include "fleet_errors.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <tuple>
#include <utility>

#include <nlohmann/json.hpp>
#include <pqxx/pqxx>

namespace gearwatch::storage::fleet {

namespace {

// Each entry moves the fleet schema from version i to i+1. Never edit a released step: add one.
constexpr std::array kFleetMigrations{
    // 0 -> 1: gearboxes, the de-duplication ledger, the data of every topic, rejects, staff views.
    R"SQL(
CREATE TABLE fleet.gearboxes (
  id bigserial PRIMARY KEY,
  site text NOT NULL,
  name text NOT NULL,
  first_seen timestamptz NOT NULL DEFAULT now(),
  last_seen timestamptz NOT NULL DEFAULT now(),
  state text CHECK (state IN ('online', 'offline')),
  version text,
  schema_version integer,
  status_at timestamptz,
  UNIQUE (site, name)
);
CREATE TABLE fleet.messages (
  gearbox_id bigint NOT NULL REFERENCES fleet.gearboxes(id),
  message_id bigint NOT NULL,
  topic text NOT NULL CHECK (topic IN ('record', 'wear', 'alert', 'model', 'gap', 'health')),
  record_id bigint,
  record_time timestamptz NOT NULL,
  received_at timestamptz NOT NULL DEFAULT now(),
  PRIMARY KEY (gearbox_id, message_id)
);
CREATE TABLE fleet.records (
  gearbox_id bigint NOT NULL REFERENCES fleet.gearboxes(id),
  record_id bigint NOT NULL,
  message_id bigint NOT NULL,
  record_time timestamptz NOT NULL,
  stream_sequence bigint NOT NULL,
  start_index bigint NOT NULL,
  duration_s double precision,
  analysed boolean NOT NULL,
  reject_reason text NOT NULL,
  speed_hz double precision,
  torque_nm double precision,
  input_revolutions double precision,
  PRIMARY KEY (gearbox_id, record_id)
);
CREATE TABLE fleet.indicator_values (
  gearbox_id bigint NOT NULL,
  record_id bigint NOT NULL,
  channel integer NOT NULL,
  name text NOT NULL,
  value double precision,
  PRIMARY KEY (gearbox_id, record_id, channel, name),
  FOREIGN KEY (gearbox_id, record_id) REFERENCES fleet.records(gearbox_id, record_id)
);
CREATE TABLE fleet.indicator_skips (
  gearbox_id bigint NOT NULL,
  record_id bigint NOT NULL,
  channel integer NOT NULL,
  name text NOT NULL,
  reason text NOT NULL,
  detail text NOT NULL,
  PRIMARY KEY (gearbox_id, record_id, channel, name),
  FOREIGN KEY (gearbox_id, record_id) REFERENCES fleet.records(gearbox_id, record_id)
);
CREATE TABLE fleet.wear_verdicts (
  gearbox_id bigint NOT NULL REFERENCES fleet.gearboxes(id),
  message_id bigint NOT NULL,
  record_id bigint,
  channel integer NOT NULL,
  mechanism text NOT NULL,
  points bigint NOT NULL,
  low_band_p double precision,
  high_band_p double precision,
  evidence text NOT NULL,
  PRIMARY KEY (gearbox_id, message_id, channel)
);
CREATE TABLE fleet.alert_events (
  gearbox_id bigint NOT NULL REFERENCES fleet.gearboxes(id),
  message_id bigint NOT NULL,
  record_id bigint,
  record_time timestamptz NOT NULL,
  transition text NOT NULL CHECK (transition IN ('raised', 'cleared', 'event')),
  severity text NOT NULL CHECK (severity IN ('info', 'warning', 'alarm')),
  kind text NOT NULL,
  channel integer,
  subject text NOT NULL,
  value text NOT NULL,
  message text NOT NULL,
  PRIMARY KEY (gearbox_id, message_id)
);
CREATE TABLE fleet.alert_state (
  gearbox_id bigint NOT NULL REFERENCES fleet.gearboxes(id),
  kind text NOT NULL,
  channel integer NOT NULL,
  subject text NOT NULL,
  active boolean NOT NULL,
  severity text NOT NULL,
  value text NOT NULL,
  message text NOT NULL,
  since timestamptz NOT NULL,
  last_message_id bigint NOT NULL,
  PRIMARY KEY (gearbox_id, kind, channel, subject)
);
CREATE TABLE fleet.model_states (
  gearbox_id bigint NOT NULL REFERENCES fleet.gearboxes(id),
  model_run_id bigint NOT NULL,
  message_id bigint NOT NULL,
  record_id bigint,
  record_time timestamptz NOT NULL,
  gear_pair bigint NOT NULL,
  advanced boolean NOT NULL,
  cycles double precision,
  k_wear double precision,
  k_pitting double precision,
  wear_mean_depth_m double precision,
  wear_max_depth_m double precision,
  pitting_mean double precision,
  forecast jsonb NOT NULL,
  PRIMARY KEY (gearbox_id, model_run_id)
);
CREATE TABLE fleet.gap_summaries (
  gearbox_id bigint NOT NULL REFERENCES fleet.gearboxes(id),
  gap_report_id bigint NOT NULL,
  message_id bigint NOT NULL,
  record_id bigint,
  record_time timestamptz NOT NULL,
  gear_pair bigint NOT NULL,
  input_revolutions double precision,
  significant_families jsonb NOT NULL,
  chosen_effects jsonb NOT NULL,
  unexplained_families jsonb NOT NULL,
  PRIMARY KEY (gearbox_id, gap_report_id)
);
CREATE TABLE fleet.health_snapshots (
  gearbox_id bigint NOT NULL REFERENCES fleet.gearboxes(id),
  message_id bigint NOT NULL,
  record_time timestamptz NOT NULL,
  final boolean NOT NULL,
  counters jsonb NOT NULL,
  PRIMARY KEY (gearbox_id, message_id)
);
CREATE TABLE fleet.rejects (
  id bigserial PRIMARY KEY,
  received_at timestamptz NOT NULL DEFAULT now(),
  topic text NOT NULL,
  payload bytea NOT NULL,
  reason text NOT NULL CHECK (reason IN ('not_utf8', 'malformed_json', 'wrong_schema', 'unknown_topic', 'unknown_gearbox', 'database_refused')),
  detail text NOT NULL
);

-- Staff views: the local database's names (docs/storage.md) with the gearbox in front.
CREATE VIEW fleet.indicators AS
  SELECT g.site, g.name AS gearbox, r.record_id, r.record_time, r.input_revolutions AS cycles, r.speed_hz, r.torque_nm,
         v.channel, v.name, v.value
  FROM fleet.indicator_values v JOIN fleet.records r USING (gearbox_id, record_id) JOIN fleet.gearboxes g ON g.id = v.gearbox_id;
CREATE VIEW fleet.alerts AS
  SELECT g.site, g.name AS gearbox, e.message_id, e.record_time AS created_at, e.severity, e.kind, e.channel,
         nullif(e.subject, '') AS subject, e.transition, e.value, e.record_id, e.message
  FROM fleet.alert_events e JOIN fleet.gearboxes g ON g.id = e.gearbox_id;
CREATE VIEW fleet.active_alerts AS
  SELECT g.site, g.name AS gearbox, s.kind, CASE WHEN s.channel < 0 THEN NULL ELSE s.channel END AS channel,
         nullif(s.subject, '') AS subject, s.severity, s.value, s.since AS raised_at, s.message
  FROM fleet.alert_state s JOIN fleet.gearboxes g ON g.id = s.gearbox_id WHERE s.active;
CREATE VIEW fleet.latest_model AS
  SELECT DISTINCT ON (m.gearbox_id) g.site, g.name AS gearbox, m.*
  FROM fleet.model_states m JOIN fleet.gearboxes g ON g.id = m.gearbox_id
  ORDER BY m.gearbox_id, m.model_run_id DESC;
CREATE VIEW fleet.latest_gap AS
  SELECT DISTINCT ON (s.gearbox_id) g.site, g.name AS gearbox, s.*
  FROM fleet.gap_summaries s JOIN fleet.gearboxes g ON g.id = s.gearbox_id
  ORDER BY s.gearbox_id, s.gap_report_id DESC;
CREATE VIEW fleet.gearbox_status AS
  SELECT g.site, g.name AS gearbox, g.state, g.version, g.schema_version, g.last_seen,
         (SELECT max(r.record_time) FROM fleet.records r WHERE r.gearbox_id = g.id) AS last_record_time,
         (SELECT count(*) FROM fleet.alert_state s WHERE s.gearbox_id = g.id AND s.active) AS active_alerts
  FROM fleet.gearboxes g;
)SQL",
    // 1 -> 2: lost messages and what finds them (docs/fleet.md): the newest id each gearbox says it
    // has published, rejects that keep their gearbox and id, the ranges a daemon can no longer send.
    R"SQL(
ALTER TABLE fleet.gearboxes ADD COLUMN delivered_through bigint;
ALTER TABLE fleet.rejects ADD COLUMN gearbox_id bigint REFERENCES fleet.gearboxes(id), ADD COLUMN message_id bigint;
CREATE INDEX rejects_message ON fleet.rejects (gearbox_id, message_id) WHERE message_id IS NOT NULL;
CREATE TABLE fleet.lost_messages (
  gearbox_id bigint NOT NULL REFERENCES fleet.gearboxes(id),
  from_id bigint NOT NULL,
  to_id bigint NOT NULL CHECK (to_id >= from_id),
  reason text NOT NULL CHECK (reason IN ('not_held', 'refused')),
  found_at timestamptz NOT NULL DEFAULT now(),
  PRIMARY KEY (gearbox_id, from_id, to_id)
);
CREATE OR REPLACE VIEW fleet.gearbox_status AS
  SELECT g.site, g.name AS gearbox, g.state, g.version, g.schema_version, g.last_seen,
         (SELECT max(r.record_time) FROM fleet.records r WHERE r.gearbox_id = g.id) AS last_record_time,
         (SELECT count(*) FROM fleet.alert_state s WHERE s.gearbox_id = g.id AND s.active) AS active_alerts,
         (SELECT coalesce(sum(l.to_id - l.from_id + 1), 0) FROM fleet.lost_messages l WHERE l.gearbox_id = g.id) AS lost_messages
  FROM fleet.gearboxes g;
)SQL",
    // 2 -> 3: holes nobody answers (docs/fleet.md, "No answer"): when each open hole was first asked
    // for, the reason no_answer, and lost_messages counting only the ids of a range not stored
    // since (a daemon that comes back may still send them).
    R"SQL(
CREATE TABLE fleet.asked_holes (
  gearbox_id bigint NOT NULL REFERENCES fleet.gearboxes(id),
  from_id bigint NOT NULL,
  to_id bigint NOT NULL CHECK (to_id >= from_id),
  first_asked_at timestamptz NOT NULL,
  PRIMARY KEY (gearbox_id, from_id)
);
ALTER TABLE fleet.lost_messages DROP CONSTRAINT lost_messages_reason_check;
ALTER TABLE fleet.lost_messages ADD CONSTRAINT lost_messages_reason_check CHECK (reason IN ('not_held', 'refused', 'no_answer'));
CREATE OR REPLACE VIEW fleet.lost_ids AS
  SELECT l.gearbox_id, l.from_id, l.to_id, l.reason, l.found_at,
         l.to_id - l.from_id + 1 - (SELECT count(*) FROM fleet.messages m
                                    WHERE m.gearbox_id = l.gearbox_id AND m.message_id BETWEEN l.from_id AND l.to_id) AS missing
  FROM fleet.lost_messages l;
CREATE OR REPLACE VIEW fleet.gearbox_status AS
  SELECT g.site, g.name AS gearbox, g.state, g.version, g.schema_version, g.last_seen,
         (SELECT max(r.record_time) FROM fleet.records r WHERE r.gearbox_id = g.id) AS last_record_time,
         (SELECT count(*) FROM fleet.alert_state s WHERE s.gearbox_id = g.id AND s.active) AS active_alerts,
         (SELECT coalesce(sum(l.missing), 0) FROM fleet.lost_ids l WHERE l.gearbox_id = g.id) AS lost_messages
  FROM fleet.gearboxes g;
)SQL"};

// Any number, also one pqxx would print with fewer digits: %.17g reads back to the same double.
struct Nullable {
  std::optional<std::string> text;
  const char* param() const { return text ? text->c_str() : nullptr; }
};
Nullable number(const std::optional<double>& v) {
  if (!v || !std::isfinite(*v)) return {};
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", *v);
  return {std::string(buf)};
}
Nullable integer(const std::optional<std::int64_t>& v) { return v ? Nullable{std::to_string(*v)} : Nullable{}; }

using detail::one_line;
using detail::translated;

}  // namespace

struct FleetStore::Connection {
  std::unique_ptr<pqxx::connection> c;
};

int current_fleet_schema_version() noexcept { return static_cast<int>(kFleetMigrations.size()); }

const char* to_string(AlertTransition t) noexcept {
  switch (t) {
    case AlertTransition::raised: return "raised";
    case AlertTransition::cleared: return "cleared";
    case AlertTransition::event: return "event";
  }
  return "event";
}

std::optional<AlertTransition> parse_alert_transition(const std::string& text) noexcept {
  for (auto t : {AlertTransition::raised, AlertTransition::cleared, AlertTransition::event})
    if (text == to_string(t)) return t;
  return std::nullopt;
}

std::optional<OutboxGoneReason> parse_gone_reason(const std::string& text) noexcept {
  for (auto r : {OutboxGoneReason::not_held, OutboxGoneReason::refused})
    if (text == storage::to_string(r)) return r;
  return std::nullopt;
}

const char* to_string(LostReason r) noexcept {
  switch (r) {
    case LostReason::not_held: return "not_held";
    case LostReason::refused: return "refused";
    case LostReason::no_answer: return "no_answer";
  }
  return "not_held";
}

std::optional<LostReason> parse_lost_reason(const std::string& text) noexcept {
  for (auto r : kAllLostReasons)
    if (text == to_string(r)) return r;
  return std::nullopt;
}

LostReason lost_reason_of(OutboxGoneReason r) noexcept {
  return r == OutboxGoneReason::refused ? LostReason::refused : LostReason::not_held;
}

const char* to_string(RejectReason r) noexcept {
  switch (r) {
    case RejectReason::not_utf8: return "not_utf8";
    case RejectReason::malformed_json: return "malformed_json";
    case RejectReason::wrong_schema: return "wrong_schema";
    case RejectReason::unknown_topic: return "unknown_topic";
    case RejectReason::unknown_gearbox: return "unknown_gearbox";
    case RejectReason::database_refused: return "database_refused";
  }
  return "wrong_schema";
}

FleetStore::FleetStore(const std::string& connection) : connection_string_(connection) {
  conn_ = std::make_unique<Connection>(Connection{detail::connect(connection_string_)});
}

FleetStore::~FleetStore() = default;

int FleetStore::migrate() { return migrate_to(current_fleet_schema_version()); }

int FleetStore::migrate_to(int version) {
  return translated([&] {
    pqxx::work w(*conn_->c);
    // One key for "the fleet schema": a second consumer waits here until the first has migrated.
    w.exec("SELECT pg_advisory_xact_lock(4711003900)");
    w.exec("CREATE SCHEMA IF NOT EXISTS fleet");
    w.exec("CREATE TABLE IF NOT EXISTS fleet.schema_version (version integer NOT NULL)");
    const auto r = w.exec("SELECT version FROM fleet.schema_version");
    const int found = r.empty() ? 0 : r[0][0].as<int>();
    if (r.empty()) w.exec("INSERT INTO fleet.schema_version VALUES (0)");
    if (found > version)
      throw FleetRefusedError("fleet database: schema version " + std::to_string(found) + " is newer than this gearwatch's (" +
                              std::to_string(current_fleet_schema_version()) + "); use a newer gearwatch");
    for (int v = found; v < version; ++v) w.exec(kFleetMigrations[static_cast<std::size_t>(v)]);
    w.exec_params("UPDATE fleet.schema_version SET version = $1", version);
    w.commit();
    return found;
  });
}

namespace {

std::int64_t upsert_gearbox(pqxx::transaction_base& w, const std::string& site, const std::string& gearbox) {
  return w
      .exec_params1("INSERT INTO fleet.gearboxes (site, name) VALUES ($1, $2) "
                    "ON CONFLICT (site, name) DO UPDATE SET last_seen = now() RETURNING id",
                    site, gearbox)[0]
      .as<std::int64_t>();
}

// The ledger: true when (gearbox, message_id) is new, i.e. this message is not a repeat.
bool first_arrival(pqxx::transaction_base& w, std::int64_t gearbox, const MessageHeader& h, const char* topic) {
  const auto r = w.exec_params(
      "INSERT INTO fleet.messages (gearbox_id, message_id, topic, record_id, record_time) VALUES ($1, $2, $3, $4, $5) "
      "ON CONFLICT DO NOTHING",
      gearbox, h.message_id, topic, integer(h.record_id).param(), h.record_time);
  return r.affected_rows() == 1;
}

void insert_record(pqxx::transaction_base& w, std::int64_t g, const RecordMessage& m) {
  w.exec_params(
      "INSERT INTO fleet.records (gearbox_id, record_id, message_id, record_time, stream_sequence, start_index, duration_s, "
      "analysed, reject_reason, speed_hz, torque_nm, input_revolutions) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12) "
      "ON CONFLICT DO NOTHING",
      g, *m.header.record_id, m.header.message_id, m.header.record_time, m.stream_sequence, m.start_index,
      number(m.duration_s).param(), m.analysed, m.reject_reason, number(m.speed_hz).param(), number(m.torque_nm).param(),
      number(m.input_revolutions).param());
  // One statement per table, whatever the number of indicators: the rows travel as one JSON array
  // (values as the %.17g text they always were, so a double reads back to the bit).
  if (!m.indicators.empty()) {
    nlohmann::json rows = nlohmann::json::array();
    for (const auto& v : m.indicators) {
      const auto value = number(v.value);
      rows.push_back({{"c", v.channel}, {"n", v.name}, {"v", value.text ? nlohmann::json(*value.text) : nlohmann::json(nullptr)}});
    }
    w.exec_params(
        "INSERT INTO fleet.indicator_values (gearbox_id, record_id, channel, name, value) "
        "SELECT $1, $2, (e->>'c')::integer, e->>'n', (e->>'v')::double precision FROM jsonb_array_elements($3::jsonb) e "
        "ON CONFLICT DO NOTHING",
        g, *m.header.record_id, rows.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  }
  if (!m.skipped.empty()) {
    nlohmann::json rows = nlohmann::json::array();
    for (const auto& k : m.skipped) rows.push_back({{"c", k.channel}, {"n", k.name}, {"r", k.reason}, {"d", k.detail}});
    w.exec_params(
        "INSERT INTO fleet.indicator_skips (gearbox_id, record_id, channel, name, reason, detail) "
        "SELECT $1, $2, (e->>'c')::integer, e->>'n', e->>'r', e->>'d' FROM jsonb_array_elements($3::jsonb) e "
        "ON CONFLICT DO NOTHING",
        g, *m.header.record_id, rows.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  }
}

void insert_wear(pqxx::transaction_base& w, std::int64_t g, const WearMessage& m) {
  for (const auto& v : m.verdicts)
    w.exec_params(
        "INSERT INTO fleet.wear_verdicts (gearbox_id, message_id, record_id, channel, mechanism, points, low_band_p, high_band_p, "
        "evidence) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9) ON CONFLICT DO NOTHING",
        g, m.header.message_id, integer(m.header.record_id).param(), v.channel, v.mechanism, v.points, number(v.low_band_p).param(),
        number(v.high_band_p).param(), v.evidence);
}

// The state follows the newest transition by message id, so a late repeat cannot undo a newer one.
void update_alert_state(pqxx::transaction_base& w, std::int64_t g, const AlertMessage& m) {
  if (m.transition == AlertTransition::event) return;
  w.exec_params(
      "INSERT INTO fleet.alert_state AS s (gearbox_id, kind, channel, subject, active, severity, value, message, since, "
      "last_message_id) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10) "
      "ON CONFLICT (gearbox_id, kind, channel, subject) DO UPDATE SET active = EXCLUDED.active, severity = EXCLUDED.severity, "
      "value = EXCLUDED.value, message = EXCLUDED.message, "
      "since = CASE WHEN EXCLUDED.active = s.active THEN s.since ELSE EXCLUDED.since END, "
      "last_message_id = EXCLUDED.last_message_id WHERE s.last_message_id < EXCLUDED.last_message_id",
      g, m.kind, m.channel.value_or(-1), m.subject, m.transition == AlertTransition::raised, m.severity, m.value, m.message,
      m.header.record_time, m.header.message_id);
}

void insert_alert(pqxx::transaction_base& w, std::int64_t g, const AlertMessage& m) {
  w.exec_params(
      "INSERT INTO fleet.alert_events (gearbox_id, message_id, record_id, record_time, transition, severity, kind, channel, "
      "subject, value, message) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11) ON CONFLICT DO NOTHING",
      g, m.header.message_id, integer(m.header.record_id).param(), m.header.record_time, to_string(m.transition), m.severity,
      m.kind, integer(m.channel ? std::optional<std::int64_t>(*m.channel) : std::nullopt).param(), m.subject, m.value, m.message);
  update_alert_state(w, g, m);
}

void insert_model(pqxx::transaction_base& w, std::int64_t g, const ModelMessage& m) {
  w.exec_params(
      "INSERT INTO fleet.model_states (gearbox_id, model_run_id, message_id, record_id, record_time, gear_pair, advanced, cycles, "
      "k_wear, k_pitting, wear_mean_depth_m, wear_max_depth_m, pitting_mean, forecast) "
      "VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14::jsonb) ON CONFLICT DO NOTHING",
      g, m.model_run_id, m.header.message_id, integer(m.header.record_id).param(), m.header.record_time, m.gear_pair, m.advanced,
      number(m.cycles).param(), number(m.k_wear).param(), number(m.k_pitting).param(), number(m.wear_mean_depth_m).param(),
      number(m.wear_max_depth_m).param(), number(m.pitting_mean).param(), m.forecast_json);
}

void insert_gap(pqxx::transaction_base& w, std::int64_t g, const GapMessage& m) {
  w.exec_params(
      "INSERT INTO fleet.gap_summaries (gearbox_id, gap_report_id, message_id, record_id, record_time, gear_pair, "
      "input_revolutions, significant_families, chosen_effects, unexplained_families) "
      "VALUES ($1, $2, $3, $4, $5, $6, $7, $8::jsonb, $9::jsonb, $10::jsonb) ON CONFLICT DO NOTHING",
      g, m.gap_report_id, m.header.message_id, integer(m.header.record_id).param(), m.header.record_time, m.gear_pair,
      number(m.input_revolutions).param(), m.significant_families_json, m.chosen_effects_json, m.unexplained_families_json);
}

std::string counters_json(const std::map<std::string, std::int64_t>& counters) {
  // Counter names are the daemon's identifiers ([a-z_]); anything else would have been refused upstream.
  std::string out = "{";
  for (const auto& [name, value] : counters) {
    if (out.size() > 1) out += ",";
    out += "\"" + name + "\":" + std::to_string(value);
  }
  return out + "}";
}

void insert_health(pqxx::transaction_base& w, std::int64_t g, const HealthMessage& m) {
  w.exec_params(
      "INSERT INTO fleet.health_snapshots (gearbox_id, message_id, record_time, final, counters) VALUES ($1, $2, $3, $4, $5::jsonb) "
      "ON CONFLICT DO NOTHING",
      g, m.header.message_id, m.header.record_time, m.final, counters_json(m.counters));
}

// A daemon's resend_gone answer: each range once; false when every range was known already.
bool insert_lost(pqxx::transaction_base& w, const GoneMessage& m) {
  const std::int64_t g = upsert_gearbox(w, m.site, m.gearbox);
  bool any = false;
  for (const auto& r : m.ranges) {
    // The daemon's answer replaces a "no answer" it overlaps; ids of it outside the answer become
    // holes again and are asked for.
    w.exec_params("DELETE FROM fleet.lost_messages WHERE gearbox_id = $1 AND reason = 'no_answer' AND from_id <= $3 AND to_id >= $2", g,
                  r.from, r.to);
    any = w.exec_params("INSERT INTO fleet.lost_messages (gearbox_id, from_id, to_id, reason) VALUES ($1, $2, $3, $4) "
                        "ON CONFLICT DO NOTHING",
                        g, r.from, r.to, to_string(lost_reason_of(r.reason)))
              .affected_rows() == 1 ||
          any;
  }
  return any;
}

}  // namespace

namespace {

const char* topic_of(const Message& m) {
  static constexpr const char* kTopics[] = {"record", "wear", "alert", "model", "gap", "health", "status", "resend_gone"};
  return kTopics[m.index()];
}

// One message inside the caller's transaction; false when it is a repeat (the caller rolls back
// its savepoint, so the gearbox's last_seen and the ledger stay as they were).
bool write_one(pqxx::transaction_base& w, const Message& message) {
  if (const auto* s = std::get_if<StatusMessage>(&message)) {
    const std::int64_t g = upsert_gearbox(w, s->site, s->gearbox);
    w.exec_params("UPDATE fleet.gearboxes SET state = $2, version = $3, schema_version = $4, status_at = now(), "
                  "delivered_through = greatest(delivered_through, $5) WHERE id = $1",
                  g, s->state, s->version, s->schema, integer(s->delivered_through).param());
    return true;
  }
  if (const auto* gone = std::get_if<GoneMessage>(&message)) return insert_lost(w, *gone);
  return std::visit(
      [&](const auto& m) -> bool {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, StatusMessage> || std::is_same_v<T, GoneMessage>) {
          return true;
        } else {
          const std::int64_t g = upsert_gearbox(w, m.header.site, m.header.gearbox);
          if (!first_arrival(w, g, m.header, topic_of(message))) return false;
          if constexpr (std::is_same_v<T, RecordMessage>) insert_record(w, g, m);
          if constexpr (std::is_same_v<T, WearMessage>) insert_wear(w, g, m);
          if constexpr (std::is_same_v<T, AlertMessage>) insert_alert(w, g, m);
          if constexpr (std::is_same_v<T, ModelMessage>) insert_model(w, g, m);
          if constexpr (std::is_same_v<T, GapMessage>) insert_gap(w, g, m);
          if constexpr (std::is_same_v<T, HealthMessage>) insert_health(w, g, m);
          return true;
        }
      },
      message);
}

}  // namespace

std::vector<BatchOutcome> FleetStore::write_batch(const std::vector<Message>& messages) {
  return translated([&] {
    std::vector<BatchOutcome> out(messages.size());
    pqxx::work w(*conn_->c);
    for (std::size_t i = 0; i < messages.size(); ++i) {
      try {
        pqxx::subtransaction one(w, "message");
        const bool first = write_one(one, messages[i]);
        if (first) one.commit();  // a repeat: the savepoint is rolled back as `one` goes
        out[i].written = first ? WriteOutcome::stored : WriteOutcome::duplicate;
      } catch (const pqxx::broken_connection&) {
        throw;
      } catch (const pqxx::in_doubt_error&) {
        throw;
      } catch (const pqxx::sql_error& e) {
        out[i].refusal = one_line(e.what());
      }
    }
    w.commit();
    return out;
  });
}

void FleetStore::write(const Reject& r) {
  translated([&] {
    pqxx::work w(*conn_->c);
    const std::optional<std::int64_t> g =
        r.header ? std::optional<std::int64_t>(upsert_gearbox(w, r.header->site, r.header->gearbox)) : std::nullopt;
    w.exec_params("INSERT INTO fleet.rejects (topic, payload, reason, detail, gearbox_id, message_id) VALUES ($1, $2, $3, $4, $5, $6)",
                  r.topic, pqxx::binarystring(r.payload), to_string(r.reason), r.detail, integer(g).param(),
                  integer(r.header ? std::optional<std::int64_t>(r.header->message_id) : std::nullopt).param());
    w.commit();
    return 0;
  });
}

std::vector<MessageHole> FleetStore::holes() {
  return translated([&] {
    pqxx::read_transaction w(*conn_->c);
    return detail::read_holes(w);
  });
}

namespace {

// When the hole was first asked for: the earliest of the asked holes it overlaps, else now.
bool asked_long_ago(pqxx::transaction_base& w, std::int64_t gearbox, const MessageHole& h, std::chrono::seconds give_up_after,
                    std::string& first_asked) {
  const auto r = w.exec_params(
      "SELECT coalesce(min(first_asked_at), now()), coalesce(min(first_asked_at), now()) <= now() - make_interval(secs => $4) "
      "FROM fleet.asked_holes WHERE gearbox_id = $1 AND from_id <= $3 AND to_id >= $2",
      gearbox, h.from, h.to, static_cast<double>(give_up_after.count()));
  first_asked = r[0][0].c_str();
  return r[0][1].as<bool>();
}

std::int64_t gearbox_id(pqxx::transaction_base& w, const MessageHole& h) {
  return w.exec_params("SELECT id FROM fleet.gearboxes WHERE site = $1 AND name = $2", h.site, h.gearbox)[0][0].as<std::int64_t>();
}

}  // namespace

// The asked holes are rewritten as the holes are now, each with its inherited first time.
FleetStore::HoleCheck FleetStore::check_holes(std::chrono::seconds give_up_after) {
  return translated([&] {
    pqxx::work w(*conn_->c);
    HoleCheck out;
    std::vector<std::tuple<std::int64_t, MessageHole, std::string>> still_open;
    for (const auto& h : detail::read_holes(w)) {
      const auto g = gearbox_id(w, h);
      std::string first_asked;
      if (asked_long_ago(w, g, h, give_up_after, first_asked)) {
        w.exec_params("INSERT INTO fleet.lost_messages (gearbox_id, from_id, to_id, reason) VALUES ($1, $2, $3, 'no_answer') "
                      "ON CONFLICT DO NOTHING",
                      g, h.from, h.to);
        out.given_up.push_back(h);
      } else {
        still_open.emplace_back(g, h, first_asked);
        out.to_ask.push_back(h);
      }
    }
    w.exec("DELETE FROM fleet.asked_holes");
    for (const auto& [g, h, first_asked] : still_open)
      w.exec_params("INSERT INTO fleet.asked_holes (gearbox_id, from_id, to_id, first_asked_at) VALUES ($1, $2, $3, $4::timestamptz)", g,
                    h.from, h.to, first_asked);
    w.commit();
    return out;
  });
}

namespace detail {

// Seen ids as intervals (stored messages, rejects with their id, lost ranges) plus one past the
// gearbox's delivered_through; a hole is where an interval starts beyond the reach of all before it.
std::vector<MessageHole> read_holes(pqxx::transaction_base& t) {
  const auto rows = t.exec(R"SQL(
WITH seen AS (
  SELECT gearbox_id, message_id AS lo, message_id AS hi FROM fleet.messages
  UNION ALL SELECT gearbox_id, message_id, message_id FROM fleet.rejects WHERE message_id IS NOT NULL
  UNION ALL SELECT gearbox_id, from_id, to_id FROM fleet.lost_messages
  UNION ALL SELECT id, delivered_through + 1, delivered_through + 1 FROM fleet.gearboxes WHERE delivered_through IS NOT NULL
), reach AS (
  SELECT gearbox_id, lo, coalesce(max(hi) OVER (PARTITION BY gearbox_id ORDER BY lo, hi
                                                ROWS BETWEEN UNBOUNDED PRECEDING AND 1 PRECEDING), 0) AS before
  FROM seen
)
SELECT g.site, g.name, r.before + 1, r.lo - 1 FROM reach r JOIN fleet.gearboxes g ON g.id = r.gearbox_id
WHERE r.lo > r.before + 1 ORDER BY g.site, g.name, r.lo
)SQL");
  std::vector<MessageHole> out;
  for (const auto& row : rows)
    out.push_back({row[0].as<std::string>(), row[1].as<std::string>(), row[2].as<std::int64_t>(), row[3].as<std::int64_t>()});
  return out;
}

}  // namespace detail

}  // namespace gearwatch::storage::fleet
