#include "gearwatch/twin/modal_gap.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <tuple>

#include "frequency_fit.hpp"
#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/gearbox_model.hpp"
#include "gearwatch/twin/mesh_stiffness.hpp"
#include "gearwatch/twin/modal_analysis.hpp"

namespace gearwatch::twin {

namespace {

constexpr int kBaseY = 21;  // the bed's DOFs follow the 21 of Eq. 5.2
constexpr int kBaseX = 22;

bool is_base_y_mount(const std::string& name) { return name == "ky4" || name == "ky6" || name == "ky9" || name == "ky11"; }
bool is_base_x_mount(const std::string& name) { return name == "kx4" || name == "kx6" || name == "kx9" || name == "kx11"; }

// DOFs whose mass a mass/inertia parameter sets.
const std::vector<int>* mass_dofs_of(const std::string& name) {
  static const std::map<std::string, std::vector<int>> map = {
      {"I1", {theta1}},   {"I2", {theta2}},   {"I3", {theta3}},   {"I5", {theta5}},  {"I7", {theta7}},
      {"I8", {theta8}},   {"I10", {theta10}}, {"I12", {theta12}}, {"I13", {theta13}}, {"m4", {y4, x4}},
      {"m5", {y5, x5}},   {"m6", {y6, x6}},   {"m9", {y9, x9}},   {"m10", {y10, x10}}, {"m11", {y11, x11}},
      {"base_mass", {kBaseY, kBaseX}}};
  const auto it = map.find(name);
  return it == map.end() ? nullptr : &it->second;
}

Eigen::VectorXd mass_vector(const StructuralModel& model) {
  const GearboxParameters& p = model.gearbox;
  Eigen::VectorXd m(model.dof_count());
  m.head(kDofCount) << p.I1, p.I2, p.I3, p.I5, p.I7, p.I8, p.I10, p.I12, p.I13, p.m4, p.m5, p.m6, p.m9, p.m10,
      p.m11, p.m4, p.m5, p.m6, p.m9, p.m10, p.m11;
  if (model.base.enabled) m[kBaseY] = m[kBaseX] = model.base.mass;
  return m;
}

// The structural springs with the pedestal mounts ending on the bed when there is one.
std::vector<SpringElement> structural_springs(const StructuralModel& model) {
  std::vector<SpringElement> springs = spring_elements(model.gearbox);
  if (!model.base.enabled) return springs;
  for (auto& s : springs) {
    if (is_base_y_mount(s.name)) s.b = kBaseY;
    if (is_base_x_mount(s.name)) s.b = kBaseX;
  }
  springs.push_back({"base_ky", kBaseY, -1, model.base.k_y});
  springs.push_back({"base_kx", kBaseX, -1, model.base.k_x});
  return springs;
}

struct MeshTerm {
  Eigen::VectorXd direction;  // g, 21 entries
  double stiffness = 0;       // mean k_m
};

MeshTerm mesh_term(const GearboxParameters& p) {
  const GearGeometry geometry = GearGeometry::from_spec(p.gears);
  MeshStiffnessOptions mo;
  mo.scale = p.mesh_stiffness_scale;
  mo.engagement_ramp_fraction = p.engagement_ramp_fraction;
  const GearMeshStiffness mesh(geometry, mo);
  return {mesh_direction(geometry), mesh.mean_stiffness()};
}

Eigen::MatrixXd stiffness_matrix(int n, const std::vector<SpringElement>& springs, const MeshTerm& mesh) {
  Eigen::MatrixXd k = Eigen::MatrixXd::Zero(n, n);
  k.topLeftCorner(kDofCount, kDofCount) = mesh.stiffness * mesh.direction * mesh.direction.transpose();
  for (const auto& s : springs) {
    k(s.a, s.a) += s.stiffness;
    if (s.b >= 0) {
      k(s.b, s.b) += s.stiffness;
      k(s.a, s.b) -= s.stiffness;
      k(s.b, s.a) -= s.stiffness;
    }
  }
  return k;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

// A named scalar of a StructuralModel, resolved once.
struct ParameterRef {
  double GearboxParameters::*gearbox = nullptr;
  double BaseSupport::*base = nullptr;
  double& get(StructuralModel& m) const { return gearbox ? m.gearbox.*gearbox : m.base.*base; }
  double get(const StructuralModel& m) const { return gearbox ? m.gearbox.*gearbox : m.base.*base; }
};

ParameterRef resolve(const std::string& name) {
  if (name == "base_mass") return {nullptr, &BaseSupport::mass};
  if (name == "base_ky") return {nullptr, &BaseSupport::k_y};
  if (name == "base_kx") return {nullptr, &BaseSupport::k_x};
  const ParameterInfo* info = find_parameter(name);
  if (!info) throw TwinParameterError("unknown structural parameter " + name);
  return {info->field, nullptr};
}

using detail::FitOutcome;
using detail::ModalEvaluation;

class ModalProblem : public detail::FrequencyFitProblem {
 public:
  ModalProblem(const StructuralModel& prior, const std::vector<ModalKnob>& knobs, const std::vector<double>& measured,
               const std::vector<bool>& use, const ModalFitOptions& options)
      : FrequencyFitProblem(measured, use, options.frequency_sigma, options.max_iterations, "modal fit"),
        base_(prior),
        mesh_(mesh_term(prior.gearbox)) {
    const std::vector<SpringElement> prior_springs = structural_springs(prior);  // the order is fixed
    for (const auto& k : knobs) {
      // Names are resolved once: the fit evaluates the model thousands of times.
      std::vector<int> springs;
      std::vector<int> dofs;
      std::vector<ParameterRef> refs;
      for (const auto& name : k.parameters) {
        refs.push_back(resolve(name));  // throws for an unknown name
        if (const auto* d = mass_dofs_of(name)) {
          dofs.insert(dofs.end(), d->begin(), d->end());
        } else {
          for (std::size_t i = 0; i < prior_springs.size(); ++i)
            if (prior_springs[i].name == name) springs.push_back(static_cast<int>(i));
        }
      }
      // x is the log of the knob's factor on the model's values: the prior centre is 0.
      add_knob(k.low, k.high, 0.0, std::move(springs), std::move(dofs));
      knob_refs_.push_back(refs);
    }
  }

  StructuralModel model(const Eigen::VectorXd& x) const {
    StructuralModel m = base_;
    for (std::size_t j = 0; j < knob_refs_.size(); ++j) {
      const double factor = std::exp(x[static_cast<Eigen::Index>(j)]);
      for (const auto& ref : knob_refs_[j]) ref.get(m) = ref.get(base_) * factor;
    }
    return m;
  }

  ModalEvaluation evaluate(const Eigen::VectorXd& x) const override {
    const StructuralModel m = model(x);
    ModalEvaluation e;
    e.mass = mass_vector(m);
    e.springs = structural_springs(m);
    solve_modes(e.mass, stiffness_matrix(m.dof_count(), e.springs, mesh_), e.frequencies, e.shapes);
    return e;
  }

 private:
  StructuralModel base_;
  MeshTerm mesh_;
  std::vector<std::vector<ParameterRef>> knob_refs_;
};

// The largest factor range that keeps every parameter of the group inside its own sheet range.
ModalKnob sheet_knob(const std::string& name, std::vector<std::string> parameters, const std::string& source) {
  double low = 0, high = std::numeric_limits<double>::infinity();
  for (const auto& p : parameters) {
    const ParameterInfo* info = find_parameter(p);
    if (!info) throw TwinParameterError("modal knob " + name + ": unknown parameter " + p);
    low = std::max(low, info->prior_low / info->prior_value);
    high = std::min(high, info->prior_high / info->prior_value);
  }
  return {name, std::move(parameters), low, high, source};
}

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : "+") + s;
  return out;
}

}  // namespace

