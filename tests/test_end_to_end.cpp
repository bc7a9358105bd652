// The verdicts users rely on, end to end: captures made by the independent generator
// (tests/capture_gen, written from the protocol document alone), replayed by `gearwatch replay`
// one file per process into one database, read back through `gearwatch query` and SQL.
#include "commands.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "command_runner.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "temp_dir.hpp"

namespace test_end_to_end {  // this file's own: the test files compile together (unity build)

namespace fs = std::filesystem;
using gearwatch::testing::run_command;

namespace {

// These verdicts do not involve the digital twin; its model thread (seconds per record) has its
// own tests (test_model_thread.cpp).
const char* const kNoModel = "[model]\nenabled = false\n";

const std::string kGenerator = std::string(GEARWATCH_PYTHON) + " " + GEARWATCH_SOURCE_DIR + "/tests/capture_gen/rig_capture.py";

void generate(const std::string& args) {
  const auto r = run_command(kGenerator + " " + args);
  INFO(args << "\n" << r.err);
  REQUIRE(r.status == 0);
}

void replay(const fs::path& capture, const fs::path& db, const fs::path& config) {
  const auto r = run_command(std::string(GEARWATCH_BINARY) + " replay " + capture.string() + " --db " + db.string() +
                             " --config " + config.string());
  INFO(capture.string() << "\n" << r.err);
  REQUIRE(r.status == 0);
}

double scalar(const fs::path& db, const std::string& sql) {
  gearwatch::storage::Database d(db.string(), gearwatch::storage::Database::Mode::read_only);
  gearwatch::storage::Statement s(d, sql);
  REQUIRE(s.step());
  return s.is_null(0) ? std::nan("") : s.get_double(0);
}

nlohmann::json query(const fs::path& db, const std::string& what) {
  const auto r = run_command(std::string(GEARWATCH_BINARY) + " query " + what + " --db " + db.string() + " --format json");
  INFO(r.err);
  REQUIRE(r.status == 0);
  return nlohmann::json::parse(r.out);
}

// One 2 s record per capture file (interval longer than the file), two accelerometers: the
// generator gives each channel its own realisation of the same content, so each channel must
// reach the campaign's verdict on its own.
fs::path campaign_config(const fs::path& dir) {
  const auto path = dir / "campaign.toml";
  std::ofstream(path) << "[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n"
                         "[[channels]]\nnumber = 1\nname = \"casing_x\"\nscale = 0.01\n"
                         "[records]\nlength_s = 2.0\ninterval_s = 600.0\nmin_length_s = 1.0\n" << kNoModel;
  return path;
}

struct Campaign {
  std::string name;
  double low_growth = 0, high_growth = 0;  // std of the GMF-modulated noise added per record, m/s²
};

// Record k: gear-mesh harmonics, broadband noise, and GMF-modulated (a = 0.5) noise in the
// pitting carrier range (3-9 kHz) and/or the abrasion range (22-34 kHz) whose strength grows
// with k; 100 000 input revolutions between records.
fs::path run_campaign(const gearwatch::testing::TempDir& dir, const Campaign& c, int records) {
  const auto config = campaign_config(dir.path());
  const auto db = dir / (c.name + ".db");
  for (int k = 0; k < records; ++k) {
    std::ostringstream args;
    const auto capture = dir / (c.name + "_" + std::to_string(k) + ".log");
    args << "--out " << capture.string() << " --duration 2.2 --speed 10 --torque 20 --channels 0,1 --seed " << 100 + k
         << " --start-revs " << 100000 * k << " --gmf-harmonics 5,2.5 --white-noise 2.0";
    args << " --am-noise 3000:9000:" << 0.5 + c.low_growth * k << ":0.5";
    args << " --am-noise 22000:34000:" << 0.5 + c.high_growth * k << ":0.5";
    generate(args.str());
    replay(capture, db, config);
    fs::remove(capture);
  }
  return db;
}

/// Raised wear-mechanism values of one channel, in order.
std::vector<std::string> raised_wear_values(const nlohmann::json& alerts, int channel) {
  std::vector<std::string> out;
  for (const auto& a : alerts)
    if (a.at("kind") == "wear_mechanism" && a.at("transition") == "raised" && a.at("channel") == channel)
      out.push_back(a.at("value"));
  return out;
}

/// Records whose assessment on `channel` named `mechanism`.
double assessments(const fs::path& db, int channel, const std::string& mechanism) {
  return scalar(db, "SELECT count(*) FROM wear_mechanism WHERE channel = " + std::to_string(channel) + " AND mechanism = '" +
                        mechanism + "'");
}

}  // namespace

TEST_CASE("end to end: defects #7: a pitting campaign turns into one fatigue_pitting alert on each channel and never abrasion",
          "[e2e][wear]") {
  const gearwatch::testing::TempDir dir("e2e-pitting");
  const int records = 9;
  const auto db = run_campaign(dir, {"pitting", 0.35, 0.0}, records);
  CHECK(scalar(db, "SELECT count(*) FROM records WHERE analysed = 1") == records);
  const auto alerts = query(db, "alerts");
  for (int channel : {0, 1}) {
    INFO("channel " << channel);
    const std::string newest = "FROM wear_mechanism WHERE channel = " + std::to_string(channel) + " ORDER BY record_id DESC LIMIT 1";
    // Low-band ICS2 rises record by record; the high band holds no growing modulation.
    CHECK(scalar(db, "SELECT low_band_p " + newest) < 0.05);
    CHECK(scalar(db, "SELECT high_band_p " + newest) >= 0.05);
    CHECK(raised_wear_values(alerts, channel) == std::vector<std::string>{"fatigue_pitting"});
    // Mann-Kendall needs 5 points to reach p < 0.05 (dsp::minimum_points_for_trend): the alert
    // comes with the 5th record at the earliest; a steady rise gets there by the 7th.
    const double at = scalar(db, "SELECT r.rowid FROM alerts a JOIN records r ON r.id = a.record_id WHERE a.kind = 'wear_mechanism'"
                                 " AND a.channel = " + std::to_string(channel));
    CHECK(at >= 5);
    CHECK(at <= 7);
    CHECK(assessments(db, channel, "fatigue_pitting") >= records - 7 + 1);
    // defects #7: the mode the channel does not see is never named, at any record.
    CHECK(assessments(db, channel, "abrasive_wear") == 0);
    CHECK(assessments(db, channel, "both") == 0);
  }
  CHECK(scalar(db, "SELECT count(*) FROM active_alerts WHERE kind = 'wear_mechanism' AND value = 'fatigue_pitting'") == 2);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE severity IN ('warning', 'alarm') AND kind <> 'wear_mechanism'") == 0);
  CHECK(scalar(db, "SELECT storage_rows_rejected FROM acquisition_health ORDER BY rowid DESC LIMIT 1") == 0);
}

TEST_CASE("end to end: defects #7: an abrasion campaign turns into one abrasive_wear alert on each channel and never pitting",
          "[e2e][wear]") {
  const gearwatch::testing::TempDir dir("e2e-abrasion");
  const auto db = run_campaign(dir, {"abrasion", 0.0, 0.35}, 9);
  const auto alerts = query(db, "alerts");
  for (int channel : {0, 1}) {
    INFO("channel " << channel);
    CHECK(raised_wear_values(alerts, channel) == std::vector<std::string>{"abrasive_wear"});
    CHECK(assessments(db, channel, "fatigue_pitting") == 0);  // defects #7
    CHECK(assessments(db, channel, "both") == 0);
  }
  CHECK(scalar(db, "SELECT count(*) FROM active_alerts WHERE kind = 'wear_mechanism' AND value = 'abrasive_wear'") == 2);
}

TEST_CASE("end to end: defects #7: both bands growing end as one active 'both' alert on each channel", "[e2e][wear]") {
  const gearwatch::testing::TempDir dir("e2e-both");
  const auto db = run_campaign(dir, {"both", 0.35, 0.35}, 9);
  const auto alerts = query(db, "alerts");
  for (int channel : {0, 1}) {
    INFO("channel " << channel);
    const auto raised = raised_wear_values(alerts, channel);
    REQUIRE_FALSE(raised.empty());
    CHECK(raised.back() == "both");
    // Each value at most once (one band may reach significance a record before the other).
    CHECK(std::set<std::string>(raised.begin(), raised.end()).size() == raised.size());
  }
  CHECK(scalar(db, "SELECT count(*) FROM active_alerts WHERE kind = 'wear_mechanism' AND value = 'both'") == 2);
}

TEST_CASE("end to end: defects #7: a healthy campaign raises no warning on either channel", "[e2e][wear]") {
  const gearwatch::testing::TempDir dir("e2e-healthy");
  const int records = 10;
  const auto db = run_campaign(dir, {"healthy", 0.0, 0.0}, records);
  CHECK(scalar(db, "SELECT count(*) FROM records WHERE analysed = 1") == records);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE severity IN ('warning', 'alarm')") == 0);
  CHECK(scalar(db, "SELECT count(*) FROM wear_mechanism WHERE mechanism IN ('fatigue_pitting', 'abrasive_wear', 'both')") == 0);
  CHECK(query(db, "active").empty());
}

namespace {

// Two accelerometers configured (the default), short records every 2 s.
fs::path two_channel_config(const fs::path& dir) {
  const auto path = dir / "two.toml";
  std::ofstream(path) << "[records]\nlength_s = 2.0\ninterval_s = 2.0\nmin_length_s = 1.0\n" << kNoModel;
  return path;
}

std::string clean_signal(int seed) {
  return " --speed 10 --torque 20 --seed " + std::to_string(seed) +
         " --gmf-harmonics 5,2.5 --white-noise 1.0 --am-noise 3000:9000:1.0:0.5";
}

}  // namespace

TEST_CASE("end to end: a configured accelerometer the stream does not carry is an alarm, not a blind gearbox",
          "[e2e][sensor]") {
  const gearwatch::testing::TempDir dir("e2e-missing");
  const auto config = two_channel_config(dir.path());
  const auto db = dir / "plant.db";
  // The header announces one channel and only 0x100 frames come: channel 1's cable is broken.
  generate("--out " + (dir / "a.log").string() + " --duration 6.1 --channels 0 --header-channels 1 --start-revs 1000" +
           clean_signal(1));
  replay(dir / "a.log", db, config);
  CHECK(scalar(db, "SELECT count(*) FROM records WHERE analysed = 1 AND sample_count = 200000") == 3);
  CHECK(scalar(db, "SELECT count(DISTINCT record_id) FROM indicators WHERE channel = 0 AND name = 'rms_sa'") == 3);
  CHECK(scalar(db, "SELECT count(*) FROM indicators WHERE channel = 1") == 0);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'sensor_missing' AND channel = 1 AND transition = 'raised'"
                   " AND value = 'missing_from_stream' AND severity = 'alarm'") == 1);
  // A second replay of the same broken stream (a restart): still raised, not raised again.
  replay(dir / "a.log", db, config);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'sensor_missing'") == 1);
  // The cable is mended: both channels analysed, the alarm clears.
  generate("--out " + (dir / "b.log").string() + " --duration 4.1 --channels 0,1 --start-revs 5000" + clean_signal(2));
  replay(dir / "b.log", db, config);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'sensor_missing' AND channel = 1 AND transition = 'cleared'") == 1);
  CHECK(scalar(db, "SELECT count(*) FROM active_alerts") == 0);
  CHECK(scalar(db, "SELECT count(DISTINCT record_id) FROM indicators WHERE channel = 1 AND name = 'rms_sa'") == 2);
  // Staff filters: by channel and time window.
  const auto ch1 = query(db, "alerts --channel 1");
  REQUIRE(ch1.size() == 2);
  CHECK(ch1[0].at("transition") == "raised");
  CHECK(ch1[1].at("transition") == "cleared");
  CHECK(query(db, "alerts --channel 0").empty());
  CHECK(query(db, "alerts --until 2000-01-01").empty());
  CHECK(query(db, "alerts --since 2000-01-01 --until 9999-01-01").size() == 2);
  const auto wrong = run_command(std::string(GEARWATCH_BINARY) + " query records --channel 0 --db " + db.string());
  CHECK(wrong.status != 0);
  CHECK(wrong.err.find("--channel applies to") != std::string::npos);
}

