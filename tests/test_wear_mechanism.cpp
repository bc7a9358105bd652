#include "gearwatch/dsp/wear_mechanism.hpp"

#include <catch2/catch.hpp>
#include <boost/math/distributions/chi_squared.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <numeric>
#include <random>
#include <vector>

#include "gearwatch/dsp/record_analyzer.hpp"

namespace test_wear_wander {  // shared by the two namespaces below (unity build: a name of its own)

/// A healthy history for the verdict: low band 0.02 + s·u_k, u AR(1) of unit variance (φ), high
/// band constant (tied: it never rises), a record every 1e5 cycles, grown one record at a time.
class WanderingHistory {
 public:
  WanderingHistory(double s, double phi, std::mt19937_64& rng, std::normal_distribution<double>& gauss)
      : s_(s), phi_(phi), rng_(rng), gauss_(gauss), u_(gauss(rng)) {}
  void grow() {
    points_.push_back({1e5 * static_cast<double>(points_.size()), 0.02 + s_ * u_, 0.03, 8000.0});
    cycles_.push_back(points_.back().cycles), low_.push_back(points_.back().ics2_low);
    u_ = phi_ * u_ + std::sqrt(1.0 - phi_ * phi_) * gauss_(rng_);
  }
  /// The verdict names wear at the newest record. It can only once the low band's evidence
  /// reaches `bar`, so it is asked only then (same answers, a fraction of the cost).
  bool raised(double bar, const gearwatch::dsp::SignalProcessingSettings& settings) const {
    return gearwatch::dsp::rising_change_evidence(cycles_, low_) >= bar &&
           gearwatch::dsp::is_wear(gearwatch::dsp::identify_wear_mechanism(points_, settings).mechanism);
  }

 private:
  double s_, phi_;
  std::mt19937_64& rng_;
  std::normal_distribution<double>& gauss_;
  double u_;
  std::vector<gearwatch::dsp::WearHistoryPoint> points_;
  std::vector<double> cycles_, low_;
};

}  // namespace test_wear_wander

