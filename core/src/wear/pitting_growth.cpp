#include "gearwatch/wear/pitting_growth.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <set>

#include <Eigen/Dense>

#include "gearwatch/wear/forecast_intervals.hpp"

namespace gearwatch::wear {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Cycles at which the line reaches g(limit) (+inf when it never does).
double crossing_cycles(double centre, double alpha, double beta, double b, double limit) {
  if (!(beta > 0)) return kInf;
  return centre + (growth_transform(limit, b) - alpha) / beta;
}

double quantile_sorted(const std::vector<double>& v, double p) {
  const double pos = p * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(std::floor(pos));
  if (i + 1 >= v.size()) return v.back();
  const double f = pos - static_cast<double>(i);
  if (!std::isfinite(v[i + 1])) return f > 0 ? v[i + 1] : v[i];
  return v[i] + f * (v[i + 1] - v[i]);
}

bool usable(const DensityReading& x) {
  if (!(x.density > 0 && x.density < 1) || !std::isfinite(x.cycles) || !(x.log_sd >= 0)) return false;
  double shared = 0;
  for (double s : x.shared) {
    if (!std::isfinite(s)) return false;
    shared += s * s;
  }
  return x.log_sd > 0 || shared > 0;
}

/// b's posterior weights on the grid (normalised), the lines, and the grid.
struct ExponentPosterior {
  std::vector<double> b, weight;
  std::vector<GrowthLine> lines;
  int mode = 0;
};

ExponentPosterior exponent_posterior(const std::vector<DensityReading>& r, const GrowthLawSettings& s) {
  ExponentPosterior p;
  const int n = s.grid_points;
  p.b.resize(n);
  p.weight.resize(n);
  p.lines.resize(n);
  double best = kInf;
  for (int k = 0; k < n; ++k) {
    p.b[k] = s.b_min + (s.b_max - s.b_min) * k / (n - 1);
    p.lines[k] = growth_line_fit(r, p.b[k]);
    const double z = (p.b[k] - s.b_prior_mean) / s.b_prior_sd;
    p.weight[k] = p.lines[k].valid ? 0.5 * (p.lines[k].chi2 + z * z) : kInf;
    best = std::min(best, p.weight[k]);
  }
  if (!std::isfinite(best)) return {};
  double total = 0;
  for (int k = 0; k < n; ++k) {
    p.weight[k] = std::isfinite(p.weight[k]) ? std::exp(best - p.weight[k]) : 0.0;
    if (p.weight[k] > p.weight[p.mode]) p.mode = k;
    total += p.weight[k];
  }
  for (double& w : p.weight) w /= total;
  return p;
}

}  // namespace

const char* to_string(GrowthExponentBound bound) noexcept {
  switch (bound) {
    case GrowthExponentBound::inside: return "inside";
    case GrowthExponentBound::at_lower: return "at_lower";
    case GrowthExponentBound::at_upper: return "at_upper";
  }
  return "?";
}

double growth_transform(double density, double b) {
  const double d = density, lambda = 1.0 - b;
  const double power = std::pow(d, lambda);
  const double head = std::abs(lambda) < 1e-12 ? std::log(d) : (power - 1.0) / lambda;
  // Σ_k D^(k+1+λ)/(k+1+λ) = D^λ [−ln(1 − D) − λ Σ_k D^(k+1) / ((k+1)(k+1+λ))]: the remaining
  // series' terms fall as 1/k², so it converges for every D < 1.
  double tail = 0, p = d;
  for (int k = 0; k < 2000; ++k) {   // converged to 1e-17 for D ≤ 0.98; a few 1e-4 near D = 1
    const double term = p / ((k + 1.0) * (k + 1.0 + lambda));
    tail += term;
    if (term < 1e-17 * tail) break;
    p *= d;
  }
  return head + power * (-std::log1p(-d) - lambda * tail);
}

double growth_inverse(double y, double b) {
  // g is increasing in v = logit D with d g / d v = D^(1 − b): Newton on v inside a bisection
  // bracket (D from 1e-300 to 1 − 1e-16).
  double lo = -690.0, hi = 36.0;
  auto density = [](double v) { return 1.0 / (1.0 + std::exp(-v)); };
  if (y <= growth_transform(density(lo), b)) return 0.0;
  if (y >= growth_transform(density(hi), b)) return density(hi);
  double v = std::clamp(y, lo, hi);
  for (int i = 0; i < 200; ++i) {
    const double d = density(v), gap = growth_transform(d, b) - y;
    (gap < 0 ? lo : hi) = v;
    if (std::abs(gap) < 1e-13 * std::max(1.0, std::abs(y)) || hi - lo < 1e-13) break;
    const double next = v - gap / std::pow(d, 1.0 - b);
    v = next > lo && next < hi ? next : 0.5 * (lo + hi);
  }
  return density(v);
}

