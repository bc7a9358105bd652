// Channels of one record analysed in parallel (daemon/channel_workers.hpp) give exactly what one
// analyzer gives analysing them one after another: every indicator, skip, note, band selection and
// speed profile, bit for bit.
#include "channel_workers.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <thread>
#include <vector>

#include "gearwatch/dsp/record_analyzer.hpp"

namespace test_channel_workers {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;

namespace {
constexpr double kPi = std::numbers::pi;

// A 19/52 gearbox record with `channels` channels: mesh harmonics, an output-shaft order, a
// resonance modulated at the mesh order and white noise, in different proportions per channel,
// at f0 (1 + 3 % sin(2π 0.5 t)); one tacho edge per input revolution.
Record gearbox_record(double fs, double seconds, double f0, int channels, unsigned seed) {
  const auto n = static_cast<std::size_t>(fs * seconds);
  const double depth = 0.03, fm = 0.5;
  auto angle = [&](double t) { return f0 * t - f0 * depth / (2 * kPi * fm) * (std::cos(2 * kPi * fm * t) - 1); };
  auto speed = [&](double t) { return f0 * (1 + depth * std::sin(2 * kPi * fm * t)); };
  Record r;
  r.sample_rate_hz = fs;
  r.speed_hz = f0;
  r.torque_nm = 20;
  r.channels.assign(static_cast<std::size_t>(channels), std::vector<float>(n));
  for (int c = 0; c < channels; ++c) r.channel_numbers.push_back(c);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  const double fc = 6000.0 / fs, rr = 0.97;
  const double a1 = -2 * rr * std::cos(2 * kPi * fc), a2 = rr * rr;
  double y1 = 0, y2 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / fs, theta = angle(t);
    const double y = normal(rng) - a1 * y1 - a2 * y2;
    y2 = y1;
    y1 = y;
    const double mesh = std::cos(2 * kPi * 19 * theta) + 0.5 * std::sin(2 * kPi * 38 * theta);
    const double modulated = (1 + 0.8 * std::cos(2 * kPi * 19 * theta)) * y;
    for (int c = 0; c < channels; ++c)
      r.channels[static_cast<std::size_t>(c)][i] = static_cast<float>(
          (1.0 - 0.2 * c) * mesh + 0.3 * std::cos(2 * kPi * theta * 19.0 / 52.0) + (0.1 + 0.1 * c) * modulated + 0.2 * normal(rng));
  }
  for (int k = 0;; ++k) {
    const double target = k + 0.2;
    double t = target / f0;
    for (int it = 0; it < 20; ++it) t -= (angle(t) - target) / speed(t);
    if (t * fs > static_cast<double>(n - 1)) break;
    r.tacho_edges[0].push_back(t * fs);
  }
  return r;
}

bool same_bits(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

void require_identical(const dsp::ChannelAnalysis& serial, const dsp::ChannelAnalysis& parallel) {
  REQUIRE(parallel.indicators.size() == serial.indicators.size());
  for (std::size_t i = 0; i < serial.indicators.size(); ++i) {
    INFO(serial.indicators[i].name << ": serial " << serial.indicators[i].value << ", parallel " << parallel.indicators[i].value);
    CHECK(parallel.indicators[i].name == serial.indicators[i].name);
    CHECK(same_bits(parallel.indicators[i].value, serial.indicators[i].value));
  }
  REQUIRE(parallel.skipped.size() == serial.skipped.size());
  for (std::size_t i = 0; i < serial.skipped.size(); ++i) {
    CHECK(parallel.skipped[i].name == serial.skipped[i].name);
    CHECK(parallel.skipped[i].reason == serial.skipped[i].reason);
    CHECK(parallel.skipped[i].detail == serial.skipped[i].detail);
  }
  REQUIRE(parallel.notes.size() == serial.notes.size());
  for (std::size_t i = 0; i < serial.notes.size(); ++i) CHECK(parallel.notes[i].detail == serial.notes[i].detail);
  REQUIRE(parallel.band_selections.size() == serial.band_selections.size());
  for (std::size_t i = 0; i < serial.band_selections.size(); ++i) {
    const auto &s = serial.band_selections[i], &p = parallel.band_selections[i];
    CHECK(p.criterion == s.criterion);
    CHECK(same_bits(p.level, s.level));
    CHECK(same_bits(p.centre_hz, s.centre_hz));
    CHECK(same_bits(p.bandwidth_hz, s.bandwidth_hz));
    CHECK(same_bits(p.value, s.value));
  }
  CHECK(same_bits(parallel.tsa_averages_input, serial.tsa_averages_input));
  CHECK(same_bits(parallel.tsa_averages_output, serial.tsa_averages_output));
  CHECK(same_bits(parallel.mean_speed_hz, serial.mean_speed_hz));
  CHECK(parallel.samples_per_revolution == serial.samples_per_revolution);
  REQUIRE(parallel.speed_profile_hz.size() == serial.speed_profile_hz.size());
  for (std::size_t i = 0; i < serial.speed_profile_hz.size(); ++i)
    CHECK(same_bits(parallel.speed_profile_hz[i], serial.speed_profile_hz[i]));
}

}  // namespace

TEST_CASE("channel workers: a record's channels analysed in parallel give the serial indicators bit for bit",
          "[daemon][channel_workers]") {
  const double fs = 50000.0;
  GearboxSpec rig;
  rig.sample_rate_hz = fs;
  dsp::SignalProcessingSettings settings;
  settings.pitting_band = {2000, 13000};
  settings.abrasion_band = {15000, 22000};
  settings.mean_carrier_ranges = {{0, 22000}};
  // Two records of different speeds (so different resolutions and transform sizes): a worker sees
  // only its channels of each, the serial analyzer every channel of both, in order.
  const std::vector<Record> records{gearbox_record(fs, 2.0, 20.0, 3, 1), gearbox_record(fs, 2.2, 17.0, 3, 2)};

  dsp::RecordAnalyzer serial(rig, settings);
  std::vector<std::vector<dsp::ChannelAnalysis>> expected;
  for (const Record& r : records) {
    expected.emplace_back();
    for (std::size_t c = 0; c < r.channels.size(); ++c) expected.back().push_back(serial.analyze(r, c));
  }
  // The serial analysis is a real one (the known mesh amplitudes), so the comparison is not of two empty sets.
  for (const auto& record : expected)
    for (std::size_t c = 0; c < record.size(); ++c) {
      CHECK(record[c].skipped.empty());
      CHECK(*record[c].value("gmf1_amplitude") == Approx(1.0 - 0.2 * static_cast<double>(c)).margin(5e-3));
      CHECK(*record[c].value("gmf_harmonic_2") == Approx(0.5 * (1.0 - 0.2 * static_cast<double>(c))).margin(5e-3));
    }

  for (unsigned workers : {3u, 2u}) {
    INFO(workers << " workers");
    daemon::ChannelWorkers parallel(rig, settings, workers);
    REQUIRE(parallel.workers() == workers);
    for (std::size_t k = 0; k < records.size(); ++k) {
      const auto got = parallel.analyze(records[k], {});
      REQUIRE(got.size() == expected[k].size());
      for (std::size_t c = 0; c < got.size(); ++c) {
        INFO("record " << k << ", channel " << c);
        require_identical(expected[k][c], got[c]);
      }
    }
    CHECK(parallel.helper_cpu_ns() > 0);  // the helpers did analyse
  }
}

TEST_CASE("channel workers: the default is the hardware threads, at most 8, and a configured count is kept",
          "[daemon][channel_workers]") {
  const unsigned hw = std::thread::hardware_concurrency();
  CHECK(daemon::channel_worker_count(0) == std::clamp(hw, 1u, 8u));
  CHECK(daemon::channel_worker_count(1) == 1);
  CHECK(daemon::channel_worker_count(3) == 3);
  CHECK(daemon::channel_worker_count(12) == 12);
}

}  // namespace test_channel_workers
