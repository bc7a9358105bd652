#include "gearwatch/gap/diagnosis.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <numbers>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "command_runner.hpp"
#include "gearwatch/dsp/order_tracking.hpp"
#include "gearwatch/gap/candidates.hpp"
#include "gearwatch/gap/evaluation.hpp"
#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/rig/rig_simulator.hpp"
#include "gearwatch/twin/gearbox_model.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "constant_speed_record.hpp"

namespace test_gap {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::gap;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kZ1 = 19, kZ2 = 52;

struct Tone {
  double order;   // in input orders (an output order m is m·z1/z2)
  double amplitude;
  double phase = 0;
};

/// A constant-speed record of tones, exactly `revs` input revolutions long (plus half a revolution,
/// so the last tacho edge lies inside), optionally with white Gaussian noise.
Record synthetic_record(double fs, double speed, int revs, const std::vector<Tone>& tones, double noise_sigma = 0,
                        std::uint64_t seed = 1) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, noise_sigma > 0 ? noise_sigma : 1.0);
  return test::constant_speed_record(fs, speed, revs, [&](double t) {
    double v = 0;
    for (const auto& tone : tones) v += tone.amplitude * std::cos(2 * kPi * tone.order * speed * t + tone.phase);
    if (noise_sigma > 0) v += gauss(rng);
    return v;
  });
}

/// The "twin": five mesh harmonics, a few shaft-order lines and sidebands on both shafts.
std::vector<Tone> twin_tones() {
  return {{19, 1.0, 0.1},         {38, 0.6, 0.7},        {57, 0.4, 1.3},       {76, 0.3, 2.1},  {95, 0.2, 0.4},
          {3, 0.05, 0.2},         {20, 0.04, 0.5},       {5.0 * kZ1 / kZ2, 0.03, 0.9},  {53.0 * kZ1 / kZ2, 0.02, 1.7}};
}

const FamilyGap& family(const std::vector<FamilyGap>& gaps, FamilyKind f) {
  for (const auto& g : gaps)
    if (g.family == f) return g;
  throw std::logic_error("family missing");
}

DiagnosisSettings fast_settings() {
  DiagnosisSettings s;
  s.bootstrap_resamples = 20;
  s.candidate_bootstrap_resamples = 10;
  return s;
}

// For tests that read the families, the candidates and their fits but not report.features: the
// features (and their descriptions, most of such a diagnosis's time) are left out. Nothing else in
// the report depends on them: the bootstrap draws they share with the families are keyed by record
// and draw, not by the order they are asked for (as in the rig bench, which leaves them out too).
DiagnosisSettings attribution_settings() {
  DiagnosisSettings s = fast_settings();
  s.find_features = false;
  return s;
}

}  // namespace

TEST_CASE("gap: the sideband families are the first sidebands n·z ± 1, the other non-mesh orders the shaft's", "[gap]") {
  REQUIRE(kSidebandOrders == 1);
  // Pinion, 19 teeth: 19 and 38 are mesh harmonics, 18/20 and 37/39 their first sidebands.
  CHECK(input_line_family(19, kZ1) == FamilyKind::mesh_harmonics);
  CHECK(input_line_family(38, kZ1) == FamilyKind::mesh_harmonics);
  for (int k : {18, 20, 37, 39}) CHECK(input_line_family(k, kZ1) == FamilyKind::input_sidebands);
  for (int k : {1, 2, 17, 21, 28, 36, 40}) CHECK(input_line_family(k, kZ1) == FamilyKind::input_shaft_orders);
  // Gear, 52 teeth: order 1 is the shaft's own line, not a sideband of a harmonic 0.
  for (int m : {51, 53, 103, 105}) CHECK(output_line_family(m, kZ2) == FamilyKind::output_sidebands);
  for (int m : {1, 2, 26, 50, 54, 102}) CHECK(output_line_family(m, kZ2) == FamilyKind::output_shaft_orders);
  CHECK(output_line_is_mesh(104, kZ2));
}

TEST_CASE("gap: a known line change lands in its own family with the closed-form dB", "[gap]") {
  const double fs = 10240, speed = 10;  // 1024 samples per revolution: the angle grid is the time grid
  struct Case {
    FamilyKind family;
    double order;        // the tone changed (input orders)
    int lines_in_family; // lines of that family in the band (0.45·fs / speed = 460 input orders)
  };
  // Input orders 1..460; output orders 1..1261 (0.45·fs over the output speed 10·19/52 Hz), mesh
  // orders (multiples of 52) excluded. Every mesh harmonic in the band (the last 24·19 = 456 and
  // 24·52 = 1248) has its kSidebandOrders sidebands on each side inside it too.
  const int mesh = 460 / kZ1;                                  // 24
  const int input_sidebands = 2 * kSidebandOrders * mesh;      // 48 for m = ±1
  const int input_shaft = 460 - mesh - input_sidebands;
  const int k_out = static_cast<int>(std::floor(0.45 * fs / (speed * kZ1 / kZ2)));
  const int output_sidebands = 2 * kSidebandOrders * (k_out / kZ2);
  const int output_shaft = k_out - k_out / kZ2 - output_sidebands;
  REQUIRE(k_out == 1261);
  const std::vector<Case> cases{{FamilyKind::mesh_harmonics, 38, mesh},
                                {FamilyKind::input_shaft_orders, 3, input_shaft},
                                {FamilyKind::input_sidebands, 20, input_sidebands},
                                {FamilyKind::output_shaft_orders, 5.0 * kZ1 / kZ2, output_shaft},
                                {FamilyKind::output_sidebands, 53.0 * kZ1 / kZ2, output_sidebands}};
  for (const auto& c : cases) {
    DYNAMIC_SECTION(to_string(c.family)) {
      auto measured = twin_tones();
      for (auto& t : measured)
        if (t.order == c.order) t.amplitude *= 4;  // +12.04 dB on that one line
      // 40 input revolutions (14 output): the other shaft's tones leak into a shaft's average as 1/R.
      const Record twin = synthetic_record(fs, speed, 40, twin_tones());
      const Record meas = synthetic_record(fs, speed, 40, measured);
      const auto report = diagnose({{meas, twin}}, {{meas, twin}}, GearPairSpec{}, fast_settings());
      const double expected = 20 * std::log10(4.0) / std::sqrt(c.lines_in_family);
      const auto& g = family(report.before, c.family);
      CHECK(g.distance_db == Approx(expected).epsilon(0.01));
      CHECK(g.energy_share == Approx(1.0).margin(0.01));
      // One line in a family of many: significant only when its RMS passes the practical minimum.
      CHECK(g.significant == (expected > fast_settings().min_gap_db));
      for (const auto& other : report.before)
        if (other.family != c.family && other.resolved) {
          INFO(to_string(other.family));
          CHECK(other.distance_db < 0.1);
          CHECK_FALSE(other.significant);
        }
    }
  }
}

TEST_CASE("gap: K_wear absorbs a mesh-harmonic gain the twin lacks, and the chosen effect gives it back", "[gap][kwear]") {
  // The measurement's mesh harmonics are all 6 dB above the twin's (energy added on RMS_SA: (g² − 1)
  // times the twin's). With RMS_SA ∝ K^e near the twin's state, the twin alone infers
  // K = K_ref · g^(1/e); a mesh-gain effect (misalignment / tip_relief) takes the whole ratio.
  const double fs = 10240, speed = 10, gain = 2.0, k_ref = 2.0e-12, elasticity = 0.5;
  auto measured = twin_tones();
  for (auto& t : measured)
    if (std::fmod(t.order, kZ1) == 0) t.amplitude *= gain;
  const Record twin = synthetic_record(fs, speed, 40, twin_tones());
  const Record meas = synthetic_record(fs, speed, 40, measured);
  auto settings = fast_settings();
  settings.reference_k_wear = k_ref;
  settings.rms_sa_wear_elasticity = elasticity;
  settings.rms_sa_harmonics = 2;
  const auto report = diagnose({{meas, twin}}, {{meas, twin}}, GearPairSpec{}, settings);
  REQUIRE(report.k_wear_before);
  REQUIRE(report.k_wear_after);
  CHECK(*report.k_wear_before == Approx(k_ref * std::pow(gain, 1.0 / elasticity)).epsilon(0.01));
  REQUIRE_FALSE(report.chosen.empty());
  CHECK(*report.k_wear_after == Approx(k_ref).epsilon(0.02));

  SECTION("without a reference K_wear nothing is inferred") {
    const auto plain = diagnose({{meas, twin}}, {{meas, twin}}, GearPairSpec{}, fast_settings());
    CHECK_FALSE(plain.k_wear_before);
    CHECK_FALSE(plain.k_wear_after);
  }
  SECTION("a zero elasticity is refused") {
    settings.rms_sa_wear_elasticity = 0;
    CHECK_THROWS_AS(diagnose({{meas, twin}}, {{meas, twin}}, GearPairSpec{}, settings), std::invalid_argument);
  }
  SECTION("per-record elasticities combine by least squares in the log") {
    // Both held-out records carry ln r = ln g; with e = (0.5, 0.05) the estimate is
    // ln(K/K_ref) = Σ e_i ln r_i / Σ e_i² = 0.55 ln g / 0.2525: the record that can tell K (0.5)
    // dominates, where the mean elasticity (0.275) would give ln g / 0.275.
    settings.rms_sa_wear_elasticities = {0.5, 0.05};
    const auto two = diagnose({{meas, twin}}, {{meas, twin}, {meas, twin}}, GearPairSpec{}, settings);
    REQUIRE(two.k_wear_before);
    CHECK(*two.k_wear_before == Approx(k_ref * std::pow(gain, 0.55 / 0.2525)).epsilon(0.01));
    REQUIRE(two.k_wear_after);
    CHECK(*two.k_wear_after == Approx(k_ref).epsilon(0.02));
    settings.rms_sa_wear_elasticities = {0.5};  // one value for two records
    CHECK_THROWS_AS(diagnose({{meas, twin}}, {{meas, twin}, {meas, twin}}, GearPairSpec{}, settings),
                    std::invalid_argument);
    // A record whose twin cannot tell K (|e| below min_rms_sa_wear_elasticity, 0.05) weighs nothing:
    // the other alone gives K_ref·g^(1/0.5).
    settings.rms_sa_wear_elasticities = {0.5, 0.04};
    const auto one = diagnose({{meas, twin}}, {{meas, twin}, {meas, twin}}, GearPairSpec{}, settings);
    REQUIRE(one.k_wear_before);
    CHECK(*one.k_wear_before == Approx(k_ref * std::pow(gain, 1.0 / 0.5)).epsilon(0.01));
    settings.rms_sa_wear_elasticities = {0.0, -0.02};
    const auto none = diagnose({{meas, twin}}, {{meas, twin}, {meas, twin}}, GearPairSpec{}, settings);
    CHECK_FALSE(none.k_wear_before);
    CHECK_FALSE(none.k_wear_after);
    settings.rms_sa_wear_elasticities = {0.5, std::numeric_limits<double>::quiet_NaN()};
    CHECK_THROWS_AS(diagnose({{meas, twin}}, {{meas, twin}, {meas, twin}}, GearPairSpec{}, settings),
                    std::invalid_argument);
  }
}