double& structural_parameter(StructuralModel& model, const std::string& name) { return resolve(name).get(model); }

double structural_parameter(const StructuralModel& model, const std::string& name) { return resolve(name).get(model); }

std::vector<StructuralMode> structural_modes(const StructuralModel& model) {
  model.gearbox.validate();
  if (model.base.enabled && !(model.base.mass > 0 && model.base.k_y > 0 && model.base.k_x > 0))
    throw TwinParameterError("base support: mass and mount stiffnesses must be positive");
  const Eigen::VectorXd mass = mass_vector(model);
  const auto springs = structural_springs(model);
  const MeshTerm mesh = mesh_term(model.gearbox);
  Eigen::VectorXd f;
  Eigen::MatrixXd shapes;
  solve_modes(mass, stiffness_matrix(model.dof_count(), springs, mesh), f, shapes);
  std::vector<StructuralMode> modes(static_cast<std::size_t>(f.size()));
  for (Eigen::Index i = 0; i < f.size(); ++i) {
    const auto phi = shapes.col(i);
    std::vector<std::pair<std::string, double>> energy;
    double total = 0;
    for (const auto& s : springs) {
      const double d = phi[s.a] - (s.b >= 0 ? phi[s.b] : 0.0);
      energy.emplace_back(s.name, s.stiffness * d * d);
      total += energy.back().second;
    }
    const double md = mesh.direction.dot(phi.head(kDofCount));
    energy.emplace_back("mesh", mesh.stiffness * md * md);
    total += energy.back().second;
    StructuralMode& mode = modes[static_cast<std::size_t>(i)];
    mode.frequency_hz = f[i];
    mode.shape = phi;
    const double omega2 = std::pow(2.0 * std::numbers::pi * f[i], 2);
    if (total > 1e-9 * std::max(omega2, 1.0)) {
      const auto best = std::max_element(energy.begin(), energy.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
      mode.dominant_element = best->first;
      mode.dominant_share = best->second / total;
    } else {
      mode.dominant_element = "rigid body";
    }
  }
  return modes;
}

std::vector<ModalKnob> grouped_modal_knobs() {
  const std::string sheet = "parameter sheet (docs/rig-parameters-used.md): ";
  return {
      sheet_knob("couplings", {"kt12", "kt23", "kt12_13"}, sheet + "couplings 1, 2, 4, one type: 1e2-2e5 N m/rad"),
      sheet_knob("shaft_torsion", {"kt35", "kt57", "kt810", "kt10_12"}, sheet + "GJ/L of the shaft sections, 5e3-6e4 N m/rad"),
      sheet_knob("shaft_bending", {"ky45", "ky56", "ky910", "ky10_11", "kx45", "kx56", "kx910", "kx10_11"},
                 sheet + "48EI/L^3 halves, 2e7-5e8 N/m, alike in x and y (round shaft)"),
      sheet_knob("bearing_y", {"ky4", "ky6", "ky9", "ky11"}, sheet + "bearing + pedestal, published lumped models, 1e7-1e9 N/m"),
      sheet_knob("bearing_x", {"kx4", "kx6", "kx9", "kx11"}, sheet + "bearing + pedestal, published lumped models, 1e7-1e9 N/m"),
      sheet_knob("pedestal_mass", {"m4", "m6", "m9", "m11"}, sheet + "bearing-block masses of other models, 0.5-10 kg"),
      sheet_knob("motor_inertia", {"I1"}, sheet + "4 kW 4-pole motor catalogue, 3e-3-3e-2 kg m^2"),
      sheet_knob("torque_meter_inertia", {"I2"}, sheet + "HBM TB1A flange 1.3e-3, 3e-4-3e-3 kg m^2"),
      sheet_knob("brake_inertia", {"I13"}, sheet + "PB-series powder brakes, 4e-3-3.5e-2 kg m^2"),
      sheet_knob("hub_inertias", {"I3", "I12"}, sheet + "coupling half + shaft stub (estimate), 1e-4-1e-3 kg m^2"),
      sheet_knob("free_end_inertias", {"I7", "I8"}, sheet + "slip ring, adapter, coupling 3/5 (estimate), 5e-5-1e-3 kg m^2"),
      sheet_knob("gear_bodies", {"I5", "I10", "m5", "m10"}, sheet + "computed discs and shaft shares (common factor inside every range)"),
  };
}

ModalFit fit_modal_model(const StructuralModel& prior, const std::vector<ModalKnob>& knobs,
                         const std::vector<double>& measured_hz, const std::vector<bool>& use,
                         const ModalFitOptions& options) {
  prior.gearbox.validate();
  if (measured_hz.empty()) throw TwinParameterError("modal fit: no measured frequencies");
  if (use.size() != measured_hz.size()) throw TwinParameterError("modal fit: use mask size differs from the data");
  if (std::none_of(use.begin(), use.end(), [](bool b) { return b; })) throw TwinParameterError("modal fit: nothing to fit");
  for (double f : measured_hz)
    if (!std::isfinite(f) || f <= 0) throw TwinParameterError("modal fit: measured frequencies must be positive");
  if (knobs.empty()) throw TwinParameterError("modal fit: no knobs");
  for (const auto& k : knobs)
    if (k.parameters.empty() || !(k.low > 0) || !(k.high > k.low) || k.low > 1 || k.high < 1)
      throw TwinParameterError("modal knob " + k.name + ": no parameters, or a range that excludes the model's value");
  if (prior.base.enabled && !(prior.base.mass > 0 && prior.base.k_y > 0 && prior.base.k_x > 0))
    throw TwinParameterError("base support: mass and mount stiffnesses must be positive");
  if (options.starts < 1 || options.frequency_sigma <= 0) throw TwinParameterError("modal fit: bad options");

  const ModalProblem problem(prior, knobs, measured_hz, use, options);
  const auto n = static_cast<Eigen::Index>(problem.knob_count());
  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> u(0.15, 0.85);
  FitOutcome best;
  std::vector<FitOutcome> all;
  for (int start = 0; start < options.starts; ++start) {
    Eigen::VectorXd x0 = Eigen::VectorXd::Zero(n);
    if (start > 0)
      for (Eigen::Index j = 0; j < n; ++j)
        x0[j] = problem.lo(static_cast<std::size_t>(j)) + u(rng) * (problem.hi(static_cast<std::size_t>(j)) - problem.lo(static_cast<std::size_t>(j)));
    FitOutcome fit = detail::fit_from(problem, x0);
    all.push_back(fit);
    if (fit.cost < best.cost) best = std::move(fit);
  }
  if (!std::isfinite(best.cost)) throw TwinParameterError("modal fit failed from every start");

  ModalFit out;
  out.model = problem.model(best.x);
  out.cost = best.cost;
  const ModalEvaluation e = problem.evaluate(best.x);
  for (Eigen::Index j = 0; j < n; ++j) {
    out.factors.push_back(std::exp(best.x[j]));
    out.at_bound.push_back(best.x[j] <= problem.lo(static_cast<std::size_t>(j)) + 1e-9 ||
                           best.x[j] >= problem.hi(static_cast<std::size_t>(j)) - 1e-9);
  }
  for (std::size_t i = 0; i < measured_hz.size(); ++i) {
    out.paired_mode.push_back(best.pairing[i]);
    out.model_hz.push_back(e.frequencies[best.pairing[i]]);
    if (use[i])
      out.max_abs_error_pct = std::max(out.max_abs_error_pct, 100.0 * std::abs(out.model_hz.back() - measured_hz[i]) / measured_hz[i]);
  }
  // The ensemble: every start's fit within the window, each weighted by its posterior density
  // relative to the best (starts that converge to the same fit weigh it by its basin).
  std::vector<std::pair<std::vector<double>, double>> members;
  for (const auto& o : all) {
    if (!std::isfinite(o.cost) || o.cost > best.cost + options.ensemble_cost_window) continue;
    const ModalEvaluation eo = problem.evaluate(o.x);
    std::vector<double> f;
    for (std::size_t i = 0; i < measured_hz.size(); ++i) f.push_back(eo.frequencies[o.pairing[i]]);
    members.emplace_back(std::move(f), std::exp(-(o.cost - best.cost)));
  }
  out.ensemble_members = static_cast<int>(members.size());
  for (std::size_t i = 0; i < measured_hz.size(); ++i) {
    std::vector<std::pair<double, double>> v;
    double total = 0;
    for (const auto& [f, w] : members) {
      v.emplace_back(f[i], w);
      total += w;
    }
    std::sort(v.begin(), v.end());
    double acc = 0, value = v.back().first;
    for (const auto& [f, w] : v)
      if ((acc += w) >= 0.5 * total) {
        value = f;
        break;
      }
    out.ensemble_hz.push_back(value);
  }
  return out;
}

const char* to_string(HeldOutPrediction prediction) {
  switch (prediction) {
    case HeldOutPrediction::best_fit: return "best fit";
    case HeldOutPrediction::ensemble: return "ensemble";
  }
  return "?";
}

const char* to_string(HeldOutIdentity identity) {
  switch (identity) {
    case HeldOutIdentity::start_pairing: return "start pairing";
    case HeldOutIdentity::full_fit_shape: return "full-fit shape";
  }
  return "?";
}

LeaveOutScore leave_two_out(const StructuralModel& prior, const std::vector<ModalKnob>& knobs,
                            const std::vector<double>& measured_hz, const ModalFitOptions& options,
                            HeldOutIdentity identity) {
  const int n = static_cast<int>(measured_hz.size());
  if (n < 4) throw TwinParameterError("leave-two-out needs at least 4 measured frequencies");
  std::vector<Eigen::VectorXd> named_shapes;
  if (identity == HeldOutIdentity::full_fit_shape) {
    const ModalFit full = fit_modal_model(prior, knobs, measured_hz, std::vector<bool>(measured_hz.size(), true), options);
    const auto modes = structural_modes(full.model);
    for (int m : full.paired_mode) named_shapes.push_back(modes[static_cast<std::size_t>(m)].shape);
  }
  LeaveOutScore score;
  std::vector<std::vector<double>> by_frequency(static_cast<std::size_t>(n));
  std::vector<double> fold_errors, all_errors;
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      std::vector<bool> use(static_cast<std::size_t>(n), true);
      use[static_cast<std::size_t>(a)] = use[static_cast<std::size_t>(b)] = false;
      const ModalFit fit = fit_modal_model(prior, knobs, measured_hz, use, options);
      const std::vector<double>& own = options.prediction == HeldOutPrediction::ensemble ? fit.ensemble_hz : fit.model_hz;
      double predicted[2] = {own[static_cast<std::size_t>(a)], own[static_cast<std::size_t>(b)]};
      if (identity == HeldOutIdentity::full_fit_shape) {
        const auto modes = structural_modes(fit.model);
        const Eigen::VectorXd mass = mass_vector(fit.model);
        std::vector<bool> taken(modes.size(), false);
        for (int i = 0; i < n; ++i)
          if (use[static_cast<std::size_t>(i)]) taken[static_cast<std::size_t>(fit.paired_mode[static_cast<std::size_t>(i)])] = true;
        std::vector<std::tuple<double, int, std::size_t>> macs;
        for (int k = 0; k < 2; ++k)
          for (std::size_t m = 0; m < modes.size(); ++m)
            if (!taken[m] && modes[m].frequency_hz > 1.0)
              macs.emplace_back(modal_assurance(named_shapes[static_cast<std::size_t>(k == 0 ? a : b)], modes[m].shape, mass), k, m);
        std::sort(macs.begin(), macs.end(), [](const auto& x, const auto& y) { return std::get<0>(x) > std::get<0>(y); });
        bool done[2] = {false, false};
        for (const auto& [mac, k, m] : macs) {
          if (done[k] || taken[m]) continue;
          predicted[k] = modes[m].frequency_hz;
          done[k] = taken[m] = true;
        }
      }
      CrossValidationFold fold;
      fold.fit_max_abs_error_pct = fit.max_abs_error_pct;
      int k = 0;
      for (int i : {a, b}) {
        const auto si = static_cast<std::size_t>(i);
        fold.held_out[k] = i;
        fold.measured_hz[k] = measured_hz[si];
        fold.predicted_hz[k] = predicted[k];
        fold.error_pct[k] = 100.0 * (predicted[k] - measured_hz[si]) / measured_hz[si];
        all_errors.push_back(std::abs(fold.error_pct[k]));
        by_frequency[si].push_back(std::abs(fold.error_pct[k]));
        ++k;
      }
      fold_errors.push_back(std::max(std::abs(fold.error_pct[0]), std::abs(fold.error_pct[1])));
      score.folds.push_back(fold);
    }
  score.median_fold_error_pct = median(fold_errors);
  score.median_abs_error_pct = median(all_errors);
  score.worst_abs_error_pct = *std::max_element(all_errors.begin(), all_errors.end());
  for (const auto& v : by_frequency) {
    score.median_by_frequency_pct.push_back(median(v));
    score.worst_by_frequency_pct.push_back(*std::max_element(v.begin(), v.end()));
  }
  return score;
}

