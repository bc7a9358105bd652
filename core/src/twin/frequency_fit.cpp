#include "frequency_fit.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <tuple>
#include <utility>

#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/modal_analysis.hpp"

namespace gearwatch::twin::detail {

FrequencyFitProblem::FrequencyFitProblem(std::vector<double> measured, std::vector<bool> use, double frequency_sigma,
                                         int max_iterations, std::string context)
    : measured_(std::move(measured)),
      use_(std::move(use)),
      frequency_sigma_(frequency_sigma),
      max_iterations_(max_iterations),
      context_(std::move(context)) {}

void FrequencyFitProblem::add_knob(double low, double high, double log_centre, std::vector<int> springs,
                                   std::vector<int> mass_dofs) {
  LogKnob k;
  k.log_low = std::log(low);
  k.log_high = std::log(high);
  k.log_centre = log_centre;
  k.sigma = (k.log_high - k.log_low) / 4.0;
  k.springs = std::move(springs);
  k.mass_dofs = std::move(mass_dofs);
  knobs_.push_back(std::move(k));
}

Eigen::VectorXd FrequencyFitProblem::log_sensitivity(const ModalEvaluation& e, int mode) const {
  const double omega2 = std::pow(2.0 * std::numbers::pi * e.frequencies[mode], 2);
  Eigen::VectorXd s(static_cast<Eigen::Index>(knobs_.size()));
  const auto phi = e.shapes.col(mode);
  for (std::size_t j = 0; j < knobs_.size(); ++j) {
    double d = 0;
    for (int i : knobs_[j].springs) {
      const SpringElement& sp = e.springs[static_cast<std::size_t>(i)];
      const double diff = phi[sp.a] - (sp.b >= 0 ? phi[sp.b] : 0.0);
      d += sp.stiffness * diff * diff;
    }
    for (int dof : knobs_[j].mass_dofs) d -= omega2 * e.mass[dof] * phi[dof] * phi[dof];
    s[static_cast<Eigen::Index>(j)] = 0.5 * d / omega2;
  }
  return s;
}

std::vector<int> FrequencyFitProblem::initial_pairing(const ModalEvaluation& e) const {
  const int n_meas = static_cast<int>(measured_.size());
  std::vector<int> elastic;
  for (int i = 0; i < e.frequencies.size(); ++i)
    if (e.frequencies[i] > 1.0) elastic.push_back(i);
  const int n_mode = static_cast<int>(elastic.size());
  if (n_mode < n_meas) throw TwinParameterError(context_ + ": more measured frequencies than model modes");
  Eigen::VectorXd sigma2(static_cast<Eigen::Index>(knobs_.size()));
  for (std::size_t j = 0; j < knobs_.size(); ++j) sigma2[static_cast<Eigen::Index>(j)] = knobs_[j].sigma * knobs_[j].sigma;
  Eigen::MatrixXd cost(n_meas, n_mode);
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
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return measured_[static_cast<std::size_t>(a)] < measured_[static_cast<std::size_t>(b)]; });
  const double inf = std::numeric_limits<double>::infinity();
  // best(r, c): the first r measured (ascending) placed on modes < c.
  const auto rows = static_cast<std::size_t>(n_meas + 1), cols = static_cast<std::size_t>(n_mode + 1);
  std::vector<double> best(rows * cols, inf);
  std::vector<char> take(rows * cols, 0);
  auto at = [cols](int r, int c) { return static_cast<std::size_t>(r) * cols + static_cast<std::size_t>(c); };
  for (int c = 0; c <= n_mode; ++c) best[at(0, c)] = 0;
  for (int r = 1; r <= n_meas; ++r)
    for (int c = 1; c <= n_mode; ++c) {
      const double skip = best[at(r, c - 1)];
      const double use = best[at(r - 1, c - 1)] + cost(order[static_cast<std::size_t>(r - 1)], c - 1);
      if (use < skip) {
        best[at(r, c)] = use;
        take[at(r, c)] = 1;
      } else {
        best[at(r, c)] = skip;
      }
    }
  std::vector<int> pairing(static_cast<std::size_t>(n_meas), -1);
  for (int r = n_meas, c = n_mode; r > 0; --c)
    if (take[at(r, c)]) {
      pairing[static_cast<std::size_t>(order[static_cast<std::size_t>(r - 1)])] = elastic[static_cast<std::size_t>(c - 1)];
      --r;
    }
  return pairing;
}

