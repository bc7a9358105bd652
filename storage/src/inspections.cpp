#include "gearwatch/storage/inspections.hpp"

#include <algorithm>

#include "model_run_columns.hpp"
#include "stored_rows.hpp"
#include "stored_tokens.hpp"

namespace gearwatch::storage {
namespace {

// gear_pair and the deepest point came with later schemas: an older database's inspections all
// belong to the first pair and have no deepest point.
std::string inspection_select(Database& db) {
  const char* pair = detail::has_column(db, "inspections", "gear_pair") ? "coalesce(gear_pair, 0)" : "0";
  const char* deepest = detail::has_column(db, "inspections", GW_COL_INSPECTION_DEPTH_MAX) ? GW_INSPECTION_DEEPEST_COLUMNS : "NULL, NULL";
  return std::string("SELECT id, entered_at, cycles, pitted_area_fraction, wear_depth_m, note, ") + pair + ", " + deepest +
         " FROM inspections";
}

std::vector<StoredInspection> read_inspections(Statement& s) {
  std::vector<StoredInspection> out;
  while (s.step())
    out.push_back({s.get_int(0), s.get_text(1), s.get_double(2), detail::optional_double(s, 3), detail::optional_double(s, 4),
                   detail::text_or_empty(s, 5), s.get_int(6), detail::optional_double(s, 7), detail::optional_double(s, 8)});
  return out;
}

}  // namespace

std::vector<StoredInspection> load_inspections(Database& db) {
  if (!detail::has_object(db, "inspections")) return {};
  Statement s(db, inspection_select(db) + " ORDER BY cycles, id");
  return read_inspections(s);
}

std::vector<StoredInspection> load_gear_pair_inspections(Database& db, std::int64_t gear_pair) {
  Statement s(db, inspection_select(db) + " WHERE coalesce(gear_pair, 0) = ? ORDER BY id");
  s.bind(1, gear_pair);
  return read_inspections(s);
}

GearPairPosition load_gear_pair_position(Database& db) {
  GearPairPosition p;
  {
    Statement st(db, "SELECT count(*), (SELECT revolutions FROM life_counter_events ORDER BY id DESC LIMIT 1) FROM life_counter_events");
    st.step();
    p.gear_pair = st.get_int(0);
    if (!st.is_null(1)) p.reset_at_cycles = st.get_double(1);
  }
  // The model also starts a pair when the configured gear pair changes (no reset): the pair now
  // installed is the newest of the life-counter resets and the model's pairs.
  if (detail::has_object(db, "model_state")) {
    Statement st(db, "SELECT max(gear_pair) FROM model_state");
    if (st.step() && !st.is_null(0)) p.gear_pair = std::max(p.gear_pair, st.get_int(0));
  }
  Statement newest(db, "SELECT input_revolutions FROM records WHERE input_revolutions IS NOT NULL ORDER BY id DESC LIMIT 1");
  if (newest.step()) p.newest_record_cycles = newest.get_double(0);
  return p;
}

std::int64_t insert_inspection(Database& db, const NewInspection& inspection) {
  Statement s(db,
              "INSERT INTO inspections(cycles, pitted_area_fraction, wear_depth_m, note, gear_pair, " GW_INSPECTION_DEEPEST_COLUMNS ")"
              " VALUES (?, ?, ?, ?, ?, ?, ?)");
  s.bind(1, inspection.cycles).bind(2, inspection.pitted_area_fraction).bind(3, inspection.wear_depth_m);
  if (inspection.note.empty()) s.bind_null(4);
  else s.bind(4, inspection.note);
  s.bind(5, inspection.gear_pair).bind(6, inspection.wear_depth_max_m).bind(7, inspection.wear_depth_relative_sd);
  s.run();
  return db.last_insert_rowid();
}

}  // namespace gearwatch::storage
