#include <cmath>
#include "gearwatch/storage/gap_reports.hpp"

#include <algorithm>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "gap_report_fixture.hpp"
#include "gearwatch/storage/schema.hpp"
#include "gearwatch/storage/writer.hpp"
#include "temp_dir.hpp"

namespace test_gap_reports {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using gearwatch::storage::Database;
using gearwatch::storage::Statement;

namespace {

void check_same(const gap::FamilyGap& a, const gap::FamilyGap& b) {
  INFO("family " << gap::to_string(b.family));
  CHECK(a.family == b.family);
  CHECK(a.resolved == b.resolved);
  CHECK(a.unresolved_reason == b.unresolved_reason);
  CHECK(a.distance_db == b.distance_db);
  CHECK(a.distance_interval_db.low == b.distance_interval_db.low);
  CHECK(a.distance_interval_db.high == b.distance_interval_db.high);
  CHECK(a.energy_share == b.energy_share);
  CHECK(a.significant == b.significant);
}

void check_same(const std::vector<gap::FamilyGap>& a, const std::vector<gap::FamilyGap>& b) {
  REQUIRE(a.size() == b.size());
  for (std::size_t i = 0; i < a.size(); ++i) check_same(a[i], b[i]);
}

void check_same(const gap::GapReport& a, const gap::GapReport& b) {
  CHECK(a.input_revolutions == b.input_revolutions);
  CHECK(a.speeds_hz == b.speeds_hz);
  CHECK(a.training_records == b.training_records);
  CHECK(a.held_out_records == b.held_out_records);
  check_same(a.before, b.before);
  check_same(a.after, b.after);
  REQUIRE(a.candidates.size() == b.candidates.size());
  for (std::size_t i = 0; i < a.candidates.size(); ++i) {
    const auto& x = a.candidates[i];
    const auto& y = b.candidates[i];
    INFO("candidate " << i);
    CHECK(x.effect == y.effect);
    CHECK(x.parameters == y.parameters);
    CHECK(x.explains == y.explains);
    check_same(x.held_out_after, y.held_out_after);
    CHECK(x.shrinkage == y.shrinkage);
    CHECK(x.information_criterion == y.information_criterion);
    CHECK(x.worsens_other_family == y.worsens_other_family);
    REQUIRE(x.at_bounds.size() == y.at_bounds.size());
    for (std::size_t j = 0; j < x.at_bounds.size(); ++j) {
      CHECK(x.at_bounds[j].name == y.at_bounds[j].name);
      CHECK(x.at_bounds[j].bound == y.at_bounds[j].bound);
      CHECK(x.at_bounds[j].upper == y.at_bounds[j].upper);
    }
  }
  REQUIRE(a.features.size() == b.features.size());
  for (std::size_t i = 0; i < a.features.size(); ++i) {
    const auto& x = a.features[i];
    const auto& y = b.features[i];
    INFO("feature " << i);
    CHECK(x.movement == y.movement);
    CHECK(x.shaft == y.shaft);
    CHECK(x.order == y.order);
    CHECK(x.order_low == y.order_low);
    CHECK(x.order_high == y.order_high);
    CHECK(x.hz == y.hz);
    CHECK(x.hz_low == y.hz_low);
    CHECK(x.hz_high == y.hz_high);
    CHECK(x.size_db == y.size_db);
    CHECK(x.size_interval_db.low == y.size_interval_db.low);
    CHECK(x.size_interval_db.high == y.size_interval_db.high);
    CHECK(x.p_value == y.p_value);
    CHECK(x.explained_by == y.explained_by);
    CHECK(x.description.kind == y.description.kind);
    CHECK(x.description.shaft == y.description.shaft);
    CHECK(x.description.gap_db == y.description.gap_db);
    CHECK(x.description.residual_db == y.description.residual_db);
    REQUIRE(x.description.parameters.size() == y.description.parameters.size());
    for (std::size_t j = 0; j < x.description.parameters.size(); ++j) {
      CHECK(x.description.parameters[j].first == y.description.parameters[j].first);
      const double u = x.description.parameters[j].second, v = y.description.parameters[j].second;
      CHECK((u == v || (std::isnan(u) && std::isnan(v))));
    }
    REQUIRE(x.seen_in.size() == y.seen_in.size());
    for (std::size_t j = 0; j < x.seen_in.size(); ++j) {
      const auto &s = x.seen_in[j], &t = y.seen_in[j];
      CHECK(s.held_out == t.held_out);
      CHECK(s.record == t.record);
      CHECK(s.speed_hz == t.speed_hz);
      CHECK((s.torque_nm == t.torque_nm || (std::isnan(s.torque_nm) && std::isnan(t.torque_nm))));
      CHECK(s.order == t.order);
      CHECK(s.hz == t.hz);
      CHECK(s.size_db == t.size_db);
    }
  }
  CHECK(a.chosen == b.chosen);
  CHECK(a.unexplained == b.unexplained);
  CHECK(a.k_wear_before == b.k_wear_before);
  CHECK(a.k_wear_after == b.k_wear_after);
  CHECK(a.order_axis == b.order_axis);
  CHECK(a.measured_order_db == b.measured_order_db);
  CHECK(a.twin_order_db == b.twin_order_db);
  CHECK(a.twin_after_order_db == b.twin_after_order_db);
  CHECK(a.hz_axis == b.hz_axis);
  CHECK(a.measured_hz_db == b.measured_hz_db);
  CHECK(a.twin_hz_db == b.twin_hz_db);
  CHECK(a.twin_after_hz_db == b.twin_after_hz_db);
  REQUIRE(a.order_bands.size() == b.order_bands.size());
  for (std::size_t i = 0; i < a.order_bands.size(); ++i) {
    CHECK(a.order_bands[i].first == b.order_bands[i].first);
    CHECK(a.order_bands[i].second.low == b.order_bands[i].second.low);
    CHECK(a.order_bands[i].second.high == b.order_bands[i].second.high);
  }
  REQUIRE(a.hz_bands.size() == b.hz_bands.size());
  for (std::size_t i = 0; i < a.hz_bands.size(); ++i) {
    CHECK(a.hz_bands[i].first == b.hz_bands[i].first);
    CHECK(a.hz_bands[i].second.low == b.hz_bands[i].second.low);
    CHECK(a.hz_bands[i].second.high == b.hz_bands[i].second.high);
  }
}

}  // namespace

TEST_CASE("gap reports: a stored report reads back with every double exact and every list in order", "[gap_reports][storage]") {
  const testing::TempDir dir("gap-roundtrip");
  Database db((dir / "a.db").string());
  storage::open_and_migrate(db);
  const gap::GapReport known = testing::known_gap_report();
  gap::GapReport second = known;
  second.k_wear_after.reset();  // a report without an after figure keeps it absent (NULL)
  second.chosen.clear();
  second.unexplained = {gap::FamilyKind::fixed_frequency, gap::FamilyKind::input_sidebands};  // not in enum order
  second.input_revolutions = 234567.125;
  std::int64_t first_id = 0, second_id = 0;
  {
    storage::Transaction tx(db);
    first_id = storage::insert_gap_report(db, known, {std::nullopt, 2});
    second_id = storage::insert_gap_report(db, second, {std::nullopt, 3});
    tx.commit();
  }
  CHECK(second_id == first_id + 1);
  const auto all = storage::load_gap_reports(db);
  REQUIRE(all.size() == 2);
  CHECK(all[0].id == first_id);
  CHECK(all[0].context.gear_pair == 2);
  CHECK_FALSE(all[0].context.record_id);
  CHECK_FALSE(all[0].created_at.empty());
  check_same(all[0].report, known);
  check_same(all[1].report, second);
  CHECK_FALSE(all[1].report.k_wear_after);
  const auto newest = storage::load_gap_reports(db, 1);
  REQUIRE(newest.size() == 1);
  CHECK(newest[0].id == second_id);
}

TEST_CASE("gap reports: the gap_reports view has one row per report and family with before, after and the attribution",
          "[gap_reports][storage]") {
  const testing::TempDir dir("gap-view");
  Database db((dir / "a.db").string());
  storage::open_and_migrate(db);
  {
    storage::Transaction tx(db);
    storage::insert_gap_report(db, testing::known_gap_report(), {std::nullopt, 0});
    tx.commit();
  }
  Statement count(db, "SELECT count(*) FROM gap_reports");
  REQUIRE(count.step());
  CHECK(count.get_int(0) == 7);
  Statement row(db, "SELECT distance_before_db, interval_before_low_db, interval_before_high_db, energy_share_before, significant_before,"
                    " distance_after_db, significant_after, shrinkage, attributed_to, unexplained, chosen, cycles, k_wear_before,"
                    " k_wear_after, training_records, held_out_records, speeds_hz, resolved, unresolved_reason"
                    " FROM gap_reports WHERE family = ?");
  row.bind(1, "fixed_frequency");
  REQUIRE(row.step());
  CHECK(row.get_double(0) == 12.625);
  CHECK(row.get_double(1) == 10.5);
  CHECK(row.get_double(2) == 14.75);
  CHECK(row.get_double(3) == 0.68);
  CHECK(row.get_int(4) == 1);
  CHECK(row.get_double(5) == 1.5);
  CHECK(row.get_int(6) == 0);
  CHECK(row.get_double(7) == Approx(1.0 - 1.5 / 12.625).epsilon(1e-15));
  CHECK(row.get_text(8) == "casing_mode");
  CHECK(row.get_int(9) == 0);
  CHECK(row.get_text(10) == "casing_mode");
  CHECK(row.get_double(11) == 123456.789);
  CHECK(row.get_double(12) == 4.25e-17);
  CHECK(row.get_double(13) == 3.0e-17);
  CHECK(row.get_int(14) == 4);
  CHECK(row.get_int(15) == 2);
  CHECK(row.get_text(16) == "[10.0,6.666666666666667]");
  CHECK(row.get_int(17) == 1);
  CHECK(row.is_null(18));
  row.reset();
  // Left unexplained: no chosen effect explains the output sidebands.
  row.bind(1, "output_sidebands");
  REQUIRE(row.step());
  CHECK(row.is_null(8));
  CHECK(row.get_int(9) == 1);
  row.reset();
  // The casing mode also explains the input sidebands.
  row.bind(1, "input_sidebands");
  REQUIRE(row.step());
  CHECK(row.get_text(8) == "casing_mode");
  row.reset();
  row.bind(1, "output_shaft_orders");
  REQUIRE(row.step());
  CHECK(row.get_int(17) == 0);
  CHECK(row.get_text(18) == "records shorter than 8 output revolutions");
  CHECK(row.is_null(7));  // an unresolved family has no distance to shrink (0 dB before)
  row.reset();

  Statement candidates(db, "SELECT rank, effect, shrinkage, information_criterion, worsens_other_family, chosen_step, explains, parameters"
                           " FROM gap_candidates ORDER BY rank");
  REQUIRE(candidates.step());
  CHECK(candidates.get_text(1) == "casing_mode");
  CHECK(candidates.get_double(2) == 0.875);
  CHECK(candidates.get_double(3) == -42.5);
  CHECK(candidates.get_int(4) == 0);
  CHECK(candidates.get_int(5) == 0);
  CHECK(candidates.get_text(6) == "fixed_frequency,input_sidebands");
  CHECK(candidates.get_text(7) == R"([["frequency_hz",2400.1428571428573],["damping_ratio",0.05],["gain",3.75]])");
  REQUIRE(candidates.step());
  CHECK(candidates.get_text(1) == "mount_resonance");
  CHECK(candidates.get_int(4) == 1);
  CHECK(candidates.is_null(5));
  REQUIRE(candidates.step());
  CHECK(candidates.get_text(1) == "noise_floor");
  CHECK_FALSE(candidates.step());
}

TEST_CASE("gap reports: family and effect names are the enums' vocabulary and nothing else is stored",
          "[gap_reports][storage][vocabulary]") {
  const testing::TempDir dir("gap-vocabulary");
  Database db((dir / "a.db").string());
  storage::open_and_migrate(db);
  auto tokens = [&](const char* domain) {
    std::vector<std::string> out;
    Statement s(db, "SELECT token FROM vocabulary WHERE domain = ? ORDER BY token");
    s.bind(1, domain);
    while (s.step()) out.push_back(s.get_text(0));
    return out;
  };
  std::vector<std::string> families, effects;
  for (auto f : gap::kAllFamilyKinds) families.emplace_back(gap::to_string(f));
  for (auto e : gap::kAllCandidateEffects) effects.emplace_back(gap::to_string(e));
  std::sort(families.begin(), families.end());
  std::sort(effects.begin(), effects.end());
  CHECK(tokens("gap_family") == families);
  CHECK(tokens("gap_effect") == effects);
  CHECK(families.size() == 7);
  CHECK(effects.size() == 10);
  db.exec("INSERT INTO gap_report_runs(speeds_hz, training_records, held_out_records) VALUES ('[]', 1, 1)");
  CHECK_THROWS_WITH(db.exec("INSERT INTO gap_report_families(report_id, family) VALUES (1, 'gear_mesh')"),
                    Catch::Contains("not in vocabulary domain gap_family"));
  CHECK_THROWS_WITH(db.exec("INSERT INTO gap_report_chosen(report_id, step, effect) VALUES (1, 0, 'gremlins')"),
                    Catch::Contains("not in vocabulary domain gap_effect"));
  CHECK_THROWS_WITH(db.exec("INSERT INTO gap_report_candidates(report_id, rank, effect, worsens_other_family, parameters)"
                            " VALUES (1, 0, 'gremlins', 0, '[]')"),
                    Catch::Contains("not in vocabulary domain gap_effect"));
  CHECK_NOTHROW(db.exec("INSERT INTO gap_report_families(report_id, family) VALUES (1, 'broadband')"));
}

TEST_CASE("gap reports: the writer stores a report with its twin_drift transitions in one message", "[gap_reports][storage]") {
  const testing::TempDir dir("gap-writer");
  const std::string path = (dir / "a.db").string();
  {
    storage::WriterOptions options;
    options.database = path;
    storage::StorageWriter writer(options);
    writer.start();
    storage::GapReportResult m;
    m.has_record = false;
    m.gear_pair = 1;
    m.report = testing::known_gap_report();
    const AlertKey key{AlertKind::twin_drift, -1, "fixed_frequency"};
    m.alerts.push_back(AlertEvent{key, AlertSeverity::warning, AlertTransition::raised, "12.6 dB", "new gap"});
    AlertState st;
    st.active = true;
    st.value = "12.6 dB";
    st.consecutive_present = 1;
    m.alert_states.emplace_back(key, st);
    writer.submit(std::move(m));
    writer.stop();
    CHECK(writer.counters().lost_at_exit == 0);
    CHECK(writer.counters().rows_rejected == 0);
  }
  Database db(path, Database::Mode::read_only);
  const auto all = storage::load_gap_reports(db);
  REQUIRE(all.size() == 1);
  CHECK(all[0].context.gear_pair == 1);
  check_same(all[0].report, testing::known_gap_report());
  Statement a(db, "SELECT kind, subject, transition, value, severity FROM alerts");
  REQUIRE(a.step());
  CHECK(a.get_text(0) == "twin_drift");
  CHECK(a.get_text(1) == "fixed_frequency");
  CHECK(a.get_text(2) == "raised");
  CHECK(a.get_text(3) == "12.6 dB");
  CHECK(a.get_text(4) == "warning");
  Statement s(db, "SELECT active, value FROM alert_state WHERE kind = 'twin_drift' AND subject = 'fixed_frequency'");
  REQUIRE(s.step());
  CHECK(s.get_int(0) == 1);
  CHECK(s.get_text(1) == "12.6 dB");
}

}  // namespace test_gap_reports
