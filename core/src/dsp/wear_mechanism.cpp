#include "gearwatch/dsp/wear_mechanism.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>

#include "gearwatch/dsp/record_analyzer.hpp"

namespace gearwatch::dsp {

namespace {

// Average ranks (1-based), ties share their mean rank.
std::vector<double> ranks(const std::vector<double>& v) {
  std::vector<std::size_t> order(v.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return v[a] < v[b]; });
  std::vector<double> r(v.size());
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    while (j + 1 < order.size() && v[order[j + 1]] == v[order[i]]) ++j;
    const double mean_rank = 0.5 * static_cast<double>(i + j) + 1.0;
    for (std::size_t k = i; k <= j; ++k) r[order[k]] = mean_rank;
    i = j + 1;
  }
  return r;
}

double two_sided_p(double z) { return std::erfc(std::abs(z) / std::sqrt(2.0)); }

bool within_octave(double a, double b) { return std::abs(std::log2(a / b)) < 1.0; }

double mean_of(const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size()); }

double standard_deviation(const std::vector<double>& v) {
  const double m = mean_of(v);
  double s2 = 0.0;
  for (double x : v) s2 += (x - m) * (x - m);
  return std::sqrt(s2 / static_cast<double>(v.size() - 1));
}

// See BandJump. `points` are sorted by cycles.
std::vector<BandJump> significant_band_jumps(const std::vector<WearHistoryPoint>& points,
                                             const SignalProcessingSettings& settings) {
  const auto persistence = static_cast<std::size_t>(std::max(1, settings.band_jump_persistence_records));
  constexpr std::size_t kScatterWindow = 20;  // the established band's recent records only
  std::vector<const WearHistoryPoint*> usable;
  for (const auto& p : points)
    if (std::isfinite(p.selected_centre_hz) && p.selected_centre_hz > 0 && std::isfinite(p.selected_ics2))
      usable.push_back(&p);
  std::vector<BandJump> jumps;
  if (usable.empty()) return jumps;
  double established = usable.front()->selected_centre_hz;
  std::vector<double> established_ics2{usable.front()->selected_ics2};
  for (std::size_t i = 1; i < usable.size(); ++i) {
    const auto& p = *usable[i];
    if (within_octave(p.selected_centre_hz, established)) {
      established_ics2.push_back(p.selected_ics2);
      if (established_ics2.size() > kScatterWindow) established_ics2.erase(established_ics2.begin());
      continue;
    }
    // A candidate: does the new band last?
    if (i + persistence > usable.size()) break;  // not enough records yet to judge
    std::vector<double> candidate_ics2;
    bool lasts = true;
    for (std::size_t k = i; k < i + persistence; ++k) {
      if (!within_octave(usable[k]->selected_centre_hz, p.selected_centre_hz)) {
        lasts = false;
        break;
      }
      candidate_ics2.push_back(usable[k]->selected_ics2);
    }
    if (!lasts) continue;  // a one-record excursion: the established band stays
    const double from_mean = mean_of(established_ics2);
    const double to_mean = mean_of(candidate_ics2);
    if (established_ics2.size() >= 3 &&
        to_mean > from_mean + settings.band_jump_sigma * standard_deviation(established_ics2))
      jumps.push_back({p.cycles, established, p.selected_centre_hz, from_mean, to_mean});
    established = p.selected_centre_hz;
    established_ics2 = candidate_ics2;
    i += persistence - 1;
  }
  return jumps;
}

}  // namespace

