#pragma once
// The sim-to-real gap page (docs/gap-report.md): one self-contained HTML page (inline CSS and SVG,
// no scripts, no network) with the newest stored gap report — the families' gap before and after
// the chosen effects, the attribution with its evidence, and the measured, twin and corrected-twin
// spectra with the families shaded — and the history of the reports before it.
#include <stdexcept>
#include <string>
#include <vector>

#include "gearwatch/storage/gap_reports.hpp"
#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::report {

/// A twin_drift alert raised now (active_alerts), with the message of its newest raise.
struct DriftAlertRow {
  std::string family, value, raised_at, message;
};

struct GapPageData {
  std::string database;      ///< as named on the command line
  std::string generated_at;  ///< ISO 8601 UTC
  std::vector<storage::StoredGapReport> reports;  ///< oldest first; the last is shown in detail
  std::size_t total_reports = 0;                  ///< in the database (the history shows the newest)
  std::vector<DriftAlertRow> active_drift;        ///< by family
};

/// Thrown when the database holds no gap report (or predates them): there is nothing to show.
struct NoGapReports : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The newest `history` reports. Throws NoGapReports, or std::runtime_error for a file that is not
/// a gearwatch database or a report that cannot be read.
GapPageData load_gap_page_data(storage::Database& db, const std::string& database_label, const std::string& generated_at,
                               std::size_t history = 50);

std::string render_gap_report_html(const GapPageData& data);

}  // namespace gearwatch::report