TEST_CASE("gap: RMS_SA(N) from the input-order lines, and its wear elasticity as a central difference in the log", "[gap][kwear]") {
  SpectralSummary s;
  s.input_lines.assign(2 * kZ1, 1e-3);
  s.input_lines[kZ1 - 1] = 9.0;       // harmonic 1: power 9
  s.input_lines[2 * kZ1 - 1] = 16.0;  // harmonic 2: power 16
  CHECK(*rms_sa_of_lines(s, kZ1, 1) == Approx(3.0).epsilon(1e-12));
  CHECK(*rms_sa_of_lines(s, kZ1, 2) == Approx(5.0).epsilon(1e-12));
  CHECK_FALSE(rms_sa_of_lines(s, kZ1, 3));  // the lines end before harmonic 3
  s.input_lines[kZ1 - 1] = s.input_lines[2 * kZ1 - 1] = 0;
  CHECK_FALSE(rms_sa_of_lines(s, kZ1, 2));
  // RMS_SA ∝ depth^e: the ratio between depths ×1.25 and ×0.8 is (1.25/0.8)^e.
  CHECK(rms_sa_wear_elasticity(1.0, std::pow(1.25 / 0.8, -0.62)) == Approx(-0.62).epsilon(1e-12));
  CHECK_THROWS_AS(rms_sa_wear_elasticity(0.0, 1.0), std::invalid_argument);
}

TEST_CASE("gap: inferred_k_wear is the fixed point of the proportional update under a power law", "[gap][kwear]") {
  // RMS_SA = c·K^e: the K at which the model's RMS_SA equals 1.21 times the reference's.
  CHECK(inferred_k_wear(1.21, 1.0, 3e-12, 2.0) == Approx(3e-12 * 1.1).epsilon(1e-12));
  CHECK(inferred_k_wear(0.5, 1.0, 1e-12, 1.0) == Approx(0.5e-12).epsilon(1e-12));
  CHECK_THROWS_AS(inferred_k_wear(0.0, 1.0, 1e-12, 1.0), std::invalid_argument);
}

TEST_CASE("gap: a non-synchronous tone's share of each line follows the two synchronous averages, the rest is broadband", "[gap]") {
  // Closed form first: with as many teeth on both wheels every output order is an input order,
  // the output average takes nothing away, and a mean over R revolutions keeps sinc²(R·Δ) of a
  // tone Δ orders away; the broadband part gets the rest times B/(B − 1) for B = R − 1 blocks.
  {
    SpectralSummary model;
    model.input_revolutions = 16;
    model.output_revolutions = 16;
    model.input_lines.assign(40, 0.0);
    model.output_lines.assign(40, 0.0);
    model.broadband.assign(40, 0.0);
    add_non_synchronous_tone(model, 19.3, 1.0, GearPairSpec{19, 19});
    auto sinc2 = [](double x) { return std::pow(std::sin(kPi * x) / (kPi * x), 2); };
    double kept = 0;
    for (int k = 17; k <= 22; ++k) {
      CHECK(model.input_lines[k - 1] == Approx(sinc2(16 * (19.3 - k))).epsilon(1e-9));
      kept += sinc2(16 * (19.3 - k));
    }
    CHECK(std::accumulate(model.output_lines.begin(), model.output_lines.end(), 0.0) == 0.0);
    CHECK(std::accumulate(model.broadband.begin(), model.broadband.end(), 0.0) == Approx((1 - kept) * 15 / 14).epsilon(1e-9));
  }
  // Against the record's own spectra at tones near and far from output orders, 16 and 32 revolutions.
  const double fs = 20000, speed = 10;
  for (double order : {19.2, 19.4, 19.55, 19.7}) {
    for (int revs : {16, 32}) {
      CAPTURE(order, revs);
      const auto measured = RecordSpectra(synthetic_record(fs, speed, revs, {{order, 1.0, 0.3}}), 0, GearPairSpec{}).summary();
      REQUIRE(measured.input_revolutions == static_cast<std::size_t>(revs));
      SpectralSummary model = measured;
      std::fill(model.input_lines.begin(), model.input_lines.end(), 0.0);
      std::fill(model.output_lines.begin(), model.output_lines.end(), 0.0);
      std::fill(model.broadband.begin(), model.broadband.end(), 0.0);
      add_non_synchronous_tone(model, order, 1.0, GearPairSpec{});
      // The nearest lines within 15 % on the input side, 5 % on the output side, the next output
      // line within 15 % (the averages' 2 % end tapers and the second pass's own leakage are not
      // followed); lines below 2e-5 of the tone cannot matter next to it.
      for (int k : {19, 20}) CHECK(measured.input_lines[k - 1] == Approx(model.input_lines[k - 1]).epsilon(0.15).margin(2e-5));
      for (int m : {53, 54}) CHECK(measured.output_lines[m - 1] == Approx(model.output_lines[m - 1]).epsilon(0.05).margin(2e-5));
      CHECK(measured.output_lines[55 - 1] == Approx(model.output_lines[55 - 1]).epsilon(0.15).margin(2e-5));
      double measured_broadband = 0, model_broadband = 0;
      for (std::size_t k = 15; k <= 24; ++k) {
        measured_broadband += measured.broadband[k - 1];
        model_broadband += model.broadband[k - 1];
      }
      // Near an output order (19.4 → 53.09, 19.7 → 53.92) the output average takes up to half the
      // tone and the broadband part reads up to 20 % above what the projections leave (they are taken
      // over different spans, so not orthogonal); elsewhere within 7 %.
      const bool near_output_order = order == 19.4 || order == 19.7;
      CHECK(measured_broadband == Approx(model_broadband).epsilon(near_output_order ? 0.25 : 0.07));
    }
  }
}

TEST_CASE("gap: a distance's interval is its bootstrap draws' spread about their median, placed on the estimate", "[gap]") {
  // 101 draws 2.00, 2.01, ..., 3.00 (shuffled): median 2.50, 5th/95th percentiles 2.05/2.95.
  std::vector<double> draws;
  for (int i = 100; i >= 0; --i) draws.push_back(2.0 + 0.01 * ((i * 37) % 101));
  // Biased draws wholly above an estimate of 1.2 dB: the interval is 1.2 - 0.45 .. 1.2 + 0.45.
  auto a = bootstrap_interval(draws, 1.2);
  CHECK(a.low == Approx(0.75).margin(1e-12));
  CHECK(a.high == Approx(1.65).margin(1e-12));
  // Coverage 0.5: the 25th/75th percentiles 2.25/2.75 about the same median.
  a = bootstrap_interval(draws, 1.2, 0.5);
  CHECK(a.low == Approx(0.95).margin(1e-12));
  CHECK(a.high == Approx(1.45).margin(1e-12));
  // A distance is never negative: the low end stops at 0 dB.
  a = bootstrap_interval(draws, 0.3);
  CHECK(a.low == 0.0);
  CHECK(a.high == Approx(0.75).margin(1e-12));
  // Unbiased draws (median at the estimate) keep their own percentiles.
  a = bootstrap_interval(draws, 2.5);
  CHECK(a.low == Approx(2.05).margin(1e-12));
  CHECK(a.high == Approx(2.95).margin(1e-12));
  a = bootstrap_interval({}, 0.7);
  CHECK(a.low == 0.7);
  CHECK(a.high == 0.7);
}

TEST_CASE("gap: a bootstrap draw is blocks of consecutive revolutions (circular) and a record's identity follows its content",
          "[gap]") {
  const Record r = synthetic_record(20000, 10, 24, twin_tones(), 0.01);
  const RecordSpectra spectra(r, 0, GearPairSpec{});
  for (std::size_t block : {1u, 2u, 5u}) {
    std::mt19937_64 rng(7), again(7);
    const auto d = spectra.draw_bootstrap(rng, block);
    REQUIRE(d.input_revs.size() == spectra.input_revolutions());
    REQUIRE(d.output_revs.size() == spectra.output_revolutions());
    REQUIRE(d.blocks.size() == spectra.input_revolutions() - 1);  // one 2-revolution block per start
    for (const auto* v : {&d.input_revs, &d.output_revs, &d.blocks}) {
      const std::size_t n = v->size();
      for (std::size_t j = 0; j < n; ++j) {
        CHECK((*v)[j] < n);
        if (j % block != 0) CHECK((*v)[j] == ((*v)[j - 1] + 1) % n);
      }
    }
    // The bootstrap is the summary over the same draw, to the bit.
    const SpectralSummary direct = spectra.summary(d.input_revs, d.output_revs, d.blocks);
    const SpectralSummary drawn = spectra.bootstrap(again, block);
    CHECK(drawn.input_lines == direct.input_lines);
    CHECK(drawn.output_lines == direct.output_lines);
    CHECK(drawn.broadband == direct.broadband);
    // Every revolution carries the same tones, so any draw reads them at their amplitude²
    // (peak amplitude, 0.01 noise: within 1e-3 of 1.0 and 0.36).
    CHECK(direct.input_lines[18] == Approx(1.0).margin(1e-3));
    CHECK(direct.input_lines[37] == Approx(0.36).margin(1e-3));
  }
  // A copy keeps the identity (the same spectra); another record and every setter take a new one.
  RecordSpectra copy = spectra;
  CHECK(copy.identity() == spectra.identity());
  CHECK(RecordSpectra(r, 0, GearPairSpec{}).identity() != spectra.identity());
  copy.set_run_out_response(nullptr);
  CHECK(copy.identity() != spectra.identity());
  const auto before_path = copy.identity();
  copy.set_bearing_force_path(nullptr);
  CHECK(copy.identity() != before_path);
  const auto before_sensitivity = copy.identity();
  copy.set_run_out_sensitivity({}, {});
  CHECK(copy.identity() != before_sensitivity);
}

TEST_CASE("gap: white noise on the measurement raises the broadband family to 10 log10(1 + N0/floor)", "[gap]") {
  const double fs = 10240, speed = 10, sigma = 0.02;
  const Record twin = synthetic_record(fs, speed, 24, twin_tones());
  const Record meas = synthetic_record(fs, speed, 24, twin_tones(), sigma, 7);
  auto s = fast_settings();
  const auto report = diagnose({{meas, twin}}, {{meas, twin}}, GearPairSpec{}, s);
  // Per 1-order bin of the 2-revolution Hann blocks: N0 = 4σ²/spr; the floor is floor_db re the
  // twin's total line power Σ A²; the twin's own broadband is ~0.
  double total = 0;
  for (const auto& t : twin_tones()) total += t.amplitude * t.amplitude;
  const double floor = total * std::pow(10.0, s.floor_db / 10);
  const double n0 = 4 * sigma * sigma / 1024;
  const double expected = 10 * std::log10(1 + n0 / floor);
  const auto& g = family(report.before, FamilyKind::broadband);
  CHECK(g.distance_db == Approx(expected).margin(0.5));  // ±0.5 dB: ~70 degrees of freedom per bin
  CHECK(g.significant);
  REQUIRE_FALSE(report.chosen.empty());
  CHECK(report.chosen.front() == CandidateEffect::noise_floor);
}

