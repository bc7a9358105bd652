#include "gearwatch/gap/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <map>

namespace gearwatch::gap {
namespace {

constexpr std::size_t kFixed = static_cast<std::size_t>(FamilyKind::fixed_frequency);
constexpr double kLowestBandHz = 10.0;
// The Hz part is shrunk towards 0 as if each band had this many extra points at no gap, so a band
// seen by a handful of lines does not absorb their order-fixed differences.
constexpr double kBandShrinkage = 1.0;
constexpr int kIterations = 40;
// Bins this many floors above it in either spectrum inform the split into order and Hz parts.
constexpr double kInformativeFloors = 10.0;

}  // namespace

double GapEvaluation::energy_share(std::size_t family) const {
  double total = 0;
  for (double e : energy) total += e;
  return total > 0 ? energy[family] / total : 0.0;
}

Interval bootstrap_interval(std::vector<double> draws, double estimate, double coverage) {
  if (draws.empty()) return {estimate, estimate};
  std::sort(draws.begin(), draws.end());
  // Nearest rank: with the few hundred draws a report uses, interpolating would not change a digit.
  auto quantile = [&](double p) { return draws[static_cast<std::size_t>(std::round(p * static_cast<double>(draws.size() - 1)))]; };
  const double tail = (1.0 - std::clamp(coverage, 0.0, 1.0)) / 2.0;
  const double shift = estimate - quantile(0.5);
  return {std::max(0.0, quantile(tail) + shift), std::max(0.0, quantile(1.0 - tail) + shift)};
}

GapEvaluator::GapEvaluator(const GearPairSpec& gears, double bands_per_octave, double min_speed_ratio)
    : gears_(gears), bands_per_octave_(bands_per_octave), min_speed_ratio_(min_speed_ratio) {}

std::string GapEvaluator::fixed_frequency_reason(const std::vector<GapPair>& pairs) const {
  // Lines are compared across speeds at one load (a line's identity includes its load).
  std::map<double, std::pair<double, double>> span;  // load → slowest, fastest
  for (const auto& p : pairs) {
    const double t = std::isfinite(p.measured->torque_nm) ? std::round(p.measured->torque_nm * 100) / 100 : -1.0;
    auto [it, fresh] = span.try_emplace(t, p.measured->speed_hz, p.measured->speed_hz);
    it->second.first = std::min(it->second.first, p.measured->speed_hz);
    it->second.second = std::max(it->second.second, p.measured->speed_hz);
  }
  for (const auto& [load, s] : span)
    if (s.second >= s.first * min_speed_ratio_) return "";
  return "fixed_frequency needs records at >= 2 speeds (at least " +
         std::to_string(static_cast<int>(std::round((min_speed_ratio_ - 1) * 100))) + " % apart) at one load; " +
         (span.size() > 1 ? "each load here has one" : "these are at one");
}

void GapEvaluator::collect_points(const std::vector<GapPair>& pairs, std::size_t max_order, std::size_t keys_per_load,
                                  std::vector<double>& loads) const {
  const int z1 = gears_.pinion_teeth, z2 = gears_.gear_teeth;
  auto load_group = [&](double torque) {
    const double t = std::isfinite(torque) ? std::round(torque * 100) / 100 : -1.0;
    const auto it = std::find(loads.begin(), loads.end(), t);
    if (it != loads.end()) return static_cast<std::size_t>(it - loads.begin());
    loads.push_back(t);
    return loads.size() - 1;
  };
  auto& pts = points_;
  pts.clear();
  std::size_t total = 0;
  for (const auto& p : pairs)
    total += 2 * std::min(p.measured->input_lines.size(), p.model->input_lines.size()) +
             std::min(p.measured->output_lines.size(), p.model->output_lines.size());
  pts.reserve(total);
  for (const auto& p : pairs) {
    const std::size_t key0 = load_group(p.measured->torque_nm) * keys_per_load;
    const auto& m = *p.measured;
    const auto& q = *p.model;
    auto ratio = [&](double a, double b) { return 10.0 * std::log10((a + p.floor) / (b + p.floor)); };
    const std::size_t first = pts.size();
    const std::size_t ki = std::min(m.input_lines.size(), q.input_lines.size());
    for (std::size_t k = 1; k <= ki; ++k) {
      const double hz = k * m.speed_hz;
      pts.push_back({key0 + k, hz, ratio(m.input_lines[k - 1], q.input_lines[k - 1]), q.input_lines[k - 1], m.input_lines[k - 1],
                     static_cast<std::size_t>(input_line_family(static_cast<int>(k), z1))});
      pts.push_back({key0 + 2 * max_order + k, hz, ratio(m.broadband[k - 1], q.broadband[k - 1]), q.broadband[k - 1],
                     m.broadband[k - 1], static_cast<std::size_t>(FamilyKind::broadband)});
    }
    const std::size_t ko = std::min(m.output_lines.size(), q.output_lines.size());
    for (std::size_t o = 1; o <= ko; ++o) {
      if (output_line_is_mesh(static_cast<int>(o), z2)) continue;
      pts.push_back({key0 + max_order + o, o * m.speed_hz * z1 / z2, ratio(m.output_lines[o - 1], q.output_lines[o - 1]),
                     q.output_lines[o - 1], m.output_lines[o - 1],
                     static_cast<std::size_t>(output_line_family(static_cast<int>(o), z2))});
    }
    for (std::size_t i = first; i < pts.size(); ++i) {
      pts[i].speed = m.speed_hz;
      pts[i].informative = std::max(pts[i].measured, pts[i].model) > kInformativeFloors * p.floor;
    }
  }
}

GapEvaluation GapEvaluator::evaluate(const std::vector<GapPair>& pairs, bool decompose) const {
  GapEvaluation e;
  std::size_t max_order = 0;
  for (const auto& p : pairs) max_order = std::max({max_order, p.measured->input_lines.size(), p.measured->output_lines.size()});
  // A line's identity is its shaft and order at one load: how an effect scales a line may change
  // with the load (a misaligned face carries more of the load as it grows), never with the speed.
  const std::size_t keys_per_load = 3 * max_order + 2;
  std::vector<double> loads;
  collect_points(pairs, max_order, keys_per_load, loads);
  auto& pts = points_;
  for (std::size_t f = 0; f < e.resolved.size(); ++f) e.resolved[f] = true;
  const bool resolvable = fixed_frequency_reason(pairs).empty();
  e.resolved[kFixed] = resolvable;
  std::vector<double> band_gain;
  if (decompose && resolvable) {
    int bands = 0;
    for (auto& pt : pts)
      if (pt.hz >= kLowestBandHz) {
        pt.band = static_cast<int>(std::floor(bands_per_octave_ * std::log2(pt.hz / kLowestBandHz)));
        bands = std::max(bands, pt.band + 1);
      }
    // A band is identifiable only when informative lines at two speeds fall in it.
    std::vector<double> speed_min(bands, 1e300), speed_max(bands, 0);
    for (const auto& pt : pts)
      if (pt.band >= 0 && pt.informative) {
        speed_min[pt.band] = std::min(speed_min[pt.band], pt.speed);
        speed_max[pt.band] = std::max(speed_max[pt.band], pt.speed);
      }
    std::vector<char> usable(bands);
    for (int b = 0; b < bands; ++b) usable[b] = speed_max[b] >= speed_min[b] * min_speed_ratio_;
    auto& line = line_;
    auto& line_n = line_n_;
    line.assign(keys_per_load * loads.size(), 0.0);
    line_n.assign(keys_per_load * loads.size(), 0.0);
    band_gain.assign(bands, 0.0);
    std::vector<double> band_sum(bands), band_n(bands);
    for (int it = 0; it < kIterations; ++it) {
      std::fill(line.begin(), line.end(), 0.0);
      std::fill(line_n.begin(), line_n.end(), 0.0);
      for (const auto& pt : pts) {
        if (!pt.informative) continue;
        line[pt.key] += pt.g - (pt.band >= 0 ? band_gain[pt.band] : 0.0);
        line_n[pt.key] += 1;
      }
      for (std::size_t k = 0; k < line.size(); ++k)
        if (line_n[k] > 0) line[k] /= line_n[k];
      std::fill(band_sum.begin(), band_sum.end(), 0.0);
      std::fill(band_n.begin(), band_n.end(), 0.0);
      for (const auto& pt : pts)
        if (pt.informative && pt.band >= 0 && usable[pt.band]) band_sum[pt.band] += pt.g - line[pt.key], band_n[pt.band] += 1;
      for (int b = 0; b < bands; ++b) band_gain[b] = usable[b] ? band_sum[b] / (band_n[b] + kBandShrinkage) : 0.0;
    }
    // The fixed-frequency family's bins are its Hz bands (each once, however many lines it holds).
    for (int b = 0; b < bands; ++b)
      if (usable[b]) e.sum_sq[kFixed] += band_gain[b] * band_gain[b], e.count[kFixed] += 1;
    for (int b = 0; b < bands; ++b)
      if (usable[b])
        e.fixed_bands.push_back({kLowestBandHz * std::exp2(b / bands_per_octave_),
                                 kLowestBandHz * std::exp2((b + 1) / bands_per_octave_), band_gain[b]});
  }
  for (const auto& pt : pts) {
    const double fixed = pt.informative && pt.band >= 0 && !band_gain.empty() ? band_gain[pt.band] : 0.0;
    const double rest = pt.g - fixed;
    e.sum_sq[pt.family] += rest * rest;
    e.count[pt.family] += 1;
    const double model_fixed = pt.model * std::pow(10.0, fixed / 10.0);
    e.energy[pt.family] += std::abs(pt.measured - model_fixed);
    if (!band_gain.empty() && pt.informative) e.energy[kFixed] += std::abs(model_fixed - pt.model);
  }
  for (std::size_t f = 0; f < e.resolved.size(); ++f)
    if (f != kFixed && e.count[f] == 0) e.resolved[f] = false;
  return e;
}

}  // namespace gearwatch::gap
