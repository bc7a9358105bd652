#include "gearwatch/twin/modal_analysis.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Eigenvalues>

#include "gearwatch/twin/errors.hpp"

namespace gearwatch::twin {

void solve_modes(const Eigen::VectorXd& mass, const Eigen::MatrixXd& stiffness, Eigen::VectorXd& frequencies_hz,
                 Eigen::MatrixXd& shapes) {
  const auto n = mass.size();
  if (stiffness.rows() != n || stiffness.cols() != n) throw TwinParameterError("modal analysis: K and M sizes differ");
  if (!mass.allFinite() || (mass.array() <= 0).any())
    throw TwinParameterError("modal analysis: every mass and inertia must be positive");
  if (!stiffness.allFinite()) throw TwinParameterError("modal analysis: stiffness matrix is not finite");
  if (!stiffness.isApprox(stiffness.transpose(), 1e-12)) throw TwinParameterError("modal analysis: K is not symmetric");
  const Eigen::VectorXd inv_sqrt = mass.cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd a = inv_sqrt.asDiagonal() * stiffness * inv_sqrt.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(a);
  if (eig.info() != Eigen::Success) throw TwinParameterError("modal analysis: eigenproblem failed");
  frequencies_hz.resize(n);
  for (Eigen::Index i = 0; i < n; ++i)
    frequencies_hz[i] = std::sqrt(std::max(eig.eigenvalues()[i], 0.0)) / (2.0 * std::numbers::pi);
  shapes = inv_sqrt.asDiagonal() * eig.eigenvectors();
}

std::vector<Mode> modal_analysis(const GearboxParameters& p, const GearboxMatrices& m) {
  Eigen::VectorXd f;
  Eigen::MatrixXd shapes;
  solve_modes(m.mass, m.linearised_stiffness(), f, shapes);
  const auto springs = spring_elements(p);
  std::vector<Mode> modes(kDofCount);
  for (int i = 0; i < kDofCount; ++i) {
    Mode& mode = modes[static_cast<std::size_t>(i)];
    mode.frequency_hz = f[i];
    mode.shape = shapes.col(i);
    double total = 0;
    for (const auto& e : springs) {
      const double d = mode.shape[e.a] - (e.b >= 0 ? mode.shape[e.b] : 0.0);
      const double energy = 0.5 * e.stiffness * d * d;
      mode.strain_energy.emplace_back(e.name, energy);
      total += energy;
    }
    const double mesh_d = m.mesh.dot(Vector21(mode.shape));
    mode.strain_energy.emplace_back("mesh", 0.5 * m.mean_mesh_stiffness * mesh_d * mesh_d);
    total += mode.strain_energy.back().second;
    // A rigid-body mode stores (numerically) nothing: leave the shares at zero.
    const double omega2 = std::pow(2.0 * std::numbers::pi * f[i], 2);
    if (total > 1e-9 * std::max(omega2, 1.0)) {
      for (auto& [name, e] : mode.strain_energy) e /= total;
      const auto best = std::max_element(mode.strain_energy.begin(), mode.strain_energy.end(),
                                         [](const auto& a, const auto& b) { return a.second < b.second; });
      mode.dominant_element = best->first;
      mode.dominant_share = best->second;
    } else {
      for (auto& [name, e] : mode.strain_energy) e = 0;
      mode.dominant_element = "rigid body";
    }
    double torsional = 0, kinetic = 0;
    for (int d = 0; d < kDofCount; ++d) {
      const double e = m.mass[d] * mode.shape[d] * mode.shape[d];
      kinetic += e;
      if (d <= theta13) torsional += e;
    }
    mode.torsional_kinetic_share = torsional / kinetic;
  }
  return modes;
}

std::vector<Mode> modal_analysis(const GearboxParameters& p) { return modal_analysis(p, assemble(p)); }

double modal_assurance(const Eigen::VectorXd& a, const Eigen::VectorXd& b, const Eigen::VectorXd& mass) {
  const double ab = a.dot(mass.cwiseProduct(b));
  const double aa = a.dot(mass.cwiseProduct(a));
  const double bb = b.dot(mass.cwiseProduct(b));
  return ab * ab / (aa * bb);
}

}  // namespace gearwatch::twin
