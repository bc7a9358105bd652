#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <stdexcept>

#include "gearwatch/gap/candidates.hpp"
#include "gearwatch/gap/evaluation.hpp"

namespace gearwatch::gap {
namespace {

constexpr std::size_t kFamilies = kAllFamilyKinds.size();

/// The training objective: the mean squared log ratio of each line/bin family, families weighted
/// alike (the broadband family has thousands of bins, the shaft orders a few).
double cost_of(const std::vector<SummaryPair>& pairs, const std::vector<AppliedEffect>& fx,
               const GearPairSpec& gears, const GapEvaluator& evaluator) {
  std::vector<SpectralSummary> models;
  for (const auto& p : pairs) models.push_back(apply_effects(fx, p.twin, gears));
  std::vector<GapPair> v;
  for (std::size_t i = 0; i < pairs.size(); ++i) v.push_back({&pairs[i].measured, &models[i], pairs[i].floor});
  const auto e = evaluator.evaluate(v, false);
  double cost = 0;
  for (std::size_t f = 0; f < kFamilies; ++f)
    if (e.count[f] > 0) cost += e.sum_sq[f] / e.count[f];
  return cost;
}

}  // namespace

double training_cost(const std::vector<SummaryPair>& training, const std::vector<AppliedEffect>& effects,
                     const GearPairSpec& gears) {
  return cost_of(training, effects, gears, GapEvaluator(gears));
}

namespace {
/// The values a form's fitted parameters stand for (a sub-form's: the full form's values).
using Expansion = std::function<std::vector<double>(const std::vector<double>&)>;

/// The fit of a form's own parameters on training records (of one load, for a per-load form): a
/// grid over each parameter's range (log where marked), then Nelder–Mead from the best starts.
std::vector<double> fit_values(const CandidateForm& form, const std::vector<AppliedEffect>& base,
                               const std::vector<SummaryPair>& training, const GearPairSpec& gears,
                               const Expansion& expand = {});

/// A form's values with their training cost, the base effects beneath them.
std::pair<double, std::vector<double>> costed(CandidateEffect effect, const std::vector<AppliedEffect>& base,
                                              const std::vector<SummaryPair>& training, const GearPairSpec& gears,
                                              std::vector<double> values) {
  auto fx = base;
  fx.push_back({effect, values});
  return {training_cost(training, fx, gears), std::move(values)};
}

/// A speed ripple is either fixed in Hz (a drive's ripple: {depth, f_m, μ}) or locked to a shaft's
/// order (once per revolution of the input or the output shaft: a bent shaft, a coupling's
/// misalignment, whatever the speed). The three are fitted apart (a locked ripple has no frequency
/// to fit: depth and μ only) and the lowest training cost is kept, as {depth, f_m or 0, μ, order or 0}.
std::vector<double> fit_speed_fluctuation(const CandidateForm& form, const std::vector<AppliedEffect>& base,
                                          const std::vector<SummaryPair>& training, const GearPairSpec& gears) {
  auto with_cost = [&](std::vector<double> v) { return costed(form.effect, base, training, gears, std::move(v)); };
  auto hz = fit_values(form, base, training, gears);
  hz.push_back(0.0);
  auto best = with_cost(std::move(hz));
  CandidateForm locked = form;
  locked.parameters = {form.parameters[0], form.parameters[2]};
  locked.parameters[1].grid = 1;  // μ: one start; the descent moves it
  for (double order : {1.0, static_cast<double>(gears.pinion_teeth) / gears.gear_teeth}) {
    const Expansion expand = [order](const std::vector<double>& u) { return std::vector<double>{u[0], 0.0, u[1], order}; };
    auto candidate = with_cost(expand(fit_values(locked, base, training, gears, expand)));
    if (candidate.first < best.first) best = std::move(candidate);
  }
  return best.second;
}

/// A load ripple is either fixed in Hz (the brake's torque ripple twisting the train: {β, f_m}) or
/// locked to a shaft's order (the mesh force rising and falling once a revolution of the input or
/// the output shaft: an AM index m and no phase part). The three are fitted apart and the lowest
/// training cost is kept, as {β, f_m, 0, 0} or {0, 0, m, order}.
std::vector<double> fit_load_fluctuation(const CandidateForm& form, const std::vector<AppliedEffect>& base,
                                         const std::vector<SummaryPair>& training, const GearPairSpec& gears) {
  auto with_cost = [&](std::vector<double> v) { return costed(form.effect, base, training, gears, std::move(v)); };
  CandidateForm in_hz = form;
  in_hz.parameters = {form.parameters[0], form.parameters[1]};
  const Expansion hz_values = [](const std::vector<double>& u) { return std::vector<double>{u[0], u[1], 0.0, 0.0}; };
  auto best = with_cost(hz_values(fit_values(in_hz, base, training, gears, hz_values)));
  CandidateForm locked = form;
  locked.parameters = {form.parameters[2]};
  for (double order : {1.0, static_cast<double>(gears.pinion_teeth) / gears.gear_teeth}) {
    const Expansion expand = [order](const std::vector<double>& u) { return std::vector<double>{0.0, 0.0, u[0], order}; };
    auto candidate = with_cost(expand(fit_values(locked, base, training, gears, expand)));
    if (candidate.first < best.first) best = std::move(candidate);
  }
  return best.second;
}
}  // namespace

std::vector<double> fit_candidate(CandidateEffect effect, const std::vector<AppliedEffect>& base,
                                  const std::vector<SummaryPair>& training, const GearPairSpec& gears) {
  if (training.empty()) throw std::invalid_argument("fit_candidate: no training records");
  CandidateForm form = candidate_form(effect, training.front().measured.sample_rate_hz);
  if (effect == CandidateEffect::speed_fluctuation) return fit_speed_fluctuation(form, base, training, gears);
  if (effect == CandidateEffect::load_fluctuation) return fit_load_fluctuation(form, base, training, gears);
  if (!form.per_load) return fit_values(form, base, training, gears);
  // One group per training load: its load, then the form's parameters fitted on that load's records.
  std::vector<double> loads;
  for (const auto& p : training)
    if (std::find(loads.begin(), loads.end(), load_key(p.measured.torque_nm)) == loads.end())
      loads.push_back(load_key(p.measured.torque_nm));
  std::vector<double> values;
  for (double load : loads) {
    std::vector<SummaryPair> subset;
    for (const auto& p : training)
      if (load_key(p.measured.torque_nm) == load) subset.push_back(p);
    values.push_back(load);
    const auto v = fit_values(form, base, subset, gears);
    values.insert(values.end(), v.begin(), v.end());
  }
  return values;
}

namespace {
/// The fit of a form's own parameters on training records (of one load, for a per-load form): a
/// grid over each parameter's range (log where marked), then Nelder–Mead from the best starts.
/// The search runs on the unit box, one coordinate per parameter.
class FormFit {
 public:
  FormFit(const CandidateForm& form, const std::vector<AppliedEffect>& base, const std::vector<SummaryPair>& training,
          const GearPairSpec& gears, const Expansion& expand)
      : form_(form), base_(base), training_(training), gears_(gears), evaluator_(gears), d_(form.parameters.size()),
        expand_(expand) {}