TEST_CASE("gap: no effect (twin plus noise against twin plus independent noise) reports no significant gap", "[gap]") {
  const double fs = 10240, sigma = 0.01;
  std::vector<DiagnosisInput> training, held_out;
  std::uint64_t seed = 11;
  for (double speed : {8.0, 12.0}) {
    training.push_back({synthetic_record(fs, speed, 16, twin_tones(), sigma, seed++),
                        synthetic_record(fs, speed, 16, twin_tones(), sigma, seed++)});
  }
  for (double speed : {10.0, 14.0}) {
    held_out.push_back({synthetic_record(fs, speed, 16, twin_tones(), sigma, seed++),
                        synthetic_record(fs, speed, 16, twin_tones(), sigma, seed++)});
  }
  const auto report = diagnose(training, held_out, GearPairSpec{}, fast_settings());
  for (const auto& g : report.before) {
    INFO(to_string(g.family) << " " << g.distance_db << " [" << g.distance_interval_db.low << ", "
                             << g.distance_interval_db.high << "]");
    CHECK(g.resolved);
    CHECK_FALSE(g.significant);
    // Noise alone lifts a redrawn line's power above the full record's (fewer distinct
    // revolutions in the average): the interval must still hold the estimate it belongs to.
    CHECK(g.distance_interval_db.low <= g.distance_db);
    CHECK(g.distance_interval_db.high >= g.distance_db);
    if (g.distance_db > 0) CHECK(g.distance_interval_db.high > g.distance_interval_db.low);
  }
  CHECK(report.chosen.empty());
  CHECK(report.unexplained.empty());
  CHECK(report.speeds_hz.size() == 4);
  // Nor at the resolution of a line or a band (features.hpp), on the real bootstrap's spreads.
  for (const auto& f : report.features) INFO(describe(f));
  CHECK(report.features.empty());
}

TEST_CASE("gap: a transfer-path gain fixed in Hz is localised to the fixed-frequency family", "[gap]") {
  const double fs = 10240;
  // The measurement's lines between 700 and 800 Hz (two 1/12-octave bands) are eight times the
  // twin's (+18 dB, a resonance of the transfer path): at each speed these are different orders.
  // (A band an octave wide would hold the same order at both held-out speeds, 10 and 14 Hz, and
  // the split into order and Hz parts could not tell them apart.)
  // Lines at every input order 1..200: 8–14 Hz apart, several in each 1/12-octave band near 750 Hz.
  auto dense = [] {
    auto tones = twin_tones();
    for (int k = 1; k <= 200; ++k)
      if (k % kZ1 != 0) tones.push_back({static_cast<double>(k), 0.05, 0.37 * k});
    return tones;
  };
  auto measured_tones = [&](double speed) {
    auto tones = dense();
    for (auto& t : tones)
      if (t.order * speed >= 700 && t.order * speed <= 800) t.amplitude *= 8;
    return tones;
  };
  std::vector<DiagnosisInput> pairs;
  for (double speed : {8.0, 12.0, 10.0, 14.0})
    pairs.push_back({synthetic_record(fs, speed, 16, measured_tones(speed)), synthetic_record(fs, speed, 16, dense())});
  const std::vector<DiagnosisInput> training(pairs.begin(), pairs.begin() + 2), held_out(pairs.begin() + 2, pairs.end());
  const auto report = diagnose(training, held_out, GearPairSpec{}, fast_settings());
  const auto& fixed = family(report.before, FamilyKind::fixed_frequency);
  REQUIRE(fixed.resolved);
  // Held out at 10 Hz (760 Hz = harmonic 4) and 14 Hz (798 Hz = harmonic 3): the same Hz band.
  const bool shaded = std::any_of(report.hz_bands.begin(), report.hz_bands.end(), [](const auto& b) {
    return b.first == FamilyKind::fixed_frequency && b.second.low <= 798 && b.second.high >= 760;
  });
  CHECK(shaded);
  // Known limit (docs/gap.md): the split gives each line one order part from only two held-out
  // speeds, so part of a Hz-fixed change stays on the strong mesh lines; the fixed family is
  // significant and its band is found, but it does not take the whole change.
  CHECK(fixed.significant);
  // At the resolution of a line: the +18 dB band is one feature fixed in Hz, seen at every speed,
  // its band inside 700–800 Hz widened by half a line (4–7 Hz), the size 18 dB (floor and
  // leakage: 1 dB).
  std::string all;
  for (const auto& f : report.features) all += describe(f) + "\n";
  INFO(all);
  const auto band = std::find_if(report.features.begin(), report.features.end(),
                                 [](const GapFeature& f) { return f.movement == FeatureMovement::fixed_in_hz; });
  REQUIRE(band != report.features.end());
  CHECK(band->seen_in.size() == 4);
  CHECK(band->hz_low >= 700 - 7);
  CHECK(band->hz_high <= 800 + 7);
  CHECK(band->size_db == Approx(20 * std::log10(8.0)).margin(1.0));
}

TEST_CASE("gap: records at a single speed leave fixed_frequency unresolved with the reason", "[gap]") {
  const Record twin = synthetic_record(10240, 10, 12, twin_tones());
  const auto report = diagnose({{twin, twin}}, {{twin, twin}}, GearPairSpec{}, fast_settings());
  const auto& g = family(report.before, FamilyKind::fixed_frequency);
  CHECK_FALSE(g.resolved);
  CHECK(g.unresolved_reason.find(">= 2 speeds") != std::string::npos);
  for (const auto& other : report.before)
    if (other.family != FamilyKind::fixed_frequency) CHECK(other.resolved);
}

TEST_CASE("gap: records at two loads, one speed each, leave fixed_frequency unresolved", "[gap]") {
  // A line's identity includes its load, so the Hz-fixed part needs two speeds at one load.
  Record light = synthetic_record(10240, 10, 12, twin_tones());
  light.torque_nm = 5;
  const Record heavy = synthetic_record(10240, 13, 14, twin_tones());
  const auto report = diagnose({{light, light}, {heavy, heavy}}, {{light, light}, {heavy, heavy}}, GearPairSpec{},
                               fast_settings());
  const auto& g = family(report.before, FamilyKind::fixed_frequency);
  CHECK_FALSE(g.resolved);
  CHECK(g.unresolved_reason.find("at one load; each load here has one") != std::string::npos);
  // The same two speeds at one load resolve it.
  Record heavy_slow = light;
  heavy_slow.torque_nm = 20;
  const auto resolved = diagnose({{heavy_slow, heavy_slow}, {heavy, heavy}}, {{heavy_slow, heavy_slow}, {heavy, heavy}},
                                 GearPairSpec{}, fast_settings());
  CHECK(family(resolved.before, FamilyKind::fixed_frequency).resolved);
}

TEST_CASE("gap: candidates fitted by re-running the twin are named, with their values, and close the gap", "[gap][rerun]") {
  // The "measurement" is the twin itself with one addition at a point of the candidate's grid, the
  // twin runs without it: the fit must return that point exactly and the held-out mesh gap must
  // close to what two identical simulations leave (nothing).
  //  - misalignment 0.1 mrad across the face (2 µm over 20 mm, more than the static deflection at
  //    the thesis's dry-test load of 5 N·m, so part of the face carries the load);
  //  - tip relief 8 µm over 0.2 of the active profile, at the lubricated test's 20 N·m.
  struct Case {
    CandidateEffect effect;
    std::vector<double> truth;
    double torque;
    std::vector<std::string> names;
  };
  //  - misalignment half a grid step above 0.1 mrad (1e-4 · 100^(1/16) rad, between two grid
  //    values): the chosen value's refinement reaches it.
  const double between = rerun_grid(CandidateEffect::misalignment)[4][0] *
                         std::pow(rerun_grid_ratios(CandidateEffect::misalignment)[0], 0.5);
  const std::vector<Case> cases{{CandidateEffect::misalignment, {1e-4}, 5.0, {"angle_rad"}},
                                {CandidateEffect::tip_relief, {8e-6, 0.2}, 20.0, {"amount_m", "length_fraction"}},
                                {CandidateEffect::misalignment, {between}, 5.0, {"angle_rad"}}};
  for (const auto& c : cases) {
    DYNAMIC_SECTION(to_string(c.effect) << " at " << c.truth.front()) {
      const double fs = 20000, seconds = 0.8;
      // Kept across the sections (Catch2 runs them in one process, one after another): the two
      // misalignment cases share their load, speeds and both candidates' grids, so the second
      // simulates only what the first did not. A record depends on nothing but its key.
      static std::map<std::tuple<int, std::vector<double>, double, double>, Record> cache;
      std::map<CandidateEffect, int> reruns;
      auto twin_record = [&](double speed, CandidateEffect effect, const std::vector<double>& values) -> const Record& {
        const auto key = std::make_tuple(static_cast<int>(effect), values, speed, c.torque);
        if (auto it = cache.find(key); it != cache.end()) return it->second;
        twin::SimulationOptions o;
        o.sample_rate_hz = fs;
        twin::ToothProfileDeviation profile;
        if (!values.empty() && effect == CandidateEffect::misalignment) o.face_misalignment_rad = values[0];
        if (!values.empty() && effect == CandidateEffect::tip_relief)
          profile = twin::with_linear_tip_relief(profile, values[0], values[1]);
        const auto s = twin::simulate_casing_signal(twin::GearboxParameters{}, profile, {speed, c.torque}, seconds, o);
        return cache.emplace(key, single_channel_record(s.acceleration, s.tacho_edges, fs, speed, c.torque)).first->second;
      };
      auto pairs = [&](std::vector<double> speeds) {
        std::vector<DiagnosisInput> in;
        for (double v : speeds) in.push_back({twin_record(v, c.effect, c.truth), twin_record(v, c.effect, {})});
        return in;
      };
      const auto training = pairs({10.0, 13.0}), held_out = pairs({11.5, 14.5});
      const auto grid = rerun_grid(c.effect);
      const bool on_grid = std::find(grid.begin(), grid.end(), c.truth) != grid.end();
      REQUIRE((on_grid || c.truth.front() == between));
      auto settings = attribution_settings();
      settings.rerun_twin = [&](CandidateEffect effect, const std::vector<double>& values, const Record& like,
                                double duration_s) {
        ++reruns[effect];
        // 0.8 s records, shorter than twin_min_seconds: the rerun is asked for the record's length.
        CHECK(duration_s == like.duration_s());
        return twin_record(like.speed_hz, effect, values);
      };
      const auto report = diagnose(training, held_out, GearPairSpec{}, settings);
      const auto& mesh_before = family(report.before, FamilyKind::mesh_harmonics);
      INFO("mesh before " << mesh_before.distance_db << " dB");
      REQUIRE(mesh_before.significant);
      // Each rerun candidate: the 2 training records at every grid point, the 2 held-out records only
      // at the one grid value its training fit picks (the other rerun candidate is not tried once
      // one is chosen, so no second value is scored). The chosen one's refinement re-runs the
      // training records at ± a half and ± a quarter grid step along each parameter (4 points each).
      for (CandidateEffect e : {CandidateEffect::misalignment, CandidateEffect::tip_relief}) {
        const auto refinement = e == c.effect ? 4 * rerun_grid_ratios(e).size() * 2 : 0;
        // Off the grid the held-out records are re-run at the grid value first chosen and at the
        // refined one.
        const std::size_t held_out_points = e == c.effect && !on_grid ? 2 : 1;
        CHECK(reruns[e] == static_cast<int>(rerun_grid(e).size() * 2 + 2 * held_out_points + refinement));
      }
      REQUIRE_FALSE(report.chosen.empty());
      CHECK(report.chosen.front() == c.effect);
      REQUIRE(report.candidates.front().effect == c.effect);
      const auto& fitted = report.candidates.front().parameters;
      REQUIRE(fitted.size() == c.truth.size());
      for (std::size_t i = 0; i < fitted.size(); ++i) {
        CHECK(fitted[i].first == c.names[i]);
        CHECK(fitted[i].second == Approx(c.truth[i]).epsilon(1e-12));
      }
      CHECK(family(report.after, FamilyKind::mesh_harmonics).distance_db < 0.01);
      CHECK(report.unexplained.empty());
    }
  }
  SECTION("without a rerun the candidates keep their spectral forms") {
    const Record twin = synthetic_record(10240, 10, 12, twin_tones());
    const auto spectral = diagnose({{twin, twin}}, {{twin, twin}}, GearPairSpec{}, fast_settings());
    for (const auto& c : spectral.candidates) {
      if (c.effect == CandidateEffect::misalignment) CHECK(c.parameters.front().first == "mesh_gain_db");
      if (c.effect == CandidateEffect::tip_relief) CHECK(c.parameters.front().first == "load_1_nm");
    }
  }
}

