#include "gearwatch/storage/record_reasons.hpp"

#include <algorithm>
#include <array>
#include <map>
#include <stdexcept>

#include "stored_tokens.hpp"

namespace gearwatch::storage {
namespace {

using detail::enum_of;
using detail::has_object;

bool has_column(Database& db, const char* object, const char* column) {
  Statement s(db, "SELECT 1 FROM pragma_table_info(?) WHERE name = ?");
  s.bind(1, object).bind(2, column);
  return s.step();
}

std::optional<double> optional_double(const Statement& s, int col) {
  if (s.is_null(col)) return std::nullopt;
  return s.get_double(col);
}
std::string text_or_empty(const Statement& s, int col) { return s.is_null(col) ? std::string{} : s.get_text(col); }

std::string row_name(const char* what, std::int64_t record_id, std::int64_t channel) {
  return std::string(what) + " of record " + std::to_string(record_id) + " channel " + std::to_string(channel);
}

}  // namespace

std::vector<RecordSummary> load_record_summaries(Database& db) {
  std::vector<RecordSummary> out;
  if (!has_object(db, "records")) return out;
  const char* speed_source = has_column(db, "records", "speed_source") ? "speed_source" : "NULL";  // schema 7
  Statement s(db, std::string("SELECT id, input_revolutions, created_at, analysed, end_reason, ") + speed_source +
                      " FROM records ORDER BY id");
  while (s.step()) {
    RecordSummary r;
    r.id = s.get_int(0);
    r.input_revolutions = optional_double(s, 1);
    r.created_at = s.get_text(2);
    r.analysed = s.get_int(3) != 0;
    const std::string row = "record " + std::to_string(r.id);
    r.end_reason = enum_of(kAllRecordEnds, s.get_text(4), "record end reason", row);
    if (!s.is_null(5)) r.speed_source = enum_of(dsp::kAllSpeedSources, s.get_text(5), "speed source", row);
    out.push_back(std::move(r));
  }
  return out;
}

std::vector<ChannelNaming> load_channel_names(Database& db) {
  std::map<std::int64_t, ChannelNaming> by_channel;
  if (!has_object(db, "run_channels")) return {};  // before schema version 10: no names kept
  Statement s(db, "SELECT channel, name FROM run_channels ORDER BY run_id DESC");
  while (s.step()) {
    const std::int64_t channel = s.get_int(0);
    std::string name = s.get_text(1);
    auto [it, first] = by_channel.try_emplace(channel, ChannelNaming{channel, name, {}});
    if (first) continue;
    auto& earlier = it->second.earlier_names;
    if (name != it->second.name && std::find(earlier.begin(), earlier.end(), name) == earlier.end())
      earlier.push_back(std::move(name));
  }
  std::vector<ChannelNaming> out;
  for (auto& [channel, naming] : by_channel) out.push_back(std::move(naming));
  return out;
}

namespace {

// The rows of indicator_skips or indicator_notes, which share their columns (record, channel,
// indicator, a token of `all`, detail), from first_record on; `sql` selects them in that order.
template <class Row, class Kind, std::size_t N>
std::vector<Row> load_indicator_rows(Database& db, const std::string& sql, std::int64_t first_record,
                                     const std::array<Kind, N>& all, const char* domain, const char* row_kind,
                                     Kind Row::*kind) {
  std::vector<Row> out;
  Statement s(db, sql);
  s.bind(1, first_record);
  while (s.step()) {
    Row k;
    k.record_id = s.get_int(0);
    k.channel = s.get_int(1);
    k.indicator = s.get_text(2);
    k.*kind = enum_of(all, s.get_text(3), domain, row_name(row_kind, k.record_id, k.channel));
    k.detail = text_or_empty(s, 4);
    out.push_back(std::move(k));
  }
  return out;
}

}  // namespace

std::vector<IndicatorSkip> load_indicator_skips(Database& db, std::int64_t first_record) {
  if (!has_object(db, "indicator_skips")) return {};
  const char* detail = has_column(db, "indicator_skips", "detail") ? "detail" : "NULL";  // schema 3
  return load_indicator_rows(db,
                             std::string("SELECT record_id, channel, name, reason, ") + detail +
                                 " FROM indicator_skips WHERE record_id >= ? ORDER BY record_id, channel, name",
                             first_record, dsp::kAllSkipReasons, "skip reason", "skip", &IndicatorSkip::reason);
}

std::vector<IndicatorCaveat> load_indicator_caveats(Database& db, std::int64_t first_record) {
  if (!has_object(db, "indicator_notes")) return {};  // schema 7
  return load_indicator_rows(db,
                             "SELECT record_id, channel, name, note, detail FROM indicator_notes WHERE record_id >= ? "
                             "ORDER BY record_id, channel, name",
                             first_record, dsp::kAllIndicatorNotes, "indicator note", "note", &IndicatorCaveat::note);
}

std::vector<StoredWearVerdict> load_newest_wear_verdicts(Database& db) {
  std::vector<StoredWearVerdict> out;
  if (!has_object(db, "wear_mechanism")) return out;
  const char* unseen = has_column(db, "wear_mechanism", "unseen_band") ? "unseen_band" : "NULL";  // schema 7
  Statement s(db, std::string("SELECT channel, record_id, mechanism, points, created_at, cycles, evidence, ") + unseen +
                      " FROM wear_mechanism w WHERE record_id = (SELECT max(record_id) FROM wear_mechanism x WHERE x.channel = w.channel)"
                      " ORDER BY channel");
  while (s.step()) {
    StoredWearVerdict v;
    v.channel = s.get_int(0);
    v.record_id = s.get_int(1);
    const std::string row = row_name("wear verdict", v.record_id, v.channel);
    v.mechanism = enum_of(dsp::kAllWearMechanisms, s.get_text(2), "wear mechanism", row);
    v.points = s.get_int(3);
    v.created_at = s.get_text(4);
    v.cycles = optional_double(s, 5);
    v.evidence = s.get_text(6);
    if (!s.is_null(7)) v.unseen_band = enum_of(dsp::kAllCarrierBands, s.get_text(7), "carrier band", row);
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace gearwatch::storage
