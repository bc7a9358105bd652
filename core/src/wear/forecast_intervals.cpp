#include "gearwatch/wear/forecast_intervals.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "gearwatch/dsp/wear_mechanism.hpp"

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>

namespace gearwatch::wear {

LogPosterior predict(LogPosterior p, double cycles, double q_per_cycle) {
  if (p.valid && cycles > p.cycles) p.var += q_per_cycle * (cycles - p.cycles);
  p.cycles = std::max(p.cycles, cycles);
  return p;
}

LogPosterior conjugate_update(const LogPosterior& prior, double z, double r) {
  LogPosterior out = prior;
  out.valid = true;
  if (!prior.valid || !(prior.var > 0)) {
    // No prior belief (or none left to weigh): the measurement is the belief.
    out.mean = prior.valid && prior.var == 0 ? prior.mean : z;
    out.var = prior.valid && prior.var == 0 ? 0.0 : r;
    return out;
  }
  out.var = 1.0 / (1.0 / prior.var + 1.0 / r);
  out.mean = out.var * (prior.mean / prior.var + z / r);
  return out;
}

FilterStep filter_update(const LogPosterior& prior, double z, double r, double gate_sd) {
  FilterStep s;
  LogPosterior p = prior;
  if (p.valid) {
    const double innovation = z - p.mean;
    s.innovation_sd = innovation / std::sqrt(p.var + r);
    if (std::abs(s.innovation_sd) > gate_sd) {
      p.var = std::max(p.var, innovation * innovation - r);
      s.inflated = true;
    }
  }
  s.posterior = conjugate_update(p, z, r);
  return s;
}

double normal_quantile(double p) { return boost::math::quantile(boost::math::normal_distribution<double>(), p); }

double chi_square_quantile(double p, double dof) {
  return boost::math::quantile(boost::math::chi_squared_distribution<double>(dof), p);
}

PathMeanMoments path_mean_moments(double q_per_cycle, double cycles) {
  const double x = q_per_cycle * std::max(0.0, cycles);
  PathMeanMoments m;
  if (x < 1e-6) {
    // Series to first order in x: E[A] = 1 + x/4, Var ln A = x/3 (the walk's mean), so μ = x/12.
    m.log_var = x / 3.0;
    m.log_mean = x / 12.0;
    return m;
  }
  const double mean = std::expm1(x / 2.0) / (x / 2.0);
  const double second = 4.0 / (3.0 * x * x) * (std::expm1(2.0 * x) / 2.0 - 2.0 * std::expm1(x / 2.0));
  m.log_var = std::log(second / (mean * mean));
  m.log_mean = std::log(mean) - m.log_var / 2.0;
  return m;
}

LogInterval log_interval(const LogPosterior& p, double q_per_cycle, double horizon_cycles, double widen, double extra_var,
                         double coverage) {
  LogInterval out;
  const double z = normal_quantile(0.5 + coverage / 2.0);
  const PathMeanMoments walk = path_mean_moments(q_per_cycle, horizon_cycles);
  out.sd = widen * std::sqrt(std::max(0.0, p.var + walk.log_var + extra_var));
  out.low = p.mean + walk.log_mean - z * out.sd;
  out.high = p.mean + walk.log_mean + z * out.sd;
  return out;
}

double scale_density_sd(double a0, double a1, double t, double rel_sd) {
  return rel_sd * std::hypot((1.0 - t) * a0, t * a1);
}

PittingMiss pitting_miss(double d_measured, double sd_measured, double d_model, double gate) {
  PittingMiss m;
  if (!(d_measured > 0 && d_measured < 1) || !(d_model >= 0)) return m;
  m.gap = log_k_gap(d_measured, d_model);
  const double h = -std::log1p(-d_measured);   // −ln(1 − D)
  m.gap_sd = sd_measured / ((1.0 - d_measured) * h);
  m.missed = std::abs(m.gap) > gate * m.gap_sd;
  if (m.missed) m.extra_var = m.gap * m.gap;
  return m;
}

double density_elasticity_of_ics2(double share) {
  if (!(share >= 0 && share < 1)) throw std::invalid_argument("the pitting share of the band's power must lie in [0, 1)");
  return 0.5 / (1.0 - share);
}

double ics2_saturation_level(int harmonics) {
  if (harmonics < 1) throw std::invalid_argument("ICS2 needs at least one harmonic");
  return dsp::am_noise_ics2(1.0, harmonics) / 4.0;   // I_s at its largest, at the share 1/2
}

bool limit_within_reach(double estimate, double sd, double limit, double coverage) {
  return estimate + normal_quantile(0.5 + coverage / 2.0) * std::max(0.0, sd) >= limit;
}

CalibrationElasticities calibration_elasticities(double a0, double a1) {
  if (!(a0 >= 0 && a1 > a0 && a1 < 1)) throw std::invalid_argument("calibration elasticities need 0 <= A0 < A1 < 1");
  const double delta = std::log1p(-a0) - std::log1p(-a1);
  return {-a0 / ((1.0 - a0) * delta), a1 / ((1.0 - a1) * delta)};
}

double closed_form_calibration_k(double a0, double n0, double a1, double n1, double terms, double m) {
  return (std::log1p(-a0) - std::log1p(-a1)) / (terms * (std::pow(n1, m) - std::pow(n0, m)));
}

double calibration_log_variance(double a0, double a1, double sd0, double sd1, double correlation) {
  const CalibrationElasticities g = calibration_elasticities(a0, a1);
  return g.d_ln_a0 * g.d_ln_a0 * sd0 * sd0 + g.d_ln_a1 * g.d_ln_a1 * sd1 * sd1 +
         2.0 * correlation * g.d_ln_a0 * g.d_ln_a1 * sd0 * sd1;
}

double log_k_gap(double density_a, double density_b) {
  auto h = [](double d) { return std::log(-std::log1p(-std::clamp(d, 1e-12, 1.0 - 1e-12))); };
  return h(density_a) - h(density_b);
}

namespace {
double median_of(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2) return *mid;
  return 0.5 * (*mid + *std::max_element(v.begin(), mid));
}
}  // namespace

