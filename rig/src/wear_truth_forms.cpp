#include "gearwatch/rig/wear_truth_forms.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "gearwatch/rig/effects.hpp"
#include "gearwatch/twin/gear_geometry.hpp"
#include "gearwatch/twin/mesh_stiffness.hpp"
#include "random.hpp"

namespace gearwatch::rig {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

void require(bool ok, const char* what) {
  if (!ok) throw RigParameterError(what);
}
bool finite_nonnegative(double v) { return std::isfinite(v) && v >= 0; }

/// ∫ₐᵇ f by 5-point Gauss–Legendre on `pieces` equal sub-intervals (f smooth inside [a, b]).
template <class F>
double gauss_legendre(const F& f, double a, double b, int pieces) {
  static const double x[5] = {0.0, -0.5384693101056831, 0.5384693101056831, -0.9061798459386640, 0.9061798459386640};
  static const double w[5] = {0.5688888888888889, 0.4786286704993665, 0.4786286704993665, 0.2369268850561891,
                              0.2369268850561891};
  const double h = (b - a) / pieces;
  double sum = 0;
  for (int p = 0; p < pieces; ++p) {
    const double mid = a + (p + 0.5) * h;
    for (int k = 0; k < 5; ++k) sum += w[k] * f(mid + 0.5 * h * x[k]);
  }
  return 0.5 * h * sum;
}

}  // namespace

/// The unit shape of the worn profiles (pinion maximum 1), root → tip at `n` uniform profile
/// fractions: Archard's depth per pinion revolution in closed form. A flank point passes through the
/// Hertz strip (half-width a, mean pressure w/(2a)) in 2a/v_r, sliding |v_s| meanwhile, so one pass
/// wears h = K w |v_s| / v_r: a cancels. With ω1 = 1, v_r1 = ρ1 = s, v_r2 = (z1/z2) ρ2 = (z1/z2)(T1T2 − s),
/// |v_s| = (1 + z1/z2)|s − s_pitch|, and a gear tooth meets z1/z2 passes per pinion revolution:
///   pinion ∝ share(s) |s − s_pitch| / ρ1(s),   gear ∝ share(s) |s − s_pitch| / ρ2(s),
/// share = 1 where one pair carries the load, k/(k + k_other) where two do (single-pair stiffness). The specific sliding
/// 1/ρ deepens each flank's dedendum (thesis §2.1, §6.2.3: Eqs. 6.2–6.3 for a pass).
ArchardProfileShape archard_profile_shape(const GearPairSpec& gears, int n) {
  const auto g = twin::GearGeometry::from_spec(gears);
  const double s_pitch = g.base_radius_pinion * std::tan(g.pressure_angle_rad);
  // The pair's share of the load: all of it alone, k/(k + k_other) beside the pair one base pitch
  // ahead or behind (static sharing by the pairs' stiffnesses, unworn teeth).
  auto share = [&g](double s) {
    const double other = s < g.contact_end - g.base_pitch ? s + g.base_pitch
                         : s > g.contact_start + g.base_pitch ? s - g.base_pitch : NAN;
    if (std::isnan(other)) return 1.0;
    const double k = twin::single_pair_stiffness(g, s);
    return k / (k + twin::single_pair_stiffness(g, other));
  };
  ArchardProfileShape shape;
  shape.pinion.resize(static_cast<std::size_t>(n));
  shape.gear.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double u = static_cast<double>(i) / (n - 1);
    const double sp = g.contact_start + u * g.active_length();  // pinion fraction u
    const double sg = g.contact_end - u * g.active_length();    // gear fraction u
    shape.pinion[static_cast<std::size_t>(i)] = share(sp) * std::abs(sp - s_pitch) / g.curvature_radius_pinion(sp);
    shape.gear[static_cast<std::size_t>(i)] = share(sg) * std::abs(sg - s_pitch) / g.curvature_radius_gear(sg);
  }
  const double top = *std::max_element(shape.pinion.begin(), shape.pinion.end());
  for (auto& v : shape.pinion) v /= top;
  for (auto& v : shape.gear) v /= top;
  return shape;
}

