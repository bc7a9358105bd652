#include "gearwatch/wear/pitting_growth.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <set>

namespace gearwatch::wear {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// A weighted straight line y = α + β (N − N̄) with its covariance, and its χ².
struct WeightedLine {
  bool valid = false;
  double centre = 0, alpha = 0, beta = 0;
  double var_alpha = 0, var_beta = 0;   // independent: the abscissa is centred on its weighted mean
  double chi2 = 0;
};

WeightedLine fit_line(const std::vector<DensityReading>& r, double lambda) {
  WeightedLine l;
  double sw = 0, swn = 0;
  std::vector<double> y(r.size()), w(r.size());
  for (std::size_t i = 0; i < r.size(); ++i) {
    y[i] = growth_transform(r[i].density, lambda);
    // Delta method: SD of g(D) = dg/dD · D · SD(ln D) = D^λ SD(ln D).
    const double sd = std::pow(r[i].density, lambda) * r[i].log_sd;
    w[i] = 1.0 / (sd * sd);
    sw += w[i];
    swn += w[i] * r[i].cycles;
  }
  l.centre = swn / sw;
  double sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    const double x = r[i].cycles - l.centre;
    sy += w[i] * y[i];
    sxx += w[i] * x * x;
    sxy += w[i] * x * y[i];
  }
  if (!(sxx > 0)) return l;
  l.alpha = sy / sw;
  l.beta = sxy / sxx;
  l.var_alpha = 1.0 / sw;
  l.var_beta = 1.0 / sxx;
  for (std::size_t i = 0; i < r.size(); ++i) {
    const double e = y[i] - l.alpha - l.beta * (r[i].cycles - l.centre);
    l.chi2 += w[i] * e * e;
  }
  l.valid = std::isfinite(l.chi2);
  return l;
}

/// Cycles at which the line reaches g(limit) (+inf when it never does).
double crossing_cycles(const WeightedLine& l, double alpha, double beta, double lambda, double limit) {
  if (!(beta > 0)) return kInf;
  return l.centre + (growth_transform(limit, lambda) - alpha) / beta;
}

double quantile_sorted(const std::vector<double>& v, double p) {
  const double pos = p * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(std::floor(pos));
  if (i + 1 >= v.size()) return v.back();
  const double f = pos - static_cast<double>(i);
  if (!std::isfinite(v[i + 1])) return f > 0 ? v[i + 1] : v[i];
  return v[i] + f * (v[i + 1] - v[i]);
}

}  // namespace

double growth_transform(double density, double lambda) {
  if (std::abs(lambda) < 1e-9) return std::log(density);
  return (std::pow(density, lambda) - 1.0) / lambda;
}

double growth_inverse(double y, double lambda) {
  if (std::abs(lambda) < 1e-9) return std::exp(y);
  const double base = 1.0 + lambda * y;
  if (base <= 0) return lambda < 0 ? kInf : 0.0;
  return std::pow(base, 1.0 / lambda);
}

GrowthLawFit fit_growth_law(const std::vector<DensityReading>& readings, double limit, double now,
                            const GrowthLawSettings& s) {
  GrowthLawFit fit;
  std::vector<DensityReading> r;
  std::set<double> distinct;
  for (const auto& x : readings)
    if (x.density > 0 && std::isfinite(x.density) && x.log_sd > 0 && std::isfinite(x.cycles)) {
      r.push_back(x);
      distinct.insert(x.cycles);
    }
  fit.readings = static_cast<int>(r.size());
  if (distinct.size() < 3 || s.grid_points < 2) return fit;

  // λ's posterior on the grid: prior on b times the line's profile likelihood exp(−χ²/2).
  const int n = s.grid_points;
  std::vector<double> b(n), weight(n);
  std::vector<WeightedLine> lines(n);
  double best = kInf;
  for (int k = 0; k < n; ++k) {
    b[k] = s.b_min + (s.b_max - s.b_min) * k / (n - 1);
    lines[k] = fit_line(r, 1.0 - b[k]);
    const double z = (b[k] - s.b_prior_mean) / s.b_prior_sd;
    weight[k] = lines[k].valid ? 0.5 * (lines[k].chi2 + z * z) : kInf;
    best = std::min(best, weight[k]);
  }
  if (!std::isfinite(best)) return fit;
  double total = 0;
  int mode = 0;
  for (int k = 0; k < n; ++k) {
    weight[k] = std::isfinite(weight[k]) ? std::exp(best - weight[k]) : 0.0;
    if (weight[k] > weight[mode]) mode = k;
    total += weight[k];
  }
  double mean = 0, sq = 0;
  for (int k = 0; k < n; ++k) {
    weight[k] /= total;
    mean += weight[k] * b[k];
    sq += weight[k] * b[k] * b[k];
  }
  fit.b_mean = mean;
  fit.b_sd = std::sqrt(std::max(0.0, sq - mean * mean));
  const auto& lm = lines[mode];
  fit.density_now = growth_inverse(lm.alpha + lm.beta * (now - lm.centre), 1.0 - b[mode]);

  // Draws: λ by its posterior (stratified), α and β by their normal posterior given λ.
  std::mt19937_64 rng(s.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> cdf(n);
  double c = 0;
  for (int k = 0; k < n; ++k) cdf[k] = (c += weight[k]);
  std::vector<double> left;
  left.reserve(static_cast<std::size_t>(s.samples));
  for (int j = 0; j < s.samples; ++j) {
    const double u = (j + 0.5) / s.samples;
    const int k = static_cast<int>(std::min<std::ptrdiff_t>(std::lower_bound(cdf.begin(), cdf.end(), u) - cdf.begin(), n - 1));
    const auto& l = lines[k];
    const double alpha = l.alpha + std::sqrt(l.var_alpha) * normal(rng);
    const double beta = l.beta + std::sqrt(l.var_beta) * normal(rng);
    left.push_back(std::max(0.0, crossing_cycles(l, alpha, beta, 1.0 - b[k], limit) - now));
  }
  std::sort(left.begin(), left.end());
  fit.cycles_left = quantile_sorted(left, 0.5);
  fit.cycles_left_low = quantile_sorted(left, 0.5 - s.coverage / 2);
  fit.cycles_left_high = quantile_sorted(left, 0.5 + s.coverage / 2);
  fit.valid = true;
  return fit;
}

}  // namespace gearwatch::wear
