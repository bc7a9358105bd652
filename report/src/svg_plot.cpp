#include "gearwatch/report/svg_plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace gearwatch::report {
namespace {

/// 10^n exactly for |n| <= 22 (every such power of ten is a double), as the divisor or
/// multiplier that keeps tick values the doubles nearest their decimal form.
double power_of_ten(int n) {
  double p = 1;
  for (int i = 0; i < std::abs(n); ++i) p *= 10;
  return p;
}

/// k x mantissa x 10^exponent, rounded once.
double scaled(long long k, int mantissa, int exponent) {
  const double integer = static_cast<double>(k * mantissa);
  return exponent >= 0 ? integer * power_of_ten(exponent) : integer / power_of_ten(-exponent);
}

std::string fixed(double value, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, value);
  return buf;
}

constexpr double kTitleBaseline = 16;
constexpr double kLegendBaseline = 33;

std::string coord(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

// Rough width of a label in the page's 11 px sans-serif, for laying out the legend.
double text_width(std::string_view text, double px_per_char = 6.4) { return static_cast<double>(text.size()) * px_per_char; }

}  // namespace

std::string html_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

double nice_number(double x, bool round) {
  if (!(x > 0) || !std::isfinite(x)) throw std::invalid_argument("nice_number: x must be finite and > 0");
  const int exponent = static_cast<int>(std::floor(std::log10(x)));
  const double fraction = x / std::pow(10.0, exponent);
  double nice;
  if (round) nice = fraction < 1.5 ? 1 : fraction < 3 ? 2 : fraction < 7 ? 5 : 10;
  else nice = fraction <= 1 ? 1 : fraction <= 2 ? 2 : fraction <= 5 ? 5 : 10;
  return nice * std::pow(10.0, exponent);
}

LinearTicks linear_ticks(double lo, double hi, int target) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || hi < lo) throw std::invalid_argument("linear_ticks: need finite lo <= hi");
  LinearTicks t;
  if (hi == lo) {
    t.values = {lo};
    t.decimals = 6;
    return t;
  }
  // The step is the nice number nearest span / (target - 1), kept as mantissa x 10^exponent.
  const double raw = (hi - lo) / std::max(1, target - 1);
  int exponent = static_cast<int>(std::floor(std::log10(raw)));
  const double fraction = raw / std::pow(10.0, exponent);
  int mantissa = fraction < 1.5 ? 1 : fraction < 3 ? 2 : fraction < 7 ? 5 : 10;
  if (mantissa == 10) {
    mantissa = 1;
    ++exponent;
  }
  t.step = scaled(1, mantissa, exponent);
  // A relative tolerance keeps a bound that is a tick (0.8 / 0.2) inside despite rounding.
  const long long k_first = static_cast<long long>(std::ceil(lo / t.step - 1e-9));
  const long long k_last = static_cast<long long>(std::floor(hi / t.step + 1e-9));
  for (long long k = k_first; k <= k_last; ++k) t.values.push_back(scaled(k, mantissa, exponent));
  t.decimals = std::max(0, -exponent);
  t.step_exponent = exponent;
  double largest = 0;
  for (const double v : t.values) largest = std::max(largest, std::abs(v));
  if (largest >= 1e4) {
    t.thousands = std::min(3, static_cast<int>(std::floor(std::log10(largest) / 3)));
  }
  return t;
}

std::vector<double> log_ticks(double lo, double hi, int max_ticks) {
  if (!(lo > 0) || !(hi >= lo) || !std::isfinite(hi)) throw std::invalid_argument("log_ticks: need 0 < lo <= hi");
  const int first = static_cast<int>(std::ceil(std::log10(lo) - 1e-9));
  const int last = static_cast<int>(std::floor(std::log10(hi) + 1e-9));
  const int decades = last - first + 1;
  const int every = std::max(1, (decades + max_ticks - 1) / std::max(1, max_ticks));
  std::vector<double> ticks;
  for (int k = first; k <= last; k += every) ticks.push_back(scaled(1, 1, k));
  return ticks;
}

