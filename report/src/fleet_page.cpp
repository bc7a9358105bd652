// The fleet page (fleet_page.hpp): one table, worst first, one row per gearbox.
#include "gearwatch/report/fleet_page.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "gearwatch/report/report_page.hpp"
#include "gearwatch/report/svg_plot.hpp"
#include "gearwatch/types/alerts.hpp"
#include "gearwatch/types/token.hpp"
#include "gearwatch/types/wear_mechanism.hpp"

namespace gearwatch::report {

namespace {

using storage::fleet::GearboxOverview;
using storage::fleet::RemainingLife;

constexpr const char* kFleetStyle = R"CSS(
table.fleet { border-collapse: collapse; width: 100%; table-layout: fixed; }
table.fleet th, table.fleet td { border-bottom: 1px solid #cfd8dc; padding: 6px 8px; vertical-align: top; text-align: left; overflow-wrap: anywhere; }
table.fleet th { background: #eceff1; font-weight: 600; }
table.fleet col.name { width: 15%; } table.fleet col.status { width: 13%; } table.fleet col.verdict { width: 14%; }
table.fleet col.alerts { width: 22%; } table.fleet col.life { width: 16%; } table.fleet col.trend { width: 20%; }
tr.gearbox-row.sev-alarm td:first-child { border-left: 5px solid #d32f2f; }
tr.gearbox-row.sev-warning td:first-child { border-left: 5px solid #ef6c00; }
tr.gearbox-row.sev-info td:first-child, tr.gearbox-row.sev-none td:first-child { border-left: 5px solid #cfd8dc; }
ul.fleet-alerts { list-style: none; margin: 0; padding: 0; }
ul.fleet-alerts li { margin: 0 0 4px; padding: 2px 6px; border-left: 4px solid #90a4ae; }
ul.fleet-alerts li.sev-alarm { border-left-color: #d32f2f; background: #ffebee; }
ul.fleet-alerts li.sev-warning { border-left-color: #ef6c00; background: #fff3e0; }
.state-offline { color: #b71c1c; font-weight: 600; }
.missing { color: #ef6c00; } .lost { color: #b71c1c; }
.mech-wear { font-weight: 600; color: #b71c1c; }
table.fleet svg { width: 100%; height: auto; }
)CSS";

// 0 alarm, 1 warning, 2 info (an unknown token reads as info: the consumer refuses those anyway).
int severity_rank(const std::string& severity) {
  switch (from_token(kAllAlertSeverities, severity).value_or(AlertSeverity::info)) {
    case AlertSeverity::alarm: return 0;
    case AlertSeverity::warning: return 1;
    case AlertSeverity::info: return 2;
  }
  return 2;
}

bool names_wear(const std::string& mechanism) {
  const auto m = from_token(dsp::kAllWearMechanisms, mechanism);
  return m && dsp::is_wear(*m);
}

const char* severity_class(int rank) {
  static constexpr const char* kClass[] = {"sev-alarm", "sev-warning", "sev-info", "sev-none"};
  return kClass[std::clamp(rank, 0, 3)];
}

std::string count_of(std::int64_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

// What did not arrive: holes still asked for, and ranges the gearbox said it cannot send, with why.
std::string render_undelivered(const storage::fleet::UndeliveredMessages& u) {
  std::string h;
  if (u.missing > 0)
    h += "<br><span class=\"missing\">missing " + count_of(u.missing, "message", "messages") + " in " +
         count_of(u.missing_ranges, "range", "ranges") + ", asked for again</span>";
  if (u.lost > 0) {
    std::string why;
    for (const auto reason : u.lost_reasons) why += (why.empty() ? "" : ", ") + std::string(storage::fleet::to_string(reason));
    h += "<br><span class=\"lost\">lost " + count_of(u.lost, "message", "messages") + " in " + count_of(u.lost_ranges, "range", "ranges") +
         " (" + html_escape(why) + ")</span>";
  }
  return h;
}

std::string render_status(const GearboxOverview& g) {
  std::string h = "<td class=\"status\"><span class=\"state-" + html_escape(g.state.empty() ? "unknown" : g.state) + "\">" +
                  html_escape(g.state.empty() ? "no status message yet" : g.state) + "</span>";
  if (!g.version.empty()) h += " <span class=\"muted\">gearwatch " + html_escape(g.version) + "</span>";
  h += "<br><span class=\"muted\">last record " + html_escape(g.last_record_time.value_or("none")) + "</span>";
  return h + render_undelivered(g.undelivered) + "</td>";
}

std::string render_verdicts(const GearboxOverview& g) {
  if (g.verdicts.empty()) return "<td class=\"verdict muted\">no verdict yet</td>";
  std::string h = "<td class=\"verdict\">";
  for (const auto& v : g.verdicts)
    h += "<div>channel " + std::to_string(v.channel) + ": <span class=\"" + (names_wear(v.mechanism) ? "mech-wear" : "mech") + "\">" +
         html_escape(v.mechanism) + "</span></div>";
  return h + "</td>";
}

std::string render_alerts(const GearboxOverview& g) {
  if (g.active_alerts.empty()) return "<td class=\"alerts muted\">none active</td>";
  std::string h = "<td class=\"alerts\"><ul class=\"fleet-alerts\">";
  for (const auto& a : g.active_alerts) {
    h += std::string("<li class=\"") + severity_class(severity_rank(a.severity)) + "\" title=\"" + html_escape(a.message) + "\"><b>" +
         html_escape(a.severity) + "</b> " + html_escape(a.kind);
    if (a.channel) h += " · channel " + std::to_string(*a.channel);
    if (!a.subject.empty()) h += " · " + html_escape(a.subject);
    if (!a.value.empty()) h += " · " + html_escape(a.value);
    h += "<br><span class=\"muted\">since " + html_escape(a.raised_at) + "</span></li>";
  }
  return h + "</ul></td>";
}

std::string render_one_life(const char* mode, const RemainingLife& l) {
  std::string h = std::string("<div class=\"life-") + mode + "\">" + mode + ": ";
  if (!l.cycles_left) return h + "<span class=\"muted\">beyond the horizon</span></div>";
  h += "<b>" + format_cycles(*l.cycles_left) + "</b> cycles";
  if (l.cycles_left_low && l.cycles_left_high)
    h += " <span class=\"muted\">(" + format_cycles(*l.cycles_left_low) + " – " + format_cycles(*l.cycles_left_high) + ")</span>";
  return h + "</div>";
}

std::string render_life(const GearboxOverview& g) {
  if (!g.cycles) return "<td class=\"life muted\">no model run</td>";
  std::string h = "<td class=\"life\">";
  if (!g.forecast_valid) {
    h += "<div class=\"muted\">no forecast: " + html_escape(g.forecast_failure.empty() ? "not valid" : g.forecast_failure) + "</div>";
  } else {
    h += render_one_life("pitting", g.pitting) + render_one_life("wear", g.wear);
  }
  h += "<div class=\"muted\">at " + format_cycles(*g.cycles) + " cycles";
  if (g.wear_max_depth_m) {
    char buf[64];
    std::snprintf(buf, sizeof buf, " · depth %.2f µm", *g.wear_max_depth_m * 1e6);
    h += buf;
  }
  if (g.pitting_mean) {
    char buf[64];
    std::snprintf(buf, sizeof buf, " · pitting %.1f %%", *g.pitting_mean * 100.0);
    h += buf;
  }
  return h + "</div></td>";
}

std::string render_trend(const GearboxOverview& g, const storage::fleet::OverviewRequest& q) {
  if (g.trend.empty()) return "<td class=\"trend muted\">no values</td>";
  PlotSeries s{q.trend_indicator, "", "#1565c0", {}, true};
  std::vector<double> xs, ys;
  for (const auto& p : g.trend) {
    const double x = p.cycles.value_or(static_cast<double>(p.record_id));
    s.points.push_back({x, p.value, "record " + std::to_string(p.record_id)});
    xs.push_back(x);
    ys.push_back(p.value);
  }
  // The axes' names are in the page's header (one for every row): the small plot keeps its ticks.
  SvgPlot plot("", fit_axis(xs, "", false), fit_axis(ys, "", false), SvgPlot::Layout{260, 110, 44, 18, 8, 22});
  plot.add_series(std::move(s));
  return "<td class=\"trend\">" + plot.render("trend-" + g.site + "-" + g.gearbox) + "</td>";
}

// The row's colour: its most severe active alert, info included.
int row_rank(const GearboxOverview& g) {
  int rank = 3;
  for (const auto& a : g.active_alerts) rank = std::min(rank, severity_rank(a.severity));
  return rank;
}

std::string render_row(const GearboxOverview& g, const storage::fleet::OverviewRequest& q) {
  return std::string("<tr class=\"gearbox-row ") + severity_class(row_rank(g)) + "\" data-gearbox=\"" + html_escape(g.site + "/" + g.gearbox) +
         "\"><td class=\"name\"><b>" + html_escape(g.gearbox) + "</b><br><span class=\"muted\">" + html_escape(g.site) + "</span></td>" +
         render_status(g) + render_verdicts(g) + render_alerts(g) + render_life(g) + render_trend(g, q) + "</tr>\n";
}

}  // namespace

FleetUrgency urgency_of(const GearboxOverview& g) {
  FleetUrgency u;
  u.alert_rank = std::min(2, row_rank(g));
  for (const auto& v : g.verdicts)
    if (names_wear(v.mechanism)) u.verdict_rank = 0;
  if (g.forecast_valid)
    for (const auto* life : {&g.wear, &g.pitting})
      if (life->cycles_left) u.shortest_life = std::min(u.shortest_life, *life->cycles_left);
  if (g.state == "offline") u.offline_rank = 0;
  return u;
}

std::vector<GearboxOverview> worst_first(std::vector<GearboxOverview> gearboxes) {
  // Each gearbox's urgency once, then a stable sort of the indices by it.
  std::vector<std::pair<FleetUrgency, std::size_t>> keyed;
  for (std::size_t i = 0; i < gearboxes.size(); ++i) keyed.emplace_back(urgency_of(gearboxes[i]), i);
  std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first.key() < b.first.key(); });
  std::vector<GearboxOverview> out;
  out.reserve(gearboxes.size());
  for (const auto& [urgency, i] : keyed) out.push_back(std::move(gearboxes[i]));
  return out;
}

std::string format_cycles(double cycles) {
  char buf[48];
  const double a = std::fabs(cycles);
  if (a >= 1e9) std::snprintf(buf, sizeof buf, "%.3g G", cycles / 1e9);
  else if (a >= 1e6) std::snprintf(buf, sizeof buf, "%.3g M", cycles / 1e6);
  else if (a >= 1e4) std::snprintf(buf, sizeof buf, "%.3g k", cycles / 1e3);
  else std::snprintf(buf, sizeof buf, "%.0f", cycles);
  return buf;
}

std::string render_fleet_page_html(const FleetPageData& d) {
  const auto boxes = worst_first(d.gearboxes);
  std::size_t alarmed = 0, wearing = 0, offline = 0, undelivered = 0;
  for (const auto& g : boxes) {
    const auto u = urgency_of(g);
    alarmed += u.alert_rank <= 1;
    wearing += u.verdict_rank == 0;
    offline += u.offline_rank == 0;
    undelivered += g.undelivered.missing > 0 || g.undelivered.lost > 0;
  }
  std::string h;
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  h += "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'; img-src data:\">\n";
  h += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  h += "<title>Fleet — " + html_escape(d.database) + "</title>\n<style>" + std::string(report_base_style()) + kFleetStyle +
       "</style>\n</head>\n<body>\n<main>\n";
  h += "<header class=\"summary\">\n<h1>Fleet: every gearbox, worst first</h1>\n<dl class=\"facts\">\n";
  h += "<dt>database</dt><dd>" + html_escape(d.database) + "</dd>\n<dt>written</dt><dd>" + html_escape(d.generated_at) + "</dd>\n";
  h += "<dt>gearboxes</dt><dd id=\"fleet-counts\">" + std::to_string(boxes.size()) + " · " + std::to_string(alarmed) +
       " with a warning or alarm · " + std::to_string(wearing) + " with wear under way · " + std::to_string(offline) + " offline · " + std::to_string(undelivered) +
       " with messages missing or lost</dd>\n";
  h += "<dt>trend</dt><dd>" + html_escape(d.trend.trend_indicator) + ", channel " + std::to_string(d.trend.trend_channel) + ", the newest " +
       std::to_string(d.trend.trend_points) + " records, against input revolutions (the record's id where a record has none)</dd>\n"
       "</dl>\n</header>\n";
  if (boxes.empty()) {
    h += "<p class=\"notice\" id=\"no-gearboxes\">The fleet database knows no gearbox yet: nothing has been published to it.</p>\n";
  } else {
    h += "<table class=\"fleet\"><colgroup><col class=\"name\"><col class=\"status\"><col class=\"verdict\"><col class=\"alerts\">"
         "<col class=\"life\"><col class=\"trend\"></colgroup>\n<thead><tr><th>gearbox</th><th>status</th><th>wear verdict</th>"
         "<th>active alerts</th><th>remaining life (90 % interval)</th><th>trend</th></tr></thead>\n<tbody>\n";
    for (const auto& g : boxes) h += render_row(g, d.trend);
    h += "</tbody></table>\n";
  }
  h += "<footer class=\"muted\"><p>gearwatch fleet report · order and columns: docs/fleet.md</p></footer>\n</main>\n</body>\n</html>\n";
  return h;
}

}  // namespace gearwatch::report
