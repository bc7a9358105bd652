#include "gearwatch/report/report_page.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <set>
#include <stdexcept>
#include <tuple>

#include "gearwatch/storage/processing_history.hpp"
#include "gearwatch/types/indicator.hpp"

namespace gearwatch::report {
namespace {

using storage::Database;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string format_number(double v, int significant = 4) {
  if (!std::isfinite(v)) return "—";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", significant, v);
  return buf;
}

// Cycle counts are integers in practice; keep them whole and grouped for reading.
std::string grouped_cycles(double cycles) {
  if (!std::isfinite(cycles)) return "—";
  if (std::abs(cycles) >= 1e15 || cycles != std::floor(cycles)) return format_number(cycles, 8);
  std::string digits = std::to_string(static_cast<long long>(cycles));
  std::string out;
  const std::size_t first = digits[0] == '-' ? 1 : 0;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > first && (digits.size() - i) % 3 == 0) out += "\u2009";  // thin space
    out += digits[i];
  }
  return out;
}

std::string cell_text(const storage::StoredValue& v) {
  if (storage::is_null(v)) return "—";
  if (const auto* d = std::get_if<double>(&v)) return format_number(*d, 6);
  if (const auto* i = std::get_if<std::int64_t>(&v)) return std::to_string(*i);
  if (const auto* t = std::get_if<std::string>(&v)) return *t;
  return "(binary)";
}

// The alert, severity and event colours; the page's stylesheet uses the same ones.
const char* severity_colour(AlertSeverity severity) {
  switch (severity) {
    case AlertSeverity::alarm: return "#d32f2f";
    case AlertSeverity::warning: return "#ef6c00";
    case AlertSeverity::info: break;
  }
  return "#546e7a";
}
constexpr const char* kClearedColour = "#9e9e9e";
constexpr const char* kInspectionColour = "#2e7d32";
const char* const kSeriesColours[] = {"#1f5fbf", "#00897b", "#8e44ad", "#795548"};


}  // namespace

std::string utc_now_iso8601() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

namespace {

/// The records of the current gear pair, by the one gear-pair rule (gearwatch/types/gear_pair_boundary.hpp).
void load_current_pair_records(Database& db, ReportData& d) {
  std::vector<RecordRow> all;
  for (auto& r : storage::load_record_summaries(db))
    all.push_back({r.id, r.input_revolutions, std::move(r.created_at), r.analysed, r.end_reason, r.speed_source});
  d.total_records = static_cast<std::int64_t>(all.size());
  const storage::CurrentGearPair pair = storage::current_gear_pair(db);
  d.gear_pair_number += static_cast<int>(pair.pairs_before);
  for (auto& r : all)
    if (r.id >= pair.first_record_id) d.records.push_back(std::move(r));
  if (!d.records.empty()) d.gear_pair_started_at = d.records.front().created_at;
}

/// Only the indicators the plots show: a long history has tens of other values per record.
void load_plot_values(Database& db, std::int64_t first_record, ReportData& d) {
  std::set<std::int64_t> channels;
  std::set<std::string> names;
  for (auto& v : storage::load_plot_indicator_values(db, first_record)) {
    d.values[{v.channel, v.name}][v.record_id] = v.value;
    channels.insert(v.channel);
    names.insert(std::move(v.name));
  }
  d.channels.assign(channels.begin(), channels.end());
  d.indicator_names.assign(names.begin(), names.end());
}

/// The twin's tables are not in the schema yet: shown as stored when a database has them.
GenericTable load_model_table(Database& db, const std::string& name) {
  GenericTable t;
  t.name = name;
  t.present = storage::has_table_or_view(db, name);
  if (!t.present) return t;
  const storage::NewestRows newest = storage::load_newest_rows(db, name, kMaxGenericRows);
  t.total_rows = newest.total_rows;
  t.columns = newest.table.columns;
  for (const auto& stored : newest.table.rows) {
    std::vector<std::string> row;
    for (const auto& v : stored) row.push_back(cell_text(v));
    t.rows.push_back(std::move(row));
  }
  return t;
}

}  // namespace

ReportData load_report_data(Database& db, const std::string& database_label, const std::string& generated_at) {
  ReportData d;
  d.database = database_label;
  d.generated_at = generated_at;
  d.schema_version = db.user_version();
  const storage::ReadSnapshot snapshot(db);

  if (storage::has_no_tables(db)) {  // a new, empty file: nothing measured yet
    for (const auto& name : model_table_names()) d.model_tables.push_back({name, false, {}, {}, 0});
    return d;
  }
  if (!storage::has_table_or_view(db, "records")) throw std::runtime_error(database_label + " is not a gearwatch database (it has no records table)");

  load_current_pair_records(db, d);
  const std::int64_t first_record = d.records.empty() ? std::numeric_limits<std::int64_t>::max() : d.records.front().id;
  d.channel_names = storage::load_channel_names(db);
  d.skips = storage::load_indicator_skips(db, first_record);
  d.caveats = storage::load_indicator_caveats(db, first_record);
  load_plot_values(db, first_record, d);

  d.verdicts = storage::load_newest_wear_verdicts(db);
  d.total_alerts = storage::count_alerts(db);
  d.alerts = storage::load_newest_alerts(db, kMaxAlertRows);
  d.active_alerts = storage::load_active_alerts(db);
  d.health = storage::load_acquisition_health(db);
  d.inspections = storage::load_inspections(db);
  for (const auto& name : model_table_names()) d.model_tables.push_back(load_model_table(db, name));

  // Alert transitions of the current gear pair, for the plots' event lines (the table above
  // holds only the newest rows of the whole history).
  if (!d.records.empty()) d.gear_pair_alerts = storage::load_alerts_since(db, first_record, *d.gear_pair_started_at);
  return d;
}

