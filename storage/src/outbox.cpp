#include "gearwatch/storage/outbox.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <nlohmann/json.hpp>

#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::storage {
namespace {

using nlohmann::json;

// A row waits to be sent while the broker has neither acknowledged nor refused it (the same
// condition as the partial index outbox_undelivered, schema.cpp).
const std::string kWaiting = "delivered_at IS NULL AND refused_at IS NULL";

// The rows of a `SELECT id, topic, payload FROM outbox ...`, in the statement's order.
std::vector<OutboxMessage> read_messages(Statement& s) {
  std::vector<OutboxMessage> out;
  while (s.step()) {
    const auto topic = parse_outbox_topic(s.get_text(1));
    if (!topic) throw SqliteError(0, "outbox row " + std::to_string(s.get_int(0)) + ": unknown topic " + s.get_text(1));
    out.push_back({s.get_int(0), *topic, s.get_text(2)});
  }
  return out;
}

// NaN and infinities are not JSON: an unknown value is null, as in the database.
json number_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }
json number_or_null(const std::optional<double>& v) { return v ? number_or_null(*v) : json(nullptr); }
json id_or_null(std::optional<std::int64_t> id) { return id ? json(*id) : json(nullptr); }

std::string record_time(Database& db, std::optional<std::int64_t> record_id) {
  if (record_id) {
    Statement s(db, "SELECT created_at FROM records WHERE id = ?");
    s.bind(1, *record_id);
    if (s.step()) return s.get_text(0);
  }
  Statement now(db, "SELECT strftime('%Y-%m-%dT%H:%M:%fZ', 'now')");
  now.step();
  return now.get_text(0);
}

// The fields every payload starts with (docs/mqtt.md): who, which message, about which record.
// The message id is the row's: ids only grow (one writer), so consumers de-duplicate and order by it.
void insert(Database& db, const OutboxIdentity& who, OutboxTopic topic, std::optional<std::int64_t> record_id, json body) {
  Statement next(db, "SELECT coalesce(max(id), 0) + 1 FROM outbox");
  next.step();
  const std::int64_t id = next.get_int(0);
  json payload{{"gearbox", who.gearbox}, {"site", who.site}, {"message_id", id}, {"topic", to_string(topic)},
               {"record_id", id_or_null(record_id)}, {"record_time", record_time(db, record_id)}};
  payload.update(body);
  Statement s(db, "INSERT INTO outbox(id, topic, record_id, payload) VALUES (?, ?, ?, ?)");
  s.bind(1, id).bind(2, to_string(topic)).bind(3, record_id).bind(4, payload.dump()).run();
}

json channels_of(const RecordResult& r) {
  json channels = json::array();
  for (const auto& ch : r.channels) {
    json values = json::object();
    for (const auto& [name, v] : ch.values) values[name] = number_or_null(v);
    json skipped = json::array();
    for (const auto& k : ch.skipped) skipped.push_back({{"indicator", k.name}, {"reason", k.reason}, {"detail", k.detail}});
    channels.push_back({{"channel", ch.channel}, {"indicators", values}, {"skipped", skipped}});
  }
  return channels;
}

json wear_verdicts(const RecordResult& r) {
  json verdicts = json::array();
  for (const auto& w : r.assessments)
    verdicts.push_back({{"channel", w.channel}, {"mechanism", dsp::to_string(w.mechanism)}, {"points", w.points},
                        {"low_band_p", number_or_null(w.low_band_p)}, {"high_band_p", number_or_null(w.high_band_p)},
                        {"evidence", w.evidence}});
  return verdicts;
}

json life_left(const wear::Forecast& f) {
  auto one = [&](const auto& limit) {
    return json{{"limit", f.valid ? number_or_null(limit.limit) : json(nullptr)},
                {"cycles_left", number_or_null(limit.cycles_left)},
                {"cycles_left_low", number_or_null(limit.cycles_left_low)},
                {"cycles_left_high", number_or_null(limit.cycles_left_high)}};
  };
  return json{{"valid", f.valid}, {"wear", one(f.wear)}, {"pitting", one(f.pitting)}, {"failure", f.failure}};
}

}  // namespace

const char* to_string(OutboxTopic topic) noexcept {
  switch (topic) {
    case OutboxTopic::alert: return "alert";
    case OutboxTopic::record: return "record";
    case OutboxTopic::wear: return "wear";
    case OutboxTopic::model: return "model";
    case OutboxTopic::health: return "health";
    case OutboxTopic::gap: return "gap";
  }
  return "unknown";
}

std::optional<OutboxTopic> parse_outbox_topic(const std::string& text) noexcept {
  for (auto t : kAllOutboxTopics)
    if (text == to_string(t)) return t;
  return std::nullopt;
}

