#include "gearwatch/types/gear_pair_boundary.hpp"

#include <algorithm>

namespace gearwatch {

const char* to_string(PairBoundary boundary) noexcept {
  switch (boundary) {
    case PairBoundary::none: return "none";
    case PairBoundary::life_counter_reset: return "life_counter_reset";
    case PairBoundary::count_went_backwards: return "count_went_backwards";
  }
  return "unknown";
}

PairBoundary pair_boundary(const PairStep& step) {
  if (step.reset_recorded) return PairBoundary::life_counter_reset;
  if (step.previous_count && step.count && *step.count < *step.previous_count) return PairBoundary::count_went_backwards;
  return PairBoundary::none;
}

GearPairHistory decide_gear_pairs(const std::vector<PairRecord>& records, std::vector<StreamPosition> resets) {
  std::sort(resets.begin(), resets.end());
  GearPairHistory h;
  auto next_reset = resets.cbegin();
  std::optional<double> previous;
  for (const PairRecord& r : records) {
    // Every reset seen at or before this record's first sample and not yet given to an earlier one is this record's.
    const auto after = std::upper_bound(next_reset, resets.cend(), r.start);
    const bool reset = after != next_reset;
    next_reset = after;
    const PairBoundary b = pair_boundary({previous, r.count, reset});
    // The history's first record begins pair 0 unless a reset came before it (an unrecorded pair before).
    if (b != PairBoundary::none) {
      ++h.current_pair;
      h.current_pair_first = h.boundaries.size();
    }
    if (r.count) previous = r.count;
    h.boundaries.push_back(b);
    h.pair_of_record.push_back(h.current_pair);
  }
  if (next_reset != resets.cend()) {  // a reset after the newest record: the installed pair has no records yet
    ++h.current_pair;
    h.current_pair_first = records.size();
  }
  return h;
}

}  // namespace gearwatch