std::vector<PlotFamily> plot_families(const ReportData& data) {
  using dsp::Indicator;
  auto name = [](Indicator i) { return std::string(dsp::to_string(i)); };
  std::vector<PlotFamily> families{
      {"ics2", "ICS2 (cyclostationarity of the residual)", "ICS2 (–)", true,
       {{name(Indicator::ics2_low_band), "low band (pitting)"},
        {name(Indicator::ics2_high_band), "high band (abrasion)"},
        {name(Indicator::ics2_selected_band), "selected band"}}},
      {name(Indicator::rms_sa), "RMS_SA (mesh harmonics)", "RMS_SA (m/s²)", false, {{name(Indicator::rms_sa), ""}}},
      {name(Indicator::rms_raw), "RMS of the raw signal", "RMS (m/s²)", false, {{name(Indicator::rms_raw), ""}}},
      {name(Indicator::kurtosis_raw), "Kurtosis of the raw signal", "kurtosis (–)", false, {{name(Indicator::kurtosis_raw), ""}}},
  };
  PlotFamily carrier{"mean_carrier", "Mean carrier frequency", "frequency (Hz)", false, {}};
  const std::string prefix(dsp::kMeanCarrierIndicatorPrefix);
  for (const auto& name : data.indicator_names) {
    if (name.rfind(prefix, 0) != 0) continue;
    // mean_carrier_hz_<lo>_<hi> -> "<lo>–<hi> Hz"
    std::string range = name.substr(prefix.size());
    const auto sep = range.find('_');
    if (sep != std::string::npos) range = range.substr(0, sep) + "–" + range.substr(sep + 1);
    carrier.series.emplace_back(name, range + " Hz");
  }
  families.push_back(std::move(carrier));
  return families;
}

std::string channel_label(const ReportData& data, std::int64_t channel) {
  for (const auto& n : data.channel_names)
    if (n.channel == channel) return n.name + " (channel " + std::to_string(channel) + ")";
  return "channel " + std::to_string(channel);
}

std::string alert_channel_label(const ReportData& data, AlertKind kind, std::int64_t channel) {
  // A tacho alert's channel is the tacho's shaft, not an accelerometer.
  if (kind == AlertKind::tacho_missing) return "shaft " + std::to_string(channel);
  return channel_label(data, channel);
}

const char* to_string(const Reason& reason) noexcept {
  return std::visit([](auto r) { return dsp::to_string(r); }, reason);
}

namespace {

// (channel, reason, indicator) -> the records and details of its rows.
struct ReasonKey {
  std::int64_t channel;
  Reason reason;
  std::string indicator;
  bool operator<(const ReasonKey& o) const {
    return std::tie(channel, reason, indicator) < std::tie(o.channel, o.reason, o.indicator);
  }
};
struct ReasonRows {
  std::vector<std::int64_t> records;  // ascending: the readers return rows by record
  std::vector<std::string> details;   // distinct, in order of first appearance
};

template <class Row, class ReasonOf>
void collect_reasons(const std::vector<Row>& rows, ReasonOf reason_of, std::map<ReasonKey, ReasonRows>& out) {
  for (const auto& r : rows) {
    auto& entry = out[ReasonKey{r.channel, reason_of(r), r.indicator}];
    if (entry.records.empty() || entry.records.back() != r.record_id) entry.records.push_back(r.record_id);
    if (!r.detail.empty() && std::find(entry.details.begin(), entry.details.end(), r.detail) == entry.details.end())
      entry.details.push_back(r.detail);
  }
}

// Indicators of a channel skipped for one reason in exactly the same records become one group.
std::vector<ReasonGroup> merge_indicators(const std::map<ReasonKey, ReasonRows>& by_indicator) {
  std::vector<ReasonGroup> groups;
  std::map<std::tuple<std::int64_t, Reason, std::vector<std::int64_t>>, std::size_t> index;
  std::vector<std::vector<std::string>> all_details;
  for (const auto& [key, rows] : by_indicator) {
    const auto [it, added] = index.try_emplace({key.channel, key.reason, rows.records}, groups.size());
    if (added) {
      groups.push_back({key.channel, key.reason, {}, rows.records, {}, 0});
      all_details.emplace_back();
    }
    groups[it->second].indicators.push_back(key.indicator);
    auto& details = all_details[it->second];
    for (const auto& text : rows.details)
      if (std::find(details.begin(), details.end(), text) == details.end()) details.push_back(text);
  }
  for (std::size_t i = 0; i < groups.size(); ++i) {
    auto& details = all_details[i];
    groups[i].more_details = details.size() > kMaxReasonDetails ? details.size() - kMaxReasonDetails : 0;
    details.resize(std::min(details.size(), kMaxReasonDetails));
    groups[i].details = std::move(details);
  }
  return groups;
}

}  // namespace

