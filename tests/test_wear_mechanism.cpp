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
  CHECK(std::string(to_string(pitting.mechanism)) == "fatigue_pitting");
  CHECK(pitting.evidence.find("low band: n=15") != std::string::npos);

  auto abrasion = identify_wear_mechanism(history(0.0, 0.005), settings);
  CHECK(abrasion.mechanism == WearMechanism::abrasive_wear);
  CHECK(std::string(to_string(abrasion.mechanism)) == "abrasive_wear");

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

TEST_CASE("Mechanism tokens are the stored snake_case values, each once", "[dsp][wear_mechanism]") {
  std::vector<std::string> tokens;
  for (auto m : kAllWearMechanisms) tokens.emplace_back(to_string(m));
  CHECK(tokens == std::vector<std::string>{"none", "fatigue_pitting", "abrasive_wear", "both", "undetermined"});
  CHECK(is_wear(WearMechanism::fatigue_pitting));
  CHECK(is_wear(WearMechanism::abrasive_wear));
  CHECK(is_wear(WearMechanism::both));
  CHECK_FALSE(is_wear(WearMechanism::none));
  CHECK_FALSE(is_wear(WearMechanism::undetermined));
}

TEST_CASE("A band jump is reported only when the new band lasts and its ICS2 rises beyond the old scatter",
          "[dsp][wear_mechanism]") {
  SignalProcessingSettings settings;  // persistence 2 records, 3 sigma
  auto point = [](double cycles, double centre, double ics2) {
    WearHistoryPoint p{cycles, 0.01, 0.01, centre};
    p.selected_ics2 = ics2;
    return p;
  };
  // Established band at ~30 kHz: ICS2 0.010, 0.012, 0.011, 0.009: mean 0.0105, sample standard
  // deviation sqrt(0.00000500/3) = 0.0012910. The new band (8 kHz) holds 0.050 and 0.060 for two
  // records: mean 0.055 > 0.0105 + 3 x 0.0012910 = 0.014373 -> one jump at the first of them.
  std::vector<WearHistoryPoint> h{point(0, 30000, 0.010), point(1, 31000, 0.012), point(2, 29000, 0.011),
                                  point(3, 30500, 0.009), point(4, 8000, 0.050),  point(5, 8500, 0.060),
                                  point(6, 9000, 0.058)};
  auto v = identify_wear_mechanism(h, settings);
  REQUIRE(v.band_jumps.size() == 1);
  CHECK(v.band_jumps[0].cycles == 4);
  CHECK(v.band_jumps[0].from_hz == 30000);
  CHECK(v.band_jumps[0].to_hz == 8000);
  CHECK(v.band_jumps[0].from_ics2 == Approx(0.0105).epsilon(1e-12));
  CHECK(v.band_jumps[0].to_ics2 == Approx(0.055).epsilon(1e-12));
  CHECK(v.evidence.find("band jumps: 1") != std::string::npos);

  // The same move seen for one record only: not yet a jump (it may be an excursion).
  h.resize(5);
  CHECK(identify_wear_mechanism(h, settings).band_jumps.empty());

  // The new band lasts but its ICS2 is within the old band's scatter: the band is re-established
  // silently (a healthy gearbox's selected band wanders between equally noisy bands).
  std::vector<WearHistoryPoint> wander{point(0, 3559, 0.010), point(1, 3600, 0.012), point(2, 3500, 0.011),
                                       point(3, 8305, 0.012), point(4, 8200, 0.011), point(5, 3559, 0.010),
                                       point(6, 3600, 0.011), point(7, 8305, 0.013), point(8, 3559, 0.012)};
  CHECK(identify_wear_mechanism(wander, settings).band_jumps.empty());

  // Fewer than 3 records in the established band: no scatter to judge against, no jump.
  std::vector<WearHistoryPoint> young{point(0, 30000, 0.010), point(1, 30000, 0.011), point(2, 8000, 0.5),
                                      point(3, 8000, 0.5)};
  CHECK(identify_wear_mechanism(young, settings).band_jumps.empty());

  // Records without a selected band (NaN) are passed over.
  std::vector<WearHistoryPoint> gaps{point(0, 30000, 0.010), point(1, std::nan(""), 0.011), point(2, 30000, 0.011),
                                     point(3, 30000, 0.012), point(4, 30000, 0.009), point(5, 8000, 0.05),
                                     point(6, 8000, std::nan("")), point(7, 8000, 0.06)};
  v = identify_wear_mechanism(gaps, settings);
  REQUIRE(v.band_jumps.size() == 1);
  CHECK(v.band_jumps[0].cycles == 5);
}