TEST_CASE("end to end: a channel whose frames stop is cut out, the other keeps its records", "[e2e][sensor]") {
  const gearwatch::testing::TempDir dir("e2e-stopped");
  const auto config = two_channel_config(dir.path());
  const auto db = dir / "plant.db";
  generate("--out " + (dir / "a.log").string() + " --duration 8.1 --channels 0,1 --stop-channel 1:3.0 --start-revs 1000" +
           clean_signal(3));
  replay(dir / "a.log", db, config);
  // Four 2 s records, every one complete and analysed; channel 1 is in the first only.
  CHECK(scalar(db, "SELECT count(*) FROM records WHERE analysed = 1 AND end_reason = 'complete' AND sample_count = 200000") == 4);
  CHECK(scalar(db, "SELECT count(DISTINCT record_id) FROM indicators WHERE channel = 0 AND name = 'rms_sa'") == 4);
  CHECK(scalar(db, "SELECT count(DISTINCT record_id) FROM indicators WHERE channel = 1 AND name = 'rms_sa'") == 1);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'sensor_missing' AND channel = 1 AND transition = 'raised'"
                   " AND value = 'stopped'") == 1);
  CHECK(scalar(db, "SELECT count(*) FROM active_alerts WHERE kind = 'sensor_missing' AND channel = 1") == 1);
}

