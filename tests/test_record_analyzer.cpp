#include "gearwatch/dsp/record_analyzer.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <set>
#include <vector>

#include "am_noise_record.hpp"

namespace test_record_analyzer {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::dsp;

namespace {
constexpr double kPi = std::numbers::pi;

struct SyntheticRig {
  double fs = 50000.0, duration = 4.0, f0 = 20.0, depth = 0.03, fm = 0.5;
  double mesh1 = 1.0, mesh2 = 0.5, output_order1 = 0.3, noise = 0.2, modulated = 0.2;
  double resonance_hz = 6000.0;
  int edges_per_rev = 1;
  // Analytic shaft angle of f(t) = f0 (1 + depth sin(2 pi fm t)), in revolutions.
  double angle(double t) const { return f0 * t - f0 * depth / (2 * kPi * fm) * (std::cos(2 * kPi * fm * t) - 1); }
  double speed(double t) const { return f0 * (1 + depth * std::sin(2 * kPi * fm * t)); }
};

// Also returns the stochastic part (noise + modulated resonance) to check the residual against.
Record make_record(const SyntheticRig& p, std::vector<double>* stochastic = nullptr, unsigned seed = 1) {
  const auto n = std::size_t(p.fs * p.duration);
  Record r;
  r.sample_rate_hz = p.fs;
  r.channels.assign(1, std::vector<float>(n));
  r.channel_numbers = {0};
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  const double fc = p.resonance_hz / p.fs, rr = 0.97;
  const double a1 = -2 * rr * std::cos(2 * kPi * fc), a2 = rr * rr;
  double y1 = 0, y2 = 0;
  if (stochastic) stochastic->resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = double(i) / p.fs;
    const double theta = p.angle(t);
    const double e = normal(rng);
    const double y = e - a1 * y1 - a2 * y2;
    y2 = y1;
    y1 = y;
    const double random_part = p.noise * normal(rng) + p.modulated * (1 + 0.8 * std::cos(2 * kPi * 19 * theta)) * y;
    const double value = p.mesh1 * std::cos(2 * kPi * 19 * theta) + p.mesh2 * std::sin(2 * kPi * 38 * theta) +
                         p.output_order1 * std::cos(2 * kPi * theta * 19.0 / 52.0) + random_part;
    r.channels[0][i] = float(value);
    if (stochastic) (*stochastic)[i] = random_part;
  }
  // Tacho edges at angles (k + 0.2) / N, by Newton on the analytic angle.
  for (int k = 0;; ++k) {
    const double target = (k + 0.2) / p.edges_per_rev;
    double t = target / p.f0;
    for (int it = 0; it < 20; ++it) t -= (p.angle(t) - target) / p.speed(t);
    if (t * p.fs > double(n - 1)) break;
    r.tacho_edges[0].push_back(t * p.fs);
  }
  return r;
}

GearboxSpec make_rig(double fs) {
  GearboxSpec rig;
  rig.sample_rate_hz = fs;
  return rig;
}

}  // namespace

