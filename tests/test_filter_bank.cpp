#include "gearwatch/dsp/filter_bank.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace test_filter_bank {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::dsp;

namespace {

// The reference data lives beside the repository (shared/reference/fast-kurtogram); a missing
// folder must fail the test loudly, never skip it.
std::filesystem::path reference_dir() {
  return std::filesystem::path(GEARWATCH_SOURCE_DIR) / ".." / "shared" / "reference" / "fast-kurtogram";
}

std::vector<std::vector<std::string>> read_csv(const std::string& name) {
  const auto path = reference_dir() / name;
  std::ifstream in(path);
  if (!in) FAIL("fast-kurtogram reference file missing: " << path.string()
                << " (expected shared/reference/fast-kurtogram beside the source tree)");
  std::vector<std::vector<std::string>> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

std::vector<double> reference_signal() {
  std::vector<double> x;
  for (const auto& row : read_csv("signal.csv")) x.push_back(std::stod(row.at(0)));
  return x;
}

// Collects every band's trimmed samples' power and the optimum band's samples (for the
// subband-signal checks below), besides nothing else.
class PowerCriterion final : public BandCriterion {
 public:
  const char* name() const noexcept override { return "power"; }
  double evaluate(const FilterBankNode& node) override {
    Complex mean{};
    for (const auto& v : node.samples) mean += v;
    mean /= double(node.samples.size());
    double p = 0;
    for (const auto& v : node.samples) p += std::norm(v - mean);
    if (node.row == 7 && node.band_index == 5) optimum_band.assign(node.samples.begin(), node.samples.end());
    used[{node.row, node.band_index}] = node.samples.size();
    return p / double(node.samples.size());
  }
  std::vector<Complex> optimum_band;
  std::map<std::pair<int, int>, std::size_t> used;
};

}  // namespace

TEST_CASE("Filter bank filters equal the reference filters.csv", "[dsp][filter_bank]") {
  OneThirdBinaryFilterBank bank;
  const auto rows = read_csv("filters.csv");
  REQUIRE(rows.size() == 1 + 17 + 16 + 3 * 25);
  double worst = 0;
  for (std::size_t r = 1; r < rows.size(); ++r) {
    const std::string& name = rows[r][0];
    const auto index = std::size_t(std::stoi(rows[r][1]));
    const Complex expected(std::stod(rows[r][2]), std::stod(rows[r][3]));
    std::span<const Complex> taps = name == "h" ? bank.low() : name == "g" ? bank.high()
                                  : name == "h1" ? bank.ternary(0) : name == "h2" ? bank.ternary(1) : bank.ternary(2);
    REQUIRE(index < taps.size());
    worst = std::max(worst, std::abs(taps[index] - expected));
  }
  // Same formulas, but numpy's exp and libm's polar may round differently: agreement to a few
  // tens of ulps of the ~0.4 peak tap (ulp 5.6e-17).
  WARN("filter taps: max difference to filters.csv " << worst);
  CHECK(worst < 1e-14);
}

TEST_CASE("Kurtosis criterion reproduces the fast-kurtogram reference (MATLAB semantics)", "[dsp][filter_bank]") {
  const auto x = reference_signal();
  REQUIRE(x.size() == 49900);
  OneThirdBinaryFilterBank bank;
  for (int levels : {7, 5}) {
    KurtosisCriterion kurtosis;
    PowerCriterion power;
    BandCriterion* criteria[] = {&kurtosis, &power};
    std::vector<BandMap> maps(2);
    bank.analyse(x, levels, criteria, maps);
    const auto reference = read_csv("kurtogram_nlevel" + std::to_string(levels) + "_matlab_semantics_unclipped.csv");
    REQUIRE(reference.size() == maps[0].rows());
    double worst_relative = 0, worst_absolute_small = 0;
    for (std::size_t r = 0; r < maps[0].rows(); ++r) {
      REQUIRE(reference[r].size() == maps[0].columns());
      for (std::size_t c = 0; c < maps[0].columns(); ++c) {
        const double expected = std::stod(reference[r][c]);
        const double got = maps[0].at(r, c);
        // README tolerance: <= 1e-9 relative, or 1e-10 absolute near 0.
        if (std::abs(expected) > 0.1) worst_relative = std::max(worst_relative, std::abs(got / expected - 1));
        else worst_absolute_small = std::max(worst_absolute_small, std::abs(got - expected));
        if (!(std::abs(got - expected) <= std::max(1e-9 * std::abs(expected), 1e-10)))
          FAIL_CHECK("row " << r << " column " << c << ": " << got << " vs " << expected);
      }
    }
    WARN("nlevel " << levels << ": kurtogram max relative error " << worst_relative
                   << ", max absolute error on |K| <= 0.1 " << worst_absolute_small);
    const auto best = maps[0].optimum();
    CHECK(best.row == 7);
    CHECK(best.level == 4.0);
    CHECK(best.bandwidth_fraction == Approx(1.0 / 32));
    CHECK(best.centre_fraction == Approx(0.171875).epsilon(1e-15));
    CHECK(best.first_column == (levels == 7 ? 120u : 30u));
    CHECK(best.value == Approx(6.149001436518942).epsilon(1e-9));

    // Subband power (bands_*.csv, MATLAB-semantics power column) and samples used.
    const auto bands = read_csv("bands_nlevel" + std::to_string(levels) + ".csv");
    double worst_power = 0;
    for (std::size_t i = 1; i < bands.size(); ++i) {
      const int row = std::stoi(bands[i][0]);
      const int band = std::stoi(bands[i][2]);
      const int nbands = std::stoi(bands[i][3]);
      const auto column = std::size_t(band) * maps[1].columns() / std::size_t(nbands);
      const double expected = std::stod(bands[i][9]);
      worst_power = std::max(worst_power, std::abs(maps[1].at(std::size_t(row), column) / expected - 1));
      CHECK(power.used.at({row, band}) == std::size_t(std::stoul(bands[i][6])));
    }
    // README: power should match to about 1e-12 relative.
    CHECK(worst_power < 1e-11);
    if (levels == 7) {
      // The optimal band's complex samples: the reference gives the filtering routine's output
      // (which trims 24 samples for ternary branches but 16 for binary ones, as ours does here)
      // before its mean is removed; it equals our trimmed node for the binary row 7.
      const auto filtered = read_csv("filtered_optimal_band_nlevel7.csv");
      std::vector<Complex> expected;
      for (const auto& row : filtered) {
        if (row.size() < 2) continue;
        try {
          expected.emplace_back(std::stod(row[0]), std::stod(row[1]));
        } catch (const std::invalid_argument&) {  // header line
        }
      }
      REQUIRE(expected.size() == 3103);
      REQUIRE(power.optimum_band.size() == expected.size());
      double worst_sample = 0, peak = 0;
      for (std::size_t i = 0; i < expected.size(); ++i) {
        worst_sample = std::max(worst_sample, std::abs(power.optimum_band[i] - expected[i]));
        peak = std::max(peak, std::abs(expected[i]));
      }
      CHECK(worst_sample < 1e-12 * peak);
    }
  }
  // Too short for the requested depth: a clear error.
  std::vector<double> short_signal(100, 1.0);
  KurtosisCriterion k;
  BandCriterion* one[] = {&k};
  std::vector<BandMap> m(1);
  CHECK_THROWS_AS(bank.analyse(short_signal, 6, one, m), std::invalid_argument);
}

TEST_CASE("ICS2 band selection finds a modulated resonance burst in its band", "[dsp][filter_bank]") {
  // Angle-domain signal, 2048 samples/rev, 64 revolutions. Stationary white noise everywhere plus
  // noise through a resonance at fc = 0.28 x the sample rate (two-pole, r = 0.97: bandwidth
  // ~0.01 fs) amplitude-modulated at the gear-mesh order 19 (19/2048 = 0.0093 fs, so the
  // modulated burst occupies about [0.266, 0.294] fs, 0.028 fs wide). The tree's prototypes pass
  // about 1.6x their nominal band (-6 dB half-width 0.2 vs 0.125, reference README quirk 5), so a
  // band holds the burst with its sidebands when its nominal width is >= 0.028 / 1.6 = 0.0175 fs:
  // levels <= 4.585 (0.0208 fs). Deeper bands cut the sidebands; shallower ones add stationary
  // noise. The selection must contain fc, lie at a level in [3, 4.585], and beat the full-band
  // ICS2 by far.
  const std::size_t spr = 2048, revs = 64, n = spr * revs;
  std::mt19937_64 rng(99);
  std::normal_distribution<double> normal;
  std::vector<double> x(n);
  const double fc = 0.28, r = 0.97;
  const double a1 = -2 * r * std::cos(2 * std::numbers::pi * fc), a2 = r * r;
  double y1 = 0, y2 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double e = normal(rng);
    const double y = e - a1 * y1 - a2 * y2;
    y2 = y1;
    y1 = y;
    const double theta = double(i) / spr;
    x[i] = 2.0 * normal(rng) + 0.25 * (1 + std::cos(2 * std::numbers::pi * 19 * theta)) * y;
  }
  FftPlanCache plans;
  SquaredEnvelopeAnalyzer envelope(plans);
  Ics2Criterion ics2(envelope, plans, spr, Ics2Parameters{19.0, 2, 3});
  BandCriterion* criteria[] = {&ics2};
  std::vector<BandMap> maps(1);
  OneThirdBinaryFilterBank bank;
  bank.analyse(x, 6, criteria, maps);
  const auto best = maps[0].optimum();
  const double low = best.centre_fraction - best.bandwidth_fraction / 2;
  const double high = best.centre_fraction + best.bandwidth_fraction / 2;
  INFO("selected level " << best.level << " band [" << low << ", " << high << "] ICS2 " << best.value
                         << " full band " << maps[0].at(0, 0));
  WARN("ICS2 band selection: level " << best.level << " [" << low << ", " << high << "] fs, ICS2 " << best.value
                                     << " vs full band " << maps[0].at(0, 0));
  CHECK(low <= fc);
  CHECK(high >= fc);
  CHECK(best.level >= 3.0);
  CHECK(best.level <= 4.585);
  CHECK(best.value > 5 * maps[0].at(0, 0));
  // Upper bound: ICS2 of a (1 + cos) modulation with H = 2 is (1 + 1/16) / 1.5^2 = 0.472 with no
  // noise, and stationary noise in the band only lowers it (10 % allowed for estimation noise).
  // Lower bound: the resonance's AR(2) variance is 9.6, so the modulated part has power
  // P = 0.25^2 x 9.6 = 0.6 (times 1.5 for the (1+cos)^2 mean); white noise of variance 4 gives
  // ~4 x 2 x 0.033 = 0.27 in a 0.0208-wide band passing 1.6x that. ICS2 = P^2 (1 + 1/16) /
  // (1.5 P + 0.27)^2 = 0.27; we require > 0.1.
  CHECK(best.value < 0.472 * 1.1);
  CHECK(best.value > 0.1);
}

