#include "gearwatch/storage/inspections.hpp"

namespace gearwatch::storage {

GearPairPosition load_gear_pair_position(Database& db) {
  GearPairPosition p;
  {
    Statement st(db, "SELECT count(*), (SELECT revolutions FROM life_counter_events ORDER BY id DESC LIMIT 1) FROM life_counter_events");
    st.step();
    p.gear_pair = st.get_int(0);
    if (!st.is_null(1)) p.reset_at_cycles = st.get_double(1);
  }
  Statement newest(db, "SELECT input_revolutions FROM records WHERE input_revolutions IS NOT NULL ORDER BY id DESC LIMIT 1");
  if (newest.step()) p.newest_record_cycles = newest.get_double(0);
  return p;
}

std::int64_t insert_inspection(Database& db, const NewInspection& inspection) {
  Statement s(db, "INSERT INTO inspections(cycles, pitted_area_fraction, wear_depth_m, note, gear_pair) VALUES (?, ?, ?, ?, ?)");
  s.bind(1, inspection.cycles).bind(2, inspection.pitted_area_fraction).bind(3, inspection.wear_depth_m);
  if (inspection.note.empty()) s.bind_null(4);
  else s.bind(4, inspection.note);
  s.bind(5, inspection.gear_pair);
  s.run();
  return db.last_insert_rowid();
}

}  // namespace gearwatch::storage
