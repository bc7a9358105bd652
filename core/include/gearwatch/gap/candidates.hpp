#pragma once
// The candidate effects' parametric forms. Each acts on the twin's order-tracked spectra (lines of
// both shafts and the broadband part) the way the physical effect acts on the twin's output, in
// expectation, so adding a candidate never re-runs the twin's ODE:
//   casing_mode       casing/foundation modes on the bearings (fixed in Hz): two modes of frequencies
//                     f1, f2, damping ζ and modal mass m, driven by the bearings' forces F, add their
//                     acceleration to the sensor's: line at f gains |1 + (F/y6)(f)/m · Σ 1/(ωc² − ω² +
//                     2iζωcω)|², F/y6 the twin's own bearing-force path (bearing_force_path()), so
//                     the peaks and notches follow from four values at every speed
//   mount_resonance   base-excited 1-DOF transmissibility: P·(1 + (2ζr)²)/((1 − r²)² + (2ζr)²), r = f/fn
//   noise_floor       additive white floor of one-sided PSD S (per Hz): 2·S·speed in each 1-order
//                     bin (white in Hz, so its level per order grows with the speed), that over R on
//                     each synchronous line (R its averages; the output's orders z1/z2 as wide)
//   eccentricity      a run-out of each shaft along the line of action (m): a transmission error at that
//                     shaft's frequency, which the twin's linearised model turns into a modulation of
//                     the mesh force (AM) and a turning of the pinion that one tacho edge per revolution
//                     cannot follow (PM growing with the harmonic): first sidebands n·z ± 1 of each
//                     shaft gain ((a·e)² + (n·b·e)²)/4 · P(n·GMF), a and b from run_out_sensitivity()
//                     at each record's speed and torque, so one run-out serves every speed and load.
//                     With the twin's run-out response on its spectra (RunOutResponse, from twin
//                     reruns; the diagnosis reads it when this form ranks among the two best) every
//                     line gains e²·(|R0|² + |R1|²)/2 per shaft instead: the twin's own change of that
//                     line under a run-out, over the run-out's phase (which line powers cannot tell),
//                     so the lower and upper sidebands each get their own, where the power form gives
//                     a sideband pair's mean
//   tooth_errors      per-tooth pattern: every non-mesh line of a shaft gains c·E(order), E the
//                     twin's mesh-harmonic envelope (its transfer path) interpolated in order, and
//                     the residual gains c_r·E(order) (the tooth pairings repeat only every z1·z2
//                     meshes, so what pairs add together is synchronous with neither shaft); at
//                     each load (the errors excite the same at any load, the twin's mesh ∝ load)
//   speed_fluctuation a speed ripple of depth d at f_m turns the shaft d/x rad ahead and back
//                     (x = f_m / shaft speed); the one-edge tacho follows all but r(x) of it
//                     (dsp::tracking_residual_share): line k keeps J0²(k·(d/x)·r); the transfer path
//                     in Hz does not follow the speed, so a share μ of every line is amplitude-
//                     modulated too; what leaves a line goes to sidebands f_m away. Or the ripple is
//                     locked to a shaft's order (once per revolution of either shaft, a fourth value:
//                     speed_fluctuation_input_order()): line k keeps (1 − μ)·J0(m)², sideband j·x
//                     away gets (1 − μ)·J_j(m)² (+ μ/2 on the first), m = k·(d/x)·r(x)
//   load_fluctuation  brake torque ripple twists the train between the encoder and the mesh: phase
//                     modulation in the encoder's angle; a share 1 − exp(−(β·k)²) of line k leaves
//                     it for sidebands f_m away (grows with order, the high mesh harmonics lose most)
// The broadband part is what neither shaft's synchronous average holds: modulation sidebands
// enter it at their fractional orders.
//   tip_relief        with a twin rerun: the twin with linearly relieved tips (gradual engagement,
//                     which changes with load as the load deflects the relieved tip into contact);
//                     without: a gain per mesh harmonic at each load, dB (fixed in orders, where
//                     casing_mode is fixed in Hz)
//   misalignment      with a twin rerun (DiagnosisSettings::rerun_twin): the twin with the load carried
//                     over part of the face (a pair's stiffness grows with its compression, so the
//                     mesh stiffness and its resonance change with load); without: one gain on all
//                     mesh harmonics, dB
//   backlash          mesh harmonics raised by b·n dB (b ≥ 0)
#include <array>
#include <complex>
#include <memory>
#include <string>
#include <vector>