std::vector<ReasonGroup> reason_groups(const ReportData& data) {
  std::map<ReasonKey, ReasonRows> by_indicator;
  collect_reasons(data.skips, [](const storage::IndicatorSkip& k) { return Reason{k.reason}; }, by_indicator);
  collect_reasons(data.caveats, [](const storage::IndicatorCaveat& k) { return Reason{k.note}; }, by_indicator);
  auto groups = merge_indicators(by_indicator);
  // Per channel, skips before caveats (the variant's order), reasons in enum order, then by records.
  std::stable_sort(groups.begin(), groups.end(), [](const ReasonGroup& a, const ReasonGroup& b) {
    return std::tie(a.channel, a.reason, a.records.front(), a.indicators.front()) <
           std::tie(b.channel, b.reason, b.records.front(), b.indicators.front());
  });
  return groups;
}

std::string record_ranges(const std::vector<std::int64_t>& ids) {
  std::string out;
  for (std::size_t i = 0; i < ids.size();) {
    std::size_t j = i;
    while (j + 1 < ids.size() && ids[j + 1] == ids[j] + 1) ++j;
    if (!out.empty()) out += ", ";
    out += std::to_string(ids[i]);
    if (j > i) out += "\u2013" + std::to_string(ids[j]);  // en dash
    i = j + 1;
  }
  return out;
}

namespace {

/// Where an alert sits on the cycle axis: its record's cycles, or (an alert without a record,
/// e.g. a sensor that stopped) those of the newest record made before it.
std::optional<double> alert_cycles(const ReportData& data, const AlertRow& a, const std::map<std::int64_t, const RecordRow*>& by_id) {
  if (a.record_id) {
    const auto it = by_id.find(*a.record_id);
    if (it != by_id.end()) return it->second->cycles;
    return std::nullopt;
  }
  std::optional<double> cycles;
  for (const auto& r : data.records)
    if (r.created_at <= a.created_at && r.cycles) cycles = r.cycles;
  return cycles;
}

std::string alert_title(const AlertRow& a) {
  std::string t = std::string(to_string(a.transition)) + " " + to_string(a.severity) + ": " + to_string(a.kind);
  if (!a.subject.empty()) t += " (" + a.subject + ")";
  t += " at " + a.created_at;
  if (a.record_id) t += ", record " + std::to_string(*a.record_id);
  if (!a.message.empty()) t += " — " + a.message;
  return t;
}

bool inspection_in_gear_pair(const ReportData& data, const InspectionRow& i) {
  // Inspection cycles count on the gear pair of their time; earlier pairs' would be misplaced.
  return data.gear_pair_number == 1 || (data.gear_pair_started_at && i.entered_at >= *data.gear_pair_started_at);
}

std::string inspection_title(const InspectionRow& i) {
  std::string t = "inspection " + std::to_string(i.id) + " at " + grouped_cycles(i.cycles) + " input revolutions";
  if (i.pitted_area_fraction) t += ", pitted area " + format_number(*i.pitted_area_fraction * 100, 3) + " %";
  if (i.wear_depth_m) t += ", wear depth " + format_number(*i.wear_depth_m * 1e6, 3) + " µm";
  if (!i.note.empty()) t += " — " + i.note;
  return t;
}

}  // namespace

std::optional<SvgPlot> make_trend_plot(const ReportData& data, const PlotFamily& family, std::int64_t channel) {
  std::vector<PlotSeries> series;
  std::vector<double> xs, ys;
  std::size_t colour = 0;
  for (const auto& [name, label] : family.series) {
    const auto found = data.values.find({channel, name});
    if (found == data.values.end() || found->second.empty()) continue;
    PlotSeries s{name, label, kSeriesColours[colour++ % std::size(kSeriesColours)], {}};
    for (const auto& r : data.records) {
      if (!r.cycles) continue;
      const auto v = found->second.find(r.id);
      PlotPoint p{*r.cycles, v == found->second.end() ? kNaN : v->second, {}};
      if (v != found->second.end()) {
        p.title = "record " + std::to_string(r.id) + " · " + r.created_at + " · " + grouped_cycles(*r.cycles) + " input revolutions · " +
                  name + " = " + format_number(v->second, 5);
        ys.push_back(v->second);
      }
      xs.push_back(*r.cycles);
      s.points.push_back(std::move(p));
    }
    series.push_back(std::move(s));
  }
  if (series.empty() || ys.empty()) return std::nullopt;

  std::map<std::int64_t, const RecordRow*> by_id;
  for (const auto& r : data.records) by_id[r.id] = &r;
  std::vector<EventLine> events;
  for (const auto& a : data.gear_pair_alerts) {
    if (a.channel && *a.channel != channel) continue;
    const auto x = alert_cycles(data, a, by_id);
    if (!x) continue;
    EventLine e{*x, "", "", alert_title(a)};
    if (a.transition == AlertTransition::raised) {
      e.css_class = std::string("raised-") + to_string(a.severity);
      e.colour = severity_colour(a.severity);
    } else if (a.transition == AlertTransition::cleared) {
      e.css_class = "cleared";
      e.colour = kClearedColour;
    } else {
      e.css_class = "event";
      e.colour = severity_colour(a.severity);
    }
    events.push_back(std::move(e));
  }
  for (const auto& i : data.inspections) {
    if (!inspection_in_gear_pair(data, i)) continue;
    events.push_back({i.cycles, "inspection", kInspectionColour, inspection_title(i)});
  }
  for (const auto& e : events) xs.push_back(e.x);

  SvgPlot plot(family.title + " — " + channel_label(data, channel), fit_axis(xs, "input revolutions", false),
               fit_axis(ys, family.y_label, family.allow_log));
  for (auto& e : events) plot.add_event(std::move(e));
  for (auto& s : series) plot.add_series(std::move(s));
  return plot;
}