namespace {
double trapezoid_mean(const std::vector<double>& v) {
  double sum = 0;
  for (double d : v) sum += d;
  sum -= 0.5 * (v.front() + v.back());
  return sum / static_cast<double>(v.size() - 1);
}

/// The profiles at the amplitude (the pinion's deepest point), their pinion and combined means.
void fill_archard_profile(WearState& w, double amplitude, const ArchardProfileShape& shape) {
  if (amplitude == 0) return;
  w.profile.pinion = shape.pinion;
  w.profile.gear = shape.gear;
  for (auto& d : w.profile.pinion) d *= amplitude;
  for (auto& d : w.profile.gear) d *= amplitude;
  w.mean_wear_depth_m = trapezoid_mean(w.profile.pinion);
  w.combined_mean_wear_depth_m = w.mean_wear_depth_m + trapezoid_mean(w.profile.gear);
}

void validate(const WeibullPittingSettings& s) {
  require(std::isfinite(s.shape) && s.shape > 0, "weibull pitting: shape must be > 0");
  require(std::isfinite(s.characteristic_life_cycles) && s.characteristic_life_cycles > 0,
          "weibull pitting: characteristic_life_cycles must be > 0");
  require(finite_nonnegative(s.location_cycles), "weibull pitting: location_cycles must be >= 0");
  require(s.sites >= 1 && s.sites <= 1000000, "weibull pitting: sites must be 1 .. 1000000");
  require(std::isfinite(s.initial_area_m2) && s.initial_area_m2 > 0, "weibull pitting: initial_area_m2 must be > 0");
  require(std::isfinite(s.max_area_m2) && s.max_area_m2 >= s.initial_area_m2,
          "weibull pitting: max_area_m2 must be >= initial_area_m2");
  require(finite_nonnegative(s.growth_per_cycle), "weibull pitting: growth_per_cycle must be >= 0");
  require(std::isfinite(s.growth_power) && s.growth_power > 0, "weibull pitting: growth_power must be > 0");
  require(std::isfinite(s.reference_torque_nm) && s.reference_torque_nm > 0, "weibull pitting: reference_torque_nm must be > 0");
  require(finite_nonnegative(s.load_life_exponent), "weibull pitting: load_life_exponent must be >= 0");
  require(s.max_density >= 0 && s.max_density <= 1, "weibull pitting: max_density must be 0 .. 1");
}

void validate(const FormsSettings& s, const TorqueSchedule& t, double reference_torque_nm, int profile_points,
              double speed_hz) {
  require(finite_nonnegative(s.k0), "wear forms: k0 must be finite and >= 0");
  require(std::isfinite(reference_torque_nm) && reference_torque_nm > 0, "wear forms: reference torque must be > 0");
  require(finite_nonnegative(t.torque_nm) && finite_nonnegative(t.torque_after_nm), "wear forms: torques must be >= 0");
  require(std::isfinite(t.change_cycles), "wear forms: load change cycles must be finite");
  require(finite_nonnegative(s.film.viscosity_pa_s) && finite_nonnegative(s.film.pressure_viscosity_per_pa),
          "wear forms: viscosity and pressure-viscosity coefficient must be >= 0");
  const auto& r = s.roughness;
  require(finite_nonnegative(r.initial_um) && finite_nonnegative(r.final_um) && finite_nonnegative(r.index_floor) &&
              finite_nonnegative(r.index_per_um_wear),
          "wear forms: roughness values must be >= 0");
  require(std::isfinite(r.runin_cycles) && r.runin_cycles > 0, "wear forms: roughness runin_cycles must be > 0");
  require(std::isfinite(s.contamination.from_cycles) && finite_nonnegative(s.contamination.wear_factor) &&
              finite_nonnegative(s.contamination.pitting_growth_factor),
          "wear forms: contamination factors must be >= 0");
  if (s.wear == WearCoefficientForm::regime && s.film.viscosity_pa_s > 0) {
    require(r.initial_um > 0 && r.final_um > 0, "wear forms: the regime form needs roughness initial_um and final_um > 0");
    require(t.torque_nm > 0 && (!t.changes() || t.torque_after_nm > 0), "wear forms: the regime form's film needs a torque > 0");
    require(std::isfinite(speed_hz) && speed_hz > 0, "wear forms: the regime form's film needs a speed > 0");
  }
  if (s.pitting == PittingForm::weibull) validate(s.weibull);
  require(profile_points >= 2, "wear profile needs at least 2 points");
}

}  // namespace

