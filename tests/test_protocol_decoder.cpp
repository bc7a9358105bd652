#include "gearwatch/acquisition/protocol_decoder.hpp"

#include <fstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "gearwatch/acquisition/candump_log.hpp"
#include "gearwatch/acquisition/protocol_encoder.hpp"

namespace test_protocol_decoder {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::acquisition;

namespace {

struct Harness {
  ProtocolIds ids;
  std::vector<AcquisitionEvent> events;
  ProtocolDecoder decoder{ids, 0b11, 0b1, [this](const AcquisitionEvent& e) { events.push_back(e); }};

  std::vector<std::int16_t> ramp(std::uint32_t first, int n) {
    std::vector<std::int16_t> s;
    for (int i = 0; i < n; ++i) s.push_back(static_cast<std::int16_t>((first + static_cast<std::uint32_t>(i)) % 30000));
    return s;
  }
  RejectReason samples(int channel, std::uint32_t first, int n = 30) {
    const auto s = ramp(first, n);
    return decoder.decode(make_vibration_frame(ids, channel, first, s, true));
  }
  void header(std::uint16_t stream = 1, std::uint32_t rate = 100000) {
    decoder.decode(make_stream_header(ids, rate, 2, stream));
  }
  std::size_t count(EventKind k) const {
    std::size_t n = 0;
    for (const auto& e : events) n += e.kind == k;
    return n;
  }
};

}  // namespace

TEST_CASE("decoder: samples are decoded with their index", "[decoder]") {
  Harness h;
  h.header();
  REQUIRE(h.count(EventKind::stream_start) == 1);
  CHECK(h.events[0].sample_rate_hz == 100000);
  CHECK(h.events[0].stream_id == 1);
  CHECK(h.events[0].channel_count == 2);
  CHECK_FALSE(h.samples(0, 0));
  CHECK_FALSE(h.samples(1, 0));
  CHECK_FALSE(h.samples(0, 30));
  REQUIRE(h.count(EventKind::samples) == 3);
  const auto& e = h.events.back();
  CHECK(e.channel == 0);
  CHECK(e.index == 30);
  CHECK(e.count == 30);
  CHECK(e.samples[0] == 30);
  CHECK(e.samples[29] == 59);
  CHECK(h.decoder.counters().samples == 90);
}

TEST_CASE("decoder: negative samples keep their sign (little-endian i16)", "[decoder]") {
  Harness h;
  h.header();
  std::vector<std::int16_t> s{-1, -32768, 32767, 0, 1234, -1234};
  REQUIRE_FALSE(h.decoder.decode(make_vibration_frame(h.ids, 0, 0, s, true)));
  const auto& e = h.events.back();
  REQUIRE(e.count == 6);
  for (int i = 0; i < 6; ++i) CHECK(e.samples[static_cast<std::size_t>(i)] == s[static_cast<std::size_t>(i)]);
}

TEST_CASE("decoder: a forward jump is a gap, counted and announced, never filled", "[decoder]") {
  Harness h;
  h.header();
  h.samples(0, 0);
  h.samples(0, 90);  // 30..89 missing
  REQUIRE(h.count(EventKind::dropout) == 1);
  const AcquisitionEvent* gap = nullptr;
  for (const auto& e : h.events)
    if (e.kind == EventKind::dropout) gap = &e;
  CHECK(gap->index == 30);
  CHECK(gap->missing == 60);
  CHECK(h.decoder.counters().dropouts == 1);
  CHECK(h.decoder.counters().dropout_samples == 60);
  CHECK(h.count(EventKind::samples) == 2);  // nothing invented
}

TEST_CASE("decoder: repeated and backward frames are dropped and counted", "[decoder]") {
  Harness h;
  h.header();
  h.samples(0, 0);
  h.samples(0, 30);
  auto repeat = h.samples(0, 30);
  auto backward = h.samples(0, 0);
  CHECK(repeat);
  CHECK(backward);
  CHECK(h.decoder.counters().duplicates == 2);
  CHECK(h.count(EventKind::samples) == 2);
  h.samples(0, 60);  // continues normally
  CHECK(h.decoder.counters().dropouts == 0);
}

TEST_CASE("decoder: malformed payloads are dropped with a reason", "[decoder]") {
  Harness h;
  h.header();
  CanFrame short_frame;
  short_frame.id = 0x100;
  short_frame.len = 3;
  CanFrame odd = short_frame;
  odd.len = 7;  // 4 + 3 sample bytes
  CanFrame tacho;
  tacho.id = 0x180;
  tacho.len = 6;
  CanFrame header;
  header.id = 0x1F0;
  header.len = 7;
  CanFrame life;
  life.id = 0x1F2;
  life.len = 4;
  for (const auto& f : {short_frame, odd, tacho, header, life}) CHECK(h.decoder.decode(f));
  CHECK(h.decoder.counters().malformed_frames == 5);
  CHECK(h.count(EventKind::samples) == 0);
}

TEST_CASE("decoder: unknown ids and unconfigured channels are counted, not errors", "[decoder]") {
  Harness h;
  h.header();
  CanFrame unknown;
  unknown.id = 0x555;
  unknown.len = 8;
  CHECK_FALSE(h.decoder.decode(unknown));
  CHECK(h.decoder.counters().unknown_ids == 1);
  CHECK_FALSE(h.samples(5, 0));  // channel 5 not in the mask 0b11
  CHECK(h.decoder.counters().unconfigured_channel_frames == 1);
  CanFrame ext = unknown;
  ext.id = 0x100;
  ext.extended = true;
  CHECK(h.decoder.decode(ext));
  CHECK(h.decoder.counters().unknown_ids == 2);
}

TEST_CASE("decoder: frames before the first stream header are dropped and counted", "[decoder]") {
  Harness h;
  h.samples(0, 0);
  h.decoder.decode(make_tacho_frame(h.ids, 0, 10.5));
  CHECK(h.decoder.counters().frames_before_header == 2);
  CHECK(h.events.empty());
}

TEST_CASE("decoder: a new stream id or sample rate starts a new stream, repeats do not", "[decoder]") {
  Harness h;
  h.header(1);
  h.samples(0, 0);
  h.header(1);  // the periodic repeat
  CHECK(h.count(EventKind::stream_start) == 1);
  h.header(2);
  CHECK(h.count(EventKind::stream_start) == 2);
  h.header(2, 50000);
  CHECK(h.count(EventKind::stream_start) == 3);
  CHECK(h.decoder.counters().stream_changes == 2);
  // The new stream's clock starts afresh: index 0 again is not a duplicate.
  CHECK_FALSE(h.samples(0, 0));
  CHECK(h.decoder.counters().duplicates == 0);
}

TEST_CASE("decoder: a header of another protocol version is refused", "[decoder]") {
  Harness h;
  CHECK(h.decoder.decode(make_stream_header(h.ids, 100000, 2, 1, 2)));
  CHECK(h.decoder.counters().unsupported_version == 1);
  CHECK_FALSE(h.decoder.in_stream());
}

TEST_CASE("decoder: u32 index wrap-around is continuous", "[decoder]") {
  Harness h;
  h.header();
  const std::uint32_t last = 0xFFFFFFFFu - 29;  // this frame covers ...FFE2..FFFF
  h.samples(0, last);
  h.samples(0, 0);  // wrapped
  CHECK(h.decoder.counters().dropouts == 0);
  CHECK(h.decoder.counters().duplicates == 0);
  CHECK(h.events.back().index == (std::uint64_t{1} << 32));
}

TEST_CASE("decoder: tacho edges carry their fraction and must increase", "[decoder]") {
  Harness h;
  h.header();
  CHECK_FALSE(h.decoder.decode(make_tacho_frame(h.ids, 0, 1234.5)));
  const auto& e = h.events.back();
  REQUIRE(e.kind == EventKind::tacho_edge);
  CHECK(e.index == 1234);
  CHECK(e.fraction == 0.5);  // 0x80000000 / 2^32 exactly
  CHECK(h.decoder.decode(make_tacho_frame(h.ids, 0, 1234.25)));
  CHECK(h.decoder.decode(make_tacho_frame(h.ids, 0, 1234.5)));
  CHECK(h.decoder.counters().tacho_out_of_order == 2);
  CHECK(h.decoder.counters().tacho_edges == 1);
  CanFrame other = make_tacho_frame(h.ids, 1, 10.0);  // shaft 1 not configured
  CHECK_FALSE(h.decoder.decode(other));
  CHECK(h.decoder.counters().unconfigured_channel_frames == 1);
}

TEST_CASE("decoder: operating condition and a life counter that goes backwards", "[decoder]") {
  Harness h;
  h.header();
  h.decoder.decode(make_operating_condition(h.ids, 20.0f, 10.0f, 500));
  const auto& c = h.events.back();
  REQUIRE(c.kind == EventKind::condition);
  CHECK(c.condition.torque_nm == 20.0f);
  CHECK(c.condition.speed_hz == 10.0f);
  CHECK(c.index == 500);
  CHECK_FALSE(h.decoder.decode(make_life_counter(h.ids, 1000000)));
  CHECK_FALSE(h.decoder.decode(make_life_counter(h.ids, 1000010)));
  CHECK(h.decoder.decode(make_life_counter(h.ids, 5)));
  CHECK(h.decoder.counters().life_counter_resets == 1);
  REQUIRE(h.count(EventKind::life_counter_reset) == 1);
  for (const auto& e : h.events)
    if (e.kind == EventKind::life_counter_reset) {
      CHECK(e.life.previous_revolutions == 1000010);
      CHECK(e.life.revolutions == 5);
    }
}

TEST_CASE("decoder: every rejection says its kind, kinds are distinct stored tokens", "[decoder]") {
  Harness h;
  h.header();
  auto kind_of = [&](const CanFrame& f) {
    const auto r = h.decoder.decode(f);
    REQUIRE(r);
    CHECK_FALSE(r->reason.empty());
    return r->kind;
  };
  CanFrame bad_samples;
  bad_samples.id = 0x100;
  bad_samples.len = 3;
  CHECK(kind_of(bad_samples) == RejectKind::malformed_frame);
  CanFrame bad_tacho;
  bad_tacho.id = 0x180;
  bad_tacho.len = 6;
  CHECK(kind_of(bad_tacho) == RejectKind::malformed_frame);
  CanFrame extended;
  extended.id = 0x100;
  extended.extended = true;
  CHECK(kind_of(extended) == RejectKind::unknown_frame);
  REQUIRE_FALSE(h.samples(0, 300));
  const auto dup = h.samples(0, 300);
  REQUIRE(dup);
  CHECK(dup->kind == RejectKind::duplicate_frame);
  REQUIRE_FALSE(h.decoder.decode(make_tacho_frame(h.ids, 0, 500.5)));
  CHECK(kind_of(make_tacho_frame(h.ids, 0, 400.0)) == RejectKind::tacho_out_of_order);
  REQUIRE_FALSE(h.decoder.decode(make_life_counter(h.ids, 1000)));
  CHECK(kind_of(make_life_counter(h.ids, 10)) == RejectKind::life_counter_reset);
  CHECK(kind_of(make_stream_header(h.ids, 100000, 2, 1, 2)) == RejectKind::unsupported_version);

  std::vector<std::string> tokens;
  for (auto k : kAllRejectKinds) tokens.emplace_back(to_string(k));
  CHECK(tokens == std::vector<std::string>{"malformed_frame", "unknown_frame", "duplicate_frame", "tacho_out_of_order",
                                           "life_counter_reset", "unsupported_version", "malformed_line"});
}

TEST_CASE("decoder: after a stream change, frames placed at 'the latest index' belong to the new stream",
          "[decoder]") {
  Harness h;
  h.header(1);
  for (std::uint32_t i = 0; i < 400000; i += 30000) REQUIRE_FALSE(h.samples(0, i));
  REQUIRE_FALSE(h.decoder.decode(make_life_counter(h.ids, 5000)));
  CHECK(h.events.back().index == 390029);  // the latest sample index of stream 1
  // Stream 7 restarts its clock at 0; its first life-counter frame comes before its samples.
  h.header(7);
  REQUIRE_FALSE(h.decoder.decode(make_life_counter(h.ids, 5040)));
  REQUIRE(h.events.back().kind == EventKind::life_counter);
  CHECK(h.events.back().index == 0);  // the new stream's start, not index 390029 of the old one
  REQUIRE_FALSE(h.samples(0, 0));
  REQUIRE_FALSE(h.samples(0, 30));
  REQUIRE_FALSE(h.decoder.decode(make_life_counter(h.ids, 5041)));
  CHECK(h.events.back().index == 59);
}

namespace {

// The frames of docs/can-protocol.md's "Worked examples" section: its indented candump lines,
// read from the page itself so the page and this test cannot drift apart.
std::vector<CanFrame> worked_example_frames() {
  std::ifstream page(std::string(GEARWATCH_SOURCE_DIR) + "/docs/can-protocol.md");
  REQUIRE(page);
  std::vector<CanFrame> frames;
  bool in_section = false;
  for (std::string line; std::getline(page, line);) {
    if (line.rfind("## ", 0) == 0) in_section = line == "## Worked examples";
    if (!in_section || line.rfind("    (", 0) != 0) continue;
    std::string reason;
    const auto parsed = parse_candump_line(line.substr(4), reason);
    INFO(line << ": " << reason);
    REQUIRE(parsed);
    frames.push_back(parsed->frame);
  }
  return frames;
}

}  // namespace

TEST_CASE("can protocol document: the worked examples decode as the page says", "[decoder]") {
  const auto frames = worked_example_frames();
  REQUIRE(frames.size() == 7);
  Harness h;
  for (const auto& f : frames) REQUIRE_FALSE(h.decoder.decode(f));
  REQUIRE(h.events.size() == 7);

  const auto& header = h.events[0];  // 1. stream header
  REQUIRE(header.kind == EventKind::stream_start);
  CHECK(header.sample_rate_hz == 100000);
  CHECK(header.channel_count == 2);
  CHECK(header.stream_id == 7);

  const auto& fd = h.events[1];  // 2. channel 0, CAN FD, 64 bytes
  REQUIRE(fd.kind == EventKind::samples);
  CHECK(frames[1].fd);
  CHECK(frames[1].len == 64);
  CHECK(fd.channel == 0);
  CHECK(fd.index == 1000);
  REQUIRE(fd.count == 30);
  CHECK(fd.samples[0] == 100);
  CHECK(fd.samples[1] == -2);
  CHECK(fd.samples[2] == 1234);
  CHECK(fd.samples[3] == -32768);
  CHECK(fd.samples[4] == 32767);
  for (int k = 5; k < 30; ++k) CHECK(fd.samples[static_cast<std::size_t>(k)] == 0);
  // The page's m/s² at the example config's scale of 0.01 m/s² per LSB.
  CHECK(fd.samples[2] * 0.01 == Approx(12.34));
  CHECK(fd.samples[3] * 0.01 == Approx(-327.68));

  const auto& classic = h.events[2];  // 3. channel 1, classic, 8 bytes
  REQUIRE(classic.kind == EventKind::samples);
  CHECK_FALSE(frames[2].fd);
  CHECK(classic.channel == 1);
  CHECK(classic.index == 1000);
  REQUIRE(classic.count == 2);
  CHECK(classic.samples[0] == 100);
  CHECK(classic.samples[1] == -2);

  const auto& edge = h.events[3];  // 4. tacho edge, shaft 0
  REQUIRE(edge.kind == EventKind::tacho_edge);
  CHECK(edge.channel == 0);
  CHECK(edge.index == 1003);
  CHECK(edge.fraction == 0.25);
  CHECK((static_cast<double>(edge.index) + edge.fraction) / 100000.0 == Approx(0.0100325));

  const auto& condition_fd = h.events[4];  // 5. operating condition with its index
  REQUIRE(condition_fd.kind == EventKind::condition);
  CHECK(frames[4].len == 12);
  CHECK(condition_fd.condition.torque_nm == 20.0f);
  CHECK(condition_fd.condition.speed_hz == 10.0f);
  CHECK(condition_fd.index == 1000);

  const auto& condition_classic = h.events[5];  // 6. without an index: the newest one received
  REQUIRE(condition_classic.kind == EventKind::condition);
  CHECK(frames[5].len == 8);
  CHECK(condition_classic.condition.torque_nm == 4.0f);
  CHECK(condition_classic.condition.speed_hz == 10.0f);
  CHECK(condition_classic.index == 1029);

  const auto& life = h.events[6];  // 7. life counter
  REQUIRE(life.kind == EventKind::life_counter);
  CHECK(life.life.revolutions == 5000000000ull);
  CHECK(life.index == 1029);

  // Example 2 says the channel's next frame is expected at 1030: one there is neither gap nor repeat.
  REQUIRE_FALSE(h.samples(0, 1030));
  CHECK(h.decoder.counters().dropouts == 0);
  CHECK(h.decoder.counters().duplicates == 0);
  CHECK(h.decoder.counters().malformed_frames == 0);
}

}  // namespace test_protocol_decoder
