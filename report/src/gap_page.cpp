#include "gearwatch/report/gap_page.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <tuple>

#include "gearwatch/report/report_page.hpp"
#include "gearwatch/report/svg_plot.hpp"

namespace gearwatch::report {
namespace {

using gap::FamilyGap;
using gap::FamilyKind;
using gap::GapReport;

std::string fmt(const char* format, double v) {
  if (!std::isfinite(v)) return "—";
  char b[64];
  std::snprintf(b, sizeof b, format, v);
  return b;
}
std::string db_text(double v) { return fmt("%.2f dB", v); }
std::string percent(double fraction) { return fmt("%.1f %%", 100.0 * fraction); }
std::string interval_text(const gap::Interval& i) { return "[" + fmt("%.2f", i.low) + ", " + fmt("%.2f", i.high) + "]"; }

// One colour per family, the same in the bar chart's labels and the spectra's shading.
const char* family_colour(FamilyKind f) {
  switch (f) {
    case FamilyKind::input_shaft_orders: return "#8e24aa";
    case FamilyKind::output_shaft_orders: return "#3949ab";
    case FamilyKind::mesh_harmonics: return "#00897b";
    case FamilyKind::input_sidebands: return "#7cb342";
    case FamilyKind::output_sidebands: return "#fdd835";
    case FamilyKind::fixed_frequency: return "#fb8c00";
    case FamilyKind::broadband: return "#90a4ae";
  }
  return "#90a4ae";
}

constexpr const char* kMeasuredColour = "#212121";
constexpr const char* kFeatureColour = "#ef6c00";
constexpr const char* kTwinColour = "#1e88e5";
constexpr const char* kAfterColour = "#e53935";
constexpr const char* kBeforeBar = "#78909c";
constexpr const char* kAfterBar = "#43a047";

const FamilyGap* find_gap(const std::vector<FamilyGap>& list, FamilyKind f) {
  for (const auto& g : list)
    if (g.family == f) return &g;
  return nullptr;
}

// The chosen effects that can act on a family: the attribution of its gap.
std::vector<gap::CandidateEffect> attribution(const GapReport& r, FamilyKind f) {
  std::vector<gap::CandidateEffect> out;
  for (const auto effect : r.chosen)
    for (const auto& c : r.candidates)
      if (c.effect == effect && std::find(c.explains.begin(), c.explains.end(), f) != c.explains.end()) {
        out.push_back(effect);
        break;
      }
  return out;
}

bool is_unexplained(const GapReport& r, FamilyKind f) {
  return std::find(r.unexplained.begin(), r.unexplained.end(), f) != r.unexplained.end();
}

template <class List, class Name>
std::string joined(const List& list, Name&& name, const char* empty = "none") {
  std::string out;
  for (const auto& v : list) out += (out.empty() ? "" : ", ") + std::string(name(v));
  return out.empty() ? empty : out;
}

std::vector<FamilyKind> families_of(const GapReport& r) {
  std::vector<FamilyKind> out;
  for (const auto& g : r.before) out.push_back(g.family);
  for (const auto& g : r.after)
    if (std::find(out.begin(), out.end(), g.family) == out.end()) out.push_back(g.family);
  return out;
}

void render_header(const GapPageData& d, const storage::StoredGapReport& s, std::string& h) {
  const GapReport& r = s.report;
  std::size_t significant = 0, significant_after = 0;
  for (const auto& g : r.before) significant += g.significant ? 1 : 0;
  for (const auto& g : r.after) significant_after += g.significant ? 1 : 0;
  h += "<header class=\"summary\">\n<h1>Sim-to-real gap: where the twin disagrees with the gearbox</h1>\n<dl class=\"facts\">\n";
  h += "<dt>database</dt><dd>" + html_escape(d.database) + "</dd>\n";
  h += "<dt>page written</dt><dd>" + html_escape(d.generated_at) + "</dd>\n";
  h += "<dt>newest report</dt><dd id=\"report-id\">#" + std::to_string(s.id) + " of " + std::to_string(d.total_reports) + ", stored " +
       html_escape(s.created_at) + (s.context.record_id ? ", after record " + std::to_string(*s.context.record_id) : "") +
       ", gear pair #" + std::to_string(s.context.gear_pair) + "</dd>\n";
  h += "<dt>life position</dt><dd>" + fmt("%.0f", r.input_revolutions) + " input revolutions</dd>\n";
  h += "<dt>speeds</dt><dd>" + joined(r.speeds_hz, [](double v) { return fmt("%.3g Hz", v); }) + "</dd>\n";
  h += "<dt>records</dt><dd>" + std::to_string(r.training_records) + " training (candidates fitted), " +
       std::to_string(r.held_out_records) + " held out (gaps scored)</dd>\n";
  h += "<dt>significant families</dt><dd>" + std::to_string(significant) + " with the twin alone, " + std::to_string(significant_after) +
       " with the chosen effects</dd>\n";
  h += "<dt>chosen effects</dt><dd id=\"chosen\">" + html_escape(joined(r.chosen, [](auto e) { return gap::to_string(e); })) + "</dd>\n";
  h += "<dt>unexplained</dt><dd id=\"unexplained\">" +
       html_escape(joined(r.unexplained, [](auto f) { return gap::to_string(f); })) + "</dd>\n";
  std::string k = r.k_wear_before ? fmt("%.4g", *r.k_wear_before) + " m²/N with the twin alone" : std::string("not inferred");
  if (r.k_wear_after) {
    k += " → " + fmt("%.4g", *r.k_wear_after) + " m²/N with the chosen effects";
    if (r.k_wear_before && *r.k_wear_before != 0)
      k += " (" + fmt("%+.1f %%", 100.0 * (*r.k_wear_after / *r.k_wear_before - 1.0)) + ")";
  }
  h += "<dt>K_wear</dt><dd id=\"k-wear\">" + html_escape(k) + "</dd>\n</dl>\n";
  if (d.active_drift.empty()) {
    h += "<p class=\"ok\" id=\"drift\">No twin_drift alert is raised.</p>\n";
  } else {
    h += "<h3>twin_drift alerts raised now</h3>\n<ul class=\"active\" id=\"drift\">\n";
    for (const auto& a : d.active_drift)
      h += "<li class=\"sev-warning drift-alert\"><b>" + html_escape(a.family) + "</b> " + html_escape(a.value) + " since " +
           html_escape(a.raised_at) + ": " + html_escape(a.message) + "</li>\n";
    h += "</ul>\n";
  }
  h += "</header>\n";
}

void render_family_table(const GapReport& r, std::string& h) {
  h += "<h2 id=\"families\">Gap per family, held out: twin alone and with the chosen effects</h2>\n";
  h += "<p class=\"muted\">Distance: RMS over the family's lines or bins of 10·log10(P<sub>measured</sub>/P<sub>model</sub>); "
       "interval: the 90 % spread of a block bootstrap over revolutions, placed on the distance; "
       "share: of the measured-vs-model energy difference; significant: beyond what the bootstrap allows for no gap.</p>\n";
  h += "<div class=\"scroll\"><table class=\"families\">\n<thead><tr><th>family</th><th>distance before</th><th>interval</th>"
       "<th>share</th><th>significant</th><th>distance after</th><th>interval</th><th>share</th><th>significant</th><th>change</th>"
       "<th>attribution</th></tr></thead>\n<tbody>\n";
  for (const FamilyKind f : families_of(r)) {
    const FamilyGap* b = find_gap(r.before, f);
    const FamilyGap* a = find_gap(r.after, f);
    const bool resolved = (b ? b->resolved : true) && (a ? a->resolved : true);
    h += std::string("<tr class=\"family-row") + (b && b->significant ? " significant" : "") + "\" data-family=\"" + gap::to_string(f) +
         "\"><td><span class=\"swatch\" style=\"background:" + family_colour(f) + "\"></span>" + gap::to_string(f) + "</td>";
    if (!resolved) {
      const std::string reason = b && !b->unresolved_reason.empty() ? b->unresolved_reason : (a ? a->unresolved_reason : "");
      h += "<td colspan=\"10\" class=\"muted\">not resolved: " + html_escape(reason) + "</td></tr>\n";
      continue;
    }
    auto cells = [&](const FamilyGap* g) {
      if (!g) return std::string("<td>—</td><td></td><td></td><td></td>");
      return "<td class=\"num\">" + db_text(g->distance_db) + "</td><td class=\"num\">" + interval_text(g->distance_interval_db) +
             "</td><td class=\"num\">" + percent(g->energy_share) + "</td><td>" + (g->significant ? "<b>yes</b>" : "no") + "</td>";
    };
    h += cells(b) + cells(a);
    std::string change = "—";
    if (a && b && std::isfinite(a->distance_db) && std::isfinite(b->distance_db) && b->distance_db != 0)
      change = fmt("%+.1f %%", 100.0 * (std::fabs(a->distance_db) / std::fabs(b->distance_db) - 1.0));
    h += "<td class=\"num\">" + change + "</td>";
    const auto by = attribution(r, f);
    std::string attributed;
    if (!by.empty()) attributed = joined(by, [](auto e) { return gap::to_string(e); });
    else if (is_unexplained(r, f)) attributed = "<span class=\"unexplained\">unexplained: no candidate explains it</span>";
    else attributed = b && b->significant ? "—" : "no significant gap";
    h += "<td>" + attributed + "</td></tr>\n";
  }
  h += "</tbody></table></div>\n";
}

// Grouped bars with the bootstrap intervals as whiskers: before (twin alone) and after (chosen effects).
void render_bar_chart(const GapReport& r, std::string& h) {
  const auto families = families_of(r);
  double lo = 0, hi = 0;
  for (const auto* list : {&r.before, &r.after})
    for (const auto& g : *list) {
      if (!g.resolved) continue;
      for (double v : {g.distance_db, g.distance_interval_db.low, g.distance_interval_db.high})
        if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
    }
  if (!(hi > lo)) hi = lo + 1;
  const auto ticks = linear_ticks(lo, hi, 6);
  lo = std::min(lo, ticks.values.front());
  hi = std::max(hi, ticks.values.back());
  const double width = 1180, height = 320, left = 70, right = 16, top = 42, bottom = 70;
  const double plot_w = width - left - right, plot_h = height - top - bottom;
  auto y_px = [&](double v) { return top + (hi - v) / (hi - lo) * plot_h; };
  auto c = [](double v) { return fmt("%.2f", v); };
  std::string s = "<svg class=\"plot gap-bars\" id=\"gap-bars\" viewBox=\"0 0 " + c(width) + " " + c(height) + "\" width=\"" + c(width) +
                  "\" height=\"" + c(height) + "\" role=\"img\" aria-label=\"gap per family before and after\">\n";
  s += "<text class=\"plot-title\" x=\"" + c(left) + "\" y=\"16\">Held-out gap per family (bars: distance, whiskers: 90 % interval)</text>\n";
  s += "<g class=\"legend\"><rect x=\"" + c(left) + "\" y=\"24\" width=\"14\" height=\"10\" fill=\"" + kBeforeBar +
       "\"/><text class=\"legend\" x=\"" + c(left + 20) + "\" y=\"33\">twin alone</text><rect x=\"" + c(left + 110) +
       "\" y=\"24\" width=\"14\" height=\"10\" fill=\"" + kAfterBar + "\"/><text class=\"legend\" x=\"" + c(left + 130) +
       "\" y=\"33\">twin + chosen effects</text><text class=\"legend\" x=\"" + c(left + 290) + "\" y=\"33\">* significant</text></g>\n";
  s += "<rect class=\"frame\" x=\"" + c(left) + "\" y=\"" + c(top) + "\" width=\"" + c(plot_w) + "\" height=\"" + c(plot_h) + "\"/>\n";
  s += "<g class=\"y-axis\">";
  for (double v : ticks.values) {
    s += "<line class=\"grid\" x1=\"" + c(left) + "\" y1=\"" + c(y_px(v)) + "\" x2=\"" + c(left + plot_w) + "\" y2=\"" + c(y_px(v)) + "\"/>";
    s += "<text class=\"tick\" x=\"" + c(left - 6) + "\" y=\"" + c(y_px(v) + 4) + "\" text-anchor=\"end\">" +
         html_escape(format_linear_tick(v, ticks)) + "</text>";
  }
  s += "<text class=\"axis-label\" transform=\"translate(14 " + c(top + plot_h / 2) +
       ") rotate(-90)\" text-anchor=\"middle\">distance (dB)</text></g>\n";
  s += "<line class=\"zero\" x1=\"" + c(left) + "\" y1=\"" + c(y_px(0)) + "\" x2=\"" + c(left + plot_w) + "\" y2=\"" + c(y_px(0)) +
       "\" stroke=\"#455a64\"/>\n";
  const double slot = plot_w / static_cast<double>(std::max<std::size_t>(families.size(), 1));
  const double bar = std::min(36.0, slot * 0.3);
  for (std::size_t i = 0; i < families.size(); ++i) {
    const FamilyKind f = families[i];
    const double centre = left + slot * (static_cast<double>(i) + 0.5);
    s += std::string("<g class=\"family\" data-family=\"") + gap::to_string(f) + "\">";
    int k = 0;
    for (const auto& [g, colour, stage] : {std::make_tuple(find_gap(r.before, f), kBeforeBar, "before"),
                                           std::make_tuple(find_gap(r.after, f), kAfterBar, "after")}) {
      const double x = centre + (k++ == 0 ? -bar - 2 : 2);
      if (!g || !g->resolved || !std::isfinite(g->distance_db)) continue;
      const double y0 = y_px(std::max(0.0, g->distance_db)), y1 = y_px(std::min(0.0, g->distance_db));
      const std::string title = std::string(gap::to_string(f)) + ", " + (std::string(stage) == "before" ? "twin alone" : "with the chosen effects") +
                                ": " + db_text(g->distance_db) + " " + interval_text(g->distance_interval_db) +
                                (g->significant ? ", significant" : "");
      s += "<rect class=\"bar " + std::string(stage) + "\" x=\"" + c(x) + "\" y=\"" + c(y0) + "\" width=\"" + c(bar) + "\" height=\"" +
           c(std::max(y1 - y0, 0.5)) + "\" fill=\"" + colour + "\"><title>" + html_escape(title) + "</title></rect>";
      const double wx = x + bar / 2;
      const double wl = y_px(g->distance_interval_db.low), wh = y_px(g->distance_interval_db.high);
      if (std::isfinite(wl) && std::isfinite(wh))
        s += "<path class=\"whisker\" d=\"M" + c(wx) + " " + c(wl) + "V" + c(wh) + "M" + c(wx - 5) + " " + c(wl) + "h10M" + c(wx - 5) + " " +
             c(wh) + "h10\" stroke=\"#263238\" fill=\"none\"/>";
      if (g->significant)
        s += "<text class=\"sig\" x=\"" + c(wx) + "\" y=\"" + c(std::min(wh, y0) - 4) + "\" text-anchor=\"middle\">*</text>";
    }
    const FamilyGap* b = find_gap(r.before, f);
    s += "<text class=\"tick family-label\" x=\"" + c(centre) + "\" y=\"" + c(top + plot_h + 16) + "\" text-anchor=\"middle\" fill=\"" +
         family_colour(f) + "\">" + gap::to_string(f) + "</text>";
    const char* note = b && !b->resolved ? "not resolved" : is_unexplained(r, f) ? "unexplained" : nullptr;
    if (note)
      s += "<text class=\"tick\" x=\"" + c(centre) + "\" y=\"" + c(top + plot_h + 30) + "\" text-anchor=\"middle\">" + note + "</text>";
    s += "</g>\n";
  }
  s += "</svg>\n";
  h += "<figure>" + s + "</figure>\n";
}

void render_candidates(const GapReport& r, std::string& h) {
  h += "<h2 id=\"attribution\">Attribution: which effect, and the evidence</h2>\n";
  h += "<p>Chosen, in the order of the greedy addition: <b>" + html_escape(joined(r.chosen, [](auto e) { return gap::to_string(e); })) +
       "</b>. Families no candidate explains: <b>" + html_escape(joined(r.unexplained, [](auto f) { return gap::to_string(f); })) +
       "</b>.</p>\n";
  h += "<p class=\"muted\">Each candidate is fitted on the training records and scored on the held-out ones. Shrinkage: 1 − after/before "
       "of the distance in its own families; information criterion: held-out fit penalised by the parameter count (lower is better); "
       "worsens: helps its own families but pushes another beyond its interval.</p>\n";
  h += "<div class=\"scroll\"><table class=\"candidates\">\n<thead><tr><th>rank</th><th>effect</th><th>explains</th><th>shrinkage</th>"
       "<th>information criterion</th><th>worsens another family</th><th>fitted parameters</th><th>chosen</th></tr></thead>\n<tbody>\n";
  for (std::size_t i = 0; i < r.candidates.size(); ++i) {
    const auto& c = r.candidates[i];
    const auto step = std::find(r.chosen.begin(), r.chosen.end(), c.effect);
    std::string params;
    for (const auto& [name, value] : c.parameters) params += (params.empty() ? "" : "; ") + html_escape(name) + " = " + fmt("%.6g", value);
    std::string worse = "no";
    if (c.worsens_other_family) {
      worse = "<b class=\"worse\">yes</b>";
      std::string which;
      for (const auto& g : c.held_out_after) {
        const FamilyGap* b = find_gap(r.before, g.family);
        if (b && g.resolved && b->resolved && std::fabs(g.distance_db) > std::fabs(b->distance_db) &&
            std::find(c.explains.begin(), c.explains.end(), g.family) == c.explains.end())
          which += (which.empty() ? "" : ", ") + std::string(gap::to_string(g.family)) + " " + db_text(b->distance_db) + " → " +
                   db_text(g.distance_db);
      }
      if (!which.empty()) worse += " (" + html_escape(which) + ")";
    }
    for (const auto& b : c.at_bounds)
      params += std::string(params.empty() ? "" : "; ") + "<b class=\"at-bound\">at a bound: " + html_escape(gap::describe(c.effect, b)) + "</b>";
    h += std::string("<tr class=\"candidate-row") + (step != r.chosen.end() ? " chosen" : "") + "\" data-effect=\"" + gap::to_string(c.effect) +
         "\"><td class=\"num\">" + std::to_string(i + 1) + "</td><td>" + gap::to_string(c.effect) + "</td><td>" +
         html_escape(joined(c.explains, [](auto f) { return gap::to_string(f); })) + "</td><td class=\"num\">" + percent(c.shrinkage) +
         "</td><td class=\"num\">" + fmt("%.4g", c.information_criterion) + "</td><td>" + worse + "</td><td>" +
         (params.empty() ? "—" : params) + "</td><td>" +
         (step != r.chosen.end() ? "step " + std::to_string(step - r.chosen.begin() + 1) : std::string("—")) + "</td></tr>\n";
  }
  if (r.candidates.empty()) h += "<tr><td colspan=\"8\" class=\"muted\">no candidate was scored</td></tr>\n";
  h += "</tbody></table></div>\n";
}

/// Where a feature sits on the plotted record's axes (the record at `speed_hz`): in input orders and
/// in Hz. A feature fixed in Hz is at its Hz, one fixed in orders at its sightings' mean input order
/// (the sightings count input orders whatever its shaft); otherwise at the sighting nearest that speed.
std::pair<double, double> feature_position(const gap::GapFeature& f, double speed_hz) {
  if (f.seen_in.empty()) return {f.hz / speed_hz, f.hz};
  if (f.movement == gap::FeatureMovement::fixed_in_hz) return {f.hz / speed_hz, f.hz};
  if (f.movement == gap::FeatureMovement::fixed_in_orders) {
    double order = 0;
    for (const auto& s : f.seen_in) order += s.order / static_cast<double>(f.seen_in.size());
    return {order, order * speed_hz};
  }
  const gap::FeatureSighting* nearest = &f.seen_in.front();
  for (const auto& s : f.seen_in)
    if (std::fabs(s.speed_hz - speed_hz) < std::fabs(nearest->speed_hz - speed_hz)) nearest = &s;
  return {nearest->order, nearest->hz};
}

std::string feature_label(std::size_t i) { return "F" + std::to_string(i + 1); }

std::string spectrum_plot(const std::string& title, const std::string& x_label, const std::vector<double>& axis,
                          const std::vector<double>& measured, const std::vector<double>& twin, const std::vector<double>& after,
                          const std::vector<std::pair<FamilyKind, gap::Interval>>& bands, const std::string& id, const std::string& unit,
                          const std::vector<std::pair<double, std::string>>& marks = {}) {
  std::vector<double> all;
  for (const auto* v : {&measured, &twin, &after}) all.insert(all.end(), v->begin(), v->end());
  Axis x = fit_axis(axis, x_label, false);
  if (!axis.empty()) x.lo = axis.front(), x.hi = axis.back();
  if (!(x.hi > x.lo)) x = fit_axis(axis, x_label, false);
  SvgPlot::Layout layout;
  layout.width = 1180;
  layout.height = 320;
  SvgPlot plot(title, x, fit_axis(all, "level (dB)", false), layout);
  for (const auto& [family, interval] : bands)
    plot.add_band(PlotBand{interval.low, interval.high, std::string("family ") + gap::to_string(family),
                           std::string(family_colour(family)),
                           std::string(gap::to_string(family)) + ": " + fmt("%.4g", interval.low) + " to " + fmt("%.4g", interval.high) + " " + unit});
  auto series = [&](const char* name, const char* label, const char* colour, const std::vector<double>& values) {
    if (values.size() != axis.size() || values.empty()) return;
    PlotSeries s{name, label, colour, {}, false};
    for (std::size_t i = 0; i < axis.size(); ++i) s.points.push_back({axis[i], values[i], {}});
    plot.add_series(std::move(s));
  };
  series("measured", "measured", kMeasuredColour, measured);
  series("twin", "twin alone", kTwinColour, twin);
  series("twin_after", "twin + chosen effects", kAfterColour, after);
  for (const auto& [x, title_text] : marks)
    if (!axis.empty() && x >= axis.front() && x <= axis.back()) plot.add_event(EventLine{x, "feature", kFeatureColour, title_text});
  return plot.render(id);
}

void render_spectra(const GapReport& r, std::string& h) {
  h += "<h2 id=\"spectra\">Spectra of a held-out record: measured, twin, twin with the chosen effects</h2>\n";
  h += "<div class=\"key\">";
  for (const FamilyKind f : gap::kAllFamilyKinds)
    h += std::string("<span><span class=\"swatch\" style=\"background:") + family_colour(f) + "\"></span>" + gap::to_string(f) + "</span>";
  h += "</div>\n";
  bool any = false;
  // Each feature marked where it sits on the plotted record (its speed: Hz over order on the axes).
  std::vector<std::pair<double, std::string>> order_marks, hz_marks;
  if (!r.order_axis.empty() && !r.hz_axis.empty() && r.order_axis.front() > 0) {
    const double speed = r.hz_axis.front() / r.order_axis.front();
    for (std::size_t i = 0; i < r.features.size(); ++i) {
      const auto [order, hz] = feature_position(r.features[i], speed);
      const std::string title = feature_label(i) + ": " + gap::describe(r.features[i]) + "; " + gap::statement(r.features[i]);
      order_marks.emplace_back(order, title);
      hz_marks.emplace_back(hz, title);
    }
  }
  if (!r.order_axis.empty()) {
    h += "<figure>" + spectrum_plot("In orders of the input shaft: lines that move with speed", "input-shaft order", r.order_axis,
                                    r.measured_order_db, r.twin_order_db, r.twin_after_order_db, r.order_bands, "spectrum-orders", "orders",
                                    order_marks) +
         "<figcaption>Shaded: where each family lies in orders. Orange lines: the features (hover: which).</figcaption></figure>\n";
    any = true;
  }
  if (!r.hz_axis.empty()) {
    h += "<figure>" + spectrum_plot("In Hz: resonances that stay put across speeds", "frequency (Hz)", r.hz_axis, r.measured_hz_db,
                                    r.twin_hz_db, r.twin_after_hz_db, r.hz_bands, "spectrum-hz", "Hz", hz_marks) +
         "<figcaption>Shaded: where each family lies in Hz. Orange lines: the features (hover: which).</figcaption></figure>\n";
    any = true;
  }
  if (!any) h += "<p class=\"notice\">This report carries no spectra to plot.</p>\n";
}

// The gaps at the resolution of a line or a band, largest first (docs/gap.md, "Features").
void render_features(const GapReport& r, std::string& h) {
  h += "<h2 id=\"features\">Features: single lines and bands off the twin</h2>\n";
  h += "<p class=\"muted\">Every line and broadband bin of every record (training and held out) against the twin alone; significant "
       "over all of them (Benjamini–Hochberg, false discovery rate 5 %) and at least the practical minimum; adjacent bins merged, "
       "records joined where the feature sits at one order or one Hz. Movement: whether it stays at one order or one frequency "
       "across the records' speeds. Size: 10·log10(measured/twin) at its largest bin, mean over the records, 90 % interval. "
       "What it is: the physical candidate that explains it (or none), and the form that describes it with its parameters.</p>\n";
  h += "<div class=\"scroll\"><table class=\"features\">\n<thead><tr><th>feature</th><th>where</th><th>movement</th><th>order</th>"
       "<th>Hz</th><th>band (Hz)</th><th>size</th><th>interval</th><th>seen in</th><th>what it is</th></tr></thead>\n<tbody>\n";
  for (std::size_t i = 0; i < r.features.size(); ++i) {
    const auto& f = r.features[i];
    std::string seen;
    for (const auto& w : f.seen_in)
      seen += (seen.empty() ? "" : ", ") + std::string(w.held_out ? "held-out " : "training ") + std::to_string(w.record) + " (" +
              fmt("%.2f Hz", w.speed_hz) + ", " + fmt("%+.1f dB", w.size_db) + ")";
    const bool in_hz = f.movement == gap::FeatureMovement::fixed_in_hz;
    h += std::string("<tr class=\"feature-row\" data-movement=\"") + gap::to_string(f.movement) + "\"><td>" + feature_label(i) +
         "</td><td>" + (in_hz ? fmt("%.1f Hz", f.hz) : std::string(gap::to_string(f.shaft)) + fmt(" order %.2f", f.order)) + "</td><td>" +
         gap::to_string(f.movement) + "</td><td class=\"num\">" + fmt("%.2f", f.order) + " (" + gap::to_string(f.shaft) +
         ")</td><td class=\"num\">" + fmt("%.1f", f.hz) + "</td><td class=\"num\">" + fmt("%.1f", f.hz_low) + "–" +
         fmt("%.1f", f.hz_high) + "</td><td class=\"num\">" + fmt("%+.2f dB", f.size_db) + "</td><td class=\"num\">" +
         interval_text(f.size_interval_db) + "</td><td>" + html_escape(seen) + "</td><td class=\"what\">" + html_escape(gap::statement(f)) +
         "</td></tr>\n";
  }
  if (r.features.empty())
    h += "<tr><td colspan=\"10\" class=\"muted\">none: no line or band is off the twin beyond its noise and the practical minimum</td></tr>\n";
  h += "</tbody></table></div>\n";
}

// Each family's gap with the twin alone over the pair's life: when the twin began to drift.
void render_trend(const GapPageData& d, std::string& h) {
  if (d.reports.size() < 2) return;
  std::vector<double> xs, ys;
  std::map<FamilyKind, PlotSeries> series;
  for (const auto& s : d.reports) {
    xs.push_back(s.report.input_revolutions);
    for (const auto& g : s.report.before) {
      PlotSeries& line = series[g.family];
      const double y = g.resolved ? g.distance_db : std::nan("");
      line.points.push_back({s.report.input_revolutions, y,
                             std::string(gap::to_string(g.family)) + " at " + fmt("%.6g", s.report.input_revolutions) + " cycles: " +
                                 (g.resolved ? db_text(g.distance_db) + " " + interval_text(g.distance_interval_db) +
                                                   (g.significant ? ", significant" : "")
                                             : "not resolved")});
      if (std::isfinite(y)) ys.push_back(y);
    }
  }
  if (ys.empty()) return;
  SvgPlot::Layout layout;
  layout.width = 1180;
  layout.height = 300;
  SvgPlot plot("Gap per family with the twin alone, report by report", fit_axis(xs, "input revolutions", false),
               fit_axis(ys, "distance (dB)", false), layout);
  for (auto& [family, line] : series) {
    if (std::none_of(line.points.begin(), line.points.end(), [](const PlotPoint& p) { return std::isfinite(p.y); })) continue;
    line.name = gap::to_string(family);
    line.label = gap::to_string(family);
    line.colour = family_colour(family);
    plot.add_series(std::move(line));
  }
  h += "<h2 id=\"trend\">Gap over life</h2>\n<figure>" + plot.render("gap-trend") +
       "<figcaption>Hover a point for its interval and significance. A family that rises and stays up is a drift of the twin "
       "(the twin_drift alert).</figcaption></figure>\n";
}

void render_history(const GapPageData& d, std::string& h) {
  h += "<h2 id=\"history\">Reports over life</h2>\n";
  if (d.total_reports > d.reports.size())
    h += "<p class=\"muted\">The newest " + std::to_string(d.reports.size()) + " of " + std::to_string(d.total_reports) + " reports.</p>\n";
  h += "<div class=\"scroll\"><table class=\"history\">\n<thead><tr><th>report</th><th>stored (UTC)</th><th>cycles</th>"
       "<th>significant, twin alone</th><th>chosen</th><th>unexplained</th><th>K_wear before → after (m²/N)</th></tr></thead>\n<tbody>\n";
  for (auto it = d.reports.rbegin(); it != d.reports.rend(); ++it) {
    const GapReport& r = it->report;
    std::vector<FamilyKind> significant;
    for (const auto& g : r.before)
      if (g.significant) significant.push_back(g.family);
    h += "<tr class=\"history-row\"><td class=\"num\">#" + std::to_string(it->id) + "</td><td class=\"time\">" + html_escape(it->created_at) +
         "</td><td class=\"num\">" + fmt("%.0f", r.input_revolutions) + "</td><td>" +
         html_escape(joined(significant, [](auto f) { return gap::to_string(f); })) + "</td><td>" +
         html_escape(joined(r.chosen, [](auto e) { return gap::to_string(e); })) + "</td><td>" +
         html_escape(joined(r.unexplained, [](auto f) { return gap::to_string(f); })) + "</td><td class=\"num\">" +
         (r.k_wear_before ? fmt("%.4g", *r.k_wear_before) : "—") + " → " + (r.k_wear_after ? fmt("%.4g", *r.k_wear_after) : "—") +
         "</td></tr>\n";
  }
  h += "</tbody></table></div>\n";
}

constexpr const char* kGapStyle = R"CSS(
table.families td.num, table.candidates td.num, table.history td.num, table.features td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
tr.family-row.significant td:first-child { font-weight: 600; }
table.families td:first-child { white-space: nowrap; }
tr.candidate-row.chosen { background: #e8f5e9; }
.unexplained { color: #b71c1c; font-weight: 600; }
.worse { color: #b71c1c; }
span.swatch { display: inline-block; width: 12px; height: 12px; border-radius: 2px; margin-right: 6px; vertical-align: -1px; }
svg.plot rect.band { fill-opacity: 0.18; stroke: none; }
svg.plot text.sig { font-size: 14px; font-weight: 700; fill: #b71c1c; }
svg.plot text.family-label { font-weight: 600; }
svg.plot line.feature { stroke-width: 1.5; stroke-dasharray: 5 3; }
.at-bound { color: #ef6c00; font-weight: 600; }
)CSS";

}  // namespace

GapPageData load_gap_page_data(storage::Database& db, const std::string& database_label, const std::string& generated_at,
                               std::size_t history) {
  if (!storage::has_table_or_view(db, "records"))
    throw std::runtime_error(database_label + " is not a gearwatch database (it has no records table)");
  if (!storage::has_gap_report_tables(db))
    throw NoGapReports(database_label + " has no gap reports: it was written by a gearwatch older than schema version 5");
  GapPageData d;
  d.database = database_label;
  d.generated_at = generated_at;
  d.total_reports = static_cast<std::size_t>(storage::count_gap_reports(db));
  if (d.total_reports == 0)
    throw NoGapReports(database_label + " has no gap reports yet: the daemon stores one every gap.every_records analysed records"
                                        " when [gap] enabled = true (docs/gap-report.md)");
  d.reports = storage::load_gap_reports(db, std::max<std::size_t>(history, 1));
  for (auto& a : storage::load_active_alerts(db, AlertKind::twin_drift))
    d.active_drift.push_back({std::move(a.subject), std::move(a.value), std::move(a.raised_at), std::move(a.message)});
  return d;
}

std::string render_gap_report_html(const GapPageData& d) {
  std::string h;
  h.reserve(1 << 17);
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  // The page loads nothing: the policy makes a browser refuse any request it might contain.
  h += "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'; img-src data:\">\n";
  h += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  h += "<title>Sim-to-real gap — " + html_escape(d.database) + "</title>\n<style>" + std::string(report_base_style()) + kGapStyle +
       "</style>\n</head>\n<body>\n<main>\n";
  if (d.reports.empty()) {
    h += "<p class=\"notice\">No gap report.</p>\n</main>\n</body>\n</html>\n";
    return h;
  }
  const storage::StoredGapReport& newest = d.reports.back();
  render_header(d, newest, h);
  render_family_table(newest.report, h);
  render_bar_chart(newest.report, h);
  render_candidates(newest.report, h);
  render_features(newest.report, h);
  render_spectra(newest.report, h);
  render_trend(d, h);
  render_history(d, h);
  h += "<footer class=\"muted\"><p>gearwatch gap report · where each number comes from: docs/gap-report.md</p></footer>\n</main>\n</body>\n</html>\n";
  return h;
}

}  // namespace gearwatch::report
