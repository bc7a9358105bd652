#pragma once
// The mesh-stiffness scale identified from the pattern of a baseline's mesh harmonics (docs/twin.md,
// "Commissioning"). A path gain multiplies every harmonic alike, so the pattern across harmonics,
// ln A_n with its mean removed, is free of the sensor's and the casing's sensitivity; the mesh
// stiffness moves it by moving the mesh-coupled resonances against the harmonics. The scale is the
// one whose simulated pattern is nearest (least squares in ln), and the scales whose pattern fits
// the baseline as well within its own misfit are stated with it.
#include <functional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace gearwatch::twin {

struct MeshPatternSettings {
  double low = 0.5, high = 1.5;  ///< the plausible range of the scale (the thesis's, §5.3)
  double grid_step = 0.05;       ///< the scan over the range (the cost need not have one minimum)
  double tolerance = 1e-3;       ///< golden-section refinement about the scan's best point
  /// A harmonic enters when its measured amplitude stands this far above the noise floor: at 10×
  /// (20 dB) the floor moves its ln by 0.1 at most, below the pattern's own changes.
  double min_snr = 10.0;
  /// Δcost / σ̂² bounding the stated interval: 3.84, the 95 % point of χ² with one degree of freedom
  /// (a profile interval, σ̂² the misfit per degree of freedom at the fit).
  double interval_chi2 = 3.84;
  /// The scale kept when the baseline does not identify one and does not reject this one either
  /// (inside the interval): the geometry's level, the ISO-normalised stiffness.
  double prior = 1.0;
};

/// What the baseline says about the scale.
enum class MeshScaleEvidence {
  identified,              ///< the interval lies inside the range
  too_few_harmonics,       ///< fewer than 3 harmonics above the floor: no pattern to fit (scale left at 1)
  minimum_at_bound,        ///< the best pattern is at an end of the range
  interval_reaches_bound,  ///< the minimum is inside, but scales up to an end fit as well
};
const char* to_string(MeshScaleEvidence e);

struct MeshPatternFit {
  double scale = 1.0;          ///< the nearest pattern's; the prior when not identified and not rejected
  double nearest_scale = 1.0;  ///< the nearest pattern's, always
  MeshScaleEvidence evidence = MeshScaleEvidence::too_few_harmonics;
  double interval_low = 0, interval_high = 0;  ///< the scales within the bound (the range when not identified)
  double misfit_ln_rms = 0;  ///< RMS over the harmonics of ln(measured/twin) minus its mean, at the fit
  double gain_ln = 0;        ///< that mean (a path gain in ln; the caller sets the gain on RMS_SA)
  std::vector<int> harmonics;  ///< harmonic numbers used (1 = the mesh frequency)
  std::vector<std::pair<double, double>> scan;  ///< (scale, cost) of every twin run, in scale order
  int simulations = 0;
};

/// The twin's mesh harmonics at a scale: element n−1 is harmonic n (as many as `measured` has).
using MeshHarmonicsAt = std::function<std::vector<double>(double scale)>;

/// Fits the scale to `measured` (element n−1: harmonic n's amplitude, NaN where not measured) whose
/// noise floor per harmonic is `floor` (0: none known). Throws std::invalid_argument on bad settings
/// and when the twin returns fewer harmonics or a non-positive amplitude at a harmonic in use.
MeshPatternFit fit_mesh_pattern(std::span<const double> measured, double floor, const MeshHarmonicsAt& twin,
                                const MeshPatternSettings& settings = {});

}  // namespace gearwatch::twin
