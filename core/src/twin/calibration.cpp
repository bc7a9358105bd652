#include "gearwatch/twin/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <cstdio>
#include <string>

#include <Eigen/Dense>

#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/gearbox_model.hpp"
#include "gearwatch/twin/modal_analysis.hpp"

namespace gearwatch::twin {

const std::vector<double>& table_5_5_frequencies() {
  static const std::vector<double> f = {22, 87, 218, 430, 512, 767, 1248, 1927};
  return f;
}

namespace {

using P = GearboxParameters;

std::string field_name(double P::*field) {
  for (const auto& info : parameter_table())
    if (info.field == field) return info.name;
  return "?";
}

CalibrationKnob knob(const std::string& name, std::vector<double P::*> fields) {
  const ParameterInfo* info = find_parameter(field_name(fields.front()));
  return {name, std::move(fields), info->prior_value, info->prior_low, info->prior_high};
}

// DOFs whose mass a mass/inertia parameter sets.
std::vector<int> mass_dofs(const std::string& name) {
  static const std::map<std::string, std::vector<int>> map = {
      {"I1", {theta1}},   {"I2", {theta2}},   {"I3", {theta3}},   {"I5", {theta5}},  {"I7", {theta7}},
      {"I8", {theta8}},   {"I10", {theta10}}, {"I12", {theta12}}, {"I13", {theta13}}, {"m4", {y4, x4}},
      {"m5", {y5, x5}},   {"m6", {y6, x6}},   {"m9", {y9, x9}},   {"m10", {y10, x10}}, {"m11", {y11, x11}}};
  const auto it = map.find(name);
  return it == map.end() ? std::vector<int>{} : it->second;
}

struct Evaluation {
  Eigen::VectorXd frequencies;  // Hz, ascending, 21
  Eigen::MatrixXd shapes;       // mass-normalised columns
  Eigen::VectorXd mass;
  std::vector<SpringElement> springs;
};

class Problem {
 public:
  Problem(const GearboxParameters& prior, const std::vector<double>& measured, const std::vector<bool>& use,
          const std::vector<CalibrationKnob>& knobs, const CalibrationOptions& options)
      : base_(prior), measured_(measured), use_(use), knobs_(knobs), options_(options) {
    const GearGeometry geometry = GearGeometry::from_spec(prior.gears);
    MeshStiffnessOptions mo;
    mo.scale = prior.mesh_stiffness_scale;
    mo.engagement_ramp_fraction = prior.engagement_ramp_fraction;
    const GearMeshStiffness mesh(geometry, mo);
    mesh_k_ = mesh.mean_stiffness() * mesh_direction(geometry) * mesh_direction(geometry).transpose();
    for (const auto& k : knobs_) {
      double log_sum = 0;
      for (auto f : k.fields) log_sum += std::log(prior.*f);
      centre_.push_back(log_sum / static_cast<double>(k.fields.size()));
      lo_.push_back(std::log(k.low));
      hi_.push_back(std::log(k.high));
      sigma_.push_back((hi_.back() - lo_.back()) / 4.0);
      std::vector<std::string> springs, masses;
      for (auto f : k.fields) {
        const std::string name = field_name(f);
        if (mass_dofs(name).empty()) springs.push_back(name);
        else masses.push_back(name);
      }
      knob_springs_.push_back(springs);
      knob_masses_.push_back(masses);
    }
  }

  std::size_t knob_count() const { return knobs_.size(); }
  const std::vector<double>& centre() const { return centre_; }
  double lo(std::size_t j) const { return lo_[j]; }
  double hi(std::size_t j) const { return hi_[j]; }

  GearboxParameters parameters(const Eigen::VectorXd& x) const {
    GearboxParameters p = base_;
    for (std::size_t j = 0; j < knobs_.size(); ++j)
      for (auto f : knobs_[j].fields) p.*f = std::exp(x[static_cast<Eigen::Index>(j)]);
    return p;
  }

