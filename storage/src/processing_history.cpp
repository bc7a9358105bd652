#include "gearwatch/storage/processing_history.hpp"

#include "gearwatch/types/indicator.hpp"
#include "stored_rows.hpp"

namespace gearwatch::storage {

std::vector<StoredIcs2Point> load_gear_pair_ics2_history(Database& db) {
  Statement s(db, R"SQL(
    SELECT r.input_revolutions, lo.channel, lo.value, hi.value, b.centre_hz, b.value
    FROM records r
    JOIN indicator_values lo ON lo.record_id = r.id AND lo.name = ?1
    LEFT JOIN indicator_values hi ON hi.record_id = r.id AND hi.channel = lo.channel AND hi.name = ?2
    LEFT JOIN band_selections b ON b.record_id = r.id AND b.channel = lo.channel AND b.criterion = ?3
    WHERE r.analysed = 1 AND r.input_revolutions IS NOT NULL
      AND r.created_at >= coalesce((SELECT max(detected_at) FROM life_counter_events), '')
    ORDER BY r.id)SQL");
  s.bind(1, dsp::to_string(dsp::Indicator::ics2_low_band))
      .bind(2, dsp::to_string(dsp::Indicator::ics2_high_band))
      .bind(3, dsp::to_string(dsp::BandSelectionCriterion::ics2));
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
      AND r.created_at >= coalesce((SELECT max(detected_at) FROM life_counter_events), '')
    ORDER BY r.id)SQL");
  std::vector<StoredIndicatorValue> out;
  while (s.step()) out.push_back({s.get_int(0), s.get_int(1), s.get_text(2), s.get_double(3)});
  return out;
}

}  // namespace gearwatch::storage
