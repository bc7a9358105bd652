#include "gearwatch/storage/resume.hpp"

#include <limits>

#include "gearwatch/types/indicator.hpp"

namespace gearwatch::storage {
namespace {

std::optional<double> optional_real(const Statement& st, int col) {
  return st.is_null(col) ? std::nullopt : std::optional<double>(st.get_double(col));
}

double real_or_nan(const Statement& st, int col) {
  return st.is_null(col) ? std::numeric_limits<double>::quiet_NaN() : st.get_double(col);
}

bool has_capture_id_column(Database& db) {
  Statement st(db, "SELECT 1 FROM pragma_table_info('runs') WHERE name = 'capture_id'");
  return st.step();
}

// The record the newest model run refers to; a run stored without one counts as the newest
// record any run refers to. 0 when the model never ran.
std::int64_t newest_modelled_record(Database& db) {
  Statement st(db, "SELECT coalesce((SELECT record_id FROM model_runs ORDER BY id DESC LIMIT 1),"
                   " (SELECT max(record_id) FROM model_runs), 0)");
  return st.step() ? st.get_int(0) : 0;
}

void load_indicator_values(Database& db, int channel, std::vector<StoredAnalysedRecord>& records) {
  Statement st(db, "SELECT name, value FROM indicator_values WHERE record_id = ? AND channel = ? ORDER BY name");
  for (auto& r : records) {
    st.bind(1, r.record_id).bind(2, channel);
    ChannelResult ch;
    ch.channel = channel;
    while (st.step()) ch.values.emplace_back(st.get_text(0), real_or_nan(st, 1));
    st.reset();
    if (!ch.values.empty()) r.record.channels.push_back(std::move(ch));
  }
}

}  // namespace

std::vector<StoredRun> load_runs(Database& db) {
  std::vector<StoredRun> runs;
  const bool with_id = has_capture_id_column(db);
  Statement st(db, with_id ? "SELECT id, source, capture_id FROM runs ORDER BY id" : "SELECT id, source, NULL FROM runs ORDER BY id");
  while (st.step())
    runs.push_back({st.get_int(0), st.get_text(1), st.is_null(2) ? std::nullopt : std::optional<std::string>(st.get_text(2))});
  return runs;
}

std::vector<StoredRunRecord> load_run_records(Database& db, std::int64_t run_id) {
  std::vector<StoredRunRecord> out;
  Statement st(db, R"SQL(
    SELECT s.sequence, s.stream_id, r.start_index, r.sample_count, r.input_revolutions, r.speed_hz, r.torque_nm,
           (SELECT v.channel FROM indicator_values v WHERE v.record_id = r.id AND v.name = ?1 ORDER BY v.channel LIMIT 1),
           (SELECT v.value FROM indicator_values v WHERE v.record_id = r.id AND v.name = ?1 ORDER BY v.channel LIMIT 1)
    FROM records r JOIN streams s ON s.id = r.stream_key WHERE s.run_id = ?2 ORDER BY r.id)SQL");
  st.bind(1, to_string(dsp::Indicator::rms_raw)).bind(2, run_id);
  while (st.step()) {
    StoredRunRecord r;
    r.stream_sequence = static_cast<std::uint64_t>(st.get_int(0));
    r.stream_id = static_cast<std::uint16_t>(st.get_int(1));
    r.start_index = static_cast<std::uint64_t>(st.get_int(2));
    r.sample_count = static_cast<std::uint64_t>(st.get_int(3));
    r.input_revolutions = optional_real(st, 4);
    r.speed_hz = optional_real(st, 5);
    r.torque_nm = optional_real(st, 6);
    if (!st.is_null(7)) r.rms_channel = static_cast<int>(st.get_int(7));
    r.rms_raw = st.is_null(8) ? 0.0 : st.get_double(8);
    out.push_back(r);
  }
  return out;
}

std::vector<StoredAnalysedRecord> load_records_after_newest_model_run(Database& db, int channel) {
  std::vector<StoredAnalysedRecord> out;
  Statement st(db, "SELECT r.id, s.sequence, r.start_index, r.sample_count, r.input_revolutions, r.speed_hz, r.torque_nm,"
                   " s.sample_rate_hz"
                   " FROM records r JOIN streams s ON s.id = r.stream_key WHERE r.analysed = 1 AND r.id > ? ORDER BY r.id");
  st.bind(1, newest_modelled_record(db));
  while (st.step()) {
    StoredAnalysedRecord r;
    r.record_id = st.get_int(0);
    r.record.stream_sequence = static_cast<std::uint64_t>(st.get_int(1));
    r.record.start_index = static_cast<std::uint64_t>(st.get_int(2));
    r.record.sample_count = static_cast<std::uint64_t>(st.get_int(3));
    r.record.analysed = true;
    r.record.input_revolutions = optional_real(st, 4);
    r.record.speed_hz = real_or_nan(st, 5);
    r.record.torque_nm = real_or_nan(st, 6);
    r.sample_rate_hz = static_cast<std::uint32_t>(st.get_int(7));
    out.push_back(std::move(r));
  }
  load_indicator_values(db, channel, out);
  return out;
}

}  // namespace gearwatch::storage
