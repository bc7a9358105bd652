#include "gearwatch/gap/features.hpp"
#include "gearwatch/dsp/window.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <stdexcept>

#include <complex>
#include <numbers>

#include <boost/math/distributions/students_t.hpp>
#include <boost/math/special_functions/beta.hpp>
#include <boost/math/special_functions/gamma.hpp>

namespace gearwatch::gap {
namespace {

double ratio_db(double measured, double model, double floor) {
  return 10.0 * std::log10((measured + floor) / (model + floor));
}

/// Two-sided tail of t with `dof` degrees of freedom: g over a spread estimated from dof + 1 draws.
double two_sided_p(double t, double dof) {
  if (!(dof >= 1)) return 1.0;
  const boost::math::students_t dist(dof);
  return std::min(1.0, 2.0 * boost::math::cdf(boost::math::complement(dist, std::abs(t))));
}

/// The normal quantile of a central coverage (bisection on erfc: no table, no library).
double normal_quantile(double coverage) {
  const double tail = (1.0 - coverage) / 2.0;
  double lo = 0, hi = 10;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(mid / std::sqrt(2.0)) > tail ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}


/// Bins [k − h, k + h] (h = band_bins / 2) against their neighbourhood's expectation
/// (local_expectation), dB; NaN where any is short or the sums are not positive.
double peak_db(const std::vector<double>& measured, const std::vector<double>& expected, std::size_t k, std::size_t band_bins) {
  const std::size_t h = band_bins / 2;
  if (k < h || k + h >= expected.size() || k + h >= measured.size()) return std::numeric_limits<double>::quiet_NaN();
  double m = 0, e = 0;
  for (std::size_t j = k - h; j <= k + h; ++j) m += measured[j], e += expected[j];
  return m > 0 && e > 0 ? 10.0 * std::log10(m / e) : std::numeric_limits<double>::quiet_NaN();
}

/// The median of v (reordered).
double median_of(std::vector<double>& v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2 == 1) return *mid;
  return 0.5 * (*mid + *std::max_element(v.begin(), mid));
}

}  // namespace

std::vector<double> local_expectation(const SpectralSummary& measured, const SpectralSummary& twin, double acquisition,
                                      const LocalPeakSettings& s) {
  const std::size_t n = std::min(measured.broadband.size(), twin.broadband.size());
  std::vector<double> ratio(n, std::numeric_limits<double>::quiet_NaN()), out(n, std::numeric_limits<double>::quiet_NaN());
  for (std::size_t j = 0; j < n; ++j) {
    const double below = twin.broadband[j] + acquisition;
    if (below > 0) ratio[j] = measured.broadband[j] / below;
  }
  std::vector<double> left, right;
  const std::size_t each = std::max<std::size_t>(1, s.min_reference / 2);
  for (std::size_t k = 0; k < n; ++k) {
    const double below = twin.broadband[k] + acquisition;
    if (!(below > 0)) continue;
    left.clear(), right.clear();
    for (std::size_t d = s.inner_bins; d <= s.outer_bins; ++d) {
      if (k >= d && std::isfinite(ratio[k - d])) left.push_back(ratio[k - d]);
      if (k + d < n && std::isfinite(ratio[k + d])) right.push_back(ratio[k + d]);
    }
    if (left.size() < each || right.size() < each) continue;
    // A peak stands over both sides; a floor's edge over one side only: the higher side's median.
    out[k] = below * std::max(median_of(left), median_of(right));
  }
  return out;
}

namespace {

/// |Σ w(t)·w(t − lag·n/2)·e^(−2πi·d·t/n)| / Σ w(t)², w the periodic Hann window of n samples: the
/// correlation of two half-order bins d apart in blocks `lag` hops apart (white noise).
double hann_correlation(int lag, int d) {
  constexpr std::size_t n = 256;  // the ratios are those of the continuous window to well under 1e-3
  static const std::vector<double> window = dsp::periodic_hann(n);
  auto w = [&](long t) { return t < 0 || t >= static_cast<long>(n) ? 0.0 : window[static_cast<std::size_t>(t)]; };
  std::complex<double> sum = 0;
  double norm = 0;
  for (long t = 0; t < static_cast<long>(n); ++t) {
    norm += w(t) * w(t);
    sum += w(t) * w(t - lag * static_cast<long>(n / 2)) * std::polar(1.0, -2 * std::numbers::pi * d * t / n);
  }
  return std::abs(sum) / norm;
}

/// The covariance of two sums of half-order bins' powers averaged over `blocks` blocks, each bin's
/// power of unit mean: Σ over pairs of bins and blocks of the squared correlation, over blocks².
double summed_covariance(std::size_t first_a, std::size_t count_a, std::size_t first_b, std::size_t count_b, double blocks) {
  double c = 0;
  for (std::size_t i = first_a; i < first_a + count_a; ++i)
    for (std::size_t j = first_b; j < first_b + count_b; ++j) {
      const int d = static_cast<int>(i) - static_cast<int>(j);
      c += blocks * std::pow(hann_correlation(0, d), 2) + 2 * std::max(0.0, blocks - 1) * std::pow(hann_correlation(1, d), 2);
    }
  return c / (blocks * blocks);
}

}  // namespace

