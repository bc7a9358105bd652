// random_campaign(): a campaign drawn from a seed over the truth forms (wear_truth_forms.hpp). The
// ranges are anchored on the thesis's two tests (Table 3.1, §6.3, §7.4) and listed with their
// sources in docs/rig-simulator.md, "Random campaigns"; change one here, change it there.
#include <algorithm>
#include <cmath>

#include "gearwatch/rig/campaign.hpp"
#include "gearwatch/rig/wear_truth_forms.hpp"
#include "gearwatch/twin/gearbox_parameters.hpp"
#include "random.hpp"

namespace gearwatch::rig {
namespace {

constexpr double kSpeedHz = 10.0;              // Table 3.1: both tests ran at 10 Hz
constexpr double kWearReferenceTorqueNm = 20.0;

/// The regime's schedule, operating point, wear coefficient form, lubricant and roughness.
void draw_lubricated(detail::Random& rng, CampaignSpec& c) {
  auto& f = c.wear.forms;
  c.max_cycles = 1e5 * std::round(rng.uniform(25, 40));  // 2.5–4.0 M (the test: 3.25 M)
  c.stop_interval_cycles = 1e5;
  c.records = 20;
  c.torque_nm = rng.uniform(15, 25);                     // the test: 20 N·m
  f.wear = rng.uniform() < 0.5 ? WearCoefficientForm::regime : WearCoefficientForm::constant;
  const bool contaminated = f.wear == WearCoefficientForm::constant || rng.uniform() < 0.5;
  if (contaminated) {
    f.contamination.from_cycles = rng.uniform(0.3, 0.8) * c.max_cycles;
    f.contamination.wear_factor = rng.uniform(1.5, 3.0);          // the test's K: ×2.76 at 2.19 M (§7.4.1)
    f.contamination.pitting_growth_factor = rng.uniform(1.2, 2.0);
  }
  f.film.viscosity_pa_s = rng.uniform(0.04, 0.15);       // 146 mm²/s at 40 °C ≈ 0.13 Pa·s; thinner when warmer
  f.film.pressure_viscosity_per_pa = rng.uniform(1.5e-8, 2.5e-8);
  f.roughness.initial_um = rng.uniform(0.5, 1.5);        // sandpaper-roughened flanks
  f.roughness.final_um = rng.uniform(0.1, 0.3);
  f.roughness.runin_cycles = rng.uniform(4e4, 1.2e5);    // run-in over the first 0.12–0.23 M cycles
}

void draw_dry(detail::Random& rng, CampaignSpec& c) {
  auto& f = c.wear.forms;
  c.max_cycles = 1e3 * std::round(rng.uniform(30, 50));  // 30 000–50 000 (the test: 38 000)
  c.stop_interval_cycles = 5000;
  c.records = 8;
  c.torque_nm = rng.uniform(5, 10);                      // the test: 5 N·m
  f.wear = WearCoefficientForm::constant;                // no film: Eq. 2.4 would give k0 throughout
  f.contamination.from_cycles = rng.uniform(0.3, 0.8) * c.max_cycles;
  f.contamination.wear_factor = rng.uniform(1.2, 1.6);   // the test's K: ×1.33 at 0.025 M (§7.4.2)
  f.film.viscosity_pa_s = 0;
  f.roughness.initial_um = f.roughness.final_um = 0;
  f.roughness.index_floor = rng.uniform(0.03, 0.08);     // the built-in dry campaign: 0.05
  f.roughness.index_per_um_wear = rng.uniform(0.05, 0.12);
}

/// T2 within [max(low, T1/2), min(high, 2 T1)], at least 15 % away from T1.
void draw_load_change(detail::Random& rng, CampaignSpec& c, double low, double high) {
  if (rng.uniform() >= 0.5) return;
  c.load_change_cycles = rng.uniform(0.3, 0.7) * c.max_cycles;
  const double a = std::max(low, 0.5 * c.torque_nm), b = std::min(high, 2.0 * c.torque_nm);
  double t = c.torque_nm;
  for (int k = 0; k < 64 && std::abs(t - c.torque_nm) < 0.15 * c.torque_nm; ++k) t = rng.uniform(a, b);
  if (std::abs(t - c.torque_nm) < 0.15 * c.torque_nm) t = std::min(b, 1.15 * c.torque_nm);
  c.torque_after_nm = t;
}

/// The Weibull pitting's drawn parameters (η is solved afterwards).
void draw_pitting(detail::Random& rng, CampaignSpec& c, double area_m2) {
  auto& w = c.wear.forms.weibull;
  c.wear.forms.pitting = PittingForm::weibull;
  w.shape = rng.uniform(1.1, 3.0);
  w.location_cycles = rng.uniform(0.05e6, 0.25e6);       // pits first seen at 0.12 M (§7.4.1)
  w.initial_area_m2 = rng.uniform(0.005, 0.02) * 1e-6;   // 0.005–0.02 mm²
  w.max_area_m2 = rng.uniform(0.1, 0.5) * 1e-6;          // 0.1–0.5 mm² (Fig. 7.10's pits)
  c.random.pit_growth_cycles = rng.uniform(0.1, 0.5) * c.max_cycles;
  w.load_life_exponent = rng.uniform(10.0 / 3.0, 6.6);
  w.reference_torque_nm = c.torque_nm;
  w.max_density = 0.3;
  c.random.final_density_target = rng.uniform(0.12, 0.28);  // the test: ~17 % at ~3.2 M
  c.random.pit_site_oversupply = rng.uniform(1.5, 3.0);
  w.sites = static_cast<int>(std::ceil(c.random.pit_site_oversupply * c.random.final_density_target * area_m2 / w.max_area_m2));
  w.seed = c.random.seed * 0x9E3779B97F4A7C15ull + 0x51735ull;
  // Drawn last, so the draws above stay those of a campaign from before the power form. Half the
  // campaigns' pits grow as a power of their age, p in [1, 3] (1: linear in cycles).
  w.growth = rng.uniform() < 0.5 ? PitGrowthForm::exponential : PitGrowthForm::power;
  w.growth_power = w.growth == PitGrowthForm::power ? rng.uniform(1.0, 3.0) : 2.0;
  const double ratio = w.max_area_m2 / w.initial_area_m2;
  const double full = w.growth == PitGrowthForm::power ? w.growth_power * (std::pow(ratio, 1.0 / w.growth_power) - 1.0) : std::log(ratio);
  w.growth_per_cycle = full / c.random.pit_growth_cycles;
}

/// η such that the realised pits reach the density target at max_cycles: the density there falls
/// monotonically as η grows (every site's life grows with it), so bisect on ln η.
void solve_characteristic_life(CampaignSpec& c, double area_m2) {
  auto& w = c.wear.forms.weibull;
  double low = std::log(1e3), high = std::log(1e11);
  for (int k = 0; k < 60; ++k) {
    w.characteristic_life_cycles = std::exp(0.5 * (low + high));
    const WeibullPitting pits(w, area_m2, c.torque_schedule(), c.wear.forms.contamination);
    (pits.density(c.max_cycles) >= c.random.final_density_target ? low : high) = std::log(w.characteristic_life_cycles);
  }
  w.characteristic_life_cycles = std::exp(0.5 * (low + high));
}

/// k0 such that the combined mean depth at max_cycles is the target (the depth is linear in k0).
void scale_wear_coefficient(CampaignSpec& c, const GearPairSpec& gears) {
  auto forms = c.wear.forms;
  forms.k0 = 1.0;
  forms.pitting = PittingForm::none;
  const FormsWearTruth unit(forms, c.torque_schedule(), c.wear.reference_torque_nm, c.wear.profile_points, gears, kSpeedHz);
  c.wear.forms.k0 = c.random.final_depth_target_um * 1e-6 / unit.at(c.max_cycles).combined_mean_wear_depth_m;
}

}  // namespace

const char* to_string(CampaignRegime regime) {
  switch (regime) {
    case CampaignRegime::lubricated_like: return "lubricated-like";
    case CampaignRegime::dry_like: return "dry-like";
  }
  return "?";
}

CampaignSpec random_campaign(std::uint64_t seed) {
  detail::Random rng(seed ^ 0xC0FFEE5EEDull);
  const GearPairSpec gears = twin::GearboxParameters{}.gears;
  const double area = active_flank_area_m2(gears);
  CampaignSpec c;
  c.name = "random-" + std::to_string(seed);
  c.random.drawn = true;
  c.random.seed = seed;
  c.random.regime = rng.uniform() < 2.0 / 3.0 ? CampaignRegime::lubricated_like : CampaignRegime::dry_like;
  c.measurement_speeds_hz = {kSpeedHz};
  c.wear.law = WearLaw::forms;
  c.wear.reference_torque_nm = kWearReferenceTorqueNm;
  const bool lubricated = c.random.regime == CampaignRegime::lubricated_like;
  if (lubricated) {
    draw_lubricated(rng, c);
    draw_load_change(rng, c, 10, 40);
  } else {
    draw_dry(rng, c);
    draw_load_change(rng, c, 5, 20);
  }
  c.random.final_depth_target_um = rng.uniform(10, 40);   // the tests' combined mean depths
  if (lubricated) draw_pitting(rng, c, area);
  c.wear.torque_nm = c.torque_nm;
  c.wear.load_change_cycles = c.load_change_cycles;
  c.wear.torque_after_nm = c.torque_after_nm;
  scale_wear_coefficient(c, gears);
  if (lubricated) solve_characteristic_life(c, area);
  // The built-in campaigns' sliding gains and noise floor, so the daemon's wear-mechanism
  // indicators see the same strengths per unit pitting and roughness.
  c.pitting_gain_m_s2 = 20.0;
  c.roughness_gain_m_s2 = 4.0;
  c.effects = "noise";
  c.effect_values["noise.psd"] = 4e-5;
  return c;
}

}  // namespace gearwatch::rig
