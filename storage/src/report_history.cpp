#include "gearwatch/storage/report_history.hpp"

#include <array>
#include <map>
#include <string_view>

#include "gearwatch/storage/messages.hpp"
#include "gearwatch/types/dropout_cause.hpp"
#include "gearwatch/types/indicator.hpp"

#include "stored_rows.hpp"
#include "stored_tokens.hpp"

namespace gearwatch::storage {

ReadSnapshot::ReadSnapshot(Database& db) : db_(db) { db_.exec("BEGIN"); }

ReadSnapshot::~ReadSnapshot() {
  try {
    db_.exec("COMMIT");
  } catch (...) {  // nothing was written: ending the read cannot lose anything
  }
}

bool has_no_tables(Database& db) {
  Statement s(db, "SELECT count(*) FROM sqlite_master WHERE type = 'table'");
  s.step();
  return s.get_int(0) == 0;
}

bool has_table_or_view(Database& db, const std::string& name) { return detail::has_object(db, name.c_str()); }

namespace {

// The indicators the report plots by name (the mean-carrier ones are found by their prefix).
constexpr std::array kPlotIndicators{dsp::Indicator::ics2_low_band, dsp::Indicator::ics2_high_band,
                                     dsp::Indicator::ics2_selected_band, dsp::Indicator::rms_sa,
                                     dsp::Indicator::rms_raw, dsp::Indicator::kurtosis_raw};

// A LIKE pattern (ESCAPE '\') matching every text that starts with `prefix`.
std::string like_prefix(std::string_view prefix) {
  std::string pattern;
  for (const char c : prefix) {
    if (c == '\\' || c == '_' || c == '%') pattern += '\\';
    pattern += c;
  }
  return pattern + '%';
}

}  // namespace

std::vector<StoredPlotValue> load_plot_indicator_values(Database& db, std::int64_t first_record) {
  std::vector<StoredPlotValue> out;
  if (!detail::has_object(db, "indicators")) return out;
  Statement s(db,
              "SELECT record_id, channel, name, value FROM indicators WHERE record_id >= ? AND value IS NOT NULL"
              " AND (name IN (?, ?, ?, ?, ?, ?) OR name LIKE ? ESCAPE '\\')");
  s.bind(1, first_record);
  int column = 2;
  for (const dsp::Indicator indicator : kPlotIndicators) s.bind(column++, to_string(indicator));
  const std::string mean_carrier = like_prefix(dsp::kMeanCarrierIndicatorPrefix);
  s.bind(column, mean_carrier);
  while (s.step()) out.push_back({s.get_int(0), s.get_int(1), s.get_text(2), s.get_double(3)});
  return out;
}

namespace {

// Read by column name, so a snapshot with more counters (a newer schema) still reads.
class ColumnsByName {
 public:
  explicit ColumnsByName(const Statement& s) : s_(s) {
    for (int i = 0; i < s.column_count(); ++i) col_[s.column_name(i)] = i;
  }
  std::int64_t integer(const char* name) const {
    const auto it = col_.find(name);
    return it == col_.end() || s_.is_null(it->second) ? 0 : s_.get_int(it->second);
  }
  std::int64_t integer(HealthCounter counter) const { return integer(to_string(counter)); }
  std::string text(const char* name) const {
    const auto it = col_.find(name);
    return it == col_.end() ? std::string{} : s_.get_text(it->second);
  }

 private:
  const Statement& s_;
  std::map<std::string, int> col_;
};

StoredHealth health_row(const ColumnsByName& c) {
  StoredHealth h;
  h.run_id = c.integer("run_id");
  h.run_kind = c.text("run_kind");
  h.source = c.text("source");
  h.run_started_at = c.text("run_started_at");
  h.run_ended_at = c.text("run_ended_at");
  h.taken_at = c.text("taken_at");
  h.final = c.integer("final") != 0;
  using C = HealthCounter;
  h.frames = c.integer(C::frames);
  h.samples = c.integer(C::samples);
  h.lost_samples = c.integer(C::dropout_samples) + c.integer("report_ring_lost");
  h.kernel_drops = c.integer(C::kernel_drops);
  for (const C counter : {C::malformed_frames, C::malformed_lines, C::unknown_ids, C::unconfigured_channel_frames,
                          C::frames_before_header, C::unsupported_version, C::duplicates}) {
    const std::int64_t n = c.integer(counter);
    h.rejected_breakdown.emplace_back(to_string(counter), n);
    h.rejected_frames += n;
  }
  h.records_rejected = c.integer(C::records_rejected);
  h.storage_rows_rejected = c.integer(C::storage_rows_rejected);
  return h;
}

}  // namespace

std::vector<StoredHealth> load_acquisition_health(Database& db) {
  std::vector<StoredHealth> out;
  if (!detail::has_object(db, "acquisition_health")) return out;
  // The samples a ring overflow lost are stored only as dropout events (the health row counts the
  // overflows, not their samples); they are added to the run's lost samples here.
  Statement s(db,
              "SELECT h.*, (SELECT coalesce(sum(g.missing_samples), 0) FROM gap_events g JOIN streams st"
              " ON st.id = g.stream_key WHERE st.run_id = h.run_id AND g.cause = ?) AS report_ring_lost"
              " FROM acquisition_health h ORDER BY run_id DESC");
  s.bind(1, acquisition::to_string(acquisition::DropoutCause::ring_overflow));
  const ColumnsByName columns(s);
  while (s.step()) out.push_back(health_row(columns));
  return out;
}

NewestRows load_newest_rows(Database& db, const std::string& name, std::size_t limit) {
  NewestRows out;
  Statement count(db, "SELECT count(*) FROM \"" + name + "\"");
  count.step();
  out.total_rows = count.get_int(0);
  // rowid order is insertion order; a view or WITHOUT ROWID table is listed as it comes.
  const bool has_rowid = [&] {
    try {
      Statement probe(db, "SELECT rowid FROM \"" + name + "\" LIMIT 0");
      return true;
    } catch (const SqliteError&) {
      return false;
    }
  }();
  Statement s(db, "SELECT * FROM \"" + name + "\"" + (has_rowid ? " ORDER BY rowid DESC" : "") + " LIMIT " + std::to_string(limit));
  out.table = detail::read_table(s);
  return out;
}

}  // namespace gearwatch::storage
