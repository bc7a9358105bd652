#pragma once
// Inspections staff enter (`gearwatch inspect`): where the installed gear pair stands in the
// stored history, and the inspection row itself. The model reads them back at every record.
#include <cstdint>
#include <optional>
#include <string>

#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::storage {

/// The gear pair now installed and the life positions an inspection is checked against.
struct GearPairPosition {
  std::int64_t gear_pair = 0;         ///< life-counter resets so far (0: the first pair)
  double reset_at_cycles = 0;         ///< revolutions at the last reset (0 without one)
  double newest_record_cycles = 0;    ///< revolutions of the newest record that has them (0 without one)
};
GearPairPosition load_gear_pair_position(Database& db);

struct NewInspection {
  double cycles = 0;
  std::optional<double> pitted_area_fraction, wear_depth_m;
  std::string note;                   ///< "" is stored as NULL
  std::int64_t gear_pair = 0;
};
/// Stores one inspection; returns its id.
std::int64_t insert_inspection(Database& db, const NewInspection& inspection);

}  // namespace gearwatch::storage
