#include "gearwatch/twin/slow_modes.hpp"

#include <cmath>
#include <numbers>

#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/modal_analysis.hpp"

namespace gearwatch::twin {

SlowModes::SlowModes(const GearboxMatrices& m, double below_hz) {
  if (!(below_hz > 0)) return;
  Eigen::VectorXd frequencies;
  Eigen::MatrixXd shapes;
  const Matrix21 stiffness = m.linearised_stiffness();
  solve_modes(m.mass, stiffness, frequencies, shapes);
  const double rigid_below = 1e-3 * frequencies.maxCoeff();  // the free rotation solves to ~0 Hz
  std::vector<Eigen::Index> elastic;
  for (Eigen::Index i = 0; i < frequencies.size(); ++i)
    if (frequencies[i] > rigid_below) elastic.push_back(i);
  const auto n = static_cast<Eigen::Index>(elastic.size());
  Eigen::MatrixXd phi(kDofCount, n);  // mass-normalised elastic shapes
  for (Eigen::Index j = 0; j < n; ++j) phi.col(j) = shapes.col(elastic[static_cast<std::size_t>(j)]);
  const Matrix21 damping = m.damping + m.mesh_damping_time_constant * m.mean_mesh_stiffness * m.mesh * m.mesh.transpose();
  // The elastic modal coordinates' first-order system: the rigid rotation left out (no stiffness,
  // no damping: a double zero eigenvalue would make the eigenvectors singular).
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(2 * n, 2 * n);
  a.topRightCorner(n, n).setIdentity();
  a.bottomLeftCorner(n, n) = -(phi.transpose() * stiffness * phi);
  a.bottomRightCorner(n, n) = -(phi.transpose() * damping * phi);
  Eigen::EigenSolver<Eigen::MatrixXd> eig(a);
  if (eig.info() != Eigen::Success) throw TwinParameterError("slow modes: eigenproblem failed");
  const Eigen::MatrixXcd v = eig.eigenvectors();
  const Eigen::MatrixXcd v_inv = v.inverse();
  const Eigen::MatrixXd to_modal = phi.transpose() * m.mass.asDiagonal();  // η = Φᵀ M q
  for (Eigen::Index j = 0; j < 2 * n; ++j) {
    const Complex lambda = eig.eigenvalues()[j];
    if (!(lambda.imag() > 0) || lambda.imag() >= 2.0 * std::numbers::pi * below_hz) continue;
    Mode mode;
    mode.lambda = lambda;
    const Eigen::VectorXcd row = v_inv.row(j).transpose();
    mode.left.head(kDofCount) = to_modal.transpose() * row.head(n);
    mode.left.tail(kDofCount) = to_modal.transpose() * row.tail(n);
    Eigen::Matrix<Complex, 2 * kDofCount, 1> right;
    right.head(kDofCount) = phi * v.col(j).head(n);
    right.tail(kDofCount) = phi * v.col(j).tail(n);
    mode.right_real = right.real();
    mode.right_imag = right.imag();
    modes_.push_back(mode);
  }
}

SlowModes::Amplitudes SlowModes::project(const State& x) const {
  const Eigen::Map<const Eigen::Matrix<double, 2 * kDofCount, 1>> d(x.data());
  Amplitudes c(modes_.size());
  for (std::size_t j = 0; j < modes_.size(); ++j) c[j] = modes_[j].left.cwiseProduct(d.cast<Complex>()).sum();
  return c;
}

SlowModes::Amplitudes SlowModes::amplitudes(const State& anchor, const State& later, double period_s) const {
  State d;
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = later[i] - anchor[i];
  Amplitudes c = project(d);
  for (std::size_t j = 0; j < modes_.size(); ++j) {
    const Complex gain = std::exp(modes_[j].lambda * period_s) - 1.0;
    c[j] = std::abs(gain) > 1e-2 ? c[j] / gain : Complex{};
  }
  return c;
}

void SlowModes::advance(State& x, const Amplitudes& c, double from_s, double to_s) const {
  Amplitudes z(modes_.size());
  for (std::size_t j = 0; j < modes_.size(); ++j)
    z[j] = c[j] * (std::exp(modes_[j].lambda * to_s) - std::exp(modes_[j].lambda * from_s));
  add_state(x, z);
}

double SlowModes::coordinate(const Amplitudes& c, int index, double s) const {
  Amplitudes z(modes_.size());
  for (std::size_t j = 0; j < modes_.size(); ++j) z[j] = c[j] * std::exp(modes_[j].lambda * s);
  return state_coordinate(z, index);
}

void SlowModes::add_state(State& x, const Amplitudes& z) const {
  Eigen::Map<Eigen::Matrix<double, 2 * kDofCount, 1>> out(x.data());
  for (std::size_t j = 0; j < modes_.size(); ++j)
    out += (2.0 * z[j].real()) * modes_[j].right_real - (2.0 * z[j].imag()) * modes_[j].right_imag;
}

double SlowModes::state_coordinate(const Amplitudes& z, int index) const {
  double sum = 0;
  for (std::size_t j = 0; j < modes_.size(); ++j)
    sum += 2.0 * (modes_[j].right_real[index] * z[j].real() - modes_[j].right_imag[index] * z[j].imag());
  return sum;
}

SampleGridPhasors::SampleGridPhasors(const SlowModes& modes, double rate, std::size_t count)
    : modes_(modes), rate_(rate), fine_(modes.size()), coarse_(modes.size()) {
  if (!(rate > 0) || !std::isfinite(rate)) throw TwinParameterError("slow modes: sample rate must be positive");
  const std::size_t coarse_count = count / kFineSteps + 1;
  for (std::size_t j = 0; j < modes.size(); ++j) {
    const Complex lambda = modes.eigenvalue(j);
    fine_[j].resize(kFineSteps);
    coarse_[j].resize(coarse_count);
    for (std::size_t n = 0; n < kFineSteps; ++n) fine_[j][n] = std::exp(lambda * (static_cast<double>(n) / rate));
    for (std::size_t m = 0; m < coarse_count; ++m) coarse_[j][m] = std::exp(lambda * (static_cast<double>(m * kFineSteps) / rate));
  }
}

SampleGridPhasors::Complex SampleGridPhasors::at(std::size_t j, std::size_t i) const {
  const std::size_t m = i / kFineSteps;
  if (m >= coarse_[j].size()) return std::exp(modes_.eigenvalue(j) * (static_cast<double>(i) / rate_));
  return coarse_[j][m] * fine_[j][i % kFineSteps];
}

}  // namespace gearwatch::twin