namespace test_wear_mechanism {  // this file's own: the test files compile together (unity build)

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

// The evidence of a tied baseline of n points followed by k strictly rising points, computed
// directly from the closed form (not the library's running sums): point j (1-based) has D_j = 0
// in the baseline and j - 1 after it; M = 1/N (change points not reached) + sum_b 1/(b(b+1))
// sum_l w_l prod_{j=b+1..N} exp(l D_j) j sinh(l) / sinh(j l), N = n + k.
struct WmBet {
  double lambda, weight;
};
constexpr WmBet kWmChangeBets[] = {{0.35, 0.25}, {1.0, 0.25}, {3.0, 0.5}};
// For comparison: a single trend martingale from the first point (b = 1 only), bets 0.1 ... 3.
constexpr WmBet kWmTrendBets[] = {{0.1, 0.1}, {0.2, 0.1}, {0.35, 0.1}, {0.6, 0.1}, {1.0, 0.1}, {3.0, 0.5}};

template <typename Bets>
double wm_closed_form_evidence(int n, int k, bool post_tied, const Bets& bets, bool change_points) {
  const int total = n + k;
  auto d = [&](int j) { return j <= n ? 0.0 : post_tied ? static_cast<double>(n) : static_cast<double>(j - 1); };
  double m = change_points ? 1.0 / total : 0.0;
  for (int b = 1; b < total; ++b) {
    const double prior = change_points ? 1.0 / (static_cast<double>(b) * (b + 1)) : (b == 1 ? 1.0 : 0.0);
    for (const auto& bet : bets) {
      double product = 1.0;
      for (int j = b + 1; j <= total; ++j)
        product *= std::exp(bet.lambda * d(j)) * j * std::sinh(bet.lambda) / std::sinh(j * bet.lambda);
      m += prior * bet.weight * product;
    }
  }
  return m;
}

template <typename Bets>
int wm_closed_form_delay(int n, bool post_tied, const Bets& bets, bool change_points) {
  for (int k = 1; k <= 60; ++k)
    if (wm_closed_form_evidence(n, k, post_tied, bets, change_points) >= 40.0) return k;
  return -1;
}

TEST_CASE("Rising-change evidence is a test martingale: mean 1 over every ordering - Ville's bound holds",
          "[dsp][wear_mechanism]") {
  // Under no change every ordering of n distinct values is equally likely, so the mean of the
  // e-value over all n! orderings is exactly 1 at every n (each change point's martingale has mean
  // 1 and the prior weights sum to 1), and the orderings whose evidence ever reaches 1/a (at any
  // prefix) make up at most a (Ville's inequality). n = 7: 5040 orderings.
  constexpr int n = 7;
  std::vector<double> y(n), x(n);
  for (int i = 0; i < n; ++i) y[static_cast<std::size_t>(i)] = i, x[static_cast<std::size_t>(i)] = i;
  double sum_last = 0, sum_mid = 0;
  int orderings = 0, ever_above_40 = 0;
  do {
    ++orderings;
    sum_last += rising_change_evidence(x, y);
    sum_mid += rising_change_evidence(std::span<const double>(x).first(4), std::span<const double>(y).first(4));
    bool above = false;
    for (std::size_t k = 1; k <= y.size(); ++k)
      above = above || rising_change_evidence(std::span<const double>(x).first(k), std::span<const double>(y).first(k)) >= 40.0;
    ever_above_40 += above;
  } while (std::next_permutation(y.begin(), y.end()));
  CHECK(orderings == 5040);
  // Prefixes of length 4 repeat each 4-ordering 210 times: their mean is 1 as well.
  CHECK(sum_last / orderings == Approx(1.0).epsilon(1e-12));
  CHECK(sum_mid / orderings == Approx(1.0).epsilon(1e-12));
  CHECK(static_cast<double>(ever_above_40) / orderings <= 1.0 / 40.0);
  // The prior over change points sums to 1: 1 - 1/(m+1) over the first m.
  double prior_sum = 0.0;
  for (std::size_t b = 1; b <= 999; ++b) prior_sum += change_point_prior(b);
  CHECK(prior_sum == Approx(1.0 - 1.0 / 1000.0).epsilon(1e-12));
  CHECK(change_point_prior(0) == 0.0);
  CHECK(change_point_prior(3) == Approx(1.0 / 12.0).epsilon(1e-15));
  // A perfectly rising run from the first point: the closed form is 48.5 at 5 points, 10.6 at 4, so
  // the verdict can come with the 5th record, as with Mann-Kendall at 0.05.
  const std::vector<double> x5{1, 2, 3, 4, 5};
  CHECK(rising_change_evidence(x5, x5) == Approx(wm_closed_form_evidence(1, 4, false, kWmChangeBets, true)).epsilon(1e-10));
  CHECK(wm_closed_form_evidence(1, 4, false, kWmChangeBets, true) == Approx(48.5).margin(0.05));
  CHECK(wm_closed_form_evidence(1, 3, false, kWmChangeBets, true) == Approx(10.6).margin(0.05));
  CHECK(minimum_points_for_evidence(0.05) == 5);
  CHECK(rising_evidence_threshold(0.05) == 40.0);
}

TEST_CASE("A ramp after a flat baseline of any length is named within 4 rising points - closed form",
          "[dsp][wear_mechanism]") {
  // The question behind the late pitting calls: after a flat baseline of n records, how many
  // strictly rising records does the evidence need to reach 2/alpha = 40? The closed form above
  // answers it for the change-point mixture and for the single trend martingale it replaces.
  for (int n = 1; n <= 100; ++n) {
    const int k = wm_closed_form_delay(n, false, kWmChangeBets, true);
    INFO("baseline " << n);
    CHECK(static_cast<int>(post_change_points_for_evidence(static_cast<std::size_t>(n), 0.05)) == k);
    // The library on the same series agrees with the closed form to rounding.
    std::vector<double> y(static_cast<std::size_t>(n), 0.0);
    for (int j = 1; j <= k; ++j) y.push_back(j);
    std::vector<double> x(y.size());
    std::iota(x.begin(), x.end(), 0.0);
    CHECK(rising_change_evidence(x, y) == Approx(wm_closed_form_evidence(n, k, false, kWmChangeBets, true)).epsilon(1e-9));
    // 4 points up to a baseline of 51, then 3 (39.5 and 40.2 at the 3rd point after 51 and 52): a
    // longer baseline costs ln(b(b+1)) in the prior but makes each new maximum rarer (1 / j), which wins.
    CHECK(k == (n <= 51 ? 4 : 3));
  }
  // A single trend martingale from the first point loses its bets on the
  // baseline's noise: with the same tied baseline it needs 4, 5, 6, 8, 11 rising points after
  // 2, 3, 8, 20, 30 records.
  CHECK(wm_closed_form_delay(2, false, kWmTrendBets, false) == 4);
  CHECK(wm_closed_form_delay(3, false, kWmTrendBets, false) == 5);
  CHECK(wm_closed_form_delay(8, false, kWmTrendBets, false) == 6);
  CHECK(wm_closed_form_delay(20, false, kWmTrendBets, false) == 8);
  CHECK(wm_closed_form_delay(30, false, kWmTrendBets, false) == 11);
}

TEST_CASE("A step whose points come in any order is named only as its ranks allow - exact enumeration",
          "[dsp][wear_mechanism]") {
  // A tied baseline of 3 points, then 7 points all above it in each of the 7! orders (a step with
  // noise: under a pure step every order is equally likely). Ranks see a step alone only through
  // the post-change points standing above the baseline: a likelihood ratio of at most C(3 + k, k)
  // (120 at k = 7) against the change point's prior 1/12. So most orders are not named within 7
  // points; the orders that rise are.
  constexpr int baseline = 3, post = 7;
  std::vector<int> order(post);
  std::iota(order.begin(), order.end(), 1);
  std::array<int, post + 1> named_at{};
  int orders = 0;
  do {
    ++orders;
    std::vector<double> y(baseline, 0.0), x;
    for (int k = 1; k <= post; ++k) {
      y.push_back(order[static_cast<std::size_t>(k - 1)]);
      x.resize(y.size());
      std::iota(x.begin(), x.end(), 0.0);
      if (rising_change_evidence(x, y) >= 40.0) {
        ++named_at[static_cast<std::size_t>(k)];
        break;
      }
    }
  } while (std::next_permutation(order.begin(), order.end()));
  CHECK(orders == 5040);
  // Reference counts from an independent implementation of the same mixture (Python, direct
  // sums over change points): named at the 4th point in 210 orders (every order whose first 4
  // points rise: 7!/4! = 210), at the 5th in 126, the 6th in 56, the 7th in 85.
  CHECK(named_at[1] + named_at[2] + named_at[3] == 0);
  CHECK(named_at[4] == 210);
  CHECK(named_at[5] == 126);
  CHECK(named_at[6] == 56);
  CHECK(named_at[7] == 85);
  // A step of tied points (no order at all) is never named: D_j stays at 3 while j grows.
  for (int k = 1; k <= 40; ++k) CHECK(wm_closed_form_evidence(baseline, k, true, kWmChangeBets, true) < 40.0);
}

TEST_CASE("A stationary history raises no wear verdict more often than the significance, however long",
          "[dsp][wear_mechanism]") {
  // The daemon re-decides at every record on the history so far. Mann-Kendall at a fixed 5 % level,
  // re-tested each record, finds a "trend" in a good share of pure-noise histories; the sequential
  // evidence keeps the chance that a history ever raises a wear verdict (either band) below
  // alpha = 0.05 at every length (Ville's bound: alpha/2 per band). 300 histories of 120 records,
  // three noise laws (the ranks make the evidence distribution-free). Materiality is off here
  // (wear_min_band_share 0): this is the bound on the significance alone; with the default floor
  // none of these histories (scatter 0.002) could rise by 0.05.
  SignalProcessingSettings settings;
  settings.wear_min_band_share = 0.0;
  constexpr int histories = 300, length = 120;
  int raised_sequential = 0, raised_mann_kendall = 0, raised_sequential_by_40 = 0;
  std::mt19937_64 rng(2026);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::exponential_distribution<double> expo(1.0);
  std::student_t_distribution<double> heavy(2.0);
  for (int h = 0; h < histories; ++h) {
    std::vector<WearHistoryPoint> points;
    std::vector<double> cycles, low, high;
    bool seq = false, seq40 = false, mk = false;
    for (int k = 0; k < length; ++k) {
      auto draw = [&]() { return h % 3 == 0 ? gauss(rng) : h % 3 == 1 ? expo(rng) : heavy(rng); };
      WearHistoryPoint p{1e5 * k, 0.02 + 0.002 * draw(), 0.03 + 0.002 * draw(), 8000.0};
      points.push_back(p);
      cycles.push_back(p.cycles), low.push_back(p.ics2_low), high.push_back(p.ics2_high);
      const bool wear = is_wear(identify_wear_mechanism(points, settings).mechanism);
      seq = seq || wear;
      seq40 = seq40 || (wear && k < 40);
      mk = mk || trend_test(cycles, low, 0.05).increasing || trend_test(cycles, high, 0.05).increasing;
    }
    raised_sequential += seq;
    raised_sequential_by_40 += seq40;
    raised_mann_kendall += mk;
  }
  const double rate = static_cast<double>(raised_sequential) / histories;
  const double rate_mk = static_cast<double>(raised_mann_kendall) / histories;
  INFO("sequential: " << raised_sequential << " / " << histories << " (" << raised_sequential_by_40
                      << " by record 40); Mann-Kendall re-tested each record: " << raised_mann_kendall);
  // Bound 0.05; the binomial 3-sigma margin at 300 histories is 0.038. Measured: 8 / 300 = 0.027,
  // all of them within the first 40 records.
  CHECK(rate <= 0.05 + 3 * std::sqrt(0.05 * 0.95 / histories));
  // The defect the sequential decision removes: 152 / 300 = 0.51 of the same histories.
  CHECK(rate_mk > 0.25);
}

// Fraction of `histories` sequences of `length` points (AR(1) with coefficient phi, phi = 0 iid)
// whose rising_change_evidence ever reaches 40, and the fraction whose first 3 points rise.
struct WmNullRun {
  double ever_40 = 0.0, first_three_rising = 0.0;
};
WmNullRun wm_null_run(double phi, int histories, int length, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  int raised = 0, rising3 = 0;
  for (int h = 0; h < histories; ++h) {
    std::vector<double> x, y;
    double v = gauss(rng) / std::sqrt(1.0 - phi * phi);
    bool ever = false;
    for (int k = 0; k < length && !ever; ++k) {
      x.push_back(k), y.push_back(v);
      v = phi * v + gauss(rng);
      ever = rising_change_evidence(x, y) >= 40.0;
      if (k == 2) rising3 += y[0] < y[1] && y[1] < y[2];
    }
    raised += ever;
  }
  return {static_cast<double>(raised) / histories, static_cast<double>(rising3) / histories};
}

TEST_CASE("False alarms of the change evidence on iid noise stay under Ville's bound - AR(1) noise is outside it",
          "[dsp][wear_mechanism]") {
  // Ville: for an exchangeable history P(M ever >= 40) <= 1/40 = 0.025 per band, at any length.
  // 2000 Gaussian sequences of 100 records; the binomial 3-sigma margin is 0.0105.
  const WmNullRun iid = wm_null_run(0.0, 2000, 100, 91);
  const WmNullRun ar = wm_null_run(0.5, 2000, 100, 92);
  INFO("iid: " << iid.ever_40 << " AR(1) 0.5: " << ar.ever_40);
  CHECK(iid.ever_40 <= 1.0 / 40.0 + 3 * std::sqrt(0.025 * 0.975 / 2000));
  // The guarantee rests on exchangeability. AR(1) noise breaks it: three successive points rise with
  // probability 1/4 + asin(rho)/(2 pi), rho = corr(y2 - y1, y3 - y2) = -(1 - phi)/2 (orthant
  // probability of two correlated Gaussians): 1/6 for iid, 0.2098 for phi = 0.5.
  const double rho = -(1.0 - 0.5) / 2.0;
  const double p3 = 0.25 + std::asin(rho) / (2 * std::numbers::pi);
  CHECK(p3 == Approx(0.2098).margin(1e-4));
  CHECK(iid.first_three_rising == Approx(1.0 / 6.0).margin(3 * std::sqrt(p3 * (1 - p3) / 2000)));
  CHECK(ar.first_three_rising == Approx(p3).margin(3 * std::sqrt(p3 * (1 - p3) / 2000)));
}

TEST_CASE("AR(1) wander of a healthy band's ICS2 below a sixth of the materiality floor stays under Ville's bound",
          "[dsp][wear_mechanism]") {
  // Sampling errors of disjoint records are independent, so a correlated history is the gearbox's own
  // ICS2 wandering: a record's sampling SD cannot see it. The ranks alone then false-alarm beyond
  // 1/40 (the test above); what bounds the verdict is the materiality floor measured against the
  // wander. The full verdict on a low band 0.02 + s u_k, u AR(1) of unit variance, s = floor / 6,
  // high band constant (tied: it never rises). The verdict can only name wear once the low band's
  // evidence reaches 2/alpha, so it is asked only then (same answers, a fraction of the cost). The
  // configured floor alone (no measured baseline): the assumption it rests on, as docs/dsp.md states it.
  SignalProcessingSettings settings;
  settings.wear_baseline_records = 0;
  const double floor = material_ics2_rise(settings);
  const double bar = rising_evidence_threshold(settings.trend_significance);
  constexpr int histories = 2000, length = 100;
  auto false_alarms = [&](double phi, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> gauss(0.0, 1.0);
    const double s = floor / 6.0;
    int raised = 0;
    for (int h = 0; h < histories; ++h) {
      test_wear_wander::WanderingHistory history(s, phi, rng, gauss);
      bool ever = false;
      for (int k = 0; k < length && !ever; ++k) {
        history.grow();
        ever = history.raised(bar, settings);
      }
      raised += ever;
    }
    return static_cast<double>(raised) / histories;
  };
  const double margin = 3 * std::sqrt(0.025 * 0.975 / histories);  // binomial 3-sigma at the bound
  const double phi_05 = false_alarms(0.5, 4660), phi_08 = false_alarms(0.8, 4661);
  INFO("AR(1) 0.5: " << phi_05 << ", AR(1) 0.8: " << phi_08 << " (bound 0.025 + " << margin << ")");
  CHECK(phi_05 <= 1.0 / 40.0 + margin);
  CHECK(phi_08 <= 1.0 / 40.0 + margin);
}

TEST_CASE("Flat then rising: the sequential verdict comes within 3 records of the first rise",
          "[dsp][wear_mechanism]") {
  // The rig's lubricated campaign: one unpitted record, then the low band rises record by record.
  // The verdict can come at the 4th rising record (5 points), as Mann-Kendall at 0.05 would.
  SignalProcessingSettings settings;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<WearHistoryPoint> h{{0, 0.02 + 0.001 * noise(rng), 0.03 + 0.001 * noise(rng), 8000.0}};
    int first_wear = -1;
    for (int k = 1; k < 10 && first_wear < 0; ++k) {
      h.push_back({1e5 * k, 0.05 + 0.02 * k + 0.002 * noise(rng), 0.03 + 0.001 * noise(rng), 8000.0});
      const auto v = identify_wear_mechanism(h, settings);
      if (is_wear(v.mechanism)) {
        first_wear = k;
        CHECK(v.mechanism == WearMechanism::fatigue_pitting);
      }
    }
    CHECK(first_wear == 4);  // first rise at record 1, verdict at record 4: 3 records later
  }
}

