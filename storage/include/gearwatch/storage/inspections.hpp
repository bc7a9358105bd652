#pragma once
// Inspections staff enter (`gearwatch inspect`): where the installed gear pair stands in the
// stored history, and the inspection row itself. The model reads them back at every record.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

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
  std::optional<double> wear_depth_max_m;        ///< the deepest flank point
  std::optional<double> wear_depth_relative_sd;  ///< the depths' relative SD (none: the configured one)
};
/// An inspection as stored (table inspections).
struct StoredInspection {
  std::int64_t id = 0;
  std::string entered_at;
  double cycles = 0;
  std::optional<double> pitted_area_fraction, wear_depth_m;
  std::string note;                   ///< "" when none was stored
  std::int64_t gear_pair = 0;         ///< NULL (a row from before gear pairs were stored) reads as 0
  std::optional<double> wear_depth_max_m, wear_depth_relative_sd;  ///< none before schema 17
};
/// Every inspection, by cycles (then id). Empty when the database has no inspections table.
std::vector<StoredInspection> load_inspections(Database& db);
/// The inspections of one gear pair, by id (the order staff entered them).
std::vector<StoredInspection> load_gear_pair_inspections(Database& db, std::int64_t gear_pair);

/// Stores one inspection; returns its id.
std::int64_t insert_inspection(Database& db, const NewInspection& inspection);

}  // namespace gearwatch::storage