TEST_CASE("end to end: a flat-lined or saturated sensor is an alert with its channel, cleared when it recovers",
          "[e2e][sensor]") {
  const gearwatch::testing::TempDir dir("e2e-flat");
  const auto config = two_channel_config(dir.path());
  const auto db = dir / "plant.db";
  generate("--out " + (dir / "a.log").string() + " --duration 6.1 --channels 0,1 --flat-channel 1:0 --saturate-channel 0:0.01" +
           " --start-revs 1000" + clean_signal(4));
  replay(dir / "a.log", db, config);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'sensor_flat_line' AND channel = 1 AND transition = 'raised'"
                   " AND severity = 'alarm'") == 1);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'sensor_saturated' AND channel = 0 AND transition = 'raised'") == 1);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind IN ('sensor_flat_line', 'sensor_saturated') AND channel = 1 - channel") == 0);
  generate("--out " + (dir / "b.log").string() + " --duration 2.1 --channels 0,1 --start-revs 9000" + clean_signal(5));
  replay(dir / "b.log", db, config);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'sensor_flat_line' AND transition = 'cleared'") == 1);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'sensor_saturated' AND transition = 'cleared'") == 1);
  CHECK(scalar(db, "SELECT count(*) FROM active_alerts") == 0);
}

TEST_CASE("end to end: cycles keep advancing across a stream change", "[e2e][acquisition]") {
  const gearwatch::testing::TempDir dir("e2e-streams");
  const auto config = two_channel_config(dir.path());
  const auto db = dir / "plant.db";
  // Stream 1 from 0 s, stream 7 from 4 s (new index origin); 10 rev/s, life counter from 5000.
  generate("--out " + (dir / "a.log").string() + " --duration 10.1 --channels 0,1 --start-revs 5000" +
           " --second-stream 4.0:7:300000" + clean_signal(6));
  replay(dir / "a.log", db, config);
  gearwatch::storage::Database d(db.string(), gearwatch::storage::Database::Mode::read_only);
  gearwatch::storage::Statement s(d, "SELECT s.stream_id, r.start_index, r.input_revolutions FROM records r"
                                     " JOIN streams s ON s.id = r.stream_key WHERE r.analysed = 1 ORDER BY r.id");
  std::vector<double> cycles;
  while (s.step()) {
    const double t = s.get_int(0) == 7 ? 4.0 + (s.get_int(1) - 300000) / 1e5 : s.get_int(1) / 1e5;
    INFO("stream " << s.get_int(0) << " index " << s.get_int(1));
    // Revolutions at the record's first sample: life counter start + 10 rev/s x t, to one edge.
    CHECK(std::abs(s.get_double(2) - (5000 + 10.0 * t)) <= 1.0);
    cycles.push_back(s.get_double(2));
  }
  REQUIRE(cycles.size() == 5);  // 0-2, 2-4 | 4-6, 6-8, 8-10
  for (std::size_t i = 1; i < cycles.size(); ++i) CHECK(cycles[i] > cycles[i - 1]);
}

