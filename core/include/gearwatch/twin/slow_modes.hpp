#pragma once
// The slow elastic modes of the linearised model (the mean mesh stiffness, the structure's damping
// and the mesh's at that stiffness) as state-space eigenvectors. A start-up transient in one of
// them decays freely, c·e^{λt}, long after the faster modes have died out: the default record's
// tiling (SimulationOptions::periodic_keeps_transient) carries that decay on from the template
// instead of integrating until it is gone, and its periodicity check holds everything else of the
// state, and what the linear model misses of these modes, to its tolerance.
#include <complex>
#include <vector>

#include <Eigen/Dense>

#include "gearwatch/twin/gearbox_model.hpp"

namespace gearwatch::twin {

class SlowModes {
 public:
  using Complex = std::complex<double>;
  using Amplitudes = std::vector<Complex>;

  /// The elastic modes whose damped frequency lies below `below_hz` (none for 0).
  SlowModes(const GearboxMatrices& m, double below_hz);

  bool empty() const { return modes_.empty(); }
  std::size_t size() const { return modes_.size(); }
  /// Mode j's eigenvalue λ (rad/s, Im λ > 0; its conjugate is the pair's other half).
  Complex eigenvalue(std::size_t j) const { return modes_[j].lambda; }

  /// The amplitudes at the anchor from the anchor's state and the state one period later: over the
  /// period a mode's free decay changes it by c·(e^{λT} − 1), a periodic part not at all. A mode
  /// whose change over the period says little of c (|e^{λT} − 1| < 1e-2) gets none.
  Amplitudes amplitudes(const State& anchor, const State& later, double period_s) const;

  /// The amplitudes of the state x itself (its projection on the slow modes at time 0).
  Amplitudes project(const State& x) const;

  /// Coordinate `index` of the state 2 Re(Σ right·c·e^{λs}) the amplitudes make at s.
  double coordinate(const Amplitudes& c, int index, double s) const;

  /// x += the slow modes' change from `from_s` to `to_s` after the anchor.
  void advance(State& x, const Amplitudes& c, double from_s, double to_s) const;

 private:
  struct Mode {
    Complex lambda;
    Eigen::Matrix<Complex, 2 * kDofCount, 1> left, right;  // z = leftᵀ x; x = 2 Re(right z)
  };
  std::vector<Mode> modes_;
};

}  // namespace gearwatch::twin