#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/twin/gearbox_model.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "gearwatch/twin/transmission_error.hpp"
#include "gearwatch/types/gap_report.hpp"

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
  /// Fitted at each training load on its own: the values are groups of the load (N·m, −1 for records
  /// without one) followed by the parameters, and a record takes the group of the nearest load.
  /// For effects whose size relative to the twin's mesh response changes with load.
  bool per_load = false;
  /// The first two parameters are interchangeable (two modes of one kind): the fit starts from one
  /// order of each pair of their grid points, descends from different pairs, and reports them rising.
  bool interchangeable_pair = false;
};

/// The form of a candidate; `sample_rate_hz` bounds the resonance searches.
CandidateForm candidate_form(CandidateEffect effect, double sample_rate_hz);

/// The parameter values at which a candidate that changes the twin's dynamics is simulated (its
/// fit picks the best); empty for the candidates that act on the twin's spectra.
///   misalignment  {angle}: across the face, 0.01–1 mrad in 9 log steps (1 mrad over a 20 mm face
///                 separates the flanks by 20 µm, several times the static deflection at the thesis's loads)
///   tip_relief    {amount, length fraction}: linear relief on both gears, 2–32 µm in 5 doubling
///                 steps × 0.1, 0.2, 0.4 of the active profile from the tip
std::vector<std::vector<double>> rerun_grid(CandidateEffect effect);
/// The ratio between neighbouring grid values along each of a rerun candidate's parameters (its
/// grid is log-spaced); a chosen candidate's value is refined in fractions of it.
std::vector<double> rerun_grid_ratios(CandidateEffect effect);
/// What re-running the twin with a rerun candidate at `values` changes: the options (misalignment:
/// the face misalignment angle) or the tooth profile (tip relief: a linear relief on top of the
/// profile, e.g. the wear state's). Every caller that re-runs the twin for the diagnosis goes through
/// this. Throws std::invalid_argument for a candidate without a rerun or values of the wrong count.
void add_rerun_effect(CandidateEffect effect, const std::vector<double>& values, twin::ToothProfileDeviation& profile,
                      twin::SimulationOptions& options);
/// The names (SI units) of a rerun candidate's values, in the order of its grid points.
/// Eccentricity has no grid but is re-run for its run-out response (run_out_response_reruns()):
/// {pinion_run_out_m, gear_run_out_m, pinion_phase_rad, gear_phase_rad}.
std::vector<std::string> rerun_parameter_names(CandidateEffect effect);

/// The run-out the twin is re-run with to read its response (RunOutResponse): enough above the
/// integrator's noise that the lines' differences are clean, small enough to stay linear (at 8 Hz
/// and 20 N·m 10 µm and 2 µm give the same response to 0.1 dB on the sidebands above the
/// comparison's floor).
inline constexpr double kRunOutResponseUnitM = 10e-6;
/// The eccentricity reruns, in rerun_parameter_names' order: without a run-out, then
/// kRunOutResponseUnitM on the pinion at phase 0 and π/2, then on the gear at 0 and π/2.
std::array<std::vector<double>, 5> run_out_response_reruns();

/// The twin's bearing-force path (BearingForcePath) from its linearised model: the response to a
/// transmission error at the mesh (twin::transmission_error_response), Σ of the grounded vertical
/// bearing springs' forces over the sensor DOF y6, from 1 Hz to `highest_hz` at 96 points an octave.
/// Throws std::invalid_argument for a highest frequency ≤ 1 Hz or not finite.
std::shared_ptr<const BearingForcePath> bearing_force_path(const twin::GearboxMatrices& matrices, double highest_hz);

/// One casing mode's share of the sensor's reading relative to the twin's, for a bearing-force path
/// ratio (N/m): e^{iφ}·ratio/m · 1/(ωc² − ω² + 2iζωcω), its constants computed once. φ is the phase
/// of the mode's residue at the sensor: 0 for a casing whose damping is proportional to its mass and
/// stiffness (real modes, casing_mode's form); otherwise (bolted joints, covers) the residue is
/// complex and the peak need not stand where the path's own phase puts it.
class CasingModeTerm {
 public:
  CasingModeTerm(double mode_hz, double damping_ratio, double modal_mass_kg, double residue_phase_rad = 0.0) noexcept;
  std::complex<double> operator()(std::complex<double> bearing_force_ratio, double f_hz) const noexcept;

 private:
  double wc2_, two_zeta_wc_;
  std::complex<double> residue_;  ///< e^{iφ}/m
};