const char* to_string(WearCoefficientForm form) {
  switch (form) {
    case WearCoefficientForm::constant: return "constant";
    case WearCoefficientForm::regime: return "regime";
  }
  return "?";
}

const char* to_string(PitGrowthForm form) {
  switch (form) {
    case PitGrowthForm::exponential: return "exponential";
    case PitGrowthForm::power: return "power";
  }
  return "?";
}

const char* to_string(PittingForm form) {
  switch (form) {
    case PittingForm::none: return "none";
    case PittingForm::weibull: return "weibull";
  }
  return "?";
}

double TorqueSchedule::equivalent_cycles(double cycles, double reference_nm, double exponent) const {
  const double r1 = std::pow(torque_nm / reference_nm, exponent);
  if (!changes() || cycles <= change_cycles) return cycles * r1;
  return change_cycles * r1 + (cycles - change_cycles) * std::pow(torque_after_nm / reference_nm, exponent);
}

double TorqueSchedule::cycles_at_equivalent(double equivalent, double reference_nm, double exponent) const {
  const double r1 = std::pow(torque_nm / reference_nm, exponent);
  if (equivalent <= 0) return 0;
  if (!changes()) return r1 > 0 ? equivalent / r1 : kInf;
  const double before = change_cycles * r1;
  if (equivalent <= before) return equivalent / r1;
  const double r2 = std::pow(torque_after_nm / reference_nm, exponent);
  return r2 > 0 ? change_cycles + (equivalent - before) / r2 : kInf;
}

double RunInRoughness::at_um(double cycles) const {
  return final_um + (initial_um - final_um) * std::exp(-cycles / runin_cycles);
}

double regime_wear_factor(double lambda) {
  if (lambda <= 0.5) return 1.0;
  if (lambda >= 4.0) return 0.0;
  return 2.0 / 7.0 * (4.0 - lambda);
}

PitchContact pitch_contact(const GearPairSpec& gears, double speed_hz, double torque_nm) {
  const auto g = twin::GearGeometry::from_spec(gears);
  const double tan_alpha = std::tan(g.pressure_angle_rad);
  const double rho1 = g.base_radius_pinion * tan_alpha;  // = s_pitch, the pinion's radius of curvature there
  const double rho2 = g.base_radius_gear * tan_alpha;
  // Between the start of contact + one base pitch and the end − one base pitch a single pair
  // carries the load; elsewhere two share it (equally, an approximation for the double zone).
  const bool single = rho1 >= g.contact_end - g.base_pitch && rho1 <= g.contact_start + g.base_pitch;
  PitchContact c;
  c.entraining_speed_m_s = 2.0 * std::numbers::pi * speed_hz * rho1;
  c.reduced_radius_m = rho1 * rho2 / (rho1 + rho2);
  c.load_per_width_n_m = std::abs(torque_nm) / g.base_radius_pinion / gears.face_width_m * (single ? 1.0 : 0.5);
  c.reduced_modulus_pa = 2.0 * g.effective_modulus;
  return c;
}

