#pragma once
// `gearwatch gap bench --generator independent`: the gap diagnosis scored on effects made by a
// generator written apart from the rig and the diagnosis (tests/capture_gen/gap_effects.py), on
// the twin's own captures (docs/gap-bench.md, "Independent bench scoring rules").
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gearwatch/types/gap_report.hpp"

namespace gearwatch::cli {

struct IndependentBenchOptions {
  int seeds = 30;
  std::uint64_t first_seed = 1;
  std::string format = "table";
  std::string config;                       ///< "" = the built-in defaults
  double sample_rate_hz = 50000;
  double seconds = 2.5;                     ///< > [records] min_length_s, so each capture is one record
  std::vector<double> torques_nm{20.0, 5.0};
  std::vector<double> speeds_hz{9.0, 11.5, 13.5, 16.0};
  double held_out_speed_hz = 11.5;          ///< its records (both loads) are held out, the others train
  std::string python;                       ///< "" = $GEARWATCH_PYTHON, else /usr/bin/python3, else python3
  std::string script = "tests/capture_gen/gap_effects.py";
  int bootstrap = -1;                       ///< -1 = [gap] bootstrap_resamples
  int jobs = 1;                             ///< draws diagnosed side by side, each on its own thread
};

/// The descriptive form a feature of the true effect should get, its main parameter, and the
/// physical candidates that stand for it (empty: none applies).
struct ExpectedReading {
  std::vector<gap::DescriptionKind> kinds;
  std::vector<gap::CandidateEffect> candidates;
};

/// One draw's truth (truth.json) scored against its report (rules in docs/gap-bench.md).
struct DrawScore {
  std::string form;
  bool effect = false;          ///< false: a no-effect draw
  bool localised = false;
  bool described = false;
  bool attribution_applies = false;
  bool attributed = false;
  bool any_finding = false;     ///< a feature or a significant family
  nlohmann::json detail;
};

DrawScore score_draw(const nlohmann::json& truth, const gap::GapReport& report, double top_speed_hz, double sample_rate_hz);

void run_independent_bench(const IndependentBenchOptions& options);

}  // namespace gearwatch::cli
