// Decode + ring throughput from a capture file (issue: foundation). Generates a 10 s capture of
// 100 kHz x 2 channels in CAN FD frames (not timed), then times, on one thread: reading the
// file, parsing each candump line, validating and decoding the frame, pushing the events into
// the SPSC ring and popping them again (the consumer's cost of taking them out).
// Prints frames/s and the multiple of real time. Target: >= 100x real time.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "capture_writer.hpp"
#include "gearwatch/acquisition/candump_log.hpp"
#include "gearwatch/acquisition/protocol_decoder.hpp"
#include "gearwatch/acquisition/spsc_ring.hpp"

namespace acq = gearwatch::acquisition;

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 10.0;
  const auto path = std::filesystem::temp_directory_path() / ("gearwatch-bench-" + std::to_string(::getpid()) + ".log");
  gearwatch::daemon::CaptureSettings cs;
  cs.duration_s = seconds;
  const auto summary = gearwatch::daemon::write_synthetic_capture(cs, path.string());

  std::vector<double> rates;
  std::uint64_t samples = 0, frames = 0, events = 0;
  for (int rep = 0; rep < 5; ++rep) {
    acq::SpscRing<acq::AcquisitionEvent> ring(1 << 16);
    acq::AcquisitionEvent out;
    events = 0;
    acq::ProtocolDecoder decoder(acq::ProtocolIds{}, 0b11, 0b1, [&](const acq::AcquisitionEvent& e) {
      if (!ring.try_push(e)) {  // one thread here: drain, then push (never happens at 64 Ki)
        while (ring.try_pop(out)) ++events;
        ring.try_push(e);
      }
    });
    const auto t0 = std::chrono::steady_clock::now();
    std::ifstream in(path, std::ios::binary);
    std::string line, reason;
    while (std::getline(in, line)) {
      if (auto parsed = acq::parse_candump_line(line, reason)) decoder.decode(parsed->frame);
      if (ring.size() > 4096)
        while (ring.try_pop(out)) ++events;
    }
    while (ring.try_pop(out)) ++events;
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    rates.push_back(seconds / dt);
    samples = decoder.counters().samples;
    frames = decoder.counters().frames;
  }
  std::filesystem::remove(path);
  std::sort(rates.begin(), rates.end());
  const double median = rates[rates.size() / 2];
  const double frames_per_s = static_cast<double>(frames) * median / seconds;
  std::printf("capture: %.0f s, 100 kHz x 2 channels, CAN FD: %llu frames, %llu samples, %llu events\n", seconds,
              static_cast<unsigned long long>(summary.frames), static_cast<unsigned long long>(samples),
              static_cast<unsigned long long>(events));
  std::printf("decode+ring (one thread, file -> parse -> validate -> ring -> pop), 5 runs:\n");
  std::printf("  median %.0f frames/s = %.1fx real time (best %.1fx, worst %.1fx); target >= 100x\n", frames_per_s, median,
              rates.back(), rates.front());
  // One machine-readable line for tools/bench.sh.
  std::printf("BENCH name=acquisition_decode_ring figure=%.1f unit=x_real_time target=100 cmp=ge met=%d\n", median,
              median >= 100.0 ? 1 : 0);
  return median >= 100.0 ? 0 : 1;
}
