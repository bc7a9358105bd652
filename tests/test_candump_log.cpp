#include "gearwatch/acquisition/candump_log.hpp"

#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <catch2/catch.hpp>

#include "gearwatch/acquisition/candump_source.hpp"
#include "temp_dir.hpp"

namespace test_candump_log {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::acquisition;

TEST_CASE("candump: a classic line as can-utils writes it", "[candump]") {
  // Line format from can-utils' log.c (candump -L): "(%010ld.%06ld) %s %03X#%02X..."
  std::string reason;
  auto line = parse_candump_line("(1436509052.249713) vcan0 044#2A366C2BBA", reason);
  REQUIRE(line);
  CHECK(reason.empty());
  CHECK(line->interface == "vcan0");
  CHECK(line->frame.id == 0x044);
  CHECK_FALSE(line->frame.fd);
  REQUIRE(line->frame.len == 5);
  CHECK(line->frame.data[0] == 0x2A);
  CHECK(line->frame.data[4] == 0xBA);
  CHECK(line->frame.timestamp_s == Approx(1436509052.249713).epsilon(1e-15));
}

TEST_CASE("candump: FD, remote and extended frames", "[candump]") {
  std::string reason;
  std::string fd_line = "(0000000001.000000) can0 100##1";
  for (int i = 0; i < 64; ++i) fd_line += "A5";
  auto fd = parse_candump_line(fd_line, reason);
  REQUIRE(fd);
  CHECK(fd->frame.fd);
  CHECK(fd->frame.fd_flags == 1);
  CHECK(fd->frame.len == 64);
  CHECK(fd->frame.data[63] == 0xA5);

  auto rtr = parse_candump_line("(1.0) can0 123#R", reason);
  REQUIRE(rtr);
  CHECK(rtr->frame.remote);
  CHECK(rtr->frame.len == 0);

  auto ext = parse_candump_line("(1.0) can0 12345678#00", reason);
  REQUIRE(ext);
  CHECK(ext->frame.extended);
  CHECK(ext->frame.id == 0x12345678u);

  auto empty = parse_candump_line("(1.0) can0 100#", reason);
  REQUIRE(empty);
  CHECK(empty->frame.len == 0);
}

TEST_CASE("candump: every kind of bad line gives a reason and no frame", "[candump]") {
  const char* bad[] = {
      "garbage",                                  // no timestamp
      "(1.0 can0 100#00",                         // unclosed timestamp
      "(abc) can0 100#00",                        // bad timestamp
      "(1.0) can0",                               // no frame
      "(1.0) can0 100#0",                         // odd hex digits (a truncated line)
      "(1.0) can0 100#0G",                        // non-hex
      "(1.0) can0 100#000102030405060708",        // 9 bytes classic
      "(1.0) can0 800#00",                        // standard id above 0x7FF
      "(1.0) can0 1000#00",                       // 4-digit id
      "(1.0) can0 100##1000102030405060708",      // FD length 9 is not a valid FD length
      "(1.0) can0 100##",                         // FD without flags
      "(1.0) can0 #00",                           // no id
  };
  for (const char* text : bad) {
    std::string reason;
    INFO(text);
    CHECK_FALSE(parse_candump_line(text, reason));
    CHECK_FALSE(reason.empty());
  }
  std::string reason;
  CHECK_FALSE(parse_candump_line("", reason));
  CHECK(reason.empty());  // blank lines and comments are not errors
  CHECK_FALSE(parse_candump_line("# comment", reason));
  CHECK(reason.empty());
}

TEST_CASE("candump: format then parse gives the same frame", "[candump]") {
  std::mt19937 rng(7);
  std::string text, reason;
  const unsigned fd_lengths[] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64};
  for (int trial = 0; trial < 500; ++trial) {
    CanFrame f;
    f.fd = trial % 2 == 0;
    f.id = rng() % 0x800;
    f.len = static_cast<std::uint8_t>(f.fd ? fd_lengths[rng() % 16] : rng() % 9);
    f.fd_flags = f.fd ? static_cast<std::uint8_t>(rng() % 4) : 0;
    f.timestamp_s = 1700000000.0 + (rng() % 1000000) * 1e-6;
    for (unsigned i = 0; i < f.len; ++i) f.data[i] = static_cast<std::uint8_t>(rng());
    format_candump_line(f, "can0", text);
    auto back = parse_candump_line(text, reason);
    INFO(text);
    REQUIRE(back);
    CHECK(back->frame.id == f.id);
    CHECK(back->frame.len == f.len);
    CHECK(back->frame.fd == f.fd);
    CHECK(back->frame.fd_flags == f.fd_flags);
    CHECK(back->frame.timestamp_s == Approx(f.timestamp_s).margin(1e-6));
    for (unsigned i = 0; i < f.len; ++i) CHECK(back->frame.data[i] == f.data[i]);
  }
}

