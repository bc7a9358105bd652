#pragma once
// The daemon's wiring: acquisition thread (Asio: frame source, protocol decoder, signals,
// watchdog) -> SPSC ring -> processing thread (record assembly, indicators) -> storage writer
// thread (SQLite). Used by `gearwatch run` (live, SocketCAN or a log) and `gearwatch replay`.
//
// Overflow policies: a live source never waits — when the ring is full the event is dropped and
// counted (ring_overflows; the processing side records the hole as a dropout with cause
// ring_overflow). A file source waits for room, so a replay loses nothing. The writer's queue
// makes processing wait (storage_queue_waits).
// SIGHUP reloads what can change while running and logs what needs a restart (config_reload.hpp).
// A capture replayed again continues after the records it already stored (replay_resume.hpp).
// Shutdown: SIGTERM/SIGINT stop the source; the acquisition io_context then runs out of work;
// processing drains the ring and ends the open record; the writer commits everything; threads
// are joined in reverse order of start.
#include <map>
#include <string>

#include "gap_monitor.hpp"
#include "gearwatch/config/config.hpp"
#include "gearwatch/storage/messages.hpp"
#include "gearwatch/types/skip_reason.hpp"

namespace gearwatch::daemon {

enum class PipelineMode { live, replay };

/// Records analysed that came out without a single indicator: every indicator of every channel
/// was skipped (a flat or clipped sensor, no tacho, too short). Counted so a summary does not
/// call them analysed without saying so.
struct RecordsWithoutIndicators {
  std::uint64_t records = 0;
  /// Skip reason -> how many of those records it skipped at least one indicator of.
  std::map<dsp::SkipReason, std::uint64_t> reasons;
  void count(const storage::RecordResult& record);
};

struct PipelineResult {
  int exit_status = 0;
  std::string end_reason;      ///< the source's error ("" when it ended normally or was stopped)
  std::string run_end_reason;  ///< as stored in runs.end_reason: also "end of capture", "stopped by SIGTERM"
  std::uint64_t records = 0, records_analysed = 0, frames = 0, samples = 0;
  RecordsWithoutIndicators records_without_indicators;
  /// Records of a capture replayed again that an earlier run had already stored (not stored twice).
  std::uint64_t records_already_stored = 0;
  /// Samples that never reached a record slot: dropouts in the protocol (a frame dropped by the
  /// kernel or the front-end shows up here) plus holes left by ring overflows.
  std::uint64_t lost_samples = 0;
  std::uint64_t kernel_dropped_frames = 0;  ///< SO_RXQ_OVFL: frames the kernel discarded
  std::uint64_t run_id = 0;
  /// CPU time per thread (seconds): where a run's time went (bench/bench_replay.cpp). The model's
  /// excludes its gap diagnoses; the storage writer's is the process's total less these.
  struct ThreadCpu {
    double acquisition_s = 0, processing_s = 0, channel_helpers_s = 0, model_s = 0, gap_s = 0;
  } cpu;
};

/// Runs until the source ends (replay), a signal arrives, or a fatal storage error. `gap`: the
/// periodic gap step's diagnosis and twin counterpart (empty: bound from the configuration).
PipelineResult run_pipeline(const config::GearwatchConfig& config, PipelineMode mode, GapHooks gap = {});

}  // namespace gearwatch::daemon