double welch_dof(std::size_t half_bins, double blocks) {
  if (half_bins == 0 || !(blocks > 0)) return 0;
  const double mean = static_cast<double>(half_bins);
  return 2 * mean * mean / summed_covariance(0, half_bins, 0, half_bins, blocks);
}

LocalPeakLaw local_peak_law(std::size_t input_revolutions, const LocalPeakSettings& s) {
  LocalPeakLaw law;
  // B = R − 1 blocks of 2 revolutions, less one for their mean (RecordSpectra).
  if (input_revolutions < std::max<std::size_t>(3, s.min_revolutions) || s.outer_bins < s.inner_bins) return law;
  const double blocks = static_cast<double>(input_revolutions) - 2.0;
  law.cell_dof = welch_dof(2 * s.band_bins, blocks);
  law.bin_dof = welch_dof(2, blocks);
  // Adjacent 1-order bins share the window's reach over their touching half-order bins.
  const double rho = summed_covariance(0, 2, 2, 2, blocks) / summed_covariance(0, 2, 0, 2, blocks);
  const double side = static_cast<double>(s.outer_bins - s.inner_bins + 1) / (1 + 2 * rho);
  const double a = (side + 1) / 2;  // the median of `side` values: the order statistic of Beta(a, a)
  // The larger of two independent sides' medians has CDF G² (G one side's): at probability u each
  // side's median sits at G⁻¹(√u). A grid in u, geometric towards 0 where the smallest references
  // (the largest ratios) come from, trapezoid weights.
  constexpr int points = 160;
  std::vector<double> u;
  for (int i = 0; i < points; ++i) u.push_back(std::pow(10.0, -15.0 * (1.0 - static_cast<double>(i) / (points - 1))));
  const double shape = law.bin_dof / 2;
  for (int i = 0; i < points; ++i) {
    const double f = boost::math::ibeta_inv(a, a, std::sqrt(std::min(u[i], 1.0 - 1e-16)));
    law.reference.push_back(boost::math::gamma_p_inv(shape, f) / shape);
    const double lo = i > 0 ? u[i - 1] : 0.0, hi = i + 1 < points ? u[i + 1] : 1.0;
    law.weight.push_back((hi - lo) / 2 + (i == 0 ? u[0] / 2 : 0.0));
  }
  return law;
}

double LocalPeakLaw::p_value(double ratio) const {
  if (!valid() || !(ratio >= 0)) return std::numeric_limits<double>::quiet_NaN();
  const double shape = cell_dof / 2;
  double p = 0;
  for (std::size_t i = 0; i < reference.size(); ++i) p += weight[i] * boost::math::gamma_q(shape, shape * ratio * reference[i]);
  return std::clamp(p, 0.0, 1.0);
}

std::vector<LocalPeakCell> local_peak_cells(const SpectralSummary& measured, const SpectralSummary& twin, double acquisition,
                                            const LocalPeakSettings& settings, const LocalPeakLaw& law) {
  const auto expected = local_expectation(measured, twin, acquisition, settings);
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<LocalPeakCell> out(expected.size(), LocalPeakCell{nan, nan});
  for (std::size_t k = 0; k < expected.size(); ++k) {
    out[k].gain_db = peak_db(measured.broadband, expected, k, settings.band_bins);
    if (law.valid() && std::isfinite(out[k].gain_db)) out[k].p = law.p_value(std::pow(10.0, out[k].gain_db / 10));
  }
  return out;
}

double FloorComparison::gap_db(std::size_t band) const {
  const FloorBand& b = bands.at(band);
  const double tiny = std::numeric_limits<double>::min();  // both empty: equal
  return 10.0 * std::log10((b.measured + tiny) / (b.twin + acquisition + tiny));
}

