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
#include "gearwatch/gap/gap_report.hpp"
#include "gearwatch/record.hpp"
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

/// What the gap step keeps of one analysed record until the next diagnosis.
struct GapSample {
  std::shared_ptr<const Record> measured;
  wear::WearState state;
  std::uint64_t stream_sequence = 0;
  std::uint64_t start_index = 0;
};

/// Every `every_records` analysed records, once it holds training + held-out records: the oldest
/// `training` of the newest (training + held_out) are the training set, the newest `held_out` the
/// held-out set (other cycles, and other speeds when the load changed), so a diagnosis is always
/// scored on records newer than the ones it was fitted on.
class GapSchedule {
 public:
  GapSchedule(std::size_t every_records, std::size_t training, std::size_t held_out);
  /// Keeps the sample (dropping the oldest beyond what a diagnosis needs); true when a diagnosis is due.
  bool add(GapSample sample);
  /// The split of the samples held now: first training, then held out.
  std::pair<std::vector<const GapSample*>, std::vector<const GapSample*>> split() const;
  const GapSample& newest() const { return samples_.back(); }

 private:
  std::size_t every_, training_, held_out_;
  std::size_t since_last_ = 0;
  std::deque<GapSample> samples_;
};

}  // namespace gearwatch::daemon
