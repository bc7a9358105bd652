#pragma once
// The model thread (docs/model.md): takes each analysed record from the processing thread,
// advances the twin's blue loop to it, applies the purple loop (K_wear from RMS_SA, K_pitting from
// ICS2 and inspections), forecasts the remaining life, raises remaining_life alerts, and hands
// everything (with its whole state) to the storage writer. The state is reloaded at start.
//
// Overflow policy: the queue holds `model.queue_capacity` records. Live, submit() never waits:
// when the queue is full it is coalesced to the newest record — the older ones are dropped,
// counted, and named in the next stored run (skipped_records, skipped_record_ids), since the
// model works on the latest state. A replay is lossless and deterministic: submit() waits for
// room (as a file source waits for the ring), so one long replay and one file per process give
// the same state. stop() is the terminate message: the queue is drained, then the thread ends.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "gap_monitor.hpp"
#include "gearwatch/alerts.hpp"
#include "gearwatch/config/config.hpp"
#include "gearwatch/storage/messages.hpp"
#include "gearwatch/storage/writer.hpp"
#include "gearwatch/wear/updating.hpp"

namespace gearwatch::daemon {

/// One analysed record as the model needs it.
struct ModelInput {
  std::uint64_t stream_sequence = 0;
  std::uint64_t start_index = 0;
  wear::ModelObservation observation;
  /// The record's own sample rate (its stream header's): the twin simulates its RMS_SA at it.
  double sample_rate_hz = 0;
  /// The record's samples, for the periodic gap diagnosis (only when gap.enabled).
  std::shared_ptr<const Record> samples;
  /// Set for a record an earlier process stored and the model had not handled (read back at start).
  std::optional<std::int64_t> stored_record_id;
  /// A life-counter reset was recorded since the record before it (the gear-pair rule's authoritative sign).
  bool life_counter_reset_before = false;
};

/// The accelerometer channel feeding the model: model.channel, else the first configured one.
int model_channel(const config::GearwatchConfig& config);

/// The model's inputs from a processed record: cycles (NaN without a life counter), the
/// front-end's speed (else the tacho's mean speed) and torque, and the RMS_SA and low-band ICS2
/// of the model's channel (absent when skipped).
ModelInput model_input(const storage::RecordResult& record, const config::GearwatchConfig& config);

/// The twin's parameters: the [twin] table of the configuration's file, when there is one (tests
/// and the built-in defaults have none: the default parameters).
twin::GearboxParameters model_twin_parameters(const config::GearwatchConfig& config);

/// The model's settings from the configuration (the rig's gears, speed range and the [model] table).
wear::ModelSettings model_settings(const config::GearwatchConfig& config);

/// The analysed records stored before this start that the model has not handled (committed
/// after the record of its newest stored run), oldest first, each rebuilt as model_input() built
/// it from the processed record. They carry no samples: the gap diagnosis cannot use them.
std::deque<ModelInput> stored_backlog(const std::string& database_path, const config::GearwatchConfig& config);

/// Where a gear pair's cycle 0 lies on the life counter and why the pair started (docs/model.md,
/// "A new gear pair"). The model's cycles (model_state, model_runs, k_update_log) are the pair's:
/// the life counter minus `origin_cycles`; records and inspections keep the counter's.
struct PairStart {
  double origin_cycles = 0;                 ///< life counter at the pair's cycle 0
  std::string reason;                       ///< why the pair started ("" in a state stored before this was kept)
  std::optional<GearPairSpec> gears;        ///< the gear pair the model was built for (absent in such a state)
};

/// One line naming a gear pair: "23/46 teeth, module 1.5 mm, face 15 mm, pressure angle 20 deg".
std::string gear_pair_text(const GearPairSpec& gears);
/// True when the two specs describe the same gear pair (every field equal).
bool same_gear_pair(const GearPairSpec& a, const GearPairSpec& b);

/// What the model remembers, as stored in model_state.state (JSON; every double exactly), with
/// the pair's start when given.
std::string memory_to_json(const wear::ModelMemory& memory, const PairStart* pair = nullptr);
/// Throws std::runtime_error when the text is not such a state.
wear::ModelMemory memory_from_json(const std::string& text);
/// The pair's start kept in such a state (the defaults when it has none). Throws like memory_from_json.
PairStart pair_start_from_json(const std::string& text);

/// The model's state as stored: gear pair, memory (ICS2 series rebuilt from model_runs) and the
/// states of the alerts the model thread owns (remaining_life, twin_drift).
struct StoredModel {
  std::int64_t gear_pair = 0;
  bool found = false;
  wear::ModelMemory memory;
  PairStart pair;
  std::map<AlertKey, AlertState> alerts;
  std::string problem;   ///< why a stored state could not be used ("" = fine)
};

/// The twin's RMS_SA at the sample rate of the record being handled (`rate_hz`, read at each call;
/// the configured rig.sample_rate_hz while it is 0).
wear::RmsSaSimulator rms_sa_simulator_at_record_rate(const twin::GearboxParameters& params, const config::GearwatchConfig& config,
                                                     const double& rate_hz);
StoredModel load_model(const std::string& database_path);

struct ModelCounters {
  std::atomic<std::uint64_t> received{0};
  std::atomic<std::uint64_t> caught_up{0};     ///< stored records handled at start (the backlog)
  std::atomic<std::uint64_t> handled{0};
  std::atomic<std::uint64_t> coalesced{0};     ///< records dropped because the model was behind (live)
  std::atomic<std::uint64_t> failures{0};      ///< records whose handling threw (logged, stored as not advanced)
  std::atomic<std::uint64_t> queue_high_water{0};
  std::atomic<std::uint64_t> gap_reports{0};       ///< gap diagnoses stored
  std::atomic<std::uint64_t> gap_failures{0};      ///< gap diagnoses that threw (logged, nothing stored)
  std::atomic<std::uint64_t> gap_k_wear_skipped{0};  ///< gap reports stored without K_wear (the twin could not tell it)
  std::atomic<std::uint64_t> gap_records_without_channel{0};  ///< records the gap step could not use: no compared channel
  std::atomic<std::uint64_t> cpu_ns{0};        ///< CPU time of the model thread, set when it ends (gap diagnoses included)
  std::atomic<std::uint64_t> gap_cpu_ns{0};    ///< CPU time of its gap diagnoses
};


class ModelThread {
 public:
  /// `lossless`: submit() waits for room instead of coalescing (replay).
  ModelThread(const config::GearwatchConfig& config, storage::StorageWriter& writer, bool lossless, GapHooks gap = {});
  ~ModelThread();
  ModelThread(const ModelThread&) = delete;
  ModelThread& operator=(const ModelThread&) = delete;