FloorComparison compare_floors(const SpectralSummary& measured, const SpectralSummary& twin, const FloorSettings& s) {
  FloorComparison out;
  const std::size_t n = std::min(measured.broadband.size(), twin.broadband.size());
  const double v = measured.speed_hz;
  if (n == 0 || !(v > 0) || !(s.bands_per_octave > 0)) return out;
  // Bin i holds orders [i + 1, i + 2): Hz [(i + 1)·v, (i + 2)·v). Bands close at edges 2^(1/b) apart,
  // each once it holds min_bins bins; the bins left at the top join the last band.
  const double step = std::pow(2.0, 1.0 / s.bands_per_octave);
  std::size_t first = 0;
  while (first < n && (first + 1.0) * v < s.lowest_hz) ++first;
  auto add_band = [&](std::size_t a, std::size_t b) { out.bands.push_back({(a + 1.0) * v, (b + 1.0) * v, a, b - a, 0, 0}); };
  double edge = s.lowest_hz * step;
  std::size_t a = first;
  for (std::size_t i = first; i < n; ++i) {
    const double centre = (i + 1.5) * v;
    if (centre < edge) continue;
    if (i - a >= s.min_bins) add_band(a, i), a = i;
    while (edge <= centre) edge *= step;
  }
  if (n - a >= s.min_bins) add_band(a, n);
  else if (!out.bands.empty()) out.bands.back().count = n - out.bands.back().first, out.bands.back().hz_high = (n + 1.0) * v;
  std::vector<double> excess, scratch;
  for (auto& band : out.bands) {
    scratch.assign(measured.broadband.begin() + static_cast<std::ptrdiff_t>(band.first),
                   measured.broadband.begin() + static_cast<std::ptrdiff_t>(band.first + band.count));
    band.measured = median_of(scratch);
    scratch.assign(twin.broadband.begin() + static_cast<std::ptrdiff_t>(band.first),
                   twin.broadband.begin() + static_cast<std::ptrdiff_t>(band.first + band.count));
    band.twin = median_of(scratch);
    if (band.measured > 0 && band.measured >= s.excess_ratio * band.twin) excess.push_back(band.measured - band.twin);
  }
  if (!excess.empty()) {
    // The low quantile finds the acquisition's level but sits under it by the bands' scatter; its
    // value is the median of the bands up to a factor of two (the half-power criterion, as the
    // features' practical minimum) above that quantile: those share the acquisition's floor.
    std::sort(excess.begin(), excess.end());
    const auto at = static_cast<std::size_t>(std::floor(std::clamp(s.acquisition_quantile, 0.0, 1.0) * static_cast<double>(excess.size() - 1)));
    const double low = std::max(0.0, excess[at]);
    std::vector<double> same;
    for (double e : excess)
      if (e <= 2 * low) same.push_back(e);
    out.acquisition = same.empty() ? low : median_of(same);
  }
  return out;
}

double FeatureFinder::Cell::sd() const { return n > 1 ? std::sqrt(m2 / (n - 1)) : std::numeric_limits<double>::quiet_NaN(); }

std::vector<char> benjamini_hochberg(const std::vector<double>& p, double q) {
  const std::size_t m = p.size();
  std::vector<char> reject(m, 0);
  if (m == 0) return reject;
  std::vector<std::size_t> order(m);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return p[a] < p[b]; });
  std::size_t k = 0;  // the number rejected: the largest rank whose p is under its line
  for (std::size_t r = 0; r < m; ++r)
    if (p[order[r]] <= q * static_cast<double>(r + 1) / static_cast<double>(m)) k = r + 1;
  for (std::size_t r = 0; r < k; ++r) reject[order[r]] = 1;
  return reject;
}

