#pragma once
// The scores of `gearwatch bench prognosis` (docs/model.md, "Prognosis benchmark"): pure functions
// on numbers, so they are checked against hand-computed answers without the rig or the model.
// A forecast "beyond the horizon" is +infinity throughout; a record without a forecast is a miss
// on every score it enters.
#include <cstddef>
#include <functional>
#include <limits>
#include <optional>
#include <vector>

namespace gearwatch::daemon::prognosis {

inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

/// A quantity of the truth as a function of cycles (pitting density, deepest flank point).
using TruthCurve = std::function<double(double cycles)>;

/// The first cycle count in [from, to] at which `curve` reaches `level`: the curve is evaluated
/// forward at from, from + step, from + 2·step, … (never past `to`); on the first bracket whose
/// upper end reaches the level, bisection narrows it to `tolerance` cycles and the bracket's upper
/// end is returned (the curve has reached the level there). nullopt: not reached by `to`. Only
/// the values at the evaluated points are used, so a curve that crosses and falls back between
/// two of them is not seen. Throws std::invalid_argument for a step or tolerance that is not
/// positive, or to < from.
std::optional<double> first_crossing(const TruthCurve& curve, double level, double from, double to, double step,
                                     double tolerance);

/// The stops at which the maintenance engineer inspects: the first stop whose truth exceeds
/// levels[0], then the first later stop exceeding levels[1], and so on; a level never exceeded
/// ends the list (a dry campaign without pitting gets none). Indices into `truth`.
std::vector<std::size_t> inspection_stops(const std::vector<double>& truth, const std::vector<double>& levels);

/// The first index whose value exceeds `level`; nullopt when none does.
std::optional<std::size_t> first_above(const std::vector<double>& values, double level);

/// (value − truth) / truth. +infinity for an infinite value, NaN for a truth of 0.
double relative_error(double value, double truth);

/// max and median of |error| over a set, and how many lie within the target.
struct ErrorSummary {
  std::size_t count = 0;
  std::size_t within = 0;   ///< |error| ≤ target
  double max_abs = std::numeric_limits<double>::quiet_NaN();      ///< NaN when count = 0
  double median_abs = std::numeric_limits<double>::quiet_NaN();   ///< mean of the two middle values for an even count
};
/// Errors may be infinite (a forecast beyond the horizon); NaN errors are refused
/// (std::invalid_argument): an undefined error must be left out by the caller, not averaged.
ErrorSummary summarise_errors(const std::vector<double>& errors, double target);

/// A forecast's cycles left to a limit: nominal value and interval, each +infinity where the
/// forecast says "beyond the horizon". `valid` false: the model gave no forecast at that record.
struct CyclesLeft {
  bool valid = false;
  double nominal = kInfinity, low = kInfinity, high = kInfinity;
};

/// low ≤ truth ≤ high (a truth of +infinity is held by an interval open above). False when not valid.
bool interval_holds(const CyclesLeft& forecast, double truth_cycles_left);

/// One record's forecast of one limit.
struct ForecastAt {
  double cycles = 0;        ///< the record's
  CyclesLeft left;
};

/// The scores of one limit over a campaign's forecasts, from the first record past the start
/// level on (the caller picks those records).
struct LimitScore {
  std::size_t forecasts = 0;         ///< scored forecasts (missing ones included)
  std::size_t missing = 0;           ///< records without a forecast
  std::size_t covered = 0;           ///< interval holds the truth's cycles left
  std::size_t reached = 0;           ///< records at or past the truth's crossing
  std::size_t excluded_reached = 0;  ///< of those, forecasts given whose interval excludes 0 cycles left
  std::size_t truth_beyond = 0;      ///< forecasts where the truth does not reach the limit by the search's end
  /// Relative errors of the nominal cycles left, for records before the truth's crossing (a
  /// missing forecast counts as +infinity).
  std::vector<double> errors;
};

/// Scores forecasts against the truth's crossing (cycles at which the truth reaches the limit;
/// +infinity when it does not by the end of the search). The truth's cycles left at a record is
/// max(0, crossing − cycles).
LimitScore score_limit(const std::vector<ForecastAt>& forecasts, double truth_crossing_cycles);

/// Sums the counts and concatenates the errors.
LimitScore combine(const std::vector<LimitScore>& scores);

/// covered / forecasts; NaN when there are none.
double coverage(const LimitScore& score);

}  // namespace gearwatch::daemon::prognosis