TEST_CASE("Band power criterion: a sinusoid's power through the node's filter", "[dsp][filter_bank]") {
  // A cos(2 pi f n) through the complex level-1 low filter h: c = (A/2)(H(f) e^{j..} + H(-f) e^{-j..}),
  // so 2 mean|c|^2 = (A^2/2)(|H(f)|^2 + |H(-f)|^2) (the cross term averages out). H is the DTFT
  // of the taps, computed directly here.
  const std::size_t n = 65536;
  const double amplitude = 3.0;
  OneThirdBinaryFilterBank bank;
  auto response = [&](std::span<const Complex> taps, double f) {
    Complex h{};
    for (std::size_t k = 0; k < taps.size(); ++k) h += taps[k] * std::polar(1.0, -2 * std::numbers::pi * f * double(k));
    return std::norm(h);
  };
  for (double f : {0.05, 0.1, 0.2, 0.3}) {
    std::vector<double> x(n);
    for (std::size_t i = 0; i < n; ++i) x[i] = amplitude * std::cos(2 * std::numbers::pi * f * double(i));
    BandPowerCriterion power;
    BandCriterion* criteria[] = {&power};
    std::vector<BandMap> maps(1);
    bank.analyse(x, 2, criteria, maps);
    const double expected_low = amplitude * amplitude / 2 * (response(bank.low(), f) + response(bank.low(), -f));
    const double expected_high = amplitude * amplitude / 2 * (response(bank.high(), f) + response(bank.high(), -f));
    INFO("f = " << f);
    CHECK(maps[0].at(0, 0) == Approx(amplitude * amplitude / 2).epsilon(1e-4));
    // Row 1 column 0 is the low band, the last column the high band. The 1/N leftover of the
    // cross term and the mean removal allow 1e-3 relative (or 1e-6 of the total power).
    CHECK(maps[0].at(1, 0) == Approx(expected_low).epsilon(1e-3).margin(1e-6 * amplitude * amplitude));
    CHECK(maps[0].at(1, maps[0].columns() - 1) == Approx(expected_high).epsilon(1e-3).margin(1e-6 * amplitude * amplitude));
  }
}

