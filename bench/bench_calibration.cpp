// The Table 5.5 calibration and its leave-two-out cross-validation: how long they take (one core)
// and what they reach. The held-out figure is reported against its target here rather than in a
// test, because inside the documented priors the target is missed (docs/twin.md).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "gearwatch/twin/calibration.hpp"

int main() {
  using namespace gearwatch::twin;
  using clock = std::chrono::steady_clock;
  const auto& measured = table_5_5_frequencies();
  const auto knobs = default_calibration_knobs();
  const GearboxParameters prior = GearboxParameters::prior();
  const std::vector<bool> all(measured.size(), true);

  constexpr int repeats = 5;
  double fastest = 1e9;
  CalibrationResult fit;
  for (int i = 0; i < repeats; ++i) {
    const auto t0 = clock::now();
    fit = calibrate(prior, measured, all, knobs);
    fastest = std::min(fastest, std::chrono::duration<double>(clock::now() - t0).count());
  }
  std::printf("calibrate(): %zu frequencies, %zu knobs, %d starts: %.3f s (fastest of %d); largest error %.4f %%\n",
              measured.size(), knobs.size(), CalibrationOptions{}.starts, fastest, repeats, fit.max_abs_error_pct);

  const auto t0 = clock::now();
  const CrossValidationResult cv = cross_validate(prior, measured, knobs);
  const double cv_wall = std::chrono::duration<double>(clock::now() - t0).count();
  std::printf("cross_validate(): %zu folds in %.3f s\n", cv.folds.size(), cv_wall);
  std::printf("  held-out error: median fold %.1f %%, worst %.1f %%, median of all %zu predictions %.1f %%\n",
              cv.median_fold_error_pct, cv.worst_abs_error_pct, 2 * cv.folds.size(), cv.median_abs_error_pct);
  for (std::size_t i = 0; i < measured.size(); ++i)
    std::printf("  %6.0f Hz: worst error when held out %.1f %%\n", measured[i], cv.worst_by_frequency_pct[i]);
  const bool met = cv.median_fold_error_pct <= kCrossValidationTargetPct;
  std::printf("  target: median fold within %.0f %% -> %s\n", kCrossValidationTargetPct, met ? "MET" : "MISSED");
  return 0;
}