void OutboxWriter::record(std::int64_t record_id, const RecordResult& r) {
  insert(db_, identity_, OutboxTopic::record, record_id,
         {{"stream_sequence", r.stream_sequence}, {"start_index", r.start_index}, {"duration_s", number_or_null(r.duration_s)},
          {"analysed", r.analysed}, {"reject_reason", r.reject_reason}, {"speed_hz", number_or_null(r.speed_hz)},
          {"torque_nm", number_or_null(r.torque_nm)}, {"input_revolutions", number_or_null(r.input_revolutions)},
          {"channels", channels_of(r)}});
  if (!r.assessments.empty()) insert(db_, identity_, OutboxTopic::wear, record_id, {{"verdicts", wear_verdicts(r)}});
}

void OutboxWriter::alerts(std::optional<std::int64_t> record_id, const std::vector<AlertEvent>& alerts) {
  for (const auto& e : alerts)
    insert(db_, identity_, OutboxTopic::alert, record_id,
           {{"transition", to_string(e.transition)}, {"severity", to_string(e.severity)}, {"kind", to_string(e.key.kind)},
            {"channel", e.key.channel < 0 ? json(nullptr) : json(e.key.channel)}, {"subject", e.key.subject},
            {"value", e.value}, {"message", e.message}});
}

void OutboxWriter::model(std::optional<std::int64_t> record_id, std::int64_t run_id, const ModelRunResult& m) {
  const wear::ModelRunReport& r = m.report;
  insert(db_, identity_, OutboxTopic::model, record_id,
         {{"model_run_id", run_id}, {"gear_pair", m.gear_pair}, {"advanced", r.advanced},
          {"cycles", number_or_null(r.observation.cycles)}, {"k_wear", number_or_null(r.k_wear_si)},
          {"k_pitting", number_or_null(r.k_pitting)}, {"wear_mean_depth_m", number_or_null(r.summary.combined_mean_depth_m)},
          {"wear_max_depth_m", number_or_null(r.max_depth_m)}, {"pitting_mean", number_or_null(r.summary.mean_pitting_density)},
          {"forecast", life_left(r.forecast)}});
}

void OutboxWriter::gap(std::optional<std::int64_t> record_id, std::int64_t report_id, const GapReportResult& g) {
  json significant = json::array(), unexplained = json::array(), chosen = json::array();
  for (const auto& f : g.report.before)
    if (f.significant) significant.push_back({{"family", gap::to_string(f.family)}, {"distance_db", number_or_null(f.distance_db)}});
  for (const auto f : g.report.unexplained) unexplained.push_back(gap::to_string(f));
  for (const auto c : g.report.chosen) chosen.push_back(gap::to_string(c));
  insert(db_, identity_, OutboxTopic::gap, record_id,
         {{"gap_report_id", report_id}, {"gear_pair", g.gear_pair}, {"input_revolutions", number_or_null(g.report.input_revolutions)},
          {"significant_families", significant}, {"chosen_effects", chosen}, {"unexplained_families", unexplained}});
}

void OutboxWriter::health(const HealthSnapshot& h) {
  json counters = json::object();
  for (HealthCounter c : kAllHealthCounters) counters[to_string(c)] = h[c];
  insert(db_, identity_, OutboxTopic::health, std::nullopt, {{"final", h.final}, {"counters", counters}});
}

void OutboxWriter::enforce_limit() {
  const auto limit = static_cast<std::int64_t>(identity_.limit);
  Statement count(db_, "SELECT count(*) FROM outbox WHERE " + kWaiting);
  count.step();
  const std::int64_t excess = count.get_int(0) - limit;
  if (excess > 0) {
    Statement drop(db_, "DELETE FROM outbox WHERE id IN (SELECT id FROM outbox WHERE " + kWaiting + " ORDER BY id LIMIT ?)");
    drop.bind(1, excess).run();
    Statement counted(db_, "UPDATE outbox_counters SET value = value + ? WHERE name = 'dropped'");
    counted.bind(1, excess).run();
  }
  Statement prune(db_, "DELETE FROM outbox WHERE (delivered_at IS NOT NULL OR refused_at IS NOT NULL) AND id <= (SELECT max(id) FROM outbox) - ?");
  prune.bind(1, 2 * limit).run();
}

std::vector<OutboxMessage> OutboxReader::undelivered_after(std::int64_t after, std::size_t limit) {
  Statement s(db_, "SELECT id, topic, payload FROM outbox WHERE " + kWaiting + " AND id > ? ORDER BY id LIMIT ?");
  s.bind(1, after).bind(2, static_cast<std::int64_t>(limit));
  return read_messages(s);
}

void OutboxReader::mark_delivered(const std::vector<std::int64_t>& ids) {
  if (ids.empty()) return;
  Transaction tx(db_);
  Statement s(db_, "UPDATE outbox SET delivered_at = strftime('%Y-%m-%dT%H:%M:%fZ', 'now') WHERE id = ? AND " + kWaiting);
  for (const auto id : ids) s.bind(1, id).run();
  tx.commit();
}