TrendTest trend_test(std::span<const double> x, std::span<const double> y, double significance) {
  if (x.size() != y.size()) throw std::invalid_argument("trend_test: x and y differ in length");
  std::vector<std::pair<double, double>> pairs;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) pairs.emplace_back(x[i], y[i]);
  std::stable_sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  TrendTest t;
  t.points = pairs.size();
  const std::size_t n = pairs.size();
  if (n < 3) return t;
  double s = 0.0;
  for (std::size_t i = 0; i + 1 < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      const double d = pairs[j].second - pairs[i].second;
      s += (d > 0) - (d < 0);
    }
  // Tie correction of Var(S): sum over tie groups of t(t-1)(2t+5).
  std::vector<double> values(n);
  for (std::size_t i = 0; i < n; ++i) values[i] = pairs[i].second;
  std::vector<double> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  double tie_term = 0.0;
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i;
    while (j + 1 < n && sorted[j + 1] == sorted[i]) ++j;
    const double g = static_cast<double>(j - i + 1);
    tie_term += g * (g - 1) * (2 * g + 5);
    i = j + 1;
  }
  const double nn = static_cast<double>(n);
  const double variance = (nn * (nn - 1) * (2 * nn + 5) - tie_term) / 18.0;
  t.mann_kendall_s = s;
  if (variance > 0) t.mann_kendall_z = s > 0 ? (s - 1) / std::sqrt(variance) : s < 0 ? (s + 1) / std::sqrt(variance) : 0.0;
  t.p_value = two_sided_p(t.mann_kendall_z);
  // Spearman: Pearson correlation of the ranks (x ranks are 1..n after sorting, ties in x kept).
  std::vector<double> xs(n);
  for (std::size_t i = 0; i < n; ++i) xs[i] = pairs[i].first;
  const auto rx = ranks(xs), ry = ranks(values);
  const double mean = (nn + 1) / 2;
  double sxy = 0, sxx = 0, syy = 0;
  for (std::size_t i = 0; i < n; ++i) {
    sxy += (rx[i] - mean) * (ry[i] - mean);
    sxx += (rx[i] - mean) * (rx[i] - mean);
    syy += (ry[i] - mean) * (ry[i] - mean);
  }
  t.spearman_rho = (sxx > 0 && syy > 0) ? sxy / std::sqrt(sxx * syy) : 0.0;
  const bool significant = t.p_value < significance;
  t.increasing = significant && s > 0;
  t.decreasing = significant && s < 0;
  return t;
}

std::size_t minimum_points_for_trend(double significance) {
  for (std::size_t n = 3; n < 1000; ++n) {
    const double nn = static_cast<double>(n);
    const double s = nn * (nn - 1) / 2;
    const double z = (s - 1) / std::sqrt(nn * (nn - 1) * (2 * nn + 5) / 18.0);
    if (two_sided_p(z) < significance) return n;
  }
  return 1000;
}

