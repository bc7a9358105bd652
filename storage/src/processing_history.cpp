#include "gearwatch/storage/processing_history.hpp"

#include "gearwatch/types/indicator.hpp"
#include "stored_rows.hpp"
#include "stored_tokens.hpp"

namespace gearwatch::storage {

GearPairInputs load_gear_pair_inputs(Database& db) {
  GearPairInputs in;
  Statement records(db, "SELECT id, input_revolutions, stream_key, start_index FROM records ORDER BY id");
  while (records.step()) {
    in.record_ids.push_back(records.get_int(0));
    in.records.push_back({detail::optional_double(records, 1), {records.get_int(2), records.get_int(3)}});
  }
  if (!detail::has_object(db, "life_counter_events")) return in;
  Statement resets(db, "SELECT stream_key, sample_index FROM life_counter_events ORDER BY id");
  while (resets.step()) in.resets.push_back({resets.get_int(0), resets.get_int(1)});
  return in;
}

CurrentGearPair current_gear_pair(Database& db) {
  const GearPairInputs in = load_gear_pair_inputs(db);
  const GearPairHistory pairs = decide_gear_pairs(in.records, in.resets);
  CurrentGearPair c{pairs.current_pair, 0};
  if (pairs.current_pair_first < in.record_ids.size()) c.first_record_id = in.record_ids[pairs.current_pair_first];
  else c.first_record_id = in.record_ids.empty() ? 0 : in.record_ids.back() + 1;
  return c;
}

std::int64_t current_gear_pair_first_record(Database& db) { return current_gear_pair(db).first_record_id; }

std::vector<StoredIcs2Point> load_gear_pair_ics2_history(Database& db) {
  Statement s(db, R"SQL(
    SELECT r.input_revolutions, lo.channel, lo.value, hi.value, b.centre_hz, b.value
    FROM records r
    JOIN indicator_values lo ON lo.record_id = r.id AND lo.name = ?1
    LEFT JOIN indicator_values hi ON hi.record_id = r.id AND hi.channel = lo.channel AND hi.name = ?2
    LEFT JOIN band_selections b ON b.record_id = r.id AND b.channel = lo.channel AND b.criterion = ?3
    WHERE r.analysed = 1 AND r.input_revolutions IS NOT NULL
      AND r.id >= ?4
    ORDER BY r.id)SQL");
  s.bind(1, dsp::to_string(dsp::Indicator::ics2_low_band))
      .bind(2, dsp::to_string(dsp::Indicator::ics2_high_band))
      .bind(3, dsp::to_string(dsp::BandSelectionCriterion::ics2))
      .bind(4, current_gear_pair_first_record(db));
  std::vector<StoredIcs2Point> out;
  while (s.step())
    out.push_back({s.get_int(1), s.get_double(0), detail::optional_double(s, 2), detail::optional_double(s, 3),
                   detail::optional_double(s, 4), detail::optional_double(s, 5)});
  return out;
}

std::vector<StoredIndicatorValue> load_gear_pair_indicator_values(Database& db) {
  Statement s(db, R"SQL(
    SELECT v.record_id, v.channel, v.name, v.value FROM indicator_values v JOIN records r ON r.id = v.record_id
    WHERE r.analysed = 1 AND v.value IS NOT NULL
      AND r.id >= ?
    ORDER BY r.id)SQL");
  s.bind(1, current_gear_pair_first_record(db));
  std::vector<StoredIndicatorValue> out;
  while (s.step()) out.push_back({s.get_int(0), s.get_int(1), s.get_text(2), s.get_double(3)});
  return out;
}

}  // namespace gearwatch::storage