TEST_CASE("gap: a rerun lasts the record, at most the longer of 2 s and 20 revolutions", "[gap][rerun]") {
  auto twin_of = [](double seconds, double speed) {
    return single_channel_record(std::vector<float>(static_cast<std::size_t>(seconds * 1000), 0.0f), {}, 1000, speed, 20);
  };
  const DiagnosisSettings settings;
  CHECK(twin_duration_s(twin_of(10, 10), settings) == Approx(2.0));        // 20 revolutions take 2 s
  CHECK(twin_duration_s(twin_of(10, 20), settings) == Approx(2.0));        // 20 revolutions take 1 s: 2 s
  CHECK(twin_duration_s(twin_of(10, 2), settings) == Approx(10.0));        // 20 revolutions take 10 s
  CHECK(twin_duration_s(twin_of(30, 1.5), settings) == Approx(20 / 1.5));  // 13.3 s of a 30 s record
  CHECK(twin_duration_s(twin_of(0.8, 10), settings) == Approx(0.8));       // never longer than the record
  auto longer = settings;
  longer.twin_min_seconds = 5;
  CHECK(twin_duration_s(twin_of(10, 10), longer) == Approx(5.0));

  // Why the cap holds: the twin has no noise and a steady speed, so a 2 s run and a 6 s run give the
  // same family summaries (the known answer is 0 dB; what remains is the start-up's share).
  const double fs = 20000;
  twin::SimulationOptions o;
  o.sample_rate_hz = fs;
  o.face_misalignment_rad = 3e-4;
  auto record = [&](double seconds) {
    const auto s = twin::simulate_casing_signal(twin::GearboxParameters{}, {}, {10, 5}, seconds, o);
    return single_channel_record(s.acceleration, s.tacho_edges, fs, 10, 5);
  };
  const Record long_run = record(6), short_run = record(2);
  auto localise = settings;
  localise.attribute = false;
  for (const auto& g : diagnose({{long_run, short_run}}, {{long_run, short_run}}, GearPairSpec{}, localise).before) {
    INFO(to_string(g.family) << ": " << g.distance_db << " dB");
    CHECK(g.distance_db < 0.05);
    CHECK_FALSE(g.significant);
  }

  auto bad = settings;
  bad.twin_min_seconds = 0;
  const Record ok = synthetic_record(10240, 10, 12, twin_tones());
  CHECK_THROWS_WITH(diagnose({{ok, ok}}, {{ok, ok}}, GearPairSpec{}, bad), Catch::Contains("twin_min_seconds"));
}

TEST_CASE("gap: bad input is refused with the reason", "[gap]") {
  const Record ok = synthetic_record(10240, 10, 12, twin_tones());
  const Record short_record = synthetic_record(10240, 10, 3, twin_tones());
  CHECK_THROWS_WITH(diagnose({}, {{ok, ok}}, GearPairSpec{}), Catch::Contains("needs training records"));
  CHECK_THROWS_WITH(diagnose({{ok, ok}}, {}, GearPairSpec{}), Catch::Contains("needs held-out records"));
  CHECK_THROWS_WITH(diagnose({{short_record, ok}}, {{ok, ok}}, GearPairSpec{}), Catch::Contains("too short"));
  Record other_rate = ok;
  other_rate.sample_rate_hz = 20480;
  CHECK_THROWS_WITH(diagnose({{ok, other_rate}}, {{ok, ok}}, GearPairSpec{}), Catch::Contains("sample rates differ"));
  Record no_tacho = ok;
  no_tacho.tacho_edges[0].clear();
  CHECK_THROWS_WITH(diagnose({{no_tacho, ok}}, {{ok, ok}}, GearPairSpec{}), Catch::Contains("tacho"));
}

namespace {

/// A twin's spectra at one speed: mesh harmonics decaying with order, the rest near zero.
SpectralSummary twin_summary(double speed, double fs = 100000) {
  SpectralSummary s;
  s.speed_hz = speed;
  s.torque_nm = 20;
  s.sample_rate_hz = fs;
  s.input_revolutions = 20;
  s.output_revolutions = 7;
  s.input_line_averages = 13.3;
  s.output_line_averages = 4.7;
  // A run-out response of the order of the shipped twin's (AM per metre, PM per harmonic per metre).
  s.pinion_run_out = {300.0, 150.0};
  s.gear_run_out = {30.0, 15.0};
  // The shipped twin's bearing-force path (casing_mode acts through it).
  static const auto path = bearing_force_path(twin::assemble(twin::GearboxParameters{}), 0.5 * fs);
  s.bearing_force_path = path;
  const auto k_in = static_cast<std::size_t>(0.45 * fs / speed);
  const auto k_out = static_cast<std::size_t>(0.45 * fs / (speed * kZ1 / kZ2));
  // Every line and bin well above the floor, so that every form changes lines the comparison sees.
  s.input_lines.assign(k_in, 1e-3);
  s.broadband.assign(k_in, 1e-3);
  s.output_lines.assign(k_out, 1e-3);
  for (std::size_t n = 1; n * kZ1 <= k_in; ++n) s.input_lines[n * kZ1 - 1] = std::exp(-static_cast<double>(n) / 30.0);
  for (std::size_t m = kZ2; m <= k_out; m += kZ2) s.output_lines[m - 1] = 0;
  return s;
}

std::vector<SummaryPair> generated(CandidateEffect c, const std::vector<double>& values, double fs = 100000) {
  std::vector<SummaryPair> pairs;
  for (double speed : {8.0, 14.0}) {
    SummaryPair p;
    p.twin = twin_summary(speed, fs);
    p.measured = apply_effects({{c, values}}, p.twin, GearPairSpec{});
    double total = 0;
    for (double v : p.twin.input_lines) total += v;
    p.floor = total * 1e-6;
    pairs.push_back(std::move(p));
  }
  return pairs;
}

}  // namespace

TEST_CASE("gap: each parametric candidate fitted on data made with its own form recovers its parameters", "[gap]") {
  struct Case {
    CandidateEffect effect;
    std::vector<double> values;
    double tolerance;  // relative
    // The records' sample rate. The fluctuation forms follow every line above the comparison's
    // floor into its two sidebands, and every line of these records is above it, so a form
    // evaluation costs in proportion to the lines: the load ripple's records are at 20 kHz, the
    // speed ripple's at 50 kHz (its depth is read off the carriers' fall with order, and the
    // orders below 0.45 of 20 kHz left its fit outside the tolerance). The mount resonance at
    // 30 kHz needs 100 kHz.
    double fs = 100000;
  };
  const std::vector<Case> cases{
      {CandidateEffect::mount_resonance, {30000, 0.05}, 0.02},
      {CandidateEffect::noise_floor, {1e-4}, 0.02},
      {CandidateEffect::eccentricity, {20e-6, 8e-6}, 0.02},  // pinion and gear run-out, m
      {CandidateEffect::tooth_errors, {20, 1e-3, 2e-3, 5e-4}, 0.02},  // per load: the records' 20 N·m, then its gains
      // depth, f_m (x = 0.375 and 0.21 of the shaft speed: 12 % and 0.7 % of the angle left by the
      // tacho), AM share; the fourth value 0: fixed in Hz, not locked to a shaft's order
      {CandidateEffect::speed_fluctuation, {0.01, 3.0, 0.02, 0.0}, 0.03, 50000},
      // β, f_m; the third value (a locked ripple's AM index) and the fourth 0: fixed in Hz
      {CandidateEffect::load_fluctuation, {0.002, 5.0, 0.0, 0.0}, 0.03, 20000},
      {CandidateEffect::misalignment, {-3.0}, 0.02},
      {CandidateEffect::backlash, {0.5}, 0.02},
      // Modes at 300 and 700 Hz, ζ = 0.03, 5 kg: reported in rising frequency.
      {CandidateEffect::casing_mode, {300, 700, 0.03, 5}, 0.02},
  };
  for (const auto& c : cases) {
    DYNAMIC_SECTION(to_string(c.effect)) {
      const auto pairs = generated(c.effect, c.values, c.fs);
      const auto fitted = fit_candidate(c.effect, {}, pairs, GearPairSpec{});
      REQUIRE(fitted.size() == c.values.size());
      for (std::size_t i = 0; i < fitted.size(); ++i) CHECK(fitted[i] == Approx(c.values[i]).epsilon(c.tolerance));
      CHECK(training_cost(pairs, {{c.effect, fitted}}, GearPairSpec{}) < 1e-3 * training_cost(pairs, {}, GearPairSpec{}));
    }
  }
}

TEST_CASE("gap: a load ripple locked to a shaft's order, fitted on data made with its form, recovers its AM index and shaft",
          "[gap]") {
  // Known answer: the form's own records (speeds 8 and 14 Hz), a 10 % AM once per output and once
  // per input revolution; the fit returns {0, 0, m, order} with m within the round-trip tolerance
  // of the other forms (3 %) and the shaft's order exactly. Each sideband gains m²/4 of its
  // carrier (a line's gain is its neighbours' m²/4 each, its own power kept): checked on mesh
  // harmonic 1 and its upper sideband (input shaft) in closed form.
  for (double order : {static_cast<double>(kZ1) / kZ2, 1.0}) {
    CAPTURE(order);
    const std::vector<double> truth{0.0, 0.0, 0.1, order};
    const auto pairs = generated(CandidateEffect::load_fluctuation, truth, 20000);
    if (order == 1.0) {
      const auto& t = pairs.front().twin.input_lines;
      const auto& m = pairs.front().measured.input_lines;
      CHECK(m[kZ1 - 1] - t[kZ1 - 1] == Approx(0.01 / 4 * t[kZ1 - 2] + 0.01 / 4 * t[kZ1]).epsilon(1e-9));
      CHECK(m[kZ1] - t[kZ1] == Approx(0.01 / 4 * t[kZ1 - 1] + 0.01 / 4 * t[kZ1 + 1]).epsilon(1e-9));
    }
    const auto fitted = fit_candidate(CandidateEffect::load_fluctuation, {}, pairs, GearPairSpec{});
    REQUIRE(fitted.size() == 4);
    CHECK(fitted[0] == 0.0);
    CHECK(fitted[1] == 0.0);
    CHECK(fitted[2] == Approx(0.1).epsilon(0.03));
    CHECK(fitted[3] == order);
  }
}