namespace {

// ln sinh(x) for x > 0 without overflow.
double log_sinh(double x) { return x + std::log1p(-std::exp(-2.0 * x)) - std::log(2.0); }

double log_add(double a, double b) {
  if (a == -INFINITY) return b;
  if (b == -INFINITY) return a;
  const double top = std::max(a, b);
  return top + std::log(std::exp(a - top) + std::exp(b - top));
}

struct BetComponent {
  double lambda, weight;
};
// Each change point's bet, mixed over lambda. lambda = 3 bets almost everything on each point after
// the change being the highest so far (a rising ICS2: the pits grow); lambda = 1 and 0.35 keep
// winning when the post-change points stand above the baseline but in shuffled order (a noisy rise,
// or a step once the pits' ICS2 saturates).
constexpr std::array<BetComponent, 3> kRisingBets{{{0.35, 0.25}, {1.0, 0.25}, {3.0, 0.5}}};

// ln of one point's bet factor exp(lambda D_j) j sinh(lambda) / sinh(j lambda): its mean over
// D_j uniform on {-(j-1), -(j-3), ..., j-1} is 1.
double log_bet_factor(double lambda, double d, std::size_t count) {
  if (count < 2) return 0.0;  // the first point has no rank to bet on
  const double j = static_cast<double>(count);
  return lambda * d - (log_sinh(j * lambda) - std::log(j) - log_sinh(lambda));
}

// D_j = sum_{i<j} sign(y_j - y_i) for every point j.
std::vector<double> sequential_rank_scores(const std::vector<double>& y) {
  std::vector<double> d(y.size(), 0.0);
  for (std::size_t j = 1; j < y.size(); ++j)
    for (std::size_t i = 0; i < j; ++i) d[j] += (y[j] > y[i]) - (y[j] < y[i]);
  return d;
}

// ln M_n over the given y sequence (in order, all finite); see rising_change_evidence.
// log_product[k] = ln prod_{j<=n} of component k's factors; log_started[k] = ln sum over the change
// points b already started of change_point_prior(b) / prod_{j<=b} (component k's factors), so that
// component k's part of M_n is weight_k exp(log_product + log_started).
double log_rising_change_evidence(const std::vector<double>& y, std::vector<double>* prefixes = nullptr) {
  const std::vector<double> d = sequential_rank_scores(y);
  std::array<double, kRisingBets.size()> log_product{}, log_started;
  log_started.fill(-INFINITY);
  for (std::size_t j = 0; j < y.size(); ++j) {
    if (j >= 1)  // a change after the first j points starts betting with point j + 1
      for (std::size_t k = 0; k < kRisingBets.size(); ++k)
        log_started[k] = log_add(log_started[k], std::log(change_point_prior(j)) - log_product[k]);
    for (std::size_t k = 0; k < kRisingBets.size(); ++k)
      log_product[k] += log_bet_factor(kRisingBets[k].lambda, d[j], j + 1);
    if (prefixes) {  // ln M over the first j + 1 points
      double log_m = -std::log(static_cast<double>(j + 1));
      for (std::size_t k = 0; k < kRisingBets.size(); ++k)
        log_m = log_add(log_m, std::log(kRisingBets[k].weight) + log_product[k] + log_started[k]);
      prefixes->push_back(log_m);
    }
  }
  // Change points not yet reached hold their prior weight: sum_{b >= n} 1/(b(b+1)) = 1/n.
  double log_m = y.empty() ? 0.0 : -std::log(static_cast<double>(y.size()));
  for (std::size_t k = 0; k < kRisingBets.size(); ++k)
    log_m = log_add(log_m, std::log(kRisingBets[k].weight) + log_product[k] + log_started[k]);
  return log_m;
}

}  // namespace

double change_point_prior(std::size_t baseline_points) {
  if (baseline_points == 0) return 0.0;
  const double b = static_cast<double>(baseline_points);
  return 1.0 / (b * (b + 1.0));
}

double rising_change_evidence(std::span<const double> x, std::span<const double> y) {
  if (x.size() != y.size()) throw std::invalid_argument("rising_change_evidence: x and y differ in length");
  std::vector<std::pair<double, double>> pairs;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) pairs.emplace_back(x[i], y[i]);
  std::stable_sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<double> ordered;
  for (const auto& p : pairs) ordered.push_back(p.second);
  return std::exp(std::min(log_rising_change_evidence(ordered), 700.0));
}

double rising_evidence_threshold(double significance) { return 2.0 / significance; }

std::size_t post_change_points_for_evidence(std::size_t baseline_points, double significance) {
  const double bar = rising_evidence_threshold(significance);
  std::vector<double> y(baseline_points, 0.0);  // a flat baseline: all tied
  for (std::size_t k = 1; k < 1000; ++k) {
    y.push_back(static_cast<double>(k));
    if (std::exp(log_rising_change_evidence(y)) >= bar) return k;
  }
  return 1000;
}

std::size_t minimum_points_for_evidence(double significance) {
  // One flat point then a rise is a rise from the first point: the first point has no rank.
  return 1 + post_change_points_for_evidence(1, significance);
}

double am_noise_ics2(double depth, int harmonics) {
  const double a2 = depth * depth;
  const double lines = (harmonics >= 1 ? a2 : 0.0) + (harmonics >= 2 ? a2 * a2 / 16.0 : 0.0);
  return lines / ((1.0 + a2 / 2.0) * (1.0 + a2 / 2.0));
}

double material_ics2_rise(const SignalProcessingSettings& settings) {
  // The reference wear vibration: noise modulated at depth 1/2 by the mesh (see the header).
  constexpr double kReferenceDepth = 0.5;
  const double share = settings.wear_min_band_share;
  return share * share * am_noise_ics2(kReferenceDepth, settings.ics2_harmonics);
}

