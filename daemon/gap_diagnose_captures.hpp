#pragma once
// The diagnosis of `gearwatch gap diagnose` on a list of captures, for other commands (the
// independent `gap bench`): the same reading, cutting, twin counterparts and run_gap_diagnosis.
#include <memory>
#include <string>
#include <vector>

#include "gearwatch/config/config.hpp"
#include "gearwatch/types/gap_report.hpp"

namespace gearwatch::daemon {
class SharedTwinRuns;
}

namespace gearwatch::cli {

/// The records of `training` train and those of `held_out` are held out, each against the twin at
/// its own speed, torque and rate, unworn (no --db). Throws CommandError as `gap diagnose` refuses.
/// `twin_runs`: counterparts kept across calls (share_twin_counterparts_across_diagnoses); without
/// it, the runs of this call's records alone are shared, as in `gap diagnose`.
gap::GapReport diagnose_capture_files(const std::vector<std::string>& training, const std::vector<std::string>& held_out,
                                      const config::GearwatchConfig& cfg,
                                      std::shared_ptr<daemon::SharedTwinRuns> twin_runs = {});

}  // namespace gearwatch::cli