std::int64_t OutboxReader::undelivered_count() {
  Statement s(db_, "SELECT count(*) FROM outbox WHERE " + kWaiting);
  return s.step() ? s.get_int(0) : 0;
}

void OutboxReader::mark_refused(const std::vector<OutboxRefusal>& refusals) {
  if (refusals.empty()) return;
  Transaction tx(db_);
  Statement s(db_, "UPDATE outbox SET refused_at = strftime('%Y-%m-%dT%H:%M:%fZ', 'now'), refused_reason = ?"
                   " WHERE id = ? AND " + kWaiting);
  Statement counted(db_, "UPDATE outbox_counters SET value = value + 1 WHERE name = 'refused'");
  for (const auto& r : refusals) {
    s.bind(1, r.reason).bind(2, r.id).run();
    if (db_.changes() > 0) counted.run();
  }
  tx.commit();
}

std::int64_t OutboxReader::refused() {
  Statement s(db_, "SELECT value FROM outbox_counters WHERE name = 'refused'");
  return s.step() ? s.get_int(0) : 0;
}

const char* to_string(OutboxGoneReason reason) noexcept {
  switch (reason) {
    case OutboxGoneReason::not_held: return "not_held";
    case OutboxGoneReason::refused: return "refused";
  }
  return "not_held";
}

std::int64_t OutboxReader::newest_id() {
  // Ids are max(id) + 1 (insert above) and pruning always keeps the newest row, so the newest row
  // carries the newest id ever given out.
  Statement s(db_, "SELECT coalesce(max(id), 0) FROM outbox");
  return s.step() ? s.get_int(0) : 0;
}

std::int64_t OutboxReader::delivered_through() {
  Statement s(db_, "SELECT coalesce((SELECT min(id) - 1 FROM outbox WHERE " + kWaiting + "), (SELECT coalesce(max(id), 0) FROM outbox))");
  return s.step() ? s.get_int(0) : 0;
}

namespace {

std::vector<OutboxMessage> held_between(Database& db, std::int64_t from, std::int64_t to, std::size_t limit) {
  Statement s(db, "SELECT id, topic, payload FROM outbox WHERE id BETWEEN ? AND ? AND refused_at IS NULL ORDER BY id LIMIT ?");
  s.bind(1, from).bind(2, to).bind(3, static_cast<std::int64_t>(limit));
  return read_messages(s);
}

// Runs of ids absent from [from, to] (the gaps between consecutive held ids, with to + 1 closing
// the range), then the refused rows, each run merged.
void gone_between(Database& db, std::int64_t from, std::int64_t to, std::vector<OutboxGone>& out) {
  Statement absent(db,
                   "SELECT prev + 1, id - 1 FROM (SELECT id, lag(id, 1, ?1 - 1) OVER (ORDER BY id) AS prev FROM "
                   "(SELECT id FROM outbox WHERE id BETWEEN ?1 AND ?2 UNION ALL SELECT ?2 + 1)) WHERE id > prev + 1");
  absent.bind(1, from).bind(2, to);
  while (absent.step()) out.push_back({absent.get_int(0), absent.get_int(1), OutboxGoneReason::not_held});
  Statement refused(db, "SELECT id FROM outbox WHERE id BETWEEN ? AND ? AND refused_at IS NOT NULL ORDER BY id");
  refused.bind(1, from).bind(2, to);
  bool first = true;
  while (refused.step()) {
    const std::int64_t id = refused.get_int(0);
    if (!first && out.back().reason == OutboxGoneReason::refused && out.back().to + 1 == id) out.back().to = id;
    else out.push_back({id, id, OutboxGoneReason::refused});
    first = false;
  }
}

}  // namespace

OutboxResend OutboxReader::resend(const std::vector<std::pair<std::int64_t, std::int64_t>>& ranges, std::size_t limit) {
  OutboxResend out;
  Transaction tx(db_);  // one snapshot: a row pruned meanwhile is either served or named gone
  for (const auto& [from, to] : ranges) {
    gone_between(db_, from, to, out.gone);
    if (out.rows.size() < limit)
      for (auto& m : held_between(db_, from, to, limit - out.rows.size())) out.rows.push_back(std::move(m));
  }
  tx.commit();
  std::sort(out.gone.begin(), out.gone.end(), [](const OutboxGone& a, const OutboxGone& b) { return a.from < b.from; });
  return out;
}

std::int64_t OutboxReader::dropped() {
  Statement s(db_, "SELECT value FROM outbox_counters WHERE name = 'dropped'");
  return s.step() ? s.get_int(0) : 0;
}

}  // namespace gearwatch::storage