double growth_log_slope(double density, double b) { return std::pow(density, 1.0 - b) / (1.0 - density); }

namespace {

/// One generalised least squares solve with the slopes d g / d ln D at `at` (one per reading).
GrowthLine solve_line(const std::vector<DensityReading>& r, double b, const std::vector<double>& at, double centre, double span) {
  GrowthLine l;
  const auto n = static_cast<Eigen::Index>(r.size());
  Eigen::MatrixXd design(n, 2);
  Eigen::VectorXd y(n), jac(n), own(n);
  Eigen::MatrixXd shared(n, static_cast<Eigen::Index>(kGrowthSharedErrors));
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& x = r[static_cast<std::size_t>(i)];
    design(i, 0) = 1.0;
    design(i, 1) = (x.cycles - centre) / span;
    y(i) = growth_transform(x.density, b);
    jac(i) = growth_log_slope(at[static_cast<std::size_t>(i)], b);
    own(i) = x.log_sd * x.log_sd;
    for (std::size_t j = 0; j < kGrowthSharedErrors; ++j) shared(i, static_cast<Eigen::Index>(j)) = x.shared[j];
  }
  // Covariance in the line's units: J (diag(own) + S Sᵀ) J.
  Eigen::MatrixXd cov = shared * shared.transpose();
  cov.diagonal() += own;
  cov = jac.asDiagonal() * cov * jac.asDiagonal();
  const Eigen::LLT<Eigen::MatrixXd> chol(cov);
  if (chol.info() != Eigen::Success) return l;
  const Eigen::MatrixXd cinv_x = chol.solve(design);
  const Eigen::Matrix2d normal = design.transpose() * cinv_x;
  if (!(normal.determinant() > 0)) return l;
  const Eigen::Matrix2d param_cov = normal.inverse();
  const Eigen::Vector2d theta = param_cov * (design.transpose() * chol.solve(y));
  const Eigen::VectorXd resid = y - design * theta;
  l.centre = centre;
  l.alpha = theta(0);
  l.beta = theta(1) / span;
  l.var_alpha = param_cov(0, 0);
  l.var_beta = param_cov(1, 1) / (span * span);
  l.cov_alpha_beta = param_cov(0, 1) / span;
  l.chi2 = resid.dot(chol.solve(resid));
  l.valid = std::isfinite(l.chi2) && std::isfinite(l.alpha) && std::isfinite(l.beta);
  return l;
}

}  // namespace

GrowthLine growth_line_fit(const std::vector<DensityReading>& r, double b) {
  if (r.size() < 2) return {};
  double centre = 0;
  for (const auto& x : r) centre += x.cycles;
  centre /= static_cast<double>(r.size());
  double span = 0;
  for (const auto& x : r) span = std::max(span, std::abs(x.cycles - centre));
  if (!(span > 0)) return {};
  // The slopes at the line's densities, not the readings' (abscissa in units of the span: the
  // normal equations stay well conditioned): a reading's error changes its own slope, and weights
  // from the read values would favour the readings below the truth. Fixed point from the readings.
  std::vector<double> at(r.size());
  for (std::size_t i = 0; i < r.size(); ++i) at[i] = r[i].density;
  GrowthLine l;
  for (int pass = 0; pass < 12; ++pass) {
    const GrowthLine next = solve_line(r, b, at, centre, span);
    if (!next.valid) return pass == 0 ? next : l;
    l = next;
    double moved = 0;
    for (std::size_t i = 0; i < r.size(); ++i) {
      const double d = std::clamp(growth_inverse(l.alpha + l.beta * (r[i].cycles - centre), b), 1e-9, 1.0 - 1e-9);
      moved = std::max(moved, std::abs(std::log(d / at[i])));
      at[i] = d;
    }
    if (moved < 1e-10) break;
  }
  return l;
}

