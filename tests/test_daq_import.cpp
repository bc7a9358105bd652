// `gearwatch import`, end to end through the binary: recordings written independently
// (tests/capture_gen/daq_recordings.py: Python's wave module, numpy text, scipy's MATLAB v5
// writer) from one known signal are imported, the captures decoded here from their candump lines
// and replayed. The direct capture they are held against is the existing capture writer's, fed
// the same samples.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "capture_writer.hpp"
#include "command_runner.hpp"
#include "gearwatch/acquisition/candump_log.hpp"
#include "gearwatch/acquisition/daq_file.hpp"
#include "gearwatch/acquisition/daq_import.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "temp_dir.hpp"

namespace test_daq_import {  // this file's own: the test files compile together (unity build)

namespace fs = std::filesystem;
using gearwatch::testing::run_command;

namespace {

// The generator's signal (tests/capture_gen/daq_recordings.py).
constexpr double kFs = 25600.0;
constexpr double kSpeedHz = 25.3;
constexpr double kLsb = 0.01;  // [[channels]] scale of the config below, m/s² per LSB

std::string q(const fs::path& p) { return "'" + p.native() + "'"; }

template <class T>
std::vector<T> read_binary(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::vector<char> bytes{std::istreambuf_iterator<char>(in), {}};
  std::vector<T> v(bytes.size() / sizeof(T));
  std::memcpy(v.data(), bytes.data(), v.size() * sizeof(T));
  return v;
}

void generate(const gearwatch::testing::TempDir& dir) {
  const auto r = run_command(std::string(GEARWATCH_PYTHON) + " " + q(fs::path(GEARWATCH_SOURCE_DIR) / "tests/capture_gen/daq_recordings.py") +
                             " --out " + q(dir.path()));
  INFO(r.err);
  REQUIRE(r.status == 0);
}

fs::path write_config(const gearwatch::testing::TempDir& dir) {
  const auto path = dir / "gearwatch.toml";
  std::ofstream(path) << "[rig]\nsample_rate_hz = 25600\n[gears]\npinion_teeth = 23\ngear_teeth = 46\n"
                         "[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n"
                         "[records]\nlength_s = 2\ninterval_s = 2\nmin_length_s = 1\n[model]\nenabled = false\n";
  return path;
}

gearwatch::testing::CommandResult gw(const std::string& args) {
  return run_command(std::string(GEARWATCH_BINARY) + " " + args);
}

void must(const std::string& args) {
  const auto r = gw(args);
  INFO(args << "\n" << r.err);
  REQUIRE(r.status == 0);
}

// What a capture carries, decoded from its lines with the protocol's default ids: channel 0's
// samples placed by their frame's first index, the tacho edges and the condition frames.
struct Decoded {
  std::vector<std::int16_t> samples;
  std::vector<double> edges;
  struct Condition {
    double torque, speed;
    std::uint32_t index;
  };
  std::vector<Condition> conditions;
  std::uint32_t rate = 0;
};

template <class T>
T le(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

Decoded decode(const fs::path& capture) {
  Decoded d;
  std::ifstream in(capture);
  std::string line, reason;
  while (std::getline(in, line)) {
    const auto parsed = gearwatch::acquisition::parse_candump_line(line, reason);
    REQUIRE(parsed);
    const auto& f = parsed->frame;
    if (f.id == 0x100) {
      const auto first = le<std::uint32_t>(f.data.data());
      const std::size_t n = (f.len - 4u) / 2u;
      if (d.samples.size() < first + n) d.samples.resize(first + n);
      for (std::size_t k = 0; k < n; ++k) d.samples[first + k] = le<std::int16_t>(f.data.data() + 4 + 2 * k);
    } else if (f.id == 0x180) {
      d.edges.push_back(le<std::uint32_t>(f.data.data()) + le<std::uint32_t>(f.data.data() + 4) / 4294967296.0);
    } else if (f.id == 0x1F1 && f.len == 12) {
      d.conditions.push_back({le<float>(f.data.data()), le<float>(f.data.data() + 4), le<std::uint32_t>(f.data.data() + 8)});
    } else if (f.id == 0x1F0) {
      d.rate = le<std::uint32_t>(f.data.data());
    }
  }
  return d;
}

std::vector<std::string> rows(const fs::path& db, const std::string& sql) {
  gearwatch::storage::Database d(db.string(), gearwatch::storage::Database::Mode::read_only);
  gearwatch::storage::Statement s(d, sql);
  std::vector<std::string> out;
  while (s.step()) {
    std::string row;
    for (int c = 0; c < s.column_count(); ++c) row += (s.is_null(c) ? std::string("NULL") : s.get_text(c)) + "|";
    out.push_back(row);
  }
  return out;
}

/// Replays `capture` into a fresh database: the records and their indicator values.
struct Replayed {
  std::vector<std::string> records, indicators;
};

Replayed replay(const gearwatch::testing::TempDir& dir, const fs::path& capture, const fs::path& config) {
  const fs::path db = dir / (capture.stem().string() + ".db");
  must("replay " + q(capture) + " --db " + q(db) + " --config " + q(config));
  // printf('%.17g'): every value to its last bit, so "equal" means equal.
  return {rows(db, "SELECT start_index, sample_count, end_reason, analysed, torque_nm, speed_hz FROM records ORDER BY id"),
          rows(db, "SELECT record_id, channel, name, printf('%.17g', value) FROM indicators ORDER BY record_id, channel, name")};
}

}  // namespace

TEST_CASE("import: a WAV and a .mat file replay to the same records as the capture written directly from the same samples",
          "[import]") {
  const gearwatch::testing::TempDir dir("daq-import-equal");
  generate(dir);
  const auto config = write_config(dir);
  const auto codes = read_binary<std::int16_t>(dir / "codes.i16");
  REQUIRE(codes.size() == 115200);

  // The existing writer, given the samples (codes × 0.01 m/s²) and a tacho at the nameplate speed.
  std::vector<float> x(codes.size());
  for (std::size_t i = 0; i < codes.size(); ++i) x[i] = static_cast<float>(codes[i] * kLsb);
  std::vector<double> edges;
  for (double k = 1; k * kFs / kSpeedHz < static_cast<double>(codes.size()); ++k) edges.push_back(k * kFs / kSpeedHz);
  gearwatch::daemon::CaptureSettings cs;
  cs.signal.sample_rate_hz = kFs;
  cs.signal.channels = 1;
  cs.signal.speed_hz = kSpeedHz;
  cs.signal.torque_nm = 20.0;
  cs.duration_s = static_cast<double>(codes.size()) / kFs;
  auto signal = gearwatch::daemon::sampled_capture_signal(kFs, x, edges);
  gearwatch::daemon::write_capture(cs, *signal, (dir / "direct.log").string());

  // WAV: 16-bit codes at full scale 1.0 = 32768 codes, so --scale 327.68 m/s² gives 0.01 m/s² a code.
  must("import " + q(dir / "rec.wav") + " --out " + q(dir / "wav.log") + " --map 0=casing_y --scale 327.68 --speed 25.3 --torque 20 --config " + q(config));
  // .mat: accel in m/s², fs from the file's variable.
  must("import " + q(dir / "rec.mat") + " --out " + q(dir / "mat.log") + " --speed 25.3 --torque 20 --config " + q(config));
  // .mat v7.3 (HDF5): the same variables, so the same capture, line for line.
  must("import " + q(dir / "rec73.mat") + " --out " + q(dir / "mat73.log") + " --speed 25.3 --torque 20 --config " + q(config));
  {
    std::ifstream a(dir / "mat.log"), b(dir / "mat73.log");
    CHECK(std::string(std::istreambuf_iterator<char>(a), {}) == std::string(std::istreambuf_iterator<char>(b), {}));
  }

  // The captures carry the file's samples exactly: they are whole codes of the capture's LSB.
  for (const char* name : {"wav.log", "mat.log"}) {
    const Decoded d = decode(dir / name);
    INFO(name);
    CHECK(d.rate == 25600);
    CHECK(d.samples == codes);
    CHECK(d.edges.size() == edges.size());
  }
  const Replayed direct = replay(dir, dir / "direct.log", config);
  REQUIRE(direct.records.size() == 3);  // 2 s, 2 s and the last 0.5 s (too short: not analysed)
  REQUIRE(direct.indicators.size() > 20);
  const Replayed wav = replay(dir, dir / "wav.log", config);
  const Replayed mat = replay(dir, dir / "mat.log", config);
  CHECK(wav.records == direct.records);
  CHECK(wav.indicators == direct.indicators);
  CHECK(mat.records == direct.records);
  CHECK(mat.indicators == direct.indicators);

  // Neither tacho nor speed: no tacho frames, speed 0 in the condition frames, and the daemon's
  // estimate from the signal. Held to the targets: speed within 0.01 % at constant speed,
  // RMS_SA within 2 % of the value on the exact tacho (the direct capture's).
  must("import " + q(dir / "rec.wav") + " --out " + q(dir / "none.log") + " --map 0=casing_y --scale 327.68 --torque 20 --config " + q(config));
  const Decoded none = decode(dir / "none.log");
  CHECK(none.edges.empty());
  CHECK(none.samples == codes);
  for (const auto& c : none.conditions) CHECK(c.speed == 0.0);
  replay(dir, dir / "none.log", config);
  CHECK(rows(dir / "none.db", "SELECT speed_source FROM records WHERE analysed = 1") ==
        std::vector<std::string>{"signal_estimate|", "signal_estimate|"});
  for (const auto& v : rows(dir / "none.db", "SELECT estimated_speed_hz FROM records WHERE analysed = 1"))
    CHECK(std::stod(v) == Approx(kSpeedHz).epsilon(1e-4));
  const auto rms = [&](const char* db) {
    return rows(dir / db, "SELECT value FROM indicators WHERE name = 'rms_sa' AND channel = 0 ORDER BY record_id");
  };
  const auto estimated = rms("none.db"), exact = rms("direct.db");
  REQUIRE(estimated.size() == 2);
  REQUIRE(exact.size() == 2);
  for (std::size_t k = 0; k < 2; ++k) CHECK(std::stod(estimated[k]) == Approx(std::stod(exact[k])).epsilon(0.02));
}

TEST_CASE("import: a CSV in g with a time column and a tacho column comes back within half an LSB and the tacho's speed",
          "[import]") {
  const gearwatch::testing::TempDir dir("daq-import-csv");
  generate(dir);
  const auto config = write_config(dir);
  const auto accel = read_binary<double>(dir / "accel.f64");
  const auto true_edges = read_binary<double>(dir / "edges.f64");
  must("import " + q(dir / "rec.csv") + " --out " + q(dir / "csv.log") + " --tacho tacho_V --unit g --torque 20 --config " + q(config));
  const Decoded d = decode(dir / "csv.log");
  CHECK(d.rate == 25600);  // from the time column
  REQUIRE(d.samples.size() == accel.size());
  // Rounding to the LSB moves a sample by at most half of it; the g → m/s² product and the
  // 17-digit text add ~1e-15 m/s².
  double worst = 0;
  for (std::size_t i = 0; i < accel.size(); ++i) worst = std::max(worst, std::fabs(d.samples[i] * kLsb - accel[i]));
  CHECK(worst <= kLsb / 2 + 1e-9);
  CHECK(worst > kLsb / 2 * 0.99);  // the bound is reached: the samples really were quantised, not copied

  // Tacho pulses (0 / 5 V rectangles): each rising edge is located between the last sample below
  // the mid level and the first above it, so within 1 sample of the true crossing.
  REQUIRE(d.edges.size() == true_edges.size());
  double edge_error = 0;
  for (std::size_t k = 0; k < true_edges.size(); ++k) edge_error = std::max(edge_error, std::fabs(d.edges[k] - true_edges[k]));
  CHECK(edge_error <= 1.0);
  // Each condition frame's speed is the mean over the edges within ±0.5 s of it: with each end
  // within a sample, relatively within 2 / span (span = those true edges' extent in samples).
  REQUIRE(d.conditions.size() == 5);
  for (const auto& c : d.conditions) {
    std::vector<double> in;
    for (double e : true_edges)
      if (e >= c.index - kFs / 2 && e < c.index + kFs / 2) in.push_back(e);
    REQUIRE(in.size() >= 2);
    const double bound = 2.0 / (in.back() - in.front()) + 1e-7;  // + float32
    CHECK(std::fabs(c.speed / kSpeedHz - 1.0) <= bound);
    CHECK(c.torque == 20.0);
  }

  const Replayed r = replay(dir, dir / "csv.log", config);
  REQUIRE(r.records.size() == 3);
  const fs::path db = dir / "csv.db";
  CHECK(rows(db, "SELECT speed_source FROM records WHERE analysed = 1 ORDER BY id") == std::vector<std::string>{"tacho|", "tacho|"});
  // Over a 2 s record (50 edges, span ~ 49 600 samples) the tacho's mean speed is within
  // 2 / 49 600 = 4.0e-5 of the true one.
  for (const auto& v : rows(db, "SELECT value FROM indicators WHERE channel = 0 AND name = 'input_speed_hz'"))
    CHECK(std::stod(v) == Approx(kSpeedHz).epsilon(4.1e-5));
}

TEST_CASE("import: each refusal prints one line and writes nothing", "[import]") {
  const gearwatch::testing::TempDir dir("daq-import-refusals");
  generate(dir);
  const auto config = write_config(dir);
  const std::string common = " --torque 20 --config " + q(config);
  const std::vector<std::pair<std::string, std::string>> cases{
      {q(dir / "rate8k.wav") + " --speed 25", "sample rate 8000 Hz is outside 10-200 kHz"},
      {q(dir / "short.wav") + " --speed 25", "shorter than one record"},
      {q(dir / "rec.wav") + " --map 5=casing_y --scale 327.68", "no channel 5 in the recording"},
      {q(dir / "rec.wav") + " --tacho 7", "no channel 7 in the recording"},
      {q(dir / "rec.wav") + " --map 0=casing_q", "no configured channel casing_q"},
      {q(dir / "bad_cell.csv") + " --unit g", "line 7, column 2: not a number: \"abc\""},
      {q(dir / "nan.csv") + " --tacho tacho_V --unit g", "sample 3 is not a number"},
      {q(dir / "clipped.wav") + " --scale 327.68", "sample 1000 sits at the file's full scale: the recording is clipped"},
      {q(dir / "rec.mat") + " --mat-variable nope", "no variable nope"},
      {q(dir / "rec.mat") + " --mat-variable info", "variable info is not a real numeric matrix"},
      {q(dir / "rec.mat") + " --mat-variable fs", "shorter than one record"},
      {q(dir / "rec.mat") + " --sample-rate 48000", "--sample-rate 48000 Hz disagrees with the 25600 Hz of the .mat variable"},
      {q(dir / "rec.wav") + " --map 0=casing_y --scale 3276800", "beyond the capture's"},
      {q(dir / "rec.csv") + " --tacho tacho_V --unit V", "--unit V needs the accelerometer's --sensitivity"},
  };
  // One --out that exists already (a previous capture): a refusal leaves it as it was.
  std::ofstream(dir / "previous.log") << "(1700000000.000000) can0 1F0#A086010002010700\n";
  const auto listing = [&] {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir.path())) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  };
  const auto before = listing();
  int i = 0;
  for (const auto& [args, reason] : cases) {
    const fs::path out = dir / (i++ % 2 == 0 ? "previous.log" : "new.log");
    const auto r = gw("import " + args + " --out " + q(out) + common);
    INFO(args << "\n" << r.err);
    CHECK(r.status == 1);
    CHECK(r.out.empty());
    CHECK(r.err.find(reason) != std::string::npos);
    CHECK(r.err.rfind("gearwatch: ", 0) == 0);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK(r.err.find("nothing written") != std::string::npos);
    CHECK(listing() == before);  // no capture, no temporary file left behind
  }
  // A recording given to replay for a capture: one line pointing to import, no database.
  for (const char* recording : {"rec.wav", "rec.mat", "rec73.mat"}) {
    const auto r = gw("replay " + q(dir / recording) + " --db " + q(dir / "replay.db") + " --config " + q(config));
    INFO(recording << "\n" << r.err);
    CHECK(r.status == 1);
    CHECK(r.err.find("recording, not a capture: turn it into one with `gearwatch import ") != std::string::npos);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK_FALSE(fs::exists(dir / "replay.db"));
  }
  std::ifstream kept(dir / "previous.log");
  std::string line;
  std::getline(kept, line);
  CHECK(line == "(1700000000.000000) can0 1F0#A086010002010700");
}

