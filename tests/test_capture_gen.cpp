// End to end against the independent capture generator (tests/capture_gen/rig_capture.py,
// docs/capture-gen.md): captures gearwatch did not make itself go through `gearwatch replay`, and
// what the database holds is compared with what the generator knows it put in.
#include <sys/wait.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "temp_dir.hpp"
#include <nlohmann/json.hpp>

namespace test_capture_gen {  // this file's own: the test files compile together (unity build)

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const std::string kGenerator = std::string(GEARWATCH_SOURCE_DIR) + "/tests/capture_gen/rig_capture.py";

// Single-quoted for /bin/sh (the test's temporary paths hold no quote).
std::string shell_quoted(const fs::path& p) {
  std::string quoted(1, '\'');
  quoted += p.native();
  quoted += '\'';
  return quoted;
}

// Runs a shell command with stdout to `out` (if given) and stderr to a log; returns the exit code.
int shell(const std::string& command, const fs::path& out, const fs::path& err) {
  const int status = std::system((command + " >" + shell_quoted(out) + " 2>" + shell_quoted(err)).c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), {}};
}

struct Capture {
  fs::path log;
  json summary;
};

Capture generate(const gearwatch::testing::TempDir& dir, const std::string& name, const std::string& options) {
  Capture c{dir / (name + ".log"), {}};
  const auto summary = dir / (name + ".json");
  const int status = shell(std::string(GEARWATCH_PYTHON) + " " + shell_quoted(kGenerator) + " --out " + shell_quoted(c.log) +
                               " --json-summary " + shell_quoted(summary) + " " + options,
                           dir / (name + ".gen.out"), dir / (name + ".gen.err"));
  INFO(slurp(dir / (name + ".gen.err")));
  REQUIRE(status == 0);
  c.summary = json::parse(slurp(summary));
  return c;
}

json gearwatch_json(const gearwatch::testing::TempDir& dir, const std::string& args) {
  const int status = shell(std::string(GEARWATCH_BINARY) + " " + args + " --format json", dir / "gw.out", dir / "gw.err");
  INFO(args << "\n" << slurp(dir / "gw.err"));
  REQUIRE(status == 0);
  return json::parse(slurp(dir / "gw.out"));
}

// (record id, channel) -> value of one indicator.
std::map<std::pair<std::int64_t, int>, double> indicator(const gearwatch::testing::TempDir& dir, const fs::path& db,
                                                         const std::string& name) {
  std::map<std::pair<std::int64_t, int>, double> values;
  for (const auto& row : gearwatch_json(dir, "query indicators --db " + shell_quoted(db) + " --name " + name))
    values[{row["record_id"].get<std::int64_t>(), row["channel"].get<int>()}] = row["value"].get<double>();
  return values;
}

fs::path write_config(const gearwatch::testing::TempDir& dir, const std::string& text) {
  const auto path = dir / "gearwatch.toml";
  // The generator's captures test acquisition and DSP; the twin's model thread has its own tests.
  std::ofstream(path) << text << "[model]\nenabled = false\n";
  return path;
}

// Short records so that a few seconds of capture give several analysed records.
const char* kOneSecondRecords = "[records]\nlength_s = 1\ninterval_s = 1\nmin_length_s = 0.5\n";

}  // namespace

TEST_CASE("capture_gen: the generator's own frame-by-frame self-test passes", "[capture_gen]") {
  // It decodes its output line by line and asserts frame counts per id, index continuity over the
  // u32 wrap, gaps, a stopped, a flat and a saturated channel, a second stream, the life counter,
  // tacho positions, harmonic amplitudes and phases, determinism, and the ICS2 closed form and
  // scatter model against AM noise (tests/capture_gen/rig_capture.py, self_test()).
  const gearwatch::testing::TempDir dir("capgen-self");
  const int status = shell(std::string(GEARWATCH_PYTHON) + " " + shell_quoted(kGenerator) + " --self-test", dir / "out", dir / "err");
  INFO(slurp(dir / "out") << slurp(dir / "err"));
  CHECK(status == 0);
  CHECK(slurp(dir / "out").find("checks passed") != std::string::npos);
}