GrowthLawFit fit_growth_law(const std::vector<DensityReading>& readings, double limit, double now,
                            const GrowthLawSettings& s) {
  GrowthLawFit fit;
  std::vector<DensityReading> r;
  std::set<double> distinct;
  for (const auto& x : readings)
    if (usable(x)) {
      r.push_back(x);
      distinct.insert(x.cycles);
    }
  fit.readings = static_cast<int>(r.size());
  if (distinct.size() < 3 || s.grid_points < 2 || !(limit > 0 && limit < 1)) return fit;

  // b's posterior on the grid: prior on b times the line's profile likelihood exp(−χ²/2).
  const ExponentPosterior post = exponent_posterior(r, s);
  if (post.b.empty()) return fit;
  const int n = s.grid_points;
  double mean = 0, sq = 0;
  for (int k = 0; k < n; ++k) {
    mean += post.weight[k] * post.b[k];
    sq += post.weight[k] * post.b[k] * post.b[k];
  }
  fit.b_mean = mean;
  fit.b_sd = std::sqrt(std::max(0.0, sq - mean * mean));
  fit.bound = post.mode == 0 ? GrowthExponentBound::at_lower : post.mode == n - 1 ? GrowthExponentBound::at_upper : GrowthExponentBound::inside;
  const auto& lm = post.lines[post.mode];
  fit.density_now = growth_inverse(lm.alpha + lm.beta * (now - lm.centre), post.b[post.mode]);

  // Draws: b by its posterior (stratified), α and β by their joint normal posterior given b.
  std::mt19937_64 rng(s.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> cdf(n);
  double c = 0;
  for (int k = 0; k < n; ++k) cdf[k] = (c += post.weight[k]);
  std::vector<double> left;
  left.reserve(static_cast<std::size_t>(s.samples));
  for (int j = 0; j < s.samples; ++j) {
    const double u = (j + 0.5) / s.samples;
    const int k = static_cast<int>(std::min<std::ptrdiff_t>(std::lower_bound(cdf.begin(), cdf.end(), u) - cdf.begin(), n - 1));
    const auto& l = post.lines[k];
    // The 2 × 2 Cholesky factor of (α, β)'s covariance.
    const double sa = std::sqrt(l.var_alpha), rho_sb = l.cov_alpha_beta / sa;
    const double sb = std::sqrt(std::max(0.0, l.var_beta - rho_sb * rho_sb));
    const double z1 = normal(rng), z2 = normal(rng);
    const double alpha = l.alpha + sa * z1, beta = l.beta + rho_sb * z1 + sb * z2;
    left.push_back(std::max(0.0, crossing_cycles(l.centre, alpha, beta, post.b[k], limit) - now));
  }
  std::sort(left.begin(), left.end());
  fit.cycles_left = quantile_sorted(left, 0.5);
  fit.cycles_left_low = quantile_sorted(left, 0.5 - s.coverage / 2);
  fit.cycles_left_high = quantile_sorted(left, 0.5 + s.coverage / 2);
  fit.valid = true;
  return fit;
}


ExponentCrossing inspection_exponent_crossing(double n0, double d0, double n1, double d1, double log_sd0, double log_sd1,
                                              double limit, double now, double coverage) {
  ExponentCrossing x;
  const bool ordered = n0 > 0 && n1 > n0 && d0 > 0 && d1 > d0 && d1 < 1 && limit > 0 && limit < 1;
  const bool sds = std::isfinite(log_sd0) && std::isfinite(log_sd1) && log_sd0 >= 0 && log_sd1 >= 0;
  if (!ordered || !sds || !std::isfinite(now) || !(coverage > 0 && coverage < 1)) return x;
  const double h0 = -std::log1p(-d0), h1 = -std::log1p(-d1), hl = -std::log1p(-limit);
  const double span = std::log(n1 / n0), v = std::log(h1 / h0), u = std::log(hl / h1);
  x.exponent = v / span;
  // A reading's error in ln D moves ln H by d ln H / d ln D = D / ((1 − D) H).
  const double s0 = log_sd0 * d0 / ((1 - d0) * h0), s1 = log_sd1 * d1 / ((1 - d1) * h1);
  x.exponent_sd = std::hypot(s0, s1) / span;
  // ln N_L = ln n1 + span u / v: its derivatives in ln H1 and ln H0 (delta method).
  const double g1 = -span * (u + v) / (v * v), g0 = span * u / (v * v);
  x.log_sd = std::hypot(g1 * s1, g0 * s0);
  x.crossing_cycles = n1 * std::exp(span * u / v);
  const double z = normal_quantile(0.5 + coverage / 2);
  x.cycles_left = std::max(0.0, x.crossing_cycles - now);
  x.cycles_left_low = std::max(0.0, x.crossing_cycles * std::exp(-z * x.log_sd) - now);
  x.cycles_left_high = std::max(0.0, x.crossing_cycles * std::exp(z * x.log_sd) - now);
  x.valid = std::isfinite(x.crossing_cycles);
  return x;
}

}  // namespace gearwatch::wear
