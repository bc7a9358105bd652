#pragma once
// The daemon's side of the sim-to-real gap (docs/gap-report.md): the twin_drift alert from a
// sequence of gap reports, and the periodic diagnosis the model thread runs on its recent records.
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/alerts.hpp"
#include "gearwatch/gap/diagnosis.hpp"
#include "gearwatch/types/gap_report.hpp"
#include "gearwatch/types/record.hpp"
#include "gearwatch/wear/wear_loop.hpp"

namespace gearwatch::daemon {

/// One observation of twin drift per resolved family of the report's held-out gaps with the twin
/// alone (`before`): a family significant now and not raised raises a warning (subject = the
/// family, value = its distance in dB as "%.1f dB"), one no longer significant clears it after the
/// hysteresis. While raised, a new distance is not a new event: the value stays the one raised
/// (each report's distance differs a little, and staff must not hear of the same drift at every
/// report). An unresolved family is no observation at all: it neither raises nor clears.
std::vector<AlertEvent> observe_twin_drift(AlertTracker& tracker, const gap::GapReport& report, AlertHysteresis hysteresis);

/// What one periodic diagnosis may use beyond its pairs (each member may be empty):
///  - the twin re-run with a rerun candidate's addition at the wear state of the record it stands
///    for (empty: misalignment and tip relief keep their spectral forms);
///  - the K_wear inference: the model's K_wear, which the twin's wear states came from, and the
///    twin's d ln RMS_SA / d ln K_wear at each held-out record (empty: no K_wear in the report).
struct GapCallContext {
  gap::TwinRerun rerun_twin;
  std::optional<double> reference_k_wear;
  std::vector<double> rms_sa_wear_elasticities;
};

/// The diagnosis as the daemon calls it: training and held-out pairs of measured record and twin
/// counterpart in, one report out. Throws (std::invalid_argument and others) when it cannot diagnose.
using GapDiagnoser = std::function<gap::GapReport(const std::vector<gap::DiagnosisInput>&,
                                                  const std::vector<gap::DiagnosisInput>&, const GapCallContext&)>;

/// The twin's simulation of a measured record: same speed, torque and sample rate, at the wear state
/// the model had reached at that record; as long as the record, but at most gap::twin_duration_s
/// (2 s or 20 revolutions: the twin repeats itself every revolution).
using TwinCounterpart = std::function<Record(const Record& measured, const wear::WearState& state)>;

/// The same with a rerun candidate's addition (gap::add_rerun_effect) at `values`, `duration_s` long
/// (what the diagnosis asks for: gap::twin_duration_s).
using TwinRerunCounterpart =
    std::function<Record(const Record& measured, const wear::WearState& state, gap::CandidateEffect effect,
                         const std::vector<double>& values, double duration_s)>;

/// What the periodic gap step calls; empty members are bound from the configuration when the
/// model thread starts (gap_diagnoser.hpp). Tests inject their own. `rerun` stays empty when
/// `gap.rerun_twin` is false.
struct GapHooks {
  GapDiagnoser diagnose;
  TwinCounterpart twin;
  TwinRerunCounterpart rerun;
};

/// d ln RMS_SA(N) / d ln K_wear of the twin at a record: the counterpart at the wear depths ×0.8 and
/// ×1.25 (depth ∝ K_wear at a constant operating point, Archard), RMS_SA(N) read from the
/// diagnosis's own input-order lines of `channel`. Throws std::invalid_argument when the twin's
/// RMS_SA is not positive at either depth.
double twin_rms_sa_wear_elasticity(const TwinCounterpart& twin, const Record& measured, const wear::WearState& state,
                                   int channel, const GearPairSpec& gears, int harmonics);

/// What the gap step keeps of one analysed record until the diagnosis that uses it.
struct GapSample {
  std::shared_ptr<const Record> measured;   ///< one channel: kept_gap_record()
  wear::WearState state;
  std::uint64_t stream_sequence = 0;
  std::uint64_t start_index = 0;
  std::uint64_t position = 0;               ///< set by GapSchedule::add: 1, 2, ... for this gear pair
};

/// The record as the gap step keeps and the diagnosis reads it: the compared channel (protocol
/// number `channel`) alone, with the tacho edges, rate, stream id, start index, speed, torque and life
/// position. Nothing else of a record reaches the diagnosis, so a record kept in memory and one read
/// back from the database (storage::load_gap_schedule) are the same. Empty when the record does not
/// carry that channel (its frames stopped, or the stream does not announce it).
std::optional<Record> kept_gap_record(const Record& record, int channel);

/// Every `every_records` analysed records, once it has had training + held-out records: the oldest
/// `training` of the newest (training + held_out) are the training set, the newest `held_out` the
/// held-out set (other cycles, and other speeds when the load changed), so a diagnosis is always
/// scored on records newer than the ones it was fitted on.
///
/// It keeps only what a coming diagnosis can use: the position of the next diagnosis follows from
/// the counters alone, so a record more than training + held_out positions before it is never
/// needed (with every_records = 50 and 4 + 2 records, 6 of every 50). restore() rebuilds the same
/// schedule from the counters and the kept records of an earlier process.
class GapSchedule {
 public:
  GapSchedule(std::size_t every_records, std::size_t training, std::size_t held_out);

  struct Step {
    bool due = false;                      ///< a diagnosis is due now (split() gives its records)
    bool keep = false;                     ///< a later diagnosis can use this record: store it
    std::uint64_t position = 0;            ///< this record's position
    std::uint64_t drop_through_position = 0;  ///< no later diagnosis uses a record at or before this
  };
  /// Adds the sample as the next position.
  Step add(GapSample sample);
  /// The counters and kept samples an earlier process stored (positions set, oldest first); samples
  /// no coming diagnosis can use are left out.
  void restore(std::uint64_t records_added, std::uint64_t since_diagnosis, std::vector<GapSample> kept);
  /// The split of the newest training + held-out samples: first training, then held out.
  std::pair<std::vector<const GapSample*>, std::vector<const GapSample*>> split() const;
  const GapSample& newest() const { return samples_.back(); }
  std::uint64_t records_added() const noexcept { return added_; }
  std::uint64_t since_diagnosis() const noexcept { return since_last_; }
  std::size_t held() const noexcept { return samples_.size(); }

 private:
  std::uint64_t next_due_position() const noexcept;
  void drop_through(std::uint64_t position);

  std::size_t every_, training_, held_out_;
  std::uint64_t added_ = 0;
  std::uint64_t since_last_ = 0;
  std::deque<GapSample> samples_;
};

/// One diagnosis as the daemon makes it from kept samples: each sample's twin counterpart at its
/// own wear state, the twin re-run for a candidate at the wear state of the record it stands for
/// (when the hooks have a rerun), and K_wear with and without the chosen effects when `model_k_wear`
/// is positive (the twin's wear states came from it; each held-out record's elasticity from two more
/// counterparts). Shared by the periodic step and `gap diagnose`. Throws what the diagnosis throws.
struct GapRun {
  gap::GapReport report;
  std::string k_wear_skipped;  ///< why the report has no K_wear although one was asked for ("" otherwise)
};
GapRun run_gap_diagnosis(const GapHooks& hooks, const std::vector<const GapSample*>& training,
                         const std::vector<const GapSample*>& held_out, double model_k_wear, const GearPairSpec& gears,
                         int rms_sa_harmonics);

}  // namespace gearwatch::daemon