  Evaluation evaluate(const Eigen::VectorXd& x) const {
    const GearboxParameters p = parameters(x);
    Evaluation e;
    e.mass.resize(kDofCount);
    e.mass << p.I1, p.I2, p.I3, p.I5, p.I7, p.I8, p.I10, p.I12, p.I13, p.m4, p.m5, p.m6, p.m9, p.m10, p.m11, p.m4,
        p.m5, p.m6, p.m9, p.m10, p.m11;
    e.springs = spring_elements(p);
    Eigen::MatrixXd k = mesh_k_;
    for (const auto& s : e.springs) {
      k(s.a, s.a) += s.stiffness;
      if (s.b >= 0) {
        k(s.b, s.b) += s.stiffness;
        k(s.a, s.b) -= s.stiffness;
        k(s.b, s.a) -= s.stiffness;
      }
    }
    solve_modes(e.mass, k, e.frequencies, e.shapes);
    return e;
  }

  /// d ln f_mode / d x_j (x = ln knob value): ½ φᵀ(K_j − ω² M_j)φ / ω² for mass-normalised φ.
  Eigen::VectorXd log_sensitivity(const Evaluation& e, int mode) const {
    const double omega2 = std::pow(2.0 * std::numbers::pi * e.frequencies[mode], 2);
    Eigen::VectorXd s(static_cast<Eigen::Index>(knobs_.size()));
    const auto phi = e.shapes.col(mode);
    for (std::size_t j = 0; j < knobs_.size(); ++j) {
      double d = 0;
      for (const auto& name : knob_springs_[j])
        for (const auto& sp : e.springs)
          if (sp.name == name) {
            const double diff = phi[sp.a] - (sp.b >= 0 ? phi[sp.b] : 0.0);
            d += sp.stiffness * diff * diff;
          }
      for (const auto& name : knob_masses_[j])
        for (int dof : mass_dofs(name)) d -= omega2 * e.mass[dof] * phi[dof] * phi[dof];
      s[static_cast<Eigen::Index>(j)] = 0.5 * d / omega2;
    }
    return s;
  }