TEST_CASE("Band selection ignores bands below the power floor and says when none is left", "[dsp][filter_bank]") {
  // Angle domain, 1024 samples/rev, 128 revolutions. A strong carrier: noise in [0.04, 0.11] fs
  // amplitude-modulated at order 19 with a = 0.5 (ICS2 0.2006 in closed form, up to ~0.24 at its
  // edges). A weak band, 47 dB below it: noise in [0.35, 0.45] fs fully modulated (a = 1, ICS2
  // 0.472), still above the carrier's leakage through the filters (-55 dB and less that far).
  // Without a floor the weak band wins; with the -40 dB floor the carrier does.
  const std::size_t spr = 1024, revs = 128, n = spr * revs;
  FftPlanCache plans;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal;
  auto band_noise = [&](double lo, double hi) {
    const RealFft& fft = plans.real(n);
    ComplexBuffer spectrum(fft.spectrum_size());
    for (std::size_t k = 0; k < spectrum.size(); ++k) {
      const double f = double(k) / double(n);
      spectrum[k] = f >= lo && f <= hi ? Complex(normal(rng), normal(rng)) : Complex{};
    }
    RealBuffer x(n);
    fft.inverse(spectrum, x);
    double p = 0;
    for (double v : x) p += v * v;
    for (double& v : x) v /= std::sqrt(p / double(n));
    return x;
  };
  const RealBuffer carrier = band_noise(0.04, 0.11), weak = band_noise(0.35, 0.45);
  const double weak_gain = std::pow(10.0, -47.0 / 20.0);
  std::vector<double> x(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double mesh = std::cos(2 * std::numbers::pi * 19 * double(i) / double(spr));
    x[i] = (1 + 0.5 * mesh) * carrier[i] + weak_gain * (1 + mesh) * weak[i];
  }
  SquaredEnvelopeAnalyzer envelope(plans);
  Ics2Criterion ics2(envelope, plans, spr, Ics2Parameters{19.0, 3, 3});
  BandPowerCriterion power;
  BandCriterion* criteria[] = {&ics2, &power};
  std::vector<BandMap> maps(2);
  OneThirdBinaryFilterBank bank;
  bank.analyse(x, 6, criteria, maps);

  const auto unfloored = maps[0].optimum();
  const double unfloored_centre = unfloored.centre_fraction;
  INFO("no floor: centre " << unfloored_centre << " ICS2 " << unfloored.value);
  CHECK(unfloored.found);
  CHECK(unfloored_centre > 0.3);
  CHECK(unfloored.value > 0.35);

  const auto floored = maps[0].optimum(0.5, &maps[1], std::pow(10.0, -40.0 / 10.0));
  const double low = floored.centre_fraction - floored.bandwidth_fraction / 2;
  const double high = floored.centre_fraction + floored.bandwidth_fraction / 2;
  WARN("power floor -40 dB: selected [" << low << ", " << high << "] fs, ICS2 " << floored.value
                                        << " (without floor: centre " << unfloored_centre << ", " << unfloored.value << ")");
  CHECK(floored.found);
  CHECK(high > 0.04 - floored.bandwidth_fraction);  // within one bandwidth of the carrier
  CHECK(low < 0.11 + floored.bandwidth_fraction);
  CHECK(floored.value > 0.2006 * 0.9);
  CHECK(floored.value < 0.30);
  const double selected_power = maps[1].at(std::size_t(floored.row), floored.first_column);
  CHECK(selected_power >= 1e-4 * maps[1].at(0, 0));

  // A floor above the whole signal's power leaves nothing.
  CHECK_FALSE(maps[0].optimum(0.5, &maps[1], 2.0).found);
  // A power map of another layout is a programming error.
  BandMap other = maps[1];
  other.levels = 5;
  CHECK_THROWS_AS(maps[0].optimum(0.5, &other, 0.0), std::invalid_argument);
}