StructuralCandidate base_support_candidate(const BaseSupport& prior, double mass_low, double mass_high,
                                           double mounts_low, double mounts_high, const std::string& source) {
  StructuralCandidate c;
  c.name = "base support";
  c.description = "the bed under the four pedestals as a rigid body on its mounts (y and x)";
  c.exclusive_group = "base";
  c.added_knobs = 3;
  c.apply = [=](StructuralModel& m, std::vector<ModalKnob>& k) {
    m.base = prior;
    m.base.enabled = true;
    k.push_back({"base_mass", {"base_mass"}, mass_low, mass_high, source});
    // Mounts differ by direction (a rubber mount is stiffer in compression than in shear).
    k.push_back({"base_mounts_y", {"base_ky"}, mounts_low, mounts_high, source});
    k.push_back({"base_mounts_x", {"base_kx"}, mounts_low, mounts_high, source});
  };
  return c;
}

std::vector<StructuralCandidate> structural_candidates() {
  std::vector<StructuralCandidate> out;
  // The bed's bounce frequency sqrt(k / (bed + pedestals)) spans the low Table 5.4 peaks that
  // Table 5.5 left out (13, 41, 59, 68, 128 Hz) at the estimated 50 kg: k = 3.8e6 N/m gives 41 Hz,
  // ×0.1…×10 gives 13…130 Hz.
  out.push_back(base_support_candidate({true, 50.0, 3.8e6, 3.8e6}, 0.2, 5.0, 0.1, 10.0,
                                       "thesis Table 5.4 peaks left out of Table 5.5, 13-128 Hz; bed mass 10-250 kg (estimate)"));
  auto coupling_type = [&](const std::string& name, const std::string& what, double low_nm, double high_nm) {
    StructuralCandidate c;
    c.name = name;
    c.description = what;
    c.exclusive_group = "coupling type";
    c.apply = [=](StructuralModel& m, std::vector<ModalKnob>& knobs) {
      // The type's range is a part of the sheet's; its geometric centre becomes the prior value.
      const double centre = std::sqrt(low_nm * high_nm);
      for (const auto* p : {"kt12", "kt23", "kt12_13"}) structural_parameter(m, p) = centre;
      for (auto& k : knobs)
        if (k.name == "couplings") {
          k.low = low_nm / centre;
          k.high = high_nm / centre;
          k.source = "parameter sheet, " + what;
        }
    };
    out.push_back(std::move(c));
  };
  coupling_type("elastomer couplings", "elastomer-insert couplings: the sheet's range below the stiff types, 1e2-5e3 N m/rad", 1e2, 5e3);
  // Thesis §3.2: "couplings with high torsional stiffness and low bending stiffness".
  coupling_type("stiff couplings",
                "torsionally stiff couplings as thesis §3.2 states them (disc/bellows, torque flange): from a shaft-type "
                "meter's GJ/L to the TB1A flange, 5e3-2e5 N m/rad", 5e3, 2e5);
  {
    StructuralCandidate c;
    c.name = "pedestal masses per shaft";
    c.description = "input-shaft and output-shaft pedestals as separate masses";
    c.exclusive_group = "pedestal";
    c.added_knobs = 1;
    c.apply = [](StructuralModel&, std::vector<ModalKnob>& knobs) {
      for (std::size_t j = 0; j < knobs.size(); ++j)
        if (knobs[j].name == "pedestal_mass") {
          ModalKnob output = knobs[j];
          knobs[j].name = "pedestal_mass_input";
          knobs[j].parameters = {"m4", "m6"};
          output.name = "pedestal_mass_output";
          output.parameters = {"m9", "m11"};
          knobs.insert(knobs.begin() + static_cast<std::ptrdiff_t>(j) + 1, output);
          return;
        }
    };
    out.push_back(std::move(c));
  }
  return out;
}