  /// Monotone assignment of measured frequencies to elastic modes, cost = prior-weighted squared
  /// distance the knobs must travel to move the mode onto the measured value.
  std::vector<int> initial_pairing(const Evaluation& e) const {
    const int n_meas = static_cast<int>(measured_.size());
    std::vector<int> elastic;
    for (int i = 0; i < kDofCount; ++i)
      if (e.frequencies[i] > 1.0) elastic.push_back(i);
    const int n_mode = static_cast<int>(elastic.size());
    if (n_mode < n_meas) throw TwinParameterError("calibration: more measured frequencies than model modes");
    Eigen::MatrixXd cost(n_meas, n_mode);
    Eigen::VectorXd sigma2(static_cast<Eigen::Index>(knobs_.size()));
    for (std::size_t j = 0; j < knobs_.size(); ++j) sigma2[static_cast<Eigen::Index>(j)] = sigma_[j] * sigma_[j];
    for (int c = 0; c < n_mode; ++c) {
      const Eigen::VectorXd s = log_sensitivity(e, elastic[static_cast<std::size_t>(c)]);
      const double reach = std::max(s.cwiseProduct(s).dot(sigma2), 1e-12);
      for (int r = 0; r < n_meas; ++r) {
        const double d = std::log(measured_[static_cast<std::size_t>(r)] / e.frequencies[elastic[static_cast<std::size_t>(c)]]);
        cost(r, c) = d * d / reach;
      }
    }
    // Measured indices in ascending frequency order.
    std::vector<int> order(static_cast<std::size_t>(n_meas));
    for (int i = 0; i < n_meas; ++i) order[static_cast<std::size_t>(i)] = i;
    std::sort(order.begin(), order.end(), [&](int a, int b) { return measured_[static_cast<std::size_t>(a)] < measured_[static_cast<std::size_t>(b)]; });
    const double inf = std::numeric_limits<double>::infinity();
    // best[r][c]: first r measured (ascending) placed on modes < c.
    std::vector<std::vector<double>> best(static_cast<std::size_t>(n_meas + 1), std::vector<double>(static_cast<std::size_t>(n_mode + 1), inf));
    std::vector<std::vector<int>> take(static_cast<std::size_t>(n_meas + 1), std::vector<int>(static_cast<std::size_t>(n_mode + 1), 0));
    for (int c = 0; c <= n_mode; ++c) best[0][static_cast<std::size_t>(c)] = 0;
    for (int r = 1; r <= n_meas; ++r)
      for (int c = 1; c <= n_mode; ++c) {
        const double skip = best[static_cast<std::size_t>(r)][static_cast<std::size_t>(c - 1)];
        const double use = best[static_cast<std::size_t>(r - 1)][static_cast<std::size_t>(c - 1)] +
                           cost(order[static_cast<std::size_t>(r - 1)], c - 1);
        if (use < skip) {
          best[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)] = use;
          take[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)] = 1;
        } else {
          best[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)] = skip;
        }
      }
    std::vector<int> pairing(static_cast<std::size_t>(n_meas), -1);
    for (int r = n_meas, c = n_mode; r > 0; --c) {
      if (take[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)]) {
        pairing[static_cast<std::size_t>(order[static_cast<std::size_t>(r - 1)])] = elastic[static_cast<std::size_t>(c - 1)];
        --r;
      }
    }
    return pairing;
  }

  /// Follows the paired modes by shape: greedy maximum-MAC assignment against reference shapes.
  std::vector<int> track(const Evaluation& e, const Eigen::MatrixXd& reference) const {
    const int n_meas = static_cast<int>(measured_.size());
    std::vector<std::tuple<double, int, int>> candidates;
    for (int r = 0; r < n_meas; ++r)
      for (int m = 0; m < kDofCount; ++m)
        if (e.frequencies[m] > 1.0)
          candidates.emplace_back(modal_assurance(reference.col(r), e.shapes.col(m), e.mass), r, m);
    std::sort(candidates.begin(), candidates.end(), [](const auto& a, const auto& b) { return std::get<0>(a) > std::get<0>(b); });
    std::vector<int> pairing(static_cast<std::size_t>(n_meas), -1);
    std::vector<bool> taken(kDofCount, false);
    int assigned = 0;
    for (const auto& [mac, r, m] : candidates) {
      if (pairing[static_cast<std::size_t>(r)] >= 0 || taken[static_cast<std::size_t>(m)]) continue;
      pairing[static_cast<std::size_t>(r)] = m;
      taken[static_cast<std::size_t>(m)] = true;
      if (++assigned == n_meas) break;
    }
    return pairing;
  }

  Eigen::VectorXd residual(const Evaluation& e, const std::vector<int>& pairing, const Eigen::VectorXd& x,
                           Eigen::MatrixXd* jacobian) const {
    const std::size_t n_meas = measured_.size(), n_knob = knobs_.size();
    Eigen::VectorXd r = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n_meas + n_knob));
    if (jacobian) jacobian->setZero(static_cast<Eigen::Index>(n_meas + n_knob), static_cast<Eigen::Index>(n_knob));
    for (std::size_t i = 0; i < n_meas; ++i) {
      if (!use_[i]) continue;
      const int m = pairing[i];
      r[static_cast<Eigen::Index>(i)] = std::log(e.frequencies[m] / measured_[i]) / options_.frequency_sigma;
      if (jacobian) jacobian->row(static_cast<Eigen::Index>(i)) = log_sensitivity(e, m).transpose() / options_.frequency_sigma;
    }
    for (std::size_t j = 0; j < n_knob; ++j) {
      const auto row = static_cast<Eigen::Index>(n_meas + j);
      r[row] = (x[static_cast<Eigen::Index>(j)] - centre_[j]) / sigma_[j];
      if (jacobian) (*jacobian)(row, static_cast<Eigen::Index>(j)) = 1.0 / sigma_[j];
    }
    return r;
  }

  const std::vector<double>& measured() const { return measured_; }
  const std::vector<CalibrationKnob>& knobs() const { return knobs_; }
  const CalibrationOptions& options() const { return options_; }

 private:
  GearboxParameters base_;
  std::vector<double> measured_;
  std::vector<bool> use_;
  std::vector<CalibrationKnob> knobs_;
  CalibrationOptions options_;
  Eigen::MatrixXd mesh_k_;
  std::vector<double> centre_, lo_, hi_, sigma_;
  std::vector<std::vector<std::string>> knob_springs_, knob_masses_;
};

struct FitOutcome {
  Eigen::VectorXd x;
  std::vector<int> pairing;
  std::vector<int> start_pairing;
  Eigen::MatrixXd start_shapes;
  double cost = std::numeric_limits<double>::infinity();
  int iterations = 0;
};

