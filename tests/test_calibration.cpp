// Calibration of the twin to thesis Table 5.5 and its leave-two-out cross-validation.
#include "gearwatch/twin/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>

#include <catch2/catch.hpp>

#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/modal_analysis.hpp"
#include "temp_dir.hpp"

namespace test_calibration {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::twin;

namespace {
CalibrationResult fresh_table_5_5_calibration() {
  const auto& measured = table_5_5_frequencies();
  return calibrate(GearboxParameters::prior(), measured, std::vector<bool>(measured.size(), true),
                   default_calibration_knobs());
}

/// The assignments `p.NAME = VALUE;` of a calibrated_values.cpp source.
std::map<std::string, double> parse_assignments(const std::string& source) {
  std::map<std::string, double> values;
  const std::regex assignment(R"(^  p\.(\w+) = ([-+0-9.eE]+);$)");
  std::istringstream in(source);
  std::string line;
  while (std::getline(in, line)) {
    std::smatch m;
    if (std::regex_match(line, m, assignment)) values[m[1]] = std::stod(m[2]);
  }
  return values;
}

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

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
    CHECK(std::abs(p.error_pct) <= 3.0);   // target (the thesis reached ±8 %)
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

TEST_CASE("The shipped defaults equal a fresh calibration to 1e-5", "[twin]") {
  // calibrated_values.cpp is written by `gearwatch twin calibrate` with 9 significant digits; the
  // fit is deterministic (fixed seed), so every parameter must come back. 1e-5 leaves room for a
  // different compiler's last-bit differences growing through the Levenberg–Marquardt steps.
  const CalibrationResult fresh = fresh_table_5_5_calibration();
  const GearboxParameters shipped;
  int moved = 0;
  for (const auto& info : parameter_table()) {
    INFO(info.name << ": shipped " << shipped.*(info.field) << ", fresh " << fresh.parameters.*(info.field));
    CHECK(shipped.*(info.field) == Approx(fresh.parameters.*(info.field)).epsilon(1e-5));
    if (fresh.parameters.*(info.field) != info.prior_value) ++moved;
  }
  // 23 knobs; five of them move four fields each (bearings x/y, shaft bending x/y, pedestal mass).
  CHECK(moved == 23 + 5 * 3);
}

TEST_CASE("calibrated_values_source lists every moved parameter and nothing else", "[twin]") {
  const CalibrationResult fresh = fresh_table_5_5_calibration();
  const std::string source = calibrated_values_source(fresh.parameters);
  const auto values = parse_assignments(source);
  CHECK(values.size() == 38);
  for (const auto& info : parameter_table()) {
    INFO(info.name);
    const auto it = values.find(info.name);
    if (fresh.parameters.*(info.field) == info.prior_value) {
      CHECK(it == values.end());
    } else {
      REQUIRE(it != values.end());
      // %.9g: half a unit in the 9th significant digit is at most 5e-9 relative.
      CHECK(it->second == Approx(fresh.parameters.*(info.field)).epsilon(5e-9));
    }
  }
  CHECK(source.find("void apply_calibrated_values(GearboxParameters& p) {") != std::string::npos);
  // The file in the tree parses to the shipped defaults.
  const auto shipped = parse_assignments(read_text(std::filesystem::path(GEARWATCH_SOURCE_DIR) / "core/src/twin/calibrated_values.cpp"));
  CHECK(shipped.size() == values.size());
  const GearboxParameters defaults;
  for (const auto& [name, value] : shipped) {
    INFO(name);
    REQUIRE(find_parameter(name) != nullptr);
    CHECK(defaults.*(find_parameter(name)->field) == value);
  }
}

TEST_CASE("gearwatch twin calibrate prints and writes the calibrated_values.cpp source", "[twin][cli]") {
  const gearwatch::testing::TempDir dir("twin-calibrate");
  const std::string expected = calibrated_values_source(fresh_table_5_5_calibration().parameters);
  const std::string binary = GEARWATCH_BINARY;
  const auto printed = dir / "printed.cpp";
  REQUIRE(std::system((binary + " twin calibrate >" + printed.string() + " 2>/dev/null").c_str()) == 0);
  CHECK(read_text(printed) == expected);  // same core code, same deterministic fit
  const auto written = dir / "written.cpp";
  const auto summary = dir / "summary.txt";
  REQUIRE(std::system((binary + " twin calibrate --out " + written.string() + " >" + summary.string() + " 2>&1").c_str()) == 0);
  CHECK(read_text(written) == expected);
  CHECK(read_text(summary).rfind("wrote " + written.string(), 0) == 0);
  CHECK(std::system((binary + " twin calibrate --out " + (dir / "missing/dir/x.cpp").string() + " >/dev/null 2>&1").c_str()) != 0);
}

TEST_CASE("Leave-two-out cross-validation: 28 folds equal direct recomputation", "[twin]") {
  // The figure itself (median fold 82 %, far outside the ±8 % target) is reported by
  // `gearwatch twin modes` and bench_calibration; here the deterministic computation is checked
  // against fitting each fold directly.
  const auto& measured = table_5_5_frequencies();
  const auto knobs = default_calibration_knobs();
  const CrossValidationResult cv = cross_validate(GearboxParameters::prior(), measured, knobs);
  REQUIRE(cv.folds.size() == 28);
  std::vector<double> fold_errors, all_errors;
  std::vector<double> worst_by_frequency(measured.size(), 0.0);
  std::size_t f = 0;
  for (std::size_t a = 0; a < measured.size(); ++a)
    for (std::size_t b = a + 1; b < measured.size(); ++b, ++f) {
      std::vector<bool> use(measured.size(), true);
      use[a] = use[b] = false;
      const CalibrationResult fit = calibrate(GearboxParameters::prior(), measured, use, knobs);
      const CrossValidationFold& fold = cv.folds[f];
      INFO("fold " << f << ": held out " << measured[a] << " and " << measured[b] << " Hz");
      CHECK(fold.held_out[0] == static_cast<int>(a));
      CHECK(fold.held_out[1] == static_cast<int>(b));
      CHECK(fold.fit_max_abs_error_pct == fit.max_abs_error_pct);
      CHECK(fold.fit_max_abs_error_pct <= 3.0);  // the six fitted frequencies are always matched
      for (int k = 0; k < 2; ++k) {
        const std::size_t i = k == 0 ? a : b;
        const ModePairing& pair = fit.pairing[i];
        CHECK_FALSE(pair.used_in_fit);
        CHECK(fold.measured_hz[k] == measured[i]);
        CHECK(fold.predicted_hz[k] == pair.model_hz);
        CHECK(fold.error_pct[k] == Approx(100.0 * (pair.model_hz - measured[i]) / measured[i]).epsilon(1e-12));
        all_errors.push_back(std::abs(fold.error_pct[k]));
        worst_by_frequency[i] = std::max(worst_by_frequency[i], std::abs(fold.error_pct[k]));
      }
      fold_errors.push_back(std::max(std::abs(fold.error_pct[0]), std::abs(fold.error_pct[1])));
    }
  std::sort(fold_errors.begin(), fold_errors.end());
  std::sort(all_errors.begin(), all_errors.end());
  CHECK(cv.median_fold_error_pct == 0.5 * (fold_errors[13] + fold_errors[14]));  // 28 folds
  CHECK(cv.median_abs_error_pct == 0.5 * (all_errors[27] + all_errors[28]));     // 56 predictions
  CHECK(cv.worst_abs_error_pct == all_errors.back());
  CHECK(cv.worst_by_frequency_pct == worst_by_frequency);
}

TEST_CASE("Calibration rejects bad input", "[twin]") {
  const auto knobs = default_calibration_knobs();
  CHECK_THROWS_AS(calibrate(GearboxParameters::prior(), {}, {}, knobs), TwinParameterError);
  CHECK_THROWS_AS(calibrate(GearboxParameters::prior(), {100, -3}, {true, true}, knobs), TwinParameterError);
  CHECK_THROWS_AS(calibrate(GearboxParameters::prior(), {100, 200}, {false, false}, knobs), TwinParameterError);
}

}  // namespace test_calibration