TEST_CASE("end to end: a record rejected at a gap is restarted after it, not ten minutes later", "[e2e][acquisition]") {
  const gearwatch::testing::TempDir dir("e2e-gap");
  const auto config = dir / "gap.toml";
  std::ofstream(config) << "[records]\nlength_s = 2.0\ninterval_s = 600.0\nmin_length_s = 1.8\n" << kNoModel;
  const auto db = dir / "plant.db";
  // A 90-sample gap 1.5 s into the first record (the generator drops whole frames: 90 = 3 x 30).
  generate("--out " + (dir / "a.log").string() + " --duration 5.0 --channels 0,1 --start-revs 1000 --gap 1.5:90" +
           clean_signal(7));
  replay(dir / "a.log", db, config);
  CHECK(scalar(db, "SELECT count(*) FROM records") == 2);
  CHECK(scalar(db, "SELECT sample_count FROM records WHERE id = 1") == 150000);
  CHECK(scalar(db, "SELECT analysed FROM records WHERE id = 1") == 0);
  // The next record starts right after the gap and is a complete, analysed 2 s record.
  CHECK(scalar(db, "SELECT start_index FROM records WHERE id = 2") == 150090);
  CHECK(scalar(db, "SELECT sample_count FROM records WHERE id = 2") == 200000);
  CHECK(scalar(db, "SELECT analysed FROM records WHERE id = 2") == 1);
}