TEST_CASE("Record analyzer: known indicators on a synthetic gearbox record", "[dsp][record_analyzer]") {
  SyntheticRig p;
  std::vector<double> stochastic;
  const Record record = make_record(p, &stochastic);
  SignalProcessingSettings settings;
  settings.pitting_band = {2000, 13000};
  settings.abrasion_band = {15000, 24000};
  settings.mean_carrier_ranges = {{0, 25000}};
  RecordAnalyzer analyzer(make_rig(p.fs), settings);
  const ChannelAnalysis a = analyzer.analyze(record, 0);
  for (const auto& s : a.skipped) INFO("skipped " << s.name << ": " << to_string(s.reason));
  REQUIRE(a.skipped.empty());

  // Every documented name is produced exactly once.
  std::set<std::string> names;
  for (const auto& i : a.indicators) CHECK(names.insert(i.name).second);
  for (const auto& n : analyzer.indicator_names()) CHECK(names.count(n) == 1);

  // Raw RMS/kurtosis: the same formulas evaluated directly (double sums over the float samples).
  double s1 = 0, s2 = 0;
  for (float v : record.channels[0]) {
    s1 += v;
    s2 += double(v) * v;
  }
  const double n = double(record.sample_count());
  CHECK(*a.value("rms_raw") == Approx(std::sqrt(s2 / n)).epsilon(1e-12));

  // Speed from the tacho: the mean over the edges' span of the analytic profile.
  const auto& edges = record.tacho_edges[0];
  const double span_revs = double(edges.size() - 1);
  CHECK(*a.value("speed_mean_hz") == Approx(span_revs * p.fs / (edges.back() - edges.front())).epsilon(1e-12));
  CHECK(*a.value("speed_fluctuation") == Approx(2 * p.depth).epsilon(0.1));  // per-revolution means smooth the peaks
  CHECK(a.speed_profile_hz.size() == std::size_t(span_revs));
  CHECK(a.tsa_averages_input == std::floor(span_revs));
  CHECK(a.tsa_averages_output == std::floor(span_revs * 19 / 52));

  // Mesh harmonics: amplitudes 1.0 and 0.5 exactly in the signal. Errors: interpolation (< 1e-4)
  // and the noise near the mesh order: a sinusoid's amplitude estimated over N = 2e5 samples in
  // white noise of std sigma has std sigma sqrt(2/N); at 380 Hz only the white part (0.2) matters
  // (the resonance is at 6 kHz), so ~6e-4. 5e-3 is ~8 standard deviations.
  CHECK(*a.value("gmf1_amplitude") == Approx(1.0).margin(5e-3));
  CHECK(*a.value("gmf_harmonic_2") == Approx(0.5).margin(5e-3));
  CHECK(*a.value("gmf_harmonic_3") == Approx(0.0).margin(5e-3));
  CHECK(*a.value("rms_sa") == Approx(std::sqrt(1.25)).margin(5e-3));  // N = 2, Eq. 7.1

  // Residual: the stochastic part minus what the two TSAs absorb of it, a fraction
  // 1/R_in + 1/R_out of its power (white-ish noise), so rms ratio sqrt(1 - 1/R_in - 1/R_out).
  double r2 = 0;
  for (double v : stochastic) r2 += v * v;
  const double expected_ratio = std::sqrt(1 - 1 / a.tsa_averages_input - 1 / a.tsa_averages_output);
  // 2 %: the resonance's AR(2) power is concentrated near 6 kHz, so its share absorbed by the TSA
  // differs from the white-noise fraction by about that much, plus edge samples outside the
  // whole revolutions.
  CHECK(*a.value("rms_residual") / std::sqrt(r2 / double(stochastic.size())) == Approx(expected_ratio).epsilon(0.02));

  // The modulated resonance at 6 kHz sits in the pitting band: low-band ICS2 far above high-band,
  // and the ICS2-selected band contains 6 kHz.
  const double low = *a.value("ics2_low_band"), high = *a.value("ics2_high_band");
  INFO("ICS2 low " << low << " high " << high << " full " << *a.value("ics2_full_band"));
  CHECK(low > 20 * high);
  REQUIRE(a.band_selections.size() == 2);
  const auto& sel = a.band_selections[0];
  CHECK(std::string(to_string(sel.criterion)) == "ics2");
  CHECK(sel.centre_hz - sel.bandwidth_hz / 2 <= 6000.0 + 200.0);  // band edges are nominal
  CHECK(sel.centre_hz + sel.bandwidth_hz / 2 >= 6000.0 - 200.0);
  CHECK(*a.value("ics2_selected_band") >= low * 0.9);  // a narrower band around the burst does at least as well
  // Spectral coherence at the mesh order peaks in the resonance, and the mean carrier over
  // 0-25 kHz is pulled toward it from the range's centre.
  CHECK(std::abs(*a.value("sc_gmf_peak_carrier_hz") - 6000.0) < 1500.0);
  CHECK(*a.value("mean_carrier_hz_0_25000") < 12500.0);
  CHECK(*a.value("sc_gmf_max") > 0.3);
}

