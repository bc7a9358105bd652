#include "gearwatch/acquisition/candump_log.hpp"

#include <random>
#include <string>

#include <catch2/catch.hpp>

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
