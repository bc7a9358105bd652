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

  /// x += 2 Re(Σ right_j·z_j): the state the modal coordinates z make.
  void add_state(State& x, const Amplitudes& z) const;
  /// Coordinate `index` of that state.
  double state_coordinate(const Amplitudes& z, int index) const;

 private:
  struct Mode {
    Complex lambda;
    Eigen::Matrix<Complex, 2 * kDofCount, 1> left;                   // z = leftᵀ x
    Eigen::Matrix<double, 2 * kDofCount, 1> right_real, right_imag;  // x = 2 Re(right z)
  };
  std::vector<Mode> modes_;
};

/// e^{λ_j·i/rate} of each slow mode at a record's sample indices i: the product of two tabulated
/// powers (i = m·kFineSteps + n), one complex product where an exponential would be. The tiling
/// reads the slow modes at every sample of the record; the indices are exact where the times are not.
class SampleGridPhasors {
 public:
  using Complex = SlowModes::Complex;
  SampleGridPhasors(const SlowModes& modes, double rate, std::size_t count);
  /// Mode j's e^{λ·i/rate}; past `count` it is computed.
  Complex at(std::size_t j, std::size_t i) const;

 private:
  static constexpr std::size_t kFineSteps = 1024;
  const SlowModes& modes_;
  double rate_;
  std::vector<std::vector<Complex>> fine_, coarse_;  // per mode: e^{λn/rate}, n < kFineSteps; e^{λ·m·kFineSteps/rate}
};

}  // namespace gearwatch::twin
