// Calibration of the twin to seed Table 5.5 and its leave-two-out cross-validation.
#include "gearwatch/twin/calibration.hpp"

#include <algorithm>
#include <cmath>

#include <catch2/catch.hpp>

#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/modal_analysis.hpp"

using namespace gearwatch::twin;

namespace {
void check_inside_priors(const GearboxParameters& p) {
  for (const auto& info : parameter_table()) {
    INFO(info.name);
    CHECK(p.*(info.field) >= info.prior_low * (1 - 1e-12));
    CHECK(p.*(info.field) <= info.prior_high * (1 + 1e-12));
  }
}
}  // namespace

TEST_CASE("Full calibration: all 8 Table 5.5 frequencies within 3 % inside the priors", "[twin]") {
  const auto& measured = table_5_5_frequencies();
  const CalibrationResult r =
      calibrate(GearboxParameters::prior(), measured, std::vector<bool>(measured.size(), true), default_calibration_knobs());
  REQUIRE(r.pairing.size() == 8);
  std::vector<int> used_modes;
  for (const auto& p : r.pairing) {
    INFO(p.measured_hz << " Hz paired with mode " << p.model_mode << " at " << p.model_hz << " Hz");
    CHECK(std::abs(p.error_pct) <= 3.0);   // target of the issue (the seed reached ±8 %)
    used_modes.push_back(p.model_mode);
  }
  std::sort(used_modes.begin(), used_modes.end());
  CHECK(std::adjacent_find(used_modes.begin(), used_modes.end()) == used_modes.end());  // distinct modes
  check_inside_priors(r.parameters);
  // The reported model frequencies are those of an independent modal analysis of the fitted set.
  const auto modes = modal_analysis(r.parameters);
  for (const auto& p : r.pairing)
    CHECK(modes[static_cast<std::size_t>(p.model_mode)].frequency_hz == Approx(p.model_hz).epsilon(1e-9));
}

TEST_CASE("The shipped default parameters are the calibrated set", "[twin]") {
  const GearboxParameters defaults;
  check_inside_priors(defaults);
  const auto modes = modal_analysis(defaults);
  // Each Table 5.5 frequency has a model mode within 3 %.
  for (double f : table_5_5_frequencies()) {
    double best = 1e9;
    for (const auto& m : modes) best = std::min(best, std::abs(m.frequency_hz - f) / f);
    INFO(f);
    CHECK(best <= 0.03);
  }
}

TEST_CASE("Leave-two-out cross-validation: 28 folds, fits and predictions consistent", "[twin]") {
  const auto& measured = table_5_5_frequencies();
  const CrossValidationResult cv = cross_validate(GearboxParameters::prior(), measured, default_calibration_knobs());
  REQUIRE(cv.folds.size() == 28);
  for (const auto& fold : cv.folds) {
    CHECK(fold.fit_max_abs_error_pct <= 3.0);  // the six fitted frequencies are always matched
    for (int k = 0; k < 2; ++k)
      CHECK(fold.error_pct[k] == Approx(100.0 * (fold.predicted_hz[k] - fold.measured_hz[k]) / fold.measured_hz[k]));
  }
  WARN("cross-validation: worst held-out " << cv.worst_abs_error_pct << " %, median fold " << cv.median_fold_error_pct
                                           << " %, median of all held-out " << cv.median_abs_error_pct << " %");
}

// The target (held-out within ±8 % in the median fold) is NOT met inside the documented
// priors: each low mode has its own coupling stiffness with a three-decade prior, so the other six
// frequencies do not constrain it (docs/twin.md). Kept as a visible, expected failure.
TEST_CASE("Cross-validation target: median fold held-out error within 8 %", "[twin][!mayfail]") {
  const CrossValidationResult cv =
      cross_validate(GearboxParameters::prior(), table_5_5_frequencies(), default_calibration_knobs());
  CHECK(cv.median_fold_error_pct <= 8.0);
}

TEST_CASE("Calibration rejects bad input", "[twin]") {
  const auto knobs = default_calibration_knobs();
  CHECK_THROWS_AS(calibrate(GearboxParameters::prior(), {}, {}, knobs), TwinParameterError);
  CHECK_THROWS_AS(calibrate(GearboxParameters::prior(), {100, -3}, {true, true}, knobs), TwinParameterError);
  CHECK_THROWS_AS(calibrate(GearboxParameters::prior(), {100, 200}, {false, false}, knobs), TwinParameterError);
}