TEST_CASE("defects #7: the materiality floor is a quarter of the ICS2 of half-depth AM noise",
          "[dsp][wear_mechanism]") {
  // Squared envelope of (1 + a cos) x noise: mean 1 + a²/2, lines a and a²/4 (closed form).
  CHECK(am_noise_ics2(0.5, 3) == Approx((0.25 + 0.0625 * 0.0625) / (1.125 * 1.125)).epsilon(1e-15));
  CHECK(am_noise_ics2(0.5, 3) == Approx(0.2006172839506173).epsilon(1e-12));
  CHECK(am_noise_ics2(0.5, 1) == Approx(0.25 / (1.125 * 1.125)).epsilon(1e-15));
  CHECK(am_noise_ics2(1.0, 2) == Approx((1.0 + 1.0 / 16.0) / 2.25).epsilon(1e-15));
  SignalProcessingSettings settings;  // wear_min_band_share 1/2, H = 3
  CHECK(material_ics2_rise(settings) == Approx(0.25 * 0.2006172839506173).epsilon(1e-12));
  settings.wear_min_band_share = 0.0;
  CHECK(material_ics2_rise(settings) == 0.0);
}

TEST_CASE("defects #7: the dry campaign's low band (ICS2 5e-5 -> 3e-3: significant but immaterial) is not a rise",
          "[dsp][wear_mechanism]") {
  // The histories: 8 records, both bands rising at every record. The high band goes from
  // 0.01 to 0.21 (abrasion fills it); the low band from 5e-5 to 3e-3, a geometric rise that is
  // perfectly monotonic (so its rank evidence is as large as the high band's) but reaches a share
  // of the band of only sqrt(3e-3 / 0.2) = 12 % for a wear vibration of ICS2 0.2.
  SignalProcessingSettings settings;
  std::vector<WearHistoryPoint> h;
  for (int k = 0; k < 8; ++k) {
    const double low = 5e-5 * std::pow(3e-3 / 5e-5, k / 7.0);
    const double high = 0.01 + 0.2 * k / 7.0;
    h.push_back({5000.0 * k, low, high, 30000.0});
  }
  const auto v = identify_wear_mechanism(h, settings);
  INFO(v.evidence);
  CHECK(v.low_band.significant_rise);       // evidence as before: the ranks rise at every record
  CHECK(v.low_band.rising_evidence == Approx(v.high_band.rising_evidence).epsilon(1e-12));
  CHECK(v.low_band.rise == Approx(3e-3 - 5e-5).epsilon(1e-9));
  CHECK_FALSE(v.low_band.material);         // 2.95e-3 < 0.0502
  CHECK_FALSE(v.low_band.increasing);
  CHECK(v.high_band.increasing);            // rise 0.2 >= 0.0502
  CHECK(v.high_band.rise == Approx(0.2).epsilon(1e-9));
  CHECK(v.mechanism == WearMechanism::abrasive_wear);  // before: both
  CHECK(v.evidence.find("immaterial") != std::string::npos);
  // At every prefix the verdict never names the low band: abrasive_wear once significant, never both.
  for (std::size_t n = 1; n <= h.size(); ++n) {
    const auto p = identify_wear_mechanism(std::span<const WearHistoryPoint>(h).first(n), settings);
    INFO("records " << n << ": " << p.evidence);
    CHECK(p.mechanism != WearMechanism::both);
    CHECK(p.mechanism != WearMechanism::fatigue_pitting);
  }
}

