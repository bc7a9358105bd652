#pragma once
// Typed readers of what the processing thread needs back at start-up (docs/storage.md): the
// current gear pair's ICS2 history per channel (for the wear-mechanism verdict) and its indicator
// values (for the alert baselines), and what decides the gear pair (gearwatch/types/gear_pair_boundary.hpp).
// "The current gear pair" is every record from the current pair's first, by that rule.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/types/gear_pair_boundary.hpp"

namespace gearwatch::storage {

/// What the gear-pair rule reads: every stored record (storage order) and every recorded
/// life-counter reset, each where it was in the acquired data.
struct GearPairInputs {
  std::vector<std::int64_t> record_ids;  ///< ids of `records`, in the same order
  std::vector<PairRecord> records;
  std::vector<StreamPosition> resets;
};
GearPairInputs load_gear_pair_inputs(Database& db);
/// The installed gear pair by decide_gear_pairs over the stored history: how many pairs began
/// before it, and the id of its first record (past the newest record when a reset follows it: the
/// installed pair has no records yet).
struct CurrentGearPair {
  std::size_t pairs_before = 0;
  std::int64_t first_record_id = 0;
};
CurrentGearPair current_gear_pair(Database& db);
/// current_gear_pair(db).first_record_id.
std::int64_t current_gear_pair_first_record(Database& db);

/// One analysed record's ICS2 bands on one channel.
struct StoredIcs2Point {
  std::int64_t channel = 0;
  double cycles = 0;                        ///< input revolutions of the record
  std::optional<double> low_band;           ///< ics2_low_band (NULL: not computed)
  std::optional<double> high_band;          ///< ics2_high_band
  std::optional<double> selected_centre_hz; ///< the ICS2 band selection's centre
  std::optional<double> selected_value;     ///< ... and its value
};
/// The ICS2 points of the current gear pair's records that have a life position, by record.
std::vector<StoredIcs2Point> load_gear_pair_ics2_history(Database& db);

/// One indicator value of one analysed record and channel.
struct StoredIndicatorValue {
  std::int64_t record_id = 0;
  std::int64_t channel = 0;
  std::string name;
  double value = 0;
};
/// Every non-NULL indicator value of the current gear pair's analysed records, by record.
std::vector<StoredIndicatorValue> load_gear_pair_indicator_values(Database& db);

}  // namespace gearwatch::storage
