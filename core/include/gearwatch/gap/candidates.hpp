#pragma once
// The candidate effects' parametric forms. Each acts on the twin's order-tracked spectra (lines of
// both shafts and the broadband part) the way the physical effect acts on the twin's output, in
// expectation, so adding a candidate never re-runs the twin's ODE:
//   casing_mode       a transfer path fixed in Hz (foundation/casing modes add coherently to the
//                     twin's response, so the ratio has peaks and notches): a gain per 1/12-octave
//                     band from 10 Hz, interpolated linearly in log f between band centres
//   mount_resonance   base-excited 1-DOF transmissibility: P·(1 + (2ζr)²)/((1 − r²)² + (2ζr)²), r = f/fn
//   noise_floor       additive white floor N0 per 1-order bin; N0/R on each synchronous line
//   eccentricity      AM at shaft order 1: sidebands n·z ± 1 gain (a²/4)·P(n·GMF) on each shaft
//   tooth_errors      per-tooth pattern: every non-mesh line of a shaft gains c·E(order), E the
//                     twin's mesh-harmonic envelope (its transfer path) interpolated in order
//   speed_fluctuation order tracking follows the speed, but the transfer path does not: the lines
//                     are amplitude-modulated at f_m; a share μ of every line leaves it for sidebands
//                     f_m away (the lines themselves barely change)
//   load_fluctuation  brake torque ripple twists the train between the encoder and the mesh: phase
//                     modulation in the encoder's angle; a share 1 − exp(−(β·k)²) of line k leaves
//                     it for sidebands f_m away (grows with order, the high mesh harmonics lose most)
// The broadband part is what neither shaft's synchronous average holds: modulation sidebands
// enter it at their fractional orders.
//   tip_relief        a gain per mesh harmonic, dB (gradual engagement reshapes the whole
//                     harmonic series; fixed in orders, where casing_mode is fixed in Hz)
//   misalignment      one gain on all mesh harmonics, dB
//   backlash          mesh harmonics raised by b·n dB (b ≥ 0)
#include <string>
#include <vector>

#include "gearwatch/gap/gap_report.hpp"
#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/rig.hpp"

namespace gearwatch::gap {

struct CandidateParameter {
  std::string name;   ///< with its unit, e.g. "frequency_hz"
  double low = 0, high = 1;
  bool log_scale = false;
  int grid = 3;       ///< starting points of the fit along this parameter
};

struct CandidateForm {
  CandidateEffect effect;
  std::vector<CandidateParameter> parameters;
  std::vector<FamilyKind> explains;
  int stage = 0;      ///< order of application: source (0), modulation (1), transfer path (2), sensor (3)
};

/// The form of a candidate; `sample_rate_hz` bounds the resonance searches.
CandidateForm candidate_form(CandidateEffect effect, double sample_rate_hz);

/// The transfer path's bands: centre of band b is 10·2^((b + 0.5)/12) Hz; enough bands to reach
/// 0.45·fs.
std::size_t transfer_path_bands(double sample_rate_hz);
double transfer_path_band_centre_hz(std::size_t band);
/// Gain (dB) of a transfer path with the given band gains at f (flat beyond the outer centres).
double transfer_path_gain_db(const std::vector<double>& band_gains_db, double f_hz);

/// How many per-harmonic gains the tip_relief form has at this sample rate.
int tip_relief_harmonics(double sample_rate_hz);

/// A candidate with its parameters (natural units, in the order of its form).
struct AppliedEffect {
  CandidateEffect effect;
  std::vector<double> values;
};

/// The twin's spectra with the effects added, in the forms' stage order.
SpectralSummary apply_effects(const std::vector<AppliedEffect>& effects, const SpectralSummary& twin,
                              const GearPairSpec& gears);

/// Measured and twin spectra of one record, and the floor they are compared above.
struct SummaryPair {
  SpectralSummary measured, twin;
  double floor = 0;
};

/// Fits a candidate on top of `base` (fixed) to the training pairs: the sum over the line/bin
/// families of the mean squared log ratio, families weighted alike. Grid over each parameter
/// (with the strongest-gap lines' frequencies as extra starts of the resonance searches), then
/// Nelder–Mead from the two best starts. Returns the values in the form's order.
std::vector<double> fit_candidate(CandidateEffect effect, const std::vector<AppliedEffect>& base,
                                  const std::vector<SummaryPair>& training, const GearPairSpec& gears);

/// That training cost (for tests and for comparing fits).
double training_cost(const std::vector<SummaryPair>& training, const std::vector<AppliedEffect>& effects,
                     const GearPairSpec& gears);

}  // namespace gearwatch::gap