std::string format_linear_tick(double value, const LinearTicks& ticks) {
  static const char* const suffix[] = {"", "k", "M", "G"};
  const int decimals = std::max(0, 3 * ticks.thousands - ticks.step_exponent);
  const double shown = value / power_of_ten(3 * ticks.thousands);
  // Zero is written "0" whatever the step, and never "-0.0".
  if (std::abs(shown) < 0.5 * std::pow(10.0, -decimals)) return "0";
  return fixed(shown, decimals) + suffix[ticks.thousands];
}

std::string format_log_tick(double value) {
  const int k = static_cast<int>(std::lround(std::log10(value)));
  if (k >= -3 && k <= 3) return fixed(value, std::max(0, -k));
  char buf[32];
  std::snprintf(buf, sizeof buf, "1e%d", k);
  return buf;
}

Axis fit_axis(const std::vector<double>& values, std::string label, bool allow_log) {
  Axis a;
  a.label = std::move(label);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const double v : values) {
    if (!std::isfinite(v)) continue;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  if (!(lo <= hi)) return a;
  if (allow_log && lo > 0 && hi / lo > 100) {
    const double l = std::log10(lo), h = std::log10(hi), pad = 0.05 * (h - l);
    a.scale = AxisScale::log;
    a.lo = std::pow(10.0, l - pad);
    a.hi = std::pow(10.0, h + pad);
    return a;
  }
  const double span = hi - lo;
  const double pad = span > 0 ? 0.05 * span : (lo != 0 ? 0.1 * std::abs(lo) : 1.0);
  a.lo = lo - pad;
  a.hi = hi + pad;
  return a;
}

SvgPlot::SvgPlot(std::string title, Axis x, Axis y, Layout layout)
    : title_(std::move(title)), x_(std::move(x)), y_(std::move(y)), layout_(layout) {
  for (const Axis* a : {&x_, &y_}) {
    if (!(a->hi > a->lo)) throw std::invalid_argument("SvgPlot: axis needs lo < hi");
    if (a->scale == AxisScale::log && !(a->lo > 0)) throw std::invalid_argument("SvgPlot: log axis needs lo > 0");
  }
}

namespace {
double fraction_along(const Axis& a, double v) {
  if (a.scale == AxisScale::log) return (std::log10(v) - std::log10(a.lo)) / (std::log10(a.hi) - std::log10(a.lo));
  return (v - a.lo) / (a.hi - a.lo);
}
}  // namespace

double SvgPlot::x_to_px(double x) const {
  const double plot_width = layout_.width - layout_.left - layout_.right;
  return layout_.left + fraction_along(x_, x) * plot_width;
}

double SvgPlot::y_to_px(double y) const {
  const double plot_height = layout_.height - layout_.top - layout_.bottom;
  return layout_.top + (1.0 - fraction_along(y_, y)) * plot_height;
}

bool SvgPlot::placeable(const PlotPoint& p) const {
  if (!std::isfinite(p.x) || !std::isfinite(p.y)) return false;
  if (x_.scale == AxisScale::log && !(p.x > 0)) return false;
  if (y_.scale == AxisScale::log && !(p.y > 0)) return false;
  return true;
}

std::size_t SvgPlot::unplottable_points() const {
  std::size_t n = 0;
  for (const auto& s : series_)
    for (const auto& p : s.points)
      if (std::isfinite(p.y) && !placeable(p)) ++n;
  return n;
}

namespace {
// An axis's ticks with their labels; each axis gets its labels from one tick set, so they share
// one format.
std::vector<std::pair<double, std::string>> axis_ticks(const Axis& a) {
  std::vector<std::pair<double, std::string>> out;
  if (a.scale == AxisScale::log) {
    for (const double v : log_ticks(a.lo, a.hi)) out.emplace_back(v, format_log_tick(v));
  } else {
    const auto t = linear_ticks(a.lo, a.hi);
    for (const double v : t.values) out.emplace_back(v, format_linear_tick(v, t));
  }
  return out;
}
}  // namespace