FeatureFinder::FeatureFinder(const std::vector<FeaturePair>& pairs, const GearPairSpec& gears, FeatureSettings settings)
    : gears_(gears), settings_(settings) {
  std::map<std::size_t, LocalPeakLaw> laws;  // by input revolutions: records of one length share theirs
  const double ratio = static_cast<double>(gears.pinion_teeth) / gears.gear_teeth;  // input orders per output order
  for (const auto& p : pairs) {
    if (!p.measured || !p.model) throw std::invalid_argument("FeatureFinder: a pair without spectra");
    RecordCells r{p, p.measured->speed_hz, p.measured->torque_nm, {}};
    const auto& m = *p.measured;
    const auto& t = *p.model;
    const std::size_t ki = std::min(m.input_lines.size(), t.input_lines.size());
    for (std::size_t k = 1; k <= ki; ++k) {
      const double o = static_cast<double>(k);
      r.cells.push_back({CellKind::input_line, k - 1, o - 0.5, o + 0.5, o, ratio_db(m.input_lines[k - 1], t.input_lines[k - 1], p.floor)});
    }
    const std::size_t kb = std::min(m.broadband.size(), t.broadband.size());
    for (std::size_t k = 1; k <= kb; ++k) {
      const double o = static_cast<double>(k);
      r.cells.push_back({CellKind::broadband, k - 1, o, o + 1, o + 0.5, ratio_db(m.broadband[k - 1], t.broadband[k - 1], p.floor)});
    }
    const FloorComparison floors = compare_floors(m, t, settings.floor);
    if (settings.local.enabled) add_local_cells(r.cells, m, t, floors.acquisition, laws);
    const std::size_t ko = std::min(m.output_lines.size(), t.output_lines.size());
    for (std::size_t j = 1; j <= ko; ++j) {
      if (output_line_is_mesh(static_cast<int>(j), gears.gear_teeth)) continue;
      const double o = static_cast<double>(j) * ratio;
      r.cells.push_back({CellKind::output_line, j - 1, o - 0.5 * ratio, o + 0.5 * ratio, o,
                         ratio_db(m.output_lines[j - 1], t.output_lines[j - 1], p.floor)});
    }
    for (std::size_t b = 0; b < floors.bands.size(); ++b) {
      const double lo = floors.bands[b].hz_low / r.speed_hz, hi = floors.bands[b].hz_high / r.speed_hz;
      r.cells.push_back({CellKind::floor_band, b, lo, hi, 0.5 * (lo + hi), floors.gap_db(b)});
    }
    records_.push_back(std::move(r));
  }
}

void FeatureFinder::add_local_cells(std::vector<Cell>& cells, const SpectralSummary& m, const SpectralSummary& t, double acquisition,
                                    std::map<std::size_t, LocalPeakLaw>& laws) const {
  auto law = laws.find(m.input_revolutions);
  if (law == laws.end()) law = laws.emplace(m.input_revolutions, local_peak_law(m.input_revolutions, settings_.local)).first;
  // Spectra made in closed form carry no revolutions: their cells are tested on the bootstrap's
  // spread (p_values); a record too short for the law has no local cells.
  if (!law->second.valid() && m.input_revolutions != 0) return;
  const auto local = local_peak_cells(m, t, acquisition, settings_.local, law->second);
  const double h = static_cast<double>(settings_.local.band_bins / 2);
  for (std::size_t k = 1; k <= local.size(); ++k) {
    if (!std::isfinite(local[k - 1].gain_db)) continue;
    const double o = static_cast<double>(k);
    cells.push_back({CellKind::broadband_peak, k - 1, o - h, o + 1 + h, o + 0.5, local[k - 1].gain_db});
    cells.back().law_p = local[k - 1].p;
  }
}

void FeatureFinder::add_draw(std::size_t pair, const SpectralSummary& measured, const SpectralSummary& model) {
  RecordCells& r = records_.at(pair);
  const double floor = r.pair.floor;
  auto value = [&](const std::vector<double>& a, const std::vector<double>& b, std::size_t i) {
    return i < a.size() && i < b.size() ? ratio_db(a[i], b[i], floor) : std::numeric_limits<double>::quiet_NaN();
  };
  const FloorComparison floors = compare_floors(measured, model, settings_.floor);
  const auto local = settings_.local.enabled ? local_peak_cells(measured, model, floors.acquisition, settings_.local, LocalPeakLaw{})
                                             : std::vector<LocalPeakCell>{};
  for (Cell& c : r.cells) {
    double g = 0;
    switch (c.kind) {
      case CellKind::input_line: g = value(measured.input_lines, model.input_lines, c.index); break;
      case CellKind::output_line: g = value(measured.output_lines, model.output_lines, c.index); break;
      case CellKind::broadband: g = value(measured.broadband, model.broadband, c.index); break;
      case CellKind::floor_band: g = c.index < floors.bands.size() ? floors.gap_db(c.index) : std::numeric_limits<double>::quiet_NaN(); break;
      case CellKind::broadband_peak:
        g = c.index < local.size() ? local[c.index].gain_db : std::numeric_limits<double>::quiet_NaN();
        break;
    }
    if (!std::isfinite(g)) continue;
    c.n += 1;
    const double delta = g - c.mean;
    c.mean += delta / c.n;
    c.m2 += delta * (g - c.mean);
  }
}