std::vector<int> FrequencyFitProblem::track(const ModalEvaluation& e, const Eigen::MatrixXd& reference) const {
  const int n_meas = static_cast<int>(measured_.size());
  const int n = static_cast<int>(e.frequencies.size());
  std::vector<std::tuple<double, int, int>> candidates;
  for (int r = 0; r < n_meas; ++r)
    for (int m = 0; m < n; ++m)
      if (e.frequencies[m] > 1.0) candidates.emplace_back(modal_assurance(reference.col(r), e.shapes.col(m), e.mass), r, m);
  std::sort(candidates.begin(), candidates.end(), [](const auto& a, const auto& b) { return std::get<0>(a) > std::get<0>(b); });
  std::vector<int> pairing(static_cast<std::size_t>(n_meas), -1);
  std::vector<bool> taken(static_cast<std::size_t>(n), false);
  int assigned = 0;
  for (const auto& [mac, r, m] : candidates) {
    if (pairing[static_cast<std::size_t>(r)] >= 0 || taken[static_cast<std::size_t>(m)]) continue;
    pairing[static_cast<std::size_t>(r)] = m;
    taken[static_cast<std::size_t>(m)] = true;
    if (++assigned == n_meas) break;
  }
  return pairing;
}

Eigen::VectorXd FrequencyFitProblem::residual(const ModalEvaluation& e, const std::vector<int>& pairing,
                                              const Eigen::VectorXd& x, Eigen::MatrixXd* jacobian) const {
  const std::size_t n_meas = measured_.size(), n_knob = knobs_.size();
  Eigen::VectorXd r = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n_meas + n_knob));
  if (jacobian) jacobian->setZero(static_cast<Eigen::Index>(n_meas + n_knob), static_cast<Eigen::Index>(n_knob));
  for (std::size_t i = 0; i < n_meas; ++i) {
    if (!use_[i]) continue;
    const int m = pairing[i];
    r[static_cast<Eigen::Index>(i)] = std::log(e.frequencies[m] / measured_[i]) / frequency_sigma_;
    if (jacobian) jacobian->row(static_cast<Eigen::Index>(i)) = log_sensitivity(e, m).transpose() / frequency_sigma_;
  }
  for (std::size_t j = 0; j < n_knob; ++j) {
    const auto row = static_cast<Eigen::Index>(n_meas + j);
    r[row] = (x[static_cast<Eigen::Index>(j)] - knobs_[j].log_centre) / knobs_[j].sigma;
    if (jacobian) (*jacobian)(row, static_cast<Eigen::Index>(j)) = 1.0 / knobs_[j].sigma;
  }
  return r;
}

FitOutcome fit_from(const FrequencyFitProblem& problem, Eigen::VectorXd x) {
  const auto n = static_cast<Eigen::Index>(problem.knob_count());
  auto clamp = [&](Eigen::VectorXd& v) {
    for (Eigen::Index j = 0; j < n; ++j)
      v[j] = std::clamp(v[j], problem.lo(static_cast<std::size_t>(j)), problem.hi(static_cast<std::size_t>(j)));
  };
  clamp(x);
  FitOutcome out;
  ModalEvaluation e = problem.evaluate(x);
  out.start_pairing = problem.initial_pairing(e);
  std::vector<int> pairing = out.start_pairing;
  Eigen::MatrixXd reference(e.shapes.rows(), static_cast<Eigen::Index>(pairing.size()));
  for (std::size_t i = 0; i < pairing.size(); ++i) reference.col(static_cast<Eigen::Index>(i)) = e.shapes.col(pairing[i]);
  out.start_shapes = reference;
  Eigen::MatrixXd jac;
  Eigen::VectorXd r = problem.residual(e, pairing, x, &jac);
  double cost = 0.5 * r.squaredNorm();
  double lambda = 1e-3;
  int iter = 0, stalls = 0;
  for (; iter < problem.max_iterations(); ++iter) {
    const Eigen::VectorXd grad = jac.transpose() * r;
    const Eigen::MatrixXd h = jac.transpose() * jac;
    Eigen::MatrixXd a = h;
    for (Eigen::Index j = 0; j < n; ++j) a(j, j) += lambda * (h(j, j) + 1e-9);
    Eigen::VectorXd b = -grad;
    // Variables held at a bound by the gradient are frozen for this step (projected LM).
    for (Eigen::Index j = 0; j < n; ++j) {
      const bool at_lo = x[j] <= problem.lo(static_cast<std::size_t>(j)) + 1e-12 && grad[j] > 0;
      const bool at_hi = x[j] >= problem.hi(static_cast<std::size_t>(j)) - 1e-12 && grad[j] < 0;
      if (at_lo || at_hi) {
        a.row(j).setZero();
        a.col(j).setZero();
        a(j, j) = 1;
        b[j] = 0;
      }
    }
    Eigen::VectorXd trial = x + a.ldlt().solve(b);
    clamp(trial);
    const ModalEvaluation et = problem.evaluate(trial);
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

}  // namespace gearwatch::twin::detail