StructuralModel softest_corner(const StructuralModel& model, const std::vector<ModalKnob>& knobs) {
  StructuralModel corner = model;
  for (const auto& k : knobs)
    for (const auto& p : k.parameters)
      structural_parameter(corner, p) = structural_parameter(model, p) * (mass_dofs_of(p) ? k.high : k.low);
  return corner;
}

CornerCheck corner_check(const std::string& name, const StructuralModel& model, const std::vector<ModalKnob>& knobs,
                         const std::vector<double>& measured_hz) {
  CornerCheck c;
  c.name = name;
  const double top = *std::max_element(measured_hz.begin(), measured_hz.end());
  std::vector<double> elastic;
  for (const auto& m : structural_modes(softest_corner(model, knobs)))
    if (m.frequency_hz > 1.0) elastic.push_back(m.frequency_hz);
  for (double f : elastic)
    if (f <= 1.5 * top) c.elastic_hz.push_back(f);
  for (double f : measured_hz) {
    const auto modes = static_cast<int>(std::count_if(elastic.begin(), elastic.end(), [&](double e) { return e <= f; }));
    const auto peaks = static_cast<int>(std::count_if(measured_hz.begin(), measured_hz.end(), [&](double g) { return g <= f; }));
    c.modes_at_or_below.push_back(modes);
    c.deficit.push_back(std::max(0, peaks - modes));
    c.max_deficit = std::max(c.max_deficit, c.deficit.back());
  }
  return c;
}

