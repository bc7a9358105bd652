#pragma once
// Test helper: a constant-speed record made in closed form, exactly `revs` input revolutions plus
// half (so the last tacho edge lies inside), one tacho edge per revolution on shaft 0, channel 0,
// float samples as acquisition gives them, 20 N·m.
#include <cstddef>
#include <vector>

#include "gearwatch/types/record.hpp"

namespace gearwatch::test {

/// `sample(t)` gives the value at time t (s); it is called once per sample, in order.
template <class Sample>
Record constant_speed_record(double fs, double speed, int revs, Sample&& sample) {
  Record r;
  r.sample_rate_hz = fs;
  const auto n = static_cast<std::size_t>((revs + 0.5) * fs / speed);
  std::vector<float> x(n, 0.0f);
  for (std::size_t i = 0; i < n; ++i) x[i] = static_cast<float>(sample(static_cast<double>(i) / fs));
  r.channels = {x};
  r.channel_numbers = {0};
  for (int k = 0; k <= revs; ++k) r.tacho_edges[0].push_back(k * fs / speed);
  r.speed_hz = speed;
  r.torque_nm = 20;
  return r;
}

}  // namespace gearwatch::test
