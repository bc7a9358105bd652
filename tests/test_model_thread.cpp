// The model thread in the daemon: its state round-trips through the database exactly, a campaign
// replayed one file per process ends in the same state as one long replay, the queue coalesces
// when behind (live) and loses nothing in a replay, bad input is stored with its reason, and the
// CLI shows it (`twin state`, `query updates|predictions`, `inspect`).
#include "model_thread.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "command_runner.hpp"
#include "gearwatch/storage/schema.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "temp_dir.hpp"

namespace test_model_thread {  // this file's own: the test files compile together (unity build)

namespace fs = std::filesystem;
using namespace gearwatch;
using gearwatch::testing::run_command;

namespace {

struct Cli {
  int status;
  std::string out, err;
};
Cli gw(const std::string& args) {
  const auto r = run_command(std::string(GEARWATCH_BINARY) + " " + args);
  return {r.status, r.out, r.err};
}

double scalar(const fs::path& db, const std::string& sql) {
  storage::Database d(db.string(), storage::Database::Mode::read_only);
  storage::Statement s(d, sql);
  REQUIRE(s.step());
  return s.is_null(0) ? std::nan("") : s.get_double(0);
}

std::string text(const fs::path& db, const std::string& sql) {
  storage::Database d(db.string(), storage::Database::Mode::read_only);
  storage::Statement s(d, sql);
  REQUIRE(s.step());
  return s.is_null(0) ? std::string("NULL") : s.get_text(0);
}

// Every column of every row, doubles printed to the last bit.
std::string dump(const fs::path& db, const std::string& sql) {
  storage::Database d(db.string(), storage::Database::Mode::read_only);
  storage::Statement s(d, sql);
  std::ostringstream out;
  out.precision(17);
  while (s.step()) {
    for (int i = 0; i < s.column_count(); ++i) {
      if (s.is_null(i)) out << "NULL";
      else if (s.column_type(i) == storage::ColumnType::real) out << s.get_double(i);
      else out << s.get_text(i);
      out << "|";
    }
    out << "\n";
  }
  return out.str();
}

// 40 kHz, so the 2-13 kHz pitting band is analysed; 1 s records; a short forecast horizon.
fs::path model_config(const fs::path& dir, const std::string& extra = "") {
  const auto path = dir / "model.toml";
  std::ofstream(path) << "[rig]\nsample_rate_hz = 40000\n[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n"
                         "[records]\nlength_s = 1.0\ninterval_s = 1.0\nmin_length_s = 0.5\n"
                         // Compared absolutely (no commissioning ratio): the first record then calibrates
                         // K_wear, so the restart tests carry a K_wear anchor across processes.
                         "[model]\nforecast_horizon_cycles = 100000.0\ncommissioning_records = 0\n"
                      << extra;
  return path;
}

// Capture k of a campaign: `seconds` whole seconds (one 1 s record each, two by default) at 20 Hz
// (7 output-shaft revolutions per record, so the residual indicators are computed), torque changing
// from file to file, the life counter and sample index continuing where the previous file ended.
void capture(const fs::path& out, int k, int seconds = 2) {
  std::ostringstream a;
  a << "simulate --out " << out.string() << " --duration " << seconds << ".0 --speed 20 --torque " << 12 + 4 * k
    << " --sample-rate 40000 --channels 1 --seed " << 7 + k << " --stream-id " << 1 + k << " --first-index " << 40000 * seconds * k
    << " --start-revs " << 20 * seconds * k;
  const auto r = gw(a.str());
  INFO(r.err);
  REQUIRE(r.status == 0);
}

}  // namespace

TEST_CASE("model thread: the stored state round-trips every double exactly", "[model][daemon]") {
  wear::ModelSettings s;
  s.loop.profile_points = 11;
  s.forecast_horizon_cycles = 1000;
  wear::TwinModel model(twin::GearboxParameters{}, s, [](const wear::WearState&, const twin::OperatingPoint&) { return 1.0; });
  model.observe({0, 1234.5, 10.3, 20.1, std::nullopt, 0.1 + 0.2}, {});
  wear::ModelMemory m = model.memory();
  m.pitting_points = {{1.0 / 3.0, 1e-300, 0.1 + 0.2}, {2.0 / 3.0, 5e-324, 1.0 - 1e-16}};
  m.recent_k_wear = {1.65e-12, std::nextafter(1.65e-12, 1.0)};
  m.calibration_inspection_id = 123456789012345;
  m.shape_depth_ratio = 1.0 / 3.0 + 1.0, m.shape_peak_ratio = 0.1 + 3.4, m.shape_depth_elasticity = std::nextafter(0.9, 1.0);
  m.shape_cycles = 2.0 / 3.0 * 1e6;
  m.depth_ratio_points = {{987654321012, 1.0 / 7.0 * 1e6, std::log(1.0 / 3.0), std::log1p(0.05 * 0.05), 1.0 / 3.0 * 1e-5}};
  const wear::ModelMemory back = daemon::memory_from_json(daemon::memory_to_json(m));
  REQUIRE(back.depth_ratio_points.size() == 1);
  CHECK(back.depth_ratio_points[0].inspection_id == 987654321012);
  CHECK(back.depth_ratio_points[0].cycles == 1.0 / 7.0 * 1e6);
  CHECK(back.depth_ratio_points[0].log_ratio == std::log(1.0 / 3.0));
  CHECK(back.depth_ratio_points[0].var == std::log1p(0.05 * 0.05));
  CHECK(back.depth_ratio_points[0].model_m == 1.0 / 3.0 * 1e-5);
  {
    // A state written before the rate reading has no model depth: read as 0 (no rate from it).
    std::string old = daemon::memory_to_json(m);
    const std::string key = "\"model_m\":";
    const std::size_t at = old.find(key);
    REQUIRE(at != std::string::npos);
    const std::size_t end = old.find_first_of(",}", at);
    old.erase(old[end] == ',' ? at : at - 1, end - at + 1);
    CHECK(daemon::memory_from_json(old).depth_ratio_points.at(0).model_m == 0.0);
  }
  CHECK(back.shape_depth_ratio == 1.0 / 3.0 + 1.0);
  CHECK(back.shape_peak_ratio == 0.1 + 3.4);
  CHECK(back.shape_depth_elasticity == std::nextafter(0.9, 1.0));
  CHECK(back.shape_cycles == 2.0 / 3.0 * 1e6);
  CHECK(daemon::memory_to_json(back) == daemon::memory_to_json(m));
  CHECK(back.current.state.pinion_depth_m == m.current.state.pinion_depth_m);
  CHECK(back.current.state.cycles == m.current.state.cycles);
  CHECK(back.current.next_step_cycles == m.current.next_step_cycles);
  CHECK(back.pitting_points[0].ics2 == 1e-300);
  CHECK(back.pitting_points[1].ics2 == 5e-324);
  CHECK(back.pitting_points[0].density == 0.1 + 0.2);
  CHECK(back.recent_k_wear[1] == std::nextafter(1.65e-12, 1.0));
  CHECK(back.intervals.size() == m.intervals.size());
  CHECK(back.intervals[0].torque_nm == 20.1);
  CHECK(back.calibration_inspection_id == 123456789012345);
  CHECK_THROWS_WITH(daemon::memory_from_json("{\"format\": 1}"), Catch::Contains("model state is not readable"));
  CHECK_THROWS_WITH(daemon::memory_from_json("{\"format\": 2}"), Catch::Contains("unknown state format"));
}

TEST_CASE("model thread: the posterior and residuals round-trip, and a state stored before them reads with the defaults",
          "[model][daemon]") {
  wear::ModelSettings s;
  s.loop.profile_points = 11;
  s.forecast_horizon_cycles = 1000;
  wear::TwinModel model(twin::GearboxParameters{}, s, [](const wear::WearState&, const twin::OperatingPoint&) { return 1.0; });
  model.observe({0, 1234.5, 10.3, 20.1, 1.0, 0.3}, {});
  wear::ModelMemory m = model.memory();
  REQUIRE(m.log_k_wear.valid);   // the prior, from the start of the pair
  m.log_k_pitting = {true, -216.1 + 1.0 / 3.0, 0.1 + 0.2, 4.5e5};
  m.rms_residuals = {{0.1 + 0.2, 0.0}, {-1e-300, 1.0}};
  m.pitting_calibration_var = 1.0 / 7.0;
  m.scale_residual_sum_sq = 2.0 / 3.0;
  m.scale_residual_count = 5;
  m.ics2_scale_inspections = 1;
  m.ics2_scale_baseline_sd = 1e-3 / 3.0;
  m.ics2_scale_form = wear::Ics2ScaleForm::square_root;
  m.ics2_scale_baseline = 2e-3 / 3.0;
  m.last_ics2_calibration_cycles = 6.5e5;
  m.rms_sa_reference_ratio = 1.0 + 1.0 / 3.0;
  m.rms_sa_reference_records = {{0.0, std::log(1.0 + 1.0 / 3.0)}, {20.0 / 3.0, -1e-300}};
  m.rms_sa_reference_closed = true;
  m.k_wear_identified_si = 3.0e-16 / 7.0;
  const std::string text = daemon::memory_to_json(m);
  const wear::ModelMemory back = daemon::memory_from_json(text);
  CHECK(daemon::memory_to_json(back) == text);
  CHECK(back.log_k_pitting.mean == -216.1 + 1.0 / 3.0);
  CHECK(back.log_k_wear.var == m.log_k_wear.var);
  CHECK(back.rms_residuals[1][0] == -1e-300);
  CHECK(back.scale_residual_count == 5);
  CHECK(back.last_ics2_calibration_cycles == 6.5e5);
  CHECK(back.rms_sa_reference_ratio == 1.0 + 1.0 / 3.0);
  CHECK(back.rms_sa_reference_records == m.rms_sa_reference_records);
  CHECK(back.rms_sa_reference_closed);
  CHECK(back.k_wear_identified_si == 3.0e-16 / 7.0);
  CHECK(back.ics2_scale_form == wear::Ics2ScaleForm::square_root);
  CHECK(back.ics2_scale_baseline == 2e-3 / 3.0);
  // A state of an older gearwatch: without the fields added with the posterior.
  nlohmann::json old = nlohmann::json::parse(text);
  for (const char* key : {"log_k_wear", "log_k_pitting", "rms_residuals", "pitting_calibration_var", "scale_residual",
                          "last_ics2_calibration_cycles", "rms_sa_reference", "k_wear_identified_si"})
    old.erase(key);
  old["ics2_scale"].erase("inspections");
  old["ics2_scale"].erase("baseline_sd");
  old["ics2_scale"].erase("form");
  old["ics2_scale"].erase("baseline");
  const wear::ModelMemory older = daemon::memory_from_json(old.dump());
  // A scale stored before the square-root one-inspection scale was linear.
  CHECK(older.ics2_scale_form == wear::Ics2ScaleForm::linear);
  CHECK(older.ics2_scale_baseline == 0.0);
  CHECK_FALSE(older.log_k_wear.valid);
  CHECK_FALSE(older.log_k_pitting.valid);
  CHECK(older.rms_residuals.empty());
  CHECK(older.scale_residual_count == 0);
  CHECK(older.last_ics2_calibration_cycles == -1.0);
  // A pair stored before the commissioning ratio is past its commissioning: ratio 1, closed.
  CHECK(older.rms_sa_reference_ratio == 1.0);
  CHECK(older.rms_sa_reference_records.empty());
  CHECK(older.rms_sa_reference_closed);
  // A state stored before the upper-bound rule: its K_wear is its last identified one.
  CHECK(older.k_wear_identified_si == older.k_wear_si);
  // The model given it starts the prior about its K_wear, from its cycles on.
  const wear::TwinModel resumed(twin::GearboxParameters{}, s, [](const wear::WearState&, const twin::OperatingPoint&) { return 1.0; }, older);
  CHECK(resumed.memory().log_k_wear.valid);
  CHECK(resumed.memory().log_k_wear.mean == std::log(std::max(older.k_wear_si, s.k_wear_min_si)));   // K 0 here: the lower bound
  CHECK(resumed.memory().log_k_wear.var == Approx(std::pow(s.prior_log_k_wear_sd, 2)).epsilon(1e-15));
  CHECK(resumed.memory().log_k_wear.cycles == older.current.state.cycles);
}

TEST_CASE("model thread: a campaign replayed one file per process ends in the state of one long replay",
          "[model][daemon][restart]") {
  const gearwatch::testing::TempDir dir("model-restart");
  const auto config = model_config(dir.path());
  // Three files of one record each: every record of the split replay is the first of its process,
  // so each resumes the model (K_wear and its root find's state included) from the stored state.
  // The claim is the same for any number of records per file; each record costs the model seconds
  // of twin runs in both replays.
  constexpr int kRecords = 3;
  std::ofstream long_capture(dir / "long.log");
  for (int k = 0; k < 3; ++k) {
    const auto file = dir / ("part" + std::to_string(k) + ".log");
    capture(file, k, 1);
    long_capture << std::ifstream(file).rdbuf();
  }
  long_capture.close();
  const auto split = dir / "split.db", whole = dir / "whole.db";
  for (int k = 0; k < 3; ++k) {
    const auto r = gw("replay " + (dir / ("part" + std::to_string(k) + ".log")).string() + " --db " + split.string() + " --config " + config.string());
    INFO(r.err);
    REQUIRE(r.status == 0);
  }
  const auto r = gw("replay " + (dir / "long.log").string() + " --db " + whole.string() + " --config " + config.string());
  INFO(r.err);
  REQUIRE(r.status == 0);
  REQUIRE(scalar(whole, "SELECT count(*) FROM model_runs WHERE advanced = 1") == kRecords);
  CHECK(scalar(split, "SELECT count(*) FROM model_runs WHERE advanced = 1") == kRecords);
  // The model learnt something (K_wear calibrated at the first record) and kept its history.
  CHECK(scalar(whole, "SELECT count(*) FROM k_updates WHERE kind = 'k_wear'") >= 1);
  CHECK(scalar(whole, "SELECT count(*) FROM predictions WHERE ics2_low IS NOT NULL") == kRecords);
  // Exactly the same state, K history and predictions, to the last bit.
  CHECK(text(split, "SELECT state FROM model_state") == text(whole, "SELECT state FROM model_state"));
  const std::string updates = "SELECT cycles, kind, triggered_by, outcome, old_value, new_value, applies_from_cycles, iterations,"
                              " measured, simulated_before, simulated_after, evidence FROM k_updates ORDER BY id";
  CHECK(dump(split, updates) == dump(whole, updates));
  const std::string predictions = "SELECT cycles, speed_hz, torque_nm, k_wear, k_pitting, rms_sa_measured, rms_sa_simulated, ics2_low,"
                                  " wear_mean_m, wear_max_m, pitting_mean, wear_cycles_left, wear_cycles_left_low,"
                                  " wear_cycles_left_high, issues FROM predictions ORDER BY run_id";
  CHECK(dump(split, predictions) == dump(whole, predictions));
}

TEST_CASE("model thread: live it coalesces to the newest record when behind, a replay loses nothing", "[model][daemon]") {
  const gearwatch::testing::TempDir dir("model-queue");
  for (const bool lossless : {false, true}) {
    const auto db = dir / (lossless ? "lossless.db" : "live.db");
    auto cfg = config::parse_config("[model]\nqueue_capacity = 2\nforecast_horizon_cycles = 1000.0\n", "test");
    cfg.storage.database = db.string();
    storage::StorageWriter writer(storage::WriterOptions{db.string(), 5000, 256, 512, 200, 30000, 60.0, {}, std::nullopt});
    writer.start();
    daemon::ModelThread model(cfg, writer, lossless);
    model.start();
    const int n = 40;
    for (int i = 1; i <= n; ++i) {
      daemon::ModelInput in;
      in.stream_sequence = 0;
      in.start_index = static_cast<std::uint64_t>(i);
      in.observation = {0, 1000.0 * i, 10, 20, std::nullopt, std::nullopt};
      model.submit(in);   // live: never waits
    }
    model.stop();
    writer.stop();
    const auto& c = model.counters();
    CHECK(c.received == n);
    CHECK(c.handled + c.coalesced == n);
    CHECK(c.queue_high_water <= 2);
    CHECK(scalar(db, "SELECT count(*) FROM model_runs") == static_cast<double>(c.handled));
    CHECK(scalar(db, "SELECT coalesce(sum(skipped_records), 0) FROM model_runs") == static_cast<double>(c.coalesced));
    // The newest record is never the one dropped: the model ends at its cycles.
    CHECK(scalar(db, "SELECT max(cycles) FROM model_runs") == 1000.0 * n);
    CHECK(scalar(db, "SELECT cycles FROM model_state") == 1000.0 * n);
    if (lossless) {
      CHECK(c.coalesced == 0);
    } else {
      CHECK(c.coalesced > 0);   // each record takes milliseconds; 40 submissions take microseconds
      // The skipped ones are named "stream:start_index" in the run that replaced them.
      const std::string ids = text(db, "SELECT skipped_record_ids FROM model_runs WHERE skipped_records > 0 ORDER BY id LIMIT 1");
      CHECK(ids.find("0:") == 0);
    }
  }
}

TEST_CASE("model thread: bad input is stored with its reason, nothing is NaN, the replay goes on", "[model][daemon]") {
  const gearwatch::testing::TempDir dir("model-bad");
  // Torque 12 N m against a model range that ends at 10: every record skipped with the reason.
  const auto config = model_config(dir.path(), "max_torque_nm = 10.0\n");
  capture(dir / "a.log", 0);   // 12 N m
  const auto db = dir / "a.db";
  auto r = gw("replay " + (dir / "a.log").string() + " --db " + db.string() + " --config " + config.string());
  REQUIRE(r.status == 0);
  CHECK(scalar(db, "SELECT count(*) FROM model_runs WHERE advanced = 0") == 2);
  CHECK(scalar(db, "SELECT count(*) FROM model_skips WHERE issues = 'operating_point_out_of_range'") == 2);
  CHECK(text(db, "SELECT detail FROM model_runs LIMIT 1").find("outside the model's") != std::string::npos);
  // 10 kHz: less than half of the 2-13 kHz band lies below 0.45 fs (at 20 kHz it is trimmed to
  // 2-9 kHz and analysed, docs/dsp.md §11), so the ICS2 low band is skipped; the model advances
  // without it.
  const auto db2 = dir / "b.db";
  const auto config2 = dir / "b.toml";
  std::ofstream(config2) << "[rig]\nsample_rate_hz = 10000\n[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n"
                            "[records]\nlength_s = 1.0\ninterval_s = 1.0\n[model]\nforecast_horizon_cycles = 100000.0\n";
  REQUIRE(gw("simulate --out " + (dir / "b.log").string() + " --duration 2.0 --speed 20 --torque 15 --sample-rate 10000 --channels 1"
             " --start-revs 1000").status == 0);
  r = gw("replay " + (dir / "b.log").string() + " --db " + db2.string() + " --config " + config2.string());
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(scalar(db2, "SELECT count(*) FROM predictions WHERE issues = 'missing_ics2'") == 2);
  CHECK(scalar(db2, "SELECT count(*) FROM predictions WHERE wear_mean_m IS NULL OR k_wear IS NULL OR rms_sa_simulated IS NULL") == 0);
  // No NaN anywhere: SQLite keeps NaN as NULL, and no stored text carries one.
  CHECK(scalar(db2, "SELECT count(*) FROM model_state WHERE state LIKE '%nan%' OR state LIKE '%null%'") == 0);
  // Impossible inspections are refused with one line; a possible one is stored for this gear pair.
  for (const std::string bad : {"--cycles 1020 --pitted-area 1.5", "--cycles 1020 --pitted-area -0.1", "--cycles 1020 --wear-depth -1e-6",
                                "--cycles 99999999 --pitted-area 0.1", "--cycles -5 --pitted-area 0.1", "--cycles nan --pitted-area 0.1"}) {
    const auto ins = gw("inspect --db " + db2.string() + " " + bad);
    INFO(bad << ": " << ins.err);
    CHECK(ins.status != 0);
    CHECK(ins.err.rfind("gearwatch: ", 0) == 0);
    CHECK(std::count(ins.err.begin(), ins.err.end(), '\n') == 1);
  }
  CHECK(gw("inspect --db " + db2.string() + " --cycles 99999999 --pitted-area 0.1").err.find("beyond the newest record") != std::string::npos);
  const auto ok = gw("inspect --db " + db2.string() + " --cycles 1000 --wear-depth 2e-6");
  CHECK(ok.status == 0);
  CHECK(scalar(db2, "SELECT count(*) FROM inspections") == 1);
  // twin state shows it against the prediction; query reads the views.
  const auto st = gw("twin state --db " + db2.string() + " --format json");
  INFO(st.err);
  REQUIRE(st.status == 0);
  const auto j = nlohmann::json::parse(st.out);
  CHECK(j["cycles"].get<double>() == scalar(db2, "SELECT max(cycles) FROM model_runs"));
  CHECK(j["k_wear_si"].get<double>() == scalar(db2, "SELECT k_wear FROM model_state"));
  CHECK(j["wear"]["combined_depth_m"].size() == 101);
  REQUIRE(j["inspections"].size() == 1);
  CHECK(j["inspections"][0]["predicted_wear_mean_m"].get<double>() == scalar(db2, "SELECT wear_mean_m FROM predictions ORDER BY abs(cycles - 1000) LIMIT 1"));
  const auto preds = gw("query predictions --db " + db2.string() + " --format json");
  REQUIRE(preds.status == 0);
  CHECK(nlohmann::json::parse(preds.out).size() == 2);
  // Every stored forecast states its interval's nominal coverage (issue 34: 90 %), through the CLI.
  for (const auto& row : nlohmann::json::parse(preds.out)) {
    REQUIRE(row.contains("interval_coverage"));
    CHECK(row["interval_coverage"].get<double>() == 0.90);
    CHECK(row.contains("forecast_flags"));
    CHECK(row.contains("forecast_evidence"));
  }
  const auto ups = gw("query updates --db " + db2.string() + " --format json");
  REQUIRE(ups.status == 0);
  CHECK(nlohmann::json::parse(ups.out).size() == scalar(db2, "SELECT count(*) FROM k_update_log"));
}

TEST_CASE("model thread: the model's enumerated values are the database's vocabulary", "[model][daemon][vocabulary]") {
  const gearwatch::testing::TempDir dir("model-vocab");
  storage::Database db((dir / "v.db").string());
  storage::open_and_migrate(db);
  for (const auto& [domain, n] : {std::pair{"model_update_kind", wear::kAllUpdateKinds.size()},
                                  {"model_update_trigger", wear::kAllUpdateTriggers.size()},
                                  {"model_update_outcome", wear::kAllUpdateOutcomes.size()},
                                  {"model_issue", wear::kAllModelIssues.size()},
                                  {"forecast_flag", wear::kAllForecastFlags.size()}}) {
    storage::Statement s(db, "SELECT count(*) FROM vocabulary WHERE domain = ?");
    s.bind(1, domain);
    REQUIRE(s.step());
    CHECK(static_cast<std::size_t>(s.get_int(0)) == n);
  }
  db.exec("INSERT INTO model_runs(gear_pair, advanced) VALUES (0, 0)");
  CHECK_THROWS_WITH(db.exec("INSERT INTO model_run_issues(run_id, issue) VALUES (1, 'tired')"), Catch::Contains("model_issue"));
  CHECK_THROWS_WITH(db.exec("INSERT INTO model_run_forecast_flags(run_id, flag) VALUES (1, 'gut_feeling')"), Catch::Contains("forecast_flag"));
  db.exec("INSERT INTO model_run_forecast_flags(run_id, flag) VALUES (1, 'pitting_limit_reached_by_ics2')");
  CHECK_THROWS_WITH(db.exec("INSERT INTO k_update_log(run_id, gear_pair, cycles, kind, triggered_by, outcome, old_value, new_value,"
                            " applies_from_cycles, iterations, evidence) VALUES (1, 0, 1, 'k_wear', 'whim', 'converged', 1, 2, 0, 1, '')"),
                    Catch::Contains("model_update_trigger"));
  db.exec("INSERT INTO k_update_log(run_id, gear_pair, cycles, kind, triggered_by, outcome, old_value, new_value,"
          " applies_from_cycles, iterations, evidence) VALUES (1, 0, 1, 'k_wear', 'rms_sa_mismatch', 'converged', 1, 2, 0, 1, '')");
}

TEST_CASE("model thread: remaining life below the configured cycles is an alarm, with hysteresis, cleared by a new pair",
          "[model][daemon][alerts]") {
  const gearwatch::testing::TempDir dir("model-alert");
  const auto db = dir / "a.db";
  // The thesis's dry K at 5 N m wears to the 0.314 mm limit in about 28 000 cycles (docs/model.md):
  // far inside 50 000, so the alarm is due, after two records in a row.
  auto cfg = config::parse_config("[model]\ninitial_k_wear = 1.65e-6\nforecast_horizon_cycles = 100000.0\n"
                                  "remaining_life_alert_cycles = 50000.0\n",
                                  "test");
  cfg.storage.database = db.string();
  storage::StorageWriter writer(storage::WriterOptions{db.string(), 5000, 256, 512, 200, 30000, 60.0, {}, std::nullopt});
  writer.start();
  daemon::ModelThread model(cfg, writer, true);
  model.start();
  for (double cycles : {1000.0, 2000.0, 3000.0, 500.0}) {
    daemon::ModelInput in;
    in.observation = {0, cycles, 10, 5, std::nullopt, std::nullopt};
    model.submit(in);
  }
  model.stop();
  writer.stop();
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'remaining_life'") == 2);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'remaining_life' AND transition = 'raised' AND subject = 'wear_depth'"
                   " AND severity = 'alarm'") == 1);
  // The condition held at all three records of the first pair: raised once (the hysteresis
  // needs two in a row), its value the limit, the cycles left in the message.
  CHECK(scalar(db, "SELECT count(*) FROM predictions WHERE gear_pair = 0 AND wear_cycles_left < 50000") == 3);
  CHECK(text(db, "SELECT value FROM alerts WHERE transition = 'raised'") == "0.3142 mm");
  CHECK(text(db, "SELECT message FROM alerts WHERE transition = 'raised'").find("cycles left") != std::string::npos);
  // The life counter went back: a new gear pair clears it.
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'remaining_life' AND transition = 'cleared'") == 1);
  CHECK(scalar(db, "SELECT count(*) FROM active_alerts") == 0);
  CHECK(scalar(db, "SELECT max(gear_pair) FROM model_state") == 1);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'remaining_life' AND subject = 'pitting_density'") == 0);
}

}  // namespace test_model_thread