  std::vector<double> run() const {
    if (form_.effect == CandidateEffect::tip_relief) return tip_relief_gains();
    auto starts = start_grid();
    std::sort(starts.begin(), starts.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<double> best_u = starts.front().second;
    double best = starts.front().first;
    for (const std::size_t s : descent_starts(starts)) {
      const Simplex simplex = nelder_mead(starts[s]);
      const auto it = std::min_element(simplex.values.begin(), simplex.values.end());
      if (*it < best) best = *it, best_u = simplex.points[static_cast<std::size_t>(it - simplex.values.begin())];
    }
    auto v = to_value(best_u);
    if (form_.interchangeable_pair && v[0] > v[1]) std::swap(v[0], v[1]);
    return v;
  }

 private:
  using Start = std::pair<double, std::vector<double>>;  // its cost, its point
  struct Simplex {
    std::vector<std::vector<double>> points;
    std::vector<double> values;
  };

  /// A point of the unit box as the form's parameter values.
  std::vector<double> to_value(const std::vector<double>& u) const {
    std::vector<double> v(d_);
    for (std::size_t i = 0; i < d_; ++i) {
      const auto& p = form_.parameters[i];
      const double t = std::clamp(u[i], 0.0, 1.0);
      v[i] = p.log_scale ? std::exp(std::log(p.low) + t * (std::log(p.high) - std::log(p.low)))
                         : p.low + t * (p.high - p.low);
    }
    return v;
  }

  /// A per-load form is applied with its group's load in front (every record here has that load).
  std::vector<double> applied(std::vector<double> v) const {
    if (expand_) v = expand_(v);
    if (form_.per_load) v.insert(v.begin(), load_key(training_.front().measured.torque_nm));
    return v;
  }

  double cost(const std::vector<double>& u) const {
    auto fx = base_;
    fx.push_back({form_.effect, applied(to_value(u))});
    return cost_of(training_, fx, gears_, evaluator_);
  }

  int grid(std::size_t i) const { return std::max(1, form_.parameters[i].grid); }

  /// Separable in the log domain: each harmonic's gain is the mean log ratio there (floors make
  /// it approximate). Harmonics no training record holds stay at 0 dB.
  std::vector<double> tip_relief_gains() const {
    const std::size_t h_max = form_.parameters.size();
    std::vector<double> sum(h_max, 0.0), n(h_max, 0.0);
    for (const auto& p : training_) {
      const auto model = apply_effects(base_, p.twin, gears_);
      const auto& m = p.measured.input_lines;
      const auto& q = model.input_lines;
      const auto z1 = static_cast<std::size_t>(gears_.pinion_teeth);
      for (std::size_t h = 1; h <= h_max && h * z1 <= std::min(m.size(), q.size()); ++h) {
        sum[h - 1] += 10 * std::log10((m[h * z1 - 1] + p.floor) / (q[h * z1 - 1] + p.floor));
        n[h - 1] += 1;
      }
    }
    std::vector<double> v(h_max);
    for (std::size_t i = 0; i < h_max; ++i) v[i] = n[i] > 0 ? std::clamp(sum[i] / n[i], -60.0, 60.0) : 0.0;
    return v;
  }

  /// Every cell centre of the start grid with its cost (an interchangeable pair's mirror images
  /// once), in the grid's order.
  std::vector<Start> start_grid() const {
    std::vector<Start> starts;
    std::vector<int> idx(d_, 0);
    while (true) {
      std::vector<double> u(d_);
      for (std::size_t i = 0; i < d_; ++i) u[i] = grid(i) == 1 ? 0.5 : (idx[i] + 0.5) / grid(i);
      const bool mirrored = form_.interchangeable_pair && idx[0] > idx[1];
      if (!mirrored) starts.emplace_back(cost(u), u);
      std::size_t i = 0;
      for (; i < d_; ++i) {
        if (++idx[i] < grid(i)) break;
        idx[i] = 0;
      }
      if (i == d_) return starts;
    }
  }

  /// Descents from the two best starts; for an interchangeable pair, the two best with different
  /// pairs of mode cells: starts in one pair that differ in damping or mass lead to one basin (the
  /// descent moves those freely), while a mode a cell away is a basin of its own. A casing at 151 and
  /// 396 Hz (67 kg) was otherwise fitted as 264 and 392 Hz from two starts at (396, 396) Hz, at a
  /// training cost above the truth's.
  std::vector<std::size_t> descent_starts(const std::vector<Start>& starts) const {
    std::vector<std::size_t> descents;
    for (std::size_t s = 0; s < starts.size() && descents.size() < 2; ++s) {
      const auto& u = starts[s].second;
      const bool same_cells = form_.interchangeable_pair && std::any_of(descents.begin(), descents.end(), [&](std::size_t t) {
                                return starts[t].second[0] == u[0] && starts[t].second[1] == u[1];
                              });
      if (!same_cells) descents.push_back(s);
    }
    return descents;
  }

  /// The first simplex: the start and, for each parameter, the start moved half a grid cell
  /// towards the box's middle.
  Simplex initial_simplex(const Start& start) const {
    Simplex simplex{{start.second}, {start.first}};
    for (std::size_t i = 0; i < d_; ++i) {
      auto u = start.second;
      u[i] = std::clamp(u[i] + 0.5 / grid(i) * (u[i] > 0.5 ? -1 : 1), 0.0, 1.0);
      simplex.points.push_back(u);
      simplex.values.push_back(cost(u));
    }
    return simplex;
  }

  /// Nelder–Mead on the unit box (clamped), step a grid cell.
  Simplex nelder_mead(const Start& start) const {
    Simplex simplex = initial_simplex(start);
    for (int it = 0; it < 60 * static_cast<int>(d_); ++it)
      if (!nelder_mead_step(simplex)) break;
    return simplex;
  }

  /// One reflection, expansion, contraction or shrink; false once the simplex's costs agree.
  bool nelder_mead_step(Simplex& simplex) const {
    auto& values = simplex.values;
    std::vector<std::size_t> order(d_ + 1);
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::sort(order.begin(), order.end(), [&](auto a, auto b) { return values[a] < values[b]; });
    const std::size_t worst = order[d_], second = order[d_ - 1], lowest = order[0];
    if (values[worst] - values[lowest] < 1e-7 * (1 + std::abs(values[lowest]))) return false;
    const auto centre = centroid_without(simplex, worst);
    auto point = [&](double t) {
      std::vector<double> u(d_);
      for (std::size_t i = 0; i < d_; ++i)
        u[i] = std::clamp(centre[i] + t * (simplex.points[worst][i] - centre[i]), 0.0, 1.0);
      return u;
    };
    auto replace_worst = [&](std::vector<double> u, double f) { simplex.points[worst] = std::move(u), values[worst] = f; };
    auto xr = point(-1.0);
    const double fr = cost(xr);
    if (fr < values[lowest]) {
      auto xe = point(-2.0);
      const double fe = cost(xe);
      if (fe < fr) replace_worst(xe, fe);
      else replace_worst(xr, fr);
    } else if (fr < values[second]) {
      replace_worst(xr, fr);
    } else {
      auto xc = point(0.5);
      const double fc = cost(xc);
      if (fc < values[worst]) replace_worst(xc, fc);
      else shrink_towards(simplex, lowest);
    }
    return true;
  }

  std::vector<double> centroid_without(const Simplex& simplex, std::size_t worst) const {
    std::vector<double> centre(d_, 0.0);
    for (std::size_t j = 0; j <= d_; ++j)
      if (j != worst)
        for (std::size_t i = 0; i < d_; ++i) centre[i] += simplex.points[j][i] / static_cast<double>(d_);
    return centre;
  }

  void shrink_towards(Simplex& simplex, std::size_t lowest) const {
    for (std::size_t j = 0; j <= d_; ++j)
      if (j != lowest) {
        for (std::size_t i = 0; i < d_; ++i) simplex.points[j][i] = 0.5 * (simplex.points[j][i] + simplex.points[lowest][i]);
        simplex.values[j] = cost(simplex.points[j]);
      }
  }

  const CandidateForm& form_;
  const std::vector<AppliedEffect>& base_;
  const std::vector<SummaryPair>& training_;
  const GearPairSpec& gears_;
  const GapEvaluator evaluator_;
  const std::size_t d_;
  const Expansion& expand_;
};

std::vector<double> fit_values(const CandidateForm& form, const std::vector<AppliedEffect>& base,
                               const std::vector<SummaryPair>& training, const GearPairSpec& gears, const Expansion& expand) {
  return FormFit(form, base, training, gears, expand).run();
}

}  // namespace

}  // namespace gearwatch::gap
