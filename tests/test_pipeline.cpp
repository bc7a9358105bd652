#include "pipeline.hpp"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <catch2/catch.hpp>

#include "temp_dir.hpp"

#include "capture_writer.hpp"
#include "gearwatch/acquisition/candump_log.hpp"
#include "gearwatch/acquisition/protocol_encoder.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "logging.hpp"
#include "record_processing.hpp"

namespace test_pipeline {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
namespace fs = std::filesystem;
namespace acq = gearwatch::acquisition;

namespace {


std::int64_t scalar(const std::string& db_path, const std::string& sql) {
  storage::Database db(db_path, storage::Database::Mode::read_only);
  storage::Statement s(db, sql);
  REQUIRE(s.step());
  return s.get_int(0);
}

config::GearwatchConfig replay_config(const fs::path& capture, const fs::path& db) {
  // The model thread has its own tests (test_model_thread.cpp); these are about the pipeline.
  auto cfg = config::parse_config("[records]\nlength_s = 1.0\ninterval_s = 1.0\nmin_length_s = 0.2\n[model]\nenabled = false\n", "test");
  cfg.acquisition.source = config::SourceKind::candump;
  cfg.acquisition.capture = capture.string();
  cfg.storage.database = db.string();
  cfg.logging.rate_limit_s = 0.0;
  return cfg;
}

}  // namespace

TEST_CASE("pipeline: a clean capture replays into exactly its records, losing nothing", "[pipeline]") {
  logging::setup(logging::Sink::stderr_only, "error");
  const gearwatch::testing::TempDir dir("clean");
  daemon::CaptureSettings cs;
  cs.duration_s = 3.5;
  cs.signal.sample_rate_hz = 20000;
  const auto summary = daemon::write_synthetic_capture(cs, (dir / "cap.log").string());
  const auto cfg = replay_config(dir / "cap.log", dir / "a.db");
  const auto r = daemon::run_pipeline(cfg, daemon::PipelineMode::replay);
  CHECK(r.exit_status == 0);
  CHECK(r.frames == summary.frames);
  CHECK(r.samples == 2 * 70000);
  CHECK(r.lost_samples == 0);
  CHECK(r.kernel_dropped_frames == 0);
  CHECK(r.records == 4);  // 3 complete 1 s records + the final 0.5 s
  const auto db = (dir / "a.db").string();
  CHECK(scalar(db, "SELECT count(*) FROM records WHERE end_reason = 'complete' AND sample_count = 20000") == 3);
  CHECK(scalar(db, "SELECT sample_count FROM records WHERE end_reason = 'stream_end'") == 10000);
  CHECK(scalar(db, "SELECT frames FROM acquisition_health") == static_cast<std::int64_t>(summary.frames));
  CHECK(scalar(db, "SELECT kernel_drops + ring_overflows + gaps + malformed_frames + malformed_lines FROM acquisition_health") == 0);
  // Input speed from the tacho: 10 Hz exactly (edges are placed exactly by the generator).
  storage::Database rd(db, storage::Database::Mode::read_only);
  storage::Statement s(rd, "SELECT value FROM indicators WHERE name = 'input_speed_hz' AND channel = 0");
  int n = 0;
  while (s.step()) {
    CHECK(s.get_double(0) == Approx(10.0).epsilon(1e-9));
    ++n;
  }
  CHECK(n == 4);
  // The same capture replayed again (a restart, or the file given twice) stores nothing twice.
  const auto r2 = daemon::run_pipeline(cfg, daemon::PipelineMode::replay);
  CHECK(r2.exit_status == 0);
  CHECK(r2.run_id == r.run_id + 1);
  CHECK(r2.records == 0);
  CHECK(r2.records_already_stored == 4);
  CHECK(scalar(db, "SELECT count(*) FROM records") == 4);
  CHECK(scalar(db, "SELECT count(*) FROM acquisition_health") == 2);
  // A different capture written later to the same path is stored, not taken for the old one:
  // one whose life counter moved on...
  cs.start_revolutions = 500000;
  daemon::write_synthetic_capture(cs, (dir / "cap.log").string());
  const auto r3 = daemon::run_pipeline(cfg, daemon::PipelineMode::replay);
  CHECK(r3.records == 4);
  CHECK(r3.records_already_stored == 0);
  CHECK(scalar(db, "SELECT count(*) FROM records") == 8);
  // ...and one with the same stream, indices, life counter and operating point but other
  // samples (another noise seed): only its content tells it apart.
  cs.signal.seed = 99;
  daemon::write_synthetic_capture(cs, (dir / "cap.log").string());
  const auto r4 = daemon::run_pipeline(cfg, daemon::PipelineMode::replay);
  CHECK(r4.records == 4);
  CHECK(r4.records_already_stored == 0);
  CHECK(scalar(db, "SELECT count(*) FROM records") == 12);
}

TEST_CASE("pipeline: every kind of bad input is counted, stored, and processing goes on", "[pipeline]") {
  logging::setup(logging::Sink::stderr_only, "off");
  const gearwatch::testing::TempDir dir("bad");
  const acq::ProtocolIds ids;
  std::ofstream out(dir / "bad.log");
  std::string line;
  double t = 1700000000.0;
  auto emit = [&](const acq::CanFrame& f0) {
    auto f = f0;
    f.timestamp_s = t;
    t += 1e-4;
    acq::format_candump_line(f, "can0", line);
    out << line << "\n";
  };
  const std::vector<std::int16_t> block(30, 100);
  emit(acq::make_stream_header(ids, 10000, 2, 7));
  emit(acq::make_life_counter(ids, 5000));
  for (std::uint32_t i = 0; i < 30000; i += 30) {
    if (i == 6000) {  // channel 1 loses one frame: a gap of 30 samples
      emit(acq::make_vibration_frame(ids, 0, i, block, true));
      continue;
    }
    emit(acq::make_vibration_frame(ids, 0, i, block, true));
    emit(acq::make_vibration_frame(ids, 1, i, block, true));
    if (i == 3000) emit(acq::make_vibration_frame(ids, 1, i, block, true));  // duplicate
    if (i == 9000) {
      out << "(1700000001.000000) can0 100##100000\n";     // truncated line: odd hex digits
      out << "this is not a candump line\n";                 // garbage
      acq::CanFrame unknown;
      unknown.id = 0x555;
      unknown.len = 2;
      emit(unknown);                                          // unknown id
      acq::CanFrame malformed;
      malformed.id = 0x100;
      malformed.len = 5;                                      // odd sample bytes
      emit(malformed);
    }
  }
  emit(acq::make_life_counter(ids, 10));                      // odometer backwards: a new gear pair?
  emit(acq::make_stream_header(ids, 10000, 2, 8));            // stream restart
  for (std::uint32_t i = 0; i < 15000; i += 30) {
    emit(acq::make_vibration_frame(ids, 0, i, block, true));
    emit(acq::make_vibration_frame(ids, 1, i, block, true));
  }
  out.close();

  const auto cfg = replay_config(dir / "bad.log", dir / "a.db");
  const auto r = daemon::run_pipeline(cfg, daemon::PipelineMode::replay);
  CHECK(r.exit_status == 0);
  const auto db = (dir / "a.db").string();
  auto health = [&](const std::string& col) { return scalar(db, "SELECT " + col + " FROM acquisition_health"); };
  CHECK(health("malformed_lines") == 2);
  CHECK(health("malformed_frames") == 1);
  CHECK(health("unknown_ids") == 1);
  CHECK(health("duplicates") == 1);
  CHECK(health("gaps") == 1);
  CHECK(health("gap_samples") == 30);
  CHECK(health("stream_changes") == 1);
  CHECK(health("life_counter_resets") == 1);
  CHECK(health("ring_gaps") == 0);
  // Stored: the bad lines and frames themselves, the gap, the reset (with an alert).
  CHECK(scalar(db, "SELECT count(*) FROM rejected_frames WHERE kind = 'malformed_line'") == 2);
  CHECK(scalar(db, "SELECT count(*) FROM rejected_frames WHERE kind = 'malformed_frame'") == 1);
  CHECK(scalar(db, "SELECT count(*) FROM rejected_frames WHERE kind = 'duplicate_frame'") == 1);
  CHECK(scalar(db, "SELECT count(*) FROM rejected_frames WHERE kind = 'life_counter_reset'") == 1);
  CHECK(scalar(db, "SELECT first_missing_index FROM gap_events") == 6000);
  CHECK(scalar(db, "SELECT missing_samples FROM gap_events") == 30);
  CHECK(scalar(db, "SELECT count(*) FROM life_counter_events WHERE previous_revolutions = 5000 AND revolutions = 10") == 1);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'life_counter_reset'") == 1);
  // Records: stream 7 is 3 s at 10 kHz in 1 s records; the first is cut at the gap (index 6000),
  // the next two start on schedule. Stream 8 gives one 1 s record and a 0.5 s end.
  CHECK(scalar(db, "SELECT count(*) FROM streams") == 2);
  CHECK(scalar(db, "SELECT count(*) FROM records") == 5);
  CHECK(scalar(db, "SELECT sample_count FROM records WHERE end_reason = 'cut_at_gap'") == 6000);
  CHECK(scalar(db, "SELECT start_index FROM records WHERE end_reason = 'cut_at_gap'") == 0);
  CHECK(scalar(db, "SELECT count(*) FROM records WHERE end_reason = 'complete'") == 3);
}

TEST_CASE("pipeline: indicators of a replayed capture recover the rig signal's known content", "[pipeline]") {
  logging::setup(logging::Sink::stderr_only, "error");
  const gearwatch::testing::TempDir dir("content");
  daemon::CaptureSettings cs;  // 100 kHz, 10 Hz, 20 N·m: GMF harmonics 5·(1, .5, .3, .2, .1) m/s² on channel 0
  cs.duration_s = 6.0;
  daemon::write_synthetic_capture(cs, (dir / "cap.log").string());
  auto cfg = replay_config(dir / "cap.log", dir / "a.db");
  cfg.rig.schedule = {5.0, 5.0, 2.0};
  REQUIRE(daemon::run_pipeline(cfg, daemon::PipelineMode::replay).exit_status == 0);
  const auto db = (dir / "a.db").string();
  auto value = [&](int channel, const std::string& name) {
    storage::Database rd(db, storage::Database::Mode::read_only);
    storage::Statement s(rd, "SELECT value FROM indicators WHERE record_id = 1 AND channel = ? AND name = ?");
    s.bind(1, channel).bind(2, name);
    REQUIRE(s.step());
    return s.get_double(0);
  };
  // The generator's amplitudes are exact; the TSA over 49 revolutions leaves the broadband
  // noise (0.5 m/s² RMS + the 1 m/s² resonance) at about 1.1/sqrt(49·5e5/2)... far below 1 %.
  const double weights[] = {1.0, 0.5, 0.3, 0.2, 0.1};
  for (int h = 1; h <= 5; ++h) {
    INFO("harmonic " << h);
    CHECK(value(0, "gmf_harmonic_" + std::to_string(h)) == Approx(5.0 * weights[h - 1]).epsilon(0.01));
    CHECK(value(1, "gmf_harmonic_" + std::to_string(h)) == Approx(5.0 * weights[h - 1] / 1.5).epsilon(0.01));
  }
  CHECK(value(0, "input_speed_hz") == Approx(10.0).epsilon(1e-9));
  // RMS_SA(N = 2), thesis Eq. 7.1: sqrt(A_GM1² + A_GM2²) = sqrt(5² + 2.5²) = 5.590.
  CHECK(value(0, "rms_sa") == Approx(std::sqrt(25.0 + 6.25)).epsilon(0.01));
}

TEST_CASE("pipeline: the wear history continues across replays into one database", "[pipeline]") {
  logging::setup(logging::Sink::stderr_only, "error");
  const gearwatch::testing::TempDir dir("history");
  daemon::CaptureSettings cs;
  cs.duration_s = 4.0;
  cs.signal.sample_rate_hz = 20000;
  daemon::write_synthetic_capture(cs, (dir / "a.log").string());
  cs.start_revolutions = 100000;
  cs.signal.seed = 2;
  daemon::write_synthetic_capture(cs, (dir / "b.log").string());
  auto cfg = replay_config(dir / "a.log", dir / "h.db");
  cfg.rig.schedule = {2.0, 2.0, 1.0};  // 2 s: 7.3 output-shaft revolutions, enough for its TSA
  cfg.processing.pitting_band = {1000.0, 4000.0};  // both carrier bands below this rate's Nyquist
  cfg.processing.abrasion_band = {5000.0, 9000.0};
  cfg.processing.mean_carrier_ranges = {{0.0, 10000.0}};
  REQUIRE(daemon::run_pipeline(cfg, daemon::PipelineMode::replay).exit_status == 0);
  cfg.acquisition.capture = (dir / "b.log").string();
  REQUIRE(daemon::run_pipeline(cfg, daemon::PipelineMode::replay).exit_status == 0);
  const auto db = (dir / "h.db").string();
  // 2 records per capture; the 4th assessment of channel 0 sees all four points.
  CHECK(scalar(db, "SELECT count(*) FROM wear_mechanism WHERE channel = 0") == 4);
  CHECK(scalar(db, "SELECT max(points) FROM wear_mechanism WHERE channel = 0") == 4);
  CHECK(daemon::load_wear_history(db).at(0).size() == 4);
  CHECK(daemon::load_wear_history(db).at(0).back().cycles == Approx(100020.0));
  // With a window of 3 records the trend test sees only the newest three.
  cs.start_revolutions = 200000;
  cs.signal.seed = 3;
  daemon::write_synthetic_capture(cs, (dir / "c.log").string());
  cfg.acquisition.capture = (dir / "c.log").string();
  cfg.processing.trend_window_records = 3;
  REQUIRE(daemon::run_pipeline(cfg, daemon::PipelineMode::replay).exit_status == 0);
  CHECK(scalar(db, "SELECT max(points) FROM wear_mechanism WHERE channel = 0 AND record_id > 4") == 3);
}

TEST_CASE("pipeline: lost samples are the samples missing from the stream, in samples", "[pipeline]") {
  logging::setup(logging::Sink::stderr_only, "off");
  const gearwatch::testing::TempDir dir("lost");
  const acq::ProtocolIds ids;
  std::ofstream out(dir / "lost.log");
  std::string line;
  auto emit = [&](const acq::CanFrame& f) {
    acq::format_candump_line(f, "can0", line);
    out << line << "\n";
  };
  const std::vector<std::int16_t> block(30, 7);
  emit(acq::make_stream_header(ids, 10000, 2, 1));
  for (std::uint32_t i = 0; i < 20000; i += 30)
    for (int ch = 0; ch < 2; ++ch)
      if (!(ch == 0 && i >= 900 && i < 1200)) emit(acq::make_vibration_frame(ids, ch, i, block, true));  // 10 frames lost
  out.close();
  const auto r = daemon::run_pipeline(replay_config(dir / "lost.log", dir / "a.db"), daemon::PipelineMode::replay);
  CHECK(r.lost_samples == 300);  // 10 frames of 30 samples, on channel 0
  CHECK(r.kernel_dropped_frames == 0);
}

TEST_CASE("pipeline: a tacho mismatch on a rounding boundary of its two digits is raised once and again when it moves by a quarter",
          "[pipeline][alerts]") {
  AlertTracker alerts;
  int raised = 0;
  std::vector<std::string> raised_values;
  auto record = [&](double relative_difference, bool mismatch = true) {
    dsp::SpeedCheck check;
    check.mismatch = mismatch;
    check.tacho_speed_hz = 10.0 * (1.0 + relative_difference);
    check.signal_speed_hz = 10.0;
    check.relative_difference = relative_difference;
    check.tolerance = 5e-5;
    const auto e = daemon::observe_speed_mismatch(alerts, check);
    if (e && e->transition == AlertTransition::raised) {
      ++raised;
      raised_values.push_back(e->value);
    }
    return e;
  };
  // Printed with two digits these read +9.8e-05, +0.0001, +0.0001 and +9.9e-05: each flip across
  // the boundary changed the text, and a tracker comparing the text raised the alert five times.
  for (double v : {9.8e-5, 1.0e-4, 9.8e-5, 1.0e-4, 1.02e-4, 9.9e-5}) record(v);
  CHECK(raised == 1);
  CHECK(raised_values == std::vector<std::string>{"+9.8e-05"});
  // Doubled since the raise (9.8e-5): raised again, with the new value.
  record(1.96e-4);
  CHECK(raised == 2);
  CHECK(raised_values.back() == "+0.0002");
  // Against the new raise's 1.96e-4: 24 % more is the same condition, 26 % more is a new value.
  record(1.96e-4 * 1.24);
  CHECK(raised == 2);
  record(1.96e-4 * 1.26);
  CHECK(raised == 3);
  CHECK(raised_values.back() == "+0.00025");
  // A sign change is always a move; clearing reports the value last raised.
  record(-2.5e-4);
  CHECK(raised == 4);
  const auto cleared = record(-2.5e-4, false);
  REQUIRE(cleared);
  CHECK(cleared->transition == AlertTransition::cleared);
  CHECK(cleared->value == "-0.00025");
}

}  // namespace test_pipeline