TEST_CASE("defects #7: a material rise (ICS2 0.05 -> 0.3) is named as soon as it is significant",
          "[dsp][wear_mechanism]") {
  SignalProcessingSettings settings;
  std::vector<WearHistoryPoint> h;
  int first_verdict = -1;
  for (int k = 0; k < 8; ++k) {
    h.push_back({1e5 * k, 0.05 + 0.25 * k / 7.0, 0.01, 30000.0});
    const auto v = identify_wear_mechanism(h, settings);
    if (first_verdict < 0 && is_wear(v.mechanism)) {
      first_verdict = k;
      CHECK(v.mechanism == WearMechanism::fatigue_pitting);
      CHECK(v.low_band.material);
    }
  }
  // A perfectly rising run reaches the evidence bar at 5 points (minimum_points_for_evidence), and
  // by then the band has risen by 4 x 0.25 / 7 = 0.143 >= 0.0502: materiality costs no record.
  CHECK(first_verdict == static_cast<int>(minimum_points_for_evidence(settings.trend_significance)) - 1);
  // Both bands rising materially: both.
  for (auto& p : h) p.ics2_high = p.ics2_low;
  CHECK(identify_wear_mechanism(h, settings).mechanism == WearMechanism::both);
  // A slow creep on a band that already carries modulation (0.10 -> 0.14, rise 0.04 < 0.0502) is
  // significant but not material.
  std::vector<WearHistoryPoint> creep;
  for (int k = 0; k < 10; ++k) creep.push_back({1e5 * k, 0.10 + 0.04 * k / 9.0, 0.01, 30000.0});
  const auto c = identify_wear_mechanism(creep, settings);
  CHECK(c.low_band.significant_rise);
  CHECK(c.low_band.rise == Approx(0.04).epsilon(1e-9));
  CHECK(c.mechanism == WearMechanism::none);
  // With wear_min_band_share = 0 significance alone decides again (the earlier behaviour).
  settings.wear_min_band_share = 0.0;
  CHECK(identify_wear_mechanism(creep, settings).mechanism == WearMechanism::fatigue_pitting);
}

