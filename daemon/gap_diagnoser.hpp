#pragma once
// The one place where the daemon's periodic gap step is bound to the diagnosis and to the twin's
// simulation (docs/gap-report.md). Tests inject their own GapDiagnoser instead.
#include <memory>
#include <vector>

#include "gap_monitor.hpp"
#include "gearwatch/config/config.hpp"
#include "gearwatch/twin/gearbox_parameters.hpp"

namespace gearwatch::daemon {

/// The diagnosis's settings from [gap]: the bootstrap resamples and seed; the compared channel is
/// index 0, the one channel of the records the gap step keeps (kept_gap_record with gap_channel).
gap::DiagnosisSettings gap_diagnosis_settings(const config::GearwatchConfig& config);

/// The diagnosis the daemon runs with this configuration's gears and gap_diagnosis_settings(), the
/// twin's parameters (the ones its counterparts are simulated with), and each call's context (its
/// twin reruns and K_wear inference) on top.
/// Empty when this build has no diagnosis to bind: the model thread then refuses `gap.enabled`.
GapDiagnoser make_gap_diagnoser(const config::GearwatchConfig& config, const twin::GearboxParameters& params);

/// Twin runs shared by the records of one diagnosis that the twin cannot tell apart: the same
/// speed, torque, sample rate, length and wear state's profile (captures of one steady run, as
/// `gap diagnose` is given them). The twin is deterministic, so such records' counterparts and
/// reruns are the same signal; it is simulated once and stamped with each record's own stream
/// fields. Only runs of records with such a twin are kept (a record alone at its operating point
/// costs no memory); one diagnosis's worth, dropped with the last hook that holds it.
class SharedTwinRuns;
std::shared_ptr<SharedTwinRuns> share_twin_runs(const std::vector<GapSample>& samples);
/// Counterparts kept across diagnoses (the independent `gap bench`: every draw's records are the same
/// captures with other samples, so the twin at each is the same). Every counterpart is kept, keyed
/// as above and simulated once even when diagnoses on several threads ask for it at once; reruns
/// (which follow each diagnosis's fits) are simulated and not kept.
std::shared_ptr<SharedTwinRuns> share_twin_counterparts_across_diagnoses();
/// How many runs `shared` has simulated and kept so far.
std::size_t kept_twin_runs(const SharedTwinRuns& shared);

/// The twin's casing signal for a measured record: y6 at the record's speed, torque, length and
/// sample rate for the given wear state, as a one-channel Record numbered like the compared
/// channel, with the simulated input-shaft tacho edges. With `shared`, a run another record of
/// its diagnosis has made is reused.
TwinCounterpart make_twin_counterpart(const twin::GearboxParameters& params, const config::GearwatchConfig& config,
                                      std::shared_ptr<SharedTwinRuns> shared = {});

/// The counterpart re-run with a rerun candidate's addition (gap::add_rerun_effect on the wear
/// state's profile or on the simulation's options); empty when `gap.rerun_twin` is false.
TwinRerunCounterpart make_twin_rerun(const twin::GearboxParameters& params, const config::GearwatchConfig& config,
                                     std::shared_ptr<SharedTwinRuns> shared = {});

/// The measured channel the gap step compares: gap.channel, else the model's.
int gap_channel(const config::GearwatchConfig& config);

}  // namespace gearwatch::daemon