FitOutcome fit_from(const Problem& problem, Eigen::VectorXd x) {
  const auto n = static_cast<Eigen::Index>(problem.knob_count());
  auto clamp = [&](Eigen::VectorXd& v) {
    for (Eigen::Index j = 0; j < n; ++j)
      v[j] = std::clamp(v[j], problem.lo(static_cast<std::size_t>(j)), problem.hi(static_cast<std::size_t>(j)));
  };
  clamp(x);
  FitOutcome out;
  Evaluation e = problem.evaluate(x);
  out.start_pairing = problem.initial_pairing(e);
  std::vector<int> pairing = out.start_pairing;
  Eigen::MatrixXd reference(kDofCount, static_cast<Eigen::Index>(pairing.size()));
  for (std::size_t i = 0; i < pairing.size(); ++i) reference.col(static_cast<Eigen::Index>(i)) = e.shapes.col(pairing[i]);
  out.start_shapes = reference;
  Eigen::MatrixXd jac;
  Eigen::VectorXd r = problem.residual(e, pairing, x, &jac);
  double cost = 0.5 * r.squaredNorm();
  double lambda = 1e-3;
  int iter = 0, stalls = 0;
  for (; iter < problem.options().max_iterations; ++iter) {
    const Eigen::VectorXd grad = jac.transpose() * r;
    const Eigen::MatrixXd h = jac.transpose() * jac;
    // Variables held at a bound by the gradient are frozen for this step (projected LM).
    std::vector<bool> free(static_cast<std::size_t>(n), true);
    for (Eigen::Index j = 0; j < n; ++j) {
      const bool at_lo = x[j] <= problem.lo(static_cast<std::size_t>(j)) + 1e-12 && grad[j] > 0;
      const bool at_hi = x[j] >= problem.hi(static_cast<std::size_t>(j)) - 1e-12 && grad[j] < 0;
      free[static_cast<std::size_t>(j)] = !(at_lo || at_hi);
    }
    Eigen::MatrixXd a = h;
    for (Eigen::Index j = 0; j < n; ++j) a(j, j) += lambda * (h(j, j) + 1e-9);
    Eigen::VectorXd b = -grad;
    for (Eigen::Index j = 0; j < n; ++j)
      if (!free[static_cast<std::size_t>(j)]) {
        a.row(j).setZero();
        a.col(j).setZero();
        a(j, j) = 1;
        b[j] = 0;
      }
    Eigen::VectorXd step = a.ldlt().solve(b);
    Eigen::VectorXd trial = x + step;
    clamp(trial);
    const Evaluation et = problem.evaluate(trial);
    const std::vector<int> tp = problem.track(et, reference);
    Eigen::MatrixXd jt;
    const Eigen::VectorXd rt = problem.residual(et, tp, trial, &jt);
    const double ct = 0.5 * rt.squaredNorm();
    if (std::isfinite(ct) && ct < cost) {
      const double gain = (cost - ct) / std::max(cost, 1e-300);
      x = trial;
      e = et;
      pairing = tp;
      r = rt;
      jac = jt;
      for (std::size_t i = 0; i < pairing.size(); ++i) reference.col(static_cast<Eigen::Index>(i)) = e.shapes.col(pairing[i]);
      cost = ct;
      lambda = std::max(lambda / 3.0, 1e-12);
      stalls = gain < 1e-10 ? stalls + 1 : 0;
      if (stalls >= 3) break;
    } else {
      lambda *= 4.0;
      if (lambda > 1e12) break;
    }
  }
  out.x = x;
  out.pairing = pairing;
  out.cost = cost;
  out.iterations = iter;
  return out;
}

}  // namespace

std::vector<CalibrationKnob> default_calibration_knobs() {
  return {
      knob("kt12", {&P::kt12}),
      knob("kt23", {&P::kt23}),
      knob("kt12_13", {&P::kt12_13}),
      knob("kt35", {&P::kt35}),
      knob("kt57", {&P::kt57}),
      knob("kt810", {&P::kt810}),
      knob("kt10_12", {&P::kt10_12}),
      knob("I1", {&P::I1}),
      knob("I2", {&P::I2}),
      knob("I3", {&P::I3}),
      knob("I5", {&P::I5}),
      knob("I7", {&P::I7}),
      knob("I8", {&P::I8}),
      knob("I10", {&P::I10}),
      knob("I12", {&P::I12}),
      knob("I13", {&P::I13}),
      knob("k_bearing_x", {&P::kx4, &P::kx6, &P::kx9, &P::kx11}),
      knob("k_bearing_y", {&P::ky4, &P::ky6, &P::ky9, &P::ky11}),
      knob("k_shaft_x", {&P::kx45, &P::kx56, &P::kx910, &P::kx10_11}),
      knob("k_shaft_y", {&P::ky45, &P::ky56, &P::ky910, &P::ky10_11}),
      knob("m_pedestal", {&P::m4, &P::m6, &P::m9, &P::m11}),
      knob("m5", {&P::m5}),
      knob("m10", {&P::m10}),
  };
}

