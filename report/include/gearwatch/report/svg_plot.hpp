#pragma once
// A small SVG line-plot writer for the HTML report: axes with "nice number" ticks, linear or
// log10 scale, polylines broken at gaps, point markers with tooltips, and vertical event lines.
// The output is a plain <svg> element meant to be inlined in HTML (no scripts, no external
// references), so the page stays one self-contained file.
#include <string>
#include <string_view>
#include <vector>

namespace gearwatch::report {

/// HTML/XML text and attribute escaping: & < > " ' -> entities. Everything that comes from the
/// database passes through here before it reaches the page.
std::string html_escape(std::string_view text);

/// Heckbert's "nice number" (Graphics Gems, 1990): a number of the form {1, 2, 5, 10} x 10^k
/// close to x (round = true) or not smaller than x (round = false). x must be > 0.
double nice_number(double x, bool round);

/// Ticks at the multiples of a nice step that lie inside [lo, hi], the step chosen so that about
/// `target` ticks span the range. Each tick is computed as an integer count of the step's mantissa
/// divided or multiplied by a power of ten, so 0.6 comes out as the double nearest 0.6 and not as
/// 3 x 0.2 = 0.6000000000000001. lo == hi gives that one value.
struct LinearTicks {
  std::vector<double> values;
  double step = 0;        ///< distance between ticks
  int decimals = 0;       ///< digits after the point that write every tick exactly
  int step_exponent = 0;  ///< step = {1, 2, 5} x 10^step_exponent
  int thousands = 0;      ///< labels in units of 1000^thousands (k, M, G) when ticks reach 10 000
};
LinearTicks linear_ticks(double lo, double hi, int target = 5);

/// Powers of ten inside [lo, hi] (0 < lo <= hi); every k-th decade when more than `max_ticks`
/// decades would be labelled.
std::vector<double> log_ticks(double lo, double hi, int max_ticks = 8);

/// A tick's label: fixed point with just the digits the step needs, in k/M/G when the axis's
/// ticks reach 10 000 (one suffix for the whole axis, so labels stay comparable).
std::string format_linear_tick(double value, const LinearTicks& ticks);
/// Decades: 0.001 … 1000 written out, others as 1e-4, 1e+06.
std::string format_log_tick(double value);

enum class AxisScale { linear, log };

struct Axis {
  double lo = 0, hi = 1;
  AxisScale scale = AxisScale::linear;
  std::string label;  ///< quantity and unit, e.g. "input revolutions"
};

/// The axis for these values: log10 when every value is > 0 and they span more than two decades
/// (and `allow_log`), else linear; padded by 5 % of the span (of log10 span on a log axis) so no
/// point sits on the frame. Non-finite values are ignored; none at all gives [0, 1].
Axis fit_axis(const std::vector<double>& values, std::string label, bool allow_log);

struct PlotPoint {
  double x = 0;
  double y = 0;       ///< NaN: no value here; the line is broken (a record not analysed)
  std::string title;  ///< tooltip (plain text, escaped on output)
};

struct PlotSeries {
  std::string name;    ///< data-name attribute (e.g. the indicator name)
  std::string label;   ///< legend text
  std::string colour;  ///< CSS colour
  std::vector<PlotPoint> points;
  bool markers = true; ///< a circle with a tooltip at each point; off for dense curves (spectra)
};

/// A shaded stretch of the x axis across the plot's height (a spectral family's band), drawn
/// under the data; `css_class` and the fill colour style it, `title` is its tooltip.
struct PlotBand {
  double lo = 0, hi = 0;
  std::string css_class;
  std::string colour;
  std::string title;
};

/// Vertical line across the plot at x. `css_class` picks its style in the page's stylesheet
/// (raised-alarm, raised-warning, cleared, event, inspection); `colour` is the stroke.
struct EventLine {
  double x = 0;
  std::string css_class;
  std::string colour;
  std::string title;
};

class SvgPlot {
 public:
  struct Layout {
    double width = 600, height = 280;
    /// Margins around the plot area; the top one holds the title and, under it, the legend.
    double left = 70, right = 16, top = 42, bottom = 46;
  };

  SvgPlot(std::string title, Axis x, Axis y, Layout layout);
  SvgPlot(std::string title, Axis x, Axis y) : SvgPlot(std::move(title), std::move(x), std::move(y), Layout{}) {}

  /// Data -> SVG user units. Linear: left + (x - lo) / (hi - lo) * plot width; log: the same on
  /// log10 values. y grows upwards: top + plot height at lo, top at hi.
  double x_to_px(double x) const;
  double y_to_px(double y) const;

  void add_series(PlotSeries series) { series_.push_back(std::move(series)); }
  void add_event(EventLine event) { events_.push_back(std::move(event)); }
  void add_band(PlotBand band) { bands_.push_back(std::move(band)); }

  /// Points that could not be placed (non-positive on a log axis): they are drawn as gaps.
  std::size_t unplottable_points() const;

  std::string render(std::string_view css_id) const;

  const Axis& x_axis() const noexcept { return x_; }
  const Axis& y_axis() const noexcept { return y_; }

 private:
  bool placeable(const PlotPoint& p) const;
  /// The plot area's edges in pixels.
  struct PlotBox {
    double left, right, top, bottom;
  };
  PlotBox box() const;
  // The parts render() draws, in its order.
  std::string frame_svg(std::string_view css_id) const;
  std::string x_axis_svg() const;
  std::string y_axis_svg() const;
  std::string bands_svg() const;
  std::string events_svg() const;
  std::string series_svg(const PlotSeries& s) const;
  std::string legend_svg() const;
  std::string title_;
  Axis x_, y_;
  Layout layout_;
  std::vector<PlotSeries> series_;
  std::vector<EventLine> events_;
  std::vector<PlotBand> bands_;
};

}  // namespace gearwatch::report
