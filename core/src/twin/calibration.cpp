#include "gearwatch/twin/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <cstdio>
#include <string>

#include <Eigen/Dense>

#include "frequency_fit.hpp"
#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/gearbox_model.hpp"
#include "gearwatch/twin/modal_analysis.hpp"

namespace gearwatch::twin {

const std::vector<double>& table_5_5_frequencies() {
  static const std::vector<double> f = {22, 87, 218, 430, 512, 767, 1248, 1927};
  return f;
}

namespace {

using P = GearboxParameters;

std::string field_name(double P::*field) {
  for (const auto& info : parameter_table())
    if (info.field == field) return info.name;
  return "?";
}

CalibrationKnob knob(const std::string& name, std::vector<double P::*> fields) {
  const ParameterInfo* info = find_parameter(field_name(fields.front()));
  return {name, std::move(fields), info->prior_value, info->prior_low, info->prior_high};
}

// DOFs whose mass a mass/inertia parameter sets.
std::vector<int> mass_dofs(const std::string& name) {
  static const std::map<std::string, std::vector<int>> map = {
      {"I1", {theta1}},   {"I2", {theta2}},   {"I3", {theta3}},   {"I5", {theta5}},  {"I7", {theta7}},
      {"I8", {theta8}},   {"I10", {theta10}}, {"I12", {theta12}}, {"I13", {theta13}}, {"m4", {y4, x4}},
      {"m5", {y5, x5}},   {"m6", {y6, x6}},   {"m9", {y9, x9}},   {"m10", {y10, x10}}, {"m11", {y11, x11}}};
  const auto it = map.find(name);
  return it == map.end() ? std::vector<int>{} : it->second;
}

using detail::FitOutcome;
using detail::ModalEvaluation;

class Problem : public detail::FrequencyFitProblem {
 public:
  Problem(const GearboxParameters& prior, const std::vector<double>& measured, const std::vector<bool>& use,
          const std::vector<CalibrationKnob>& knobs, const CalibrationOptions& options)
      : FrequencyFitProblem(measured, use, options.frequency_sigma, options.max_iterations, "calibration"),
        base_(prior),
        knobs_(knobs) {
    const GearGeometry geometry = GearGeometry::from_spec(prior.gears);
    MeshStiffnessOptions mo;
    mo.scale = prior.mesh_stiffness_scale;
    mo.engagement_ramp_fraction = prior.engagement_ramp_fraction;
    const GearMeshStiffness mesh(geometry, mo);
    mesh_k_ = mesh.mean_stiffness() * mesh_direction(geometry) * mesh_direction(geometry).transpose();
    const std::vector<SpringElement> prior_springs = spring_elements(prior);  // the order is fixed
    for (const auto& k : knobs_) {
      double log_sum = 0;
      for (auto f : k.fields) log_sum += std::log(prior.*f);
      std::vector<std::string> spring_names;
      std::vector<int> springs, dofs;
      for (auto f : k.fields) {
        const std::string name = field_name(f);
        const std::vector<int> d = mass_dofs(name);
        if (d.empty()) spring_names.push_back(name);
        else dofs.insert(dofs.end(), d.begin(), d.end());
      }
      for (const auto& name : spring_names)
        for (std::size_t i = 0; i < prior_springs.size(); ++i)
          if (prior_springs[i].name == name) springs.push_back(static_cast<int>(i));
      add_knob(k.low, k.high, log_sum / static_cast<double>(k.fields.size()), std::move(springs), std::move(dofs));
    }
  }

  double centre(std::size_t j) const { return knob(j).log_centre; }

  GearboxParameters parameters(const Eigen::VectorXd& x) const {
    GearboxParameters p = base_;
    for (std::size_t j = 0; j < knobs_.size(); ++j)
      for (auto f : knobs_[j].fields) p.*f = std::exp(x[static_cast<Eigen::Index>(j)]);
    return p;
  }

