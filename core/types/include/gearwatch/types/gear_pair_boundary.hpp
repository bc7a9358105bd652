#pragma once
// Which gear pair (the set of gears installed since the last replacement) a record belongs to:
// the one rule the processing history, the model thread and the report all follow
// (docs/storage.md, "Which gear pair a record belongs to").
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace gearwatch {

/// Why a record begins a new gear pair.
enum class PairBoundary {
  none,                  ///< it continues the pair of the record before it
  life_counter_reset,    ///< a life-counter reset was recorded since the record before it (with or without the count going back)
  count_went_backwards,  ///< no reset was recorded, but its life-counter count is below the previous count
};
/// The words for logs and notes: none, life_counter_reset, count_went_backwards.
const char* to_string(PairBoundary boundary) noexcept;

/// One step of the rule: a record and what came before it.
struct PairStep {
  std::optional<double> previous_count;  ///< life-counter count of the pair's previous record with one (none yet: absent)
  std::optional<double> count;           ///< this record's count (absent: it has none)
  bool reset_recorded = false;           ///< a life-counter reset was recorded after the previous record, at or before this one
};

/// The rule. A recorded reset is authoritative: the record after it begins a new pair, whatever its
/// count. Without one, a count below the previous count also begins a new pair (the counter was
/// reset while nothing recorded it: the daemon was off, or the records came from another
/// recording); an equal count does not. A record without a count begins a pair only by a reset.
PairBoundary pair_boundary(const PairStep& step);

/// Where in the acquired data something happened: the stream (storage order) and the sample index in it.
struct StreamPosition {
  std::int64_t stream = 0;  ///< the stream's storage key (streams are stored in the order they came)
  std::int64_t index = 0;   ///< sample index in the stream
  friend bool operator<(const StreamPosition& a, const StreamPosition& b) {
    return a.stream != b.stream ? a.stream < b.stream : a.index < b.index;
  }
};

/// A stored record as the rule sees it.
struct PairRecord {
  std::optional<double> count;  ///< its life-counter count (input revolutions) at its first sample
  StreamPosition start;         ///< its first sample
};

/// The rule over a stored history, records in storage order. `resets` are where the recorded
/// resets were seen: a reset belongs to the first record starting at or after it (a record the
/// reset fell inside started on the old pair's count).
struct GearPairHistory {
  std::vector<PairBoundary> boundaries;     ///< per record: why it begins a pair (none: it continues one)
  std::vector<std::size_t> pair_of_record;  ///< per record: its pair, 0 for the history's first
  std::size_t current_pair = 0;             ///< the pair installed now (past the last record's when a reset follows it)
  std::size_t current_pair_first = 0;       ///< index of the current pair's first record (records.size(): none yet)
};
GearPairHistory decide_gear_pairs(const std::vector<PairRecord>& records, std::vector<StreamPosition> resets);

}  // namespace gearwatch
