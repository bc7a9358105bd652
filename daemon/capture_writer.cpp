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
  explicit SyntheticCaptureSignal(const rig::SyntheticSignalSettings& s) : settings_(s), generator_(s) {}
  int channels() const override { return settings_.channels; }
  double sample_rate_hz() const override { return settings_.sample_rate_hz; }
  double input_revolutions_at(double t) const override { return generator_.input_revolutions_at(t); }
  void generate(std::uint64_t first, std::size_t count, std::vector<std::vector<double>>& out) override {
    generator_.generate(first, count, out);
  }
  std::vector<double> tacho_edges(double from, double to, int epr) const override { return generator_.tacho_edges(from, to, epr); }

 private:
  rig::SyntheticSignalSettings settings_;
  rig::SyntheticSignal generator_;
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

std::unique_ptr<CaptureSignal> synthetic_capture_signal(const rig::SyntheticSignalSettings& settings) {
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

namespace {

namespace acq = gearwatch::acquisition;

// Writes one capture: blocks of a frame's samples, with the header, the operating condition and
// the life counter at the start and once a second, and the tacho edges of each block.
class CaptureFileWriter {
 public:
  CaptureFileWriter(const CaptureSettings& cs, CaptureSignal& rig, const std::string& path)
      : cs_(cs), generator_(rig), path_(path), file_(std::fopen(path.c_str(), "wb"), &std::fclose),
        fs_(rig.sample_rate_hz()), channel_count_(rig.channels()), per_frame_(cs.fd ? 30 : 2),
        quantised_(per_frame_) {
    if (!file_) throw std::runtime_error("cannot write " + path);
    std::setvbuf(file_.get(), buffer_.data(), _IOFBF, buffer_.size());
  }

  CaptureSummary write() {
    const auto total = static_cast<std::uint64_t>(std::llround(cs_.duration_s * fs_));
    const auto per_second = static_cast<std::uint64_t>(fs_);
    std::uint64_t next_meta = 0;
    for (std::uint64_t i = 0; i < total; i += per_frame_) {
      const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(per_frame_, total - i));
      const auto index32 = static_cast<std::uint32_t>(cs_.first_index + i);
      const bool meta_due = i >= next_meta;
      if (meta_due) {
        write_stream_header_and_condition(i, index32);
        next_meta += per_second;
      }
      if (cs_.tacho) write_tacho_edges(i, n);
      generator_.generate(i, n, block_);
      for (int c = 0; c < channel_count_; ++c) write_vibration(c, i, n, index32);
      if (meta_due) write_life_counter(i, n);
    }
    summary_.samples_per_channel = total;
    if (std::fflush(file_.get()) != 0) throw std::runtime_error("write error on " + path_);
    return summary_;
  }

 private:
  void emit(acq::CanFrame f, std::uint64_t at_sample) {
    f.timestamp_s = cs_.start_time_s + static_cast<double>(at_sample) / fs_;
    acq::format_candump_line(f, cs_.interface, line_);
    line_.push_back('\n');
    if (std::fwrite(line_.data(), 1, line_.size(), file_.get()) != line_.size()) throw std::runtime_error("write error on " + path_);
    ++summary_.frames;
  }

  void write_stream_header_and_condition(std::uint64_t i, std::uint32_t index32) {
    emit(acq::make_stream_header(cs_.ids, static_cast<std::uint32_t>(fs_), static_cast<std::uint8_t>(channel_count_),
                                 cs_.stream_id),
         i);
    const double speed = generator_.speed_hz_at(i);
    auto cond = acq::make_operating_condition(cs_.ids, static_cast<float>(cs_.signal.torque_nm),
                                              static_cast<float>(std::isfinite(speed) ? speed : cs_.signal.speed_hz), index32);
    if (!cs_.fd) {  // classic frames carry at most 8 bytes: the form without an index
      cond.fd = false;
      cond.len = 8;
    }
    emit(cond, i);
  }

  void write_tacho_edges(std::uint64_t i, std::size_t n) {
    for (double edge : generator_.tacho_edges(static_cast<double>(i), static_cast<double>(i + n), cs_.edges_per_rev)) {
      emit(acq::make_tacho_frame(cs_.ids, cs_.tacho_shaft, edge + cs_.first_index), i);
      ++summary_.tacho_edges;
    }
  }

  // Channel c's block in LSB of its scale, clipped (and counted) at full scale.
  void quantise(int c, std::size_t n) {
    constexpr double kFullScale = 32767.0;
    const double scale = cs_.channel_scales_m_s2_per_lsb.empty() ? cs_.scale_m_s2_per_lsb
                                                                 : cs_.channel_scales_m_s2_per_lsb.at(static_cast<std::size_t>(c));
    for (std::size_t k = 0; k < n; ++k) {
      double q = std::round(block_[static_cast<std::size_t>(c)][k] / scale);
      if (std::fabs(q) > kFullScale) {
        q = std::copysign(kFullScale, q);
        ++summary_.clipped_samples;
      }
      quantised_[k] = static_cast<std::int16_t>(q);
    }
  }

  void write_vibration(int c, std::uint64_t i, std::size_t n, std::uint32_t index32) {
    quantise(c, n);
    // An FD frame must have a valid FD length; a short final block is sent as classic-sized
    // FD frames of 2 samples (8 bytes, always valid).
    if (cs_.fd && n != per_frame_) {
      for (std::size_t k = 0; k < n; k += 2) {
        const std::size_t m = std::min<std::size_t>(2, n - k);
        emit(acq::make_vibration_frame(cs_.ids, c, static_cast<std::uint32_t>(index32 + k),
                                       std::span<const std::int16_t>(quantised_.data() + k, m), true),
             i + k);
      }
    } else {
      emit(acq::make_vibration_frame(cs_.ids, c, index32, std::span<const std::int16_t>(quantised_.data(), n), cs_.fd), i);
    }
  }

  // The odometer after this block's samples: every revolution completed up to its last sample.
  void write_life_counter(std::uint64_t i, std::size_t n) {
    const double last = static_cast<double>(i + n - 1) / fs_;
    const double revs = static_cast<double>(cs_.start_revolutions) + std::floor(generator_.input_revolutions_at(last) + 1e-9);
    emit(acq::make_life_counter(cs_.ids, static_cast<std::uint64_t>(revs)), i + n - 1);
  }

  const CaptureSettings& cs_;
  CaptureSignal& generator_;
  const std::string& path_;
  std::vector<char> buffer_ = std::vector<char>(1 << 20);   // before file_: closed before it is freed
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file_;
  const double fs_;
  const int channel_count_;
  const std::size_t per_frame_;
  CaptureSummary summary_;
  std::string line_;
  std::vector<std::vector<double>> block_;
  std::vector<std::int16_t> quantised_;
};

}  // namespace

CaptureSummary write_capture(const CaptureSettings& cs, CaptureSignal& rig, const std::string& path) {
  return CaptureFileWriter(cs, rig, path).write();
}

}  // namespace gearwatch::daemon
