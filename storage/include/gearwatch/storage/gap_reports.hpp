#pragma once
// Sim-to-real gap reports in the database (schema version 5, docs/gap-report.md): writing one
// diagnosis into its tables and reading them back, every double exactly.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/types/gap_report.hpp"

namespace gearwatch::storage {

/// Where a report belongs: the record whose arrival triggered the diagnosis and the gear pair.
struct GapReportContext {
  std::optional<std::int64_t> record_id;
  std::int64_t gear_pair = 0;
};

/// Inserts `report` into gap_report_runs and its detail tables (inside the caller's transaction)
/// and returns its id. Throws SqliteError, e.g. when a family or effect is not in the vocabulary.
std::int64_t insert_gap_report(Database& db, const gap::GapReport& report, const GapReportContext& context);

struct StoredGapReport {
  std::int64_t id = 0;
  std::string created_at;
  GapReportContext context;
  gap::GapReport report;
};

/// Every stored report, oldest first, or only the newest `newest` of them (still oldest first).
/// A database older than schema version 5 has none. Throws std::runtime_error naming the report
/// when a stored token or plot document cannot be read. The features (GapReport::features) are kept
/// in the plot document, under "features" (a report stored before them reads back with none), and a
/// candidate's parameters at a bound of their range in its parameters document: no schema change.
std::vector<StoredGapReport> load_gap_reports(Database& db, std::optional<std::size_t> newest = std::nullopt);

/// True when the database has the gap report tables (schema version 5 or later).
bool has_gap_report_tables(Database& db);
/// Gap reports stored (table gap_report_runs, which must exist: has_gap_report_tables).
std::int64_t count_gap_reports(Database& db);

}  // namespace gearwatch::storage