namespace {

/// A record of mesh-like tones locked to the angle of a shaft whose speed ripples by `depth` at
/// `f_m` (it turns depth·f0/f_m rad ahead and back), with one tacho edge per revolution.
Record rippling_shaft_record(double fs, double f0, int revs, double depth, double f_m, const std::vector<int>& orders) {
  const double amplitude_rev = depth * f0 / (2 * kPi * f_m);  // angle ripple in revolutions
  auto revolutions_at = [&](double t) { return f0 * t - amplitude_rev * std::cos(2 * kPi * f_m * t); };
  Record r;
  r.sample_rate_hz = fs;
  const auto n = static_cast<std::size_t>((revs + 0.5) * fs / f0);
  std::vector<float> x(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double phi = revolutions_at(static_cast<double>(i) / fs);
    double v = 0;
    for (int k : orders) v += std::cos(2 * kPi * k * phi);
    x[i] = static_cast<float>(v);
  }
  r.channels = {x};
  r.channel_numbers = {0};
  double t = 0;
  for (int k = 0; k <= revs + 1; ++k) {
    // Newton on the angle: the edge where it passes revolution k (the angle at t = 0 is −a).
    const double target = k - amplitude_rev;
    for (int it = 0; it < 30; ++it)
      t -= (revolutions_at(t) - target) / (f0 + amplitude_rev * 2 * kPi * f_m * std::sin(2 * kPi * f_m * t));
    if (t * fs < static_cast<double>(n)) r.tacho_edges[0].push_back(t * fs);
  }
  r.speed_hz = f0;
  r.torque_nm = 20;
  return r;
}

// A twin for the ripple tests: the measured summary's layout with unit input lines at `orders`
// and nothing else.
SpectralSummary unit_lines_twin(const SpectralSummary& measured, const std::vector<int>& orders) {
  SpectralSummary twin = measured;
  std::fill(twin.input_lines.begin(), twin.input_lines.end(), 0.0);
  std::fill(twin.output_lines.begin(), twin.output_lines.end(), 0.0);
  std::fill(twin.broadband.begin(), twin.broadband.end(), 0.0);
  for (int k : orders) twin.input_lines[static_cast<std::size_t>(k - 1)] = 1.0;
  return twin;
}

}  // namespace

TEST_CASE("gap: the speed-ripple form keeps at each line what one tacho edge per revolution leaves of the ripple", "[gap]") {
  // A speed ripple of depth d at f_m turns the shaft d/x rad (x = f_m/f0); one edge per revolution
  // follows all but r(x) of that angle, so a line at order k keeps J0²(k·(d/x)·r(x)) of its power.
  const double fs = 20000, f0 = 10;
  const std::vector<int> orders{19, 57, 95, 133, 190};
  auto twin_of = [&](const SpectralSummary& measured) { return unit_lines_twin(measured, orders); };
  // The form against its closed form, with r from dsp::tracking_residual_share (the form reads it
  // off a table; measured within 7e-5): x = 0.25 and 0.3, depth 2 %.
  for (double f_m : {2.5, 3.0}) {
    CAPTURE(f_m);
    const double d = 0.02, x = f_m / f0, residual_rad = d / x * dsp::tracking_residual_share(x);
    const auto twin = twin_of(RecordSpectra(rippling_shaft_record(fs, f0, 40, d, f_m, orders), 0, GearPairSpec{}).summary());
    const auto model = apply_effects({{CandidateEffect::speed_fluctuation, {d, f_m, 0.0}}}, twin, GearPairSpec{});
    for (int k : orders) {
      CAPTURE(k);
      CHECK(model.input_lines[static_cast<std::size_t>(k - 1)] ==
            Approx(std::pow(std::cyl_bessel_j(0.0, k * residual_rad), 2)).epsilon(1e-3));
    }
  }
  // Against the order-tracked record where no tracking is possible: a ripple at the shaft's own
  // order (x = 1) and at twice it meets every edge at the same phase, so all of it stays (r = 1)
  // and the record's lines keep J0²(k·d/x). Slower ripples leave less, but the spline through the
  // edges also carries an image of the ripple at 1 − x, a second phase modulation the form leaves
  // out: at x = 0.3 (160 revolutions) a record's order-190 line keeps 0.80 of its power where the
  // form says 0.90 (docs/gap-bench.md).
  for (double f_m : {10.0, 20.0}) {
    CAPTURE(f_m);
    const double d = 0.005, x = f_m / f0;
    const auto measured = RecordSpectra(rippling_shaft_record(fs, f0, 40, d, f_m, orders), 0, GearPairSpec{}).summary();
    const auto model = apply_effects({{CandidateEffect::speed_fluctuation, {d, f_m, 0.0}}}, twin_of(measured), GearPairSpec{});
    for (int k : orders) {
      CAPTURE(k);
      const double kept = std::pow(std::cyl_bessel_j(0.0, k * d / x), 2);
      // Measured: the record within 1e-4, the form within 1e-8.
      CHECK(measured.input_lines[static_cast<std::size_t>(k - 1)] == Approx(kept).epsilon(1e-3));
      CHECK(model.input_lines[static_cast<std::size_t>(k - 1)] == Approx(kept).epsilon(1e-6));
    }
  }
}

TEST_CASE("gap: a once-per-revolution speed ripple is fitted locked to the shaft's order, at three speeds", "[gap]") {
  // A ripple at the input shaft's own order (f_m = f0 at every speed) turns the shaft d rad ahead and
  // back; one tacho edge per revolution meets it at one phase, so all of it stays: line k is phase-
  // modulated with index k·d and holds J_j(k·d)² of its power at k ± j (Jacobi–Anger). Known answers
  // from std::cyl_bessel_j; tolerances chosen before running: the records' lines within 2e-3 of the
  // closed form (the order tracking's own error, 1e-4 in the test above), the form within 1e-6, the
  // fitted depth within 3 %.
  const double fs = 20000, d = 0.01;
  const std::vector<int> orders{19, 57, 95, 190};
  auto twin_of = [&](const SpectralSummary& measured) { return unit_lines_twin(measured, orders); };
  auto pairs_at = [&](double depth) {
    std::vector<SummaryPair> pairs;
    for (double f0 : {8.0, 11.0, 14.0}) {
      const auto measured = RecordSpectra(rippling_shaft_record(fs, f0, 40, depth, f0, orders), 0, GearPairSpec{}).summary();
      pairs.push_back({measured, twin_of(measured), 1e-6 * static_cast<double>(orders.size())});
    }
    return pairs;
  };
  const auto pairs = pairs_at(d);
  for (const auto& p : pairs) {
    CAPTURE(p.measured.speed_hz);
    const auto model = apply_effects({{CandidateEffect::speed_fluctuation, {d, 0.0, 0.0, 1.0}}}, p.twin, GearPairSpec{});
    for (int k : orders)
      for (int j = -4; j <= 4; ++j) {
        CAPTURE(k, j);
        const double want = std::pow(std::cyl_bessel_j(std::abs(j), k * d), 2);
        const auto line = static_cast<std::size_t>(k + j - 1);
        CHECK(p.measured.input_lines[line] == Approx(want).margin(2e-3));
        CHECK(model.input_lines[line] == Approx(want).margin(1e-6));
      }
  }
  // One depth serves every speed, locked to the input shaft (order 1); a ripple fixed in Hz cannot.
  const auto fitted = fit_candidate(CandidateEffect::speed_fluctuation, {}, pairs, GearPairSpec{});
  REQUIRE(fitted.size() == 4);
  CHECK(speed_fluctuation_input_order(fitted) == 1.0);
  CHECK(fitted[0] == Approx(d).epsilon(0.03));
  CHECK(training_cost(pairs, {{CandidateEffect::speed_fluctuation, fitted}}, GearPairSpec{}) <
        1e-2 * training_cost(pairs, {}, GearPairSpec{}));
  // Without a ripple the fit changes no line by 0.1 dB (whatever mode it lands in).
  const auto still = pairs_at(0.0);
  const auto none = fit_candidate(CandidateEffect::speed_fluctuation, {}, still, GearPairSpec{});
  for (const auto& p : still) {
    const auto model = apply_effects({{CandidateEffect::speed_fluctuation, none}}, p.twin, GearPairSpec{});
    for (int k : orders)
      CHECK(std::abs(10 * std::log10((model.input_lines[static_cast<std::size_t>(k - 1)] + p.floor) / (1.0 + p.floor))) < 0.1);
  }
}

TEST_CASE("gap: the run-out sensitivity is the twin's response to a transmission error, kept as the order tracking keeps it",
          "[gap]") {
  const auto matrices = twin::assemble(twin::GearboxParameters{});
  const GearPairSpec gears{};
  for (double speed : {8.0, 17.0}) {
    INFO("input speed " << speed << " Hz");
    const auto pinion = run_out_sensitivity(matrices, gears, false, speed, 20.0);
    const auto gear = run_out_sensitivity(matrices, gears, true, speed, 20.0);
    const auto at_input = twin::transmission_error_response(matrices, speed);
    const auto at_output = twin::transmission_error_response(matrices, speed * kZ1 / kZ2);
    // PM: z1 times the pinion's angle; all of it at the input shaft's own frequency (its tacho cannot
    // see it), the tracking residual's share at the output shaft's.
    CHECK(pinion.pm_per_harmonic_per_m == Approx(kZ1 * std::abs(at_input[twin::theta5])).epsilon(1e-3));
    CHECK(gear.pm_per_harmonic_per_m ==
          Approx(kZ1 * std::abs(at_output[twin::theta5]) * dsp::tracking_residual_share(double(kZ1) / kZ2)).epsilon(1e-9));
    // AM: the loaded deflection's change over the mean deflection T/(r_b1·k̄), which halves when the
    // torque doubles.
    const double mean_deflection = 20.0 / matrices.mesh[twin::theta5] / matrices.mean_mesh_stiffness;
    CHECK(pinion.am_per_m ==
          Approx(std::abs(matrices.mesh.cast<std::complex<double>>().dot(at_input) + 1.0) / mean_deflection).epsilon(1e-9));
    CHECK(run_out_sensitivity(matrices, gears, false, speed, 40.0).am_per_m == Approx(pinion.am_per_m / 2).epsilon(1e-9));
    CHECK(run_out_sensitivity(matrices, gears, false, speed, std::nan("")).am_per_m == 0.0);
  }
  CHECK_THROWS_AS(run_out_sensitivity(matrices, gears, false, 0.0, 20.0), std::invalid_argument);
  // A pair whose gear turns more than 16 times as fast as the tacho's shaft (the config allows 5–500
  // teeth) is still diagnosed: above the shaft's own order the edges keep all of the deviation.
  GearPairSpec step_up;
  step_up.pinion_teeth = 400;
  step_up.gear_teeth = 20;
  const auto fast_gear = run_out_sensitivity(matrices, step_up, true, 8.0, 20.0);
  CHECK(fast_gear.pm_per_harmonic_per_m ==
        Approx(400 * std::abs(twin::transmission_error_response(matrices, 160.0)[twin::theta5])).epsilon(1e-3));
}