TEST_CASE("Record analyzer: bad input gives reasons, never a crash", "[dsp][record_analyzer]") {
  SyntheticRig p;
  p.duration = 2.0;
  const GearboxSpec rig = make_rig(p.fs);
  RecordAnalyzer analyzer(rig, SignalProcessingSettings{});
  auto reason = [](const ChannelAnalysis& a, const std::string& name) {
    const auto* s = a.skip_reason(name);
    return s ? std::string(to_string(s->reason)) : std::string("<computed>");
  };

  SECTION("defaults at 50 kHz: bands and ranges above 25 kHz are skipped as above Nyquist") {
    const auto a = analyzer.analyze(make_record(p), 0);
    CHECK(reason(a, "ics2_high_band") == "band_above_nyquist");   // 20-37 kHz
    CHECK(reason(a, "mean_carrier_hz_0_30000") == "band_above_nyquist");
    CHECK(reason(a, "mean_carrier_hz_0_50000") == "band_above_nyquist");
    CHECK(a.value("ics2_low_band").has_value());
  }
  SECTION("no tacho") {
    Record r = make_record(p);
    r.tacho_edges[0].clear();
    const auto a = analyzer.analyze(r, 0);
    CHECK(a.value("rms_raw").has_value());
    CHECK(reason(a, "gmf1_amplitude") == "no_tacho");
    CHECK(reason(a, "ics2_low_band") == "no_tacho");
    CHECK(a.speed_profile_hz.empty());
  }
  SECTION("missing tacho edge") {
    Record r = make_record(p);
    r.tacho_edges[0].erase(r.tacho_edges[0].begin() + 10);
    CHECK(reason(analyzer.analyze(r, 0), "rms_sa") == "tacho_irregular");
  }
  SECTION("NaN or Inf samples") {
    Record r = make_record(p);
    r.channels[0][1234] = std::nanf("");
    auto a = analyzer.analyze(r, 0);
    CHECK(a.indicators.empty());
    CHECK(reason(a, "rms_raw") == "non_finite_samples");
    r.channels[0][1234] = INFINITY;
    CHECK(reason(analyzer.analyze(r, 0), "kurtosis_raw") == "non_finite_samples");
  }
  SECTION("clipped samples") {
    Record r = make_record(p);
    const float full_scale = float(32767 * rig.channels[0].scale_m_s2_per_lsb);
    for (std::size_t i = 0; i < r.channels[0].size(); i += 1000) r.channels[0][i] = -full_scale;  // 0.1 %
    const auto a = analyzer.analyze(r, 0);
    CHECK(a.indicators.empty());
    CHECK(reason(a, "rms_raw") == "clipped_samples");
  }
  SECTION("speed outside the rig's range") {
    SyntheticRig fast = p;
    fast.f0 = 70.0;  // max 60 Hz
    const auto a = analyzer.analyze(make_record(fast), 0);
    CHECK(reason(a, "gmf1_amplitude") == "speed_out_of_range");
    CHECK(a.value("rms_raw").has_value());
  }
  SECTION("too few revolutions for a TSA") {
    SyntheticRig slow = p;
    slow.f0 = 2.0;
    slow.duration = 2.0;  // 4 revolutions < 5
    const auto a = analyzer.analyze(make_record(slow), 0);
    CHECK(reason(a, "rms_sa") == "too_few_revolutions");
    CHECK(reason(a, "ics2_low_band") == "too_few_revolutions");
    CHECK(a.value("speed_mean_hz").has_value());
  }
  SECTION("enough input but too few output-shaft revolutions") {
    SyntheticRig slow = p;
    slow.f0 = 6.0;
    slow.duration = 2.0;  // 12 input revs, 4.4 output revs
    const auto a = analyzer.analyze(make_record(slow), 0);
    CHECK(a.value("rms_sa").has_value());
    CHECK(reason(a, "rms_residual") == "too_few_revolutions");
  }
  SECTION("empty record and bad channel index") {
    Record r;
    r.sample_rate_hz = p.fs;
    r.channels.assign(1, {});
    CHECK(reason(analyzer.analyze(r, 0), "rms_raw") == "empty_record");
    CHECK_THROWS_AS(analyzer.analyze(r, 3), std::out_of_range);
  }
}