TEST_CASE("capture_gen: a clean capture replays with every frame and sample, exact speed and mesh harmonics",
          "[capture_gen]") {
  // 3 s at 100 kHz on CAN FD, channels 0 and 1 (channel 1 at half gain), 10 Hz, mesh harmonics
  // 5 and 2.5 m/s² phase-locked to the tacho, starting 150 000 samples before the u32 wrap.
  const gearwatch::testing::TempDir dir("capgen-clean");
  const auto cap = generate(dir, "clean",
                            "--duration 3 --speed 10 --torque 15 --gmf-harmonics 5,2.5 --channels 0,1 --channel-gain 1:0.5 "
                            "--first-index 4294817296 --seed 3");
  const auto& s = cap.summary;
  // 2 x 10 000 vibration frames, 30 edges, and header, condition and life counter every 3333 frames
  // (99 990 samples, the most whole frames in 1 s): at 0, 0.9999, 1.9998 and 2.9997 s.
  REQUIRE(s["frames_total"] == 20042);
  const auto db = dir / "clean.db";
  const auto config = write_config(dir, kOneSecondRecords);
  const auto replay = gearwatch_json(dir, "replay " + shell_quoted(cap.log) + " --db " + shell_quoted(db) + " --config " + shell_quoted(config));
  CHECK(replay["frames"] == s["frames_total"]);
  CHECK(replay["samples"] == s["samples_total"]);
  CHECK(replay["lost_samples"] == 0);
  CHECK(replay["records"] == 3);
  CHECK(replay["records_analysed"] == 3);

  const auto health = gearwatch_json(dir, "query health --db " + shell_quoted(db));
  REQUIRE(health.size() == 1);
  const auto& h = health[0];
  CHECK(h["samples"] == s["samples_total"]);
  CHECK(h["tacho_edges"] == s["tacho_edges"]);
  for (const char* counter : {"malformed_frames", "malformed_lines", "unknown_ids", "unconfigured_channel_frames",
                              "frames_before_header", "gaps", "gap_samples", "duplicates", "tacho_out_of_order",
                              "stream_changes", "life_counter_resets", "unsupported_version"}) {
    INFO(counter);
    CHECK(h[counter] == 0);
  }
  CHECK(gearwatch_json(dir, "query rejected --db " + shell_quoted(db)).empty());

  const auto records = gearwatch_json(dir, "query records --db " + shell_quoted(db));
  REQUIRE(records.size() == 3);
  for (std::size_t i = 0; i < records.size(); ++i) {
    CHECK(records[i]["end_reason"] == "complete");
    CHECK(records[i]["sample_count"] == 100000);
    CHECK(records[i]["start_index"] == 4294817296 + 100000 * static_cast<std::int64_t>(i));  // unwrapped past 2^32
  }

  // The tacho edges carry exact fractional positions, so the speed is exact to the 2^-32 sample
  // resolution of the edge frame.
  const auto speed = indicator(dir, db, "input_speed_hz");
  REQUIRE(speed.size() == 6);
  for (const auto& [key, value] : speed) CHECK(value == Approx(10.0).margin(1e-6));
  // Mesh harmonics from the input TSA. Bound 1e-3 relative. The signal repeats every revolution,
  // so its 0.01 m/s² quantisation error (2.9e-3 m/s² rms) repeats too and the TSA does not
  // average it away. Projected on one line over the 10 000 samples of a revolution, it is
  // ~sqrt(2/10 000)·2.9e-3 = 4e-5 m/s², which is 30 times below 1e-3 of the smallest amplitude
  // (1.25). The order-tracking interpolator's ripple is 1e-4 (docs/dsp.md). Measured relative
  // errors: 3.3e-6 to 4.8e-5.
  const auto h1 = indicator(dir, db, "gmf_harmonic_1");
  const auto h2 = indicator(dir, db, "gmf_harmonic_2");
  REQUIRE(h1.size() == 6);
  REQUIRE(h2.size() == 6);
  for (const auto& [key, value] : h1) CHECK(value == Approx(key.second == 0 ? 5.0 : 2.5).epsilon(1e-3));
  for (const auto& [key, value] : h2) CHECK(value == Approx(key.second == 0 ? 2.5 : 1.25).epsilon(1e-3));
  // The operating condition reaches the records.
  for (const auto& row : gearwatch_json(dir, "query indicators --db " + shell_quoted(db) + " --name input_speed_hz")) {
    CHECK(row["torque_nm"] == Approx(15.0));
    CHECK(row["speed_hz"] == Approx(10.0));
  }
}

