#include "capture_writer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

#include "gearwatch/acquisition/candump_log.hpp"
#include "gearwatch/acquisition/protocol_encoder.hpp"

namespace gearwatch::daemon {
namespace {

class SyntheticCaptureSignal final : public CaptureSignal {
 public:
  explicit SyntheticCaptureSignal(const SyntheticRigSettings& s) : settings_(s), rig_(s) {}
  int channels() const override { return settings_.channels; }
  double sample_rate_hz() const override { return settings_.sample_rate_hz; }
  double input_revolutions_at(double t) const override { return rig_.input_revolutions_at(t); }
  void generate(std::uint64_t first, std::size_t count, std::vector<std::vector<double>>& out) override {
    rig_.generate(first, count, out);
  }
  std::vector<double> tacho_edges(double from, double to, int epr) const override { return rig_.tacho_edges(from, to, epr); }

 private:
  SyntheticRigSettings settings_;
  SyntheticRig rig_;
};

class SampledCaptureSignal final : public CaptureSignal {
 public:
  SampledCaptureSignal(double fs, std::vector<float> x, std::vector<double> edges)
      : fs_(fs), x_(std::move(x)), edges_(std::move(edges)) {}
  int channels() const override { return 1; }
  double sample_rate_hz() const override { return fs_; }
  double input_revolutions_at(double t) const override {
    // Whole revolutions completed by sample t·fs, plus the fraction of the one under way.
    const double pos = t * fs_;
    const auto it = std::upper_bound(edges_.begin(), edges_.end(), pos);
    const auto k = static_cast<std::size_t>(it - edges_.begin());
    if (k == 0 || k == edges_.size()) return static_cast<double>(k);
    return static_cast<double>(k - 1) + (pos - edges_[k - 1]) / (edges_[k] - edges_[k - 1]);
  }
  void generate(std::uint64_t first, std::size_t count, std::vector<std::vector<double>>& out) override {
    out.resize(1);
    out[0].resize(count);
    for (std::size_t i = 0; i < count; ++i) {
      const std::uint64_t k = first + i;
      out[0][i] = k < x_.size() ? x_[k] : 0.0;
    }
  }
  std::vector<double> tacho_edges(double from, double to, int epr) const override {
    if (epr != 1) throw std::runtime_error("a sampled signal carries one tacho edge per revolution only");
    // Called once per frame-sized block: find the few edges by bisection, not a scan of all.
    return {std::lower_bound(edges_.begin(), edges_.end(), from), std::lower_bound(edges_.begin(), edges_.end(), to)};
  }

 private:
  double fs_;
  std::vector<float> x_;
  std::vector<double> edges_;
};

}  // namespace

std::unique_ptr<CaptureSignal> synthetic_capture_signal(const SyntheticRigSettings& settings) {
  return std::make_unique<SyntheticCaptureSignal>(settings);
}

std::unique_ptr<CaptureSignal> sampled_capture_signal(double sample_rate_hz, std::vector<float> acceleration,
                                                      std::vector<double> input_edges) {
  return std::make_unique<SampledCaptureSignal>(sample_rate_hz, std::move(acceleration), std::move(input_edges));
}

CaptureSummary write_synthetic_capture(const CaptureSettings& cs, const std::string& path) {
  auto signal = synthetic_capture_signal(cs.signal);
  return write_capture(cs, *signal, path);
}

CaptureSummary write_capture(const CaptureSettings& cs, CaptureSignal& rig, const std::string& path) {
  namespace acq = gearwatch::acquisition;
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!file) throw std::runtime_error("cannot write " + path);
  std::vector<char> buffer(1 << 20);
  std::setvbuf(file.get(), buffer.data(), _IOFBF, buffer.size());

  const double fs = rig.sample_rate_hz();
  const int channel_count = rig.channels();
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
      emit(acq::make_stream_header(cs.ids, static_cast<std::uint32_t>(fs), static_cast<std::uint8_t>(channel_count),
                                   cs.stream_id),
           i);
      const double speed = rig.speed_hz_at(i);
      auto cond = acq::make_operating_condition(cs.ids, static_cast<float>(cs.signal.torque_nm),
                                                static_cast<float>(std::isfinite(speed) ? speed : cs.signal.speed_hz), index32);
      if (!cs.fd) {  // classic frames carry at most 8 bytes: the form without an index
        cond.fd = false;
        cond.len = 8;
      }
      emit(cond, i);
    }
    const bool life_due = i >= next_meta;
    if (life_due) next_meta += per_second;
    if (cs.tacho)
      for (double edge : rig.tacho_edges(static_cast<double>(i), static_cast<double>(i + n), cs.edges_per_rev)) {
          emit(acq::make_tacho_frame(cs.ids, cs.tacho_shaft, edge + cs.first_index), i);
        ++summary.tacho_edges;
      }
    rig.generate(i, n, block);
    for (int c = 0; c < channel_count; ++c) {
      const double scale = cs.channel_scales_m_s2_per_lsb.empty() ? cs.scale_m_s2_per_lsb
                                                                  : cs.channel_scales_m_s2_per_lsb.at(static_cast<std::size_t>(c));
      for (std::size_t k = 0; k < n; ++k) {
        double q = std::round(block[static_cast<std::size_t>(c)][k] / scale);
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