double min_film_thickness_m(const PitchContact& c, const LubricantFilm& film) {
  // Dowson, D. and Higginson, G. R., Elasto-hydrodynamic Lubrication (SI ed., Pergamon 1977):
  // H_min = h_min/R' = 2.65 U^0.70 G^0.54 W^−0.13 for an isothermal, fully flooded line contact.
  if (film.viscosity_pa_s <= 0) return 0;
  const double er = c.reduced_modulus_pa * c.reduced_radius_m;
  const double u = film.viscosity_pa_s * c.entraining_speed_m_s / er;
  const double g = film.pressure_viscosity_per_pa * c.reduced_modulus_pa;
  const double w = c.load_per_width_n_m / er;
  return 2.65 * c.reduced_radius_m * std::pow(u, 0.70) * std::pow(g, 0.54) * std::pow(w, -0.13);
}

double active_flank_area_m2(const GearPairSpec& gears) {
  const auto g = twin::GearGeometry::from_spec(gears);
  // The involute's arc length from the base circle to roll distance s is s²/(2 r_b).
  const double flank = (g.contact_end * g.contact_end - g.contact_start * g.contact_start) / (2.0 * g.base_radius_pinion);
  return gears.pinion_teeth * gears.face_width_m * flank;
}

WeibullPitting::WeibullPitting(const WeibullPittingSettings& settings, double active_area_m2, const TorqueSchedule& torque,
                               const Contamination& contamination)
    : s_(settings), area_m2_(active_area_m2), contamination_(contamination) {
  validate(s_);
  require(std::isfinite(area_m2_) && area_m2_ > 0, "weibull pitting: the active flank area must be > 0");
  detail::Random rng(s_.seed);
  initiation_.reserve(static_cast<std::size_t>(s_.sites));
  for (int i = 0; i < s_.sites; ++i) {
    const double u = rng.uniform();  // [0, 1): −log1p(−u) is finite
    const double life = s_.location_cycles + s_.characteristic_life_cycles * std::pow(-std::log1p(-u), 1.0 / s_.shape);
    initiation_.push_back(torque.cycles_at_equivalent(life, s_.reference_torque_nm, s_.load_life_exponent));
  }
  std::sort(initiation_.begin(), initiation_.end());
}

double WeibullPitting::growth_exponent(double cycles) const {
  double g = s_.growth_per_cycle * cycles;
  if (contamination_.active(cycles))
    g += s_.growth_per_cycle * (contamination_.pitting_growth_factor - 1.0) * (cycles - contamination_.from_cycles);
  return g;
}

double WeibullPitting::growth_rate(double cycles) const {
  return s_.growth_per_cycle * (contamination_.active(cycles) ? contamination_.pitting_growth_factor : 1.0);
}

double WeibullPitting::full_growth_age() const {
  const double ratio = s_.max_area_m2 / s_.initial_area_m2;
  if (s_.growth == PitGrowthForm::power) return s_.growth_power * (std::pow(ratio, 1.0 / s_.growth_power) - 1.0);
  return std::log(ratio);
}

double WeibullPitting::pit_area(double age) const {
  if (age >= full_growth_age()) return s_.max_area_m2;
  if (s_.growth == PitGrowthForm::power) return s_.initial_area_m2 * std::pow(1.0 + age / s_.growth_power, s_.growth_power);
  return s_.initial_area_m2 * std::exp(age);
}

double WeibullPitting::density(double cycles) const {
  const auto end = std::upper_bound(initiation_.begin(), initiation_.end(), cycles);
  const double g_now = growth_exponent(cycles);
  double area = 0;
  for (auto it = initiation_.begin(); it != end; ++it) area += pit_area(g_now - growth_exponent(*it));
  return std::min(s_.max_density, area / area_m2_);
}

