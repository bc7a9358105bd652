#pragma once
// The fit of a lumped model's natural frequencies to measured ones, shared by the calibration of the
// 21-DOF twin and the modal-gap fits of its structural variants. The model is the caller's; the fit
// sees it only through evaluate() and the knobs' stiffness and mass terms.

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "gearwatch/twin/gearbox_model.hpp"

namespace gearwatch::twin::detail {

struct ModalEvaluation {
  Eigen::VectorXd frequencies;  // Hz, ascending
  Eigen::MatrixXd shapes;       // mass-normalised columns
  Eigen::VectorXd mass;
  std::vector<SpringElement> springs;
};

/// A log-space knob: x_j = ln of its value (or factor), a Gaussian prior of σ = range/4 about
/// `log_centre`, and the springs (indices into ModalEvaluation::springs) and mass DOFs it scales.
struct LogKnob {
  double log_low = 0, log_high = 0, log_centre = 0, sigma = 0;
  std::vector<int> springs;
  std::vector<int> mass_dofs;
};

class FrequencyFitProblem {
 public:
  /// `context` prefixes the error messages ("calibration", "modal fit").
  FrequencyFitProblem(std::vector<double> measured, std::vector<bool> use, double frequency_sigma, int max_iterations,
                      std::string context);
  virtual ~FrequencyFitProblem() = default;

  virtual ModalEvaluation evaluate(const Eigen::VectorXd& x) const = 0;

  std::size_t knob_count() const { return knobs_.size(); }
  const LogKnob& knob(std::size_t j) const { return knobs_[j]; }
  double lo(std::size_t j) const { return knobs_[j].log_low; }
  double hi(std::size_t j) const { return knobs_[j].log_high; }
  int max_iterations() const { return max_iterations_; }

  /// d ln f_mode / d x_j (x = ln knob value): ½ φᵀ(K_j − ω² M_j)φ / ω² for mass-normalised φ.
  Eigen::VectorXd log_sensitivity(const ModalEvaluation& e, int mode) const;
  /// Monotone assignment of the measured frequencies (all of them) to elastic modes; cost: the
  /// prior-weighted squared distance the knobs must travel to move the mode onto the value.
  std::vector<int> initial_pairing(const ModalEvaluation& e) const;
  /// Follows the paired modes by shape: greedy maximum-MAC assignment against reference shapes.
  std::vector<int> track(const ModalEvaluation& e, const Eigen::MatrixXd& reference) const;
  /// Used frequencies' log errors over σ_f, then each knob's prior term; the Jacobian if asked.
  Eigen::VectorXd residual(const ModalEvaluation& e, const std::vector<int>& pairing, const Eigen::VectorXd& x,
                           Eigen::MatrixXd* jacobian) const;

 protected:
  void add_knob(double low, double high, double log_centre, std::vector<int> springs, std::vector<int> mass_dofs);

 private:
  std::vector<double> measured_;
  std::vector<bool> use_;
  double frequency_sigma_;
  int max_iterations_;
  std::string context_;
  std::vector<LogKnob> knobs_;
};

struct FitOutcome {
  Eigen::VectorXd x;
  std::vector<int> pairing;
  std::vector<int> start_pairing;
  Eigen::MatrixXd start_shapes;
  double cost = std::numeric_limits<double>::infinity();
  int iterations = 0;
};

/// Projected Levenberg–Marquardt from x (clamped into the knob box), the modes followed by MAC
/// against the previous accepted step's shapes.
FitOutcome fit_from(const FrequencyFitProblem& problem, Eigen::VectorXd x);

}  // namespace gearwatch::twin::detail
