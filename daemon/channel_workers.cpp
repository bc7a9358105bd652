#include "channel_workers.hpp"

#include <algorithm>

#include "thread_cpu.hpp"

namespace gearwatch::daemon {
namespace {

// One record's channels in flight: the caller waits until the helpers' share is done.
struct Batch {
  std::mutex mutex;
  std::condition_variable done;
  std::size_t pending = 0;
};

struct Job {
  const Record* record = nullptr;
  std::size_t channel = 0;
  std::span<const double> input_edges;
  dsp::ChannelAnalysis* out = nullptr;
  std::exception_ptr* error = nullptr;
  Batch* batch = nullptr;
};

void run_job(dsp::RecordAnalyzer& analyzer, const Job& job) {
  try {
    *job.out = analyzer.analyze(*job.record, job.channel, job.input_edges);
  } catch (...) {
    *job.error = std::current_exception();
  }
}

}  // namespace

unsigned channel_worker_count(unsigned configured) {
  if (configured > 0) return configured;
  return std::clamp(std::thread::hardware_concurrency(), 1u, kMaxDefaultChannelWorkers);
}

// A thread with its own analyzer and its own queue of channels to analyse.
class ChannelWorkers::Helper {
 public:
  Helper(const GearboxSpec& rig, const dsp::SignalProcessingSettings& settings, std::atomic<std::uint64_t>& cpu_ns)
      : analyzer_(rig, settings), cpu_ns_(cpu_ns) {}
  ~Helper() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    wake_.notify_one();
    if (thread_.joinable()) thread_.join();
  }
  Helper(const Helper&) = delete;
  Helper& operator=(const Helper&) = delete;

  void post(const Job& job) {
    {
      std::lock_guard lock(mutex_);
      queue_.push_back(job);
    }
    // Started by the first job, on the thread that posts it (the processing thread: its nice value).
    if (!thread_.joinable()) thread_ = std::thread([this] { run(); });
    wake_.notify_one();
  }

 private:
  void run() {
    for (;;) {
      Job job;
      {
        std::unique_lock lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (queue_.empty()) return;  // stopped, nothing left
        job = queue_.front();
        queue_.pop_front();
      }
      const std::uint64_t start = thread_cpu_ns();
      run_job(analyzer_, job);
      cpu_ns_.fetch_add(thread_cpu_ns() - start, std::memory_order_relaxed);
      {
        std::lock_guard lock(job.batch->mutex);
        if (--job.batch->pending == 0) job.batch->done.notify_one();
      }
    }
  }

  dsp::RecordAnalyzer analyzer_;
  std::atomic<std::uint64_t>& cpu_ns_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Job> queue_;
  bool stop_ = false;
  std::thread thread_;
};

ChannelWorkers::ChannelWorkers(const GearboxSpec& rig, const dsp::SignalProcessingSettings& settings, unsigned workers)
    : own_(rig, settings) {
  for (unsigned i = 1; i < std::max(1u, workers); ++i) helpers_.push_back(std::make_unique<Helper>(rig, settings, helper_cpu_ns_));
}

ChannelWorkers::~ChannelWorkers() = default;

std::vector<dsp::ChannelAnalysis> ChannelWorkers::analyze(const Record& record, std::span<const double> input_edges) {
  const std::size_t channels = record.channels.size();
  std::vector<dsp::ChannelAnalysis> results(channels);
  std::vector<std::exception_ptr> errors(channels);
  const std::size_t n = workers();
  Batch batch;
  for (std::size_t c = 0; c < channels; ++c)
    if (c % n != 0) ++batch.pending;
  for (std::size_t c = 0; c < channels; ++c)
    if (c % n != 0) helpers_[c % n - 1]->post(Job{&record, c, input_edges, &results[c], &errors[c], &batch});
  for (std::size_t c = 0; c < channels; c += n) run_job(own_, Job{&record, c, input_edges, &results[c], &errors[c], &batch});
  {
    std::unique_lock lock(batch.mutex);
    batch.done.wait(lock, [&] { return batch.pending == 0; });
  }
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  return results;
}

}  // namespace gearwatch::daemon