CalibrationResult calibrate(const GearboxParameters& prior, const std::vector<double>& measured_hz,
                            const std::vector<bool>& use, const std::vector<CalibrationKnob>& knobs,
                            const CalibrationOptions& options) {
  prior.validate();
  if (measured_hz.empty()) throw TwinParameterError("calibration: no measured frequencies");
  if (use.size() != measured_hz.size()) throw TwinParameterError("calibration: use mask size differs from the data");
  if (std::none_of(use.begin(), use.end(), [](bool b) { return b; })) throw TwinParameterError("calibration: nothing to fit");
  for (double f : measured_hz)
    if (!std::isfinite(f) || f <= 0) throw TwinParameterError("calibration: measured frequencies must be positive");
  if (knobs.empty()) throw TwinParameterError("calibration: no knobs");
  for (const auto& k : knobs)
    if (k.fields.empty() || !(k.low > 0) || !(k.high > k.low))
      throw TwinParameterError("calibration: knob " + k.name + " has no fields or an empty range");
  if (options.starts < 1 || options.frequency_sigma <= 0) throw TwinParameterError("calibration: bad options");

  const Problem problem(prior, measured_hz, use, knobs, options);
  const auto n = static_cast<Eigen::Index>(problem.knob_count());
  std::mt19937 rng(options.seed);
  FitOutcome best;
  int best_start = 0;
  for (int start = 0; start < options.starts; ++start) {
    Eigen::VectorXd x0(n);
    for (Eigen::Index j = 0; j < n; ++j) x0[j] = problem.centre()[static_cast<std::size_t>(j)];
    if (start == 1) {
      // The parameter sheet's hint: soft couplings on the input side (elastomer-insert values).
      for (Eigen::Index j = 0; j < n; ++j) {
        const std::string& name = problem.knobs()[static_cast<std::size_t>(j)].name;
        if (name == "kt12") x0[j] = std::log(250.0);
        if (name == "kt23") x0[j] = std::log(100.0);
        if (name == "kt12_13") x0[j] = std::log(2.8e4);
        if (name == "k_bearing_x") x0[j] = std::log(1.5e7);
        if (name == "k_bearing_y") x0[j] = std::log(1e9);
      }
    } else if (start > 1) {
      for (Eigen::Index j = 0; j < n; ++j) {
        std::uniform_real_distribution<double> u(0.15, 0.85);
        x0[j] = problem.lo(static_cast<std::size_t>(j)) +
                u(rng) * (problem.hi(static_cast<std::size_t>(j)) - problem.lo(static_cast<std::size_t>(j)));
      }
    }
    FitOutcome fit = fit_from(problem, x0);
    if (fit.cost < best.cost) {
      best = std::move(fit);
      best_start = start;
    }
  }
  if (!std::isfinite(best.cost)) throw TwinParameterError("calibration failed from every start");

  CalibrationResult result;
  result.parameters = problem.parameters(best.x);
  result.cost = best.cost;
  result.best_start = best_start;
  result.iterations = best.iterations;
  const Evaluation e = problem.evaluate(best.x);
  const std::vector<Mode> modes = modal_analysis(result.parameters);
  for (std::size_t i = 0; i < measured_hz.size(); ++i) {
    ModePairing pair;
    pair.measured_index = static_cast<int>(i);
    pair.measured_hz = measured_hz[i];
    pair.model_mode = best.pairing[i];
    pair.model_hz = e.frequencies[pair.model_mode];
    pair.error_pct = 100.0 * (pair.model_hz - measured_hz[i]) / measured_hz[i];
    pair.used_in_fit = use[i];
    const Mode& mode = modes[static_cast<std::size_t>(pair.model_mode)];
    pair.dominant_element = mode.dominant_element;
    pair.dominant_share = mode.dominant_share;
    pair.torsional_kinetic_share = mode.torsional_kinetic_share;
    pair.mac_to_start = modal_assurance(best.start_shapes.col(static_cast<Eigen::Index>(i)), e.shapes.col(pair.model_mode), e.mass);
    const Eigen::VectorXd s = problem.log_sensitivity(e, pair.model_mode);
    std::vector<std::pair<std::string, double>> sens;
    for (Eigen::Index j = 0; j < n; ++j) sens.emplace_back(problem.knobs()[static_cast<std::size_t>(j)].name, s[j]);
    std::sort(sens.begin(), sens.end(), [](const auto& a, const auto& b) { return std::abs(a.second) > std::abs(b.second); });
    sens.resize(std::min<std::size_t>(2, sens.size()));
    pair.top_sensitivities = sens;
    if (use[i]) result.max_abs_error_pct = std::max(result.max_abs_error_pct, std::abs(pair.error_pct));
    result.pairing.push_back(pair);
  }
  for (Eigen::Index j = 0; j < n; ++j) {
    const auto& k = problem.knobs()[static_cast<std::size_t>(j)];
    KnobChange c;
    c.name = k.name;
    c.prior_value = std::exp(problem.centre()[static_cast<std::size_t>(j)]);
    c.fitted_value = std::exp(best.x[j]);
    c.low = k.low;
    c.high = k.high;
    c.factor = c.fitted_value / c.prior_value;
    c.at_bound = best.x[j] <= problem.lo(static_cast<std::size_t>(j)) + 1e-9 || best.x[j] >= problem.hi(static_cast<std::size_t>(j)) - 1e-9;
    result.knobs.push_back(c);
  }
  return result;
}

