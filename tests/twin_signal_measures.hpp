#pragma once
// Measures of a simulated casing signal the twin's path tests compare between two integrations:
// RMS, a mesh harmonic's amplitude by a direct DFT, and RMS_SA through the analyzer.
#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <vector>

#include <catch2/catch.hpp>

#include "gearwatch/dsp/record_analyzer.hpp"
#include "gearwatch/twin/simulation.hpp"

namespace gearwatch::testing {

inline double signal_rms(const std::vector<float>& x) {
  double sum = 0;
  for (float v : x) sum += static_cast<double>(v) * v;
  return std::sqrt(sum / static_cast<double>(x.size()));
}

/// Amplitude of the h-th mesh harmonic by a direct DFT over the whole number of mesh periods the
/// record holds (the mesh frequency is z1 × the input speed).
inline double mesh_harmonic_amplitude(const std::vector<float>& x, double fs, double mesh_hz, int h) {
  const double f = h * mesh_hz;
  const auto periods = std::floor(static_cast<double>(x.size()) / fs * mesh_hz);
  const auto n = static_cast<std::size_t>(std::floor(periods * fs / mesh_hz));
  std::complex<double> sum = 0;
  for (std::size_t i = 0; i < n; ++i)
    sum += static_cast<double>(x[i]) * std::polar(1.0, -2.0 * std::numbers::pi * f * static_cast<double>(i) / fs);
  return 2.0 * std::abs(sum) / static_cast<double>(n);
}

/// RMS_SA of the signal with its tacho, through the analyzer with the default settings.
inline double simulated_signal_rms_sa(const twin::CasingSignal& s) {
  Record record;
  record.sample_rate_hz = s.sample_rate_hz;
  record.channels.push_back(s.acceleration);
  record.channel_numbers.push_back(0);
  record.tacho_edges[0] = s.tacho_edges;
  dsp::RecordAnalyzer analyzer(GearboxSpec{}, dsp::SignalProcessingSettings{});
  const auto value = analyzer.analyze(record, 0).value("rms_sa");
  REQUIRE(value.has_value());
  return *value;
}

// 10 µm at the pinion's root falling to 0 at the tip, as the RMS_SA test wears it.
inline twin::ToothProfileDeviation root_to_tip_wear() {
  twin::ToothProfileDeviation wear;
  for (int i = 0; i <= 20; ++i) wear.pinion.push_back(10e-6 * std::pow(1.0 - i / 20.0, 2));
  return wear;
}

// Bounds a tiled twin record is held to against the full integration, fixed before comparing: the
// RMS difference and the largest difference as fractions of the reference's RMS; RMS, the 0-2 kHz
// band RMS, line amplitudes and RMS_SA relative; the tacho edges in samples.
struct RecordAgreement {
  double relative = 1e-3, largest = 1e-2, edge_samples = 1e-2;
};

// Line amplitudes at base_hz x 1..orders compared where a line is there (above 1e-3 of the RMS),
// not on the floor; returns how many were compared.
inline int check_lines_agree(const twin::CasingSignal& a, const twin::CasingSignal& r, double base_hz, int orders,
                             double relative) {
  const double r_rms = signal_rms(r.acceleration);
  int lines = 0;
  for (int h = 1; h <= orders; ++h) {
    const double ref_amplitude = mesh_harmonic_amplitude(r.acceleration, r.sample_rate_hz, base_hz, h);
    if (ref_amplitude <= 1e-3 * r_rms) continue;
    ++lines;
    INFO("order " << h << " of " << base_hz << " Hz");
    CHECK(mesh_harmonic_amplitude(a.acceleration, a.sample_rate_hz, base_hz, h) == Approx(ref_amplitude).epsilon(relative));
  }
  return lines;
}

// Record a against the reference r sample for sample (same length): the bounds above on the
// difference, the RMS, the 0-2 kHz band RMS, the tacho edges and RMS_SA.
inline void check_record_agrees(const twin::CasingSignal& a, const twin::CasingSignal& r, const RecordAgreement& bound) {
  REQUIRE(a.acceleration.size() == r.acceleration.size());
  const double r_rms = signal_rms(r.acceleration);
  double diff = 0, largest = 0;
  for (std::size_t i = 0; i < r.acceleration.size(); ++i) {
    const double d = static_cast<double>(a.acceleration[i]) - r.acceleration[i];
    diff += d * d;
    largest = std::max(largest, std::abs(d));
  }
  CHECK(std::sqrt(diff / static_cast<double>(r.acceleration.size())) <= bound.relative * r_rms);
  CHECK(largest <= bound.largest * r_rms);
  CHECK(signal_rms(a.acceleration) == Approx(r_rms).epsilon(bound.relative));
  const std::vector<double> a64(a.acceleration.begin(), a.acceleration.end());
  const std::vector<double> r64(r.acceleration.begin(), r.acceleration.end());
  const double fs = r.sample_rate_hz;
  CHECK(twin::lowpass_rms(a64, fs, 2000.0) == Approx(twin::lowpass_rms(r64, fs, 2000.0)).epsilon(bound.relative));
  REQUIRE(a.tacho_edges.size() == r.tacho_edges.size());
  double worst_edge = 0;
  for (std::size_t i = 0; i < r.tacho_edges.size(); ++i) worst_edge = std::max(worst_edge, std::abs(a.tacho_edges[i] - r.tacho_edges[i]));
  CHECK(worst_edge <= bound.edge_samples);
  CHECK(simulated_signal_rms_sa(a) == Approx(simulated_signal_rms_sa(r)).epsilon(bound.relative));
}

}  // namespace gearwatch::testing