namespace {

/// The rig at one operating point with the given effects (one channel, 20 N·m, the twin's wear-free profile).
rig::RigRecord rig_at(const rig::EffectSet& fx, double speed, double fs, double seconds) {
  rig::RigRunSettings run;
  run.speed_hz = speed;
  run.torque_nm = 20;
  run.duration_s = seconds;
  run.sample_rate_hz = fs;
  run.channels = 1;
  return rig::simulate_record(twin::GearboxParameters{}, fx, {}, {}, run);
}

/// The rig with `fx` against the twin at each speed (20 N·m): the pairs a diagnosis takes.
std::vector<DiagnosisInput> rig_against_twin(const rig::EffectSet& fx, const std::vector<double>& speeds, double fs,
                                             double seconds) {
  std::vector<DiagnosisInput> in;
  for (double speed : speeds) {
    const auto r = rig_at(fx, speed, fs, seconds);
    twin::SimulationOptions o;
    o.sample_rate_hz = fs;
    const auto t = twin::simulate_casing_signal(twin::GearboxParameters{}, {}, {speed, 20.0}, seconds, o);
    in.push_back({single_channel_record(r.acceleration[0], r.tacho_edges, fs, speed, 20.0),
                  single_channel_record(t.acceleration, t.tacho_edges, fs, speed, 20.0)});
  }
  return in;
}

/// A ranked candidate's fitted values by name (the candidate must be in the report).
std::map<std::string, double> fitted_values(const GapReport& report, CandidateEffect effect) {
  const auto candidate = std::find_if(report.candidates.begin(), report.candidates.end(),
                                      [&](const CandidateScore& c) { return c.effect == effect; });
  REQUIRE(candidate != report.candidates.end());
  return {candidate->parameters.begin(), candidate->parameters.end()};
}

/// The twin at 20 N·m with a candidate's rerun addition (add_rerun_effect), as a record.
Record twin_rerun_at(CandidateEffect effect, const std::vector<double>& values, double speed, double fs, double seconds) {
  twin::SimulationOptions o;
  o.sample_rate_hz = fs;
  twin::ToothProfileDeviation profile;
  if (!values.empty()) add_rerun_effect(effect, values, profile, o);
  const auto t = twin::simulate_casing_signal(twin::GearboxParameters{}, profile, {speed, 20.0}, seconds, o);
  return single_channel_record(t.acceleration, t.tacho_edges, fs, speed, 20.0);
}

rig::EffectSet casing_modes(double mode1_hz, double mode2_hz, double damping_ratio, double modal_mass_kg) {
  rig::EffectSet fx = rig::EffectSet::parse("casing");
  fx.set("casing.mode1_hz", mode1_hz);
  fx.set("casing.mode2_hz", mode2_hz);
  fx.set("casing.damping_ratio", damping_ratio);
  fx.set("casing.modal_mass_kg", modal_mass_kg);
  return fx;
}

}  // namespace

TEST_CASE("gap: eccentricity fitted on the rig's records recovers the run-outs the rig was given, across speeds", "[gap]") {
  // The rig puts a run-out into every pair's transmission error inside its ODE. The candidate's power
  // form knows only the twin's linearised response and the order tracking; with twin reruns, the
  // diagnosis reads the twin's own response to a run-out, line by line (eccentricity ranks first by
  // its power form, so each record's twin is re-run for it). Training at 8 and 14 Hz, held out at 11
  // and 17 Hz (where the pinion's PM per metre is 6 % and 45 % above the 8 Hz one), 20 N·m.
  const double fs = 20000, seconds = 3.0, pinion_um = 20, gear_um = 30;
  rig::EffectSet fx = rig::EffectSet::parse("eccentricity");
  fx.set("eccentricity.pinion_um", pinion_um);
  fx.set("eccentricity.gear_um", gear_um);
  fx.set("eccentricity.pinion_phase_rad", 0.4);
  fx.set("eccentricity.gear_phase_rad", 2.1);
  const auto training = rig_against_twin(fx, {8.0, 14.0}, fs, seconds), held_out = rig_against_twin(fx, {11.0, 17.0}, fs, seconds);
  // Measured, power form: pinion 19.79 µm (−1 %), gear 34.6 µm (+15 %), held-out input sidebands
  // 13.75 -> 0.239 dB. The gear's comes out high: at 8 Hz the rig's output first
  // sidebands hold 8–28 % more power than the form says at harmonics 2–14 (20 s records), of which
  // 7 % is the rig's train turning 3.4 % more at the gear's 2.9 Hz than the twin's linearised
  // response (its encoder 2.378e-4 against 2.301e-4 rad for 30 µm); the rest is not located
  // (docs/gap-bench.md). The pinion's, at its own frequency, agrees to 1e-5 (test_rig_simulator).
  // With the reruns: pinion 19.82 µm (−0.9 %), gear 33.8 µm (+13 %), input sidebands 13.75 -> 0.114
  // dB. The output shaft's sidebands also hold the twin's own leakage from the mesh harmonics beside
  // them, and a run-out's share interferes with it at its phase, which the phase-free form averages
  // out (up to 0.74 dB on those lines for a gear run-out alone, test below).
  double after_db[2] = {0, 0};
  for (const bool with_reruns : {false, true}) {
    INFO((with_reruns ? "with the twin's run-out response" : "power form"));
    auto settings = attribution_settings();
    std::map<std::pair<std::vector<double>, double>, Record> reruns;
    if (with_reruns)
      settings.rerun_twin = [&](CandidateEffect effect, const std::vector<double>& values, const Record& like, double duration_s) {
        const auto key = std::make_pair(values, like.speed_hz);
        if (auto it = reruns.find(key); it != reruns.end()) return it->second;
        return reruns.emplace(key, twin_rerun_at(effect, values, like.speed_hz, fs, duration_s)).first->second;
      };
    const auto report = diagnose(training, held_out, GearPairSpec{}, settings);
    if (with_reruns) {
      // The twin counterparts (3 s) are longer than a rerun (2–2.5 s): 5 reruns a speed, one of them
      // without a run-out.
      std::set<std::vector<double>> eccentricity_values;
      for (const auto& [key, record] : reruns)
        if (key.first.size() == 4) eccentricity_values.insert(key.first);
      CHECK(eccentricity_values.size() == 5);
    }
    REQUIRE_FALSE(report.chosen.empty());
    CHECK(report.chosen.front() == CandidateEffect::eccentricity);
    auto fitted = fitted_values(report, CandidateEffect::eccentricity);
    INFO("pinion " << fitted["pinion_run_out_m"] * 1e6 << " um, gear " << fitted["gear_run_out_m"] * 1e6 << " um");
    CHECK(fitted["pinion_run_out_m"] == Approx(pinion_um * 1e-6).epsilon(0.05));
    CHECK(fitted["gear_run_out_m"] == Approx(gear_um * 1e-6).epsilon(0.20));
    // Held out at other speeds, the input sidebands' gap is what is left after the run-out is added.
    const auto& before = family(report.before, FamilyKind::input_sidebands);
    const auto& after = family(report.after, FamilyKind::input_sidebands);
    INFO("input sidebands " << before.distance_db << " -> " << after.distance_db << " dB");
    REQUIRE(before.significant);
    CHECK(after.distance_db < 0.3 * before.distance_db);
    after_db[with_reruns] = after.distance_db;
  }
  // The twin's own response leaves half of what the power form leaves (measured 0.48).
  CHECK(after_db[1] < 0.6 * after_db[0]);
}

TEST_CASE("gap: the twin's run-out response gives each line of a twin run with a run-out", "[gap]") {
  // The response is read off 5 twin runs (none, then 10 µm on each shaft at phase 0 and π/2); a run
  // with another run-out and phase is then, line by line, the run without plus their combination,
  // as a small run-out enters the pairs' compression additively. 8 Hz, 20 N·m.
  const double fs = 50000, seconds = 2.0, speed = 8;
  const GearPairSpec gears{};
  std::vector<RecordSpectra> unit;
  for (const auto& v : run_out_response_reruns())
    unit.emplace_back(twin_rerun_at(CandidateEffect::eccentricity, v, speed, fs, seconds), 0, gears);
  const auto response = run_out_response(unit[0], {&unit[1], &unit[2], &unit[3], &unit[4]}, kRunOutResponseUnitM);
  RecordSpectra base = unit[0];
  base.set_run_out_response(response);
  // One shaft at a time: with both, the output shaft's lines also hold the pinion's sidebands (5
  // output revolutions cannot average them out), and the two run-outs' shares interfere there with
  // the phase between them, which the phase-free form leaves out (±1.3 dB on those lines here).
  // Measured, pinion (84 lines): the change off by 6.6 % of it at most (a phase turn at the high
  // harmonics, where the run-out's phase modulation is no longer small against a radian), the form's
  // power by 0.010 dB. Gear (11 lines): 1.4 % and 0.74 dB, as the output shaft's lines also hold the
  // twin's own leakage from the mesh harmonics beside them, with which the run-out's share
  // interferes at its phase (the cross term the phase-free form averages out).
  struct Case {
    const char* shaft;
    std::vector<double> values;  // pinion, gear run-out (m), their phases (rad)
    double change_bound, form_db_bound;
  };
  for (const Case& c : {Case{"pinion", {6.6e-6, 0.0, 1.0, 0.0}, 0.08, 0.05}, Case{"gear", {0.0, 12.5e-6, 0.0, 2.0}, 0.03, 1.0}}) {
    INFO(c.shaft << " run-out");
    const auto& v = c.values;
    const RecordSpectra direct(twin_rerun_at(CandidateEffect::eccentricity, v, speed, fs, seconds), 0, gears);
    const double weight[4] = {v[0] * std::cos(v[2]), v[0] * std::sin(v[2]), v[1] * std::cos(v[3]), v[1] * std::sin(v[3])};
    auto combined = [&](const std::array<std::vector<std::complex<double>>, 4>& per_m, std::size_t i) {
      return weight[0] * per_m[0][i] + weight[1] * per_m[1][i] + weight[2] * per_m[2][i] + weight[3] * per_m[3][i];
    };
    // The phase-free form: each line gains e²(|R0|² + |R1|²)/2 per shaft.
    const auto form = apply_effects({{CandidateEffect::eccentricity, {v[0], v[1]}}}, base.summary(), gears);
    const auto run = direct.summary();
    // Every first sideband above the comparison's floor (DiagnosisSettings::floor_db, 60 dB under
    // the twin's total line power), on both shafts.
    const double floor = 1e-6 * total_input_line_power(run);
    int checked = 0;
    double worst_change = 0, worst_form_db = 0;
    auto check_lines = [&](const std::vector<std::complex<double>>& with, const std::vector<std::complex<double>>& without,
                           const std::array<std::vector<std::complex<double>>, 4>& per_m, const std::vector<double>& form_power,
                           const std::vector<double>& run_power, int teeth) {
      for (std::size_t i = 0; i < with.size() && i < per_m[0].size(); ++i) {
        const int order = static_cast<int>(i) + 1, r = order % teeth;
        if ((r != 1 && r != teeth - 1) || order < 2 || run_power[i] < floor) continue;
        const auto change = with[i] - without[i];
        worst_change = std::max(worst_change, std::abs(combined(per_m, i) - change) / std::abs(change));
        worst_form_db = std::max(worst_form_db, std::abs(10 * std::log10(form_power[i] / run_power[i])));
        ++checked;
      }
    };
    check_lines(direct.input_line_means(), unit[0].input_line_means(), response->input_per_m, form.input_lines, run.input_lines, kZ1);
    check_lines(direct.output_line_means(), unit[0].output_line_means(), response->output_per_m, form.output_lines, run.output_lines, kZ2);
    INFO(checked << " first sidebands above the floor: the response's change off the run's by at most " << worst_change
                 << " of it, the form's power by " << worst_form_db << " dB");
    CHECK(checked >= 8);
    CHECK(worst_change < c.change_bound);
    CHECK(worst_form_db < c.form_db_bound);
  }
  CHECK_THROWS_AS(run_out_response(unit[0], {&unit[1], &unit[2], &unit[3], &unit[4]}, 0.0), std::invalid_argument);
  CHECK_THROWS_AS(run_out_response(unit[0], {&unit[1], nullptr, &unit[3], &unit[4]}, kRunOutResponseUnitM), std::invalid_argument);
}