namespace {

constexpr const char* kStyle = R"CSS(
:root { color-scheme: light; }
body { font: 14px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; margin: 0; color: #212121; background: #fafafa; }
main { max-width: 1260px; margin: 0 auto; padding: 16px 20px 40px; }
h1 { font-size: 22px; margin: 0 0 8px; }
h2 { font-size: 18px; margin: 28px 0 8px; border-bottom: 2px solid #cfd8dc; padding-bottom: 4px; }
h3 { font-size: 15px; margin: 18px 0 6px; }
header.summary { background: #fff; border: 1px solid #cfd8dc; border-radius: 6px; padding: 14px 18px; }
dl.facts { display: grid; grid-template-columns: max-content 1fr; gap: 2px 14px; margin: 0 0 10px; }
dl.facts dt { color: #546e7a; }
dl.facts dd { margin: 0; overflow-wrap: anywhere; }
.badges { display: flex; flex-wrap: wrap; gap: 8px; margin: 4px 0 10px; }
.badge { border-radius: 4px; padding: 4px 10px; border: 1px solid; background: #fff; }
.verdict-none { border-color: #2e7d32; color: #1b5e20; background: #e8f5e9; }
.verdict-undetermined { border-color: #90a4ae; color: #37474f; background: #eceff1; }
.verdict-fatigue_pitting, .verdict-abrasive_wear, .verdict-both { border-color: #ef6c00; color: #8a3b00; background: #fff3e0; font-weight: 600; }
ul.active { list-style: none; padding: 0; margin: 4px 0 0; }
ul.active li { border-left: 6px solid; padding: 4px 10px; margin: 4px 0; background: #fff; }
ul.active li.sev-alarm { border-left-color: #d32f2f; background: #ffebee; }
ul.active li.sev-warning { border-left-color: #ef6c00; background: #fff3e0; }
ul.active li.sev-info { border-left-color: #546e7a; }
table.alerts tr.sev-alarm td:first-child { border-left-color: #d32f2f; }
table.alerts tr.sev-warning td:first-child { border-left-color: #ef6c00; }
table.alerts tr.sev-info td:first-child { border-left-color: #90a4ae; }
td.time { white-space: nowrap; }
.ok { color: #1b5e20; }
.notice { background: #fff8e1; border: 1px solid #ffca28; padding: 8px 12px; border-radius: 4px; }
.muted { color: #607d8b; }
.plots { display: flex; flex-wrap: wrap; gap: 12px; }
figure { margin: 0; background: #fff; border: 1px solid #e0e0e0; border-radius: 4px; padding: 4px; }
figcaption { font-size: 12px; color: #607d8b; padding: 0 6px 4px; max-width: 590px; }
svg.plot { display: block; font-family: inherit; }
svg.plot .frame { fill: #fff; stroke: #90a4ae; }
svg.plot .grid { stroke: #eceff1; }
svg.plot .tick { font-size: 11px; fill: #455a64; }
svg.plot .axis-label { font-size: 12px; fill: #37474f; }
svg.plot .plot-title { font-size: 13px; font-weight: 600; fill: #263238; }
svg.plot text.legend { font-size: 11px; fill: #37474f; }
svg.plot polyline { stroke-width: 1.6; }
svg.plot circle.pt { stroke: none; }
svg.plot line.ev { stroke-width: 1.6; }
svg.plot line.ev.cleared { stroke-dasharray: 4 3; }
svg.plot line.ev.event { stroke-dasharray: 1 3; stroke-width: 2; }
svg.plot line.ev.inspection { stroke-dasharray: 8 3; }
.key { display: flex; flex-wrap: wrap; gap: 14px; font-size: 12px; color: #455a64; margin: 4px 0 8px; }
.key span.sw { display: inline-block; width: 18px; height: 0; border-top: 2px solid; vertical-align: middle; margin-right: 4px; }
table { border-collapse: collapse; background: #fff; font-size: 13px; }
th, td { border: 1px solid #e0e0e0; padding: 3px 8px; text-align: left; vertical-align: top; }
th { background: #eceff1; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
td.bad { color: #b71c1c; font-weight: 600; }
table.alerts td:first-child { border-left: 6px solid #e0e0e0; }
tr.trans-cleared td { color: #616161; }
.scroll { overflow-x: auto; max-width: 100%; }
svg.plot { max-width: 100%; height: auto; }
table.health, table.why { width: 100%; }
table.health td.source, table.why td.names, table.why td.detail { overflow-wrap: anywhere; }
table.health td.time { white-space: normal; min-width: 8em; }
table.why td.names { max-width: 26em; }
table.why td.detail { max-width: 34em; }
p.cannot-see { border-left: 6px solid #90a4ae; background: #eceff1; padding: 6px 10px; margin: 6px 0; }
)CSS";

std::string td(const std::string& text, const char* cls = nullptr) {
  return cls ? "<td class=\"" + std::string(cls) + "\">" + html_escape(text) + "</td>" : "<td>" + html_escape(text) + "</td>";
}
std::string td_num(std::int64_t v, bool bad_if_nonzero = false) {
  return td(std::to_string(v), bad_if_nonzero && v != 0 ? "num bad" : "num");
}
// An ISO 8601 time that may wrap between its date and its time of day (narrow columns).
std::string td_time(const std::string& text) {
  const auto t = text.find('T');
  if (t == std::string::npos) return td(text, "time");
  return "<td class=\"time\">" + html_escape(text.substr(0, t + 1)) + "<wbr>" + html_escape(text.substr(t + 1)) + "</td>";
}

// The band each verdict could not see and, from it, the mechanism it cannot identify.
dsp::WearMechanism hidden_mechanism(dsp::CarrierBand band) {
  return band == dsp::CarrierBand::abrasion ? dsp::WearMechanism::abrasive_wear : dsp::WearMechanism::fatigue_pitting;
}

void render_cannot_see(const ReportData& d, std::string& h) {
  for (const auto& v : d.verdicts) {
    if (!v.unseen_band) continue;
    const std::string band = dsp::to_string(*v.unseen_band);
    h += "<p class=\"cannot-see\" id=\"cannot-see-ch" + std::to_string(v.channel) + "\"><strong>" + html_escape(channel_label(d, v.channel)) +
         " cannot see the " + band + " band</strong> (<code>unseen_band = " + band + "</code>): it lies above 0.45·fs of the records, so <code>" +
         dsp::to_string(hidden_mechanism(*v.unseen_band)) + "</code> cannot be identified and the verdict rests on the other band alone. "
         "<span class=\"muted\">Evidence: " + html_escape(v.evidence) + "</span></p>\n";
  }
}

void render_header(const ReportData& d, std::string& h) {
  h += "<header class=\"summary\">\n<h1>Gearbox condition report</h1>\n<dl class=\"facts\">\n";
  h += "<dt>Database</dt><dd>" + html_escape(d.database) + " <span class=\"muted\">(schema version " + std::to_string(d.schema_version) +
       ")</span></dd>\n";
  h += "<dt>Generated</dt><dd>" + html_escape(d.generated_at) + "</dd>\n";
  h += "<dt>Gear pair</dt><dd>";
  if (d.records.empty()) {
    h += "no records yet";
  } else {
    const RecordRow* newest_with_cycles = nullptr;
    for (const auto& r : d.records)
      if (r.cycles) newest_with_cycles = &r;
    h += "#" + std::to_string(d.gear_pair_number) + " since the database began";
    if (newest_with_cycles)
      h += " — <strong>" + html_escape(grouped_cycles(*newest_with_cycles->cycles)) + " input revolutions</strong> now (record " +
           std::to_string(newest_with_cycles->id) + ", " + html_escape(newest_with_cycles->created_at) + ")";
    else
      h += " — no cycle count (no life counter in the stream)";
  }
  h += "</dd>\n";
  std::size_t analysed = 0;
  for (const auto& r : d.records) analysed += r.analysed ? 1 : 0;
  h += "<dt>Records</dt><dd>" + std::to_string(d.records.size()) + " of this gear pair (" + std::to_string(analysed) + " analysed); " +
       std::to_string(d.total_records) + " in the database</dd>\n</dl>\n";

  h += "<h3>Wear mechanism (newest verdict per channel)</h3>\n<div class=\"badges\">";
  if (d.verdicts.empty()) h += "<span class=\"muted\">no verdict yet</span>";
  for (const auto& v : d.verdicts) {
    const std::string mechanism = dsp::to_string(v.mechanism);
    h += "<span class=\"badge verdict-" + mechanism + "\" title=\"" + html_escape(v.evidence) + "\">" +
         html_escape(channel_label(d, v.channel)) + ": <strong>" + mechanism + "</strong> <span class=\"muted\">(" +
         std::to_string(v.points) + " points, record " + std::to_string(v.record_id) +
         (v.cycles ? ", " + html_escape(grouped_cycles(*v.cycles)) + " rev" : std::string{}) + ")</span></span>";
  }
  h += "</div>\n";
  render_cannot_see(d, h);
  h += "<h3>Active alerts</h3>\n";
  if (d.active_alerts.empty()) {
    h += "<p class=\"ok\">No alert is raised.</p>\n";
  } else {
    h += "<ul class=\"active\">\n";
    for (const auto& a : d.active_alerts) {
      const std::string severity = to_string(a.severity.value_or(AlertSeverity::warning));
      h += "<li class=\"sev-" + severity + "\"><strong>" + severity + "</strong> " + to_string(a.kind);
      if (a.channel) h += ", " + html_escape(alert_channel_label(d, a.kind, *a.channel));
      if (!a.subject.empty()) h += " (" + html_escape(a.subject) + ")";
      if (!a.message.empty()) h += ": " + html_escape(a.message);
      else if (!a.value.empty() && a.value != a.subject) h += ": " + html_escape(a.value);
      h += " <span class=\"muted\">raised " + html_escape(a.raised_at) + ", updated " + html_escape(a.updated_at) + "</span></li>\n";
    }
    h += "</ul>\n";
  }
  h += "</header>\n";
}

void render_trends(const ReportData& d, std::string& h) {
  h += "<section id=\"trends\">\n<h2>Trends over the gear pair's life</h2>\n";
  if (d.records.empty()) {
    h += "<p class=\"notice\">This database has no records yet: nothing to plot.</p>\n</section>\n";
    return;
  }
  if (d.gear_pair_number > 1)
    h += "<p class=\"muted\">" + std::to_string(d.total_records - static_cast<std::int64_t>(d.records.size())) +
         " records of earlier gear pairs are not plotted.</p>\n";
  std::size_t without_cycles = 0;
  for (const auto& r : d.records) without_cycles += r.cycles ? 0 : 1;
  if (without_cycles)
    h += "<p class=\"notice\">" + std::to_string(without_cycles) + " records have no cycle count and cannot be placed on the plots.</p>\n";
  h += "<div class=\"key\"><span><span class=\"sw\" style=\"border-color:#d32f2f\"></span>alarm raised</span>"
       "<span><span class=\"sw\" style=\"border-color:#ef6c00\"></span>warning raised</span>"
       "<span><span class=\"sw\" style=\"border-color:#9e9e9e;border-top-style:dashed\"></span>cleared</span>"
       "<span><span class=\"sw\" style=\"border-color:#ef6c00;border-top-style:dotted\"></span>one-off event</span>"
       "<span><span class=\"sw\" style=\"border-color:#2e7d32;border-top-style:dashed\"></span>inspection</span>"
       "<span>Gaps in a line: records not analysed or indicators skipped (why: <em>What was not computed, and why</em>, below). "
       "Hover a point for its record and time.</span></div>\n";
  if (d.channels.empty()) h += "<p class=\"notice\">No record of this gear pair has indicator values yet.</p>\n";
  const auto families = plot_families(d);
  for (const auto channel : d.channels) {
    h += "<h3>" + html_escape(channel_label(d, channel)) + "</h3>\n<div class=\"plots\">\n";
    for (const auto& f : families) {
      const auto plot = make_trend_plot(d, f, channel);
      if (!plot) continue;
      std::size_t values = 0;
      for (const auto& [name, label] : f.series) {
        const auto it = d.values.find({channel, name});
        if (it != d.values.end()) values = std::max(values, it->second.size());
      }
      h += "<figure>" + plot->render("plot-" + f.id + "-ch" + std::to_string(channel)) + "<figcaption>" + std::to_string(values) +
           " records with values";
      if (plot->y_axis().scale == AxisScale::log) h += "; log scale: the values span more than two decades";
      if (const auto n = plot->unplottable_points()) h += "; " + std::to_string(n) + " values ≤ 0 not shown on the log scale";
      h += ".</figcaption></figure>\n";
    }
    h += "</div>\n";
  }
  h += "</section>\n";
}

// Records not analysed, by how they ended (both ends mean: shorter than records.min_length_s).
void render_unanalysed(const ReportData& d, std::string& h) {
  std::map<RecordEnd, std::vector<std::int64_t>> by_end;
  for (const auto& r : d.records)
    if (!r.analysed) by_end[r.end_reason].push_back(r.id);
  if (by_end.empty()) {
    h += "<p>Every record of the gear pair was analysed.</p>\n";
    return;
  }
  h += "<div class=\"scroll\"><table class=\"why unanalysed\">\n<thead><tr><th>record not analysed: ended</th><th>records</th>"
       "<th>which</th></tr></thead>\n<tbody>\n";
  for (const auto& [end, ids] : by_end)
    h += "<tr class=\"unanalysed-row\"><td><code>" + std::string(to_string(end)) + "</code> (shorter than records.min_length_s)</td>" +
         td_num(static_cast<std::int64_t>(ids.size())) + td(record_ranges(ids)) + "</tr>\n";
  h += "</tbody></table></div>\n";
}

// Where the analysed records' shaft angle came from (docs/dsp.md, "Speed from the signal").
void render_speed_sources(const ReportData& d, std::string& h) {
  std::map<dsp::SpeedSource, std::int64_t> counts;
  for (const auto& r : d.records)
    if (r.analysed && r.speed_source) ++counts[*r.speed_source];
  if (counts.empty()) return;
  h += "<p class=\"speed-sources\">Shaft angle of the analysed records from: ";
  bool first = true;
  for (const auto& [source, n] : counts) {
    h += std::string(first ? "" : ", ") + "<code>" + dsp::to_string(source) + "</code> " + std::to_string(n);
    first = false;
  }
  h += ".</p>\n";
}

std::vector<std::int64_t> why_channels(const ReportData& d, const std::vector<ReasonGroup>& groups) {
  std::set<std::int64_t> channels(d.channels.begin(), d.channels.end());
  for (const auto& g : groups) channels.insert(g.channel);
  return {channels.begin(), channels.end()};
}

void render_reason_row(const ReasonGroup& g, std::string& h) {
  const bool skipped = std::holds_alternative<dsp::SkipReason>(g.reason);
  const std::string token = to_string(g.reason);
  std::string indicators;
  for (const auto& name : g.indicators) indicators += (indicators.empty() ? "" : ", ") + name;
  std::string details;
  for (const auto& text : g.details) details += (details.empty() ? "" : "; ") + text;
  if (g.more_details) details += "; and " + std::to_string(g.more_details) + " more";
  h += std::string("<tr class=\"") + (skipped ? "skip-row" : "caveat-row") + "\" data-reason=\"" + token + "\"><td><code>" + token +
       "</code>" + (skipped ? "" : " <span class=\"muted\">(computed)</span>") + "</td>" + td(indicators, "names") +
       td_num(static_cast<std::int64_t>(g.records.size())) + td(record_ranges(g.records)) + td(details.empty() ? "—" : details, "detail") +
       "</tr>\n";
}

void render_why(const ReportData& d, std::string& h) {
  h += "<section id=\"why\">\n<h2>What was not computed, and why</h2>\n";
  if (d.records.empty()) {
    h += "<p>No record yet.</p>\n</section>\n";
    return;
  }
  render_unanalysed(d, h);
  render_speed_sources(d, h);
  const auto groups = reason_groups(d);
  for (const auto channel : why_channels(d, groups)) {
    h += "<h3 id=\"why-ch" + std::to_string(channel) + "\">" + html_escape(channel_label(d, channel)) + "</h3>\n";
    bool any = false;
    for (const auto& g : groups) any = any || g.channel == channel;
    if (!any) {
      h += "<p>Every indicator was computed in every analysed record.</p>\n";
      continue;
    }
    h += "<div class=\"scroll\"><table class=\"why\">\n<thead><tr><th>reason</th><th>indicators</th><th>records</th><th>which records</th>"
         "<th>detail</th></tr></thead>\n<tbody>\n";
    for (const auto& g : groups)
      if (g.channel == channel) render_reason_row(g, h);
    h += "</tbody></table></div>\n";
  }
  h += "<p class=\"muted\">A reason's rows list the indicators skipped for it in exactly the same records; "
       "<em>(computed)</em> marks a caveat of a value that was computed (docs/dsp.md).</p>\n</section>\n";
}

void render_alert_table(const ReportData& d, std::string& h) {
  h += "<section id=\"alert-history\">\n<h2>Alert history</h2>\n";
  if (d.alerts.empty()) {
    h += "<p>No alert has been recorded.</p>\n</section>\n";
    return;
  }
  if (static_cast<std::int64_t>(d.alerts.size()) < d.total_alerts)
    h += "<p class=\"muted\">The " + std::to_string(d.alerts.size()) + " newest of " + std::to_string(d.total_alerts) +
         " (all: <code>gearwatch query alerts</code>).</p>\n";
  h += "<div class=\"scroll\"><table class=\"alerts\">\n<thead><tr><th>time (UTC)</th><th>severity</th><th>kind</th><th>channel</th>"
       "<th>subject</th><th>transition</th><th>value</th><th>record</th><th>message</th></tr></thead>\n<tbody>\n";
  for (const auto& a : d.alerts) {
    h += std::string("<tr class=\"alert-row sev-") + to_string(a.severity) + " trans-" + to_string(a.transition) + "\">";
    h += td_time(a.created_at) + td(to_string(a.severity)) + td(to_string(a.kind)) +
         td(a.channel ? alert_channel_label(d, a.kind, *a.channel) : "—") + td(a.subject) + td(to_string(a.transition)) + td(a.value) +
         td(a.record_id ? std::to_string(*a.record_id) : "—", "num") + td(a.message) + "</tr>\n";
  }
  h += "</tbody></table></div>\n</section>\n";
}

void render_health_table(const ReportData& d, std::string& h) {
  h += "<section id=\"health\">\n<h2>Acquisition health (newest snapshot per run)</h2>\n";
  if (d.health.empty()) {
    h += "<p>No health snapshot yet.</p>\n</section>\n";
    return;
  }
  h += "<div class=\"scroll\"><table class=\"health\">\n<thead><tr><th>run</th><th>kind</th><th>source</th><th>started</th><th>ended</th>"
       "<th>snapshot</th><th>frames</th><th>samples</th><th>lost samples</th><th>kernel drops</th><th>rejected frames</th>"
       "<th>records rejected</th><th>storage rows rejected</th></tr></thead>\n<tbody>\n";
  for (const auto& r : d.health) {
    std::string breakdown;
    for (const auto& [name, n] : r.rejected_breakdown) breakdown += (breakdown.empty() ? "" : ", ") + name + " " + std::to_string(n);
    h += "<tr class=\"health-row\">" + td_num(r.run_id) + td(r.run_kind) + td(r.source, "source") + td_time(r.run_started_at) +
         td_time(r.run_ended_at.empty() ? "running" : r.run_ended_at) + td_time(r.taken_at + (r.final ? " (final)" : "")) + td_num(r.frames) +
         td_num(r.samples) + td_num(r.lost_samples, true) + td_num(r.kernel_drops, true) + "<td class=\"num" +
         (r.rejected_frames ? " bad" : "") + "\" title=\"" + html_escape(breakdown) + "\">" + std::to_string(r.rejected_frames) + "</td>" +
         td_num(r.records_rejected, true) + td_num(r.storage_rows_rejected, true) + "</tr>\n";
  }
  h += "</tbody></table></div>\n<p class=\"muted\">Lost samples = gap_samples + samples lost to ring overflow; rejected frames = malformed "
       "frames and lines, unknown ids, unconfigured channels, frames before the stream header, unsupported versions and duplicates "
       "(hover for the split).</p>\n</section>\n";
}

void render_inspections(const ReportData& d, std::string& h) {
  h += "<section id=\"inspections\">\n<h2>Inspections</h2>\n";
  if (d.inspections.empty()) {
    h += "<p>No inspection recorded (<code>gearwatch inspect</code>).</p>\n</section>\n";
    return;
  }
  h += "<table class=\"inspections\">\n<thead><tr><th>entered (UTC)</th><th>input revolutions</th><th>pitted area</th>"
       "<th>wear depth</th><th>note</th></tr></thead>\n<tbody>\n";
  for (const auto& i : d.inspections) {
    h += "<tr class=\"inspection-row\">" + td(i.entered_at, "time") + td(grouped_cycles(i.cycles), "num") +
         td(i.pitted_area_fraction ? format_number(*i.pitted_area_fraction * 100, 3) + " %" : "—", "num") +
         td(i.wear_depth_m ? format_number(*i.wear_depth_m * 1e6, 3) + " µm" : "—", "num") + td(i.note) + "</tr>\n";
  }
  h += "</tbody></table>\n</section>\n";
}

void render_model(const ReportData& d, std::string& h) {
  h += "<section id=\"model\">\n<h2>Digital twin: wear model</h2>\n"
       "<p class=\"muted\">RMS_SA measured against the twin, wear depth and pitting density with their forecasts, and the "
       "stiffness (K) updates come from the wear model's tables; they are listed here as stored.</p>\n";
  for (const auto& t : d.model_tables) {
    h += "<h3 id=\"model-" + html_escape(t.name) + "\">" + html_escape(t.name) + "</h3>\n";
    if (!t.present) {
      h += "<p class=\"model-missing\">" + html_escape(t.name) + ": not available in this database.</p>\n";
      continue;
    }
    if (t.rows.empty()) {
      h += "<p>" + html_escape(t.name) + ": no rows yet.</p>\n";
      continue;
    }
    if (static_cast<std::int64_t>(t.rows.size()) < t.total_rows)
      h += "<p class=\"muted\">The " + std::to_string(t.rows.size()) + " newest of " + std::to_string(t.total_rows) + " rows.</p>\n";
    h += "<div class=\"scroll\"><table class=\"model\"><thead><tr>";
    for (const auto& c : t.columns) h += "<th>" + html_escape(c) + "</th>";
    h += "</tr></thead>\n<tbody>\n";
    for (const auto& row : t.rows) {
      h += "<tr>";
      for (const auto& cell : row) h += td(cell);
      h += "</tr>\n";
    }
    h += "</tbody></table></div>\n";
  }
  h += "</section>\n";
}

}  // namespace

const char* report_base_style() noexcept { return kStyle; }

std::string render_report_html(const ReportData& d) {
  std::string h;
  h.reserve(1 << 16);
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  // The page loads nothing: the policy makes a browser refuse any request it might contain.
  h += "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'; img-src data:\">\n";
  h += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  h += "<title>Gearbox condition — " + html_escape(d.database) + "</title>\n<style>" + std::string(kStyle) + "</style>\n</head>\n<body>\n<main>\n";
  render_header(d, h);
  if (d.total_records == 0) h += "<p class=\"notice\" id=\"no-records\">This database has no records: nothing has been measured yet.</p>\n";
  render_trends(d, h);
  render_why(d, h);
  render_alert_table(d, h);
  render_health_table(d, h);
  render_inspections(d, h);
  render_model(d, h);
  h += "<footer class=\"muted\"><p>gearwatch report · where each number comes from: docs/report.md</p></footer>\n</main>\n</body>\n</html>\n";
  return h;
}

}  // namespace gearwatch::report
