#pragma once
// One gap report on stdout, as `gap report --format table|json` and `gap diagnose` print it
// (docs/cli.md). The JSON holds every field of the stored report, doubles with round-trip
// precision (NaN as null); the table the figures staff read.
#include <ostream>
#include <string>

#include <nlohmann/json.hpp>

#include "gearwatch/storage/gap_reports.hpp"

namespace gearwatch::cli {

/// The report as JSON. `stored` false: a report not (yet) in a database (id, created_at and
/// record_id null).
nlohmann::json gap_report_json(const storage::StoredGapReport& report, bool stored = true);

/// The report as text: its header, the families before/after with their intervals, the
/// candidates ranked with their evidence, the chosen and unexplained, K_wear.
void print_gap_report_table(std::ostream& out, const storage::StoredGapReport& report, bool stored = true);

/// The report on stdout in `format` (table | json).
void print_gap_report(const storage::StoredGapReport& report, const std::string& format, bool stored = true);

}  // namespace gearwatch::cli
