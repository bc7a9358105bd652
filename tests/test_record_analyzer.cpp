#include "gearwatch/dsp/record_analyzer.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <random>
#include <set>
#include <vector>

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

RigSpec make_rig(double fs) {
  RigSpec rig;
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
  CHECK(sel.criterion == "ics2");
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
  const RigSpec rig = make_rig(p.fs);
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
  const RigSpec rig;
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
