#include "gearwatch/storage/writer.hpp"

#include <chrono>
#include <cmath>
#include <future>
#include <map>
#include <optional>

#include <spdlog/spdlog.h>

#include "gearwatch/storage/gap_kept_records.hpp"
#include "gearwatch/storage/gap_reports.hpp"
#include "gearwatch/storage/schema.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/types/log_rate.hpp"
#include "model_run_columns.hpp"

namespace gearwatch::storage {
namespace {

using Clock = std::chrono::steady_clock;

// State derived from committed rows. Work on a copy inside a transaction and keep it only
// when the transaction commits, so a rolled-back batch leaves no stale ids behind.
struct WriterState {
  std::int64_t run_id = 0;
  std::map<std::uint64_t, std::int64_t> stream_keys;  // stream sequence -> streams.id
};

// Writes `part` in a savepoint; a constraint failure (a bug in what was submitted) drops that
// part alone, logged with what it was (`describe()`, called only then: no text is built for the
// parts that succeed). Transient errors go up: the whole batch is retried.
template <class Describe, class Part>
void write_part(Database& db, WriterCounters& counters, const char* what, Describe&& describe, Part&& part) {
  Savepoint sp(db);
  try {
    part();
    sp.release();
  } catch (const SqliteError& e) {
    if (e.transient()) throw;
    const auto n = counters.rows_rejected.fetch_add(1, std::memory_order_relaxed) + 1;
    if (log_occurrence(n))
      spdlog::critical("storage: {} of {} refused ({} refused so far), the rest is stored: {}", what, describe(), n, e.what());
  }
}

class BatchWriter {
 public:
  BatchWriter(Database& db, WriterState& state, WriterCounters& counters, const std::optional<OutboxIdentity>& outbox)
      : db_(db), state_(state), counters_(counters) {
    if (outbox) outbox_.emplace(db, *outbox);
  }
  /// Ends the batch: the outbox keeps within its limit in the same transaction.
  void finish() {
    if (outbox_) outbox_->enforce_limit();
  }