std::vector<double> FeatureFinder::p_values(std::vector<std::pair<std::size_t, std::size_t>>& where) const {
  std::vector<double> p;
  for (std::size_t r = 0; r < records_.size(); ++r)
    for (std::size_t i = 0; i < records_[r].cells.size(); ++i) {
      const Cell& c = records_[r].cells[i];
      const double sd = c.sd();
      double value = 1.0;
      // A local peak's test is one-sided (rising only, as it is counted), by the χ² law of the
      // record's bins; the bootstrap's spread only where the record's blocks are not known (spectra
      // made in closed form): over a few revolutions it is narrower than the bins' own scatter.
      if (c.kind == CellKind::broadband_peak && std::isfinite(c.law_p)) value = c.law_p;
      else if (std::isfinite(sd) && sd > 0 && c.kind == CellKind::broadband_peak)
        value = c.g > 0 ? two_sided_p(c.g / sd, c.n - 1) / 2 : 1.0 - two_sided_p(c.g / sd, c.n - 1) / 2;
      else if (std::isfinite(sd) && sd > 0) value = two_sided_p(c.g / sd, c.n - 1);
      // No spread over the draws: both spectra are the same in every draw (no noise at all), so any
      // difference is exact; none is no evidence.
      else if (std::isfinite(sd)) value = std::abs(c.g) > 1e-9 ? 0.0 : 1.0;
      p.push_back(value);
      where.emplace_back(r, i);
    }
  return p;
}

std::vector<char> FeatureFinder::counted(std::size_t& rejected) const {
  std::vector<std::pair<std::size_t, std::size_t>> where;
  const auto p = p_values(where);
  const auto reject = benjamini_hochberg(p, settings_.false_discovery_rate);
  rejected = static_cast<std::size_t>(std::count(reject.begin(), reject.end(), 1));
  std::vector<char> out(reject.size(), 0);
  for (std::size_t i = 0; i < reject.size(); ++i) {
    const Cell& c = records_[where[i].first].cells[where[i].second];
    // A local peak is tested rising only (p_values): a short record's bins scatter further down than
    // up (the log of a χ²), and no narrow form makes a dip under the capture's own floor.
    out[i] = reject[i] && std::abs(c.g) >= settings_.min_feature_db;
  }
  return out;
}

std::size_t FeatureFinder::rejected_cells() const {
  std::size_t rejected = 0;
  counted(rejected);
  return rejected;
}

namespace {

/// The movement rule (features.hpp): spreads of the sightings' centres at distinct speeds.
FeatureMovement movement_of(const std::vector<FeatureSighting>& seen, double min_speed_ratio) {
  double slow = std::numeric_limits<double>::infinity(), fast = 0;
  double order_lo = slow, order_hi = -slow, hz_lo = slow, hz_hi = -slow;
  for (const auto& s : seen) {
    slow = std::min(slow, s.speed_hz), fast = std::max(fast, s.speed_hz);
    order_lo = std::min(order_lo, s.order), order_hi = std::max(order_hi, s.order);
    hz_lo = std::min(hz_lo, s.hz), hz_hi = std::max(hz_hi, s.hz);
  }
  if (seen.size() < 2 || fast < slow * min_speed_ratio) return FeatureMovement::undetermined;
  // One bin: an input order, which in Hz is the fastest sighting's speed (the widest of the bins).
  const bool orders_hold = order_hi - order_lo <= 1.0;
  const bool hz_holds = hz_hi - hz_lo <= fast;
  if (orders_hold && !hz_holds) return FeatureMovement::fixed_in_orders;
  if (hz_holds && !orders_hold) return FeatureMovement::fixed_in_hz;
  return orders_hold ? FeatureMovement::undetermined : FeatureMovement::neither;
}

/// The movement of a feature of several pieces (pieces_of: its peaks in each record), such as tones
/// at 60, 120 and 180 Hz, each with its leakage, joined where one's leakage comes within a bin of
/// the next one's. Its |g|-weighted centre follows whichever piece weighs most at each speed (a
/// tone that falls on a line at one speed has no leakage there), so movement_of reads it as moving
/// with neither. Each piece stands where its own cause is: when every piece has a piece within one
/// bin in Hz (one input order at the faster speed) in every sighting at a speed min_speed_ratio
/// apart, and not so within one order, the pieces are fixed in Hz; and the converse.
FeatureMovement movement_of_pieces(const std::vector<FeatureFinder::Piece>& pieces, double min_speed_ratio) {
  bool hz_holds = true, orders_hold = true, compared = false;
  for (const auto& a : pieces)
    for (const auto& b : pieces) {
      if (std::max(a.speed_hz, b.speed_hz) < min_speed_ratio * std::min(a.speed_hz, b.speed_hz)) continue;
      bool in_hz = false, in_orders = false;  // a has a piece of b's sighting beside it
      for (const auto& c : pieces) {
        if (c.speed_hz != b.speed_hz) continue;
        in_hz = in_hz || std::abs(c.hz - a.hz) <= std::max(a.speed_hz, c.speed_hz);
        in_orders = in_orders || std::abs(c.order - a.order) <= 1.0;
      }
      hz_holds = hz_holds && in_hz, orders_hold = orders_hold && in_orders, compared = true;
      if (!hz_holds && !orders_hold) return FeatureMovement::neither;  // a broad feature's many peaks: at once
    }
  if (!compared) return FeatureMovement::undetermined;
  if (hz_holds && !orders_hold) return FeatureMovement::fixed_in_hz;
  if (orders_hold && !hz_holds) return FeatureMovement::fixed_in_orders;
  return FeatureMovement::neither;
}

}  // namespace

