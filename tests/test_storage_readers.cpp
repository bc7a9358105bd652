// The typed readers other rooms ask storage through (docs/storage.md): each test inserts rows
// by hand into a freshly migrated database and asserts the reader gives them back, value for
// value, with the filters and orders it promises.
#include <algorithm>

#include <catch2/catch.hpp>

#include "gearwatch/storage/alert_history.hpp"
#include "gearwatch/storage/gap_reports.hpp"
#include "gearwatch/storage/inspections.hpp"
#include "gearwatch/storage/model_history.hpp"
#include "gearwatch/storage/processing_history.hpp"
#include "gearwatch/storage/report_history.hpp"
#include "gearwatch/storage/schema.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/storage/staff_queries.hpp"

#include "temp_dir.hpp"

namespace test_storage_readers {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::storage;

namespace {

// A migrated database with one run, one stream and records 1..4 at the given created_at times.
struct ReaderDb {
  testing::TempDir dir;
  Database db;
  explicit ReaderDb(const std::string& name) : dir("readers-" + name), db((dir / "h.db").string()) {
    open_and_migrate(db);
    db.exec("INSERT INTO runs(id, kind, source) VALUES (1, 'replay', 'test.log')");
    db.exec("INSERT INTO streams(id, run_id, sequence, stream_id, sample_rate_hz, channel_count) VALUES (1, 1, 1, 7, 25600, 2)");
  }
  void record(int id, const char* created_at, const char* revolutions, int analysed = 1) {
    db.exec("INSERT INTO records(id, stream_key, start_index, sample_count, duration_s, end_reason, analysed, input_revolutions, created_at)"
            " VALUES (" + std::to_string(id) + ", 1, " + std::to_string(id * 1000) + ", 1000, 1.0, 'complete', " +
            std::to_string(analysed) + ", " + revolutions + ", '" + created_at + "')");
  }
  void value(int record, int channel, const char* name, const char* v) {
    db.exec("INSERT INTO indicator_values(record_id, channel, name, value) VALUES (" + std::to_string(record) + ", " +
            std::to_string(channel) + ", '" + name + "', " + v + ")");
  }
};

}  // namespace

TEST_CASE("storage readers: alert states come back as stored, all kinds or the asked ones", "[storage][readers]") {
  ReaderDb h("alert-states");
  h.db.exec("INSERT INTO alert_state(kind, channel, active, value, consecutive_present, consecutive_absent, marker, subject) VALUES"
            " ('sensor_missing', 2, 1, 'no samples', 3, 0, 0, ''),"
            " ('remaining_life', -1, 0, NULL, 0, 4, 0, 'wear'),"
            " ('twin_drift', -1, 1, '0.31', 2, 1, 1.5e6, 'mesh_stiffness')");
  const auto all = load_alert_states(h.db);
  REQUIRE(all.size() == 3);
  const AlertState& missing = all.at(AlertKey{AlertKind::sensor_missing, 2});
  CHECK(missing.active);
  CHECK(missing.value == "no samples");
  CHECK(missing.consecutive_present == 3);
  CHECK(missing.consecutive_absent == 0);
  const AlertState& life = all.at(AlertKey{AlertKind::remaining_life, -1, "wear"});
  CHECK_FALSE(life.active);
  CHECK(life.value.empty());
  CHECK(life.consecutive_absent == 4);
  const AlertState& drift = all.at(AlertKey{AlertKind::twin_drift, -1, "mesh_stiffness"});
  CHECK(drift.marker == 1.5e6);
  CHECK(drift.value == "0.31");

  const auto model = load_alert_states(h.db, {AlertKind::remaining_life, AlertKind::twin_drift});
  REQUIRE(model.size() == 2);
  CHECK(model.count(AlertKey{AlertKind::sensor_missing, 2}) == 0);
  CHECK(model.at(AlertKey{AlertKind::twin_drift, -1, "mesh_stiffness"}) == drift);
}

TEST_CASE("storage readers: the active alerts of one kind carry their newest raised message", "[storage][readers]") {
  ReaderDb h("active-kind");
  h.db.exec("INSERT INTO alert_state(kind, channel, active, value, consecutive_present, consecutive_absent, marker, subject) VALUES"
            " ('twin_drift', -1, 1, '0.4', 2, 0, 0, 'damping'),"
            " ('twin_drift', -1, 1, '0.2', 2, 0, 0, 'backlash'),"
            " ('twin_drift', -1, 0, NULL, 0, 2, 0, 'mass'),"
            " ('sensor_missing', 1, 1, 'x', 1, 0, 0, '')");
  h.db.exec("INSERT INTO alert_events(id, created_at, severity, kind, message, channel, transition, value, subject) VALUES"
            " (1, '2026-01-01T00:00:00Z', 'warning', 'twin_drift', 'damping drifts (first)', NULL, 'raised', '0.3', 'damping'),"
            " (2, '2026-01-02T00:00:00Z', 'warning', 'twin_drift', 'damping drifts (newest)', NULL, 'raised', '0.4', 'damping'),"
            " (3, '2026-01-03T00:00:00Z', 'alarm', 'twin_drift', 'backlash drifts', NULL, 'raised', '0.2', 'backlash')");
  const auto drift = load_active_alerts(h.db, AlertKind::twin_drift);
  REQUIRE(drift.size() == 2);  // 'mass' is not active, sensor_missing is another kind
  CHECK(drift[0].subject == "backlash");
  CHECK(drift[0].value == "0.2");
  CHECK(drift[0].message == "backlash drifts");
  CHECK(drift[0].severity == AlertSeverity::alarm);
  CHECK(drift[1].subject == "damping");
  CHECK(drift[1].message == "damping drifts (newest)");
  CHECK(drift[1].raised_at == "2026-01-02T00:00:00Z");
  CHECK(load_active_alerts(h.db).size() == 3);
}

TEST_CASE("storage readers: inspections, all by cycles and one gear pair's by id", "[storage][readers]") {
  ReaderDb h("inspections");
  h.db.exec("INSERT INTO inspections(id, entered_at, cycles, pitted_area_fraction, wear_depth_m, note, gear_pair) VALUES"
            " (1, '2026-02-01T00:00:00Z', 3e6, 0.02, NULL, 'second look', 0),"
            " (2, '2026-02-02T00:00:00Z', 1e6, NULL, 4e-6, NULL, NULL),"
            " (3, '2026-02-03T00:00:00Z', 2e5, 0.001, 1e-6, NULL, 1)");
  const auto all = load_inspections(h.db);
  REQUIRE(all.size() == 3);
  CHECK(all[0].id == 3);
  CHECK(all[0].gear_pair == 1);
  CHECK(all[1].id == 2);
  CHECK(all[1].gear_pair == 0);  // NULL: the first pair
  CHECK_FALSE(all[1].pitted_area_fraction.has_value());
  CHECK(all[1].wear_depth_m == 4e-6);
  CHECK(all[2].id == 1);
  CHECK(all[2].note == "second look");
  CHECK(all[2].entered_at == "2026-02-01T00:00:00Z");

  const auto first_pair = load_gear_pair_inspections(h.db, 0);
  REQUIRE(first_pair.size() == 2);
  CHECK(first_pair[0].id == 1);  // by id, as entered
  CHECK(first_pair[0].cycles == 3e6);
  CHECK(first_pair[0].pitted_area_fraction == 0.02);
  CHECK(first_pair[1].id == 2);
  REQUIRE(load_gear_pair_inspections(h.db, 1).size() == 1);
}

TEST_CASE("storage readers: the model's state, resets, ICS2 series, curve and nearest predictions", "[storage][readers]") {
  ReaderDb h("model");
  CHECK(has_model_state(h.db));
  CHECK_FALSE(load_newest_model_state(h.db).has_value());
  CHECK(count_life_counter_resets(h.db) == 0);
  h.db.exec("INSERT INTO life_counter_events(stream_key, sample_index, previous_revolutions, revolutions) VALUES (1, 10, 500, 0)");
  CHECK(count_life_counter_resets(h.db) == 1);
  h.db.exec("INSERT INTO model_state(gear_pair, updated_at, cycles, k_wear, k_pitting, state) VALUES"
            " (0, '2026-03-01T00:00:00Z', 1, 1, 1, '{\"old\":1}'), (1, '2026-03-02T00:00:00Z', 2, 2, 2, '{\"new\":2}')");
  const auto state = load_newest_model_state(h.db);
  REQUIRE(state);
  CHECK(state->gear_pair == 1);
  CHECK(state->updated_at == "2026-03-02T00:00:00Z");
  CHECK(state->state_json == "{\"new\":2}");

  h.db.exec("INSERT INTO model_runs(id, gear_pair, cycles, advanced, ics2_low, wear_mean_m, pitting_mean, forecast_curve) VALUES"
            " (1, 1, 1000, 1, 0.11, 1e-6, 0.01, '[1,2]'),"
            " (2, 1, 2000, 0, 0.12, NULL, NULL, NULL),"
            " (3, 1, 3000, 1, NULL, 3e-6, 0.03, NULL),"
            " (4, 1, 4000, 1, 0.14, 4e-6, 0.04, NULL),"
            " (5, 0, 9000, 1, 0.99, 9e-6, 0.09, NULL)");
  const auto series = load_advanced_ics2_series(h.db, 1);
  REQUIRE(series.size() == 2);  // run 2 not advanced, run 3 without ICS2, run 5 another pair
  CHECK(series[0] == std::array<double, 2>{1000, 0.11});
  CHECK(series[1] == std::array<double, 2>{4000, 0.14});

  CHECK(load_forecast_curve(h.db, 1) == std::optional<std::string>("[1,2]"));
  CHECK_FALSE(load_forecast_curve(h.db, 3).has_value());

  const auto near = load_predictions_nearest(h.db, 1, 3300, 2);
  REQUIRE(near.size() == 2);
  CHECK(near[0].cycles == 3000);
  CHECK(near[0].wear_mean_m == 3e-6);
  CHECK(near[1].cycles == 4000);
  CHECK(near[1].pitting_mean == 0.04);

  const StoredTable newest = load_newest_prediction(h.db, 1);
  REQUIRE(newest.rows.size() == 1);
  CHECK(std::get<std::int64_t>(newest.rows[0][*newest.column("run_id")]) == 4);
  CHECK(std::get<double>(newest.rows[0][*newest.column("ics2_low")]) == 0.14);
  CHECK(is_null(newest.rows[0][*newest.column("wear_limit_m")]));
}

TEST_CASE("storage readers: the K updates of a gear pair by id", "[storage][readers]") {
  ReaderDb h("k-updates");
  h.db.exec("INSERT INTO model_runs(id, gear_pair, cycles, advanced) VALUES (1, 0, 1000, 1), (2, 1, 2000, 1)");
  h.db.exec("INSERT INTO k_update_log(id, run_id, gear_pair, cycles, kind, triggered_by, outcome, old_value, new_value,"
            " applies_from_cycles, iterations, evidence)"
            " VALUES (1, 1, 0, 1000, 'k_wear', 'rms_sa_mismatch', 'converged', 1e-16, 2e-16, 1000, 3, 'first'),"
            "        (2, 2, 1, 2000, 'k_wear', 'rms_sa_mismatch', 'converged', 2e-16, 1.5e-16, 2000, 4, 'second')");
  const StoredTable t = load_gear_pair_k_updates(h.db, 1);
  REQUIRE(t.rows.size() == 1);
  REQUIRE(t.columns.size() == 16);
  CHECK(t.columns.front() == "id");
  CHECK(t.columns.back() == "evidence");
  CHECK(std::get<std::int64_t>(t.rows[0][*t.column("iterations")]) == 4);
  CHECK(std::get<double>(t.rows[0][*t.column("new_value")]) == 1.5e-16);
  CHECK(std::get<std::string>(t.rows[0][*t.column("evidence")]) == "second");
}

TEST_CASE("storage readers: the processing thread's history starts at the newest life-counter reset", "[storage][readers]") {
  ReaderDb h("processing");
  h.record(1, "2026-01-01T00:00:00Z", "100");
  h.record(2, "2026-01-03T00:00:00Z", "50");
  h.record(3, "2026-01-04T00:00:00Z", "80");
  h.record(4, "2026-01-05T00:00:00Z", "NULL");
  h.record(5, "2026-01-06T00:00:00Z", "90", 0);
  h.db.exec("INSERT INTO life_counter_events(stream_key, sample_index, previous_revolutions, revolutions, detected_at)"
            " VALUES (1, 1500, 100, 0, '2026-01-02T00:00:00Z')");
  for (int r : {1, 2, 3, 4, 5}) h.value(r, 0, "ics2_low_band", ("0." + std::to_string(r)).c_str());
  h.value(2, 0, "ics2_high_band", "0.25");
  h.value(3, 1, "ics2_low_band", "NULL");
  h.value(3, 0, "rms_sa", "2.5");
  h.db.exec("INSERT INTO band_selections(record_id, channel, criterion, level, centre_hz, bandwidth_hz, value) VALUES"
            " (2, 0, 'ics2', 3, 4800, 800, 0.7), (2, 0, 'kurtosis', 3, 9600, 800, 5.0)");

  const auto ics2 = load_gear_pair_ics2_history(h.db);
  REQUIRE(ics2.size() == 3);  // records 2 and 3 (channels 0 and 1); 1 before the reset, 4 without cycles, 5 not analysed
  CHECK(ics2[0].channel == 0);
  CHECK(ics2[0].cycles == 50);
  CHECK(ics2[0].low_band == 0.2);
  CHECK(ics2[0].high_band == 0.25);
  CHECK(ics2[0].selected_centre_hz == 4800);
  CHECK(ics2[0].selected_value == 0.7);
  CHECK(ics2[1].cycles == 80);
  CHECK_FALSE(ics2[1].high_band.has_value());
  CHECK_FALSE(ics2[1].selected_centre_hz.has_value());
  const auto& no_value = ics2[1].channel == 1 ? ics2[1] : ics2[2];
  CHECK_FALSE(no_value.low_band.has_value());

  const auto values = load_gear_pair_indicator_values(h.db);
  // Records 2, 3 and 4 (analysed, after the reset), NULL values left out.
  REQUIRE(values.size() == 5);
  CHECK(values[0].record_id == 2);
  CHECK(values[4].record_id == 4);
  CHECK(values[4].name == "ics2_low_band");
  CHECK(values[4].value == 0.4);
  double rms = 0;
  for (const auto& v : values)
    if (v.name == "rms_sa") rms = v.value;
  CHECK(rms == 2.5);
}

TEST_CASE("storage readers: staff query views filter by time, channel and name, and keep the newest", "[storage][readers]") {
  ReaderDb h("query");
  h.record(1, "2026-01-01T00:00:00Z", "10");
  h.record(2, "2026-01-02T00:00:00Z", "20");
  h.record(3, "2026-01-03T00:00:00Z", "30");
  for (int r : {1, 2, 3}) {
    h.value(r, 0, "rms_sa", std::to_string(r).c_str());
    h.value(r, 1, "rms_sa", std::to_string(10 * r).c_str());
    h.value(r, 0, "kurtosis_raw", "3");
  }
  QueryFilter f;
  f.since = "2026-01-02";
  f.channel = 1;
  f.name = "rms_sa";
  StoredTable t = query_view(h.db, QueryView::indicators, f);
  REQUIRE(t.rows.size() == 2);
  REQUIRE(t.columns == std::vector<std::string>{"record_id", "created_at", "cycles", "speed_hz", "torque_nm", "channel", "name", "value"});
  // Without --limit the view's rows come in the order the view gives them: compare by record.
  std::sort(t.rows.begin(), t.rows.end(), [](const auto& a, const auto& b) { return std::get<std::int64_t>(a[0]) < std::get<std::int64_t>(b[0]); });
  CHECK(std::get<std::int64_t>(t.rows[0][0]) == 2);
  CHECK(std::get<std::string>(t.rows[0][1]) == "2026-01-02T00:00:00Z");
  CHECK(std::get<double>(t.rows[0][2]) == 20);
  CHECK(std::get<double>(t.rows[0][7]) == 20);
  CHECK(std::get<double>(t.rows[1][7]) == 30);
  CHECK(is_null(t.rows[1][3]));

  QueryFilter newest;
  newest.limit = 2;
  newest.until = "2026-01-03";
  const StoredTable n = query_view(h.db, QueryView::indicators, newest);
  REQUIRE(n.rows.size() == 2);  // 6 rows before the 3rd, the 2 newest (both of one record) in time order
  CHECK(std::get<std::int64_t>(n.rows[0][0]) == 2);
  CHECK(std::get<std::int64_t>(n.rows[1][0]) == 2);

  QueryFilter bad;
  bad.channel = 0;
  CHECK_THROWS_AS(query_view(h.db, QueryView::inspections, bad), std::invalid_argument);
  for (auto v : kAllQueryViews) CHECK(parse_query_view(to_string(v)) == v);
  CHECK_FALSE(parse_query_view("alert").has_value());
  CHECK(query_view_availability(h.db, QueryView::predictions) == QueryViewAvailability::available);
}

TEST_CASE("storage readers: the report's health, plotted values and newest rows", "[storage][readers]") {
  ReaderDb h("report");
  CHECK_FALSE(has_no_tables(h.db));
  CHECK(has_table_or_view(h.db, "predictions"));
  CHECK_FALSE(has_table_or_view(h.db, "no_such_table"));
  h.db.exec("INSERT INTO runs(id, kind, source) VALUES (2, 'run', 'can0')");
  h.db.exec("INSERT INTO health_snapshots(run_id, taken_at, final, frames, samples, gap_samples, malformed_frames, duplicates,"
            " records_rejected) VALUES (1, '2026-01-01T00:00:00Z', 1, 100, 4000, 7, 2, 3, 1),"
            " (2, '2026-01-02T00:00:00Z', 0, 50, 2000, 0, 0, 0, 0)");
  const auto health = load_acquisition_health(h.db);
  REQUIRE(health.size() == 2);
  CHECK(health[0].run_id == 2);  // newest run first
  CHECK(health[0].run_kind == "run");
  CHECK(health[1].source == "test.log");
  CHECK(health[1].final);
  CHECK(health[1].frames == 100);
  CHECK(health[1].lost_samples == 7);
  CHECK(health[1].rejected_frames == 5);
  CHECK(health[1].records_rejected == 1);
  // Samples a ring overflow lost are stored only as gap events: they add to the run's lost samples;
  // a protocol gap is in gap_samples already.
  h.db.exec("INSERT INTO gap_events(stream_key, channel, first_missing_index, missing_samples, cause) VALUES"
            " (1, 0, 10, 40, 'ring_overflow'), (1, 0, 100, 5, 'protocol')");
  const auto with_overflow = load_acquisition_health(h.db);
  REQUIRE(with_overflow.size() == 2);
  CHECK(with_overflow[1].lost_samples == 7 + 40);
  CHECK(with_overflow[0].lost_samples == 0);

  h.record(1, "2026-01-01T00:00:00Z", "10");
  h.record(2, "2026-01-02T00:00:00Z", "20");
  h.value(1, 0, "rms_sa", "1");
  h.value(2, 0, "rms_sa", "2");
  h.value(2, 0, "mean_carrier_hz_low", "4800");
  h.value(2, 0, "meanXcarrier_hz_low", "1");  // LIKE's '_' is escaped: not a plotted name
  h.value(2, 0, "crest_factor", "4");
  h.value(2, 1, "rms_sa", "NULL");
  auto plotted = load_plot_indicator_values(h.db, 2);
  std::sort(plotted.begin(), plotted.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  REQUIRE(plotted.size() == 2);
  CHECK(plotted[0].record_id == 2);
  CHECK(plotted[0].name == "mean_carrier_hz_low");
  CHECK(plotted[0].value == 4800);
  CHECK(plotted[1].name == "rms_sa");
  CHECK(plotted[1].value == 2);

  h.db.exec("INSERT INTO model_runs(id, gear_pair, cycles, advanced, wear_mean_m) VALUES (1, 0, 10, 1, 1e-6), (2, 0, 20, 1, 2e-6),"
            " (3, 0, 30, 0, NULL)");
  const NewestRows runs = load_newest_rows(h.db, "model_runs", 2);
  CHECK(runs.total_rows == 3);
  REQUIRE(runs.table.rows.size() == 2);
  CHECK(std::get<std::int64_t>(runs.table.rows[0][*runs.table.column("id")]) == 3);  // a table: newest rowid first
  CHECK(std::get<std::int64_t>(runs.table.rows[1][*runs.table.column("id")]) == 2);
  const NewestRows view = load_newest_rows(h.db, "predictions", 1);
  CHECK(view.total_rows == 2);  // the advanced runs
  CHECK(view.table.rows.size() == 1);
}

TEST_CASE("storage readers: a new file has no tables and no gap reports table", "[storage][readers]") {
  testing::TempDir dir("readers-empty");
  Database db((dir / "e.db").string());
  CHECK(has_no_tables(db));
  CHECK_FALSE(has_gap_report_tables(db));
  open_and_migrate(db);
  REQUIRE(has_gap_report_tables(db));
  CHECK(count_gap_reports(db) == 0);
}

TEST_CASE("storage readers: the current gear pair's first record by the gear-pair rule", "[storage][readers][gear_pair]") {
  ReaderDb h("pair-start");
  for (int r = 1; r <= 5; ++r) h.record(r, "2026-01-01T00:00:00Z", std::to_string(100 * r).c_str());
  CHECK(current_gear_pair_first_record(h.db) == 1);  // neither: one pair
  // A reset inside record 3 (samples 3000-3999), the counts still rising: record 4 begins the pair.
  h.db.exec("INSERT INTO life_counter_events(stream_key, sample_index, previous_revolutions, revolutions) VALUES (1, 3500, 350, 0)");
  const GearPairInputs in = load_gear_pair_inputs(h.db);
  REQUIRE(in.record_ids.size() == 5);
  CHECK(in.records[2].count == 300.0);
  CHECK(in.records[2].start.index == 3000);
  REQUIRE(in.resets.size() == 1);
  CHECK(in.resets[0].index == 3500);
  CHECK(current_gear_pair_first_record(h.db) == 4);
  // Record 6's count below record 5's with no reset recorded: record 6 begins the pair.
  h.record(6, "2026-01-02T00:00:00Z", "20");
  CHECK(current_gear_pair_first_record(h.db) == 6);
  // A reset after the newest record: the installed pair has no records yet.
  h.db.exec("INSERT INTO life_counter_events(stream_key, sample_index, previous_revolutions, revolutions) VALUES (1, 7000, 30, 0)");
  CHECK(current_gear_pair_first_record(h.db) == 7);
  CHECK(load_gear_pair_indicator_values(h.db).empty());
}

}  // namespace test_storage_readers
