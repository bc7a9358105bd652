#pragma once
// Modal analysis of the linearised 21-DOF model (mean mesh stiffness): K φ = ω² M φ with M
// diagonal, solved as the symmetric problem M^-1/2 K M^-1/2 (Eigen SelfAdjointEigenSolver).
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "gearwatch/twin/gearbox_model.hpp"

namespace gearwatch::twin {

struct Mode {
  double frequency_hz = 0;
  Eigen::VectorXd shape;             ///< mass-normalised (φᵀ M φ = 1)
  /// Share of the modal strain energy stored in each spring (element names of spring_elements(),
  /// plus "mesh"), summing to 1 (all zero for a rigid-body mode).
  std::vector<std::pair<std::string, double>> strain_energy;
  std::string dominant_element;      ///< the spring storing the largest share
  double dominant_share = 0;
  /// Share of the modal kinetic energy in torsional DOFs (the rest is translational).
  double torsional_kinetic_share = 0;
};

/// Natural frequencies (Hz, ascending) and mass-normalised shapes of a generic M (diagonal), K.
/// Throws TwinParameterError for non-positive masses or a non-symmetric K.
void solve_modes(const Eigen::VectorXd& mass, const Eigen::MatrixXd& stiffness, Eigen::VectorXd& frequencies_hz,
                 Eigen::MatrixXd& shapes);

/// All 21 modes of the linearised model, ascending, with their energy distributions.
std::vector<Mode> modal_analysis(const GearboxParameters& p);
std::vector<Mode> modal_analysis(const GearboxParameters& p, const GearboxMatrices& matrices);

/// Mass-weighted modal assurance criterion |aᵀ M b|² / ((aᵀ M a)(bᵀ M b)).
double modal_assurance(const Eigen::VectorXd& a, const Eigen::VectorXd& b, const Eigen::VectorXd& mass);

}  // namespace gearwatch::twin
