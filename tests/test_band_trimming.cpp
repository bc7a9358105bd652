// Any acquisition rate: carrier bands reaching past 0.45·fs are trimmed to it (noted), bands
// mostly or wholly above are skipped with band_above_nyquist, and the wear verdict from the
// pitting band alone names the band it cannot see.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "gearwatch/dsp/record_analyzer.hpp"
#include "gearwatch/dsp/wear_mechanism.hpp"

#include "am_noise_record.hpp"

namespace test_band_trimming {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::dsp;

namespace {

// One accelerometer at 25.6 kHz, input shaft at a constant 10 Hz, 10 s: Gaussian noise
// band-limited (brick wall) to 4-11 kHz, amplitude-modulated at the mesh frequency (19 x 10 Hz)
// with depth a = 0.5. Everything lies inside the trimmed pitting band (2-11.52 kHz).
Record am_noise_record(unsigned seed, double a) {
  const double fs = 25600.0, f0 = 10.0;
  const std::size_t n = 256000;
  const auto noise = gearwatch::test::band_limited_am_noise(seed, fs, n, f0, a);
  Record r;
  r.sample_rate_hz = fs;
  r.channels.assign(1, std::vector<float>(n));
  r.channel_numbers = {0};
  const double scale = 30.0 / noise.rms;  // 30 m/s² RMS
  for (std::size_t i = 0; i < n; ++i) r.channels[0][i] = float(noise.x[i] * scale);
  r.tacho_edges[0] = gearwatch::test::steady_tacho_edges(f0, fs, n);
  return r;
}

GearboxSpec rig_at(double fs) {
  GearboxSpec rig;
  rig.sample_rate_hz = fs;
  return rig;
}

}  // namespace

TEST_CASE("Band trimming: at 25.6 kHz the pitting band is analysed up to 0.45 fs, the abrasion band skipped",
          "[dsp][record_analyzer][band_trimming]") {
  const double a = 0.5;
  // Closed form (H >= 2): (a² + a⁴/16) / (1 + a²/2)² = 0.2006 (am_noise_ics2). Its estimation std
  // (test_record_analyzer.cpp's AM-noise capture): sigma = 2 sqrt(g / (B L)) / a with g = 1.40 at
  // a = 0.5, B = 7.4 kHz (the noise and its sidebands) over the angle-domain rate (spr samples per
  // revolution x 10 Hz; spr = 2592, the smallest 2·3·5·7-smooth size above 25600 / 9.99...), L = 98
  // revolutions x spr samples: 1.8 %; 4 sigma allowed.
  const double closed_form = am_noise_ics2(a, 3);
  const Record record = am_noise_record(11, a);
  RecordAnalyzer analyzer(rig_at(25600.0), SignalProcessingSettings{});  // bands 2-13 kHz and 20-37 kHz
  const ChannelAnalysis r = analyzer.analyze(record, 0);
  const double spr = double(r.samples_per_revolution);
  REQUIRE(spr >= 2560);
  const double sigma = 2 * std::sqrt(1.40 / (7.4 / (spr * 10.0 / 1000.0) * 98.0 * spr)) / a;
  REQUIRE(r.value("ics2_low_band"));
  INFO("ICS2 of the trimmed pitting band " << *r.value("ics2_low_band") << ", closed form " << closed_form);
  CHECK(*r.value("ics2_low_band") == Approx(closed_form).epsilon(4 * sigma));
  // The trim is said, with the band used: 0.45 x 25.6 kHz = 11520 Hz.
  REQUIRE(r.notes.size() == 1);
  CHECK(r.notes[0].name == "ics2_low_band");
  CHECK(r.notes[0].note == IndicatorNote::band_trimmed);
  CHECK(r.notes[0].detail == "2000-11520 Hz analysed of 2000-13000 Hz");
  CHECK(std::string(to_string(IndicatorNote::band_trimmed)) == "band_trimmed");
  // 20-37 kHz lies wholly above 11520 Hz.
  const auto* high = r.skip_reason("ics2_high_band");
  REQUIRE(high != nullptr);
  CHECK(high->reason == SkipReason::band_above_nyquist);
  CHECK(high->detail == "20000-37000 Hz: 0 % of it below 11520 Hz");
  // The selected band stays below 0.45 fs too.
  for (const auto& b : r.band_selections) CHECK(b.centre_hz + b.bandwidth_hz / 2 <= 11520.0 + 1e-6);
}

TEST_CASE("Band trimming: a band with less than half of it below 0.45 fs is skipped, not trimmed",
          "[dsp][record_analyzer][band_trimming]") {
  const Record record = am_noise_record(12, 0.5);
  SignalProcessingSettings settings;
  settings.pitting_band = {2000, 30000};  // 9520 of 28000 Hz below 11520 Hz: 34 %
  RecordAnalyzer analyzer(rig_at(25600.0), settings);
  const ChannelAnalysis r = analyzer.analyze(record, 0);
  const auto* low = r.skip_reason("ics2_low_band");
  REQUIRE(low != nullptr);
  CHECK(low->reason == SkipReason::band_above_nyquist);
  CHECK(low->detail == "2000-30000 Hz: 34 % of it below 11520 Hz");
  CHECK(r.notes.empty());
}

TEST_CASE("Wear verdict from the pitting band alone names the abrasion band it cannot see", "[dsp][wear_mechanism]") {
  SignalProcessingSettings settings;
  const std::size_t needed = minimum_points_for_evidence(settings.trend_significance);
  // A flat pitting band (alternating readings: no rise) and no abrasion readings at all.
  std::vector<WearHistoryPoint> flat;
  for (std::size_t i = 0; i < needed + 5; ++i)
    flat.push_back({double(i) * 1e5, 0.02 + 0.001 * double(i % 2), std::nan(""), std::nan(""), std::nan("")});
  // The two-band rule cannot decide: one band has no verdict (kept as it was).
  CHECK(identify_wear_mechanism(flat, settings).mechanism == WearMechanism::undetermined);
  const auto v = identify_wear_mechanism(flat, settings, CarrierBand::abrasion);
  CHECK(v.mechanism == WearMechanism::none);
  REQUIRE(v.unseen_band.has_value());
  CHECK(*v.unseen_band == CarrierBand::abrasion);
  CHECK(v.evidence.find("abrasion band (20000-37000 Hz) lies above 0.45 fs, so abrasive wear cannot be seen") != std::string::npos);

  // A pitting band that rises by far more than the material rise (0.050): fatigue pitting.
  std::vector<WearHistoryPoint> rising;
  for (std::size_t i = 0; i < needed + 5; ++i)
    rising.push_back({double(i) * 1e5, 0.02 + 0.02 * double(i), std::nan(""), std::nan(""), std::nan("")});
  const auto p = identify_wear_mechanism(rising, settings, CarrierBand::abrasion);
  CHECK(p.mechanism == WearMechanism::fatigue_pitting);
  CHECK(p.unseen_band == CarrierBand::abrasion);

  // Too short a history stays undetermined, with the limitation still named.
  const std::vector<WearHistoryPoint> short_history(rising.begin(), rising.begin() + 2);
  const auto s = identify_wear_mechanism(short_history, settings, CarrierBand::abrasion);
  CHECK(s.mechanism == WearMechanism::undetermined);
  CHECK(s.unseen_band == CarrierBand::abrasion);
  CHECK(std::string(to_string(CarrierBand::abrasion)) == "abrasion");
  CHECK(std::string(to_string(CarrierBand::pitting)) == "pitting");
}

}  // namespace test_band_trimming
