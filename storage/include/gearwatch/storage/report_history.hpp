#pragma once
// Typed readers of what the maintenance report shows beyond records, alerts and verdicts
// (docs/report.md): the plotted indicators, the acquisition health per run, and the rows of
// tables the page lists as stored. Older schemas read as far as they go.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/storage/stored_table.hpp"

namespace gearwatch::storage {

/// A deferred read transaction: everything read while it lives is one snapshot of the database,
/// and in WAL mode a reader holds no lock the writer waits for (BEGIN IMMEDIATE, as Transaction
/// does, would). Ends the read in its destructor.
class ReadSnapshot {
 public:
  explicit ReadSnapshot(Database& db);
  ~ReadSnapshot();
  ReadSnapshot(const ReadSnapshot&) = delete;
  ReadSnapshot& operator=(const ReadSnapshot&) = delete;

 private:
  Database& db_;
};

/// True when the database has no table at all (a new, empty file).
bool has_no_tables(Database& db);
/// True when `name` is a table or view of the database.
bool has_table_or_view(Database& db, const std::string& name);

/// One indicator value of the view indicators.
struct StoredPlotValue {
  std::int64_t record_id = 0;
  std::int64_t channel = 0;
  std::string name;
  double value = 0;
};
/// The non-NULL values of the plotted indicators (ICS2 bands and selected band, rms_sa, rms_raw,
/// kurtosis_raw, mean_carrier_hz_*) of records with id >= first_record. Empty without the view.
std::vector<StoredPlotValue> load_plot_indicator_values(Database& db, std::int64_t first_record);

/// The newest acquisition-health snapshot of a run (view acquisition_health); counters a schema
/// lacks read as 0.
struct StoredHealth {
  std::int64_t run_id = 0;
  std::string run_kind, source, run_started_at, run_ended_at, taken_at;
  bool final = false;
  std::int64_t frames = 0, samples = 0;
  std::int64_t lost_samples = 0;  ///< gap_samples + samples of ring-overflow gaps
  std::int64_t kernel_drops = 0;
  std::int64_t rejected_frames = 0;  ///< sum of the rejected_breakdown counters
  std::vector<std::pair<std::string, std::int64_t>> rejected_breakdown;
  std::int64_t records_rejected = 0, storage_rows_rejected = 0;
};
/// Every snapshot of view acquisition_health, newest run first. Empty without the view.
std::vector<StoredHealth> load_acquisition_health(Database& db);

/// The newest rows of a table or view as stored, and how many it has.
struct NewestRows {
  StoredTable table;       ///< at most `limit` rows, newest (highest rowid) first when it has rowids
  std::int64_t total_rows = 0;
};
/// `name` must be a table or view of the database (has_table_or_view).
NewestRows load_newest_rows(Database& db, const std::string& name, std::size_t limit);

}  // namespace gearwatch::storage
