#include "gearwatch/acquisition/spsc_ring.hpp"

#include <cstdint>
#include <thread>

#include <catch2/catch.hpp>

namespace test_spsc_ring {  // this file's own: the test files compile together (unity build)

using gearwatch::acquisition::SpscRing;

TEST_CASE("ring: capacity is a power of two and overflow is counted, never silent", "[ring]") {
  SpscRing<std::uint64_t> ring(5);
  CHECK(ring.capacity() == 8);
  for (std::uint64_t i = 0; i < 8; ++i) CHECK(ring.try_push(i));
  CHECK_FALSE(ring.try_push(99));
  CHECK_FALSE(ring.try_push(100));
  CHECK(ring.overflows() == 2);
  CHECK(ring.size() == 8);
  std::uint64_t v = 0;
  for (std::uint64_t i = 0; i < 8; ++i) {
    REQUIRE(ring.try_pop(v));
    CHECK(v == i);  // FIFO; the refused items never appear
  }
  CHECK_FALSE(ring.try_pop(v));
  CHECK(ring.high_water() == 8);
  CHECK_THROWS_AS(SpscRing<int>(1), std::invalid_argument);
}

TEST_CASE("ring: two threads pass ten million items in order without loss", "[ring]") {
  SpscRing<std::uint64_t> ring(1024);
  constexpr std::uint64_t kItems = 10'000'000;
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kItems; ++i)
      while (!ring.try_push(i)) std::this_thread::yield();
  });
  std::uint64_t expected = 0, sum = 0, v = 0;
  bool in_order = true;
  while (expected < kItems) {
    if (ring.try_pop(v)) {
      in_order = in_order && v == expected;
      sum += v;
      ++expected;
    }
  }
  producer.join();
  CHECK(in_order);
  CHECK(sum == kItems * (kItems - 1) / 2);
}

TEST_CASE("ring: the high-water mark is the real fill, not the number of pushes", "[ring]") {
  SpscRing<int> ring(1024);
  int v = 0;
  for (int i = 0; i < 10000; ++i) {
    REQUIRE(ring.try_push(i));
    if (i % 3 == 2)  // the consumer keeps the fill at 1..3 items
      while (ring.try_pop(v)) {
      }
  }
  CHECK(ring.high_water() == 3);
}

}  // namespace test_spsc_ring
