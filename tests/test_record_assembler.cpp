#include "gearwatch/acquisition/record_assembler.hpp"

#include <vector>

#include <catch2/catch.hpp>

namespace test_record_assembler {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::acquisition;

namespace {

// A 1 kHz, two-channel stream whose sample value encodes its index, so every sample of every
// record can be checked exactly: value(ch, i) = (i % 1000 + 1000·ch) · scale.
struct Stream {
  GearboxSpec rig;
  std::vector<std::pair<Record, bool>> records;
  std::vector<DropoutInfo> gaps;
  std::vector<StreamInfo> streams;
  std::vector<ChannelStatusChange> statuses;
  std::unique_ptr<RecordAssembler> assembler;

  explicit Stream(double length_s = 1.0, double interval_s = 1.0, double min_length_s = 0.2) {
    rig.sample_rate_hz = 1000;
    rig.channels = {{0, "a", 0.5}, {1, "b", 0.5}};
    rig.tachos = {{0, "input", 1, 1.0}};
    rig.schedule = {length_s, interval_s, min_length_s};
    assembler = std::make_unique<RecordAssembler>(
        rig, RecordAssembler::Callbacks{[this](Record&& r, bool ok) { records.emplace_back(std::move(r), ok); },
                                        [this](const StreamInfo& s) { streams.push_back(s); },
                                        [this](const DropoutInfo& g) { gaps.push_back(g); }, {},
                                        [this](const ChannelStatusChange& c) { statuses.push_back(c); }, {}});
  }
  void start(std::uint16_t id = 1, std::uint8_t channel_count = 2) {
    AcquisitionEvent e;
    e.kind = EventKind::stream_start;
    e.stream_id = id;
    e.sample_rate_hz = 1000;
    e.channel_count = channel_count;
    assembler->consume(e);
  }
  void edge(std::uint64_t index, double fraction = 0.25) {
    AcquisitionEvent e;
    e.kind = EventKind::tacho_edge;
    e.channel = 0;
    e.index = index;
    e.fraction = fraction;
    assembler->consume(e);
  }
  void life(std::uint64_t index, std::uint64_t revolutions) {
    AcquisitionEvent e;
    e.kind = EventKind::life_counter;
    e.index = index;
    e.life.revolutions = revolutions;
    assembler->consume(e);
  }
  void samples(int ch, std::uint64_t first, int n = 10) {
    AcquisitionEvent e;
    e.kind = EventKind::samples;
    e.channel = static_cast<std::uint8_t>(ch);
    e.index = first;
    e.count = static_cast<std::uint8_t>(n);
    for (int i = 0; i < n; ++i) e.samples[static_cast<std::size_t>(i)] = static_cast<std::int16_t>((first + static_cast<std::uint64_t>(i)) % 1000 + 1000 * ch);
    assembler->consume(e);
  }
  // Both channels, interleaved frame by frame as a front-end sends them, over [from, to).
  void run(std::uint64_t from, std::uint64_t to, int skip_channel = -1, std::uint64_t skip_from = 0, std::uint64_t skip_to = 0) {
    for (std::uint64_t i = from; i < to; i += 10)
      for (int ch = 0; ch < 2; ++ch)
        if (!(ch == skip_channel && i >= skip_from && i < skip_to)) samples(ch, i);
  }
  void gap_event(int ch, std::uint64_t index, std::uint64_t missing) {
    AcquisitionEvent e;
    e.kind = EventKind::dropout;
    e.channel = static_cast<std::uint8_t>(ch);
    e.index = index;
    e.missing = missing;
    assembler->consume(e);
  }
  static bool values_match(const Record& r) {
    for (std::size_t c = 0; c < r.channels.size(); ++c)
      for (std::size_t i = 0; i < r.channels[c].size(); ++i)
        if (r.channels[c][i] != static_cast<float>(((r.start_index + i) % 1000 + 1000 * c) * 0.5)) return false;
    return true;
  }
};

}  // namespace

TEST_CASE("assembler: back-to-back records hold exactly the samples of their window", "[assembler]") {
  Stream s;
  s.start();
  s.run(0, 5500);
  s.assembler->finish();
  REQUIRE(s.records.size() == 6);
  for (int k = 0; k < 5; ++k) {
    const auto& [r, ok] = s.records[static_cast<std::size_t>(k)];
    CHECK(ok);
    CHECK(r.start_index == static_cast<std::uint64_t>(1000 * k));
    CHECK(r.sample_count() == 1000);
    CHECK(r.end == RecordEnd::complete);
    CHECK(Stream::values_match(r));
  }
  CHECK(s.records[5].first.end == RecordEnd::stream_end);
  CHECK(s.records[5].first.sample_count() == 500);
  CHECK(s.records[5].second);  // 0.5 s >= min_length 0.2 s
  CHECK(s.assembler->counters().records_complete == 5);
  CHECK(s.assembler->counters().records_cut == 1);
}

TEST_CASE("assembler: records every interval, the time between them unused", "[assembler]") {
  Stream s(1.0, 2.5);
  s.start();
  s.run(0, 7000);
  s.assembler->finish();
  REQUIRE(s.records.size() == 3);
  CHECK(s.records[0].first.start_index == 0);
  CHECK(s.records[1].first.start_index == 2500);
  CHECK(s.records[2].first.start_index == 5000);
  for (const auto& [r, ok] : s.records) {
    CHECK(r.sample_count() == 1000);
    CHECK(Stream::values_match(r));
  }
}

TEST_CASE("assembler: a gap in one channel cuts the record, the schedule goes on", "[assembler]") {
  Stream s;
  s.start();
  // Channel 1 loses [1300, 1400): the decoder announces it, then samples resume.
  s.run(0, 1300);
  s.samples(0, 1300);
  s.gap_event(1, 1300, 100);
  s.run(1310, 4000, 1, 1300, 1400);
  s.assembler->finish();
  REQUIRE(s.records.size() == 4);
  const auto& cut = s.records[1];
  CHECK(cut.first.start_index == 1000);
  CHECK(cut.first.end == RecordEnd::cut_at_dropout);
  CHECK(cut.first.sample_count() == 300);  // both channels cut where channel 1 stopped
  CHECK(cut.second);                        // 0.3 s >= 0.2 s: analysed
  CHECK(Stream::values_match(cut.first));
  CHECK(s.records[2].first.start_index == 2000);
  CHECK(s.records[2].first.end == RecordEnd::complete);
  CHECK(s.records[3].first.start_index == 3000);
  REQUIRE(s.gaps.size() == 1);
  CHECK(s.gaps[0].cause == DropoutCause::protocol);
  CHECK(s.assembler->counters().ring_dropouts == 0);
}

TEST_CASE("assembler: a record cut shorter than min_length is kept but not analysable", "[assembler]") {
  Stream s;
  s.start();
  s.run(0, 1100);
  s.gap_event(0, 1100, 500);
  s.gap_event(1, 1100, 500);
  s.run(1600, 3000);
  s.assembler->finish();
  REQUIRE(s.records.size() == 3);
  CHECK(s.records[1].first.start_index == 1000);
  CHECK(s.records[1].first.sample_count() == 100);
  CHECK_FALSE(s.records[1].second);
  CHECK(s.assembler->counters().records_rejected == 1);
  CHECK(s.records[2].first.start_index == 2000);
}

TEST_CASE("assembler: a hole nobody announced is a ring-overflow gap", "[assembler]") {
  Stream s;
  s.start();
  s.run(0, 500);
  s.run(530, 1000);  // 500..529 vanished between decoder and assembler
  s.assembler->finish();
  REQUIRE(s.gaps.size() == 2);  // one per channel
  CHECK(s.gaps[0].cause == DropoutCause::ring_overflow);
  CHECK(s.gaps[0].first_missing == 500);
  CHECK(s.gaps[0].missing == 30);
  CHECK(s.assembler->counters().ring_dropout_samples == 60);
  REQUIRE(s.records.size() == 1);
  CHECK(s.records[0].first.end == RecordEnd::cut_at_dropout);
  CHECK(s.records[0].first.sample_count() == 500);
}

TEST_CASE("assembler: a channel silent for more than the slack is cut out, the other keeps its records", "[assembler]") {
  Stream s;
  s.start();
  s.run(0, 400);
  for (std::uint64_t i = 400; i < 3000; i += 10) s.samples(0, i);  // channel 1 dead from 400
  // Channel 1 is declared stopped when channel 0 is a second (the slack) past the first
  // record's end; every record is complete with channel 0 alone.
  REQUIRE(s.records.size() == 3);
  for (std::size_t k = 0; k < 3; ++k) {
    const auto& [r, ok] = s.records[k];
    CHECK(ok);
    CHECK(r.start_index == 1000 * k);
    CHECK(r.end == RecordEnd::complete);
    CHECK(r.sample_count() == 1000);
    CHECK(r.channel_numbers == std::vector<int>{0});
    CHECK(Stream::values_match(r));
  }
  REQUIRE(s.statuses.size() == 1);
  CHECK(s.statuses[0].channel == 1);
  CHECK(s.statuses[0].status == ChannelStatus::stopped);
  CHECK(s.statuses[0].index == 400);  // its first missing sample
  CHECK(s.assembler->counters().channels_stopped == 1);
}

TEST_CASE("assembler: a stopped channel rejoins at the record after its frames come back", "[assembler]") {
  Stream s;
  s.start();
  s.run(0, 400);
  s.run(400, 2500, 1, 400, 2500);  // channel 1 silent over [400, 2500)
  s.run(2500, 4000);
  s.assembler->finish();
  REQUIRE(s.records.size() == 4);
  CHECK(s.records[0].first.channel_numbers == std::vector<int>{0});
  CHECK(s.records[1].first.channel_numbers == std::vector<int>{0});
  CHECK(s.records[2].first.channel_numbers == std::vector<int>{0});  // back at 2500: not mid-record
  CHECK(s.records[3].first.channel_numbers == std::vector<int>{0, 1});
  for (const auto& [r, ok] : s.records) {
    CHECK(ok);
    CHECK(r.sample_count() == 1000);
    CHECK(Stream::values_match(r));
  }
  REQUIRE(s.statuses.size() == 2);
  CHECK(s.statuses[0].status == ChannelStatus::stopped);
  CHECK(s.statuses[1].status == ChannelStatus::resumed);
  CHECK(s.statuses[1].channel == 1);
  CHECK(s.statuses[1].index == 2500);
}

TEST_CASE("assembler: configured channels the stream header does not announce are left out", "[assembler]") {
  Stream s;
  s.start(1, 1);  // the header announces one channel: only channel 0 sends
  for (std::uint64_t i = 0; i < 3000; i += 10) s.samples(0, i);
  s.assembler->finish();
  REQUIRE(s.records.size() == 3);
  for (const auto& [r, ok] : s.records) {
    CHECK(ok);
    CHECK(r.end == RecordEnd::complete);
    CHECK(r.sample_count() == 1000);
    CHECK(r.channel_numbers == std::vector<int>{0});
    CHECK(Stream::values_match(r));
  }
  REQUIRE(s.statuses.size() == 1);
  CHECK(s.statuses[0].channel == 1);
  CHECK(s.statuses[0].status == ChannelStatus::missing_from_stream);
  // A later stream that carries both: both are in its records, and nothing more is reported.
  s.start(2, 2);
  s.run(0, 1000);
  REQUIRE(s.records.size() == 4);
  CHECK(s.records[3].first.channel_numbers == std::vector<int>{0, 1});
  CHECK(s.statuses.size() == 1);
}

TEST_CASE("assembler: a record rejected at a gap restarts right after it when a whole record fits", "[assembler]") {
  SECTION("fits before the next scheduled start") {
    Stream s(1.0, 10.0, 0.8);  // 1000-sample records every 10 000 samples, at least 800
    s.start();
    s.run(0, 300);
    s.gap_event(0, 300, 10);
    s.gap_event(1, 300, 10);
    s.run(310, 12000);
    s.assembler->finish();
    REQUIRE(s.records.size() >= 3);
    CHECK(s.records[0].first.start_index == 0);
    CHECK(s.records[0].first.sample_count() == 300);
    CHECK(s.records[0].first.end == RecordEnd::cut_at_dropout);
    CHECK_FALSE(s.records[0].second);
    CHECK(s.records[1].first.start_index == 310);  // right after the gap
    CHECK(s.records[1].first.sample_count() == 1000);
    CHECK(s.records[1].first.end == RecordEnd::complete);
    CHECK(s.records[1].second);
    CHECK(Stream::values_match(s.records[1].first));
    CHECK(s.records[2].first.start_index == 10000);  // the schedule is kept
    CHECK(s.assembler->counters().records_restarted_after_dropout == 1);
  }
  SECTION("does not fit: the schedule goes on") {
    Stream s(1.0, 1.2, 0.8);  // every 1200: 310 + 1000 > 1200
    s.start();
    s.run(0, 300);
    s.gap_event(0, 300, 10);
    s.gap_event(1, 300, 10);
    s.run(310, 3000);
    REQUIRE(s.records.size() >= 2);
    CHECK_FALSE(s.records[0].second);
    CHECK(s.records[1].first.start_index == 1200);
    CHECK(s.assembler->counters().records_restarted_after_dropout == 0);
  }
  SECTION("a gap in one channel only: the restart waits for its end") {
    Stream s(1.0, 10.0, 0.8);
    s.start();
    s.run(0, 300);
    s.gap_event(1, 300, 20);
    s.run(300, 2000, 1, 300, 320);
    REQUIRE(s.records.size() == 2);
    CHECK(s.records[0].first.sample_count() == 300);
    // Channel 1's gap ends at 320, but channel 0 had already handed samples up to 330 to the
    // rejected record when channel 1's next frame showed the gap: the restart is at 330.
    CHECK(s.records[1].first.start_index == 330);
    CHECK(s.records[1].first.sample_count() == 1000);
    CHECK(s.records[1].first.channel_numbers == std::vector<int>{0, 1});
    CHECK(Stream::values_match(s.records[1].first));
  }
}

TEST_CASE("assembler: cycles keep advancing across a stream change", "[assembler]") {
  Stream s;
  s.start(1);
  // 10 rev/s at 1 kHz: an edge every 100 samples (at 50, 150, ...); the odometer reads 5000 at
  // index 0 and 5025 at index 2500.
  for (std::uint64_t i = 0; i < 3000; i += 10) {
    if (i == 0) s.life(0, 5000);
    if (i == 2500) s.life(2500, 5025);
    if (i % 100 == 0) s.edge(i + 50, 0.0);
    s.samples(0, i);
    s.samples(1, i);
  }
  // The front-end restarts its stream: the clock starts again at 0 and no odometer frame
  // comes for the next three seconds (edges at 50, 150, ... go on).
  s.start(2);
  for (std::uint64_t i = 0; i < 3000; i += 10) {
    if (i % 100 == 0) s.edge(i + 50, 0.0);
    s.samples(0, i);
    s.samples(1, i);
  }
  REQUIRE(s.records.size() == 6);
  // Stream 1: 5000 + the edges before each record's start. Stream 2 continues from the
  // revolutions counted at its start (5025 + edges 2550..2950 = 5030), then +10 per second —
  // not frozen at 5030 because the last odometer frame's index (2500) is on the old clock.
  const double expected[] = {5000, 5010, 5020, 5030, 5040, 5050};
  for (std::size_t k = 0; k < 6; ++k) {
    INFO("record " << k);
    REQUIRE(s.records[k].first.input_revolutions);
    CHECK(*s.records[k].first.input_revolutions == Approx(expected[k]).margin(1e-9));
  }
}

TEST_CASE("assembler: a stream change ends the record in progress", "[assembler]") {
  Stream s;
  s.start(1);
  s.run(0, 1500);
  s.start(2);
  s.run(0, 1000);
  s.assembler->finish();
  REQUIRE(s.records.size() == 3);
  CHECK(s.records[1].first.end == RecordEnd::stream_end);
  CHECK(s.records[1].first.sample_count() == 500);
  CHECK(s.records[1].first.stream_id == 1);
  CHECK(s.records[2].first.stream_id == 2);
  REQUIRE(s.streams.size() == 2);
  CHECK(s.streams[1].sequence == 2);
}

TEST_CASE("assembler: tacho edges, condition and life counter travel with the record", "[assembler]") {
  Stream s;
  s.start();
  AcquisitionEvent c;
  c.kind = EventKind::condition;
  c.condition.torque_nm = 20;
  c.condition.speed_hz = 10;
  s.assembler->consume(c);
  AcquisitionEvent life;
  life.kind = EventKind::life_counter;
  life.index = 0;
  life.life.revolutions = 1000;
  s.assembler->consume(life);
  // 10 edges per second at 100.25 + 100 k
  for (std::uint64_t i = 0; i < 2000; i += 10) {
    if (i % 100 == 0) {
      AcquisitionEvent e;
      e.kind = EventKind::tacho_edge;
      e.channel = 0;
      e.index = i + 100;
      e.fraction = 0.25;
      s.assembler->consume(e);
    }
    s.samples(0, i);
    s.samples(1, i);
  }
  REQUIRE(s.records.size() >= 2);
  const Record& r1 = s.records[1].first;
  CHECK(r1.torque_nm == 20);
  CHECK(r1.speed_hz == 10);
  REQUIRE(r1.tacho_edges[0].size() == 10);
  CHECK(r1.tacho_edges[0][0] == Approx(0.25));   // 1000.25 relative to 1000
  CHECK(r1.tacho_edges[0][9] == Approx(900.25));
  REQUIRE(r1.input_revolutions);
  // 1000 at index 0, plus the edges at 100.25 ... 900.25 before sample 1000: 9 revolutions.
  CHECK(*r1.input_revolutions == 1009.0);
}

}  // namespace test_record_assembler