const char* to_string(ModalGapStatus status) {
  switch (status) {
    case ModalGapStatus::explained_by_twin: return "explained by the twin";
    case ModalGapStatus::explained_by_effect: return "explained by an added effect";
    case ModalGapStatus::unexplained: return "unexplained";
  }
  return "?";
}

namespace {

// modal_gap_analysis's steps: the baseline, the greedy selection of effects, the final fit, the
// spread over the starts' seeds, the softest corners and each measured mode's verdict.
class ModalGapAnalysis {
 public:
  ModalGapAnalysis(const StructuralModel& baseline, const std::vector<ModalKnob>& knobs,
                   const std::vector<StructuralCandidate>& candidates, const std::vector<double>& measured_hz,
                   const ModalGapOptions& options)
      : baseline_(baseline), knobs_(knobs), candidates_(candidates), measured_hz_(measured_hz), options_(options),
        all_(measured_hz.size(), true) {}

  ModalGapReport run() {
    score_baseline();
    select_effects();
    fit_final();
    spread_over_seeds();
    check_corners();
    judge_modes();
    return std::move(report_);
  }

 private:
  // An option of candidates scored on top of what is adopted.
  struct ScoredOption {
    LeaveOutScore score;
    StructuralModel model;
    std::vector<ModalKnob> knobs;
  };