  void write(const RunStarted& m) {
    Statement s(db_, "INSERT INTO runs(kind, source, config_path, capture_id) VALUES (?, ?, ?, ?)");
    s.bind(1, m.kind).bind(2, m.source).bind(3, m.config_path);
    if (m.capture_id.empty()) s.bind_null(4);
    else s.bind(4, m.capture_id);
    s.run();
    state_.run_id = db_.last_insert_rowid();
    state_.stream_keys.clear();
    Statement name(db_, "INSERT OR REPLACE INTO run_channels(run_id, channel, name) VALUES (?, ?, ?)");
    for (const auto& c : m.channels) name.bind(1, state_.run_id).bind(2, c.channel).bind(3, c.name).run();
  }
  void write(const RunEnded& m) {
    Statement s(db_, "UPDATE runs SET ended_at = strftime('%Y-%m-%dT%H:%M:%fZ', 'now'), end_reason = ? WHERE id = ?");
    s.bind(1, m.reason).bind(2, state_.run_id).run();
  }
  void write(const StreamStarted& m) {
    Statement s(db_, "INSERT INTO streams(run_id, sequence, stream_id, sample_rate_hz, channel_count) VALUES (?, ?, ?, ?, ?)");
    s.bind(1, run()).bind(2, m.sequence).bind(3, static_cast<std::int64_t>(m.stream_id))
        .bind(4, static_cast<std::int64_t>(m.sample_rate_hz)).bind(5, static_cast<std::int64_t>(m.channel_count)).run();
    state_.stream_keys[m.sequence] = db_.last_insert_rowid();
  }
  // A record's skipped indicators and its indicator notes: one row per channel and indicator with
  // a token (`token` of each row) and an optional detail, each row on its own (write_part).
  template <class Row>
  void write_indicator_flags(const char* sql, const char* what, std::int64_t record_id, const std::string& context,
                             const std::vector<ChannelResult>& channels, std::vector<Row> ChannelResult::*rows,
                             std::string Row::*token) {
    Statement s(db_, sql);
    for (const auto& ch : channels)
      for (const auto& k : ch.*rows)
        write_part(db_, counters_, what, [&] { return context + " channel " + std::to_string(ch.channel) + " " + k.name + ": " + k.*token; }, [&] {
                     s.bind(1, record_id).bind(2, ch.channel).bind(3, k.name).bind(4, k.*token);
                     if (k.detail.empty()) s.bind_null(5);
                     else s.bind(5, k.detail);
                     s.run();
                   });
  }
  void write(const RecordResult& m) {
    Statement s(db_,
                "INSERT INTO records(stream_key, start_index, sample_count, duration_s, end_reason, analysed, reject_reason,"
                " torque_nm, speed_hz, input_revolutions, speed_source, estimated_speed_hz) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
    s.bind(1, stream(m.stream_sequence)).bind(2, m.start_index).bind(3, m.sample_count).bind(4, m.duration_s)
        .bind(5, to_string(m.end_reason)).bind(6, m.analysed ? 1 : 0);
    if (m.reject_reason.empty()) s.bind_null(7);
    else s.bind(7, m.reject_reason);
    s.bind(8, m.torque_nm).bind(9, m.speed_hz).bind(10, m.input_revolutions);
    if (m.speed_source) s.bind(11, dsp::to_string(*m.speed_source));
    else s.bind_null(11);
    s.bind(12, m.estimated_speed_hz).run();
    const std::int64_t record_id = db_.last_insert_rowid();
    Statement value(db_, "INSERT OR REPLACE INTO indicator_values(record_id, channel, name, value) VALUES (?, ?, ?, ?)");
    Statement band(db_, "INSERT OR REPLACE INTO band_selections(record_id, channel, criterion, level, centre_hz, bandwidth_hz, value)"
                        " VALUES (?, ?, ?, ?, ?, ?, ?)");
    for (const auto& ch : m.channels) {
      for (const auto& [name, v] : ch.values) value.bind(1, record_id).bind(2, ch.channel).bind(3, name).bind(4, v).run();
      for (const auto& b : ch.bands)
        band.bind(1, record_id).bind(2, ch.channel).bind(3, b.criterion).bind(4, b.level).bind(5, b.centre_hz)
            .bind(6, b.bandwidth_hz).bind(7, b.value).run();
    }
    const std::string context = "record " + std::to_string(record_id) + " (stream " + std::to_string(m.stream_sequence) +
                                ", index " + std::to_string(m.start_index) + ")";
    write_indicator_flags("INSERT OR REPLACE INTO indicator_skips(record_id, channel, name, reason, detail) VALUES (?, ?, ?, ?, ?)",
                          "skip reason", record_id, context, m.channels, &ChannelResult::skipped, &SkippedRow::reason);
    write_indicator_flags("INSERT OR REPLACE INTO indicator_notes(record_id, channel, name, note, detail) VALUES (?, ?, ?, ?, ?)",
                          "indicator note", record_id, context, m.channels, &ChannelResult::notes, &NoteRow::note);
    for (const auto& w : m.assessments)
      write_part(db_, counters_, "wear assessment", [&] { return context + " channel " + std::to_string(w.channel) + ": " + dsp::to_string(w.mechanism); }, [&] {
                   Statement a(db_, "INSERT OR REPLACE INTO wear_mechanism_assessments(record_id, channel, mechanism, points, low_band_p,"
                                    " high_band_p, low_band_rho, high_band_rho, band_jumps, evidence, unseen_band)"
                                    " VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
                   a.bind(1, record_id).bind(2, w.channel).bind(3, dsp::to_string(w.mechanism)).bind(4, w.points).bind(5, w.low_band_p)
                       .bind(6, w.high_band_p).bind(7, w.low_band_rho).bind(8, w.high_band_rho).bind(9, w.band_jumps)
                       .bind(10, w.evidence);
                   if (w.unseen_band) a.bind(11, dsp::to_string(*w.unseen_band));
                   else a.bind_null(11);
                   a.run();
                 });
    if (outbox_) outbox_->record(record_id, m);
    write_alerts(m.alerts, m.alert_states, record_id, context);
  }
  // The model run's own row: its observation, state, forecast and calibrations, one column each.
  std::int64_t insert_model_run_row(const ModelRunResult& m, std::optional<std::int64_t> record_id) {
    const wear::ModelRunReport& r = m.report;
    const wear::Forecast& f = r.forecast;
    const bool advanced = r.advanced;
    auto opt = [&](bool ok, double v) { return ok ? std::optional<double>(v) : std::nullopt; };
    Statement s(db_,
                "INSERT INTO model_runs(record_id, gear_pair, cycles, speed_hz, torque_nm, advanced, skipped_records, skipped_record_ids,"
                " rms_sa_measured, rms_sa_simulated, ics2_low, ics2_density_estimate, k_wear, k_pitting, wear_mean_m, wear_max_m,"
                " pinion_wear_mean_m, gear_wear_mean_m, pitting_mean, pitting_max, pitting_max_fraction, forecast_speed_hz,"
                " forecast_torque_nm, wear_limit_m, wear_cycles_left, wear_cycles_left_low, wear_cycles_left_high, pitting_limit,"
                " pitting_cycles_left, pitting_cycles_left_low, pitting_cycles_left_high, forecast_failure, profile, forecast_curve, detail,"
                " interval_coverage, forecast_evidence, wear_mean_low_m, wear_mean_high_m, " GW_DEPTH_RATIO_COLUMNS ", " GW_PEAK_RATIO_COLUMNS ")"
                " VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?,"
                " ?, ?, ?, ?, ?, ?, ?, ?)");
    s.bind(1, record_id).bind(2, m.gear_pair).bind(3, r.observation.cycles).bind(4, r.observation.speed_hz)
        .bind(5, r.observation.torque_nm).bind(6, advanced ? 1 : 0).bind(7, m.skipped_records);
    if (m.skipped_record_ids.empty()) s.bind_null(8);
    else s.bind(8, m.skipped_record_ids);
    s.bind(9, r.observation.rms_sa).bind(10, r.rms_sa_simulated).bind(11, r.observation.ics2_low).bind(12, r.ics2_density_estimate)
        .bind(13, r.k_wear_si).bind(14, r.k_pitting).bind(15, r.summary.combined_mean_depth_m).bind(16, r.max_depth_m)
        .bind(17, r.summary.pinion_mean_depth_m).bind(18, r.summary.gear_mean_depth_m).bind(19, r.summary.mean_pitting_density)
        .bind(20, r.summary.max_pitting_density).bind(21, r.summary.max_pitting_fraction)
        .bind(22, opt(f.valid, f.speed_hz)).bind(23, opt(f.valid, f.torque_nm)).bind(24, opt(f.valid, f.wear.limit))
        .bind(25, f.wear.cycles_left).bind(26, f.wear.cycles_left_low).bind(27, f.wear.cycles_left_high)
        .bind(28, opt(f.valid, f.pitting.limit)).bind(29, f.pitting.cycles_left).bind(30, f.pitting.cycles_left_low)
        .bind(31, f.pitting.cycles_left_high);
    if (f.failure.empty()) s.bind_null(32);
    else s.bind(32, f.failure);
    if (m.profile_json.empty()) s.bind_null(33);
    else s.bind(33, m.profile_json);
    if (m.forecast_json.empty()) s.bind_null(34);
    else s.bind(34, m.forecast_json);
    if (r.detail.empty()) s.bind_null(35);
    else s.bind(35, r.detail);
    s.bind(36, opt(f.valid, f.coverage));
    if (!f.valid || f.evidence.empty()) s.bind_null(37);
    else s.bind(37, f.evidence);
    s.bind(38, opt(f.valid && f.depth_high_m > 0, f.depth_low_m)).bind(39, opt(f.valid && f.depth_high_m > 0, f.depth_high_m));
    const bool calibrated = f.valid && f.depth_inspections > 0;
    s.bind(40, opt(calibrated, f.depth_mean_m)).bind(41, opt(calibrated, f.depth_ratio)).bind(42, opt(calibrated, f.depth_ratio_log_sd));
    if (calibrated) s.bind(43, static_cast<std::int64_t>(f.depth_inspections));
    else s.bind_null(43);
    const bool peaked = f.valid && f.peak_inspections > 0;
    s.bind(44, opt(peaked, f.peak_ratio_log_mean)).bind(45, opt(peaked, f.peak_ratio_log_sd)).bind(46, opt(peaked, f.peak_ratio));
    if (peaked) s.bind(47, static_cast<std::int64_t>(f.peak_inspections));
    else s.bind_null(47);
    s.run();
    return db_.last_insert_rowid();
  }
  void write(const ModelRunResult& m) {
    const std::optional<std::int64_t> record_id =
        m.stored_record_id ? m.stored_record_id : find_record(m.has_record, m.stream_sequence, m.start_index);
    const wear::ModelRunReport& r = m.report;
    const wear::Forecast& f = r.forecast;
    const std::int64_t run_id = insert_model_run_row(m, record_id);
    if (m.store_state) {
      Statement st(db_, "INSERT OR REPLACE INTO model_state(gear_pair, updated_at, record_id, cycles, k_wear, k_pitting, state)"
                        " VALUES (?, strftime('%Y-%m-%dT%H:%M:%fZ', 'now'), ?, ?, ?, ?, ?)");
      st.bind(1, m.gear_pair).bind(2, record_id).bind(3, r.summary.cycles).bind(4, r.k_wear_si).bind(5, r.k_pitting)
          .bind(6, m.state_json).run();
    }
    // Not a part of its own: the kept record and the schedule's counters stand or fall with the run.
    if (m.gap) write_gap_schedule_update(db_, *m.gap, record_id, run_id);
    const std::string context = "model run " + std::to_string(run_id) + " at " + std::to_string(r.observation.cycles) + " cycles";
    for (const auto issue : r.issues)
      write_part(db_, counters_, "model issue", [&] { return context + ": " + wear::to_string(issue); }, [&] {
        Statement i(db_, "INSERT OR IGNORE INTO model_run_issues(run_id, issue) VALUES (?, ?)");
        i.bind(1, run_id).bind(2, wear::to_string(issue)).run();
      });
    for (const auto flag : f.flags)
      write_part(db_, counters_, "forecast flag", [&] { return context + ": " + wear::to_string(flag); }, [&] {
        Statement i(db_, "INSERT OR IGNORE INTO model_run_forecast_flags(run_id, flag) VALUES (?, ?)");
        i.bind(1, run_id).bind(2, wear::to_string(flag)).run();
      });
    if (outbox_) outbox_->model(record_id, run_id, m);
    for (const auto& u : r.updates)
      write_part(db_, counters_, "K update", [&] { return context + ": " + wear::to_string(u.kind) + " " + wear::to_string(u.outcome); }, [&] {
        Statement k(db_, "INSERT INTO k_update_log(run_id, gear_pair, cycles, kind, triggered_by, outcome, old_value, new_value,"
                         " applies_from_cycles, iterations, measured, simulated_before, simulated_after, correlation_before,"
                         " correlation_after, evidence) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
        k.bind(1, run_id).bind(2, m.gear_pair).bind(3, u.cycles).bind(4, wear::to_string(u.kind)).bind(5, wear::to_string(u.trigger))
            .bind(6, wear::to_string(u.outcome)).bind(7, u.old_value).bind(8, u.new_value).bind(9, u.applies_from_cycles)
            .bind(10, u.iterations).bind(11, u.measured).bind(12, u.simulated_before).bind(13, u.simulated_after)
            .bind(14, u.correlation_before).bind(15, u.correlation_after).bind(16, u.evidence).run();
      });
    write_alerts(m.alerts, m.alert_states, record_id, context);
  }
  void write(const GapReportResult& m) {
    const std::optional<std::int64_t> record_id = find_record(m.has_record, m.stream_sequence, m.start_index);
    const std::int64_t id = insert_gap_report(db_, m.report, GapReportContext{record_id, m.gear_pair});
    if (outbox_) outbox_->gap(record_id, id, m);
    write_alerts(m.alerts, m.alert_states, record_id, "gap report " + std::to_string(id));
  }
  void write(const AlertUpdate& m) { write_alerts(m.alerts, m.alert_states, std::nullopt, "alert update"); }
  void write(const DropoutEvent& m) {
    Statement s(db_, "INSERT INTO gap_events(stream_key, channel, first_missing_index, missing_samples, cause) VALUES (?, ?, ?, ?, ?)");
    s.bind(1, stream(m.stream_sequence)).bind(2, m.channel).bind(3, m.first_missing_index).bind(4, m.missing_samples)
        .bind(5, acquisition::to_string(m.cause)).run();
  }
  void write(const LifeCounterEvent& m) {
    Statement s(db_, "INSERT INTO life_counter_events(stream_key, sample_index, previous_revolutions, revolutions) VALUES (?, ?, ?, ?)");
    s.bind(1, stream(m.stream_sequence)).bind(2, m.sample_index).bind(3, m.previous_revolutions).bind(4, m.revolutions).run();
  }
  void write(const RejectedFrame& m) {
    Statement s(db_, "INSERT INTO rejected_frames(run_id, kind, reason, frame) VALUES (?, ?, ?, ?)");
    s.bind(1, run()).bind(2, m.kind).bind(3, m.reason).bind(4, m.frame).run();
  }
  void write(const HealthSnapshot& m) {
    insert_counters("health_snapshots", "run_id", run(), m.final, kAllHealthCounters, m);
    if (outbox_) outbox_->health(m);
  }
  void write(const PublisherHealth& m) {
    insert_counters("publisher_health", "pid", m.pid, m.final, kMqttHealthCounters, m.counters);
  }

 private:
  // One row of counters: (owner column, final, one column per counter named by its to_string).
  template <std::size_t N>
  void insert_counters(const char* table, const char* owner_column, std::int64_t owner, bool final,
                       const std::array<HealthCounter, N>& which, const HealthSnapshot& values) {
    std::string cols = std::string(owner_column) + ", final";
    std::string qs = "?, ?";
    for (HealthCounter c : which) {
      cols += std::string(", ") + to_string(c);
      qs += ", ?";
    }
    Statement s(db_, std::string("INSERT INTO ") + table + "(" + cols + ") VALUES (" + qs + ")");
    s.bind(1, owner).bind(2, final ? 1 : 0);
    int i = 3;
    for (HealthCounter c : which) s.bind(i++, values[c]);
    s.run();
  }

  void write_alerts(const std::vector<AlertEvent>& alerts, const std::vector<std::pair<AlertKey, AlertState>>& states,
                    std::optional<std::int64_t> record_id, const std::string& context) {
    if (alerts.empty() && states.empty()) return;
    Statement event(db_, "INSERT INTO alert_events(record_id, severity, kind, channel, transition, value, message, subject)"
                         " VALUES (?, ?, ?, ?, ?, ?, ?, ?)");
    Statement state(db_, "INSERT OR REPLACE INTO alert_state(kind, channel, subject, active, value, consecutive_present,"
                         " consecutive_absent, marker) VALUES (?, ?, ?, ?, ?, ?, ?, ?)");
    for (const auto& e : alerts)
      write_part(db_, counters_, "alert", [&] { return context + ": " + to_string(e.key.kind) + " " + to_string(e.transition) + " " + e.value; }, [&] {
        Statement& a = event;
        a.bind(1, record_id).bind(2, to_string(e.severity)).bind(3, to_string(e.key.kind));
        if (e.key.channel < 0) a.bind_null(4);
        else a.bind(4, e.key.channel);
        a.bind(5, to_string(e.transition));
        if (e.value.empty()) a.bind_null(6);
        else a.bind(6, e.value);
        a.bind(7, e.message);
        if (e.key.subject.empty()) a.bind_null(8);
        else a.bind(8, e.key.subject);
        a.run();
        if (outbox_) outbox_->alerts(record_id, {e});
      });
    for (const auto& [key, st] : states)
      write_part(db_, counters_, "alert state", [&] { return context + ": " + to_string(key.kind); }, [&] {
        state.bind(1, to_string(key.kind)).bind(2, key.channel).bind(3, key.subject).bind(4, st.active ? 1 : 0).bind(5, st.value)
            .bind(6, st.consecutive_present).bind(7, st.consecutive_absent).bind(8, st.marker).run();
      });
  }

  std::optional<std::int64_t> find_record(bool has_record, std::uint64_t stream_sequence, std::uint64_t start_index) {
    if (!has_record) return std::nullopt;
    const auto key = state_.stream_keys.find(stream_sequence);
    if (key == state_.stream_keys.end()) return std::nullopt;
    Statement find(db_, "SELECT id FROM records WHERE stream_key = ? AND start_index = ? ORDER BY id DESC LIMIT 1");
    find.bind(1, key->second).bind(2, start_index);
    if (find.step()) return find.get_int(0);
    return std::nullopt;
  }
  std::int64_t run() const {
    if (state_.run_id == 0) throw SqliteError(0, "message before RunStarted");
    return state_.run_id;
  }
  std::int64_t stream(std::uint64_t sequence) const {
    const auto it = state_.stream_keys.find(sequence);
    if (it == state_.stream_keys.end()) throw SqliteError(0, "record for unknown stream " + std::to_string(sequence));
    return it->second;
  }
  Database& db_;
  WriterState& state_;
  WriterCounters& counters_;
  std::optional<OutboxWriter> outbox_;
};

}  // namespace

StorageWriter::StorageWriter(WriterOptions options, ErrorHandler on_fatal)
    : options_(std::move(options)), on_fatal_(std::move(on_fatal)) {}

StorageWriter::~StorageWriter() {
  if (thread_.joinable()) stop();
}

// The writer thread's loop: takes a batch from the queue, commits it in one transaction and, on a
// transient failure, keeps what is left of it and retries with a doubling back-off (until the
// deadline after stop).
class StorageWriter::Loop {
 public:
  Loop(StorageWriter& writer, std::unique_ptr<Database> db)
      : w_(writer), db_(std::move(db)), backoff_(writer.options_.retry_initial_ms) {}

  void run() {
    for (;;) {
      if (!take_batch()) return;
      std::size_t done = 0;  // messages of the batch committed or dropped so far
      try {
        write_batch(done);
        batch_.clear();
        backoff_ = std::chrono::milliseconds(w_.options_.retry_initial_ms);
      } catch (const SqliteError& e) {
        if (!wait_to_retry(e, done)) return;
      }
    }
  }

 private:
  // Tops the batch up from the queue (waiting while both are empty); false once stopped and empty.
  bool take_batch() {
    {
      std::unique_lock lock(w_.mutex_);
      if (batch_.empty()) {
        w_.not_empty_.wait(lock, [&] { return !w_.queue_.empty() || w_.terminate_; });
        if (w_.queue_.empty() && w_.terminate_) return false;
      }
      while (!w_.queue_.empty() && batch_.size() < w_.options_.max_batch) {
        batch_.push_back(std::move(w_.queue_.front()));
        w_.queue_.pop_front();
      }
      if (w_.terminate_ && !stop_deadline_)
        stop_deadline_ = Clock::now() + std::chrono::milliseconds(static_cast<long>(w_.options_.give_up_after_stop_s * 1000));
    }
    w_.not_full_.notify_all();
    return true;
  }

  // Commits batch[from, to) in one transaction; the derived state is kept only on commit.
  void commit_range(std::size_t from, std::size_t to) {
    WriterState trial = state_;
    Transaction tx(*db_);
    BatchWriter writer(*db_, trial, w_.counters_, w_.options_.outbox);
    for (std::size_t i = from; i < to; ++i) std::visit([&](const auto& msg) { writer.write(msg); }, batch_[i]);
    writer.finish();
    tx.commit();
    state_ = std::move(trial);
    w_.counters_.messages_committed.fetch_add(to - from, std::memory_order_relaxed);
    w_.counters_.transactions.fetch_add(1, std::memory_order_relaxed);
    w_.counters_.run_id.store(static_cast<std::uint64_t>(state_.run_id), std::memory_order_relaxed);
  }

  // The whole batch in one transaction; a message refused for good is dropped, counted and
  // logged, the rest written. A transient failure is thrown with `done` saying how far it got.
  void write_batch(std::size_t& done) {
    try {
      commit_range(0, batch_.size());
      done = batch_.size();
    } catch (const SqliteError& e) {
      if (e.transient()) throw;
      if (batch_.size() == 1) {
        drop_single(e);
        done = 1;
      } else {
        write_one_by_one(done);
      }
    }
  }

  void drop_single(const SqliteError& e) {
    spdlog::critical("storage: {} — message not written", e.what());
    w_.counters_.lost_at_exit.fetch_add(1, std::memory_order_relaxed);
    if (w_.on_fatal_ && e.code() != 0 && (e.code() & 0xFF) != 19 /* SQLITE_CONSTRAINT */) w_.on_fatal_(e.what());
  }

  // One bad message must not take its batch with it: write them one by one and drop only what
  // fails on its own (a transient failure still goes to the retry).
  void write_one_by_one(std::size_t& done) {
    for (; done < batch_.size(); ++done) {
      try {
        commit_range(done, done + 1);
      } catch (const SqliteError& one) {
        if (one.transient()) throw;
        spdlog::error("storage: message dropped: {}", one.what());
        w_.counters_.lost_at_exit.fetch_add(1, std::memory_order_relaxed);
      }
    }
  }

  // After a transient failure: keeps the unwritten rest, logs (at most every 10 s) and sleeps
  // the back-off; false (everything left counted as lost) once the deadline after stop passed.
  bool wait_to_retry(const SqliteError& e, std::size_t done) {
    batch_.erase(batch_.begin(), batch_.begin() + static_cast<std::ptrdiff_t>(done));
    w_.counters_.retries.fetch_add(1, std::memory_order_relaxed);
    const auto now = Clock::now();
    if (now - last_log_ > std::chrono::seconds(10)) {
      spdlog::error("storage: {} — keeping {} messages in memory, retrying in {} ms", e.what(), batch_.size(),
                    backoff_.count());
      last_log_ = now;
    }
    if (stop_deadline_ && now > *stop_deadline_) {
      std::lock_guard lock(w_.mutex_);
      const auto lost = batch_.size() + w_.queue_.size();
      spdlog::critical("storage: giving up after stop: {} messages could not be written ({})", lost, e.what());
      w_.counters_.lost_at_exit.fetch_add(lost, std::memory_order_relaxed);
      return false;
    }
    std::this_thread::sleep_for(backoff_);
    backoff_ = std::min(backoff_ * 2, std::chrono::milliseconds(w_.options_.retry_max_ms));
    return true;
  }

  StorageWriter& w_;
  std::unique_ptr<Database> db_;
  WriterState state_;
  std::deque<Message> batch_;
  std::chrono::milliseconds backoff_;
  Clock::time_point last_log_{};
  std::optional<Clock::time_point> stop_deadline_;
};

void StorageWriter::start() {
  std::promise<void> opened;
  auto ready = opened.get_future();
  thread_ = std::thread([this, p = std::move(opened)]() mutable {
    std::unique_ptr<Database> db;
    try {
      db = std::make_unique<Database>(options_.database, Database::Mode::read_write_create, options_.busy_timeout_ms);
      open_and_migrate(*db, options_.vocabulary);
    } catch (...) {
      p.set_exception(std::current_exception());
      return;
    }
    p.set_value();
    Loop(*this, std::move(db)).run();
  });
  try {
    ready.get();
  } catch (...) {
    thread_.join();
    throw;
  }
}

void StorageWriter::submit(Message message) {
  std::unique_lock lock(mutex_);
  if (queue_.size() >= options_.queue_capacity) {
    counters_.queue_waits.fetch_add(1, std::memory_order_relaxed);
    not_full_.wait(lock, [&] { return queue_.size() < options_.queue_capacity || terminate_; });
  }
  queue_.push_back(std::move(message));
  lock.unlock();
  not_empty_.notify_one();
}

void StorageWriter::stop() {
  {
    std::lock_guard lock(mutex_);
    terminate_ = true;
  }
  not_empty_.notify_all();
  not_full_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::size_t StorageWriter::queued() const {
  std::lock_guard lock(mutex_);
  return queue_.size();
}

}  // namespace gearwatch::storage