CrossValidationResult cross_validate(const GearboxParameters& prior, const std::vector<double>& measured_hz,
                                     const std::vector<CalibrationKnob>& knobs, const CalibrationOptions& options) {
  const int n = static_cast<int>(measured_hz.size());
  if (n < 4) throw TwinParameterError("cross-validation needs at least 4 measured frequencies");
  CrossValidationResult cv;
  cv.worst_by_frequency_pct.assign(static_cast<std::size_t>(n), 0.0);
  std::vector<double> fold_errors, all_errors;
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      std::vector<bool> use(static_cast<std::size_t>(n), true);
      use[static_cast<std::size_t>(a)] = use[static_cast<std::size_t>(b)] = false;
      const CalibrationResult fit = calibrate(prior, measured_hz, use, knobs, options);
      CrossValidationFold fold;
      fold.fit_max_abs_error_pct = fit.max_abs_error_pct;
      int k = 0;
      for (int i : {a, b}) {
        const ModePairing& p = fit.pairing[static_cast<std::size_t>(i)];
        fold.held_out[k] = i;
        fold.measured_hz[k] = p.measured_hz;
        fold.predicted_hz[k] = p.model_hz;
        fold.error_pct[k] = p.error_pct;
        all_errors.push_back(std::abs(p.error_pct));
        cv.worst_by_frequency_pct[static_cast<std::size_t>(i)] =
            std::max(cv.worst_by_frequency_pct[static_cast<std::size_t>(i)], std::abs(p.error_pct));
        ++k;
      }
      fold_errors.push_back(std::max(std::abs(fold.error_pct[0]), std::abs(fold.error_pct[1])));
      cv.folds.push_back(fold);
    }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t m = v.size() / 2;
    return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
  };
  cv.worst_abs_error_pct = *std::max_element(all_errors.begin(), all_errors.end());
  cv.median_fold_error_pct = median(fold_errors);
  cv.median_abs_error_pct = median(all_errors);
  return cv;
}

std::string calibrated_values_source(const GearboxParameters& calibrated) {
  std::string out =
      "// The calibrated parameter set: the result of `calibrate()` against seed Table 5.5 with the\n"
      "// default knobs and priors (docs/twin.md lists the fit, the pairing and the cross-validation).\n"
      "// Values not listed keep their prior. Generated by `gearwatch twin calibrate --out FILE`;\n"
      "// regenerate it that way rather than editing it (a test compares it with a fresh calibration).\n"
      "#include \"gearwatch/twin/gearbox_parameters.hpp\"\n"
      "\n"
      "namespace gearwatch::twin {\n"
      "\n"
      "void apply_calibrated_values(GearboxParameters& p) {\n";
  for (const auto& info : parameter_table()) {
    const double value = calibrated.*(info.field);
    if (value == info.prior_value) continue;
    char line[128];
    std::snprintf(line, sizeof line, "  p.%s = %.9g;\n", info.name, value);
    out += line;
  }
  out += "}\n\n}  // namespace gearwatch::twin\n";
  return out;
}

}  // namespace gearwatch::twin