TEST_CASE("Band gate: the optima and the power map as without it and the other bands not evaluated", "[dsp][filter_bank]") {
  // Reference: the same bank without the gate, where optimum() applies the same rule afterwards.
  const std::size_t spr = 512, revs = 64, n = spr * revs;
  std::mt19937_64 rng(23);
  std::normal_distribution<double> normal;
  std::vector<double> x(n);
  double y1 = 0, y2 = 0;
  const double fc = 0.12, r = 0.97;
  const double a1 = -2 * r * std::cos(2 * std::numbers::pi * fc), a2 = r * r;
  for (std::size_t i = 0; i < n; ++i) {
    const double y = normal(rng) - a1 * y1 - a2 * y2;
    y2 = y1;
    y1 = y;
    x[i] = 0.01 * normal(rng) + (1 + 0.5 * std::cos(2 * std::numbers::pi * 19 * double(i) / double(spr))) * y;
  }
  FftPlanCache plans;
  SquaredEnvelopeAnalyzer envelope(plans);
  Ics2Criterion ics2(envelope, plans, spr, Ics2Parameters{19.0, 3, 3});
  BandPowerCriterion power;
  KurtosisCriterion kurtosis;
  BandCriterion* criteria[] = {&power, &ics2, &kurtosis};
  OneThirdBinaryFilterBank bank;
  std::vector<BandMap> plain(3), gated(3);
  const double max_high = 0.4, floor_fraction = 1e-3;
  bank.analyse(x, 5, criteria, plain);
  bank.analyse(x, 5, criteria, gated, BandGate{0, max_high, floor_fraction});
  CHECK(gated[0].values == plain[0].values);
  std::size_t not_evaluated = 0;
  for (std::size_t i = 0; i < plain[1].values.size(); ++i) {
    if (std::isnan(gated[1].values[i])) {
      ++not_evaluated;
      CHECK(std::isnan(gated[2].values[i]));
    } else {
      CHECK(gated[1].values[i] == plain[1].values[i]);
      CHECK(gated[2].values[i] == plain[2].values[i]);
    }
  }
  WARN("band gate: " << not_evaluated << " of " << plain[1].values.size() << " map entries not evaluated");
  CHECK(not_evaluated > 0);
  for (std::size_t m : {1u, 2u}) {
    const auto a = plain[m].optimum(max_high, &plain[0], floor_fraction);
    const auto b = gated[m].optimum(max_high, &gated[0], floor_fraction);
    CHECK(a.found == b.found);
    CHECK(a.row == b.row);
    CHECK(a.first_column == b.first_column);
    CHECK(a.value == b.value);
  }
  BandCriterion* no_power[] = {&ics2};
  std::vector<BandMap> one(1);
  CHECK_THROWS_AS(bank.analyse(x, 5, no_power, one, BandGate{1, 0.5, 0.0}), std::invalid_argument);
}

}  // namespace test_filter_bank

