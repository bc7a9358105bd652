#include "capture_writer.hpp"

#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

#include "gearwatch/acquisition/candump_log.hpp"
#include "gearwatch/acquisition/protocol_encoder.hpp"

namespace gearwatch::daemon {

CaptureSummary write_synthetic_capture(const CaptureSettings& cs, const std::string& path) {
  namespace acq = gearwatch::acquisition;
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!file) throw std::runtime_error("cannot write " + path);
  std::vector<char> buffer(1 << 20);
  std::setvbuf(file.get(), buffer.data(), _IOFBF, buffer.size());

  SyntheticRig rig(cs.signal);
  const double fs = cs.signal.sample_rate_hz;
  const auto total = static_cast<std::uint64_t>(std::llround(cs.duration_s * fs));
  const std::size_t per_frame = cs.fd ? 30 : 2;
  const auto per_second = static_cast<std::uint64_t>(fs);
  CaptureSummary summary;
  std::string line;
  auto emit = [&](acq::CanFrame f, std::uint64_t at_sample) {
    f.timestamp_s = cs.start_time_s + static_cast<double>(at_sample) / fs;
    acq::format_candump_line(f, cs.interface, line);
    line.push_back('\n');
    if (std::fwrite(line.data(), 1, line.size(), file.get()) != line.size()) throw std::runtime_error("write error on " + path);
    ++summary.frames;
  };

  std::vector<std::vector<double>> block;
  std::vector<std::int16_t> quantised(per_frame);
  const double full_scale = 32767.0;
  std::uint64_t next_meta = 0;
  for (std::uint64_t i = 0; i < total; i += per_frame) {
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(per_frame, total - i));
    const auto index32 = static_cast<std::uint32_t>(cs.first_index + i);
    if (i >= next_meta) {
      // Header, operating condition and life counter at the start and once a second.
      emit(acq::make_stream_header(cs.ids, static_cast<std::uint32_t>(fs), static_cast<std::uint8_t>(cs.signal.channels),
                                   cs.stream_id),
           i);
      auto cond = acq::make_operating_condition(cs.ids, static_cast<float>(cs.signal.torque_nm),
                                                static_cast<float>(cs.signal.speed_hz), index32);
      if (!cs.fd) {  // classic frames carry at most 8 bytes: the form without an index
        cond.fd = false;
        cond.len = 8;
      }
      emit(cond, i);
    }
    const bool life_due = i >= next_meta;
    if (life_due) next_meta += per_second;
    for (double edge : rig.tacho_edges(static_cast<double>(i), static_cast<double>(i + n), cs.edges_per_rev)) {
      emit(acq::make_tacho_frame(cs.ids, 0, edge + cs.first_index), i);
      ++summary.tacho_edges;
    }
    rig.generate(i, n, block);
    for (int c = 0; c < cs.signal.channels; ++c) {
      for (std::size_t k = 0; k < n; ++k) {
        double q = std::round(block[static_cast<std::size_t>(c)][k] / cs.scale_m_s2_per_lsb);
        if (std::fabs(q) > full_scale) {
          q = std::copysign(full_scale, q);
          ++summary.clipped_samples;
        }
        quantised[k] = static_cast<std::int16_t>(q);
      }
      // An FD frame must have a valid FD length; a short final block is sent as classic-sized
      // FD frames of 2 samples (8 bytes, always valid).
      if (cs.fd && n != per_frame) {
        for (std::size_t k = 0; k < n; k += 2) {
          const std::size_t m = std::min<std::size_t>(2, n - k);
          emit(acq::make_vibration_frame(cs.ids, c, static_cast<std::uint32_t>(index32 + k),
                                         std::span<const std::int16_t>(quantised.data() + k, m), true),
               i + k);
        }
      } else {
        emit(acq::make_vibration_frame(cs.ids, c, index32, std::span<const std::int16_t>(quantised.data(), n), cs.fd), i);
      }
    }
    if (life_due) {
      // The odometer after this block's samples: every revolution completed up to its last sample.
      const double last = static_cast<double>(i + n - 1) / fs;
      const double revs = static_cast<double>(cs.start_revolutions) + std::floor(rig.input_revolutions_at(last) + 1e-9);
      emit(acq::make_life_counter(cs.ids, static_cast<std::uint64_t>(revs)), i + n - 1);
    }
  }
  summary.samples_per_channel = total;
  if (std::fflush(file.get()) != 0) throw std::runtime_error("write error on " + path);
  return summary;
}

}  // namespace gearwatch::daemon