ResidualLaw ar1_line_residual_law(std::size_t n, double phi) {
  if (n < 3) return {};
  // MR = R - X B, B = (X'X)^-1 X'R (2 x n), column by column so that memory stays O(n).
  const double nn = static_cast<double>(n);
  const double sk = nn * (nn - 1) / 2, skk = (nn - 1) * nn * (2 * nn - 1) / 6;
  const double det = nn * skk - sk * sk;
  std::vector<double> power(n, 1.0), b0(n), b1(n);  // power[d] = phi^d
  for (std::size_t d = 1; d < n; ++d) power[d] = power[d - 1] * phi;
  auto rho = [&](std::size_t i, std::size_t j) { return power[i > j ? i - j : j - i]; };
  for (std::size_t j = 0; j < n; ++j) {
    double r = 0.0, kr = 0.0;
    for (std::size_t k = 0; k < n; ++k) r += rho(k, j), kr += static_cast<double>(k) * rho(k, j);
    b0[j] = (skk * r - sk * kr) / det;
    b1[j] = (nn * kr - sk * r) / det;
  }
  auto mr = [&](std::size_t i, std::size_t j) { return rho(i, j) - b0[j] - static_cast<double>(i) * b1[j]; };
  double trace = 0.0, trace_sq = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    trace += mr(i, i);
    for (std::size_t j = 0; j < n; ++j) trace_sq += mr(i, j) * mr(j, i);
  }
  return {trace, trace * trace / trace_sq};
}

namespace {

// Residual sum of squares of `y` about its least-squares line against the record index.
double line_residual_ss(std::span<const double> y) {
  const double n = static_cast<double>(y.size());
  double sy = 0.0, sky = 0.0;
  for (std::size_t k = 0; k < y.size(); ++k) sy += y[k], sky += static_cast<double>(k) * y[k];
  const double sk = n * (n - 1) / 2, skk = (n - 1) * n * (2 * n - 1) / 6;
  const double slope = (n * sky - sk * sy) / (n * skk - sk * sk);
  const double intercept = (sy - slope * sk) / n;
  double rss = 0.0;
  for (std::size_t k = 0; k < y.size(); ++k) {
    const double e = y[k] - intercept - slope * static_cast<double>(k);
    rss += e * e;
  }
  return rss;
}

}  // namespace

namespace {

// dof / (tr(MR) chi2_dof(1 - confidence)) for n baseline values: the bound's factor on the RSS.
double wander_bound_factor_of(std::size_t n) {
  const ResidualLaw law = ar1_line_residual_law(n, kWanderMaxCorrelation);
  return law.dof / (law.mean_factor * boost::math::quantile(boost::math::chi_squared(law.dof), 1.0 - kWanderBoundConfidence));
}

// The factor depends on n alone, and every verdict asks it for each length of its growing baseline
// (an O(n²) law and a quantile each): tabulated once for the lengths the setting allows.
double wander_bound_factor(std::size_t n) {
  constexpr std::size_t kTabulated = 201;  // wear_baseline_records is at most 200
  static const std::vector<double> table = [] {
    std::vector<double> t(kTabulated, 0.0);
    for (std::size_t k = 3; k < kTabulated; ++k) t[k] = wander_bound_factor_of(k);
    return t;
  }();
  return n < kTabulated ? table[n] : wander_bound_factor_of(n);
}

}  // namespace

double wander_sd_upper_bound(std::span<const double> baseline) {
  if (baseline.size() < 3) return std::numeric_limits<double>::quiet_NaN();
  return std::sqrt(line_residual_ss(baseline) * wander_bound_factor(baseline.size()));
}

double incomplete_baseline_floor(std::size_t earlier_points, const SignalProcessingSettings& settings) {
  const double configured = material_ics2_rise(settings);
  const double tail = settings.trend_significance / (2.0 * static_cast<double>(std::max<std::size_t>(1, earlier_points)));
  if (configured <= 0.0 || !(tail > 0.0 && tail < 0.5)) return configured;
  const double z = boost::math::quantile(boost::math::normal(), 1.0 - tail);
  return std::max(configured, std::sqrt(2.0) * kEarlyWanderFraction * configured * z);
}