  void score_baseline() {
    report_.measured_hz = measured_hz_;
    report_.baseline_knobs = knobs_;
    report_.target_median_fold_pct = options_.target_median_fold_pct;
    report_.baseline = leave_two_out(baseline_, knobs_, measured_hz_, options_.fit, options_.identity);
    report_.baseline_fit = fit_modal_model(baseline_, knobs_, measured_hz_, all_, options_.fit);
    model_ = baseline_;
    current_knobs_ = knobs_;
    current_ = report_.baseline;
  }

  bool available(std::size_t c) const {
    return std::find(used_groups_.begin(), used_groups_.end(), candidates_[c].exclusive_group) == used_groups_.end();
  }

  // Every remaining candidate, and every pair of them from different groups.
  std::vector<std::vector<std::size_t>> step_options() const {
    std::vector<std::vector<std::size_t>> out;
    for (std::size_t c = 0; c < candidates_.size(); ++c)
      if (available(c)) out.push_back({c});
    for (std::size_t c = 0; c < candidates_.size(); ++c)
      for (std::size_t d = c + 1; d < candidates_.size(); ++d)
        if (available(c) && available(d) && candidates_[c].exclusive_group != candidates_[d].exclusive_group)
          out.push_back({c, d});
    return out;
  }

  // Applies an option's candidates to the current model and scores it; its row goes to the report.
  ScoredOption score_option(const std::vector<std::size_t>& option, int step) {
    ScoredOption o{{}, model_, current_knobs_};
    StructuralOptionScore cs;
    for (std::size_t c : option) {
      candidates_[c].apply(o.model, o.knobs);
      cs.name += (cs.name.empty() ? "" : " + ") + candidates_[c].name;
      cs.description += (cs.description.empty() ? "" : "; ") + candidates_[c].description;
      cs.added_knobs += candidates_[c].added_knobs;
    }
    o.score = leave_two_out(o.model, o.knobs, measured_hz_, options_.fit, options_.identity);
    cs.step = step;
    cs.median_fold_before_pct = current_.median_fold_error_pct;
    cs.median_fold_after_pct = o.score.median_fold_error_pct;
    cs.worst_after_pct = o.score.worst_abs_error_pct;
    report_.candidates.push_back(cs);
    return o;
  }

