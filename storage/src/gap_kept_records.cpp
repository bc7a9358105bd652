#include "gearwatch/storage/gap_kept_records.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "json_numbers.hpp"

namespace gearwatch::storage {
namespace {

using nlohmann::json;
using detail::kNaN;

// Samples as little-endian IEEE float32, whatever the host's byte order: the float the record held.
std::string samples_blob(const std::vector<float>& x) {
  std::string out(x.size() * 4, '\0');
  for (std::size_t i = 0; i < x.size(); ++i) {
    std::uint32_t bits = 0;
    std::memcpy(&bits, &x[i], 4);
    for (int b = 0; b < 4; ++b) out[i * 4 + static_cast<std::size_t>(b)] = static_cast<char>((bits >> (8 * b)) & 0xFF);
  }
  return out;
}

std::vector<float> samples_from(const std::string& blob, std::uint64_t expected, std::int64_t row) {
  if (blob.size() != expected * 4)
    throw std::runtime_error("gap kept record " + std::to_string(row) + ": " + std::to_string(blob.size()) +
                             " bytes of samples, expected " + std::to_string(expected * 4));
  std::vector<float> x(static_cast<std::size_t>(expected));
  for (std::size_t i = 0; i < x.size(); ++i) {
    std::uint32_t bits = 0;
    for (int b = 0; b < 4; ++b) bits |= static_cast<std::uint32_t>(static_cast<unsigned char>(blob[i * 4 + static_cast<std::size_t>(b)])) << (8 * b);
    std::memcpy(&x[i], &bits, 4);
  }
  return x;
}

// JSON numbers are written with round-trip precision; JSON has no NaN, so it goes as null.
using detail::json_numbers;
using detail::numbers_from_json;

std::string edges_json(const Record& r) {
  json a = json::array();
  for (const auto& shaft : r.tacho_edges) a.push_back(json_numbers(shaft));
  return a.dump();
}

std::string state_json(const wear::WearState& s) {
  return json{{"cycles", std::isfinite(s.cycles) ? json(s.cycles) : json(nullptr)},
              {"pinion_depth_m", json_numbers(s.pinion_depth_m)},
              {"gear_depth_m", json_numbers(s.gear_depth_m)},
              {"pinion_pitting", json_numbers(s.pinion_pitting)}}
      .dump();
}

void read_json_columns(const std::string& edges, const std::string& state, KeptGapRecord& k, std::int64_t row) {
  try {
    const json e = json::parse(edges);
    if (!e.is_array() || e.size() != k.record.tacho_edges.size()) throw std::runtime_error("not one array per shaft");
    for (std::size_t s = 0; s < e.size(); ++s) k.record.tacho_edges[s] = numbers_from_json(e[s]);
    const json w = json::parse(state);
    k.state.cycles = w.at("cycles").is_null() ? kNaN : w.at("cycles").get<double>();
    k.state.pinion_depth_m = numbers_from_json(w.at("pinion_depth_m"));
    k.state.gear_depth_m = numbers_from_json(w.at("gear_depth_m"));
    k.state.pinion_pitting = numbers_from_json(w.at("pinion_pitting"));
  } catch (const std::exception& ex) {
    throw std::runtime_error("gap kept record " + std::to_string(row) + " cannot be read: " + ex.what());
  }
}

void insert_kept(Database& db, std::int64_t gear_pair, const KeptGapRecord& k, std::optional<std::int64_t> record_id,
                 std::optional<std::int64_t> model_run_id) {
  const Record& r = k.record;
  if (r.channels.size() != 1 || r.channel_numbers.size() != 1)
    throw SqliteError(0, "gap kept record: one channel expected, got " + std::to_string(r.channels.size()));
  Statement s(db, "INSERT OR REPLACE INTO gap_kept_records(gear_pair, position, record_id, model_run_id, stream_sequence, stream_id,"
                  " start_index, sample_rate_hz, speed_hz, torque_nm, input_revolutions, channel, sample_count, samples, tacho_edges,"
                  " wear_state) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  const std::string blob = samples_blob(r.channels[0]);
  s.bind(1, gear_pair).bind(2, k.position).bind(3, record_id).bind(4, model_run_id).bind(5, k.stream_sequence)
      .bind(6, static_cast<std::int64_t>(r.stream_id)).bind(7, r.start_index).bind(8, r.sample_rate_hz).bind(9, r.speed_hz)
      .bind(10, r.torque_nm).bind(11, r.input_revolutions).bind(12, r.channel_numbers[0])
      .bind(13, static_cast<std::uint64_t>(r.channels[0].size()));
  s.bind_blob(14, blob.data(), blob.size()).bind(15, edges_json(r)).bind(16, state_json(k.state)).run();
}

}  // namespace

bool has_gap_schedule_tables(Database& db) {
  Statement s(db, "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name IN ('gap_schedule', 'gap_kept_records')");
  return s.step() && s.get_int(0) == 2;
}

void write_gap_schedule_update(Database& db, const GapScheduleUpdate& u, std::optional<std::int64_t> record_id,
                               std::optional<std::int64_t> model_run_id) {
  Statement counters(db, "INSERT OR REPLACE INTO gap_schedule(gear_pair, records_added, since_diagnosis) VALUES (?, ?, ?)");
  counters.bind(1, u.gear_pair).bind(2, u.counters.records_added).bind(3, u.counters.since_diagnosis).run();
  // Another pair's records belong to another wear history: no diagnosis of this pair uses them.
  Statement drop(db, "DELETE FROM gap_kept_records WHERE gear_pair <> ? OR position <= ?");
  drop.bind(1, u.gear_pair).bind(2, u.drop_through_position).run();
  Statement drop_counters(db, "DELETE FROM gap_schedule WHERE gear_pair <> ?");
  drop_counters.bind(1, u.gear_pair).run();
  if (u.keep) insert_kept(db, u.gear_pair, *u.keep, record_id, model_run_id);
}

StoredGapSchedule load_gap_schedule(Database& db, std::int64_t gear_pair) {
  StoredGapSchedule out;
  if (!has_gap_schedule_tables(db)) return out;
  Statement c(db, "SELECT records_added, since_diagnosis FROM gap_schedule WHERE gear_pair = ?");
  c.bind(1, gear_pair);
  if (!c.step()) return out;
  out.found = true;
  out.counters = {static_cast<std::uint64_t>(c.get_int(0)), static_cast<std::uint64_t>(c.get_int(1))};
  Statement s(db, "SELECT id, position, stream_sequence, stream_id, start_index, sample_rate_hz, speed_hz, torque_nm,"
                  " input_revolutions, channel, sample_count, samples, tacho_edges, wear_state FROM gap_kept_records"
                  " WHERE gear_pair = ? ORDER BY position");
  s.bind(1, gear_pair);
  while (s.step()) {
    const std::int64_t row = s.get_int(0);
    KeptGapRecord k;
    k.position = static_cast<std::uint64_t>(s.get_int(1));
    k.stream_sequence = static_cast<std::uint64_t>(s.get_int(2));
    Record& r = k.record;
    r.stream_id = static_cast<std::uint16_t>(s.get_int(3));
    r.start_index = static_cast<std::uint64_t>(s.get_int(4));
    r.sample_rate_hz = s.get_double(5);
    r.speed_hz = s.is_null(6) ? kNaN : s.get_double(6);
    r.torque_nm = s.is_null(7) ? kNaN : s.get_double(7);
    if (!s.is_null(8)) r.input_revolutions = s.get_double(8);
    r.channel_numbers = {static_cast<int>(s.get_int(9))};
    r.channels = {samples_from(s.get_blob(11), static_cast<std::uint64_t>(s.get_int(10)), row)};
    read_json_columns(s.get_text(12), s.get_text(13), k, row);
    out.kept.push_back(std::move(k));
  }
  return out;
}

}  // namespace gearwatch::storage