TEST_CASE("defects #7: the floor against ICS2's estimation noise and the share law by direct Monte Carlo",
          "[dsp][wear_mechanism]") {
  // A band of N = bandwidth x duration independent complex samples: 2-13 kHz over a 2 s record at
  // 10 rev/s is N = 22000 samples spanning 20 revolutions, the mesh order 19 at SES bins 380 h.
  constexpr std::size_t n = 22000;
  constexpr double revolutions = 20.0;
  FftPlanCache plans;
  SquaredEnvelopeAnalyzer envelope(plans);
  const Ics2Parameters p;  // order 19, H = 3, +-3 bins
  std::mt19937_64 rng(1977);
  std::normal_distribution<double> gauss(0.0, std::sqrt(0.5));
  std::vector<Complex> c(n);
  auto noise = [&] { return Complex(gauss(rng), gauss(rng)); };
  // Stationary noise: E|SES[k]|² / SES[0]² = (N - k) / N², independent exponentials; the largest of
  // 2 tol + 1 = 7 has mean H_7 = 1 + 1/2 + ... + 1/7 and variance 1 + 1/4 + ... + 1/49.
  double h7 = 0, h7_2 = 0;
  for (int i = 1; i <= 7; ++i) h7 += 1.0 / i, h7_2 += 1.0 / (i * i);
  double expected = 0, variance = 0;
  for (int h = 1; h <= 3; ++h) {
    const double unit = (n - 380.0 * h) / (static_cast<double>(n) * n);
    expected += h7 * unit;
    variance += h7_2 * unit * unit;
  }
  constexpr int trials = 200;
  double sum = 0, largest = 0;
  for (int t = 0; t < trials; ++t) {
    for (auto& v : c) v = noise();
    const double ics2 = envelope.complex_ics2(c, revolutions, p).value;
    sum += ics2;
    largest = std::max(largest, ics2);
  }
  const double mean = sum / trials;
  INFO("noise: mean " << mean << " (closed form " << expected << "), largest of " << trials << " " << largest);
  CHECK(std::abs(mean - expected) < 4.0 * std::sqrt(variance / trials));
  SignalProcessingSettings settings;
  // The floor is two orders of magnitude above what noise alone reads.
  CHECK(material_ics2_rise(settings) > 100.0 * expected);
  CHECK(material_ics2_rise(settings) > 20.0 * largest);
  // Share law: noise modulated at depth 1/2 by the mesh, holding half of the band's power beside
  // independent stationary noise, reads a quarter of the modulated noise's own ICS2 (+ the noise
  // term above, scaled by the modulation's fourth moment): the floor.
  const double depth = 0.5, mod_power = 1.0 + depth * depth / 2.0;
  double share_sum = 0;
  constexpr int share_trials = 40;
  for (int t = 0; t < share_trials; ++t) {
    for (std::size_t i = 0; i < n; ++i) {
      const double m = 1.0 + depth * std::cos(2.0 * std::numbers::pi * 19.0 * revolutions * static_cast<double>(i) / n);
      c[i] = m * noise() + std::sqrt(mod_power) * noise();
    }
    share_sum += envelope.complex_ics2(c, revolutions, p).value;
  }
  const double share_mean = share_sum / share_trials;
  INFO("half-share band: mean ICS2 " << share_mean << ", floor " << material_ics2_rise(settings));
  CHECK(share_mean == Approx(material_ics2_rise(settings) + expected).epsilon(0.03));
}

