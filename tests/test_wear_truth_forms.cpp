// The rig's wear truths in other forms (rig/include/gearwatch/rig/wear_truth_forms.hpp) against
// their closed forms: the thesis's Eq. 2.4, the Dowson–Higginson film worked by hand, the wear
// integral (constant λ, a run-in λ integrated analytically, the contamination step, the load
// change), the Weibull pitting's expected density over many seeds, the load-life scaling of the
// initiation; random campaigns: deterministic, inside their documented ranges, and written by
// `gearwatch simulate --campaign random` as random_campaign() says.
#include "gearwatch/rig/wear_truth_forms.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "command_runner.hpp"
#include "gearwatch/rig/campaign.hpp"
#include "gearwatch/twin/gear_geometry.hpp"
#include "gearwatch/twin/gearbox_parameters.hpp"
#include "gearwatch/twin/transmission_error.hpp"
#include "temp_dir.hpp"

namespace test_wear_truth_forms {  // this file's own: the test files compile together (unity build)

namespace rig = gearwatch::rig;
namespace fs = std::filesystem;

namespace {

const gearwatch::GearPairSpec kGears{};   // the thesis's pair: 19/52 teeth, module 2 mm, 20°, 20 mm face
const double kRatio = 19.0 / 52.0;

/// A forms truth with the roughness held at R so that λ = h_min/R is `lambda` at torque T.
rig::FormsSettings constant_lambda(double lambda, double torque_nm, double k0) {
  rig::FormsSettings f;
  f.wear = rig::WearCoefficientForm::regime;
  f.k0 = k0;
  f.film = {0.1, 2e-8};
  const double h = rig::min_film_thickness_m(rig::pitch_contact(kGears, 10.0, torque_nm), f.film);
  f.roughness.initial_um = f.roughness.final_um = h / lambda * 1e6;
  return f;
}

rig::TorqueSchedule constant_torque(double t) { return {t, -1, t}; }

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The torques of the operating-condition frames (0x1F1, f32 little-endian first) of a candump log.
std::vector<float> condition_torques(const fs::path& log) {
  std::ifstream in(log);
  std::vector<float> out;
  std::string line;
  while (std::getline(in, line)) {
    const auto at = line.find(" 1F1#");
    if (at == std::string::npos) continue;
    std::size_t data = at + 5;
    if (line[data] == '#') data += 2;   // CAN FD: "##<flags>"
    std::uint32_t bits = 0;
    for (int b = 3; b >= 0; --b) bits = (bits << 8) | std::stoul(line.substr(data + 2 * static_cast<std::size_t>(b), 2), nullptr, 16);
    float v;
    std::memcpy(&v, &bits, sizeof v);
    out.push_back(v);
  }
  return out;
}

}  // namespace

TEST_CASE("wear truth forms: the regime wear coefficient is the thesis's Eq. 2.4 at given lambda", "[wear_truth_forms]") {
  // Eq. 2.4: k0 for λ < 1/2, (2/7) k0 (4 − λ) for 1/2 < λ < 4, 0 for λ > 4 (continuous at 1/2).
  CHECK(rig::regime_wear_factor(0.0) == 1.0);
  CHECK(rig::regime_wear_factor(0.3) == 1.0);
  CHECK(rig::regime_wear_factor(0.5) == Approx(1.0).epsilon(1e-15));
  CHECK(rig::regime_wear_factor(1.0) == Approx(6.0 / 7.0).epsilon(1e-15));
  CHECK(rig::regime_wear_factor(2.25) == Approx(0.5).epsilon(1e-15));
  CHECK(rig::regime_wear_factor(3.5) == Approx(1.0 / 7.0).epsilon(1e-15));
  CHECK(rig::regime_wear_factor(4.0) == 0.0);
  CHECK(rig::regime_wear_factor(7.0) == 0.0);
  // Through the truth: the roughness set so that λ is 0.3, 1, 2.25, 3.5, 5; K in force is k0 f(λ).
  for (double lambda : {0.3, 1.0, 2.25, 3.5, 5.0}) {
    const rig::FormsWearTruth t(constant_lambda(lambda, 20, 2e-11), constant_torque(20), 20, 41, kGears, 10.0);
    CHECK(t.lambda(1e5) == Approx(lambda).epsilon(1e-12));
    const double expected = lambda <= 0.5 ? 1.0 : lambda >= 4 ? 0.0 : 2.0 / 7.0 * (4 - lambda);
    CHECK(t.at(1e5).k_wear == Approx(2e-11 * expected).epsilon(1e-12).margin(1e-30));
  }
}

TEST_CASE("wear truth forms: the Dowson-Higginson film at the pitch point equals a hand computation", "[wear_truth_forms]") {
  // By hand, the thesis's pair at 10 Hz and 20 N m: r_p1 = 19 mm, r_p2 = 52 mm, α = 20°:
  // ρ1 = r_p1 sin α = 6.498383 mm, ρ2 = 17.785047 mm, R' = ρ1ρ2/(ρ1+ρ2) = 4.759379 mm;
  // E' = E/(1 − ν²) = 205 GPa / 0.9159 = 223.8236 GPa; u = 2π·10·ρ1 = 0.4083054 m/s;
  // w' = T/(r_b1 b) = 20/(17.8542 mm · 20 mm) = 56009.36 N/m (the pitch point, 6.498 mm along the
  // line of action, lies in the single-contact zone 5.151–7.203 mm: ε = 1.653).
  const auto c = rig::pitch_contact(kGears, 10.0, 20.0);
  CHECK(c.reduced_radius_m == Approx(4.759379e-3).epsilon(1e-6));
  CHECK(c.reduced_modulus_pa == Approx(223.8236e9).epsilon(1e-6));
  CHECK(c.entraining_speed_m_s == Approx(0.4083054).epsilon(1e-6));
  CHECK(c.load_per_width_n_m == Approx(56009.36).epsilon(1e-6));
  // η0 = 0.1 Pa s, α = 2e-8 /Pa: U = 3.832914e-11, G = 4476.471, W = 5.257805e-5;
  // H = 2.65 U^0.7 G^0.54 W^−0.13 = 4.565801e-5, h_min = H R' = 0.2173038 µm.
  const double h = rig::min_film_thickness_m(c, {0.1, 2e-8});
  CHECK(h == Approx(0.2173038e-6).epsilon(1e-6));
  // λ at a composite roughness of 0.25 µm: 0.8692.
  rig::FormsSettings f;
  f.film = {0.1, 2e-8};
  f.roughness.initial_um = f.roughness.final_um = 0.25;
  const rig::FormsWearTruth t(f, constant_torque(20), 20, 41, kGears, 10.0);
  CHECK(t.film_thickness_m(0) == Approx(0.2173038e-6).epsilon(1e-6));
  CHECK(t.lambda(0) == Approx(0.2173038 / 0.25).epsilon(1e-6));
  // No lubricant: no film, λ = 0, boundary wear.
  CHECK(rig::min_film_thickness_m(c, {0.0, 2e-8}) == 0.0);
  // The pinion's active flank: 19 teeth × 20 mm × (s_end² − s_start²)/(2 r_b1) = 1282.791 mm².
  CHECK(rig::active_flank_area_m2(kGears) == Approx(1282.791e-6).epsilon(1e-6));
}

TEST_CASE("wear truth forms: the profile shape is Archard's depth per pass in closed form", "[wear_truth_forms]") {
  // One pass wears h = K w |v_s| / v_r (the Hertz width cancels), per pinion revolution, ω1 = 1:
  // pinion ∝ share |s − s_p| / ρ1, gear ∝ share |s − s_p| / ρ2 (z1/z2 passes at (z1/z2)ρ2 rolling).
  // Known answers independent of the load share: at one contact point s the gear's depth over the
  // pinion's is ρ1/ρ2; where one pair carries the load (share 1) two pinion points stand as
  // (|s_a − s_p|/s_a) / (|s_b − s_p|/s_b). The pitch point is the shallowest; the pinion maximum is 1.
  const auto g = gearwatch::twin::GearGeometry::from_spec(kGears);
  const int n = 401;
  const auto shape = rig::archard_profile_shape(kGears, n);
  const double s_pitch = g.base_radius_pinion * std::tan(g.pressure_angle_rad);
  CHECK(*std::max_element(shape.pinion.begin(), shape.pinion.end()) == Approx(1.0).epsilon(1e-15));
  auto s_of = [&](int i) { return g.contact_start + g.active_length() * i / (n - 1.0); };  // pinion fraction i/(n−1)
  int checked = 0;
  for (int i = 0; i < n; ++i) {
    const double s = s_of(i);
    if (std::abs(s - s_pitch) < 1e-5) continue;
    // The gear's table is indexed by its own fraction: the point s is gear index n − 1 − i.
    CHECK(shape.gear[static_cast<std::size_t>(n - 1 - i)] / shape.pinion[static_cast<std::size_t>(i)] ==
          Approx(s / (g.line_of_action_length - s)).epsilon(1e-12));
    ++checked;
  }
  CHECK(checked > n - 3);
  // Two points inside the single-pair zone [s_end − p_b, s_start + p_b], one each side of the pitch.
  const double lo = g.contact_end - g.base_pitch, hi = g.contact_start + g.base_pitch;
  REQUIRE(lo < s_pitch);
  REQUIRE(s_pitch < hi);
  const int ia = static_cast<int>(std::ceil((lo - g.contact_start) / g.active_length() * (n - 1)));
  const int ib = static_cast<int>(std::floor((hi - g.contact_start) / g.active_length() * (n - 1)));
  const double sa = s_of(ia), sb = s_of(ib);
  CHECK(shape.pinion[static_cast<std::size_t>(ia)] / shape.pinion[static_cast<std::size_t>(ib)] ==
        Approx((std::abs(sa - s_pitch) / sa) / (std::abs(sb - s_pitch) / sb)).epsilon(1e-12));
  // The dedendum of each flank is the deeper end (specific sliding, thesis §2.1): the pinion's root
  // (fraction 0) deeper than its tip, the gear's root deeper than its tip.
  CHECK(shape.pinion.front() > shape.pinion.back());
  CHECK(shape.gear.front() > shape.gear.back());
}

TEST_CASE("wear truth forms: the linear law's V shape leaves the double-contact deviation constant", "[wear_truth_forms]") {
  // Why the V shape |u − u_pitch| hides its wear from the mesh harmonics: with pinion and gear
  // depths linear in |s − s_p| (slope c), the two pairs of double contact at s and s + p_b stand
  // on either side of the pitch point and their deviations sum to −c p_b whatever s: under equal
  // pair stiffnesses the loaded transmission error there does not move. The closed-form shape
  // (specific sliding and load share) has no such cancellation.
  namespace twin = gearwatch::twin;
  const auto g = twin::GearGeometry::from_spec(kGears);
  rig::WearModelSettings ws;
  ws.phases = {{0, 1e-12}};
  const rig::BuiltinWearTruth v(ws, kGears);
  const auto w = v.at(1e7);   // amplitude 10 µm
  const twin::GeometricTransmissionError gte(g, w.profile);
  const double s_pitch = g.base_radius_pinion * std::tan(g.pressure_angle_rad);
  const double pinion_pitch = g.profile_fraction_pinion(s_pitch), gear_pitch = g.profile_fraction_gear(s_pitch);
  const double slope = 10e-6 / g.active_length() *
                       (1.0 / std::max(pinion_pitch, 1 - pinion_pitch) + kRatio / std::max(gear_pitch, 1 - gear_pitch));
  twin::ToothProfileDeviation c;
  const auto shape = rig::archard_profile_shape(kGears, 41);
  for (double d : shape.pinion) c.pinion.push_back(10e-6 * d);   // the pinion's deepest point 10 µm
  for (double d : shape.gear) c.gear.push_back(10e-6 * d);
  const twin::GeometricTransmissionError closed(g, c);
  double min_c = INFINITY, max_c = -INFINITY;
  for (double f = 0.02; f < 0.98; f += 0.05) {
    const double s = g.contact_start + f * (g.contact_end - g.base_pitch - g.contact_start);
    REQUIRE(s < s_pitch);
    REQUIRE(s + g.base_pitch > s_pitch);
    CHECK(gte.pair_error(s, 0, 0) + gte.pair_error(s + g.base_pitch, 0, 0) == Approx(-slope * g.base_pitch).epsilon(0.01));
    const double sum = closed.pair_error(s, 0, 0) + closed.pair_error(s + g.base_pitch, 0, 0);
    min_c = std::min(min_c, sum);
    max_c = std::max(max_c, sum);
  }
  CHECK(max_c - min_c > 2e-6);   // a fifth of the pinion's deepest point
}

TEST_CASE("wear truth forms: the depth amplitude is the integral of K dN times T/T_ref", "[wear_truth_forms]") {
  SECTION("a constant lambda: linear in the cycles") {
    // λ = 1.5: f = (2/7)(2.5) = 5/7; at 30 N m against T_ref 20 N m the amplitude is k0·(5/7)·1.5·N.
    const double k0 = 3e-11;
    const rig::FormsWearTruth t(constant_lambda(1.5, 30, k0), constant_torque(30), 20, 41, kGears, 10.0);
    for (double n : {1e3, 2.5e5, 3e6}) {
      CHECK(t.wear_amplitude_m(n) == Approx(k0 * 5.0 / 7.0 * 1.5 * n).epsilon(1e-12));
      const auto w = t.at(n);
      CHECK(*std::max_element(w.profile.pinion.begin(), w.profile.pinion.end()) == Approx(t.wear_amplitude_m(n)).epsilon(1e-12));
      // The profiles are the amplitude times the unit shape (its pinion maximum 1), and the
      // combined mean is the pinion's plus the gear's.
      const auto shape = rig::archard_profile_shape(kGears, 41);
      for (std::size_t i = 0; i < shape.gear.size(); ++i) {
        CHECK(w.profile.pinion[i] == Approx(t.wear_amplitude_m(n) * shape.pinion[i]).epsilon(1e-14));
        CHECK(w.profile.gear[i] == Approx(t.wear_amplitude_m(n) * shape.gear[i]).epsilon(1e-14));
      }
      double gear_mean = 0;
      for (std::size_t i = 0; i < w.profile.gear.size(); ++i)
        gear_mean += (i == 0 || i + 1 == w.profile.gear.size() ? 0.5 : 1.0) * w.profile.gear[i] / 40.0;
      CHECK(w.combined_mean_wear_depth_m == Approx(w.mean_wear_depth_m + gear_mean).epsilon(1e-12));
    }
  }
  SECTION("a roughness running in: the mixed regime's integral in closed form") {
    // R(n) = Rf + c e^{−n/Nr}; in the mixed regime ∫ (2/7)(4 − h/R) dn with
    // ∫ dn/R = n/Rf + (Nr/Rf) ln(Rf + c e^{−n/Nr}) (d/dn of the latter: 1/R).
    rig::FormsSettings f;
    f.wear = rig::WearCoefficientForm::regime;
    f.k0 = 1e-11;
    f.film = {0.1, 2e-8};
    const double h = rig::min_film_thickness_m(rig::pitch_contact(kGears, 10.0, 20.0), f.film) * 1e6;  // µm
    f.roughness = {h / 0.6, h / 3.0, 7e4};   // λ from 0.6 to 3: mixed throughout
    const rig::FormsWearTruth t(f, constant_torque(20), 20, 41, kGears, 10.0);
    const double rf = f.roughness.final_um, c = f.roughness.initial_um - rf, nr = f.roughness.runin_cycles;
    auto inv_r = [&](double n) { return n / rf + nr / rf * std::log(rf + c * std::exp(-n / nr)); };
    for (double n : {3e4, 2e5, 1.5e6}) {
      const double expected = f.k0 * 2.0 / 7.0 * (4 * n - h * (inv_r(n) - inv_r(0)));
      CHECK(t.wear_amplitude_m(n) == Approx(expected).epsilon(1e-10));
    }
    // From boundary into mixed: λ crosses 1/2 at n* = −Nr ln((2h − Rf)/c); k0 before, mixed after.
    f.roughness = {h / 0.2, h / 2.0, 5e4};
    const rig::FormsWearTruth crossing(f, constant_torque(20), 20, 41, kGears, 10.0);
    const double rf2 = f.roughness.final_um, c2 = f.roughness.initial_um - rf2, nr2 = f.roughness.runin_cycles;
    auto inv_r2 = [&](double n) { return n / rf2 + nr2 / rf2 * std::log(rf2 + c2 * std::exp(-n / nr2)); };
    const double n_star = -nr2 * std::log((2 * h - rf2) / c2);
    REQUIRE(crossing.lambda(n_star * 0.999) < 0.5);
    REQUIRE(crossing.lambda(n_star * 1.001) > 0.5);
    const double n = 4e5;
    const double expected = f.k0 * (n_star + 2.0 / 7.0 * (4 * (n - n_star) - h * (inv_r2(n) - inv_r2(n_star))));
    CHECK(crossing.wear_amplitude_m(n) == Approx(expected).epsilon(1e-10));
  }
  SECTION("a contamination step: the slope changes by exactly the factor at N_c") {
    auto f = constant_lambda(1.0, 20, 2e-11);
    f.contamination = {1e6, 2.5, 1.0};
    const rig::FormsWearTruth t(f, constant_torque(20), 20, 41, kGears, 10.0);
    const double k = 2e-11 * 6.0 / 7.0;   // λ = 1
    CHECK(t.wear_amplitude_m(1e6) == Approx(k * 1e6).epsilon(1e-12));
    CHECK(t.wear_amplitude_m(1.8e6) == Approx(k * (1e6 + 2.5 * 0.8e6)).epsilon(1e-12));
    const double d = 1e4;
    const double before = (t.wear_amplitude_m(1e6) - t.wear_amplitude_m(1e6 - d)) / d;
    const double after = (t.wear_amplitude_m(1e6 + d) - t.wear_amplitude_m(1e6)) / d;
    CHECK(after / before == Approx(2.5).epsilon(1e-10));
    CHECK(t.at(1e6 - 1).k_wear == Approx(k).epsilon(1e-14));
    CHECK(t.at(1e6).k_wear == Approx(2.5 * k).epsilon(1e-14));
  }
}

TEST_CASE("wear truth forms: a load change scales the depth slope by T2/T1 and the pitting lives by (T/T_ref)^-p",
          "[wear_truth_forms]") {
  SECTION("the depth slope, without a film and with one") {
    rig::FormsSettings dry;
    dry.wear = rig::WearCoefficientForm::constant;
    dry.k0 = 1e-9;
    dry.film.viscosity_pa_s = 0;
    const rig::TorqueSchedule change{10, 2e4, 25};
    const rig::FormsWearTruth t(dry, change, 20, 41, kGears, 10.0);
    const double d = 500;
    const double before = (t.wear_amplitude_m(2e4) - t.wear_amplitude_m(2e4 - d)) / d;
    const double after = (t.wear_amplitude_m(2e4 + d) - t.wear_amplitude_m(2e4)) / d;
    CHECK(before == Approx(1e-9 * 10 / 20).epsilon(1e-12));
    CHECK(after / before == Approx(25.0 / 10.0).epsilon(1e-10));
    // With a film, the load also thins it (W^−0.13): λ2/λ1 = (T2/T1)^−0.13, and the slope ratio is
    // (T2/T1)·f(λ2)/f(λ1).
    const auto wet = constant_lambda(2.0, 10, 1e-11);
    const rig::FormsWearTruth w(wet, change, 20, 41, kGears, 10.0);
    CHECK(w.lambda(2e4) / w.lambda(1e4) == Approx(std::pow(2.5, -0.13)).epsilon(1e-12));
    const double l2 = 2.0 * std::pow(2.5, -0.13);
    const double ratio = 2.5 * (2.0 / 7.0 * (4 - l2)) / (2.0 / 7.0 * (4 - 2.0));
    const double wb = (w.wear_amplitude_m(2e4) - w.wear_amplitude_m(2e4 - d)) / d;
    const double wa = (w.wear_amplitude_m(2e4 + d) - w.wear_amplitude_m(2e4)) / d;
    CHECK(wa / wb == Approx(ratio).epsilon(1e-10));
  }
  SECTION("the pitting lives") {
    rig::WeibullPittingSettings s;
    s.sites = 500;
    s.reference_torque_nm = 20;
    s.load_life_exponent = 4.0;
    s.location_cycles = 1e5;
    s.characteristic_life_cycles = 1.5e6;
    s.seed = 77;
    const double area = rig::active_flank_area_m2(kGears);
    const rig::WeibullPitting at_ref(s, area, constant_torque(20), {});
    const rig::WeibullPitting heavier(s, area, constant_torque(25), {});
    const double scale = std::pow(25.0 / 20.0, -4.0);   // life ∝ T^−p
    REQUIRE(at_ref.initiation_cycles().size() == 500);
    for (std::size_t i = 0; i < 500; ++i)
      CHECK(heavier.initiation_cycles()[i] == Approx(at_ref.initiation_cycles()[i] * scale).epsilon(1e-12));
    // T = 20 until 1 M, then 30: Miner's rule: a site whose life L (at 20 N m) is past 1 M
    // initiates at 1 M + (L − 1 M)·(30/20)^−4.
    const rig::WeibullPitting changed(s, area, rig::TorqueSchedule{20, 1e6, 30}, {});
    const double r2 = std::pow(30.0 / 20.0, 4.0);
    for (std::size_t i = 0; i < 500; ++i) {
      const double life = at_ref.initiation_cycles()[i];
      CHECK(changed.initiation_cycles()[i] == Approx(life <= 1e6 ? life : 1e6 + (life - 1e6) / r2).epsilon(1e-12));
    }
  }
}

TEST_CASE("wear truth forms: the Weibull pitting's mean density over many seeds equals its closed form", "[wear_truth_forms]") {
  const double area = rig::active_flank_area_m2(kGears);
  rig::WeibullPittingSettings s;
  s.shape = 1.8;
  s.characteristic_life_cycles = 1e6;
  s.location_cycles = 1e5;
  s.sites = 200;
  s.max_density = 1.0;
  s.reference_torque_nm = 20;
  auto weibull_cdf = [&](double n) { return n <= s.location_cycles ? 0.0 : 1 - std::exp(-std::pow((n - s.location_cycles) / s.characteristic_life_cycles, s.shape)); };
  const int seeds = 400;
  // The mean density over `seeds` campaigns drawn from first_seed on.
  auto mean_density_over_seeds = [&](double n, std::uint64_t first_seed) {
    double sum = 0;
    for (int k = 0; k < seeds; ++k) {
      s.seed = first_seed + static_cast<std::uint64_t>(k);
      sum += rig::WeibullPitting(s, area, constant_torque(20), {}).density(n);
    }
    return sum / seeds;
  };
  // E[density] at n and the SD of that mean over the seeds, for a pit whose area at age x is
  // area_of_age(x): the expectation and second moment by the midpoint rule on 200 000 steps of
  // the Weibull density (an independent integration of the same law). Sites are independent: a
  // campaign's density has the variance sites Var(a)/A².
  auto expected_density = [&](double n, const auto& area_of_age) {
    double m1 = 0, m2 = 0;
    const int steps = 200000;
    const double dt = (n - s.location_cycles) / steps;
    for (int i = 0; i < steps; ++i) {
      const double t = s.location_cycles + (i + 0.5) * dt;
      const double x = (t - s.location_cycles) / s.characteristic_life_cycles;
      const double pdf = s.shape / s.characteristic_life_cycles * std::pow(x, s.shape - 1) * std::exp(-std::pow(x, s.shape));
      const double a = std::min(s.max_area_m2, area_of_age(n - t));
      m1 += a * pdf * dt;
      m2 += a * a * pdf * dt;
    }
    return std::pair{s.sites * m1 / area, std::sqrt(s.sites * (m2 - m1 * m1) / seeds) / area};
  };
  SECTION("growth as a step: E[density] = a n F(N) / A") {
    s.initial_area_m2 = s.max_area_m2 = 2e-6;   // each pit appears at its full 2 mm²
    for (double n : {3e5, 1e6, 2.5e6}) {
      const double mean = mean_density_over_seeds(n, 1000);
      const double f = weibull_cdf(n);
      const double expected = s.max_area_m2 * s.sites * f / area;
      // The initiated count is binomial(n_sites, F): the mean over the seeds has the SD
      // a/A · sqrt(n F (1 − F) / seeds); 4 SD leaves a false failure at 6e-5 per check.
      const double sd = s.max_area_m2 / area * std::sqrt(s.sites * f * (1 - f) / seeds);
      INFO("N " << n << " expected " << expected << " sd " << sd);
      CHECK(std::abs(mean - expected) < 4 * sd);
    }
  }
  SECTION("exponential growth: E[density] = n/A ∫ min(a_max, a0 e^{g(N−t)}) dF(t)") {
    s.initial_area_m2 = 0.01e-6;
    s.max_area_m2 = 0.4e-6;
    s.growth_per_cycle = std::log(40.0) / 6e5;
    const double n = 1.5e6;
    const auto [expected, sd] = expected_density(n, [&](double age) { return s.initial_area_m2 * std::exp(s.growth_per_cycle * age); });
    const double mean = mean_density_over_seeds(n, 5000);
    // The mean over the seeds has the campaign's SD over sqrt(seeds); 4 SD as above.
    INFO("expected " << expected << " sd " << sd);
    CHECK(std::abs(mean - expected) < 4 * sd);
  }
  SECTION("power growth: E[density] = n/A ∫ min(a_max, a0 (1 + g(N−t)/p)^p) dF(t)") {
    s.initial_area_m2 = 0.01e-6;
    s.max_area_m2 = 0.4e-6;
    s.growth = rig::PitGrowthForm::power;
    s.growth_power = 1.7;
    const double full = 1.7 * (std::pow(40.0, 1.0 / 1.7) - 1.0);   // the age at a_max
    s.growth_per_cycle = full / 6e5;
    const double n = 1.5e6;
    const auto [expected, sd] =
        expected_density(n, [&](double age) { return s.initial_area_m2 * std::pow(1.0 + s.growth_per_cycle * age / 1.7, 1.7); });
    const double mean = mean_density_over_seeds(n, 7000);
    INFO("expected " << expected << " sd " << sd);
    CHECK(std::abs(mean - expected) < 4 * sd);
    // One pit's area in closed form: a0 (1 + x/p)^p, a_max from the full age on.
    const rig::WeibullPitting one(s, area, constant_torque(20), {});
    CHECK(one.pit_area(1.0) == Approx(0.01e-6 * std::pow(1.0 + 1.0 / 1.7, 1.7)).epsilon(1e-12));
    CHECK(one.full_growth_age() == Approx(full).epsilon(1e-12));
    CHECK(one.pit_area(full * 1.01) == s.max_area_m2);
  }
  SECTION("contamination multiplies the growth rate from N_c on") {
    s.initial_area_m2 = 0.01e-6;
    s.max_area_m2 = 10e-6;
    s.growth_per_cycle = 2e-6;
    s.seed = 9;
    const rig::WeibullPitting clean(s, area, constant_torque(20), {});
    const rig::WeibullPitting dirty(s, area, constant_torque(20), {1.2e6, 1.0, 1.7});
    CHECK(dirty.growth_rate(1.2e6 - 1) == 2e-6);
    CHECK(dirty.growth_rate(1.2e6) == Approx(3.4e-6).epsilon(1e-15));
    CHECK(dirty.density(1.2e6) == clean.density(1.2e6));
    // A pit initiated before N_c: area a0 exp(g (N_c − N_i) + 1.7 g (N − N_c)), below the cap here.
    const double ni = clean.initiation_cycles().front();
    REQUIRE(ni < 1.2e6);
    rig::WeibullPittingSettings one = s;
    one.sites = 1;
    one.location_cycles = 0;
    one.characteristic_life_cycles = 1e-3;   // initiates at once (life ≤ a few 1e-3 cycles)
    const rig::WeibullPitting single(one, area, constant_torque(20), {1.2e6, 1.0, 1.7});
    const double ni1 = single.initiation_cycles().front();
    const double expected = 0.01e-6 * std::exp(2e-6 * (1.2e6 - ni1) + 3.4e-6 * 0.5e6) / area;
    CHECK(single.density(1.7e6) == Approx(expected).epsilon(1e-9));
  }
}

TEST_CASE("wear truth forms: refusals are one line naming the parameter", "[wear_truth_forms]") {
  auto f = constant_lambda(1.0, 20, 1e-11);
  f.roughness.final_um = 0;
  CHECK_THROWS_WITH(rig::FormsWearTruth(f, constant_torque(20), 20, 41, kGears, 10.0),
                    "wear forms: the regime form needs roughness initial_um and final_um > 0");
  f = constant_lambda(1.0, 20, -1);
  CHECK_THROWS_WITH(rig::FormsWearTruth(f, constant_torque(20), 20, 41, kGears, 10.0), "wear forms: k0 must be finite and >= 0");
  rig::FormsSettings p;
  p.pitting = rig::PittingForm::weibull;
  p.weibull.max_area_m2 = 0.5 * p.weibull.initial_area_m2;
  CHECK_THROWS_WITH(rig::FormsWearTruth(p, constant_torque(20), 20, 41, kGears, 10.0),
                    "weibull pitting: max_area_m2 must be >= initial_area_m2");
  // A load change with the older laws is refused by make_wear_truth.
  rig::WearModelSettings linear;
  linear.load_change_cycles = 1e5;
  CHECK_THROWS_WITH(rig::make_wear_truth(linear, gearwatch::twin::GearboxParameters{}, 10.0),
                    "a load change needs the forms wear law (law is linear)");
}

TEST_CASE("random campaigns: deterministic per seed, different between seeds, inside the documented ranges",
          "[wear_truth_forms][campaign]") {
  const gearwatch::twin::GearboxParameters params;
  auto text = [](const rig::CampaignSpec& c) {
    return rig::truth_json(c, rig::campaign_effects(c, true, c.random.seed), c.random.seed, true, {}, 19, 52);
  };
  CHECK(text(rig::random_campaign(7)) == text(rig::random_campaign(7)));
  std::set<double> k0s;
  std::map<std::string, int> seen;
  const double area = rig::active_flank_area_m2(kGears);
  for (std::uint64_t seed = 1; seed <= 200; ++seed) {
    const auto c = rig::random_campaign(seed);
    const auto& f = c.wear.forms;
    INFO("seed " << seed);
    CHECK(c.name == "random-" + std::to_string(seed));
    REQUIRE(c.wear.law == rig::WearLaw::forms);
    k0s.insert(f.k0);
    const bool lubricated = c.random.regime == rig::CampaignRegime::lubricated_like;
    ++seen[rig::to_string(c.random.regime)];
    ++seen[rig::to_string(f.wear)];
    ++seen[rig::to_string(f.pitting)];
    if (f.contamination.on()) ++seen["contamination"];
    if (c.load_change_cycles >= 0) ++seen["load change"];
    if (f.pitting == rig::PittingForm::weibull) ++seen[std::string("pit growth ") + rig::to_string(f.weibull.growth)];
    // The ranges of docs/rig-simulator.md, "Random campaigns".
    CHECK(c.measurement_speeds_hz == std::vector<double>{10.0});
    CHECK(c.pitting_gain_m_s2 == 20.0);
    CHECK(c.roughness_gain_m_s2 == 4.0);
    CHECK(c.effect_values.at("noise.psd") == 4e-5);
    const double tlo = lubricated ? 15 : 5, thi = lubricated ? 25 : 10;
    CHECK((c.torque_nm >= tlo && c.torque_nm <= thi));
    CHECK(c.wear.torque_nm == c.torque_nm);
    if (c.load_change_cycles >= 0) {
      CHECK((c.load_change_cycles >= 0.3 * c.max_cycles && c.load_change_cycles <= 0.7 * c.max_cycles));
      CHECK((c.torque_after_nm >= (lubricated ? 10 : 5) && c.torque_after_nm <= (lubricated ? 40 : 20)));
      CHECK((c.torque_after_nm >= 0.5 * c.torque_nm && c.torque_after_nm <= 2 * c.torque_nm));
      CHECK(std::abs(c.torque_after_nm - c.torque_nm) >= 0.15 * c.torque_nm - 1e-12);
      CHECK(c.wear.load_change_cycles == c.load_change_cycles);
      CHECK(c.wear.torque_after_nm == c.torque_after_nm);
    }
    if (f.contamination.on())
      CHECK((f.contamination.from_cycles >= 0.3 * c.max_cycles && f.contamination.from_cycles <= 0.8 * c.max_cycles));
    if (lubricated) {
      CHECK((c.max_cycles >= 2.5e6 && c.max_cycles <= 4e6));
      CHECK(c.stop_interval_cycles == 1e5);
      CHECK(f.pitting == rig::PittingForm::weibull);
      if (f.wear == rig::WearCoefficientForm::constant) CHECK(f.contamination.on());
      if (f.contamination.on()) {
        CHECK((f.contamination.wear_factor >= 1.5 && f.contamination.wear_factor <= 3.0));
        CHECK((f.contamination.pitting_growth_factor >= 1.2 && f.contamination.pitting_growth_factor <= 2.0));
      }
      CHECK((f.film.viscosity_pa_s >= 0.04 && f.film.viscosity_pa_s <= 0.15));
      CHECK((f.film.pressure_viscosity_per_pa >= 1.5e-8 && f.film.pressure_viscosity_per_pa <= 2.5e-8));
      CHECK((f.roughness.initial_um >= 0.5 && f.roughness.initial_um <= 1.5));
      CHECK((f.roughness.final_um >= 0.1 && f.roughness.final_um <= 0.3));
      CHECK((f.roughness.runin_cycles >= 4e4 && f.roughness.runin_cycles <= 1.2e5));
      const auto& w = f.weibull;
      CHECK((w.shape >= 1.1 && w.shape <= 3.0));
      CHECK((w.location_cycles >= 5e4 && w.location_cycles <= 2.5e5));
      CHECK((w.initial_area_m2 >= 0.005e-6 && w.initial_area_m2 <= 0.02e-6));
      CHECK((w.max_area_m2 >= 0.1e-6 && w.max_area_m2 <= 0.5e-6));
      CHECK((w.load_life_exponent >= 10.0 / 3.0 && w.load_life_exponent <= 6.6));
      CHECK((c.random.pit_growth_cycles >= 0.1 * c.max_cycles && c.random.pit_growth_cycles <= 0.5 * c.max_cycles));
      const double ratio = w.max_area_m2 / w.initial_area_m2;
      if (w.growth == rig::PitGrowthForm::power) {
        CHECK((w.growth_power >= 1.0 && w.growth_power <= 3.0));
        CHECK(w.growth_per_cycle == Approx(w.growth_power * (std::pow(ratio, 1.0 / w.growth_power) - 1.0) / c.random.pit_growth_cycles));
      } else {
        CHECK(w.growth_per_cycle == Approx(std::log(ratio) / c.random.pit_growth_cycles));
      }
      CHECK((c.random.final_density_target >= 0.12 && c.random.final_density_target <= 0.28));
      CHECK((c.random.pit_site_oversupply >= 1.5 && c.random.pit_site_oversupply <= 3.0));
      CHECK(w.sites == static_cast<int>(std::ceil(c.random.pit_site_oversupply * c.random.final_density_target * area / w.max_area_m2)));
      CHECK(w.reference_torque_nm == c.torque_nm);
    } else {
      CHECK((c.max_cycles >= 3e4 && c.max_cycles <= 5e4));
      CHECK(c.stop_interval_cycles == 5000);
      CHECK(f.wear == rig::WearCoefficientForm::constant);
      CHECK(f.pitting == rig::PittingForm::none);
      CHECK(f.contamination.on());
      CHECK((f.contamination.wear_factor >= 1.2 && f.contamination.wear_factor <= 1.6));
      CHECK(f.film.viscosity_pa_s == 0);
      CHECK((f.roughness.index_floor >= 0.03 && f.roughness.index_floor <= 0.08));
      CHECK((f.roughness.index_per_um_wear >= 0.05 && f.roughness.index_per_um_wear <= 0.12));
    }
    // The truth the campaign makes: the final combined mean depth is the drawn 10–40 µm; the
    // final density the drawn target, to within one initial pit (the bisection's step).
    CHECK((c.random.final_depth_target_um >= 10 && c.random.final_depth_target_um <= 40));
    const auto truth = rig::make_wear_truth(c.wear, params, c.measurement_speeds_hz.front());
    const auto end = truth->at(c.max_cycles);
    CHECK(end.combined_mean_wear_depth_m * 1e6 == Approx(c.random.final_depth_target_um).epsilon(1e-9));
    if (lubricated) {
      CHECK(std::abs(end.pitting_density - c.random.final_density_target) <= f.weibull.initial_area_m2 / area + 1e-9);
      // The 5 % density is passed inside the campaign.
      CHECK(truth->at(0.98 * c.max_cycles).pitting_density > 0.05);
    }
  }
  CHECK(k0s.size() == 200);   // every seed a different campaign
  // Every option occurs (each is drawn with probability ≥ 1/6 per lubricated-like seed).
  for (const char* key : {"lubricated-like", "dry-like", "regime", "constant", "weibull", "none", "contamination", "load change",
                          "pit growth exponential", "pit growth power"})
    CHECK(seen[key] >= 10);
}

TEST_CASE("random campaigns: plan_records carries the torque schedule, record_truth and record_run_settings the record's",
          "[wear_truth_forms][campaign]") {
  rig::CampaignSpec c;
  c.max_cycles = 3e6;
  c.stop_interval_cycles = 1e5;
  c.records = 31;
  c.torque_nm = 18;
  c.load_change_cycles = 1.5e6;
  c.torque_after_nm = 27;
  c.measurement_speeds_hz = {10.0, 6.0};
  c.pitting_gain_m_s2 = 20;
  c.roughness_gain_m_s2 = 4;
  c.seconds = 2.5;
  c.channels = 1;
  const auto plan = rig::plan_records(c);
  REQUIRE(plan.size() == 62);
  for (const auto& p : plan) CHECK(p.torque_nm == (p.cycles >= 1.5e6 ? 27.0 : 18.0));
  CHECK(plan[29].torque_nm == 18.0);   // 1.4 M
  CHECK(plan[30].torque_nm == 27.0);   // 1.5 M: the record at the change runs at the new torque
  rig::WearState w;
  w.pitting_density = 0.1;
  w.roughness = 0.5;
  const auto t = rig::record_truth(c, plan[33], w);
  CHECK(t.sliding.pitting_rms_m_s2 == Approx(2.0));
  CHECK(t.sliding.abrasion_rms_m_s2 == Approx(2.0));
  CHECK(t.life_counter == 1600000);
  const auto run = rig::record_run_settings(c, plan[33], 5);
  CHECK(run.torque_nm == 27.0);
  CHECK(run.speed_hz == 6.0);
  CHECK(run.duration_s == 2.5);
  CHECK(run.channels == 1);
  CHECK(run.seed == 5 * 1000003ull + 33);
}

TEST_CASE("random campaigns: gearwatch simulate --campaign random writes the records and truth_forms random_campaign draws",
          "[wear_truth_forms][campaign]") {
  // Seed 3 (whatever it draws), and the first seed with a load change, whose last record runs after it.
  std::uint64_t changed = 0;
  for (std::uint64_t s = 1; s < 100 && changed == 0; ++s)
    if (rig::random_campaign(s).load_change_cycles >= 0) changed = s;
  REQUIRE(changed != 0);
  const gearwatch::testing::TempDir dir("random-campaign");
  for (std::uint64_t seed : {std::uint64_t{3}, changed}) {
    INFO("seed " << seed);
    const auto out = dir / ("r" + std::to_string(seed));
    const auto r = gearwatch::testing::run_command(std::string(GEARWATCH_BINARY) + " simulate --campaign random --seed " +
                                                   std::to_string(seed) + " --records 3 --seconds 0.3 --out " + out.string());
    INFO(r.err);
    REQUIRE(r.status == 0);
    auto spec = rig::random_campaign(seed);
    spec.records = 3;
    const auto plan = rig::plan_records(spec);
    REQUIRE(plan.size() == 3);
    const auto truth = nlohmann::json::parse(read_text(out / "truth.json"));
    CHECK(truth.at("campaign").at("name") == "random-" + std::to_string(seed));
    CHECK(truth.at("campaign").at("wear_law") == "forms");
    const auto& forms = truth.at("truth_forms");
    CHECK(forms.at("wear_coefficient_form") == rig::to_string(spec.wear.forms.wear));
    CHECK(forms.at("pitting_form") == rig::to_string(spec.wear.forms.pitting));
    CHECK(forms.at("k0_m_per_cycle").get<double>() == spec.wear.forms.k0);
    CHECK(forms.at("random").at("regime") == rig::to_string(spec.random.regime));
    CHECK(forms.at("contamination").is_null() == !spec.wear.forms.contamination.on());
    CHECK(forms.at("load_change").is_null() == (spec.load_change_cycles < 0));
    if (spec.load_change_cycles >= 0) {
      CHECK(forms.at("load_change").at("from_cycles").get<double>() == spec.load_change_cycles);
      CHECK(forms.at("load_change").at("torque_after_nm").get<double>() == spec.torque_after_nm);
    }
    if (spec.wear.forms.pitting == rig::PittingForm::weibull)
      CHECK(forms.at("pitting").at("characteristic_life_cycles").get<double>() == spec.wear.forms.weibull.characteristic_life_cycles);
    const auto wear = rig::make_wear_truth(spec.wear, gearwatch::twin::GearboxParameters{}, 10.0);
    std::vector<std::string> logs;
    for (const auto& e : fs::directory_iterator(out))
      if (e.path().extension() == ".log") logs.push_back(e.path().filename().string());
    std::sort(logs.begin(), logs.end());
    REQUIRE(logs.size() == 3);
    for (std::size_t k = 0; k < 3; ++k) {
      const auto& rec = truth.at("records")[k];
      CHECK(rec.at("file") == plan[k].file_name);
      CHECK(logs[k] == plan[k].file_name);
      CHECK(rec.at("torque_nm").get<double>() == plan[k].torque_nm);
      CHECK(rec.at("combined_mean_wear_depth_um").get<double>() == Approx(wear->at(plan[k].cycles).combined_mean_wear_depth_m * 1e6).epsilon(1e-12));
      CHECK(rec.at("pitting_density").get<double>() == Approx(wear->at(plan[k].cycles).pitting_density).epsilon(1e-12).margin(1e-15));
      // The capture's operating-condition frames carry the record's torque (f32) for the daemon.
      const auto torques = condition_torques(out / logs[k]);
      REQUIRE(!torques.empty());
      for (float t : torques) CHECK(t == static_cast<float>(plan[k].torque_nm));
    }
    if (seed == changed) CHECK(plan[2].torque_nm == spec.torque_after_nm);
  }
  // Without a seed there is nothing to draw from.
  const auto r = gearwatch::testing::run_command(std::string(GEARWATCH_BINARY) + " simulate --campaign random --out " +
                                                 (dir / "none").string());
  CHECK(r.status != 0);
  CHECK_THAT(r.err, Catch::Matchers::Contains("--campaign random needs --seed N"));
  CHECK(!fs::exists(dir / "none"));
}

}  // namespace test_wear_truth_forms
