#pragma once
// The one place where the daemon's periodic gap step is bound to the diagnosis and to the twin's
// simulation (docs/gap-report.md). Tests inject their own GapDiagnoser instead.
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

/// The twin's casing signal for a measured record: y6 at the record's speed, torque, length and
/// sample rate for the given wear state, as a one-channel Record numbered like the compared
/// channel, with the simulated input-shaft tacho edges.
TwinCounterpart make_twin_counterpart(const twin::GearboxParameters& params, const config::GearwatchConfig& config);

/// The counterpart re-run with a rerun candidate's addition (gap::add_rerun_effect on the wear
/// state's profile or on the simulation's options); empty when `gap.rerun_twin` is false.
TwinRerunCounterpart make_twin_rerun(const twin::GearboxParameters& params, const config::GearwatchConfig& config);

/// The measured channel the gap step compares: gap.channel, else the model's.
int gap_channel(const config::GearwatchConfig& config);

}  // namespace gearwatch::daemon
