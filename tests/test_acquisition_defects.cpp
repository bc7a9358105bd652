// Acquisition defects of issue 33 (items 9, 10, 11, 13), end to end through the `gearwatch`
// binary where a user meets them: captures from the independent generator
// (tests/capture_gen/rig_capture.py), replayed, and the database read back with SQL.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "command_runner.hpp"
#include "gearwatch/acquisition/record_assembler.hpp"
#include "gearwatch/wear/wear_loop.hpp"
#include "model_thread.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "temp_dir.hpp"

namespace test_acquisition_defects {  // this file's own: the test files compile together (unity build)

namespace fs = std::filesystem;
using gearwatch::testing::run_command;

namespace {

const std::string kGenerator = std::string(GEARWATCH_PYTHON) + " " + GEARWATCH_SOURCE_DIR + "/tests/capture_gen/rig_capture.py";

// One-second records, one every second; the twin's model thread has its own tests.
const char* const kOneSecondRecords = "[records]\nlength_s = 1\ninterval_s = 1\nmin_length_s = 0.5\n[model]\nenabled = false\n";

void generate(const fs::path& out, const std::string& args) {
  const auto r = run_command(kGenerator + " --out " + out.string() + " " + args);
  INFO(args << "\n" << r.err);
  REQUIRE(r.status == 0);
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// The capture's lines, without those a filter drops.
std::vector<std::string> lines_of(const fs::path& p) {
  std::vector<std::string> lines;
  std::istringstream in(slurp(p));
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

void write_lines(const fs::path& p, const std::vector<std::string>& lines, std::ios::openmode mode = std::ios::trunc) {
  std::ofstream out(p, std::ios::binary | mode);
  for (const auto& l : lines) out << l << '\n';
}

fs::path write_config(const fs::path& dir, const std::string& text) {
  const auto path = dir / "gearwatch.toml";
  std::ofstream(path) << text;
  return path;
}

gearwatch::testing::CommandResult replay(const fs::path& capture, const fs::path& db, const fs::path& config,
                                         const std::string& prefix = {}) {
  return run_command(prefix + std::string(GEARWATCH_BINARY) + " replay " + capture.string() + " --db " + db.string() +
                     " --config " + config.string());
}

double scalar(const fs::path& db, const std::string& sql) {
  gearwatch::storage::Database d(db.string(), gearwatch::storage::Database::Mode::read_only);
  gearwatch::storage::Statement s(d, sql);
  REQUIRE(s.step());
  return s.is_null(0) ? std::nan("") : s.get_double(0);
}

std::vector<std::string> texts(const fs::path& db, const std::string& sql) {
  gearwatch::storage::Database d(db.string(), gearwatch::storage::Database::Mode::read_only);
  gearwatch::storage::Statement s(d, sql);
  std::vector<std::string> out;
  while (s.step()) out.push_back(s.is_null(0) ? "NULL" : s.get_text(0));
  return out;
}

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + what.size())) ++n;
  return n;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Item 13: unbounded line length.

TEST_CASE("defects #13: an 800 MB line is counted once as malformed and skipped in bounded memory and every frame around it is replayed",
          "[defects][acquisition]") {
  const gearwatch::testing::TempDir dir("defects13-long");
  const auto clean = dir / "clean.log";
  generate(clean, "--duration 2 --json-summary " + (dir / "clean.json").string());
  const auto lines = lines_of(clean);
  REQUIRE(lines.size() > 100);
  // The first half of the lines, then 800 MB of NUL bytes (a hole in a sparse file: no disk is
  // used) ending in a newline, then the second half.
  const auto capture = dir / "long.log";
  const std::vector<std::string> first(lines.begin(), lines.begin() + static_cast<std::ptrdiff_t>(lines.size() / 2));
  const std::vector<std::string> second(lines.begin() + static_cast<std::ptrdiff_t>(lines.size() / 2), lines.end());
  write_lines(capture, first);
  const std::uintmax_t long_line = 800'000'000;
  fs::resize_file(capture, fs::file_size(capture) + long_line);
  {
    std::ofstream out(capture, std::ios::binary | std::ios::app);
    out << '\n';
  }
  write_lines(capture, second, std::ios::app);
  const auto config = write_config(dir.path(), kOneSecondRecords);
  const auto db = dir / "long.db";
  // 256 MiB of data segment: the line cannot be held whole.
  const auto r = replay(capture, db, config, "prlimit --data=268435456 ");
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(r.out.find("replayed") == 0);
  CHECK(scalar(db, "SELECT malformed_lines FROM acquisition_health") == 1);
  CHECK(scalar(db, "SELECT count(*) FROM rejected_frames WHERE kind = 'malformed_line'") == 1);
  CHECK(texts(db, "SELECT reason FROM rejected_frames") ==
        std::vector<std::string>{"line longer than 300 characters; the rest of it skipped"});
  // The first 300 characters of the line (NUL bytes here) are what is kept of it.
  CHECK(scalar(db, "SELECT length(CAST(frame AS BLOB)) FROM rejected_frames") == 300);
  // Every generated frame is in the file before or after the long line, and all are decoded.
  CHECK(scalar(db, "SELECT frames FROM acquisition_health") == static_cast<double>(lines.size()));
  CHECK(scalar(db, "SELECT samples FROM acquisition_health") == 2 * 200010.0);  // 2 channels, 2 s rounded up to whole frames
  CHECK(scalar(db, "SELECT count(*) FROM records WHERE analysed = 1") == 2);
}

TEST_CASE("defects #13: replaying /dev/zero is refused in one line before anything is stored, and nothing says 'replayed'",
          "[defects][acquisition]") {
  const gearwatch::testing::TempDir dir("defects13-zero");
  const auto db = dir / "z.db";
  const auto r = run_command("prlimit --data=268435456 " + std::string(GEARWATCH_BINARY) + " replay /dev/zero --db " + db.string());
  CHECK(r.status != 0);
  CHECK(r.out.empty());
  CHECK(r.err == "gearwatch: capture /dev/zero is a device, not a candump log file\n");
  CHECK(!fs::exists(db));
}

// ---------------------------------------------------------------------------------------------
// Item 11: dead sensors.

TEST_CASE("defects #11: accelerometers that send nothing while the tacho goes on raise sensor_missing once each and it clears when they deliver",
          "[defects][acquisition]") {
  const gearwatch::testing::TempDir dir("defects11-vib");
  // Stream 1: 4 s of tacho, header, speed and life counter, and no vibration frame at all.
  // Stream 2: 3 s with both accelerometers.
  const auto silent = dir / "silent.log", back = dir / "back.log", capture = dir / "capture.log";
  generate(silent, "--duration 4 --stop-channel 0:0 --stop-channel 1:0 --white-noise 1");
  generate(back, "--duration 3 --stream-id 2 --start-time 1700000010 --start-revs 40 --white-noise 1");
  REQUIRE(slurp(silent).find(" 100##") == std::string::npos);
  write_lines(capture, lines_of(silent));
  write_lines(capture, lines_of(back), std::ios::app);
  const auto config = write_config(dir.path(), kOneSecondRecords);
  const auto db = dir / "vib.db";
  const auto r = replay(capture, db, config);
  INFO(r.err);
  REQUIRE(r.status == 0);
  // Raised once per channel (value: the stream announced them but they never sent), cleared by
  // the first record of stream 2 that holds them.
  CHECK(texts(db, "SELECT channel || ' ' || transition || ' ' || coalesce(value, '') FROM alerts WHERE kind = 'sensor_missing' ORDER BY id") ==
        std::vector<std::string>{"0 raised silent", "1 raised silent", "0 cleared silent", "1 cleared silent"});
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'sensor_missing' AND severity = 'alarm'") == 2);
  // No record from stream 1; stream 2's three seconds give three analysed records of both channels.
  CHECK(scalar(db, "SELECT count(*) FROM records r JOIN streams s ON s.id = r.stream_key WHERE s.stream_id = 1") == 0);
  CHECK(scalar(db, "SELECT count(*) FROM records WHERE analysed = 1") == 3);
  CHECK(scalar(db, "SELECT channels_stopped FROM acquisition_health") == 2);
  CHECK(scalar(db, "SELECT count(*) FROM active_alerts") == 0);
}

TEST_CASE("defects #11: a tacho that sends nothing while the samples go on raises tacho_missing once and it clears when its edges come back",
          "[defects][acquisition]") {
  const gearwatch::testing::TempDir dir("defects11-tacho");
  // Stream 1: 6 s without a single tacho frame (the generator's capture with them taken out).
  // At rig.min_speed_hz = 0.5 and one edge per revolution the tacho is missing after two edge
  // intervals, 4 s. Stream 2: 3 s with the tacho.
  const auto with_tacho = dir / "with.log", back = dir / "back.log", capture = dir / "capture.log";
  generate(with_tacho, "--duration 6 --white-noise 1");
  generate(back, "--duration 3 --stream-id 2 --start-time 1700000010 --start-revs 60 --white-noise 1");
  std::vector<std::string> without;
  std::size_t removed = 0;
  for (const auto& l : lines_of(with_tacho)) {
    if (l.find(" 180##") != std::string::npos) ++removed;
    else without.push_back(l);
  }
  REQUIRE(removed == 60);  // 10 Hz for 6 s
  write_lines(capture, without);
  write_lines(capture, lines_of(back), std::ios::app);
  const auto config = write_config(dir.path(), kOneSecondRecords);
  const auto db = dir / "tacho.db";
  const auto r = replay(capture, db, config);
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(texts(db, "SELECT channel || ' ' || severity || ' ' || transition || ' ' || coalesce(value, '') FROM alerts WHERE kind = 'tacho_missing' ORDER BY id") ==
        std::vector<std::string>{"0 alarm raised missing", "0 info cleared missing"});
  // Raised 4 s into stream 1 (sample 400 000 past the stream's first index 0), before stream 2.
  CHECK(texts(db, "SELECT message FROM alerts WHERE kind = 'tacho_missing' AND transition = 'raised'").at(0).find("no edge since sample 0") !=
        std::string::npos);
  CHECK(count_of(r.err, "tacho of shaft 0: no edge since sample 0") == 1);
  // Stream 1's records are still stored and analysed as far as they can be (no order domain).
  CHECK(scalar(db, "SELECT count(*) FROM records r JOIN streams s ON s.id = r.stream_key WHERE s.stream_id = 1 AND r.analysed = 1") == 6);
  CHECK(scalar(db, "SELECT count(*) FROM alerts WHERE kind = 'sensor_missing'") == 0);
  CHECK(scalar(db, "SELECT count(*) FROM active_alerts") == 0);
}

// ---------------------------------------------------------------------------------------------
// Item 9: cycle counts that cannot be right.

TEST_CASE("defects #9: a tacho with 4 edges per revolution against a config of 1 gives no cycle counts, one cycle_count_fault alert, and records that say why",
          "[defects][acquisition]") {
  const gearwatch::testing::TempDir dir("defects9");
  const auto capture = dir / "capture.log";
  generate(capture, "--duration 5 --tacho-edges-per-rev 4 --start-revs 1000000 --white-noise 1");
  const auto db = dir / "wrong.db";
  const auto r = replay(capture, db, write_config(dir.path(), kOneSecondRecords));  // [[tachos]] edges_per_rev = 1 by default
  INFO(r.err);
  REQUIRE(r.status == 0);
  // Five analysed records; none has a place in the pair's life, and none a negative one.
  CHECK(scalar(db, "SELECT count(*) FROM records WHERE analysed = 1") == 5);
  CHECK(scalar(db, "SELECT count(*) FROM records WHERE input_revolutions IS NOT NULL") == 0);
  // The tacho's 40 edges a second read as 40 Hz against the speed frame's 10 Hz: raised once.
  const auto alerts = texts(db, "SELECT severity || ' ' || transition || ' ' || value || ' | ' || message FROM alerts WHERE kind = 'cycle_count_fault'");
  REQUIRE(alerts.size() == 1);
  CHECK(alerts[0].find("warning raised edge_rate_mismatch | input tacho gives 40 Hz with edges_per_rev = 1, the speed frame 10 Hz") == 0);
  // Each analysed record says so for each channel, instead of a wear verdict.
  CHECK(scalar(db, "SELECT count(*) FROM indicator_skips WHERE name = 'wear_mechanism' AND reason = 'cycle_count_fault'"
                   " AND detail LIKE 'input tacho gives 40 Hz%'") == 10);
  CHECK(scalar(db, "SELECT count(*) FROM wear_mechanism_assessments") == 0);

  SECTION("the same capture with the right edges_per_rev: counts as the generator's life counter plus edges / 4, and no alert") {
    const auto good = dir / "right.db";
    const auto config = write_config(dir.path(), std::string(kOneSecondRecords) +
                                                     "[[tachos]]\nshaft = 0\nname = \"input\"\nedges_per_rev = 4\nratio_to_input = 1.0\n");
    const auto ok = replay(capture, good, config);
    INFO(ok.err);
    REQUIRE(ok.status == 0);
    CHECK(scalar(good, "SELECT count(*) FROM alerts WHERE kind = 'cycle_count_fault'") == 0);
    // Record k starts at sample 100 000 k; the life counter of the status frame at 99 990 j <= it
    // counts the whole revolutions begun before it (every 4th edge, edge j at (j/4 + phase)
    // revolutions), and the assembler adds a quarter for each edge after it up to the start.
    const double fs = 100000, speed = 10, phase = 0.31415926535;
    auto edge_at = [&](int j) { return (j / 4.0 + phase) * fs / speed; };
    const auto starts = texts(good, "SELECT start_index FROM records WHERE analysed = 1 ORDER BY id");
    const auto revs = texts(good, "SELECT input_revolutions FROM records WHERE analysed = 1 ORDER BY id");
    REQUIRE(starts.size() == 5);
    for (std::size_t k = 0; k < starts.size(); ++k) {
      const double start = std::stod(starts[k]);
      const double status = std::floor(start / 99990.0) * 99990.0;
      int before = 0, after = 0;
      for (int j = 0; edge_at(j) < start; ++j) (edge_at(j) < status ? before : after) += 1;
      const double expected = 1000000.0 + (before + 3) / 4 + after / 4.0;
      INFO("record starting at " << start);
      CHECK(std::stod(revs[k]) == expected);
    }
  }
}

TEST_CASE("defects #9: revolutions that go backwards within a stream leave the record without them, with the numbers",
          "[defects][acquisition]") {
  // No speed frame, so only the count itself can show the fault. 1 kHz, one channel, one-second
  // records; the tacho sends 4 edges per revolution at 10 rev/s (every 25 samples) but the rig
  // says 1: the assembler counts 40 rev/s. Life counter 100 at sample 0, 115 at sample 1500.
  using namespace gearwatch;
  using namespace gearwatch::acquisition;
  GearboxSpec rig;
  rig.sample_rate_hz = 1000;
  rig.channels = {{0, "a", 0.5}};
  rig.tachos = {{0, "input", 1, 1.0}};
  rig.schedule = {1.0, 1.0, 0.5};
  std::vector<Record> records;
  RecordAssembler::Callbacks callbacks;
  callbacks.on_record = [&](Record&& r, bool) { records.push_back(std::move(r)); };
  RecordAssembler assembler(rig, callbacks);
  AcquisitionEvent e;
  e.kind = EventKind::stream_start;
  e.stream_id = 1;
  e.sample_rate_hz = 1000;
  e.channel_count = 1;
  assembler.consume(e);
  auto life = [&](std::uint64_t index, std::uint64_t revolutions) {
    AcquisitionEvent l;
    l.kind = EventKind::life_counter;
    l.index = index;
    l.life.revolutions = revolutions;
    assembler.consume(l);
  };
  life(0, 100);
  for (std::uint64_t i = 0; i < 3000; i += 25) {
    AcquisitionEvent edge;
    edge.kind = EventKind::tacho_edge;
    edge.index = i + 10;
    edge.fraction = 0.5;
    assembler.consume(edge);
    AcquisitionEvent s;
    s.kind = EventKind::samples;
    s.index = i;
    s.count = 25;
    for (int k = 0; k < 25; ++k) s.samples[static_cast<std::size_t>(k)] = static_cast<std::int16_t>(k % 7);
    assembler.consume(s);
    if (i + 25 == 1500) life(1500, 115);
  }
  assembler.finish();
  REQUIRE(records.size() == 3);
  // Record 0: the reading itself. Record 1: 100 + 40 edges. Record 2: 115 + the 20 edges after
  // sample 1500 = 135, below 140: refused.
  REQUIRE(records[0].input_revolutions);
  CHECK(*records[0].input_revolutions == 100.0);
  REQUIRE(records[1].input_revolutions);
  CHECK(*records[1].input_revolutions == 140.0);
  CHECK(!records[2].input_revolutions);
  CHECK(records[2].cycle_fault == CycleCountFault::went_backwards);
  CHECK(records[2].cycle_fault_detail == "input revolutions 135 at the record's start, 140 at the previous record's in this stream: not used");
  CHECK(assembler.counters().cycle_count_faults == 1);
}

// ---------------------------------------------------------------------------------------------
// Item 10: the stream header's sample rate against the config's.

TEST_CASE("defects #10: a header rate of 200 kHz against a 100 kHz config is reported once per stream and the samples are analysed at 200 kHz",
          "[defects][acquisition]") {
  const gearwatch::testing::TempDir dir("defects10");
  // Streams 1 and 2 at 200 kHz, stream 3 at the configured 100 kHz; 2 s each at 10 Hz.
  const auto a = dir / "a.log", b = dir / "b.log", c = dir / "c.log", capture = dir / "capture.log";
  generate(a, "--duration 2 --sample-rate 200000 --white-noise 1");
  generate(b, "--duration 2 --sample-rate 200000 --stream-id 2 --start-time 1700000010 --start-revs 20 --white-noise 1");
  generate(c, "--duration 2 --stream-id 3 --start-time 1700000020 --start-revs 40 --white-noise 1");
  write_lines(capture, lines_of(a));
  write_lines(capture, lines_of(b), std::ios::app);
  write_lines(capture, lines_of(c), std::ios::app);
  const auto db = dir / "rate.db";
  const auto r = replay(capture, db, write_config(dir.path(), std::string("[rig]\nsample_rate_hz = 100000\n") + kOneSecondRecords));
  INFO(r.err);
  REQUIRE(r.status == 0);
  // Logged once per stream that differs, raised once (its value is the header's rate), cleared
  // by the stream at the configured rate.
  CHECK(count_of(r.err, "the header's sample rate 200000 Hz differs from rig.sample_rate_hz = 100000 Hz") == 2);
  CHECK(texts(db, "SELECT severity || ' ' || transition || ' ' || coalesce(value, '') FROM alerts WHERE kind = 'sample_rate_mismatch' ORDER BY id") ==
        std::vector<std::string>{"warning raised 200000", "info cleared 200000"});
  // A one-second record holds 200 000 samples in the 200 kHz streams, and the tacho's 10 edges a
  // second read as 10 Hz: both only at the header's rate.
  CHECK(texts(db, "SELECT r.sample_count || ' ' || r.duration_s FROM records r JOIN streams s ON s.id = r.stream_key"
                  " WHERE r.analysed = 1 ORDER BY r.id") ==
        std::vector<std::string>{"200000 1.0", "200000 1.0", "200000 1.0", "200000 1.0", "100000 1.0", "100000 1.0"});
  const auto speeds = texts(db, "SELECT value FROM indicator_values WHERE name = 'input_speed_hz'");
  REQUIRE(speeds.size() == 12);
  for (const auto& v : speeds) CHECK(std::abs(std::stod(v) - 10.0) < 1e-6);
}

TEST_CASE("defects #10: the twin simulates a record's RMS_SA at the record's sample rate, not rig.sample_rate_hz",
          "[defects][model]") {
  // The model's simulator against the twin run directly at each rate (the reference), for an
  // unworn pair at 10 Hz and 5 N m.
  using namespace gearwatch;
  const config::GearwatchConfig config;  // rig.sample_rate_hz = 100 000
  REQUIRE(config.rig.sample_rate_hz == 100000);
  const twin::GearboxParameters params;
  const wear::BlueLoop unworn(params, wear::WearLoopOptions{});
  const twin::OperatingPoint op{10, 5};
  auto direct = [&](double rate_hz) {
    GearboxSpec rig = config.rig;
    rig.sample_rate_hz = rate_hz;
    return wear::twin_rms_sa_simulator(params, rig, config.processing, config.model.simulation_revolutions)(unworn.state(), op);
  };
  double record_rate = 50000;
  const auto simulator = daemon::rms_sa_simulator_at_record_rate(params, config, record_rate);
  const double at_50k = direct(50000), at_100k = direct(100000);
  REQUIRE(at_50k != at_100k);  // the rate matters, so the comparison can tell them apart
  CHECK(simulator(unworn.state(), op) == at_50k);
  record_rate = 100000;
  CHECK(simulator(unworn.state(), op) == at_100k);
}

}  // namespace test_acquisition_defects