/// The power gain of casing modes (casing_mode's form) at f for a bearing-force path ratio (N/m):
/// |1 + ratio/m · Σ_c 1/(ωc² − ω² + 2iζωcω)|².
double casing_modes_gain(std::complex<double> bearing_force_ratio, double f_hz, double mode1_hz, double mode2_hz,
                         double damping_ratio, double modal_mass_kg) noexcept;

/// How many per-harmonic gains the tip_relief form has at this sample rate.
int tip_relief_harmonics(double sample_rate_hz);
/// The power a white floor of one-sided PSD `psd_per_hz` puts in one order bin of a shaft turning
/// at `shaft_speed_hz` (a bin `shaft_speed_hz` wide), in the spectra's peak-amplitude² convention.
double noise_floor_per_order_bin(double psd_per_hz, double shaft_speed_hz) noexcept;
/// The load key of a record's torque (−1 when it has none), as per-load forms group records.
double load_key(double torque_nm) noexcept;
/// A per-load form's values for a record at `torque_nm`: the group of the nearest load, without
/// its load (the values themselves for other forms).
std::vector<double> values_at_load(const CandidateForm& form, const std::vector<double>& values, double torque_nm);

/// The names of a candidate's fitted values (the form's names; per-load forms' prefixed by the group).
std::vector<std::string> parameter_names(const CandidateForm& form, const std::vector<double>& values);

/// The fitted values of a candidate that sit at an end of their range (the form's range for a
/// spectral fit, which clamps there; the grid's for a rerun fit, `rerun` true): the fit would have
/// gone further, so the physics would need a value beyond the range (e.g. a run-out above 0.3 mm).
/// Named as parameter_names() (rerun_parameter_names() for a rerun fit). A per-load form's loads are
/// not parameters.
std::vector<ParameterBound> parameters_at_bounds(CandidateEffect effect, const std::vector<double>& values,
                                                 double sample_rate_hz, bool rerun);

/// The twin's response to a run-out of one metre of the pinion (`gear_shaft` false) or the gear shaft
/// at a record's input speed and torque. The run-out is a transmission error at that shaft's
/// frequency f (twin::transmission_error_response). AM index: the loaded deflection's change over the
/// mean deflection T/(r_b1·k̄) (0 without a torque). PM per harmonic: z1 times the pinion's angle
/// (the mesh phase follows it) times the share one tacho edge per input revolution leaves of an angle
/// deviation at f (dsp::tracking_residual_share: all of it at the input shaft's own frequency; the
/// encoder at the input shaft's free end, thesis §3.2, turns with the pinion at these frequencies).
/// Throws std::invalid_argument for a speed that is not positive and finite.
RunOutSensitivity run_out_sensitivity(const twin::GearboxMatrices& matrices, const GearPairSpec& gears, bool gear_shaft,
                                      double input_speed_hz, double torque_nm);

/// A candidate with its parameters (natural units, in the order of its form).
struct AppliedEffect {
  CandidateEffect effect;
  std::vector<double> values;
};

/// The twin's spectra with the effects added, in the forms' stage order.
SpectralSummary apply_effects(const std::vector<AppliedEffect>& effects, const SpectralSummary& twin,
                              const GearPairSpec& gears);

/// Measured and twin spectra of one record, and the floor they are compared above.
/// A speed-fluctuation candidate's ripple locked to a shaft's order: its values are {depth,
/// modulation_frequency_hz, am_share, modulation_input_order}; a fourth value > 0 is the ripple's order
/// in input orders (1: once per input revolution, z1/z2: once per output revolution) and the frequency
/// in Hz is unused (0); three values, or a fourth of 0, a ripple fixed in Hz.
double speed_fluctuation_input_order(const std::vector<double>& values) noexcept;

struct SummaryPair {
  SpectralSummary measured, twin;
  double floor = 0;
};

/// Fits a candidate on top of `base` (fixed) to the training pairs: the sum over the line/bin
/// families of the mean squared log ratio, families weighted alike. Grid over each parameter, then
/// Nelder–Mead from the two best starts. Returns the values in the form's order.
std::vector<double> fit_candidate(CandidateEffect effect, const std::vector<AppliedEffect>& base,
                                  const std::vector<SummaryPair>& training, const GearPairSpec& gears);

/// That training cost (for tests and for comparing fits).
double training_cost(const std::vector<SummaryPair>& training, const std::vector<AppliedEffect>& effects,
                     const GearPairSpec& gears);

}  // namespace gearwatch::gap
