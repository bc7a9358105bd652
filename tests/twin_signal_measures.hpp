#pragma once
// Measures of a simulated casing signal the twin's path tests compare between two integrations:
// RMS, a mesh harmonic's amplitude by a direct DFT, and RMS_SA through the analyzer.
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

}  // namespace gearwatch::testing