TEST_CASE("gap: the bearing-force path is the twin's response to a mesh error, read between its points", "[gap]") {
  const twin::GearboxParameters p;
  const auto m = twin::assemble(p);
  const auto path = bearing_force_path(m, 10000);
  // Off the table's points (96 an octave: 0.7 % apart), at and away from the twin's modes.
  for (double f : {37.3, 152.0, 611.7, 1234.5, 4321.0}) {
    const auto q = twin::transmission_error_response(m, f);
    const std::complex<double> direct = (p.ky4 * q[twin::y4] + p.ky6 * q[twin::y6] + p.ky9 * q[twin::y9] + p.ky11 * q[twin::y11]) / q[twin::y6];
    INFO(f << " Hz: table " << path->at(f) << ", direct " << direct);
    CHECK(std::abs(path->at(f) - direct) < 2e-3 * std::abs(direct));
  }
  CHECK(path->highest_hz() >= 10000);
  CHECK_THROWS_AS(bearing_force_path(m, 0.5), std::invalid_argument);
  // A heavy casing adds nothing; without the path the form refuses.
  CHECK(casing_modes_gain(path->at(500), 500, 300, 700, 0.03, 1e12) == Approx(1.0).epsilon(1e-9));
  // One mode's term at its own f_n is e^{iφ}(F/y6)/m / (2iζωn²); off it, the equation of motion's
  // 1/(ωn² − ω² + 2iζωnω); two modes' gain is |1 + both terms|².
  const std::complex<double> ratio(3.0e7, -1.2e7);
  const double fn = 2500, zeta = 0.004, mass = 2.5, wn = 2 * std::numbers::pi * fn;
  for (double phase : {0.0, 1.0, -2.5}) {
    const CasingModeTerm term(fn, zeta, mass, phase);
    const std::complex<double> at_fn = std::polar(1.0, phase) * ratio / mass / std::complex<double>(0, 2 * zeta * wn * wn);
    CHECK(std::abs(term(ratio, fn) - at_fn) < 1e-12 * std::abs(at_fn));
    const double w = 2 * std::numbers::pi * 2600;
    const std::complex<double> off = std::polar(1.0, phase) * ratio / mass / std::complex<double>(wn * wn - w * w, 2 * zeta * wn * w);
    CHECK(std::abs(term(ratio, 2600) - off) < 1e-12 * std::abs(off));
  }
  {
    const double w = 2 * std::numbers::pi * 2600, w1 = 2 * std::numbers::pi * 2400, w2 = 2 * std::numbers::pi * 2700;
    const std::complex<double> sum = 1.0 / std::complex<double>(w1 * w1 - w * w, 2 * zeta * w1 * w) +
                                     1.0 / std::complex<double>(w2 * w2 - w * w, 2 * zeta * w2 * w);
    CHECK(casing_modes_gain(ratio, 2600, 2400, 2700, zeta, mass) == Approx(std::norm(1.0 + ratio / mass * sum)).epsilon(1e-12));
  }
  SpectralSummary bare;
  bare.speed_hz = 10;
  bare.input_lines.assign(100, 1.0);
  bare.broadband.assign(100, 1.0);
  CHECK_THROWS_WITH(apply_effects({{CandidateEffect::casing_mode, {300, 700, 0.03, 5}}}, bare, GearPairSpec{}),
                    Catch::Contains("bearing-force path"));
}

TEST_CASE("gap: casing_mode's form is what the rig's casing modes do to its record, line by line, at two speeds", "[gap]") {
  // The rig integrates two casing modes driven by the bearings' forces inside its ODE and adds their
  // acceleration to ÿ6; the form knows only the twin's linearised bearing-force path. Modes at 300
  // and 700 Hz (ζ = 0.03, 5 kg) put peaks and a notch among the first mesh harmonics at both speeds.
  // Measured: within 0.01 dB at the mesh harmonics 1–20 (the largest change 11 dB).
  const double fs = 20000, seconds = 2.0;
  const auto fx = casing_modes(300, 700, 0.03, 5);
  const auto path = bearing_force_path(twin::assemble(twin::GearboxParameters{}), 0.5 * fs);
  for (double speed : {8.0, 14.0}) {
    const auto plain = rig_at(rig::EffectSet{}, speed, fs, seconds), with = rig_at(fx, speed, fs, seconds);
    auto twin = RecordSpectra(single_channel_record(plain.acceleration[0], plain.tacho_edges, fs, speed, 20), 0, GearPairSpec{}).summary();
    const auto measured = RecordSpectra(single_channel_record(with.acceleration[0], with.tacho_edges, fs, speed, 20), 0, GearPairSpec{}).summary();
    twin.bearing_force_path = path;
    const auto model = apply_effects({{CandidateEffect::casing_mode, {300, 700, 0.03, 5}}}, twin, GearPairSpec{});
    double largest = 0;
    for (std::size_t n = 1; n <= 20 && n * kZ1 <= twin.input_lines.size(); ++n) {
      const std::size_t k = n * kZ1 - 1;
      const double rig_db = 10 * std::log10(measured.input_lines[k] / twin.input_lines[k]);
      const double form_db = 10 * std::log10(model.input_lines[k] / twin.input_lines[k]);
      INFO(speed << " Hz, mesh harmonic " << n << ": rig " << rig_db << " dB, form " << form_db << " dB");
      CHECK(form_db == Approx(rig_db).margin(0.05));
      largest = std::max(largest, std::abs(rig_db));
    }
    CHECK(largest > 6.0);  // the modes do move lines: the comparison is not of two unchanged spectra
  }
}

TEST_CASE("gap: casing_mode fitted on the rig's records is named and recovers the casing's mass and damping", "[gap]") {
  // Training at 8 and 14 Hz, held out at 11 and 17 Hz, 20 N·m; the rig has casing modes the twin lacks.
  const double fs = 20000, seconds = 2.0, mass_kg = 5, zeta = 0.03;
  const auto fx = casing_modes(300, 700, zeta, mass_kg);
  const auto report =
      diagnose(rig_against_twin(fx, {8.0, 14.0}, fs, seconds), rig_against_twin(fx, {11.0, 17.0}, fs, seconds), GearPairSpec{}, attribution_settings());
  REQUIRE_FALSE(report.chosen.empty());
  CHECK(report.chosen.front() == CandidateEffect::casing_mode);
  auto fitted = fitted_values(report, CandidateEffect::casing_mode);
  INFO("modes " << fitted["mode1_hz"] << ", " << fitted["mode2_hz"] << " Hz, zeta " << fitted["damping_ratio"] << ", "
                << fitted["modal_mass_kg"] << " kg");
  // Measured: 297.6 and 711.0 Hz (−0.8 %, +1.6 %), ζ 0.0294 (−2 %), 5.76 kg (+15 %). On spectra made
  // with the form itself the fit recovers all four within 2 % (the own-form case above), and ten times
  // the simplex's iterations end at the same point: the mass's 15 % is how the rig's records differ
  // from the twin's beyond the casing, weighed by the training cost (not located further).
  CHECK(fitted["mode1_hz"] == Approx(300).epsilon(0.02));
  CHECK(fitted["mode2_hz"] == Approx(700).epsilon(0.02));
  CHECK(fitted["damping_ratio"] == Approx(zeta).epsilon(0.05));
  CHECK(fitted["modal_mass_kg"] == Approx(mass_kg).epsilon(0.20));
  const auto& before = family(report.before, FamilyKind::mesh_harmonics);
  const auto& after = family(report.after, FamilyKind::mesh_harmonics);
  INFO("mesh harmonics " << before.distance_db << " -> " << after.distance_db << " dB");
  REQUIRE(before.significant);
  // Measured 2.70 → 0.40 dB.
  CHECK(after.distance_db < 0.2 * before.distance_db);
}

TEST_CASE("gap: noise_floor fitted on records with white noise of a known PSD recovers the PSD", "[gap]") {
  // One-sided PSD S of white noise with per-sample variance σ² at fs: S = 2σ²/fs. In the spectra a
  // 1-order bin holds 2·S·speed, so a floor fitted per order at one speed would be wrong at another
  // by their ratio; the form is in Hz and must find S from records at 8 and 14 Hz alike.
  const double fs = 10240, sigma = 0.02, psd = 2 * sigma * sigma / fs;
  CHECK(noise_floor_per_order_bin(psd, 10.0) == Approx(4 * sigma * sigma / 1024));  // the 4σ²/spr of a 1024-sample revolution
  std::vector<SummaryPair> training;
  std::uint64_t seed = 31;
  for (double speed : {8.0, 14.0}) {
    const auto twin = RecordSpectra(synthetic_record(fs, speed, 48, twin_tones()), 0, GearPairSpec{}).summary();
    const auto measured = RecordSpectra(synthetic_record(fs, speed, 48, twin_tones(), sigma, seed++), 0, GearPairSpec{}).summary();
    double total = 0;
    for (double v : twin.input_lines) total += v;
    training.push_back({measured, twin, total * std::pow(10.0, DiagnosisSettings{}.floor_db / 10.0)});
  }
  const auto fitted = fit_candidate(CandidateEffect::noise_floor, {}, training, GearPairSpec{});
  REQUIRE(fitted.size() == 1);
  // ±10 %: each 1-order bin has ~90 degrees of freedom (47 blocks, two half-order bins), and
  // thousands of bins are fitted at once; the synchronous means remove 1/R of the noise.
  CHECK(fitted[0] == Approx(psd).epsilon(0.10));
}

