#pragma once
// The diagnosis of `gearwatch gap diagnose` on a list of captures, for other commands (the
// independent `gap bench`): the same reading, cutting, twin counterparts and run_gap_diagnosis.
#include <string>
#include <vector>

#include "gearwatch/config/config.hpp"
#include "gearwatch/types/gap_report.hpp"

namespace gearwatch::cli {

/// The records of `training` train and those of `held_out` are held out, each against the twin at
/// its own speed, torque and rate, unworn (no --db). Throws CommandError as `gap diagnose` refuses.
gap::GapReport diagnose_capture_files(const std::vector<std::string>& training, const std::vector<std::string>& held_out,
                                      const config::GearwatchConfig& cfg);

}  // namespace gearwatch::cli