  ModalEvaluation evaluate(const Eigen::VectorXd& x) const override {
    const GearboxParameters p = parameters(x);
    ModalEvaluation e;
    e.mass.resize(kDofCount);
    e.mass << p.I1, p.I2, p.I3, p.I5, p.I7, p.I8, p.I10, p.I12, p.I13, p.m4, p.m5, p.m6, p.m9, p.m10, p.m11, p.m4,
        p.m5, p.m6, p.m9, p.m10, p.m11;
    e.springs = spring_elements(p);
    Eigen::MatrixXd k = mesh_k_;
    for (const auto& s : e.springs) {
      k(s.a, s.a) += s.stiffness;
      if (s.b >= 0) {
        k(s.b, s.b) += s.stiffness;
        k(s.a, s.b) -= s.stiffness;
        k(s.b, s.a) -= s.stiffness;
      }
    }
    solve_modes(e.mass, k, e.frequencies, e.shapes);
    return e;
  }

  const std::vector<CalibrationKnob>& knobs() const { return knobs_; }

 private:
  GearboxParameters base_;
  std::vector<CalibrationKnob> knobs_;
  Eigen::MatrixXd mesh_k_;
};

}  // namespace

std::vector<CalibrationKnob> default_calibration_knobs() {
  return {
      knob("kt12", {&P::kt12}),
      knob("kt23", {&P::kt23}),
      knob("kt12_13", {&P::kt12_13}),
      knob("kt35", {&P::kt35}),
      knob("kt57", {&P::kt57}),
      knob("kt810", {&P::kt810}),
      knob("kt10_12", {&P::kt10_12}),
      knob("I1", {&P::I1}),
      knob("I2", {&P::I2}),
      knob("I3", {&P::I3}),
      knob("I5", {&P::I5}),
      knob("I7", {&P::I7}),
      knob("I8", {&P::I8}),
      knob("I10", {&P::I10}),
      knob("I12", {&P::I12}),
      knob("I13", {&P::I13}),
      knob("k_bearing_x", {&P::kx4, &P::kx6, &P::kx9, &P::kx11}),
      knob("k_bearing_y", {&P::ky4, &P::ky6, &P::ky9, &P::ky11}),
      knob("k_shaft_x", {&P::kx45, &P::kx56, &P::kx910, &P::kx10_11}),
      knob("k_shaft_y", {&P::ky45, &P::ky56, &P::ky910, &P::ky10_11}),
      knob("m_pedestal", {&P::m4, &P::m6, &P::m9, &P::m11}),
      knob("m5", {&P::m5}),
      knob("m10", {&P::m10}),
  };
}

namespace {

void check_calibration_inputs(const GearboxParameters& prior, const std::vector<double>& measured_hz,
                              const std::vector<bool>& use, const std::vector<CalibrationKnob>& knobs,
                              const CalibrationOptions& options) {
  prior.validate();
  if (measured_hz.empty()) throw TwinParameterError("calibration: no measured frequencies");
  if (use.size() != measured_hz.size()) throw TwinParameterError("calibration: use mask size differs from the data");
  if (std::none_of(use.begin(), use.end(), [](bool b) { return b; })) throw TwinParameterError("calibration: nothing to fit");
  for (double f : measured_hz)
    if (!std::isfinite(f) || f <= 0) throw TwinParameterError("calibration: measured frequencies must be positive");
  if (knobs.empty()) throw TwinParameterError("calibration: no knobs");
  for (const auto& k : knobs)
    if (k.fields.empty() || !(k.low > 0) || !(k.high > k.low))
      throw TwinParameterError("calibration: knob " + k.name + " has no fields or an empty range");
  if (options.starts < 1 || options.frequency_sigma <= 0) throw TwinParameterError("calibration: bad options");
}

// Start 0 is the prior's centre, start 1 the parameter sheet's hint, later ones random inside the box.
Eigen::VectorXd start_point(const Problem& problem, int start, std::mt19937& rng) {
  const auto n = static_cast<Eigen::Index>(problem.knob_count());
  Eigen::VectorXd x0(n);
  for (Eigen::Index j = 0; j < n; ++j) x0[j] = problem.centre(static_cast<std::size_t>(j));
  if (start == 1) {
    // The parameter sheet's hint: soft couplings on the input side (elastomer-insert values).
    for (Eigen::Index j = 0; j < n; ++j) {
      const std::string& name = problem.knobs()[static_cast<std::size_t>(j)].name;
      if (name == "kt12") x0[j] = std::log(250.0);
      if (name == "kt23") x0[j] = std::log(100.0);
      if (name == "kt12_13") x0[j] = std::log(2.8e4);
      if (name == "k_bearing_x") x0[j] = std::log(1.5e7);
      if (name == "k_bearing_y") x0[j] = std::log(1e9);
    }
  } else if (start > 1) {
    for (Eigen::Index j = 0; j < n; ++j) {
      std::uniform_real_distribution<double> u(0.15, 0.85);
      x0[j] = problem.lo(static_cast<std::size_t>(j)) +
              u(rng) * (problem.hi(static_cast<std::size_t>(j)) - problem.lo(static_cast<std::size_t>(j)));
    }
  }
  return x0;
}

// One measured frequency's model mode in the best fit, with its error, shape and sensitivities.
ModePairing pairing_of(const Problem& problem, const FitOutcome& best, const ModalEvaluation& e,
                       const std::vector<Mode>& modes, const std::vector<double>& measured_hz,
                       const std::vector<bool>& use, std::size_t i) {
  ModePairing pair;
  pair.measured_index = static_cast<int>(i);
  pair.measured_hz = measured_hz[i];
  pair.model_mode = best.pairing[i];
  pair.model_hz = e.frequencies[pair.model_mode];
  pair.error_pct = 100.0 * (pair.model_hz - measured_hz[i]) / measured_hz[i];
  pair.used_in_fit = use[i];
  const Mode& mode = modes[static_cast<std::size_t>(pair.model_mode)];
  pair.dominant_element = mode.dominant_element;
  pair.dominant_share = mode.dominant_share;
  pair.torsional_kinetic_share = mode.torsional_kinetic_share;
  pair.mac_to_start = modal_assurance(best.start_shapes.col(static_cast<Eigen::Index>(i)), e.shapes.col(pair.model_mode), e.mass);
  const Eigen::VectorXd s = problem.log_sensitivity(e, pair.model_mode);
  std::vector<std::pair<std::string, double>> sens;
  for (Eigen::Index j = 0; j < static_cast<Eigen::Index>(problem.knob_count()); ++j) sens.emplace_back(problem.knobs()[static_cast<std::size_t>(j)].name, s[j]);
  std::sort(sens.begin(), sens.end(), [](const auto& a, const auto& b) { return std::abs(a.second) > std::abs(b.second); });
  sens.resize(std::min<std::size_t>(2, sens.size()));
  pair.top_sensitivities = sens;
  return pair;
}

KnobChange knob_change(const Problem& problem, const FitOutcome& best, std::size_t j) {
  const auto& k = problem.knobs()[j];
  const auto jj = static_cast<Eigen::Index>(j);
  KnobChange c;
  c.name = k.name;
  c.prior_value = std::exp(problem.centre(j));
  c.fitted_value = std::exp(best.x[jj]);
  c.low = k.low;
  c.high = k.high;
  c.factor = c.fitted_value / c.prior_value;
  c.at_bound = best.x[jj] <= problem.lo(j) + 1e-9 || best.x[jj] >= problem.hi(j) - 1e-9;
  return c;
}

}  // namespace

CalibrationResult calibrate(const GearboxParameters& prior, const std::vector<double>& measured_hz,
                            const std::vector<bool>& use, const std::vector<CalibrationKnob>& knobs,
                            const CalibrationOptions& options) {
  check_calibration_inputs(prior, measured_hz, use, knobs, options);
  const Problem problem(prior, measured_hz, use, knobs, options);
  std::mt19937 rng(options.seed);
  FitOutcome best;
  int best_start = 0;
  for (int start = 0; start < options.starts; ++start) {
    FitOutcome fit = detail::fit_from(problem, start_point(problem, start, rng));
    if (fit.cost < best.cost) {
      best = std::move(fit);
      best_start = start;
    }
  }
  if (!std::isfinite(best.cost)) throw TwinParameterError("calibration failed from every start");

  CalibrationResult result;
  result.parameters = problem.parameters(best.x);
  result.cost = best.cost;
  result.best_start = best_start;
  result.iterations = best.iterations;
  const ModalEvaluation e = problem.evaluate(best.x);
  const std::vector<Mode> modes = modal_analysis(result.parameters);
  for (std::size_t i = 0; i < measured_hz.size(); ++i) {
    ModePairing pair = pairing_of(problem, best, e, modes, measured_hz, use, i);
    if (use[i]) result.max_abs_error_pct = std::max(result.max_abs_error_pct, std::abs(pair.error_pct));
    result.pairing.push_back(std::move(pair));
  }
  for (std::size_t j = 0; j < problem.knob_count(); ++j) result.knobs.push_back(knob_change(problem, best, j));
  return result;
}

CrossValidationResult cross_validate(const GearboxParameters& prior, const std::vector<double>& measured_hz,
                                     const std::vector<CalibrationKnob>& knobs, const CalibrationOptions& options) {
  const int n = static_cast<int>(measured_hz.size());
  if (n < 4) throw TwinParameterError("cross-validation needs at least 4 measured frequencies");
  CrossValidationResult cv;
  cv.worst_by_frequency_pct.assign(static_cast<std::size_t>(n), 0.0);
  std::vector<double> fold_errors, all_errors;
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      std::vector<bool> use(static_cast<std::size_t>(n), true);
      use[static_cast<std::size_t>(a)] = use[static_cast<std::size_t>(b)] = false;
      const CalibrationResult fit = calibrate(prior, measured_hz, use, knobs, options);
      CrossValidationFold fold;
      fold.fit_max_abs_error_pct = fit.max_abs_error_pct;
      int k = 0;
      for (int i : {a, b}) {
        const ModePairing& p = fit.pairing[static_cast<std::size_t>(i)];
        fold.held_out[k] = i;
        fold.measured_hz[k] = p.measured_hz;
        fold.predicted_hz[k] = p.model_hz;
        fold.error_pct[k] = p.error_pct;
        all_errors.push_back(std::abs(p.error_pct));
        cv.worst_by_frequency_pct[static_cast<std::size_t>(i)] =
            std::max(cv.worst_by_frequency_pct[static_cast<std::size_t>(i)], std::abs(p.error_pct));
        ++k;
      }
      fold_errors.push_back(std::max(std::abs(fold.error_pct[0]), std::abs(fold.error_pct[1])));
      cv.folds.push_back(fold);
    }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t m = v.size() / 2;
    return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
  };
  cv.worst_abs_error_pct = *std::max_element(all_errors.begin(), all_errors.end());
  cv.median_fold_error_pct = median(fold_errors);
  cv.median_abs_error_pct = median(all_errors);
  return cv;
}

std::string calibrated_values_source(const GearboxParameters& calibrated) {
  std::string out =
      "// The calibrated parameter set: the result of `calibrate()` against thesis Table 5.5 with the\n"
      "// default knobs and priors (docs/twin.md lists the fit, the pairing and the cross-validation).\n"
      "// Values not listed keep their prior. Generated by `gearwatch twin calibrate --out FILE`;\n"
      "// regenerate it that way rather than editing it (a test compares it with a fresh calibration).\n"
      "#include \"gearwatch/twin/gearbox_parameters.hpp\"\n"
      "\n"
      "namespace gearwatch::twin {\n"
      "\n"
      "void apply_calibrated_values(GearboxParameters& p) {\n";
  for (const auto& info : parameter_table()) {
    const double value = calibrated.*(info.field);
    if (value == info.prior_value) continue;
    char line[128];
    std::snprintf(line, sizeof line, "  p.%s = %.9g;\n", info.name, value);
    out += line;
  }
  out += "}\n\n}  // namespace gearwatch::twin\n";
  return out;
}

}  // namespace gearwatch::twin