const char* to_string(Ics2ScaleForm form) {
  switch (form) {
    case Ics2ScaleForm::linear: return "linear";
    case Ics2ScaleForm::square_root: return "square_root";
  }
  return "linear";
}

std::optional<Ics2ScaleForm> ics2_scale_form_from_string(const std::string& text) {
  for (const Ics2ScaleForm f : {Ics2ScaleForm::linear, Ics2ScaleForm::square_root})
    if (text == to_string(f)) return f;
  return std::nullopt;
}

double Ics2Scale::density_at(double ics2_reading) const {
  if (form == Ics2ScaleForm::linear) return density + slope * (ics2_reading - ics2);
  const double rise = ics2_reading - baseline, rise0 = ics2 - baseline;
  return rise > 0 && rise0 > 0 ? density * std::sqrt(rise / rise0) : 0.0;
}

double Ics2Scale::ics2_for(double d) const {
  if (form == Ics2ScaleForm::linear) return slope > 0 ? ics2 + (d - density) / slope : ics2;
  if (!(d > 0) || !(density > 0)) return baseline;
  const double r = d / density;
  return baseline + (ics2 - baseline) * r * r;
}

double Ics2Scale::density_noise(double d, double ics2_sd) const {
  if (form == Ics2ScaleForm::linear) return std::abs(slope) * ics2_sd;
  const double at = ics2_for(d);
  return std::abs(density_at(at + ics2_sd) - density_at(at));
}

std::optional<Ics2Scale> one_inspection_scale(const std::vector<double>& first_ics2, double ics2_at_inspection, double area,
                                              double min_rise_sd) {
  if (first_ics2.empty() || !std::isfinite(ics2_at_inspection) || !(area > 0 && area < 1)) return std::nullopt;
  Ics2Scale s;
  s.form = Ics2ScaleForm::square_root;
  s.baseline = median_of(first_ics2);
  std::vector<double> dev;
  for (double v : first_ics2) dev.push_back(std::abs(v - s.baseline));
  s.baseline_sd = 1.4826 * median_of(dev);
  const double rise = ics2_at_inspection - s.baseline;
  if (!(rise > 0) || rise <= min_rise_sd * s.baseline_sd) return std::nullopt;
  s.ics2 = ics2_at_inspection;
  s.density = area;
  s.slope = 0;
  return s;
}

RobustLine theil_sen(const std::vector<std::array<double, 2>>& points) {
  RobustLine line;
  std::vector<double> slopes;
  for (std::size_t i = 0; i < points.size(); ++i)
    for (std::size_t j = i + 1; j < points.size(); ++j)
      if (points[j][0] != points[i][0]) slopes.push_back((points[j][1] - points[i][1]) / (points[j][0] - points[i][0]));
  if (slopes.empty()) return line;
  line.slope = median_of(slopes);
  std::vector<double> intercepts;
  for (const auto& p : points) intercepts.push_back(p[1] - line.slope * p[0]);
  line.intercept = median_of(intercepts);
  line.valid = true;
  return line;
}

ScatterCheck residual_scatter_check(const std::vector<double>& log_residuals, double expected_sd, double level) {
  ScatterCheck c;
  c.n = static_cast<int>(log_residuals.size());
  if (c.n == 0 || !(expected_sd > 0)) return c;
  for (double r : log_residuals) c.statistic += r * r;
  c.statistic /= expected_sd * expected_sd;
  c.critical = chi_square_quantile(1.0 - level, c.n);
  c.exceeded = c.statistic > c.critical;
  if (c.exceeded) c.ratio = std::sqrt(c.statistic / c.n);
  return c;
}

double scatter_sd(const std::vector<double>& log_residuals, double floor) {
  if (log_residuals.empty()) return floor;
  double s = 0;
  for (double r : log_residuals) s += r * r;
  return std::max(floor, std::sqrt(s / static_cast<double>(log_residuals.size())));
}

ModelFormTerm model_form_term(const std::vector<double>& log_residuals, double scatter_sd, double elasticity,
                              double min_elasticity, double cap) {
  ModelFormTerm t;
  if (log_residuals.empty() || !(scatter_sd > 0)) return t;
  if (!residual_scatter_check(log_residuals, scatter_sd).exceeded) return t;
  double ms = 0;
  for (const double r : log_residuals) ms += r * r;
  ms /= static_cast<double>(log_residuals.size());
  t.exceeded = true;
  t.excess_mean_square = std::max(0.0, ms - scatter_sd * scatter_sd);
  const double e = std::max(std::isfinite(elasticity) ? std::abs(elasticity) : 1.0, min_elasticity);
  t.log_k_var = std::min(t.excess_mean_square / (e * e), cap);
  return t;
}

}  // namespace gearwatch::wear
