#include "gearwatch/types/gear_pair_boundary.hpp"

#include <catch2/catch.hpp>

#include <optional>
#include <string>
#include <vector>

namespace test_gear_pair_boundary {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using B = PairBoundary;
using Pairs = std::vector<std::size_t>;

// Records of 1000 samples each, back to back in stream 1 from sample 0, with the given counts.
std::vector<PairRecord> pair_test_records(const std::vector<std::optional<double>>& counts) {
  std::vector<PairRecord> out;
  for (std::size_t i = 0; i < counts.size(); ++i) out.push_back({counts[i], {1, static_cast<std::int64_t>(i) * 1000}});
  return out;
}

TEST_CASE("gear pair rule: a recorded reset begins a pair at the next record even when the count does not go back", "[gear_pair]") {
  // A reset inside record 1 (samples 1000-1999): record 1 started on the old pair's count, record 2 is the new pair's.
  const auto h = decide_gear_pairs(pair_test_records({100, 200, 400, 500}), {{1, 1500}});
  CHECK(h.boundaries == std::vector<B>{B::none, B::none, B::life_counter_reset, B::none});
  CHECK(h.pair_of_record == Pairs{0, 0, 1, 1});
  CHECK(h.current_pair == 1);
  CHECK(h.current_pair_first == 2);
}

TEST_CASE("gear pair rule: a count going backwards without a recorded reset begins a pair", "[gear_pair]") {
  // Record 2 has no count: record 3 is compared with record 1's; an equal count continues the pair.
  const auto h = decide_gear_pairs(pair_test_records({100, 200, std::nullopt, 50, 50, 80}), {});
  CHECK(h.boundaries == std::vector<B>{B::none, B::none, B::none, B::count_went_backwards, B::none, B::none});
  CHECK(h.pair_of_record == Pairs{0, 0, 0, 1, 1, 1});
  CHECK(h.current_pair == 1);
  CHECK(h.current_pair_first == 3);
}

TEST_CASE("gear pair rule: a reset with the count going backwards is one boundary and a reset after the newest record a pair without records",
          "[gear_pair]") {
  // The usual replacement: the reset at sample 1800 and record 2's count 10 below record 1's 200.
  // Two resets before record 4 (the second in a later stream) are one boundary; record 5 going back begins
  // pair 3 and a reset after it pair 4.
  auto records = pair_test_records({100, 200, 10, 20, 30});
  records[4].start = {2, 0};
  records.push_back({5, {2, 1000}});
  const auto h = decide_gear_pairs(records, {{2, 1500}, {1, 1800}, {1, 3500}, {2, 0}});
  CHECK(h.boundaries == std::vector<B>{B::none, B::none, B::life_counter_reset, B::none, B::life_counter_reset, B::count_went_backwards});
  CHECK(h.pair_of_record == Pairs{0, 0, 1, 1, 2, 3});
  CHECK(h.current_pair == 4);
  CHECK(h.current_pair_first == 6);
}

TEST_CASE("gear pair rule: neither a reset nor a count going back is one pair, and a reset before the first record begins pair 1",
          "[gear_pair]") {
  const auto h = decide_gear_pairs(pair_test_records({100, 100, std::nullopt, 150}), {});
  CHECK(h.boundaries == std::vector<B>{B::none, B::none, B::none, B::none});
  CHECK(h.pair_of_record == Pairs{0, 0, 0, 0});
  CHECK(h.current_pair == 0);
  CHECK(h.current_pair_first == 0);
  CHECK(decide_gear_pairs({}, {}).current_pair == 0);

  const auto before = decide_gear_pairs(pair_test_records({std::nullopt, 900}), {{0, 5}});
  CHECK(before.boundaries == std::vector<B>{B::life_counter_reset, B::none});
  CHECK(before.pair_of_record == Pairs{1, 1});
  CHECK(before.current_pair_first == 0);
}

TEST_CASE("gear pair rule: one step", "[gear_pair]") {
  CHECK(pair_boundary({100.0, 99.0, false}) == B::count_went_backwards);
  CHECK(pair_boundary({100.0, 100.0, false}) == B::none);
  CHECK(pair_boundary({std::nullopt, 5.0, false}) == B::none);
  CHECK(pair_boundary({100.0, std::nullopt, false}) == B::none);
  CHECK(pair_boundary({100.0, std::nullopt, true}) == B::life_counter_reset);
  CHECK(pair_boundary({100.0, 150.0, true}) == B::life_counter_reset);
  CHECK(pair_boundary({100.0, 10.0, true}) == B::life_counter_reset);
  CHECK(std::string(to_string(B::count_went_backwards)) == "count_went_backwards");
}

}  // namespace test_gear_pair_boundary