std::vector<std::vector<std::size_t>> FeatureFinder::join_clusters(const std::vector<Cluster>& clusters) const {
  std::vector<std::size_t> live(clusters.size());
  std::iota(live.begin(), live.end(), std::size_t{0});
  std::vector<std::vector<std::size_t>> out;
  // Components of the live clusters whose extents, widened by half a bin each side, overlap along
  // one axis: input orders, or Hz (a bin there is the record's speed).
  auto components = [&](bool in_hz) {
    auto lo = [&](std::size_t c) { return (clusters[c].low - 0.5) * (in_hz ? records_[clusters[c].record].speed_hz : 1.0); };
    auto hi = [&](std::size_t c) { return (clusters[c].high + 0.5) * (in_hz ? records_[clusters[c].record].speed_hz : 1.0); };
    auto sorted = live;
    std::sort(sorted.begin(), sorted.end(), [&](std::size_t a, std::size_t b) { return lo(a) < lo(b); });
    std::vector<std::vector<std::size_t>> groups;
    double reach = -std::numeric_limits<double>::infinity();
    for (std::size_t c : sorted) {
      if (groups.empty() || lo(c) > reach) groups.emplace_back(), reach = hi(c);
      groups.back().push_back(c);
      reach = std::max(reach, hi(c));
    }
    return groups;
  };
  auto records_in = [&](const std::vector<std::size_t>& g) {
    std::vector<std::size_t> r;
    for (std::size_t c : g) r.push_back(clusters[c].record);
    std::sort(r.begin(), r.end());
    return static_cast<std::size_t>(std::unique(r.begin(), r.end()) - r.begin());
  };
  auto weight = [&](const std::vector<std::size_t>& g) {
    double w = 0;
    for (std::size_t c : g)
      for (std::size_t i : clusters[c].cells) w += std::abs(records_[clusters[c].record].cells[i].g);
    return w;
  };
  while (!live.empty()) {
    std::vector<std::size_t> best;
    std::pair<std::size_t, double> best_key{0, -1.0};
    for (bool in_hz : {false, true})
      for (auto& g : components(in_hz)) {
        const std::pair<std::size_t, double> key{records_in(g), weight(g)};
        if (key > best_key) best_key = key, best = std::move(g);
      }
    std::vector<char> taken(clusters.size(), 0);
    for (std::size_t c : best) taken[c] = 1;
    live.erase(std::remove_if(live.begin(), live.end(), [&](std::size_t c) { return taken[c] != 0; }), live.end());
    out.push_back(std::move(best));
  }
  return out;
}

std::vector<GapFeature> FeatureFinder::features() const {
  // The bins' local peaks where the lines and bins against the twin show nothing: their own layer,
  // so that a line or bin feature keeps its extent and sightings.
  auto out = layer_features(Layer::lines_and_bins);
  const std::size_t found = out.size();
  // Persistence over records (LocalPeakSettings::min_record_share): a chance peak is in few.
  const std::size_t needed = settings_.local.records_needed(records_.size());
  for (auto& f : layer_features(Layer::local_peaks)) {
    if (f.seen_in.size() < needed) continue;
    // The same finding when its centre lies inside a line or bin feature's extent. Overlapping
    // extents are not enough: a narrow resonance between two mesh harmonics lifts the nearer one on
    // its skirt, a line feature a few bins from the peak, while the peak itself stands in the local
    // cells between the lines, which reach over that line.
    const bool same = std::any_of(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(found),
                                  [&](const GapFeature& g) { return g.hz_low <= f.hz && f.hz <= g.hz_high; });
    if (!same) out.push_back(std::move(f));
  }
  return out;
}

