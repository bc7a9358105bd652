#include "gearwatch/wear/load_sharing.hpp"

#include <algorithm>
#include <cmath>

#include "gearwatch/twin/errors.hpp"

namespace gearwatch::wear {

double share_load(double total_force_n, const double* stiffness, const double* gap_error, int count, double* forces) {
  bool active[3] = {true, true, true};
  if (count < 1 || count > 3) throw twin::TwinParameterError("load sharing: 1 to 3 pairs");
  double deflection = 0;
  // Drop pairs that would be in tension until every remaining pair is compressed (at most 3 rounds).
  for (int round = 0; round <= count; ++round) {
    double k_sum = 0, ke_sum = 0;
    for (int i = 0; i < count; ++i)
      if (active[i]) {
        k_sum += stiffness[i];
        ke_sum += stiffness[i] * gap_error[i];
      }
    if (k_sum <= 0) break;
    deflection = (total_force_n - ke_sum) / k_sum;
    bool changed = false;
    for (int i = 0; i < count; ++i)
      if (active[i] && deflection + gap_error[i] <= 0) {
        active[i] = false;
        changed = true;
      }
    if (!changed) {
      for (int i = 0; i < count; ++i) forces[i] = active[i] ? stiffness[i] * (deflection + gap_error[i]) : 0.0;
      return deflection;
    }
  }
  // Degenerate (no stiffness left): the pair that touches first carries everything.
  int first = 0;
  for (int i = 1; i < count; ++i)
    if (gap_error[i] > gap_error[first]) first = i;
  for (int i = 0; i < count; ++i) forces[i] = i == first ? total_force_n : 0.0;
  return -gap_error[first];
}

PassLoad quasi_static_pass_load(const twin::GearMeshStiffness& mesh, const twin::GeometricTransmissionError& gte,
                                double input_torque_nm, int points) {
  if (!std::isfinite(input_torque_nm) || input_torque_nm < 0)
    throw twin::TwinParameterError("input torque must be finite and non-negative");
  if (points < 2) throw twin::TwinParameterError("pass load needs at least 2 points");
  const twin::GearGeometry& g = mesh.geometry();
  const double force = input_torque_nm / g.base_radius_pinion;
  PassLoad pass;
  pass.position_m.resize(static_cast<std::size_t>(points));
  pass.force_n.resize(static_cast<std::size_t>(points));
  for (int j = 0; j < points; ++j) {
    const double s = g.contact_start + g.active_length() * j / (points - 1);
    // The tracked pair and its neighbours one and two base pitches ahead/behind, if on the line.
    double pos[3], k[3], e[3], f[3];
    int n = 0, tracked = 0;
    for (int m = -2; m <= 2 && n < 3; ++m) {
      const double sm = s + m * g.base_pitch;
      if (sm < g.contact_start - 1e-12 || sm > g.contact_end + 1e-12) continue;
      if (m == 0) tracked = n;
      pos[n] = std::clamp(sm, g.contact_start, g.contact_end);
      k[n] = mesh.pair_stiffness(pos[n]);
      e[n] = gte.pair_error(pos[n], 0, 0);
      ++n;
    }
    share_load(force, k, e, n, f);
    pass.position_m[static_cast<std::size_t>(j)] = s;
    pass.force_n[static_cast<std::size_t>(j)] = f[tracked];
  }
  return pass;
}

PassLoad dynamic_pass_load(const twin::GearboxParameters& p, const twin::ToothProfileDeviation& deviation,
                           const twin::OperatingPoint& op, const twin::SimulationOptions& options) {
  // Long enough for the tracked pair (it enters in the first full mesh cycle) to leave the line.
  const twin::GearGeometry g = twin::GearGeometry::from_spec(p.gears);
  const double mesh_period = 1.0 / (op.input_speed_hz * p.gears.pinion_teeth);
  const double duration = (g.contact_ratio + 3.0) * mesh_period;
  const twin::SimulationResult r = twin::simulate(p, deviation, op, duration, options);
  const auto& prof = r.contact_profile;
  PassLoad pass;
  for (std::size_t i = 0; i < prof.position_m.size(); ++i) {
    if (!pass.position_m.empty() && !(prof.position_m[i] > pass.position_m.back())) continue;
    pass.position_m.push_back(prof.position_m[i]);
    pass.force_n.push_back(prof.force_n[i]);
  }
  if (pass.position_m.size() < 2)
    throw twin::TwinParameterError("the dynamic simulation returned no tooth-pair pass (sample rate too low?)");
  return pass;
}

}  // namespace gearwatch::wear
