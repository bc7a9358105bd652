#pragma once
// Steady-state simulation of the 21-DOF model (thesis §5.2.3, §5.3): Boost.Odeint dopri5 with dense
// output sampled at the acquisition rate, with step checks that stop a divergent run.
#include <cstddef>
#include <vector>

#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/gearbox_model.hpp"
#include "gearwatch/twin/gearbox_parameters.hpp"
#include "gearwatch/twin/transmission_error.hpp"

namespace gearwatch::twin {

struct OperatingPoint {
  double input_speed_hz = 10.0;   ///< pinion (input) shaft speed
  double input_torque_nm = 20.0;  ///< motor torque; the brake holds it times the ratio
};

struct SimulationOptions {
  double sample_rate_hz = 100000.0;
  double settle_s = 0.05;               ///< simulated, not output, before the first sample
  /// dopri5's step control. The default is the reference tolerance: the gap diagnosis's fits were
  /// validated on it, and fast()'s looser step control moves a fitted casing damping past its
  /// test's tolerance (docs/twin.md, Speed), so fast() is opt-in only.
  double relative_tolerance = 1e-6;
  double absolute_tolerance = 1e-12;    ///< the state mixes rad and m; 1e-12 resolves 1e-9 m vibration
  int max_steps_per_sample = 2000;      ///< odeint max_step_checker between two output samples
  double deflection_limit_m = 1e-3;     ///< |δ| beyond this is divergence (teeth are ~4 mm high)
  MeshModel mesh_model = MeshModel::time_varying;
  /// An addition the thesis's twin does not have (for the gap diagnosis's misalignment candidate):
  /// angular misalignment across the face, rad; the flank separation is this × the face width.
  double face_misalignment_rad = 0;
  /// An addition for the gap diagnosis's eccentricity candidate: the shafts' run-out along the line
  /// of action (ShaftRunOut); zero (the default) is none.
  ShaftRunOut shaft_run_out;
  /// simulate_casing_signal only: the sensor front-end reads the model at this many times the
  /// sample rate and low-passes before decimating (dsp::AntiAliasDecimator), as an oversampling
  /// converter does; 0 (the default) takes dsp::front_end_oversampling(sample_rate_hz), 4 at
  /// 100 kHz; 1 samples the acceleration directly, which folds the mesh's lines above fs/2 onto
  /// the band. simulate() always samples directly.
  int front_end_oversampling = 0;

  /// Tiling by the inputs' period: every input the twin takes (constant speed and torque, the
  /// tooth profiles, misalignment, run-out) repeats with the period periodic_inputs_period_s()
  /// gives, so once the start-up transient has died out the state repeats with it. The run is
  /// integrated until consecutive period boundaries agree (periodic_tolerance); one more period is
  /// integrated as the template, and samples are read off the template's dense output at their
  /// own time shifted by whole periods. A run that never agrees is the full integration.
  /// The default (periodic_keeps_transient): the record is the full integration up to the
  /// template's end and the template tiled after it, so the start-up transient the rig's records
  /// hold stays in the record; the search ends with the record. periodic_path() (opt-in): every
  /// sample, from the first, is read off the template, searched past the record's end if need be
  /// (periodic_search_s): the steady state, no start-up transient, its content independent of the
  /// record's length (docs/twin.md, Periodic path). reference() turns tiling off.
  bool periodic = true;
  /// How far past the record's start periodic_path()'s search for the steady state may integrate
  /// when the record is shorter (s): after a worn start the lowest torsional mode rings for about
  /// a second. Not used while periodic_keeps_transient.
  double periodic_search_s = 3.0;
  /// With `periodic`: the samples up to the template's end are the full integration's (the
  /// start-up transient stays in the record), only the later ones are read off the template.
  bool periodic_keeps_transient = true;
  /// The periodicity check between period boundaries: the casing acceleration within this fraction
  /// of its RMS over a period, the same bound as fast()'s on the whole record's difference, and the
  /// whole state's difference in the energy norm within its square of the vibration's kinetic energy.
  double periodic_tolerance = 1e-3;
  /// And the input shaft's angle within the angle it turns in this many samples: a third of the
  /// tacho bound docs/twin.md states (the tiled record differs by the transient at two times).
  double periodic_tacho_tolerance_samples = 3e-3;