namespace test_filter_bank {

namespace {

// Keeps the trimmed samples of the binary rows 1 and 3 (every band).
class BinaryRowsCriterion final : public BandCriterion {
 public:
  const char* name() const noexcept override { return "binary rows"; }
  double evaluate(const FilterBankNode& node) override {
    if (node.row == 1 || node.row == 3) bands[{node.row, node.band_index}].assign(node.samples.begin(), node.samples.end());
    return 0.0;
  }
  std::map<std::pair<int, int>, std::vector<Complex>> bands;
};

// The binary split as the reference writes it: MATLAB filter() with the complex taps (causal, zero
// initial state) kept at n = 2m + 1, the high half times (-1)^(m+1), every tap its own product.
std::pair<std::vector<Complex>, std::vector<Complex>> direct_binary_split(const std::vector<Complex>& c,
                                                                          std::span<const Complex> h,
                                                                          std::span<const Complex> g) {
  std::vector<Complex> a(c.size() / 2), d(c.size() / 2);
  for (std::size_t m = 0; m < a.size(); ++m) {
    const std::size_t n = 2 * m + 1;
    for (std::size_t k = 0; k < h.size() && k <= n; ++k) a[m] += h[k] * c[n - k];
    for (std::size_t k = 0; k < g.size() && k <= n; ++k) d[m] += g[k] * c[n - k];
    if (m % 2 == 0) d[m] = -d[m];
  }
  return {a, d};
}

}  // namespace

TEST_CASE("Binary split with folded linear-phase taps equals the direct convolution with every tap", "[dsp][filter_bank]") {
  // The split sums the two samples sharing a tap of the symmetric prototype before multiplying:
  // the same values up to rounding, so within 1e-13 of each band's peak (a few hundred ulps).
  std::mt19937_64 rng(38);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<double> x(4099);  // odd, so both rows end with an odd output count somewhere
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = noise(rng) + 0.5 * std::sin(0.3 * double(i));
  OneThirdBinaryFilterBank bank;
  BinaryRowsCriterion rows;
  BandCriterion* criteria[] = {&rows};
  std::vector<BandMap> maps(1);
  bank.analyse(x, 3, criteria, maps);

  const double mean = std::accumulate(x.begin(), x.end(), 0.0) / double(x.size());
  std::vector<Complex> root;
  for (double v : x) root.emplace_back(v - mean, 0.0);
  const auto [a, d] = direct_binary_split(root, bank.low(), bank.high());
  const auto [aa, ad] = direct_binary_split(a, bank.low(), bank.high());
  const auto [da, dd] = direct_binary_split(d, bank.low(), bank.high());
  const std::map<std::pair<int, int>, const std::vector<Complex>*> expected{
      {{1, 0}, &a}, {{1, 1}, &d}, {{3, 0}, &aa}, {{3, 1}, &ad}, {{3, 2}, &da}, {{3, 3}, &dd}};
  for (const auto& [key, full] : expected) {
    const std::size_t trim = key.second % 2 == 0 ? 16 : 15;
    REQUIRE(rows.bands.count(key) == 1);
    const auto& got = rows.bands.at(key);
    REQUIRE(got.size() == full->size() - trim);
    double worst = 0, peak = 0;
    for (std::size_t i = 0; i < got.size(); ++i) {
      worst = std::max(worst, std::abs(got[i] - (*full)[i + trim]));
      peak = std::max(peak, std::abs((*full)[i + trim]));
    }
    INFO("row " << key.first << " band " << key.second << ": worst " << worst << ", peak " << peak);
    CHECK(peak > 0.1);
    CHECK(worst <= 1e-13 * peak);
  }
}

}  // namespace test_filter_bank
