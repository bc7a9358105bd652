#pragma once
// Discrete lines removed from an angle-domain residual: what the residual's structure indicators
// (ICS2, band selection, spectral coherence) should see is its random part only. The thesis names
// TSA or discrete/random separation (DRS) to remove the deterministic part; TSA removes only what
// is synchronous with a shaft, so a line at another frequency (a mesh line moved by an angle
// error, a modulation the shafts do not share, another machine) stays in the residual and reads
// as cyclostationary content at the mesh order when such lines sit at a fixed offset from every
// mesh harmonic. Like DRS, this removes every discrete line, whatever its frequency.
#include <cstddef>
#include <span>
#include <vector>

#include "gearwatch/dsp/fft.hpp"

namespace gearwatch::dsp {

/// Bins per block of the local level: wide enough for a robust median, narrow against how fast a
/// residual's spectrum changes across its band.
inline constexpr std::size_t kLineRemovalBlockBins = 64;

struct LineRemovalResult {
  std::size_t bins_removed = 0;
  double energy_removed_fraction = 0.0;  ///< of the one-sided spectrum's energy (DC, Nyquist out)
};

/// A bin is a line when its power exceeds ln(M) times the local mean power of a random signal
/// (M = the bins tested): the power of a random signal's bin is exponentially distributed about
/// that mean (chi-squared, 2 degrees of freedom), so a random bin exceeds it with probability
/// 1/M, one bin per record on average. The local mean is the median of its block of
/// `block_bins` bins divided by ln 2 (the exponential's median), robust to the lines it holds. A
/// line between two bins and its leakage spread into the neighbours: the bins next to a line are
/// removed too. Removed bins are set to zero (the random part they held is lost, a share of
/// bins_removed / M of it).
class DiscreteLineRemover {
 public:
  explicit DiscreteLineRemover(std::size_t block_bins = kLineRemovalBlockBins);
  /// The shortest x remove() takes: 4 blocks of bins besides DC and Nyquist.
  std::size_t min_length() const noexcept { return 8 * block_bins_ + 2; }
  /// x in place; it must hold at least min_length() samples. Returns what was removed.
  LineRemovalResult remove(std::span<double> x, FftPlanCache& plans);

 private:
  void mark_lines(std::size_t bins, double factor);
  std::size_t block_bins_;
  ComplexBuffer spectrum_;
  RealBuffer power_, block_;
  std::vector<unsigned char> is_line_;  ///< per bin, reused: no allocation per record
};

}  // namespace gearwatch::dsp
