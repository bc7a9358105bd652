#include "gearwatch/dsp/wear_mechanism.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <vector>

#include "gearwatch/dsp/record_analyzer.hpp"

using namespace gearwatch::dsp;

TEST_CASE("Mann-Kendall and Spearman statistics match hand computation", "[dsp][wear_mechanism]") {
  // y = 1..5: S = 10, Var(S) = n(n-1)(2n+5)/18 = 16.667, Z = (S-1)/sqrt(Var) = 2.20454,
  // two-sided p = erfc(Z/sqrt 2) = 0.027486; Spearman rho = 1.
  const std::vector<double> x{1, 2, 3, 4, 5}, y{1, 2, 3, 4, 5};
  const auto t = trend_test(x, y, 0.05);
  CHECK(t.points == 5);
  CHECK(t.mann_kendall_s == 10);
  CHECK(t.mann_kendall_z == Approx(9.0 / std::sqrt(50.0 / 3.0)).epsilon(1e-12));
  CHECK(t.p_value == Approx(0.027486).epsilon(1e-4));
  CHECK(t.spearman_rho == Approx(1.0));
  CHECK(t.increasing);
  // With a tie, y = 1, 2, 2, 3: S = 5; tie term 2*1*9 = 18: Var = (4*3*13 - 18)/18 = 7.6667,
  // Z = 4 / sqrt(7.6667) = 1.44463, p = 0.14856; Spearman on ranks (1, 2.5, 2.5, 4) = 0.948683.
  const std::vector<double> x4{10, 20, 30, 40}, y4{1, 2, 2, 3};
  const auto tied = trend_test(x4, y4, 0.05);
  CHECK(tied.mann_kendall_s == 5);
  CHECK(tied.mann_kendall_z == Approx(4.0 / std::sqrt(23.0 / 3.0)).epsilon(1e-12));
  CHECK(tied.p_value == Approx(0.14856).epsilon(1e-3));
  CHECK(tied.spearman_rho == Approx(0.9486833).epsilon(1e-6));
  CHECK_FALSE(tied.increasing);
  // Points come sorted by x, and non-finite y are dropped: reversed input gives the same result.
  const std::vector<double> xr{5, 4, 3, std::nan(""), 2, 1};
  const std::vector<double> yr_nan{5, 4, 3, std::nan(""), 2, 1};
  CHECK(trend_test(xr, yr_nan, 0.05).mann_kendall_s == 10);
  // n = 4 cannot reach p < 0.05 (best p = 0.0895), n = 5 can.
  CHECK(minimum_points_for_trend(0.05) == 5);
  CHECK(minimum_points_for_trend(0.01) == 6);  // n = 6: Z = 14/5.323 = 2.630, p = 0.0085
}

TEST_CASE("Wear mechanism from synthetic ICS2 histories", "[dsp][wear_mechanism]") {
  SignalProcessingSettings settings;  // trend_significance 0.05
  std::mt19937_64 rng(31);
  std::normal_distribution<double> noise(0.0, 1.0);
  auto history = [&](double low_growth, double high_growth) {
    std::vector<WearHistoryPoint> h;
    for (int i = 0; i < 15; ++i) {
      const double cycles = 1e5 * i;
      h.push_back({cycles, 0.02 + low_growth * i + 0.002 * noise(rng), 0.03 + high_growth * i + 0.002 * noise(rng),
                   8000.0});
    }
    return h;
  };
  // Growth of 0.005 per record against noise 0.002: a strongly significant trend (Z > 4).
  auto pitting = identify_wear_mechanism(history(0.005, 0.0), settings);
  INFO(pitting.evidence);
  CHECK(pitting.mechanism == WearMechanism::fatigue_pitting);
  CHECK(pitting.low_band.increasing);
  CHECK_FALSE(pitting.high_band.increasing);
  CHECK(std::string(to_string(pitting.mechanism)) == "fatigue pitting");
  CHECK(pitting.evidence.find("low band: n=15") != std::string::npos);

  auto abrasion = identify_wear_mechanism(history(0.0, 0.005), settings);
  CHECK(abrasion.mechanism == WearMechanism::abrasive_wear);
  CHECK(std::string(to_string(abrasion.mechanism)) == "abrasive wear");

  auto both = identify_wear_mechanism(history(0.005, 0.005), settings);
  CHECK(both.mechanism == WearMechanism::both);

  // Neither band grows: pure noise. (With this seed neither test is significant; any one noise
  // series has a 5 % chance of a false trend by construction of the test.)
  auto neither = identify_wear_mechanism(history(0.0, 0.0), settings);
  INFO(neither.evidence);
  CHECK(neither.mechanism == WearMechanism::none);

  // A decreasing low band is reported but is not a wear signature.
  auto decreasing = identify_wear_mechanism(history(-0.005, 0.0), settings);
  CHECK(decreasing.low_band.decreasing);
  CHECK(decreasing.mechanism == WearMechanism::none);

  // Too short a history: undetermined, whatever the values.
  std::vector<WearHistoryPoint> short_history{{0, 0.01, 0.01, 8000}, {1, 0.02, 0.01, 8000}, {2, 0.03, 0.01, 8000},
                                              {3, 0.04, 0.01, 8000}};
  CHECK(identify_wear_mechanism(short_history, settings).mechanism == WearMechanism::undetermined);
  CHECK(identify_wear_mechanism({}, settings).mechanism == WearMechanism::undetermined);
}

TEST_CASE("Selected-band jumps are flagged at octave changes", "[dsp][wear_mechanism]") {
  SignalProcessingSettings settings;
  std::vector<WearHistoryPoint> h;
  const double centres[] = {30000, 31000, 29000, 8000, 8500, std::nan(""), 9000, 25000};
  for (int i = 0; i < 8; ++i) h.push_back({double(i), 0.01, 0.01, centres[i]});
  const auto v = identify_wear_mechanism(h, settings);
  REQUIRE(v.band_jumps.size() == 2);
  CHECK(v.band_jumps[0].cycles == 3);
  CHECK(v.band_jumps[0].from_hz == 29000);
  CHECK(v.band_jumps[0].to_hz == 8000);
  CHECK(v.band_jumps[1].cycles == 7);  // 9000 -> 25000 (NaN point skipped)
  CHECK(v.evidence.find("jump at 3 cycles 29000 Hz -> 8000 Hz") != std::string::npos);
}