BandFloor band_material_floor(std::span<const double> values, std::size_t earlier_points,
                              const SignalProcessingSettings& settings) {
  BandFloor f;
  f.floor = material_ics2_rise(settings);
  const auto wanted = static_cast<std::size_t>(std::max(0, settings.wear_baseline_records));
  if (wanted == 0 || f.floor <= 0.0) return f;  // off, or materiality off (share 0)
  // The newest point is the one judged: it never measures its own floor.
  const std::size_t usable = std::min(wanted, earlier_points);
  std::vector<double> base;
  for (double v : values)
    if (std::isfinite(v) && base.size() < usable) base.push_back(v);
  f.baseline_points = base.size();
  f.source = FloorSource::baseline_incomplete;
  if (base.size() < kMinimumBaselinePoints) return f;
  // Wear that started inside the baseline and was named at its last record (with the floor that
  // record had): keeping the verdict matters more than a floor measured on a rise, and under no
  // wear this is a false alarm already. The floors of the growing baseline, first to last:
  std::vector<double> log_evidence;
  log_rising_change_evidence(base, &log_evidence);
  const double log_bar = std::log(rising_evidence_threshold(settings.trend_significance));
  const double configured = f.floor;
  double floor_before = configured;  // the floor of point k - 1 (judged on the first k - 1 values)
  for (std::size_t k = kMinimumBaselinePoints - 1; k <= base.size(); ++k) {
    const std::span<const double> first(base.data(), k);
    const double last_rise = first.back() - *std::min_element(first.begin(), first.end() - 1);
    const bool named = log_evidence[k - 1] >= log_bar && last_rise >= floor_before;
    if (k < kMinimumBaselinePoints) {  // point k - 1 had the configured floor; k judges the next
      floor_before = configured;
      continue;
    }
    f.source = named ? FloorSource::baseline_named_wear : FloorSource::baseline;
    f.floor = configured;
    if (!named) {
      f.residual_sd = std::sqrt(line_residual_ss(first) / static_cast<double>(k - 2));
      f.wander_bound = wander_sd_upper_bound(first);
      f.floor = std::max(configured, kWanderFloorMultiple * f.wander_bound);
    }
    floor_before = f.floor;
  }
  return f;
}