TEST_CASE("end to end: an indicator far above the gear pair's own baseline is an alert, with hysteresis",
          "[e2e][alerts]") {
  const gearwatch::testing::TempDir dir("e2e-threshold");
  const auto config = dir / "threshold.toml";
  std::ofstream(config) << "[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n"
                           "[records]\nlength_s = 2.0\ninterval_s = 600.0\nmin_length_s = 1.0\n"
                           "[alerts]\nbaseline_records = 5\nwatched_indicators = [\"rms_raw\"]\n" << kNoModel;
  const auto db = dir / "plant.db";
  // Records 1-5: the baseline (broadband noise 2 m/s²); 6-8: noise 10 m/s², rms_raw about five
  // times the baseline (far beyond 6 sd of it); 9-11: back to normal.
  for (int k = 0; k < 11; ++k) {
    const double noise = (k >= 5 && k < 8) ? 10.0 : 2.0;
    const auto capture = dir / ("r" + std::to_string(k) + ".log");
    generate("--out " + capture.string() + " --duration 2.2 --channels 0 --start-revs " + std::to_string(100000 * k) +
             " --speed 10 --torque 20 --seed " + std::to_string(300 + k) + " --gmf-harmonics 5,2.5 --white-noise " +
             std::to_string(noise));
    replay(capture, db, config);
  }
  // Raised on the second record above the limit (threshold_raise_after_records = 2) = record 7,
  // cleared on the third record back below it (threshold_clear_after_records = 3) = record 11.
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'indicator_threshold'") == 2);
  CHECK(scalar(db, "SELECT record_id FROM alerts WHERE kind = 'indicator_threshold' AND transition = 'raised'"
                   " AND subject = 'rms_raw' AND channel = 0") == 7);
  CHECK(scalar(db, "SELECT record_id FROM alerts WHERE kind = 'indicator_threshold' AND transition = 'cleared'") == 11);
  CHECK(query(db, "active").empty());
}

}  // namespace test_end_to_end
