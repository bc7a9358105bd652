#pragma once
// Turns an assembled record into what is stored for it: the indicators of every channel
// (dsp::RecordAnalyzer), the wear-mechanism assessment over the gear pair's history (§4.4), and
// the alerts these raise or clear (AlertTracker, state reloaded from the database at start).
// Runs on the processing thread; owns the analyzers (one per channel worker, each with its FFT
// plans and scratch).
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "channel_workers.hpp"
#include "gearwatch/alerts.hpp"
#include "gearwatch/config/config.hpp"
#include "gearwatch/dsp/record_analyzer.hpp"
#include "gearwatch/dsp/speed_estimation.hpp"
#include "gearwatch/dsp/wear_mechanism.hpp"
#include "gearwatch/storage/messages.hpp"
#include "gearwatch/types/record.hpp"

namespace gearwatch::daemon {

/// Per protocol channel: the (cycles, ICS2 low, ICS2 high, selected band) history.
using WearHistory = std::map<int, std::vector<dsp::WearHistoryPoint>>;
using AlertStates = std::map<AlertKey, AlertState>;
/// Per (channel, indicator): the gear pair's first alerts.baseline_records values.
using IndicatorBaselines = std::map<std::pair<int, std::string>, std::vector<double>>;

/// What processing remembers across restarts, read back from the database at start.
struct ProcessorMemory {
  WearHistory wear_history;
  AlertStates alerts;
  IndicatorBaselines baselines;
};

/// The shaft angle a record is analysed on (docs/dsp.md "Speed from the signal").
struct RecordSpeed {
  std::optional<dsp::SpeedSource> source;   ///< nullopt: no tacho and no estimate
  std::span<const double> estimated_edges;  ///< the estimate's edges when they replace the tacho, else empty
  std::string estimate_failure;             ///< why no estimate ("" when there is one)
};

/// A raised tacho_speed_mismatch is raised again only when the relative difference moved by more
/// than this fraction of its value at the last raise (docs/daemon.md): its two printed digits
/// flip at a rounding boundary (9.8e-5, 1.0e-4) with the estimate's last digits, which is the same
/// disagreement; a quarter is a change staff can read off the two values.
inline constexpr double kSpeedMismatchReraiseChange = 0.25;

/// The tacho check's alert (raised, raised again with a moved value, cleared), or nothing.
std::optional<AlertEvent> observe_speed_mismatch(AlertTracker& alerts, const dsp::SpeedCheck& check);

class RecordProcessor {
 public:
  explicit RecordProcessor(const config::GearwatchConfig& config, ProcessorMemory memory = {});
  /// Never throws on bad data: problems become skipped indicators with a reason.
  storage::RecordResult process(const Record& record, bool analysable, std::uint64_t stream_sequence);
  /// A new gear pair (the life counter went backwards): its history starts empty, the old
  /// pair's wear alerts clear, and the reset itself is an alert event.
  storage::AlertUpdate life_counter_reset(std::uint64_t previous_revolutions, std::uint64_t revolutions);
  /// A configured channel the stream does not carry, or whose frames stopped (present = false),
  /// or that came back (present = true). `how` says which ("missing_from_stream", "stopped").
  storage::AlertUpdate sensor_presence(int channel, bool present, const std::string& how, const std::string& message);
  /// A configured tacho whose edges stopped while the samples go on (present = false), or came back.
  storage::AlertUpdate tacho_presence(int shaft, bool present, const std::string& how, const std::string& message);
  /// A new stream: its header's sample rate against rig.sample_rate_hz (raised when they differ,
  /// cleared by a stream at the configured rate). The stream's own rate is used either way.
  storage::AlertUpdate stream_sample_rate(std::uint32_t stream_rate_hz, const std::string& message);
  const WearHistory& history() const noexcept { return history_; }
  const AlertTracker& alerts() const noexcept { return alerts_; }
  /// CPU time of the channel workers' helper threads so far (the processing thread's own is its own).
  std::uint64_t channel_helper_cpu_ns() const noexcept { return channels_.helper_cpu_ns(); }

 private:
  RecordSpeed establish_speed(const Record& record, storage::RecordResult& out);
  void observe_speed_check(const dsp::SpeedCheck& check, storage::RecordResult& out);
  void observe_cycle_count(const Record& record, storage::RecordResult& out);
  void observe_channel_alerts(int channel, const dsp::ChannelAnalysis& a, storage::RecordResult& out);
  void assess_wear(int channel, double cycles, const dsp::ChannelAnalysis& a, storage::RecordResult& out);
  void check_thresholds(int channel, const dsp::ChannelAnalysis& a, storage::RecordResult& out);
  /// A presence event that is definite when it comes (no hysteresis beyond its source's own): the
  /// alert `kind` on `subject` raised while absent, cleared when present.
  storage::AlertUpdate definite_presence(AlertKind kind, int subject, bool present, const std::string& how,
                                         const std::string& message);

  config::GearwatchConfig config_;
  ChannelWorkers channels_;
  dsp::SpeedEstimator estimator_;
  WearHistory history_;
  /// Per channel: the gear pair's first records, until both bands hold wear_baseline_records finite
  /// values (at most trend_window_records records): the wear floors' baseline, kept when the
  /// history's window has moved past it.
  WearHistory wear_baseline_;
  AlertTracker alerts_;
  IndicatorBaselines baselines_;
};

/// The wear history of the gear pair now installed, from an existing database: analysed
/// records with a cycle count since the last life-counter reset. Empty for a new database.
WearHistory load_wear_history(const std::string& database_path);

/// The alert states stored by earlier runs (table alert_state). Empty for a new database.
AlertStates load_alert_states(const std::string& database_path);

/// The watched indicators' first values since the last life-counter reset.
IndicatorBaselines load_baselines(const std::string& database_path, const config::AlertSettings& settings);

/// All of the above.
ProcessorMemory load_processor_memory(const std::string& database_path, const config::AlertSettings& settings);

}  // namespace gearwatch::daemon