namespace {

// Newest finite value minus the lowest earlier finite one (in the given order); 0 with < 2 values.
double rise_over_lowest(const std::vector<double>& values) {
  std::vector<double> finite;
  for (double v : values)
    if (std::isfinite(v)) finite.push_back(v);
  if (finite.size() < 2) return 0.0;
  return finite.back() - *std::min_element(finite.begin(), finite.end() - 1);
}

// "0.0502 (configured ...)": the floor and where it came from, for the evidence line.
std::string floor_text(const BandFloor& f, const SignalProcessingSettings& settings) {
  char text[200];
  const int wanted = settings.wear_baseline_records;
  switch (f.source) {
    case FloorSource::configured:
      std::snprintf(text, sizeof text, "%.3g (configured)", f.floor);
      break;
    case FloorSource::baseline_incomplete:
      std::snprintf(text, sizeof text,
                    "%.3g (first records: wander up to %.2g x the configured %.3g; baseline %zu records, measured from %zu, complete at %d)",
                    f.floor, kEarlyWanderFraction, material_ics2_rise(settings), f.baseline_points, kMinimumBaselinePoints, wanted);
      break;
    case FloorSource::baseline_named_wear:
      std::snprintf(text, sizeof text, "%.3g (configured: wear named at the baseline's last record)", f.floor);
      break;
    case FloorSource::baseline:
      std::snprintf(text, sizeof text, "%.3g (baseline of %zu records: scatter about its line %.3g, wander bound %.3g x %.0f = %.3g%s)",
                    f.floor, f.baseline_points, f.residual_sd, f.wander_bound, kWanderFloorMultiple,
                    kWanderFloorMultiple * f.wander_bound, f.floor > kWanderFloorMultiple * f.wander_bound ? ", below the configured" : "");
      break;
  }
  return text;
}

// Both bands' floors, from `baseline` when given (the daemon's window may have moved past the
// pair's first records), else from the history's own bands (in cycle order).
std::pair<BandFloor, BandFloor> band_floors(const std::vector<double>& cycles, const std::vector<double>& low,
                                            const std::vector<double>& high, std::span<const WearHistoryPoint> baseline,
                                            const SignalProcessingSettings& settings) {
  std::vector<double> base_cycles = cycles, base_low = low, base_high = high;
  if (!baseline.empty()) {
    std::vector<WearHistoryPoint> base(baseline.begin(), baseline.end());
    std::stable_sort(base.begin(), base.end(), [](const auto& a, const auto& b) { return a.cycles < b.cycles; });
    base_cycles.clear(), base_low.clear(), base_high.clear();
    for (const auto& p : base) base_cycles.push_back(p.cycles), base_low.push_back(p.ics2_low), base_high.push_back(p.ics2_high);
  }
  // The baseline's finite values before the judged one (the band's newest finite value), which
  // the baseline holds too while it is still growing.
  auto earlier = [&](const std::vector<double>& y, const std::vector<double>& base) {
    double judged = INFINITY;
    for (std::size_t i = y.size(); i-- > 0;)
      if (std::isfinite(y[i])) {
        judged = cycles[i];
        break;
      }
    std::size_t n = 0;
    for (std::size_t i = 0; i < base.size(); ++i) n += std::isfinite(base[i]) && base_cycles[i] < judged;
    return n;
  };
  // Until the wander is measured the points cannot rule out a wander as large as the early guard.
  auto floor_of = [&](const std::vector<double>& y, const std::vector<double>& base) {
    BandFloor f = band_material_floor(base, earlier(y, base), settings);
    if (f.source == FloorSource::baseline_incomplete)
      f.floor = std::max(f.floor, incomplete_baseline_floor(f.baseline_points, settings));
    return f;
  };
  return {floor_of(low, base_low), floor_of(high, base_high)};
}

}  // namespace

WearMechanismVerdict identify_wear_mechanism(std::span<const WearHistoryPoint> history,
                                             const SignalProcessingSettings& settings,
                                             std::optional<CarrierBand> unseen_band,
                                             std::span<const WearHistoryPoint> baseline) {
  WearMechanismVerdict v = identify_wear_mechanism(history, settings, baseline);
  if (!unseen_band) return v;
  v.unseen_band = unseen_band;
  // The seen band alone decides; the unseen band's history (from records at another rate, if any)
  // is reported in the evidence but not used.
  const bool abrasion_unseen = *unseen_band == CarrierBand::abrasion;
  const TrendTest& seen = abrasion_unseen ? v.low_band : v.high_band;
  const std::size_t needed = minimum_points_for_evidence(settings.trend_significance);
  if (seen.increasing) v.mechanism = abrasion_unseen ? WearMechanism::fatigue_pitting : WearMechanism::abrasive_wear;
  else if (seen.points >= needed) v.mechanism = WearMechanism::none;
  else v.mechanism = WearMechanism::undetermined;
  const FrequencyBand& band = abrasion_unseen ? settings.abrasion_band : settings.pitting_band;
  char text[200];
  std::snprintf(text, sizeof text, "; from the %s band alone: the %s band (%.0f-%.0f Hz) lies above 0.45 fs, so %s cannot be seen",
                abrasion_unseen ? "pitting" : "abrasion", abrasion_unseen ? "abrasion" : "pitting", band.low_hz, band.high_hz,
                abrasion_unseen ? "abrasive wear" : "fatigue pitting");
  v.evidence += text;
  return v;
}

