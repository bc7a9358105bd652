// The Table 5.5 calibration and its leave-two-out cross-validation: how long they take (one core)
// and what they reach. The held-out figure is reported against its target here rather than in a
// test, because inside the documented priors the target is missed (docs/twin.md).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "gearwatch/twin/calibration.hpp"
#include "gearwatch/twin/modal_gap.hpp"

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

  // The modal gap: grouped knobs inside their sourced priors, candidate structural effects adopted
  // by leave-two-out median fold error (docs/twin.md, "The modal gap").
  const auto g0 = clock::now();
  const ModalGapReport gap = table_5_5_modal_gap();
  const double gap_wall = std::chrono::duration<double>(clock::now() - g0).count();
  std::printf("table_5_5_modal_gap(): %zu options scored in %.1f s\n", gap.candidates.size(), gap_wall);
  std::printf("  grouped twin (%zu knobs): median fold %.1f %%, worst %.1f %%\n", gap.baseline_knobs.size(),
              gap.baseline.median_fold_error_pct, gap.baseline.worst_abs_error_pct);
  std::string adopted;
  for (const auto& a : gap.adopted) adopted += (adopted.empty() ? "" : ", ") + a;
  std::printf("  adopted: %s -> median fold %.1f %%, worst %.1f %%\n", adopted.empty() ? "none" : adopted.c_str(),
              gap.final_score.median_fold_error_pct, gap.final_score.worst_abs_error_pct);
  std::printf("  median fold per seed of the random starts (grouped -> adopted):");
  for (std::size_t i = 0; i < gap.seeds.size(); ++i)
    std::printf("%s %u: %.1f -> %.1f %%", i ? "," : "", gap.seeds[i], gap.baseline_fold_by_seed[i], gap.final_fold_by_seed[i]);
  std::printf("\n");
  for (const auto& m : gap.modes)
    std::printf("  %6.0f Hz: held out median %.1f %% -> %.1f %% (worst seed %.1f %% -> %.1f %%)  %s%s\n", m.measured_hz,
                m.median_error_before_pct, m.median_error_after_pct, m.worst_seed_median_before_pct,
                m.worst_seed_median_after_pct, to_string(m.status), m.effect.empty() ? "" : (" (" + m.effect + ")").c_str());
  std::printf("BENCH name=calibration_cv_median_fold figure=%.1f unit=pct target=%.0f cmp=le met=%d\n", cv.median_fold_error_pct,
              kCrossValidationTargetPct, met ? 1 : 0);
  // The figure is the worst seed's: the target holds only if it holds whichever seed the starts use.
  std::printf("BENCH name=modal_gap_median_fold figure=%.1f unit=pct target=%.0f cmp=le met=%d\n",
              *std::max_element(gap.final_fold_by_seed.begin(), gap.final_fold_by_seed.end()), gap.target_median_fold_pct,
              gap.target_met ? 1 : 0);
  return 0;
}