SvgPlot::PlotBox SvgPlot::box() const {
  const auto& L = layout_;
  return {L.left, L.width - L.right, L.top, L.height - L.bottom};
}

std::string SvgPlot::frame_svg(std::string_view css_id) const {
  const auto& L = layout_;
  const PlotBox b = box();
  const std::string id = html_escape(css_id);
  std::string svg;
  svg += "<svg class=\"plot\" id=\"" + id + "\" viewBox=\"0 0 " + coord(L.width) + " " + coord(L.height) + "\" width=\"" +
         coord(L.width) + "\" height=\"" + coord(L.height) + "\" role=\"img\" aria-label=\"" + html_escape(title_) + "\">\n";
  svg += "<text class=\"plot-title\" x=\"" + coord(b.left) + "\" y=\"" + coord(kTitleBaseline) + "\">" + html_escape(title_) + "</text>\n";
  svg += "<rect class=\"frame\" x=\"" + coord(b.left) + "\" y=\"" + coord(b.top) + "\" width=\"" + coord(b.right - b.left) +
         "\" height=\"" + coord(b.bottom - b.top) + "\"/>\n";
  return svg;
}

std::string SvgPlot::x_axis_svg() const {
  const PlotBox b = box();
  std::string svg = "<g class=\"x-axis\">";
  for (const auto& [v, text] : axis_ticks(x_)) {
    const std::string px = coord(x_to_px(v));
    svg += "<line class=\"grid\" x1=\"" + px + "\" y1=\"" + coord(b.top) + "\" x2=\"" + px + "\" y2=\"" + coord(b.bottom) + "\"/>";
    svg += "<text class=\"tick\" x=\"" + px + "\" y=\"" + coord(b.bottom + 15) + "\" text-anchor=\"middle\">" + html_escape(text) + "</text>";
  }
  svg += "<text class=\"axis-label\" x=\"" + coord((b.left + b.right) / 2) + "\" y=\"" + coord(layout_.height - 8) +
         "\" text-anchor=\"middle\">" + html_escape(x_.label) + "</text></g>\n";
  return svg;
}

std::string SvgPlot::y_axis_svg() const {
  const PlotBox b = box();
  std::string svg = "<g class=\"y-axis\">";
  for (const auto& [v, text] : axis_ticks(y_)) {
    const std::string py = coord(y_to_px(v));
    svg += "<line class=\"grid\" x1=\"" + coord(b.left) + "\" y1=\"" + py + "\" x2=\"" + coord(b.right) + "\" y2=\"" + py + "\"/>";
    svg += "<text class=\"tick\" x=\"" + coord(b.left - 6) + "\" y=\"" + coord(y_to_px(v) + 4) + "\" text-anchor=\"end\">" +
           html_escape(text) + "</text>";
  }
  const double mid_y = (b.top + b.bottom) / 2;
  svg += "<text class=\"axis-label\" transform=\"translate(14 " + coord(mid_y) + ") rotate(-90)\" text-anchor=\"middle\">" +
         html_escape(y_.label + (y_.scale == AxisScale::log ? " (log scale)" : "")) + "</text></g>\n";
  return svg;
}

// The bands, clipped to the x axis.
std::string SvgPlot::bands_svg() const {
  const PlotBox box_px = box();
  std::string svg;
  for (const auto& b : bands_) {
    if (!std::isfinite(b.lo) || !std::isfinite(b.hi)) continue;
    const double lo = std::max(std::min(b.lo, b.hi), x_.lo), hi = std::min(std::max(b.lo, b.hi), x_.hi);
    if (!(hi > lo) || (x_.scale == AxisScale::log && !(lo > 0))) continue;
    const double x0 = x_to_px(lo), x1 = x_to_px(hi);
    svg += "<rect class=\"band " + html_escape(b.css_class) + "\" x=\"" + coord(x0) + "\" y=\"" + coord(box_px.top) + "\" width=\"" +
           coord(std::max(x1 - x0, 1.0)) + "\" height=\"" + coord(box_px.bottom - box_px.top) + "\" fill=\"" + html_escape(b.colour) +
           "\"><title>" + html_escape(b.title) + "</title></rect>\n";
  }
  return svg;
}