TEST_CASE("gap: the closed-form candidate (tip relief's per-harmonic gains) recovers its gains", "[gap]") {
  SECTION("tip_relief: one gain per mesh harmonic at the records' load") {
    // Values: the load (N·m), then the gains; the generated records are at 20 N·m.
    std::vector<double> values(static_cast<std::size_t>(tip_relief_harmonics(100000)) + 1, 0.0);
    values[0] = 20;
    for (std::size_t n = 0; n < 40; ++n) values[n + 1] = 8.0 * std::sin(0.7 * static_cast<double>(n));
    const auto fitted = fit_candidate(CandidateEffect::tip_relief, {}, generated(CandidateEffect::tip_relief, values), GearPairSpec{});
    REQUIRE(fitted.size() == values.size());
    CHECK(fitted[0] == 20.0);
    for (std::size_t n = 1; n <= 40; ++n) CHECK(fitted[n] == Approx(values[n]).margin(0.05));
  }
  SECTION("tip_relief: each training load has its own gains; a record takes the nearest load's") {
    // Records at 20 and at 5 N·m whose mesh harmonics change differently: the fit returns one group
    // per load, and a record at 7 N·m is changed as the 5 N·m group says.
    const std::size_t group = static_cast<std::size_t>(tip_relief_harmonics(100000)) + 1;
    std::vector<double> heavy(group, 0.0), light(group, 0.0);
    heavy[0] = 20, light[0] = 5;
    for (std::size_t n = 1; n <= 40; ++n) heavy[n] = 6.0, light[n] = -4.0 + 0.1 * static_cast<double>(n);
    auto pairs = generated(CandidateEffect::tip_relief, heavy);
    std::vector<double> both = heavy;
    both.insert(both.end(), light.begin(), light.end());
    for (auto p : generated(CandidateEffect::tip_relief, light)) {
      p.twin.torque_nm = 5;
      p.measured = apply_effects({{CandidateEffect::tip_relief, both}}, p.twin, GearPairSpec{});
      pairs.push_back(std::move(p));
    }
    const auto fitted = fit_candidate(CandidateEffect::tip_relief, {}, pairs, GearPairSpec{});
    REQUIRE(fitted.size() == 2 * group);
    CHECK(fitted[0] == 20.0);
    CHECK(fitted[group] == 5.0);
    for (std::size_t n = 1; n <= 40; ++n) {
      CHECK(fitted[n] == Approx(6.0).margin(0.05));
      CHECK(fitted[group + n] == Approx(light[n]).margin(0.05));
    }
    auto at_seven = twin_summary(8.0);
    at_seven.torque_nm = 7;
    const auto changed = apply_effects({{CandidateEffect::tip_relief, fitted}}, at_seven, GearPairSpec{});
    for (std::size_t n = 1; n <= 40 && n * kZ1 <= at_seven.input_lines.size(); ++n)
      CHECK(10 * std::log10(changed.input_lines[n * kZ1 - 1] / at_seven.input_lines[n * kZ1 - 1]) ==
            Approx(light[n]).margin(0.05));
    CHECK(parameter_names(candidate_form(CandidateEffect::tip_relief, 100000), fitted)[group] == "load_2_nm");
  }
}

TEST_CASE("gap: gap bench's scenario 21 (casing at 151 and 396 Hz, 67 kg): its casing candidate recovers all four values", "[gap]") {
  // The casing fit's grid has cells ×2.9 apart in Hz. Here its best starts all have both modes in
  // the 396 Hz cell and differ in damping or mass; descents from two of them ended with a mode at
  // 264 Hz. The first mode sits on the first mesh harmonic of the 8 Hz training records (152 Hz).
  // The scenario's held-out records (11 and 17 Hz) show it too little for a choice (docs/gap-bench.md), so
  // what is checked is the candidate as ranked, against the truth the bench reports beside it.
  const auto r = gearwatch::testing::run_command(std::string(GEARWATCH_BINARY) +
                                                 " gap bench --seeds 1 --first-seed 21 --no-effect-runs 0 --sample-rate 100000 --format json");
  REQUIRE(r.status == 0);
  const auto scenario = nlohmann::json::parse(r.out)["scenarios"].at(0);
  REQUIRE(scenario["truth"].front() == "casing");
  const auto& truth = scenario["parameters"];
  const auto candidate = std::find_if(scenario["candidates"].begin(), scenario["candidates"].end(),
                                      [](const auto& c) { return c["effect"] == "casing_mode"; });
  REQUIRE(candidate != scenario["candidates"].end());
  const auto& fitted = (*candidate)["parameters"];
  INFO("truth " << truth.dump() << "; fitted " << fitted.dump());
  REQUIRE(truth["casing.mode1_hz"].get<double>() == Approx(151.19).epsilon(0.001));
  // Measured: 151.04 and 395.93 Hz, ζ 0.0523 and 66.92 kg for 151.19, 395.99, 0.0514 and 67.04.
  CHECK(fitted["mode1_hz"].get<double>() == Approx(truth["casing.mode1_hz"].get<double>()).epsilon(0.01));
  CHECK(fitted["mode2_hz"].get<double>() == Approx(truth["casing.mode2_hz"].get<double>()).epsilon(0.01));
  CHECK(fitted["damping_ratio"].get<double>() == Approx(truth["casing.damping_ratio"].get<double>()).epsilon(0.05));
  CHECK(fitted["modal_mass_kg"].get<double>() == Approx(truth["casing.modal_mass_kg"].get<double>()).epsilon(0.02));
}

TEST_CASE("gap: gap bench with a few seeds writes the scores as JSON", "[gap]") {
  const auto r = gearwatch::testing::run_command(std::string(GEARWATCH_BINARY) +
                             " gap bench --seeds 4 --no-effect-runs 1 --effects 1 --sample-rate 50000 --seconds 1.5 "
                             "--bootstrap 30 --format json");
  REQUIRE(r.status == 0);
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"top1_accuracy", "top2_accuracy", "median_shrinkage", "false_alarm_rate", "k_wear_bias_before",
                          "k_wear_bias_after", "per_effect"})
    CHECK(j.contains(key));
  // Seeds 1–4 are casing, tooth_errors, eccentricity and tip_relief, each with random parameters.
  CHECK(j["per_effect"].size() == 4);
  const double false_alarms = j["false_alarm_rate"];
  const double top1 = j["top1_accuracy"];
  const double shrinkage = j["median_shrinkage"];
  // The targets scaled to these runs: top-1 >= 90 % of 4 seeds is all 4, and no
  // significant gap on the no-effect run.
  CHECK(false_alarms == 0.0);
  CHECK(top1 == 1.0);
  // The held-out shrinkage target (median >= 0.70) is met over 30 seeds at 100 kHz
  // (0.758, docs/gap.md); these 4 short 50 kHz scenarios give 0.64-0.74 (median 0.67), so it is not
  // asserted here. What must hold for every scenario is that adding the truth's own effect brings its
  // families closer on held-out records.
  CHECK(shrinkage > 0.0);
  // The rig's effect names and the candidates' differ in three places (docs/gap.md).
  const std::map<std::string, std::string> candidate_of{{"casing", "casing_mode"}, {"noise", "noise_floor"}, {"mounting", "mount_resonance"}};
  for (const auto& scenario : j["scenarios"]) {
    INFO(scenario.dump());
    const std::string truth = scenario["truth"].front();
    REQUIRE_FALSE(scenario["chosen"].empty());
    CHECK(scenario["chosen"].front() == (candidate_of.count(truth) ? candidate_of.at(truth) : truth));
    CHECK(scenario["shrinkage"].get<double>() > 0.0);
  }
  // Rig and twin share the wear state, so with no effect the twin's RMS_SA is the rig's and the K
  // inferred is the true one (to the two integrators' agreement).
  REQUIRE(j["k_wear_bias_no_effect"].is_number());
  CHECK(j["k_wear_bias_no_effect"].get<double>() < 0.05);
  CHECK(j["k_wear_bias_before"].is_number());
  CHECK(j["k_wear_bias_after"].is_number());

  // The headline scores (docs/gap-bench.md, "What the records can show") recounted here from the
  // per-scenario trace: the first named effect among those with a signature of their own; nothing
  // significant and nothing named without one or without an effect; the median shrinkage over the
  // identifiable scenarios with one.
  auto name_of = [&](const nlohmann::json& rig_name) {
    const std::string n = rig_name;
    return candidate_of.count(n) ? candidate_of.at(n) : n;
  };
  int named = 0, with_trace = 0, silent = 0, without_trace = 0;
  std::vector<double> shrinks;
  for (const auto& scenario : j["scenarios"]) {
    const auto& own = scenario["identifiable_effects"];
    CHECK(scenario["identifiable"] == !own.empty());
    if (own.empty()) {
      ++without_trace;
      silent += !scenario["detected"].get<bool>() && scenario["chosen"].empty();
      continue;
    }
    ++with_trace;
    bool first_is_own = false;
    for (const auto& e : own) first_is_own |= !scenario["chosen"].empty() && scenario["chosen"].front() == name_of(e);
    named += first_is_own;
    if (scenario["shrinkage"].is_number()) shrinks.push_back(scenario["shrinkage"]);
  }
  int alarms = 0;
  for (const auto& q : j["no_effect_scenarios"]) alarms += q["detected"].get<bool>() || !q["chosen"].empty();
  const auto& scores = j["scores"];
  CHECK(scores["identifiable_named"]["part"] == named);
  CHECK(scores["identifiable_named"]["whole"] == with_trace);
  CHECK(scores["non_identifiable_silent"]["part"] == silent);
  CHECK(scores["non_identifiable_silent"]["whole"] == without_trace);
  CHECK(scores["no_effect_false_alarms"]["part"] == alarms);
  CHECK(scores["no_effect_false_alarms"]["whole"] == 1);
  std::sort(shrinks.begin(), shrinks.end());
  REQUIRE(scores["shrinkage"]["whole"] == shrinks.size());
  REQUIRE_FALSE(shrinks.empty());
  const std::size_t n = shrinks.size();
  CHECK(scores["shrinkage"]["value"].get<double>() ==
        Approx(n % 2 ? shrinks[n / 2] : 0.5 * (shrinks[n / 2 - 1] + shrinks[n / 2])).epsilon(1e-12));
  // One effect per scenario: no two-effect figure.
  CHECK(scores["both_named"]["whole"] == 0);
  CHECK(scores["both_named"]["value"].is_null());
  // The targets scaled to 4 scenarios and 1 no-effect run: >= 95 % of those with a signature is
  // all of them; the no-effect run silent.
  CHECK(named == with_trace);
  CHECK(alarms == 0);
  CHECK(scores["identifiable_named"]["met"] == (with_trace > 0));
  CHECK(scores["no_effect_false_alarms"]["met"] == true);
}

TEST_CASE("gap: gap bench refuses a practical minimum that is negative or not a number, before simulating", "[gap]") {
  for (const char* option : {"--min-gap-db -0.5", "--min-residual-gap-db nan"}) {
    INFO(option);
    const auto r = gearwatch::testing::run_command(std::string(GEARWATCH_BINARY) + " gap bench --seeds 1 " + option);
    CHECK(r.status == 1);
    CHECK(r.err.find("--min-gap-db and --min-residual-gap-db must be finite and >= 0") != std::string::npos);
  }
}

}  // namespace test_gap