TEST_CASE("Signal-processing settings are validated with the setting's name", "[dsp][record_analyzer]") {
  const GearboxSpec rig;
  auto message = [&](SignalProcessingSettings s) -> std::string {
    try {
      s.validate(rig);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  SignalProcessingSettings s;
  CHECK(message(s).empty());
  s.rms_sa_harmonics = 11;
  CHECK(message(s).find("rms_sa_harmonics") != std::string::npos);
  s = {};
  s.samples_per_revolution = 97;  // prime: FFT sizes would be slow
  CHECK(message(s).find("samples_per_revolution") != std::string::npos);
  s.samples_per_revolution = 4096;
  CHECK(message(s).empty());
  s = {};
  s.pitting_band = {13000, 2000};
  CHECK(message(s).find("pitting_band") != std::string::npos);
  s = {};
  s.abrasion_band = {20000, 90000};  // above Nyquist: not a settings error (skipped per record)
  CHECK(message(s).empty());
  s = {};
  s.mean_carrier_ranges = {{0, 30000}, {0, 30000}};
  CHECK(message(s).find("duplicate") != std::string::npos);
  s = {};
  s.trend_significance = 0.0;
  CHECK(message(s).find("trend_significance") != std::string::npos);
  s = {};
  s.min_revolutions_for_tsa = 1;
  CHECK_THROWS_AS(RecordAnalyzer(rig, s), std::invalid_argument);
}

namespace {

// The capture of the ICS2 defect: one accelerometer, input shaft at a constant 10 Hz, 100 kHz,
// Gaussian noise band-limited (brick wall) to 4-11 kHz and amplitude-modulated at the mesh
// frequency (19 x 10 Hz) with depth a = 0.5, std 3000 LSB of the 0.01 m/s2 channel scale, then
// int16 quantisation and nothing else. Above ~11.2 kHz the record holds only quantisation noise,
// 85 dB below it.
Record am_noise_capture(unsigned seed) {
  const double fs = 100000.0, f0 = 10.0, a = 0.5, lsb = 0.01;
  const std::size_t n = 1000000;
  const auto noise = gearwatch::test::band_limited_am_noise(seed, fs, n, f0, a);
  const double scale = 3000.0 / noise.rms;
  Record r;
  r.sample_rate_hz = fs;
  r.channels.assign(1, std::vector<float>(n));
  r.channel_numbers = {0};
  for (std::size_t i = 0; i < n; ++i) r.channels[0][i] = float(double(std::lround(noise.x[i] * scale)) * lsb);
  r.tacho_edges[0] = gearwatch::test::steady_tacho_edges(f0, fs, n);
  return r;
}

std::string reason_of(const ChannelAnalysis& a, const std::string& name) {
  const auto* s = a.skip_reason(name);
  return s ? std::string(to_string(s->reason)) : std::string("<computed>");
}

}  // namespace

TEST_CASE("Record analyzer: no end-discontinuity clicks in bands 85 dB below an AM-noise record",
          "[dsp][record_analyzer]") {
  // Closed form of ICS2 (H >= 2) for AM noise: (a^2 + a^4/16) / (1 + a^2/2)^2 = 0.2006 at a = 0.5
  // (test_envelope.cpp derives it). Its estimation std here is sigma = 2 sqrt(g / (B L)) / a with
  // g = 1.40 (a = 0.5), B = 7.4 kHz / 100.8 kHz (angle-domain rate of 10080 samples/rev at 10 Hz),
  // L = 98 revolutions x 10080 = 987840 samples: sigma = 1.8 %; 4 sigma allowed.
  const double a = 0.5;
  const double closed_form = (a * a + std::pow(a, 4) / 16.0) / std::pow(1.0 + a * a / 2.0, 2);
  const double sigma = 2 * std::sqrt(1.40 / (7.4 / 100.8 * 987840.0)) / a;
  const Record record = am_noise_capture(7);

  SECTION("default floors: the quantisation-only high band is below the energy floor") {
    RecordAnalyzer analyzer(make_rig(100000.0), SignalProcessingSettings{});
    const auto r = analyzer.analyze(record, 0);
    REQUIRE(r.samples_per_revolution == 10080);
    CHECK(*r.value("ics2_low_band") == Approx(closed_form).epsilon(4 * sigma));
    CHECK(*r.value("ics2_full_band") == Approx(closed_form).epsilon(4 * sigma));
    // 20-37 kHz holds quantisation noise only: (0.01/sqrt(12))^2 x 17/50 against 30^2 m2/s4,
    // -85 dB, far below the -40 dB floor. Before the fix it read 2.79.
    CHECK(reason_of(r, "ics2_high_band") == "band_below_floor");
    // The selected band reads the carrier's modulation: 0.2006 inside it, and at most
    // (1/4) / (1 + a^2/2) = 0.222 on the first harmonic in a band on the carrier's edge (there
    // one sideband has no partner and a band's slope can rebalance the other pair), plus the
    // estimation noise of a narrow band. Before the fix: 2.04 in 12.6-13.7 kHz, on a click.
    REQUIRE(r.band_selections.size() == 2);
    const auto& sel = r.band_selections[0];
    INFO("selected " << sel.centre_hz - sel.bandwidth_hz / 2 << "-" << sel.centre_hz + sel.bandwidth_hz / 2
                     << " Hz, ICS2 " << sel.value);
    CHECK(sel.value > closed_form * (1 - 4 * sigma));
    CHECK(sel.value < 0.30);
    // The tree's filters pass ~1.6x their nominal band with a transition about one band wide, so
    // a band holding the carrier's energy lies within one bandwidth of 3.81-11.19 kHz (the
    // 4-11 kHz noise with its +-190 Hz sidebands).
    CHECK(sel.centre_hz - sel.bandwidth_hz / 2 < 11190.0 + sel.bandwidth_hz);
    CHECK(sel.centre_hz + sel.bandwidth_hz / 2 > 3810.0 - sel.bandwidth_hz);
  }
  SECTION("floor off: the white band reads white-noise ICS2 and no tree band reads a click") {
    SignalProcessingSettings settings;
    settings.band_energy_floor_db = -300.0;
    RecordAnalyzer analyzer(make_rig(100000.0), settings);
    const auto r = analyzer.analyze(record, 0);
    CHECK(*r.value("ics2_low_band") == Approx(closed_form).epsilon(4 * sigma));
    // Stationary noise: each SES bin in the 3 windows of +-3 bins has relative power
    // 1/(B L) = 1 / (17/100.8 x 987840) = 6.0e-6; the max of 7 exponentials is below
    // ln(7000) = 8.9 times that with probability 0.999, so ICS2 < 3 x 8.9 x 6.0e-6 = 1.6e-4.
    // An impulse (the click before the fix) reads H = 3; the fix measured 3.2e-5.
    const double high = *r.value("ics2_high_band");
    WARN("AM-noise capture, floor off: ICS2 high band " << high << ", selected " << *r.value("ics2_selected_band"));
    CHECK(high < 1.6e-4);
    // Every tree band is eligible now, the quantisation-only ones included: the largest reading
    // anywhere is still the carrier's modulation (its leakage through the filters' -55 dB
    // stopband dominates those bands), not a click (before the fix: 2.04).
    CHECK(*r.value("ics2_selected_band") < 0.30);
  }
}

TEST_CASE("Record analyzer: a residual at the numerical floor gives residual_below_floor", "[dsp][record_analyzer]") {
  // Noise-free casing signal: mesh orders 19 and 38 and the output shaft's first order, int16.
  // Both TSAs take all of it; what is left is quantisation (0.0029 m/s2) and interpolation residue.
  const double fs = 100000.0, f0 = 10.0, lsb = 0.01;
  const std::size_t n = 1000000;
  Record r;
  r.sample_rate_hz = fs;
  r.channels.assign(1, std::vector<float>(n));
  r.channel_numbers = {0};
  for (std::size_t i = 0; i < n; ++i) {
    const double theta = f0 * double(i) / fs;
    const double v = 3000 * std::cos(2 * kPi * 19 * theta) + 1000 * std::cos(2 * kPi * 38 * theta) +
                     500 * std::cos(2 * kPi * theta * 19.0 / 52.0);
    r.channels[0][i] = float(double(std::lround(v)) * lsb);
  }
  for (int k = 0;; ++k) {
    const double t = (k + 0.3) / f0 * fs;
    if (t > double(n - 1)) break;
    r.tacho_edges[0].push_back(t);
  }
  RecordAnalyzer analyzer(make_rig(fs), SignalProcessingSettings{});
  const auto a = analyzer.analyze(r, 0);
  const double raw_std = std::sqrt((3000.0 * 3000 + 1000.0 * 1000 + 500.0 * 500) / 2) * lsb;
  const double ratio = *a.value("rms_residual") / raw_std;
  WARN("noise-free casing signal: residual RMS / raw RMS = " << ratio);
  CHECK(ratio < 0.005);
  for (const char* name : {"ics2_full_band", "ics2_low_band", "ics2_high_band", "ics2_selected_band",
                           "kurtosis_selected_band", "sc_gmf_max", "mean_carrier_hz_0_30000"})
    CHECK(reason_of(a, name) == "residual_below_floor");
  CHECK(a.band_selections.empty());
  CHECK(*a.value("rms_sa") == Approx(std::sqrt(30.0 * 30.0 + 10.0 * 10.0)).epsilon(1e-3));
  // The floor is what skips them: with it at 0 the same record gives numbers.
  SignalProcessingSettings no_floor;
  no_floor.residual_rms_floor = 0.0;
  RecordAnalyzer unfloored(make_rig(fs), no_floor);
  CHECK(unfloored.analyze(r, 0).value("ics2_low_band").has_value());
}

TEST_CASE("Record analyzer: a flat channel gives flat_line, a live one does not", "[dsp][record_analyzer]") {
  SyntheticRig p;
  p.duration = 2.0;
  const GearboxSpec rig = make_rig(p.fs);
  const double lsb = rig.channels[0].scale_m_s2_per_lsb;
  RecordAnalyzer analyzer(rig, SignalProcessingSettings{});
  Record r = make_record(p);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal;
  SECTION("all samples equal") {
    std::fill(r.channels[0].begin(), r.channels[0].end(), float(123 * lsb));
    const auto a = analyzer.analyze(r, 0);
    CHECK(a.indicators.empty());
    for (const auto& name : analyzer.indicator_names()) CHECK(reason_of(a, name) == "flat_line");
  }
  SECTION("toggling by one LSB: standard deviation 0.5 LSB, at the default floor") {
    for (std::size_t i = 0; i < r.channels[0].size(); ++i) r.channels[0][i] = float(double(i % 2) * lsb);
    CHECK(reason_of(analyzer.analyze(r, 0), "rms_raw") == "flat_line");
  }
  SECTION("quantised noise of 2 LSB standard deviation is live") {
    for (auto& v : r.channels[0]) v = float(double(std::lround(2.0 * normal(rng))) * lsb);
    const auto a = analyzer.analyze(r, 0);
    CHECK(*a.value("rms_raw") == Approx(2.0 * lsb).epsilon(0.05));
  }
  SECTION("without a channel scale only an exactly constant channel is flat") {
    GearboxSpec unscaled = rig;
    unscaled.channels.clear();
    RecordAnalyzer a(unscaled, SignalProcessingSettings{});
    for (std::size_t i = 0; i < r.channels[0].size(); ++i) r.channels[0][i] = float(double(i % 2) * lsb);
    CHECK(a.analyze(r, 0).value("rms_raw").has_value());
    std::fill(r.channels[0].begin(), r.channels[0].end(), 0.0f);
    CHECK(reason_of(a.analyze(r, 0), "rms_raw") == "flat_line");
  }
}

TEST_CASE("Skip reasons: every enum value listed once, distinct snake_case tokens", "[dsp][record_analyzer]") {
  // The enumerators are consecutive from 0: the list must hold exactly 0..size-1, and the value
  // one past it is no enumerator (to_string's fallback).
  std::set<int> values;
  std::set<std::string> tokens;
  for (SkipReason r : kAllSkipReasons) {
    CHECK(values.insert(int(r)).second);
    const std::string token = to_string(r);
    CHECK(tokens.insert(token).second);
    CHECK(!token.empty());
    CHECK(token.front() != '_');
    CHECK(token.back() != '_');
    for (char c : token) CHECK(((c >= 'a' && c <= 'z') || c == '_'));
    CHECK(parse_skip_reason(token) == r);
  }
  CHECK(*values.begin() == 0);
  CHECK(*values.rbegin() == int(kAllSkipReasons.size()) - 1);
  CHECK(std::string(to_string(static_cast<SkipReason>(kAllSkipReasons.size()))) == "unknown");
  CHECK(!parse_skip_reason("filter_bank: too short").has_value());
  // Tokens already stored by earlier versions keep their spelling.
  for (const char* stored : {"empty_record", "bad_sample_rate", "non_finite_samples", "clipped_samples", "no_tacho",
                             "too_few_edges", "tacho_irregular", "speed_out_of_range", "too_few_revolutions",
                             "above_nyquist", "band_above_nyquist", "band_empty", "non_finite_result", "not_computed"})
    CHECK(parse_skip_reason(stored).has_value());
}

TEST_CASE("Record analyzer: the fixed indicator names are the stored spellings, and the analyzer names each", "[dsp][record_analyzer]") {
  // The stored names (docs/dsp.md), spelled out: a renamed enum value must not rename stored rows.
  const std::vector<std::pair<Indicator, std::string>> stored{
      {Indicator::rms_raw, "rms_raw"},
      {Indicator::kurtosis_raw, "kurtosis_raw"},
      {Indicator::speed_mean_hz, "speed_mean_hz"},
      {Indicator::speed_fluctuation, "speed_fluctuation"},
      {Indicator::gmf1_amplitude, "gmf1_amplitude"},
      {Indicator::rms_sa, "rms_sa"},
      {Indicator::rms_residual, "rms_residual"},
      {Indicator::kurtosis_residual, "kurtosis_residual"},
      {Indicator::ics2_full_band, "ics2_full_band"},
      {Indicator::ics2_low_band, "ics2_low_band"},
      {Indicator::ics2_high_band, "ics2_high_band"},
      {Indicator::ics2_selected_band, "ics2_selected_band"},
      {Indicator::kurtosis_selected_band, "kurtosis_selected_band"},
      {Indicator::sc_gmf_max, "sc_gmf_max"},
      {Indicator::sc_gmf_mean, "sc_gmf_mean"},
      {Indicator::sc_gmf_peak_carrier_hz, "sc_gmf_peak_carrier_hz"},
      {Indicator::input_speed_hz, "input_speed_hz"},
  };
  REQUIRE(stored.size() == kAllIndicators.size());
  for (std::size_t i = 0; i < stored.size(); ++i) {
    CHECK(kAllIndicators[i] == stored[i].first);
    CHECK(to_string(stored[i].first) == stored[i].second);
  }
  // Every one but the daemon's input_speed_hz is a name the analyzer produces (kurtogram on).
  SignalProcessingSettings settings;
  settings.kurtogram_band_selection = true;
  const RecordAnalyzer analyzer(make_rig(50000), settings);
  const auto names = analyzer.indicator_names();
  for (Indicator i : kAllIndicators) {
    INFO(to_string(i));
    CHECK(std::count(names.begin(), names.end(), std::string(to_string(i))) == (i == Indicator::input_speed_hz ? 0 : 1));
  }
}

}  // namespace test_record_analyzer