  // Greedy forward selection. Each step scores every remaining candidate, and every pair of them,
  // on top of what is adopted: two effects may only help together (one frees the knob the other
  // needs). An option of n effects must bring the median fold down to adopt_ratio^n of the current
  // figure, so more knobs need a larger gain.
  void select_effects() {
    for (int step = 1;; ++step) {
      const auto options = step_options();
      int best = -1;
      double best_ratio = 1;
      ScoredOption best_option;
      for (std::size_t o = 0; o < options.size(); ++o) {
        ScoredOption scored = score_option(options[o], step);
        const double needed = std::pow(options_.adopt_ratio, static_cast<double>(options[o].size()));
        const double ratio = scored.score.median_fold_error_pct / std::max(current_.median_fold_error_pct, 1e-300);
        if (ratio <= needed && (best < 0 || ratio / needed < best_ratio)) {
          best = static_cast<int>(o);
          best_ratio = ratio / needed;
          best_option = std::move(scored);
        }
      }
      if (best < 0) return;
      adopt(options[static_cast<std::size_t>(best)], report_.candidates.size() - options.size() + static_cast<std::size_t>(best),
            std::move(best_option));
    }
  }

  void adopt(const std::vector<std::size_t>& option, std::size_t row, ScoredOption scored) {
    report_.candidates[row].adopted = true;
    for (std::size_t c : option) {
      used_groups_.push_back(candidates_[c].exclusive_group);
      report_.adopted.push_back(candidates_[c].name);
    }
    model_ = std::move(scored.model);
    current_knobs_ = std::move(scored.knobs);
    current_ = std::move(scored.score);
  }

  void fit_final() {
    report_.final_knobs = current_knobs_;
    report_.final_score = current_;
    report_.final_fit = report_.adopted.empty() ? report_.baseline_fit
                                                : fit_modal_model(model_, current_knobs_, measured_hz_, all_, options_.fit);
    report_.knobs_inside_priors = true;
    for (std::size_t j = 0; j < current_knobs_.size(); ++j) {
      const double f = report_.final_fit.factors[j];
      if (f < current_knobs_[j].low * (1 - 1e-9) || f > current_knobs_[j].high * (1 + 1e-9)) report_.knobs_inside_priors = false;
    }
  }