TEST_CASE("defects #7: wear_min_band_share outside [0 1] is refused naming the setting", "[dsp][wear_mechanism]") {
  const gearwatch::GearboxSpec rig;
  SignalProcessingSettings s;
  CHECK_NOTHROW(s.validate(rig));  // default 0.5
  for (double bad : {-0.1, 1.5, std::nan("")}) {
    s.wear_min_band_share = bad;
    CHECK_THROWS_WITH(s.validate(rig), Catch::Contains("wear_min_band_share"));
  }
  for (double good : {0.0, 1.0}) {
    s.wear_min_band_share = good;
    CHECK_NOTHROW(s.validate(rig));
  }
}

}  // namespace test_wear_mechanism

namespace test_wear_floor {

using namespace gearwatch::dsp;

TEST_CASE("issue 36: the measured floor from a known baseline equals its formula - closed form", "[dsp][wear_mechanism]") {
  // Independent AR(1) law by dense matrices: M = I - H, R_ij = phi^|i-j|; at phi 0, tr(MR) = n - 2.
  auto dense_law = [](std::size_t n, double phi) {
    std::vector<double> m(n * n), r(n * n), mr(n * n, 0.0);
    const double nn = static_cast<double>(n), mk = (nn - 1) / 2;
    double skk = 0.0;
    for (std::size_t k = 0; k < n; ++k) skk += (k - mk) * (k - mk);
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = 0; j < n; ++j) {
        m[i * n + j] = (i == j) - 1.0 / nn - (i - mk) * (j - mk) / skk;
        r[i * n + j] = std::pow(phi, std::abs(static_cast<double>(i) - static_cast<double>(j)));
      }
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t k = 0; k < n; ++k)
        for (std::size_t j = 0; j < n; ++j) mr[i * n + j] += m[i * n + k] * r[k * n + j];
    double t1 = 0.0, t2 = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      t1 += mr[i * n + i];
      for (std::size_t j = 0; j < n; ++j) t2 += mr[i * n + j] * mr[j * n + i];
    }
    return std::pair{t1, t1 * t1 / t2};
  };
  CHECK(ar1_line_residual_law(20, 0.0).mean_factor == Approx(18.0).epsilon(1e-12));
  CHECK(ar1_line_residual_law(20, 0.0).dof == Approx(18.0).epsilon(1e-12));
  for (std::size_t n : {10u, 37u, 50u}) {
    const auto [t1, dof] = dense_law(n, 0.8);
    CHECK(ar1_line_residual_law(n, 0.8).mean_factor == Approx(t1).epsilon(1e-10));
    CHECK(ar1_line_residual_law(n, 0.8).dof == Approx(dof).epsilon(1e-10));
  }
  // A baseline of 50 points on a line plus +-d about it (d alternating in pairs, so the residual
  // about the fitted line is computed here independently): floor = max(configured, 6 x bound).
  SignalProcessingSettings settings;  // wear_baseline_records 50
  const std::size_t n = 50;
  std::vector<double> y;
  for (std::size_t k = 0; k < n; ++k) y.push_back(0.02 + 1e-4 * k + ((k / 2) % 2 ? 0.006 : -0.006));
  y.push_back(0.5);  // the newest point, judged, not part of the baseline
  double sy = 0, sky = 0;
  const double mk = (n - 1) / 2.0;
  double skk = 0.0;
  for (std::size_t k = 0; k < n; ++k) sy += y[k], sky += (k - mk) * y[k], skk += (k - mk) * (k - mk);
  double rss = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double e = y[k] - sy / n - sky / skk * (k - mk);
    rss += e * e;
  }
  const auto [t1, dof] = dense_law(n, kWanderMaxCorrelation);
  const double bound = std::sqrt(rss * dof / (t1 * boost::math::quantile(boost::math::chi_squared(dof), 1.0 - kWanderBoundConfidence)));
  const BandFloor f = band_material_floor(y, n, settings);
  INFO("rss " << rss << " bound " << bound << " floor " << f.floor);
  CHECK(f.source == FloorSource::baseline);
  CHECK(f.baseline_points == n);
  CHECK(f.wander_bound == Approx(bound).epsilon(1e-9));
  CHECK(f.floor == Approx(std::max(material_ics2_rise(settings), 6.0 * bound)).epsilon(1e-9));
  CHECK(f.floor > material_ics2_rise(settings));  // this baseline's wander raises the floor
  // Fewer than 10 earlier values, or the setting off: the configured floor.
  CHECK(band_material_floor(y, 9, settings).source == FloorSource::baseline_incomplete);
  CHECK(band_material_floor(y, 9, settings).floor == material_ics2_rise(settings));
  settings.wear_baseline_records = 0;
  CHECK(band_material_floor(y, n, settings).source == FloorSource::configured);
  CHECK(band_material_floor(y, n, settings).floor == material_ics2_rise(settings));
}