TEST_CASE("import readers: a wide int16 .mat, a header-less semicolon CSV with a time column, units and tacho edges",
          "[import]") {
  namespace acq = gearwatch::acquisition;
  const gearwatch::testing::TempDir dir("daq-import-readers");
  generate(dir);
  const auto codes = read_binary<std::int16_t>(dir / "codes.i16");

  // A 2 x 1000 matrix is two channels of 1000 samples (channels along the shorter dimension);
  // int16 values come back as they are; the rate from the variable Fs.
  const acq::DaqRecording wide = acq::read_daq_file((dir / "rows.mat").string());
  REQUIRE(wide.channels.size() == 2);
  REQUIRE(wide.samples() == 1000);
  CHECK(wide.names == std::vector<std::string>{"wide[0]", "wide[1]"});
  CHECK(wide.sample_rate_hz == 51200.0);
  CHECK(wide.rate_source == acq::RateSource::mat_variable);
  for (std::size_t i = 0; i < 1000; ++i) {
    CHECK(wide.channels[0][i] == codes[i]);
    CHECK(wide.channels[1][i] == -codes[i]);
  }

  // No header: columns are named by index, and the time column is named by index too.
  const acq::DaqRecording csv = acq::read_csv((dir / "semicolon.csv").string(), {"0", "", ""});
  REQUIRE(csv.channels.size() == 1);
  CHECK(csv.names == std::vector<std::string>{"column 1"});
  // Times printed to 1 ns: the rate (n-1)/(t_last - t_0) is within 1e-9 s / 19.5 ms of 51 200 Hz.
  CHECK(csv.sample_rate_hz == Approx(51200.0).epsilon(1e-6));
  for (std::size_t i = 0; i < 1000; ++i) CHECK(csv.channels[0][i] == Approx(codes[i] * kLsb).margin(1e-12));

  // Units: g is standard gravity; V through the sensitivity (100 mV/g: 10 g per volt).
  CHECK(acq::m_s2_per_file_unit({2.0, acq::SampleUnit::g, std::nan("")}) == 2.0 * 9.80665);
  CHECK(acq::m_s2_per_file_unit({1.0, acq::SampleUnit::volt, 100.0}) == Approx(98.0665).epsilon(1e-15));
  CHECK_THROWS_AS(acq::m_s2_per_file_unit({1.0, acq::SampleUnit::volt, std::nan("")}), acq::DaqFileError);

  // Tacho edges on trapezoidal pulses (0 → 4 V over a linear 8-sample ramp) with up to 0.2 V of
  // ripple on the flat parts, towards the middle (so the range stays 0 … 4 V and the mid level 2 V):
  // the mid-level crossing of a linear ramp is found exactly, and the ripple (5 % of the range,
  // short of the hysteresis levels at 40 % and 60 %) adds no edge. Rises start at 100.37 + 250.5 k.
  std::vector<double> tacho(3000);
  std::vector<double> expected;
  for (double start = 100.37; start + 60 < 3000; start += 250.5) expected.push_back(start + 4.0);  // mid-level at half the ramp
  for (std::size_t i = 0; i < tacho.size(); ++i) {
    const double t = static_cast<double>(i);
    double v = 0;
    for (double e : expected) {
      const double start = e - 4.0;
      if (t >= start && t < start + 8) v = 4.0 * (t - start) / 8;
      if (t >= start + 8 && t < start + 60) v = 4.0;
    }
    const bool on_ramp = v > 0 && v < 4.0;
    const double ripple = on_ramp ? 0.0 : 0.2 * std::fabs(std::sin(1.7 * t));
    tacho[i] = v >= 4.0 ? v - ripple : v + ripple;
  }
  const auto edges = acq::detect_tacho_edges(tacho);
  REQUIRE(edges.size() == expected.size());
  for (std::size_t k = 0; k < edges.size(); ++k) CHECK(edges[k] == Approx(expected[k]).margin(1e-9));
  CHECK(acq::speed_from_edges(edges, 1, 51200.0, 0, 3000) == Approx(51200.0 / 250.5).epsilon(1e-12));
}

}  // namespace test_daq_import