  // The same scores with the random starts drawn from the other seeds.
  void spread_over_seeds() {
    report_.seeds.push_back(options_.fit.seed);
    before_by_seed_ = {report_.baseline};
    after_by_seed_ = {current_};
    for (unsigned seed : options_.spread_seeds) {
      ModalFitOptions fit = options_.fit;
      fit.seed = seed;
      report_.seeds.push_back(seed);
      before_by_seed_.push_back(leave_two_out(baseline_, knobs_, measured_hz_, fit, options_.identity));
      after_by_seed_.push_back(report_.adopted.empty() ? before_by_seed_.back()
                                                       : leave_two_out(model_, current_knobs_, measured_hz_, fit, options_.identity));
    }
    for (std::size_t k = 0; k < before_by_seed_.size(); ++k) {
      report_.baseline_fold_by_seed.push_back(before_by_seed_[k].median_fold_error_pct);
      report_.final_fold_by_seed.push_back(after_by_seed_[k].median_fold_error_pct);
    }
    report_.target_met = report_.knobs_inside_priors &&
                         *std::max_element(report_.final_fold_by_seed.begin(), report_.final_fold_by_seed.end()) <=
                             options_.target_median_fold_pct;
  }

  void check_corners() {
    report_.corners.push_back(corner_check("grouped twin", baseline_, knobs_, measured_hz_));
    for (const auto& cand : candidates_) {
      StructuralModel m = baseline_;
      std::vector<ModalKnob> k = knobs_;
      cand.apply(m, k);
      report_.corners.push_back(corner_check(cand.name, m, k, measured_hz_));
    }
  }

  void judge_modes() {
    const auto modes_before = structural_modes(report_.baseline_fit.model);
    const auto modes_after = structural_modes(report_.final_fit.model);
    for (std::size_t i = 0; i < measured_hz_.size(); ++i) {
      ModalGapMode m;
      m.measured_hz = measured_hz_[i];
      m.median_error_before_pct = report_.baseline.median_by_frequency_pct[i];
      m.worst_error_before_pct = report_.baseline.worst_by_frequency_pct[i];
      m.median_error_after_pct = current_.median_by_frequency_pct[i];
      m.worst_error_after_pct = current_.worst_by_frequency_pct[i];
      const StructuralMode& before = modes_before[static_cast<std::size_t>(report_.baseline_fit.paired_mode[i])];
      const StructuralMode& after = modes_after[static_cast<std::size_t>(report_.final_fit.paired_mode[i])];
      m.element_before = before.dominant_element;
      m.share_before = before.dominant_share;
      m.element_after = after.dominant_element;
      m.share_after = after.dominant_share;
      m.fitted_hz_after = report_.final_fit.model_hz[i];
      judge_mode(m, i);
      report_.modes.push_back(m);
    }
  }

  // The verdict holds at every seed of the starts, or it is not given.
  void judge_mode(ModalGapMode& m, std::size_t i) const {
    for (std::size_t k = 0; k < before_by_seed_.size(); ++k) {
      m.worst_seed_median_before_pct = std::max(m.worst_seed_median_before_pct, before_by_seed_[k].median_by_frequency_pct[i]);
      m.worst_seed_median_after_pct = std::max(m.worst_seed_median_after_pct, after_by_seed_[k].median_by_frequency_pct[i]);
    }
    if (m.worst_seed_median_before_pct <= options_.explained_within_pct) {
      m.status = ModalGapStatus::explained_by_twin;
      m.worse_with_effects = m.worst_seed_median_after_pct > options_.explained_within_pct;
    } else if (m.worst_seed_median_after_pct <= options_.explained_within_pct) {
      m.status = ModalGapStatus::explained_by_effect;
      m.effect = join(report_.adopted);
    }
  }

  const StructuralModel& baseline_;
  const std::vector<ModalKnob>& knobs_;
  const std::vector<StructuralCandidate>& candidates_;
  const std::vector<double>& measured_hz_;
  const ModalGapOptions& options_;
  const std::vector<bool> all_;
  ModalGapReport report_;
  StructuralModel model_;
  std::vector<ModalKnob> current_knobs_;
  LeaveOutScore current_;
  std::vector<std::string> used_groups_;
  std::vector<LeaveOutScore> before_by_seed_, after_by_seed_;
};

}  // namespace

ModalGapReport modal_gap_analysis(const StructuralModel& baseline, const std::vector<ModalKnob>& knobs,
                                  const std::vector<StructuralCandidate>& candidates,
                                  const std::vector<double>& measured_hz, const ModalGapOptions& options) {
  return ModalGapAnalysis(baseline, knobs, candidates, measured_hz, options).run();
}

ModalGapReport table_5_5_modal_gap(const ModalGapOptions& options) {
  const StructuralModel baseline;
  const auto knobs = grouped_modal_knobs();
  return modal_gap_analysis(baseline, knobs, structural_candidates(), table_5_5_frequencies(), options);
}

}  // namespace gearwatch::twin