TEST_CASE("capture_gen: records carry the life counter plus the tacho revolutions since it", "[capture_gen]") {
  // The odometer starts beyond 2^32 revolutions; the life counter frame comes once a second. A
  // record starting at sample k must carry start_revs + (edges before k); with edges at
  // (j + phase)·fs/speed that is start_revs + ceil(k·speed/fs − phase), i.e. speed × t within one
  // edge. Records of 0.7 s start between life-counter frames, so the tacho count matters.
  const gearwatch::testing::TempDir dir("capgen-life");
  const std::uint64_t start_revs = 123456789012ULL;
  const double fs = 100000, speed = 12.5, phase = 0.31415926535;
  const auto cap = generate(dir, "life",
                            "--duration 4.5 --speed 12.5 --gmf-harmonics 1 --channels 0,1 --start-revs " +
                                std::to_string(start_revs) + " --first-index 4294917296");
  const auto lives = cap.summary["life_counter_values"];
  REQUIRE(lives.size() == 5);
  const auto db = dir / "life.db";
  const auto config = write_config(dir, "[records]\nlength_s = 0.7\ninterval_s = 0.7\nmin_length_s = 0.5\n");
  gearwatch_json(dir, "replay " + shell_quoted(cap.log) + " --db " + shell_quoted(db) + " --config " + shell_quoted(config));
  const auto records = gearwatch_json(dir, "query records --db " + shell_quoted(db));
  REQUIRE(records.size() == 7);  // 6 complete records of 0.7 s and the 0.3 s tail (not analysed)
  std::map<std::int64_t, std::int64_t> start_sample;
  for (const auto& r : records) start_sample[r["record_id"]] = r["start_index"].get<std::int64_t>() - 4294917296LL;
  int checked = 0;
  for (const auto& row : gearwatch_json(dir, "query indicators --db " + shell_quoted(db) + " --name input_speed_hz")) {
    const auto k = start_sample.at(row["record_id"].get<std::int64_t>());
    const double expected = static_cast<double>(start_revs) + std::ceil(static_cast<double>(k) * speed / fs - phase);
    INFO("record at sample " << k);
    CHECK(row["cycles"].get<double>() == expected);
    CHECK(std::abs(row["cycles"].get<double>() - (static_cast<double>(start_revs) + speed * static_cast<double>(k) / fs)) <= 1.0);
    ++checked;
  }
  CHECK(checked == 12);  // 6 analysed records x 2 channels
}

TEST_CASE("capture_gen: ICS2 of AM noise in the pitting band agrees with the closed form within its scatter",
          "[capture_gen]") {
  // Gaussian noise of 3 m/s² in 4–11 kHz, modulated by 1 + 0.5 cos(2π GMF t), on two channels
  // (independent noise), two 10 s records: four estimates of ics2_low_band (2–13 kHz band, H = 3,
  // ±3 bins). Closed form (a² + a⁴/16)/(1 + a²/2)² = 0.200617. Each record analyses R' = 98
  // whole revolutions (99 after the first edge, largest 7-smooth count ≤ 99), i.e. 9.8 s; the
  // generator's scatter model for 9.8 s gives the expected mean (0.20067, the ±3-bin maximum adds
  // a little) and standard deviation (0.0021). 48 estimates over 12 seeds measured mean 0.20112,
  // std 0.00211. Each estimate must lie within 4σ, their mean within 3σ/√4.
  const gearwatch::testing::TempDir dir("capgen-ics2");
  const auto cap = generate(dir, "am", "--duration 20 --speed 10 --am-noise 4000:11000:3:0.5 --channels 0,1 "
                                       "--ics2-analysis-seconds 9.8 --seed 1");
  const auto& noise = cap.summary["am_noise"].at(0);
  const double a = 0.5;
  CHECK(noise["ics2_closed_form"].get<double>() == Approx((a * a + std::pow(a, 4) / 16) / std::pow(1 + a * a / 2, 2)).epsilon(1e-14));
  const double mean = noise["ics2_predicted_mean"], sigma = noise["ics2_predicted_std"];
  CHECK(mean == Approx(noise["ics2_closed_form"].get<double>()).epsilon(2e-3));  // finite-length bias is small
  CHECK(sigma == Approx(0.0021).epsilon(0.05));
  const auto db = dir / "am.db";
  const auto config = write_config(dir, "[records]\nlength_s = 10\ninterval_s = 10\n");
  const auto replay = gearwatch_json(dir, "replay " + shell_quoted(cap.log) + " --db " + shell_quoted(db) + " --config " + shell_quoted(config));
  CHECK(replay["records_analysed"] == 2);
  const auto ics2 = indicator(dir, db, "ics2_low_band");
  REQUIRE(ics2.size() == 4);
  double sum = 0;
  for (const auto& [key, value] : ics2) {
    INFO("record " << key.first << " channel " << key.second << ": " << value << ", expected " << mean << " ± " << sigma);
    CHECK(std::abs(value - mean) <= 4 * sigma);
    sum += value;
  }
  CHECK(std::abs(sum / 4 - mean) <= 3 * sigma / 2);
}

}  // namespace test_capture_gen
