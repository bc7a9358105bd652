#include "gearwatch/twin/mesh_pattern_fit.hpp"

#include "gearwatch/numeric/line_search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace gearwatch::twin {

const char* to_string(MeshScaleEvidence e) {
  switch (e) {
    case MeshScaleEvidence::identified: return "identified";
    case MeshScaleEvidence::too_few_harmonics: return "too_few_harmonics";
    case MeshScaleEvidence::minimum_at_bound: return "minimum_at_bound";
    case MeshScaleEvidence::interval_reaches_bound: return "interval_reaches_bound";
  }
  return "unknown";
}

namespace {

constexpr std::size_t kMinHarmonics = 3;  // a scale and a gain fitted: one degree of freedom left

class PatternFitter {
 public:
  PatternFitter(std::span<const double> measured, double floor, const MeshHarmonicsAt& twin, const MeshPatternSettings& s)
      : measured_(measured), floor_(floor), twin_(twin), s_(s) {}

  MeshPatternFit run() {
    check_settings();
    select_harmonics();
    if (fit_.harmonics.size() < kMinHarmonics) {
      fit_.interval_low = s_.low;
      fit_.interval_high = s_.high;
      return fit_;
    }
    scan_range();
    refine_minimum();
    state_interval();
    std::sort(fit_.scan.begin(), fit_.scan.end());
    return fit_;
  }

 private:
  void check_settings() const {
    if (!(s_.low > 0) || !(s_.high > s_.low) || !(s_.grid_step > 0) || !(s_.tolerance > 0) || !(s_.min_snr >= 0) ||
        !(s_.interval_chi2 > 0) || !(floor_ >= 0) || !(s_.prior >= s_.low && s_.prior <= s_.high))
      throw std::invalid_argument("mesh pattern fit: range, step, tolerance, SNR, interval bound and floor must be positive");
  }

  // The harmonics measured, positive and above the floor.
  void select_harmonics() {
    for (std::size_t i = 0; i < measured_.size(); ++i) {
      const double a = measured_[i];
      if (std::isfinite(a) && a > 0 && a >= s_.min_snr * floor_) {
        fit_.harmonics.push_back(static_cast<int>(i + 1));
        ln_measured_.push_back(std::log(a));
      }
    }
  }

  // Σ (d_n − mean d)², d_n = ln measured − ln twin: the pattern's misfit with the best gain.
  double cost(double scale) {
    const std::vector<double> h = twin_(scale);
    ++fit_.simulations;
    std::vector<double> d;
    for (std::size_t k = 0; k < fit_.harmonics.size(); ++k) {
      const auto i = static_cast<std::size_t>(fit_.harmonics[k] - 1);
      if (i >= h.size() || !(h[i] > 0) || !std::isfinite(h[i]))
        throw std::invalid_argument("mesh pattern fit: the twin has no positive amplitude at harmonic " +
                                    std::to_string(fit_.harmonics[k]));
      d.push_back(ln_measured_[k] - std::log(h[i]));
    }
    double mean = 0;
    for (double v : d) mean += v;
    mean /= static_cast<double>(d.size());
    double c = 0;
    for (double v : d) c += (v - mean) * (v - mean);
    fit_.scan.emplace_back(scale, c);
    if (c < best_cost_) {
      best_cost_ = c;
      fit_.scale = scale;
      fit_.gain_ln = mean;
    }
    return c;
  }

  void scan_range() {
    const int steps = static_cast<int>(std::ceil((s_.high - s_.low) / s_.grid_step - 1e-9));
    for (int i = 0; i <= steps; ++i) cost(std::min(s_.high, s_.low + i * s_.grid_step));
  }

  // Golden section between the best scan point's neighbours; cost() keeps the best point it saw.
  void refine_minimum() {
    const double a = std::max(s_.low, fit_.scale - s_.grid_step), b = std::min(s_.high, fit_.scale + s_.grid_step);
    numeric::golden_section_maximise([this](double x) { return -cost(x); }, a, b, s_.tolerance,
                                     std::numeric_limits<int>::max());
  }

  // Every run whose cost is within the bound, widened to where the cost crosses it between runs.
  void state_interval() {
    const double dof = static_cast<double>(fit_.harmonics.size() - 2);
    fit_.misfit_ln_rms = std::sqrt(best_cost_ / static_cast<double>(fit_.harmonics.size()));
    const double bound = best_cost_ * (1.0 + s_.interval_chi2 / dof);
    std::vector<std::pair<double, double>> runs = fit_.scan;
    std::sort(runs.begin(), runs.end());
    std::size_t first = runs.size(), last = 0;
    for (std::size_t i = 0; i < runs.size(); ++i)
      if (runs[i].second <= bound) {
        first = std::min(first, i);
        last = i;
      }
    auto crossing = [&](std::size_t in, std::size_t out) {
      const auto [si, ci] = runs[in];
      const auto [so, co] = runs[out];
      return co > ci ? si + (so - si) * (bound - ci) / (co - ci) : si;
    };
    fit_.interval_low = first > 0 ? crossing(first, first - 1) : runs[first].first;
    fit_.interval_high = last + 1 < runs.size() ? crossing(last, last + 1) : runs[last].first;
    const double edge = 0.5 * s_.tolerance;
    if (fit_.scale <= s_.low + edge || fit_.scale >= s_.high - edge)
      fit_.evidence = MeshScaleEvidence::minimum_at_bound;
    else if (fit_.interval_low <= s_.low + edge || fit_.interval_high >= s_.high - edge)
      fit_.evidence = MeshScaleEvidence::interval_reaches_bound;
    else
      fit_.evidence = MeshScaleEvidence::identified;
    fit_.nearest_scale = fit_.scale;
    if (fit_.evidence != MeshScaleEvidence::identified && s_.prior >= fit_.interval_low && s_.prior <= fit_.interval_high)
      fit_.scale = s_.prior;
  }

  std::span<const double> measured_;
  double floor_;
  const MeshHarmonicsAt& twin_;
  MeshPatternSettings s_;
  std::vector<double> ln_measured_;
  double best_cost_ = std::numeric_limits<double>::infinity();
  MeshPatternFit fit_;
};

}  // namespace

MeshPatternFit fit_mesh_pattern(std::span<const double> measured, double floor, const MeshHarmonicsAt& twin,
                                const MeshPatternSettings& settings) {
  return PatternFitter(measured, floor, twin, settings).run();
}

}  // namespace gearwatch::twin
