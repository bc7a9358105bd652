#pragma once
// The rig simulator: the 21-DOF model of the thesis's rig (core twin building blocks) with the
// truth effects of effects.hpp inside its equations of motion, a wear state, the sliding-induced
// cyclostationary vibration (thesis §4.2–4.3) and the sensor chain. Integrated by fixed-step
// classical Runge–Kutta whose steps are split at the mesh-stiffness steps (docs/rig-simulator.md
// "Integration", with its error against the twin's dopri5).
#include <cstdint>
#include <vector>

#include "gearwatch/rig/effects.hpp"
#include "gearwatch/rig/wear_truth.hpp"
#include "gearwatch/twin/gearbox_parameters.hpp"

namespace gearwatch::rig {

/// Sliding-induced random vibration modulated by the gear mesh (CS2): band-limited Gaussian noise
/// in a carrier band, times the mesh's sliding-speed pattern. Its strength follows the surface:
/// low carriers from pitting, high carriers from abrasion/roughness (thesis §4.2–4.3).
struct SlidingVibration {
  double pitting_rms_m_s2 = 0;     ///< RMS of the low-carrier (pitting) component
  double abrasion_rms_m_s2 = 0;    ///< RMS of the high-carrier (abrasion/roughness) component
  double pitting_band_low_hz = 3000, pitting_band_high_hz = 9000;
  double abrasion_band_low_hz = 22000, abrasion_band_high_hz = 34000;
};

/// An integration rate (5 µs steps) for records compared line by line with the twin's. The default
/// 10 µs steps leave an error 51 dB under the signal whose pattern over the mesh cycle drifts at
/// frac(rate / f_mesh)·f_mesh; where that falls on the gear's rate (15.479 Hz, for one) it puts
/// lines on the gear's first sidebands 12 dB above the gap diagnosis's comparison floor, which the
/// twin's adaptive integration does not have. Halving the step takes that error down 24 dB.
inline constexpr double kFineOdeRateHz = 200000;

/// The default integration rate (10 µs steps, `bench_rig`'s speed target).
inline constexpr double kDefaultIntegrationRateHz = 100000;

struct RigRunSettings {
  double speed_hz = 10.0;           ///< mean input speed
  double torque_nm = 20.0;          ///< motor torque (the brake holds it times the ratio); < 0: the load drives
  double duration_s = 10.0;
  double sample_rate_hz = 100000.0;
  int channels = 2;                 ///< 1: casing vertical (y6 side); 2: + horizontal (x6 side)
  double settle_s = 0.05;           ///< simulated, not output, before the first sample
  double min_ode_rate_hz = kDefaultIntegrationRateHz;  ///< the integration step is at most 1/this (sub-steps per sample)
  std::uint64_t seed = 1;           ///< noise and sliding-vibration realisations
  bool keep_diagnostics = false;    ///< fill RigRecord's diagnostic signals
  /// The sensor front-end reads the structure's acceleration this many times per sample and
  /// low-passes before decimating (dsp::AntiAliasDecimator), as an oversampling converter does;
  /// 0 (the default) takes dsp::front_end_oversampling(sample_rate_hz), 4 at 100 kHz; 1 reads it
  /// once per sample, which folds the mesh's lines above fs/2 onto the band. The sliding
  /// vibration, the mount and the noise act on the decimated record.
  int front_end_oversampling = 0;
};

struct RigRecord {
  double sample_rate_hz = 0;
  std::vector<std::vector<float>> acceleration;   ///< [channel][sample], m/s², what the sensors give
  std::vector<double> tacho_edges;                ///< input-shaft encoder (free end), 1/rev, fractional samples

  // Diagnostics (keep_diagnostics): per sample.
  std::vector<double> mesh_deflection_m;          ///< δ = gᵀq, dynamic transmission error
  std::vector<double> mesh_force_n;               ///< total mesh force (negative on back-flank contact)
  std::vector<double> bearing_force_y_n;          ///< vertical force of the bearings on the casing
  std::vector<double> casing_y_m_s2;              ///< the casing modes' share of channel 0
  std::vector<double> structure_y_m_s2;           ///< ÿ6 (+ casing) before sliding vibration and sensor
  std::vector<double> input_angle_rad;            ///< input-shaft encoder angle
  std::vector<double> mesh_cycles;                ///< mesh cycles since t = 0 (floor: cycle, fraction: phase)
  std::size_t rhs_evaluations = 0;
  std::size_t integration_steps = 0;
};

/// Simulates one record. Throws RigParameterError (bad settings) or twin::TwinParameterError /
/// TwinDivergenceError from the model.
RigRecord simulate_record(const twin::GearboxParameters& params, const EffectSet& effects, const WearState& wear,
                          const SlidingVibration& sliding, const RigRunSettings& settings);

/// The tooth-profile deviation the rig's GTE uses for a wear state and the effects (wear profile
/// + per-tooth errors + tip relief), exposed for tests and the truth record.
twin::ToothProfileDeviation truth_profile(const twin::GearboxParameters& params, const EffectSet& effects,
                                          const WearState& wear);

}  // namespace gearwatch::rig