std::vector<GapFeature> FeatureFinder::floor_features() const { return layer_features(Layer::floor_bands); }

std::vector<GapFeature> FeatureFinder::layer_features(Layer layer) const {
  auto layer_of = [](CellKind k) {
    return k == CellKind::floor_band ? Layer::floor_bands : k == CellKind::broadband_peak ? Layer::local_peaks : Layer::lines_and_bins;
  };
  std::size_t rejected = 0;
  const auto flags = counted(rejected);
  std::vector<std::pair<std::size_t, std::size_t>> where;
  const auto p = p_values(where);
  // The p-value of each cell, for the feature's smallest.
  std::vector<std::vector<double>> cell_p(records_.size());
  for (std::size_t r = 0; r < records_.size(); ++r) cell_p[r].assign(records_[r].cells.size(), 1.0);
  for (std::size_t i = 0; i < p.size(); ++i) cell_p[where[i].first][where[i].second] = p[i];
  std::vector<GapFeature> out;
  // One layer: lines and bins, or the broadband floors' bands (the test above is over both).
  {
    // Clusters: each record's counted cells in order of their extent, touching ones merged.
    std::vector<Cluster> clusters;
    std::vector<std::vector<std::size_t>> by_record(records_.size());
    for (std::size_t i = 0; i < flags.size(); ++i)
      if (flags[i] && layer_of(records_[where[i].first].cells[where[i].second].kind) == layer)
        by_record[where[i].first].push_back(where[i].second);
    for (std::size_t r = 0; r < records_.size(); ++r) {
      auto& cells = by_record[r];
      const auto& all = records_[r].cells;
      std::sort(cells.begin(), cells.end(), [&](std::size_t a, std::size_t b) { return all[a].low < all[b].low; });
      for (std::size_t c : cells) {
        if (!clusters.empty() && clusters.back().record == r && all[c].low <= clusters.back().high + 1e-9) {
          clusters.back().cells.push_back(c);
          clusters.back().high = std::max(clusters.back().high, all[c].high);
        } else {
          clusters.push_back({r, {c}, all[c].low, all[c].high});
        }
      }
    }
    for (const auto& group : join_clusters(clusters)) out.push_back(feature_of(clusters, group, cell_p));
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const GapFeature& a, const GapFeature& b) { return std::abs(a.size_db) > std::abs(b.size_db); });
  return out;
}

std::vector<FeatureFinder::Piece> FeatureFinder::pieces_of(const std::vector<Cluster>& clusters, const std::vector<std::size_t>& group) const {
  std::vector<Piece> out;
  for (std::size_t r = 0; r < records_.size(); ++r) {
    std::vector<const Cell*> cells;
    for (std::size_t b : group)
      if (clusters[b].record == r)
        for (std::size_t c : clusters[b].cells) cells.push_back(&records_[r].cells[c]);
    std::sort(cells.begin(), cells.end(), [](const Cell* a, const Cell* b) { return a->centre < b->centre; });
    // A peak: no cell of the feature within one order of it stands higher (the bins a tone's
    // leakage spreads over fall away from it on both sides).
    std::size_t lo = 0;
    for (std::size_t i = 0; i < cells.size(); ++i) {
      while (cells[lo]->centre < cells[i]->centre - 1.0) ++lo;
      bool peak = true;
      for (std::size_t j = lo; j < cells.size() && cells[j]->centre <= cells[i]->centre + 1.0 && peak; ++j)
        peak = j == i || std::abs(cells[j]->g) <= std::abs(cells[i]->g);
      if (peak) out.push_back({records_[r].speed_hz, cells[i]->centre, cells[i]->centre * records_[r].speed_hz});
    }
  }
  return out;
}

