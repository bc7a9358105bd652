#pragma once
// The maintenance report: one self-contained HTML page (inline CSS and SVG, no scripts, no
// network) with the gearbox's state from the database (docs/report.md). Loading and rendering
// are separate so the page can be rendered from hand-made data.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "gearwatch/report/svg_plot.hpp"
#include "gearwatch/storage/alert_history.hpp"
#include "gearwatch/storage/inspections.hpp"
#include "gearwatch/storage/record_reasons.hpp"
#include "gearwatch/storage/report_history.hpp"
#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::report {

/// One record of the gear pair on display, in record order.
struct RecordRow {
  std::int64_t id = 0;
  std::optional<double> cycles;  ///< input revolutions at the record (NULL without a life counter)
  std::string created_at;
  bool analysed = false;
  RecordEnd end_reason = RecordEnd::complete;
  std::optional<dsp::SpeedSource> speed_source;  ///< where the analysed shaft angle came from
};

using AlertRow = storage::StoredAlert;
using ActiveAlertRow = storage::StoredActiveAlert;

using WearVerdictRow = storage::StoredWearVerdict;

using HealthRow = storage::StoredHealth;
using InspectionRow = storage::StoredInspection;

/// A table the schema does not define yet (the twin's k_updates, predictions): listed as it is.
struct GenericTable {
  std::string name;
  bool present = false;
  std::vector<std::string> columns;
  std::vector<std::vector<std::string>> rows;  ///< at most kMaxGenericRows, newest (highest rowid) first
  std::int64_t total_rows = 0;
};

struct ReportData {
  std::string database;
  std::string generated_at;  ///< UTC, ISO 8601
  int schema_version = 0;

  std::int64_t total_records = 0;      ///< in the whole database
  int gear_pair_number = 1;            ///< 1 + the pairs begun before the current one (the gear-pair rule)
  std::vector<RecordRow> records;      ///< of the current gear pair, by id
  std::optional<std::string> gear_pair_started_at;  ///< created_at of its first record

  std::vector<std::int64_t> channels;  ///< channels with indicator values in the current gear pair
  std::vector<std::string> indicator_names;  ///< every indicator name stored for them
  /// (channel, indicator name) -> record id -> value (only non-NULL values).
  std::map<std::pair<std::int64_t, std::string>, std::map<std::int64_t, double>> values;

  std::vector<storage::ChannelNaming> channel_names;  ///< as the runs' configs named them, by channel
  std::vector<storage::IndicatorSkip> skips;          ///< of the current gear pair
  std::vector<storage::IndicatorCaveat> caveats;      ///< of the current gear pair

  std::vector<WearVerdictRow> verdicts;   ///< newest per channel
  std::vector<ActiveAlertRow> active_alerts;
  std::vector<AlertRow> alerts;           ///< newest first, at most kMaxAlertRows
  std::int64_t total_alerts = 0;
  std::vector<AlertRow> gear_pair_alerts; ///< every transition of the current gear pair, oldest first (event lines)
  std::vector<HealthRow> health;          ///< newest snapshot per run, newest run first
  std::vector<InspectionRow> inspections; ///< all, by cycles
  std::vector<GenericTable> model_tables; ///< k_updates, predictions
};

inline constexpr std::size_t kMaxAlertRows = 500;
inline constexpr std::size_t kMaxGenericRows = 200;

/// The twin's tables the page shows when a database has them.
inline const std::vector<std::string>& model_table_names() {
  static const std::vector<std::string> names{"k_updates", "predictions"};
  return names;
}

/// Reads everything the page shows in one read transaction (one consistent snapshot; in WAL
/// mode it never blocks the writer). A database without any table is read as empty; one that
/// has tables but no `records` is refused (std::runtime_error).
ReportData load_report_data(storage::Database& db, const std::string& database_label, const std::string& generated_at);

/// "casing_y (channel 0)", or "channel 0" when no run named it (a database before schema 10).
std::string channel_label(const ReportData& data, std::int64_t channel);
/// The same for an alert's channel, which for a tacho alert is the tacho's shaft ("shaft 0").
std::string alert_channel_label(const ReportData& data, AlertKind kind, std::int64_t channel);

/// Why something was not computed, or computed with a caveat its value depends on.
using Reason = std::variant<dsp::SkipReason, dsp::IndicatorNote>;
/// The reason's stored token, from its enum's to_string.
const char* to_string(const Reason& reason) noexcept;

/// Indicators of one channel skipped (or computed with a caveat) for one reason in exactly the
/// same records: the page's rows of "what was not computed, and why".
struct ReasonGroup {
  std::int64_t channel = 0;
  Reason reason;
  std::vector<std::string> indicators;      ///< sorted
  std::vector<std::int64_t> records;        ///< record ids, ascending
  std::vector<std::string> details;         ///< the distinct details stored with them, at most kMaxReasonDetails
  std::size_t more_details = 0;             ///< distinct details beyond those
};
inline constexpr std::size_t kMaxReasonDetails = 3;

/// The skips and caveats of the current gear pair grouped per channel: skips first, then by
/// reason (enum order), then by first record and indicator.
std::vector<ReasonGroup> reason_groups(const ReportData& data);

/// Ascending record ids as runs of consecutive ids: {1, 2, 3, 5, 9, 10} -> "1–3, 5, 9–10".
std::string record_ranges(const std::vector<std::int64_t>& ids);

/// A trend plot family: one SVG per channel, a series per indicator.
struct PlotFamily {
  std::string id;        ///< used in element ids: "ics2", "rms_sa", ...
  std::string title;
  std::string y_label;   ///< quantity and unit
  bool allow_log;
  std::vector<std::pair<std::string, std::string>> series;  ///< (indicator name, legend label)
};

/// The families for the indicators of `data`, in page order: ICS2 (low, high, selected band),
/// RMS_SA, rms_raw, kurtosis_raw, mean carrier frequency (every mean_carrier_hz_* stored).
std::vector<PlotFamily> plot_families(const ReportData& data);

/// The plot of one family and channel (x: input revolutions of the current gear pair; a point per
/// record with cycles, NaN where the record has no value), with alert transitions and inspections
/// as event lines. nullopt when the channel has no value of any of the family's indicators.
std::optional<SvgPlot> make_trend_plot(const ReportData& data, const PlotFamily& family, std::int64_t channel);

/// The whole page.
std::string render_report_html(const ReportData& data);

/// UTC now, ISO 8601 with seconds ("2026-11-23T07:23:42Z").
std::string utc_now_iso8601();

/// The stylesheet every gearwatch page shares (page layout, tables, plots).
const char* report_base_style() noexcept;

}  // namespace gearwatch::report