  /// Loads the stored state and the stored backlog (handled before anything submitted: crash
  /// and resume give the state of an uninterrupted history) and starts the thread; throws (with the reason) when the twin's
  /// parameters or the model settings are unusable, or gap.enabled has no diagnosis to run.
  void start();
  /// Never waits when live (see the overflow policy); waits for room when lossless.
  void submit(ModelInput input);
  /// Terminate: drains what is queued, then joins.
  void stop();
  const ModelCounters& counters() const noexcept { return counters_; }

 private:
  void run();
  /// Decides at start whether the next usable record begins a new gear pair (no stored state,
  /// a stored state that cannot be used, or a stored pair that is not the configured one).
  void plan_pair_start(const StoredModel& stored);
  /// The record's cycles on the pair's axis; begins a new pair first when one is due (planned, or
  /// by the gear-pair rule: a recorded reset, or the life counter went backwards). Returns what the
  /// record's run says about it ("" = nothing).
  std::string place_on_pair(wear::ModelObservation& obs, storage::ModelRunResult& msg);
  void handle(const ModelInput& input, std::uint64_t skipped, const std::string& skipped_ids);
  std::vector<wear::Inspection> read_inspections() const;
  wear::ModelRunReport observe(const ModelInput& input, const wear::ModelObservation& observation,
                               const std::vector<wear::Inspection>& inspections);
  void log_report(const wear::ModelRunReport& r, double cycles);
  void start_new_gear_pair(storage::ModelRunResult& msg);
  void observe_remaining_life(const wear::ModelRunReport& r, storage::ModelRunResult& msg);
  void diagnose_gap();
  /// The counters and records an earlier process kept for the next diagnosis of this gear pair.
  void restore_gap_schedule();
  /// Adds the record to the gap schedule and puts what changes into the record's model run (stored
  /// in its transaction); true when a diagnosis is due.
  bool add_gap_sample(const ModelInput& input, storage::ModelRunResult& msg);

  config::GearwatchConfig config_;
  storage::StorageWriter& writer_;
  bool lossless_;
  ModelCounters counters_;
  std::unique_ptr<wear::TwinModel> model_;
  twin::GearboxParameters params_;
  wear::ModelSettings settings_;
  wear::RmsSaSimulator simulator_;
  std::int64_t gear_pair_ = 0;
  PairStart pair_;
  /// A new pair the next record with a life-counter position begins.
  struct PendingPair {
    std::string reason;
    bool counted_by_life_counter = false;  ///< its cycle 0 is the counter's 0 (else the record's count)
    bool new_number = true;                ///< false for a database's first pair (it keeps its number)
  };
  std::optional<PendingPair> pending_pair_;
  /// A life-counter reset recorded since the last record with a count (it begins the next such record's pair).
  bool reset_recorded_ = false;
  double record_rate_hz_ = 0;  ///< sample rate of the record being handled (model thread only)
  AlertTracker alerts_;
  GapHooks gap_;
  std::optional<GapSchedule> gap_schedule_;
  std::mutex mutex_;
  std::condition_variable not_empty_, not_full_;
  std::deque<ModelInput> queue_;
  std::deque<ModelInput> backlog_;   ///< read at start; used by the model thread only
  std::uint64_t pending_skipped_ = 0;
  std::string pending_skipped_ids_;
  std::map<wear::ModelIssue, std::uint64_t> issue_counts_;
  bool terminate_ = false;
  std::thread thread_;
};

}  // namespace gearwatch::daemon