// Found by fuzz/fuzz_candump_log (fuzz/corpus/fuzz_candump_log/remote_extended_error.txt): a remote
// frame's length was dropped when the frame was formatted, so "123#R5" came back as "123#R", a
// remote frame of length 0. can-utils writes the DLC after the 'R' (lib.c, sprint_canframe).
TEST_CASE("candump: a remote frame's length survives formatting", "[candump][fuzz]") {
  std::string reason, text;
  const auto rtr = parse_candump_line("(0000000002.500001) can0 123#R5", reason);
  REQUIRE(rtr);
  CHECK(rtr->frame.remote);
  CHECK(rtr->frame.len == 5);
  format_candump_line(rtr->frame, "can0", text);
  CHECK(text == "(0000000002.500001) can0 123#R5");
  const auto back = parse_candump_line(text, reason);
  REQUIRE(back);
  CHECK(back->frame.remote);
  CHECK(back->frame.len == 5);
  // length 0 keeps the bare 'R'
  format_candump_line(parse_candump_line("(1.0) can0 123#R", reason)->frame, "can0", text);
  CHECK(text == "(0000000001.000000) can0 123#R");
}

// Found by fuzz/fuzz_candump_log under UBSan: from_chars took "1436509052000000000002.5" (and would
// take inf, nan, -1, 1e300) as a timestamp; formatting that frame again (a rejected frame is stored
// as its candump line) converted 1.4e21 to long long, which is undefined. The fuzzer's input:
TEST_CASE("candump: timestamps that are not times are rejected", "[candump][fuzz]") {
  const char* bad[] = {
      "(1436509052000000000002.500000) can0 123#R00002.500000) can0 12(0) can0 n0 20000080",
      "(inf) can0 100#00",
      "(nan) can0 100#00",
      "(-1.000000) can0 100#00",
      "(1e300) can0 100#00",
      "(1000000000000.000000) can0 100#00",
  };
  for (const char* text : bad) {
    std::string reason;
    INFO(text);
    CHECK_FALSE(parse_candump_line(text, reason));
    CHECK(reason == "timestamp out of range (0 to 1e12 s)");
  }
  std::string reason;
  const auto edge = parse_candump_line("(999999999999.500000) can0 100#00", reason);  // exact in a double
  REQUIRE(edge);
  CHECK(edge->frame.timestamp_s == 999999999999.5);
}

// The same fuzzer input showed "123#R00002.5" read as a remote frame of length 0, the rest ignored.
TEST_CASE("candump: a remote frame with characters after its length is rejected", "[candump][fuzz]") {
  std::string reason;
  CHECK_FALSE(parse_candump_line("(0000000002.500000) can0 123#R00002.500000", reason));
  CHECK(reason == "bad remote-frame length");
  CHECK_FALSE(parse_candump_line("(1.0) can0 123#R55", reason));
  CHECK(reason == "bad remote-frame length");
}

TEST_CASE("candump source: it ends finished at the log's end and stopped after stop()", "[candump]") {
  const gearwatch::testing::TempDir dir("candump-end");
  const auto path = (dir / "a.log").string();
  {
    std::ofstream f(path);
    for (int i = 0; i < 10; ++i) f << "(1436509052.2497" << 10 + i << ") vcan0 044#2A366C2BBA\n";
  }
  struct Run {
    std::size_t frames = 0;
    std::vector<SourceEnd> ends;
  };
  auto run = [&](std::size_t lines_per_chunk, bool stop_at_first_frame) {
    boost::asio::io_context io;
    CandumpFileSource source(io, path, {}, lines_per_chunk);
    Run r;
    source.start(
        [&](const CanFrame&) {
          if (r.frames++ == 0 && stop_at_first_frame) source.stop();
        },
        [&](const SourceEnd& end) { r.ends.push_back(end); });
    io.run();
    return r;
  };
  const Run whole = run(4, false);
  CHECK(whole.frames == 10);
  REQUIRE(whole.ends.size() == 1);
  CHECK(whole.ends[0].kind == SourceEndKind::finished);
  CHECK(whole.ends[0].error.empty());
  // Stopped by the first frame's handler: no frame after it, and the end says stopped.
  const Run stopped = run(4, true);
  CHECK(stopped.frames == 1);
  REQUIRE(stopped.ends.size() == 1);
  CHECK(stopped.ends[0].kind == SourceEndKind::stopped);
  CHECK(stopped.ends[0].error.empty());
}

}  // namespace test_candump_log