TEST_CASE("issue 36: AR(1) wander of SD floor/3 and floor/2 stays under Ville's bound once the baseline is measured",
          "[dsp][wear_mechanism]") {
  // As the floor/6 test above, with the wander at a third and a half of the configured floor. Until
  // kMinimumBaselinePoints earlier values exist ten records of an AR(1) path cannot measure its
  // wander: the verdict asks incomplete_baseline_floor (wander up to kEarlyWanderFraction = 1/2 of the
  // configured floor), and a history counts there when the verdict is raised within the first
  // kMinimumBaselinePoints records. From then on the measured floor must carry the bound: a history
  // counts when the verdict is raised at any record past them, whatever came before. Both bounded.
  SignalProcessingSettings settings;
  const double floor = material_ics2_rise(settings);
  const double bar = rising_evidence_threshold(settings.trend_significance);
  constexpr int histories = 2000, length = 100;
  const auto measured_from = static_cast<int>(kMinimumBaselinePoints);
  struct Rates {
    double before_measured, once_measured;
  };
  auto false_alarms = [&](double k, double phi, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> gauss(0.0, 1.0);
    const double s = floor / k;
    int early = 0, late = 0;
    for (int h = 0; h < histories; ++h) {
      test_wear_wander::WanderingHistory history(s, phi, rng, gauss);
      bool raised_early = false, raised_late = false;
      for (int r = 0; r < length && !raised_late; ++r) {
        history.grow();
        if (r < measured_from && raised_early) continue;
        (r < measured_from ? raised_early : raised_late) |= history.raised(bar, settings);
      }
      early += raised_early, late += raised_late;
    }
    return Rates{static_cast<double>(early) / histories, static_cast<double>(late) / histories};
  };
  const double margin = 3 * std::sqrt(0.025 * 0.975 / histories);  // binomial 3-sigma at the bound
  const Rates a = false_alarms(3, 0.5, 4670), b = false_alarms(3, 0.8, 4671);
  const Rates c = false_alarms(2, 0.5, 4672), d = false_alarms(2, 0.8, 4673);
  INFO("raised within the first " << measured_from << " records / after: floor/3 phi 0.5 " << a.before_measured << " / "
                                  << a.once_measured << ", phi 0.8 " << b.before_measured << " / " << b.once_measured
                                  << "; floor/2 phi 0.5 " << c.before_measured << " / " << c.once_measured << ", phi 0.8 "
                                  << d.before_measured << " / " << d.once_measured << " (bound 0.025 + " << margin << ")");
  CHECK(a.once_measured <= 1.0 / 40.0 + margin);
  CHECK(b.once_measured <= 1.0 / 40.0 + margin);
  CHECK(c.once_measured <= 1.0 / 40.0 + margin);
  CHECK(d.once_measured <= 1.0 / 40.0 + margin);
  CHECK(a.before_measured <= 1.0 / 40.0 + margin);
  CHECK(b.before_measured <= 1.0 / 40.0 + margin);
  CHECK(c.before_measured <= 1.0 / 40.0 + margin);
  CHECK(d.before_measured <= 1.0 / 40.0 + margin);
}