FormsWearTruth::FormsWearTruth(const FormsSettings& settings, const TorqueSchedule& torque, double reference_torque_nm,
                               int profile_points, const GearPairSpec& gears, double speed_hz)
    : s_(settings), torque_(torque), reference_torque_nm_(reference_torque_nm), profile_points_(profile_points),
      gears_(gears), speed_hz_(speed_hz) {
  validate(s_, torque_, reference_torque_nm_, profile_points_, speed_hz_);
  shape_ = archard_profile_shape(gears, profile_points_);
  area_m2_ = active_flank_area_m2(gears);
  for (double t : {torque_.torque_nm, torque_.torque_after_nm})
    film_m_.push_back(s_.film.viscosity_pa_s > 0 && t > 0 ? min_film_thickness_m(pitch_contact(gears, speed_hz, t), s_.film) : 0.0);
  if (s_.pitting == PittingForm::weibull)
    pitting_ = std::make_unique<WeibullPitting>(s_.weibull, area_m2_, torque_, s_.contamination);
}

double FormsWearTruth::film_thickness_m(double cycles) const {
  return film_m_[torque_.changes() && cycles >= torque_.change_cycles ? 1 : 0];
}

double FormsWearTruth::lambda(double cycles) const {
  const double h = film_thickness_m(cycles);
  return h > 0 ? h / (s_.roughness.at_um(cycles) * 1e-6) : 0.0;
}

double FormsWearTruth::wear_factor(double cycles) const {
  const double f = s_.wear == WearCoefficientForm::regime ? regime_wear_factor(lambda(cycles)) : 1.0;
  return f * (s_.contamination.active(cycles) ? s_.contamination.wear_factor : 1.0);
}

std::vector<double> FormsWearTruth::breakpoints(double cycles) const {
  // The integrand jumps at the contamination and the load change, and has kinks where λ crosses
  // Eq. 2.4's 1/2 and 4 (R(N) is monotonic, so each film meets each once at most).
  std::vector<double> b{0.0, cycles};
  if (s_.contamination.on()) b.push_back(s_.contamination.from_cycles);
  if (torque_.changes()) b.push_back(torque_.change_cycles);
  const auto& r = s_.roughness;
  for (double h : film_m_)
    for (double limit : {0.5, 4.0}) {
      const double ratio = (h / limit * 1e6 - r.final_um) / (r.initial_um - r.final_um);
      if (h > 0 && std::isfinite(ratio) && ratio > 0 && ratio < 1) b.push_back(-r.runin_cycles * std::log(ratio));
    }
  b.erase(std::remove_if(b.begin(), b.end(), [cycles](double x) { return x < 0 || x > cycles; }), b.end());
  std::sort(b.begin(), b.end());
  b.erase(std::unique(b.begin(), b.end()), b.end());
  return b;
}

double FormsWearTruth::wear_amplitude_m(double cycles) const {
  if (cycles <= 0 || s_.k0 == 0) return 0;
  const auto b = breakpoints(cycles);
  // Pieces of an eighth of the run-in length follow exp(−N/N_r) to far below double rounding.
  const double piece = s_.roughness.runin_cycles / 8.0;
  double sum = 0;
  for (std::size_t i = 0; i + 1 < b.size(); ++i) {
    const double len = b[i + 1] - b[i];
    const int pieces = static_cast<int>(std::clamp(std::ceil(len / piece), 1.0, 4096.0));
    sum += gauss_legendre([this](double n) { return integrand(n); }, b[i], b[i + 1], pieces);
  }
  return s_.k0 * sum;
}

WearState FormsWearTruth::at(double cycles) const {
  WearState w;
  w.cycles = cycles;
  fill_archard_profile(w, wear_amplitude_m(cycles), shape_);
  w.k_wear = s_.k0 * wear_factor(cycles);
  const auto& r = s_.roughness;
  w.roughness = std::max(0.0, (r.at_um(cycles) - r.final_um) + r.index_floor + r.index_per_um_wear * w.mean_wear_depth_m * 1e6);
  if (pitting_) {
    w.pitting_density = pitting_->density(cycles);
    w.k_pitting = pitting_->growth_rate(cycles);
  }
  return w;
}

}  // namespace gearwatch::rig