WearMechanismVerdict identify_wear_mechanism(std::span<const WearHistoryPoint> history,
                                             const SignalProcessingSettings& settings,
                                             std::span<const WearHistoryPoint> baseline) {
  const double alpha = settings.trend_significance;
  std::vector<WearHistoryPoint> points(history.begin(), history.end());
  std::stable_sort(points.begin(), points.end(), [](const auto& a, const auto& b) { return a.cycles < b.cycles; });
  std::vector<double> cycles, low, high;
  for (const auto& p : points) {
    cycles.push_back(p.cycles);
    low.push_back(p.ics2_low);
    high.push_back(p.ics2_high);
  }
  WearMechanismVerdict v;
  std::tie(v.low_floor, v.high_floor) = band_floors(cycles, low, high, baseline, settings);
  v.low_band = trend_test(cycles, low, alpha);
  v.high_band = trend_test(cycles, high, alpha);
  // The verdict re-decides at every record: Mann-Kendall at a fixed level would, on a stationary
  // history, eventually report a trend by chance (one more test per record). The sequential
  // evidence keeps that chance below alpha however long the history grows. Significance says
  // nothing of size: a rise must also be material (see the header).
  const double bar = rising_evidence_threshold(alpha);
  for (auto [band, values, floor] : {std::tuple{&v.low_band, &low, v.low_floor.floor}, std::tuple{&v.high_band, &high, v.high_floor.floor}}) {
    band->rising_evidence = rising_change_evidence(cycles, *values);
    band->significant_rise = band->rising_evidence >= bar;
    band->rise = rise_over_lowest(*values);
    band->material = floor <= 0.0 || band->rise >= floor;  // share 0: materiality off
    band->increasing = band->significant_rise && band->material;
  }

  v.band_jumps = significant_band_jumps(points, settings);

  const std::size_t needed = minimum_points_for_evidence(alpha);
  if (v.low_band.points < needed && v.high_band.points < needed) {
    v.mechanism = WearMechanism::undetermined;
  } else if (v.low_band.increasing && v.high_band.increasing) {
    v.mechanism = WearMechanism::both;
  } else if (v.low_band.increasing) {
    v.mechanism = WearMechanism::fatigue_pitting;
  } else if (v.high_band.increasing) {
    v.mechanism = WearMechanism::abrasive_wear;
  } else if (v.low_band.points < needed || v.high_band.points < needed) {
    v.mechanism = WearMechanism::undetermined;  // one band has no verdict and the other no trend
  } else {
    v.mechanism = WearMechanism::none;
  }

  auto trend_word = [](const TrendTest& t) {
    return t.increasing ? " increasing" : t.significant_rise ? " immaterial" : t.decreasing ? " decreasing" : "";
  };
  char buffer[640];
  std::snprintf(buffer, sizeof buffer,
                "low band: n=%zu S=%.0f Z=%.3f p=%.4g rho=%.3f e=%.3g rise=%.3g%s; "
                "high band: n=%zu S=%.0f Z=%.3f p=%.4g rho=%.3f e=%.3g rise=%.3g%s; "
                "alpha=%.3g (rising when e >= %.3g and rise >= the band's floor, configured %.3g, needs >= %zu points); band jumps: %zu",
                v.low_band.points, v.low_band.mann_kendall_s, v.low_band.mann_kendall_z, v.low_band.p_value,
                v.low_band.spearman_rho, v.low_band.rising_evidence, v.low_band.rise, trend_word(v.low_band),
                v.high_band.points, v.high_band.mann_kendall_s, v.high_band.mann_kendall_z, v.high_band.p_value,
                v.high_band.spearman_rho, v.high_band.rising_evidence, v.high_band.rise, trend_word(v.high_band), alpha,
                bar, material_ics2_rise(settings), needed, v.band_jumps.size());
  v.evidence = buffer;
  v.evidence += "; floors: low " + floor_text(v.low_floor, settings) + ", high " + floor_text(v.high_floor, settings);
  for (const auto& j : v.band_jumps) {
    std::snprintf(buffer, sizeof buffer, "; jump at %.6g cycles %.0f Hz -> %.0f Hz", j.cycles, j.from_hz, j.to_hz);
    v.evidence += buffer;
  }
  return v;
}

}  // namespace gearwatch::dsp