TEST_CASE("issue 36: a ramp after a wandering baseline is named within the rank rule's records of crossing the measured floor",
          "[dsp][wear_mechanism]") {
  // 50 baseline records wandering at SD floor/3 (AR(1) 0.8), then a ramp of 0.3 x the measured
  // floor per record on top of the same wander (3x the floor after 10 records). Crossing: the first
  // ramp record whose ramp alone reaches the floor. The rank rule needs
  // post_change_points_for_evidence(50) = 4 rising records after a baseline of 50; the verdict comes
  // at the latest 4 records after the crossing.
  SignalProcessingSettings settings;
  const double configured = material_ics2_rise(settings), s = configured / 3;
  const std::size_t needed = post_change_points_for_evidence(50, settings.trend_significance);
  CHECK(needed == 4);
  std::mt19937_64 rng(4790);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<WearHistoryPoint> points;
    double u = gauss(rng);
    for (int r = 0; r < 50; ++r) {
      points.push_back({1e5 * r, 0.02 + s * u, 0.03, 8000.0});
      u = 0.8 * u + 0.6 * gauss(rng);
    }
    std::vector<double> base;
    for (const auto& p : points) base.push_back(p.ics2_low);
    const BandFloor f = band_material_floor(base, 50, settings);
    REQUIRE(f.source == FloorSource::baseline);
    const double slope = 0.3 * f.floor;
    const int crossing = static_cast<int>(std::ceil(1.0 / 0.3 - 1e-12));  // ramp record reaching the floor
    int named = -1;
    for (int r = 1; r <= 10 && named < 0; ++r) {
      points.push_back({1e5 * (49 + r), 0.02 + s * u + slope * r, 0.03, 8000.0});
      u = 0.8 * u + 0.6 * gauss(rng);
      const auto v = identify_wear_mechanism(points, settings);
      if (is_wear(v.mechanism)) {
        named = r;
        CHECK(v.mechanism == WearMechanism::fatigue_pitting);
        CHECK(v.low_floor.floor == Approx(f.floor).epsilon(1e-12));  // the baseline's floor, not grown
        CHECK(v.evidence.find("baseline of 50 records") != std::string::npos);
      }
    }
    INFO("trial " << trial << " floor " << f.floor << " named at ramp record " << named);
    CHECK(named >= 1);
    CHECK(named <= crossing + static_cast<int>(needed));
  }
}

TEST_CASE("issue 36: a history window past the pair's first records keeps their floor when given them as the baseline",
          "[dsp][wear_mechanism]") {
  // The daemon keeps the last trend_window_records records and, apart, the pair's first records:
  // the verdict on the window with that baseline has the floors of the whole history.
  SignalProcessingSettings settings;
  std::mt19937_64 rng(4791);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<WearHistoryPoint> all;
  for (int r = 0; r < 120; ++r) all.push_back({1e5 * r, 0.02 + 0.01 * gauss(rng), 0.03 + 0.005 * gauss(rng), 8000.0});
  const auto whole = identify_wear_mechanism(all, settings);
  REQUIRE(whole.low_floor.source == FloorSource::baseline);
  REQUIRE(whole.high_floor.source == FloorSource::baseline);
  const std::span<const WearHistoryPoint> window = std::span<const WearHistoryPoint>(all).last(40);
  const std::span<const WearHistoryPoint> first = std::span<const WearHistoryPoint>(all).first(50);
  const auto windowed = identify_wear_mechanism(window, settings, first);
  CHECK(windowed.low_floor.floor == whole.low_floor.floor);
  CHECK(windowed.high_floor.floor == whole.high_floor.floor);
  CHECK(windowed.low_floor.baseline_points == 50);
  // Without the baseline the window measures its own first 39 records: another floor.
  CHECK(identify_wear_mechanism(window, settings).low_floor.baseline_points == 39);
  // The two-band overload with an unseen band passes the baseline on.
  CHECK(identify_wear_mechanism(window, settings, CarrierBand::abrasion, first).low_floor.floor == whole.low_floor.floor);
}

}  // namespace test_wear_floor