  /// The reference integration: the full record integrated step by step (no periodic path), named
  /// for the tests and benchmarks comparing with it.
  static SimulationOptions reference() {
    SimulationOptions o;
    o.periodic = false;
    return o;
  }
  /// The periodic path on (see `periodic`).
  static SimulationOptions periodic_path() {
    SimulationOptions o;
    o.periodic = true;
    o.periodic_keeps_transient = false;
    return o;
  }
  /// The fast integration: the reference's dopri5 at a relative tolerance of 1e-4, fewer than half
  /// the steps; its casing acceleration stays within the bounds docs/twin.md states of reference()'s.
  static SimulationOptions fast() {
    SimulationOptions o = reference();
    o.relative_tolerance = 1e-4;
    return o;
  }
};

/// The dynamic force carried by one tooth pair over its pass along the line of action (root of the
/// pinion → tip), with the Hertz pressure (thesis Fig. 5.18; input to the wear models).
struct ContactForceProfile {
  std::vector<double> position_m;         ///< s on the line of action
  std::vector<double> pinion_fraction;    ///< 0 = pinion start of active profile .. 1 = tip
  std::vector<double> force_n;
  std::vector<double> max_pressure_pa;
  std::vector<double> half_width_m;
};

struct SimulationResult {
  double sample_rate_hz = 0;
  std::vector<double> time_s;
  std::vector<double> casing_acceleration;   ///< ÿ6 (m/s²)
  std::vector<double> mesh_force_n;          ///< total dynamic mesh force
  std::vector<double> mesh_stiffness_n_m;    ///< Σ k_i of the pairs in contact
  std::vector<double> transmission_error_m;  ///< δ = gᵀq (dynamic TE along the line of action)
  std::vector<double> gte_m;                 ///< kinematic GTE of the pairs in contact
  std::vector<int> pairs_in_contact;
  /// Input-shaft tacho: one edge per revolution, in samples from the first sample (fractional).
  std::vector<double> tacho_edges;
  ContactForceProfile contact_profile;       ///< the first full tooth-pair pass after settling
  double brake_torque_nm = 0;
  std::size_t rhs_evaluations = 0;
  /// The periodic path was taken: every sample was read off the template period that starts at
  /// `template_start_s` from the record's start (past the record's end for a short record).
  bool tiled = false;
  double template_start_s = 0;
};

/// The period every input of a run repeats with: one mesh period for uniform tooth profiles and no
/// run-out; a pinion turn (z1 mesh periods) with per-tooth pinion profiles or a pinion run-out; a
/// gear turn (z2) likewise; the hunting period (lcm(z1, z2) mesh periods) with both.
double periodic_inputs_period_s(const GearboxParameters& p, const ToothProfileDeviation& deviation, const OperatingPoint& op,
                                const SimulationOptions& options);

/// Simulates `duration_s` of steady running after `settle_s`, starting from the static equilibrium
/// of the linearised model; on the periodic path (opt-in) every sample is the steady state's
/// (SimulationOptions::periodic). Throws TwinParameterError (bad input) or TwinDivergenceError.
SimulationResult simulate(const GearboxParameters& p, const ToothProfileDeviation& deviation, const OperatingPoint& op,
                          double duration_s, const SimulationOptions& options = {});

/// The twin's record: the casing acceleration y6 (m/s²) at `sample_rate_hz` as a sensor front-end
/// gives it (SimulationOptions::front_end_oversampling, anti-aliased by default) and the
/// input-shaft tacho edges (one per revolution, in samples), for a given wear state.
struct CasingSignal {
  double sample_rate_hz = 0;
  std::vector<float> acceleration;
  std::vector<double> tacho_edges;
};
CasingSignal simulate_casing_signal(const GearboxParameters& p, const ToothProfileDeviation& deviation,
                                    const OperatingPoint& op, double duration_s, double sample_rate_hz);
/// The same with every simulation option (the rate is options.sample_rate_hz).
CasingSignal simulate_casing_signal(const GearboxParameters& p, const ToothProfileDeviation& deviation,
                                    const OperatingPoint& op, double duration_s, const SimulationOptions& options);

/// RMS of a signal after a 4th-order Butterworth low-pass (two biquads, bilinear transform): the
/// thesis's 0–2 kHz band RMS of y6 used to tune the mesh (§5.3). The mean is removed first and the
/// first 5/cutoff seconds (filter start-up) are left out of the RMS.
double lowpass_rms(const std::vector<double>& signal, double sample_rate_hz, double cutoff_hz);

/// Fine-tunes mesh_stiffness_scale (inside [low, high]) so that lowpass_rms of the simulated y6 at
/// `op` equals target_rms (bisection on the monotone branch; the thesis adjusted it by hand).
struct MeshTuningResult {
  double mesh_stiffness_scale = 1;
  double simulated_rms = 0;
  double target_rms = 0;
  int simulations = 0;
  bool reached = false;             ///< |sim − target| ≤ 1 % of target
};
MeshTuningResult tune_mesh_to_rms(const GearboxParameters& p, const OperatingPoint& op, double target_rms,
                                  double duration_s, double cutoff_hz = 2000.0, double low = 0.5, double high = 1.5,
                                  double sample_rate_hz = 100000.0);

}  // namespace gearwatch::twin


namespace gearwatch::dsp {
struct SignalProcessingSettings;
struct ChannelAnalysis;
}

namespace gearwatch::twin {

/// RMS_SA(N) (Eq. 7.1) of the simulated casing acceleration, computed by the measurement code:
/// the simulated y6 and input tacho are packed into a gearwatch::Record and passed to
/// dsp::RecordAnalyzer, which returns its "rms_sa" indicator (N from `settings`). Throws
/// TwinParameterError when the analyzer skips it (the reason is in the message).
double simulated_rms_sa(const GearboxParameters& p, const ToothProfileDeviation& deviation, const OperatingPoint& op,
                        double duration_s, const GearboxSpec& rig, const dsp::SignalProcessingSettings& settings);

/// Every indicator of the simulated casing acceleration by the measurement code (the same Record
/// and dsp::RecordAnalyzer as simulated_rms_sa, which reads its "rms_sa" from this analysis): the
/// mesh harmonics of the synchronous average ("gmf_harmonic_N") among them. Never throws on what
/// the analyser skips; the skips are in the analysis.
dsp::ChannelAnalysis simulated_analysis(const GearboxParameters& p, const ToothProfileDeviation& deviation, const OperatingPoint& op,
                                        double duration_s, const GearboxSpec& rig, const dsp::SignalProcessingSettings& settings);

}  // namespace gearwatch::twin
