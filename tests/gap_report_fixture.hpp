#pragma once
// A sim-to-real gap report with known values, as the diagnosis would hand it over: a casing mode
// at 2.4 kHz missing from the twin, found and chosen; the output sidebands left unexplained; the
// output shaft orders not resolvable from short records. Not a component: shared by the storage,
// report-page and alert tests and by the browser test's database writer. The doubles are picked
// so that any rounding on the way through the database or the page shows.
#include <limits>
#include <cmath>
#include <vector>

#include "gearwatch/types/gap_report.hpp"

namespace gearwatch::testing {

inline gap::FamilyGap family_gap(gap::FamilyKind family, double distance, double low, double high, double share,
                                 bool significant) {
  gap::FamilyGap g;
  g.family = family;
  g.distance_db = distance;
  g.distance_interval_db = {low, high};
  g.energy_share = share;
  g.significant = significant;
  return g;
}

inline gap::FamilyGap unresolved_gap(gap::FamilyKind family, const char* reason) {
  gap::FamilyGap g;
  g.family = family;
  g.resolved = false;
  g.unresolved_reason = reason;
  return g;
}

/// Measured, twin and twin-with-casing-mode levels (dB) on a grid: mesh lines at multiples of
/// `mesh` on a floor, the measurement with a resonance hump at `mode` (one-degree-of-freedom
/// magnitude, ζ = 0.05) that the twin lacks and the corrected twin has.
struct Spectra {
  std::vector<double> axis, measured, twin, after;
};
inline Spectra spectra(double step, int points, double mesh, double mode) {
  Spectra s;
  for (int i = 0; i < points; ++i) {
    const double x = step * (i + 1);
    const double line_offset = std::fabs(std::remainder(x, mesh));
    const double base = -60.0 + (line_offset < step ? 40.0 : 0.0);
    const double r = x / mode;
    const double hump = -20.0 * std::log10(std::sqrt((1 - r * r) * (1 - r * r) + (0.1 * r) * (0.1 * r)));
    s.axis.push_back(x);
    s.twin.push_back(base);
    s.measured.push_back(base + hump);
    s.after.push_back(base + 0.9 * hump);
  }
  return s;
}

inline gap::GapReport known_gap_report() {
  using gap::FamilyKind;
  gap::GapReport r;
  r.input_revolutions = 123456.789;
  r.speeds_hz = {10.0, 20.0 / 3.0};
  r.training_records = 4;
  r.held_out_records = 2;
  r.before = {family_gap(FamilyKind::input_shaft_orders, 0.4 + 1.0 / 3.0, -0.25, 1.1, 0.021, false),
              unresolved_gap(FamilyKind::output_shaft_orders, "records shorter than 8 output revolutions"),
              family_gap(FamilyKind::mesh_harmonics, 1.25, 0.5, 2.0, 0.05, false),
              family_gap(FamilyKind::input_sidebands, 2.1, 0.9, 3.3, 0.08, true),
              family_gap(FamilyKind::output_sidebands, 4.75, 3.5, 6.0, 0.11, true),
              family_gap(FamilyKind::fixed_frequency, 12.625, 10.5, 14.75, 0.68, true),
              family_gap(FamilyKind::broadband, 0.3, -0.5, 1.0, 0.059, false)};
  r.after = {family_gap(FamilyKind::input_shaft_orders, 0.35, -0.3, 1.0, 0.09, false),
             unresolved_gap(FamilyKind::output_shaft_orders, "records shorter than 8 output revolutions"),
             family_gap(FamilyKind::mesh_harmonics, 1.0, 0.25, 1.75, 0.2, false),
             family_gap(FamilyKind::input_sidebands, 0.7, -0.2, 1.6, 0.12, false),
             family_gap(FamilyKind::output_sidebands, 4.5, 3.25, 5.75, 0.45, true),
             family_gap(FamilyKind::fixed_frequency, 1.5, 0.75, 2.25, 0.1, false),
             family_gap(FamilyKind::broadband, 0.25, -0.5, 1.0, 0.04, false)};

  gap::CandidateScore casing;
  casing.effect = gap::CandidateEffect::casing_mode;
  casing.parameters = {{"frequency_hz", 2400.0 + 1.0 / 7.0}, {"damping_ratio", 0.05}, {"gain", 3.75}};
  casing.explains = {FamilyKind::fixed_frequency, FamilyKind::input_sidebands};
  casing.held_out_after = r.after;
  casing.shrinkage = 0.875;
  casing.information_criterion = -42.5;

  gap::CandidateScore mount;
  mount.effect = gap::CandidateEffect::mount_resonance;
  mount.parameters = {{"frequency_hz", 2450.0}, {"quality_factor", 9.5}};
  mount.explains = {FamilyKind::fixed_frequency};
  mount.held_out_after = r.before;
  mount.held_out_after[5] = family_gap(FamilyKind::fixed_frequency, 3.0, 2.0, 4.0, 0.3, true);
  mount.held_out_after[2] = family_gap(FamilyKind::mesh_harmonics, 3.5, 2.75, 4.25, 0.25, true);
  mount.shrinkage = 0.7623762376237624;
  mount.information_criterion = -30.125;
  mount.worsens_other_family = true;
  mount.at_bounds = {{"frequency_hz", 2450.0, true}};  // fitted at the top of its range

  gap::CandidateScore floor;
  floor.effect = gap::CandidateEffect::noise_floor;
  floor.parameters = {{"level_m_s2_per_sqrt_hz", 1.5e-4}};
  floor.explains = {FamilyKind::broadband};
  floor.held_out_after = r.before;
  floor.shrinkage = 0.0625;
  floor.information_criterion = 2.5;

  r.candidates = {casing, mount, floor};
  r.chosen = {gap::CandidateEffect::casing_mode};
  r.unexplained = {FamilyKind::output_sidebands};
  r.k_wear_before = 4.25e-17;
  r.k_wear_after = 3.0e-17;

  // The order axis in input orders (mesh at order 22), the Hz axis at 10 Hz input speed.
  const Spectra orders = spectra(0.75, 400, 22.0, 240.0);
  r.order_axis = orders.axis;
  r.measured_order_db = orders.measured;
  r.twin_order_db = orders.twin;
  r.twin_after_order_db = orders.after;
  const Spectra hz = spectra(7.5, 400, 220.0, 2400.0);
  r.hz_axis = hz.axis;
  r.measured_hz_db = hz.measured;
  r.twin_hz_db = hz.twin;
  r.twin_after_hz_db = hz.after;
  r.order_bands = {{FamilyKind::mesh_harmonics, {21.5, 22.5}}, {FamilyKind::input_sidebands, {20.5, 21.5}},
                   {FamilyKind::fixed_frequency, {228.0, 252.0}}};
  r.hz_bands = {{FamilyKind::mesh_harmonics, {215.0, 225.0}}, {FamilyKind::fixed_frequency, {2280.0, 2520.0}},
                {FamilyKind::broadband, {500.0, 900.0}}};
  // Features: a band fixed in Hz at the casing's 2400 Hz, seen in two records, and a line at a
  // non-integer output order seen in one.
  gap::GapFeature band;
  band.movement = gap::FeatureMovement::fixed_in_hz;
  band.order = 240.0 + 1.0 / 3.0;
  band.order_low = 238.5;
  band.order_high = 242.5;
  band.hz = 2403.125;
  band.hz_low = 2385.0;
  band.hz_high = 2425.0;
  band.size_db = 11.75;
  band.size_interval_db = {11.5, 12.0};
  band.p_value = 1.25e-12;
  band.seen_in = {{true, 0, 10.0, 20.0, 240.3125, 2403.125, 11.5}, {false, 1, 8.0, 5.0, 300.375, 2403.0, 12.0}};
  gap::GapFeature ghost;
  ghost.movement = gap::FeatureMovement::undetermined;
  ghost.shaft = gap::FeatureShaft::output;
  ghost.order = 2.5;
  ghost.order_low = 2.0;
  ghost.order_high = 3.0;
  ghost.hz = 9.125;
  ghost.hz_low = 7.3;
  ghost.hz_high = 10.95;
  ghost.size_db = -4.5;
  ghost.size_interval_db = {-5.0, -4.0};
  ghost.p_value = 3e-7;
  ghost.seen_in = {{true, 1, 10.0, std::numeric_limits<double>::quiet_NaN(), 0.9125, 9.125, -4.5}};
  // Descriptions: the band a resonance explained by the chosen casing mode, the line a 15 % AM at the
  // gear shaft's order no candidate explains.
  band.description = {gap::DescriptionKind::resonance, gap::FeatureShaft::input,
                      {{"frequency_hz", 2403.5}, {"damping_ratio", 0.0125}, {"gain_db", 11.75}}, 4.25, 0.1875};
  band.explained_by = gap::CandidateEffect::casing_mode;
  ghost.description = {gap::DescriptionKind::modulation, gap::FeatureShaft::output,
                       {{"am_index", 0.15}, {"pm_index_rad", std::numeric_limits<double>::quiet_NaN()}}, 3.5, 0.25};
  r.features = {band, ghost};
  return r;
}

}  // namespace gearwatch::testing
