#pragma once
// The channels of one record analysed in parallel (docs/daemon.md, "Channel workers"). A plant's
// box has 4–8 cores and a record 2–8 channels; each channel's analysis is independent of the
// others, so each goes to its own analyzer. The calling (processing) thread analyses its share
// itself; the helpers are started on the first record, from the processing thread, so they run at
// its nice value.
//
// Results equal the serial ones bit for bit: every analyzer (its FFT plans, resampling tables and
// scratch) belongs to one thread, an analysis depends only on the record and its own settings
// (never on what the analyzer saw before), and FFTW's plans are made with FFTW_ESTIMATE under the
// process-wide planner lock (dsp/fft.hpp), so the same sizes get the same algorithm in every
// thread; execution on new arrays is thread-safe. Test: tests/test_channel_workers.cpp.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <span>
#include <thread>
#include <vector>

#include "gearwatch/dsp/record_analyzer.hpp"
#include "gearwatch/types/record.hpp"
#include "gearwatch/gearbox_spec.hpp"

namespace gearwatch::daemon {

/// The worker count a setting means: `configured` when > 0, else the hardware threads, at most
/// kMaxDefaultChannelWorkers (and at least 1).
unsigned channel_worker_count(unsigned configured);
inline constexpr unsigned kMaxDefaultChannelWorkers = 8;

class ChannelWorkers {
 public:
  /// `workers`: threads analysing channels, the calling thread included (1 = serial, no helper).
  ChannelWorkers(const GearboxSpec& rig, const dsp::SignalProcessingSettings& settings, unsigned workers);
  ~ChannelWorkers();
  ChannelWorkers(const ChannelWorkers&) = delete;
  ChannelWorkers& operator=(const ChannelWorkers&) = delete;

  /// Every channel of the record, result c for channel index c; `input_edges` as
  /// dsp::RecordAnalyzer::analyze. Channel c goes to worker c mod workers (worker 0 = the caller).
  /// Rethrows the first exception an analysis threw, after every channel is done.
  std::vector<dsp::ChannelAnalysis> analyze(const Record& record, std::span<const double> input_edges);

  unsigned workers() const noexcept { return static_cast<unsigned>(helpers_.size()) + 1; }
  /// CPU time the helper threads spent on analyses so far (the caller's share is in its own thread).
  std::uint64_t helper_cpu_ns() const noexcept { return helper_cpu_ns_.load(std::memory_order_relaxed); }

 private:
  class Helper;

  dsp::RecordAnalyzer own_;
  std::vector<std::unique_ptr<Helper>> helpers_;
  std::atomic<std::uint64_t> helper_cpu_ns_{0};
};

}  // namespace gearwatch::daemon
