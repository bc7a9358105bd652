#pragma once
// The rig bench's headline scores (docs/gap-bench.md, "What the records can show"): each scenario
// is scored against what its own records can show. Which true effects leave a trace is decided
// from the truth alone (the rig with the effect against the rig without it), never from the
// diagnosis's output; the report is then right to name an effect that leaves one and to stay
// silent on one that does not.
#include <array>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gearwatch/types/gap_report.hpp"

namespace gearwatch::cli {

/// One scenario as the scores read it: the truth, the effects of it whose trace the records hold,
/// and what the report says.
struct RigOutcome {
  std::vector<gap::CandidateEffect> truth;         ///< empty: a no-effect run
  std::vector<gap::CandidateEffect> identifiable;  ///< the true effects that leave a trace (from the truth)
  std::vector<gap::CandidateEffect> chosen;        ///< what the report names, in its order
  bool detected = false;                           ///< some family significant
  double shrinkage = 0;                            ///< held out, the true effects' families; NaN when not detected
};

enum class RigFigure {
  identifiable_named,       ///< scenarios with an identifiable effect: the first named is one of them
  non_identifiable_silent,  ///< scenarios whose effects leave no trace: nothing significant, nothing named
  no_effect_false_alarms,   ///< no-effect runs with something significant or named
  shrinkage,                ///< median held-out shrinkage over the identifiable scenarios (detected)
  both_named,               ///< two-effect scenarios with both identifiable: both named
};
const char* to_string(RigFigure figure) noexcept;
inline constexpr std::array kAllRigFigures{RigFigure::identifiable_named, RigFigure::non_identifiable_silent,
                                           RigFigure::no_effect_false_alarms, RigFigure::shrinkage,
                                           RigFigure::both_named};

enum class TargetBound { at_least, at_most };

/// One score with its target. A rate is part / whole; the shrinkage is a median over `whole`
/// scenarios (`part` unused). With whole = 0 the figure is not measured (value NaN, met false).
struct ScoreFigure {
  RigFigure figure{};
  double value = 0;
  int part = 0, whole = 0;
  double target = 0;
  TargetBound bound = TargetBound::at_least;
  bool measured() const noexcept { return whole > 0; }
  bool met() const noexcept;
  /// How far the value is on the wrong side of the target (0 when met or not measured).
  double missed_by() const noexcept;
};

/// The targets (docs/gap-bench.md).
double rig_target(RigFigure figure) noexcept;
TargetBound rig_bound(RigFigure figure) noexcept;

/// The report found something: a significant family or a named effect.
bool finds_something(const RigOutcome& o) noexcept;

/// The five figures, in kAllRigFigures' order, from the effect scenarios and the no-effect runs.
std::vector<ScoreFigure> score_rig_outcomes(const std::vector<RigOutcome>& scenarios, const std::vector<RigOutcome>& no_effect);

/// {"identifiable_named": {"value", "part", "whole", "target", "bound", "met", "missed_by"}, …};
/// value null when not measured.
nlohmann::json scores_json(const std::vector<ScoreFigure>& figures);
/// One line per figure for the table: "identifiable_named 0.95 (19/20; target >= 0.95: met)".
std::vector<std::string> scores_lines(const std::vector<ScoreFigure>& figures);

}  // namespace gearwatch::cli