GapFeature FeatureFinder::feature_of(const std::vector<Cluster>& clusters, const std::vector<std::size_t>& group,
                                     const std::vector<std::vector<double>>& cell_p) const {
  const double z = normal_quantile(settings_.coverage);
  const double ratio = static_cast<double>(gears_.pinion_teeth) / gears_.gear_teeth;
  GapFeature f;
  f.p_value = 1.0;
  double order_lo = std::numeric_limits<double>::infinity(), order_hi = -order_lo;
  f.hz_low = order_lo, f.hz_high = order_hi;
  double variance = 0, peak_abs = -1;
  CellKind peak_kind = CellKind::input_line;
  for (std::size_t r = 0; r < records_.size(); ++r) {
    double weight = 0, centre = 0, peak = 0, peak_sd = 0;
    for (std::size_t b : group) {
      if (clusters[b].record != r) continue;
      for (std::size_t c : clusters[b].cells) {
        const Cell& cell = records_[r].cells[c];
        weight += std::abs(cell.g), centre += std::abs(cell.g) * cell.centre;
        if (std::abs(cell.g) > std::abs(peak)) peak = cell.g, peak_sd = cell.sd();
        if (std::abs(cell.g) > peak_abs) peak_abs = std::abs(cell.g), peak_kind = cell.kind;
        f.p_value = std::min(f.p_value, cell_p[r][c]);
        order_lo = std::min(order_lo, cell.low), order_hi = std::max(order_hi, cell.high);
        f.hz_low = std::min(f.hz_low, cell.low * records_[r].speed_hz);
        f.hz_high = std::max(f.hz_high, cell.high * records_[r].speed_hz);
      }
    }
    if (weight == 0) continue;
    const auto& rec = records_[r];
    f.seen_in.push_back({rec.pair.held_out, rec.pair.record, rec.speed_hz, rec.torque_nm, centre / weight,
                         centre / weight * rec.speed_hz, peak});
    variance += std::isfinite(peak_sd) ? peak_sd * peak_sd : 0.0;
  }
  const double n = static_cast<double>(f.seen_in.size());
  for (const auto& s : f.seen_in) f.order += s.order / n, f.hz += s.hz / n, f.size_db += s.size_db / n;
  const double half = z * std::sqrt(variance) / n;
  f.size_interval_db = {f.size_db - half, f.size_db + half};
  f.movement = movement_of(f.seen_in, settings_.min_speed_ratio);
  // A feature of several pieces is read piece by piece when its centres move with neither.
  if (f.movement == FeatureMovement::neither) {
    const auto pieces = pieces_of(clusters, group);
    if (pieces.size() > f.seen_in.size()) f.movement = movement_of_pieces(pieces, settings_.min_speed_ratio);
  }
  f.shaft = peak_kind == CellKind::output_line ? FeatureShaft::output : FeatureShaft::input;
  const double to_shaft = f.shaft == FeatureShaft::output ? 1.0 / ratio : 1.0;
  f.order *= to_shaft;
  f.order_low = order_lo * to_shaft, f.order_high = order_hi * to_shaft;
  return f;
}

GapFeature joined_features(const GapFeature& a, const GapFeature& b, const GearPairSpec& gears, double min_speed_ratio) {
  const double ratio = static_cast<double>(gears.pinion_teeth) / gears.gear_teeth;  // input orders per output order
  auto to_input = [&](const GapFeature& f) { return f.shaft == FeatureShaft::output ? ratio : 1.0; };
  GapFeature u;
  u.shaft = std::abs(a.size_db) >= std::abs(b.size_db) ? a.shaft : b.shaft;
  const double from_input = 1.0 / to_input(u);
  u.order_low = std::min(a.order_low * to_input(a), b.order_low * to_input(b)) * from_input;
  u.order_high = std::max(a.order_high * to_input(a), b.order_high * to_input(b)) * from_input;
  u.hz_low = std::min(a.hz_low, b.hz_low), u.hz_high = std::max(a.hz_high, b.hz_high);
  u.p_value = std::min(a.p_value, b.p_value);
  u.seen_in = a.seen_in;
  u.seen_in.insert(u.seen_in.end(), b.seen_in.begin(), b.seen_in.end());
  const double n = static_cast<double>(u.seen_in.size());
  for (const auto& s : u.seen_in) u.order += s.order / n, u.hz += s.hz / n, u.size_db += s.size_db / n;
  u.order *= from_input;
  // Each interval's half-width is z·sqrt(Σ var)/n over its own sightings: the variances add.
  auto spread = [](const GapFeature& f) {
    return (f.size_interval_db.high - f.size_interval_db.low) / 2 * static_cast<double>(f.seen_in.size());
  };
  const double half = std::hypot(spread(a), spread(b)) / n;
  u.size_interval_db = {u.size_db - half, u.size_db + half};
  u.movement = movement_of(u.seen_in, min_speed_ratio);
  return u;
}

}  // namespace gearwatch::gap