std::string SvgPlot::events_svg() const {
  const PlotBox b = box();
  std::string svg;
  for (const auto& e : events_) {
    if (!std::isfinite(e.x) || (x_.scale == AxisScale::log && !(e.x > 0))) continue;
    const std::string px = coord(x_to_px(e.x));
    svg += "<line class=\"ev " + html_escape(e.css_class) + "\" x1=\"" + px + "\" y1=\"" + coord(b.top) + "\" x2=\"" + px + "\" y2=\"" +
           coord(b.bottom) + "\" stroke=\"" + html_escape(e.colour) + "\"><title>" + html_escape(e.title) + "</title></line>\n";
  }
  return svg;
}

std::string SvgPlot::series_svg(const PlotSeries& s) const {
  std::string svg = "<g class=\"series\" data-name=\"" + html_escape(s.name) + "\" stroke=\"" + html_escape(s.colour) +
                    "\" fill=\"" + html_escape(s.colour) + "\">\n";
  // One polyline per run of consecutive values: a missing value is a visible gap.
  std::string run;
  std::size_t run_points = 0;
  auto flush = [&] {
    if (run_points > 1) svg += "<polyline fill=\"none\" points=\"" + run + "\"/>\n";
    run.clear();
    run_points = 0;
  };
  for (const auto& p : s.points) {
    if (!placeable(p)) {
      flush();
      continue;
    }
    if (run_points++) run += ' ';
    run += coord(x_to_px(p.x)) + "," + coord(y_to_px(p.y));
  }
  flush();
  for (const auto& p : s.points) {
    if (!s.markers || !placeable(p)) continue;
    svg += "<circle class=\"pt\" cx=\"" + coord(x_to_px(p.x)) + "\" cy=\"" + coord(y_to_px(p.y)) + "\" r=\"2.5\"><title>" +
           html_escape(p.title) + "</title></circle>\n";
  }
  svg += "</g>\n";
  return svg;
}

// On its own row under the title, so long titles and labels never collide; none for one
// unlabelled series.
std::string SvgPlot::legend_svg() const {
  if (!(series_.size() > 1 || (series_.size() == 1 && !series_[0].label.empty()))) return {};
  double x = box().left;
  std::string legend;
  for (const auto& s : series_) {
    legend += "<line x1=\"" + coord(x) + "\" y1=\"" + coord(kLegendBaseline - 4) + "\" x2=\"" + coord(x + 16) + "\" y2=\"" +
              coord(kLegendBaseline - 4) + "\" stroke=\"" + html_escape(s.colour) + "\" stroke-width=\"2\"/>";
    x += 22;
    legend += "<text class=\"legend\" x=\"" + coord(x) + "\" y=\"" + coord(kLegendBaseline) + "\">" + html_escape(s.label) + "</text>";
    x += text_width(s.label) + 16;
  }
  return "<g class=\"legend\">" + legend + "</g>\n";
}

std::string SvgPlot::render(std::string_view css_id) const {
  std::string svg = frame_svg(css_id) + x_axis_svg() + y_axis_svg();
  // Bands first, so lines and events stay on top of the shading; events under the data, so the
  // points stay visible and hoverable.
  svg += bands_svg();
  svg += events_svg();
  for (const auto& s : series_) svg += series_svg(s);
  svg += legend_svg();
  svg += "</svg>\n";
  return svg;
}

}  // namespace gearwatch::report
