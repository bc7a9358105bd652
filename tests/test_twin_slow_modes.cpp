// The slow modes the default record's tiling carries on (SlowModes, docs/twin.md "Tiling"):
// (1) on the linear model a state in one slow mode evolves as 2 Re(right·c·e^{λt}): an independent
// integration (dopri5 at relative 1e-10) against the closed form; (2) on the full model the state
// carried from early in the transient (the boundary one period after an anchor, moved on by the
// slow modes' free decay with the amplitudes that period gives, read at the mesh phase the pinion's
// slow turn gives) equals the full integration's
// state long after, in the energy norm, within the periodicity check's tolerance: the state
// difference's energy Δqᵀ K Δq + Δvᵀ M Δv within (1e-3)² of the vibration's (its mean vᵀMv over the
// last period); without carrying it the same difference is outside.
#include <cmath>
#include <complex>
#include <memory>
#include <numbers>

#include <catch2/catch.hpp>

#include "gearwatch/twin/gearbox_model.hpp"
#include "gearwatch/twin/integration.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "gearwatch/twin/slow_modes.hpp"

namespace test_twin_slow_modes {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::twin;

namespace {

double energy(const GearboxMatrices& m, const State& a, const State& b) {
  Vector21 dq, dv;
  for (int i = 0; i < kDofCount; ++i) {
    dq[i] = b[static_cast<std::size_t>(i)] - a[static_cast<std::size_t>(i)];
    dv[i] = b[static_cast<std::size_t>(kDofCount + i)] - a[static_cast<std::size_t>(kDofCount + i)];
  }
  return dq.dot(m.linearised_stiffness() * dq) + dv.dot(m.mass.cwiseProduct(dv));
}

}  // namespace

TEST_CASE("A slow mode of the linear model decays as its eigenvalue says", "[twin][twin-periodic]") {
  const GearboxParameters p;
  const GearGeometry g = GearGeometry::from_spec(p.gears);
  auto mesh = std::make_shared<const GearMeshStiffness>(g);
  const GearboxMatrices m = assemble(p, *mesh);
  const GearboxDynamics dyn(m, mesh, nullptr, 0.0, 0.0, MeshModel::constant_mean);
  const SlowModes slow(m, 190.0);  // the mesh frequency at 10 Hz input
  REQUIRE(slow.size() >= 1);
  for (std::size_t j = 0; j < slow.size(); ++j) {
    INFO("slow mode " << j << ", " << slow.eigenvalue(j).imag() / (2 * std::numbers::pi) << " Hz");
    // The mode alone: c = 1e-4 · e^{iπ/3} from a zero state, by advance() from t = −∞ (e^{λ·−∞} = 0)
    // written as the state 2 Re(right·c): the projection of that state must give c back.
    SlowModes::Amplitudes c(slow.size());
    c[j] = std::polar(1e-4, std::numbers::pi / 3);
    State x0{};
    slow.advance(x0, c, 1e3, 0.0);  // e^{λ·1000 s} underflows to 0 for any damped mode
    const SlowModes::Amplitudes back = slow.project(x0);
    CHECK(std::abs(back[j] - c[j]) <= 1e-9 * std::abs(c[j]));
    State x = x0;
    SimulationOptions o;
    o.relative_tolerance = 1e-10;
    o.absolute_tolerance = 1e-18;
    const double rate = 1000.0;
    double worst = 0, scale = 0;
    integrate_sampled(dyn, x, 0.0, rate, 501, o, [&](const State& s, double t) {
      State expected = x0;
      slow.advance(expected, c, 0.0, t);
      worst = std::max(worst, energy(m, s, expected));
      scale = std::max(scale, energy(m, State{}, expected));
    });
    // 0.5 s of free decay: the integration and the closed form within 1e-6 in amplitude.
    CHECK(std::sqrt(worst / scale) < 1e-6);
  }
}

TEST_CASE("The sample grid's phasors equal std::exp at every sample index and past the record", "[twin][twin-periodic]") {
  // A direct reference: e^{λ·i/rate} by std::exp, at a 400 kHz rate over a 2 s record and past its
  // end (where at() computes it itself).
  const GearboxParameters p;
  const GearGeometry g = GearGeometry::from_spec(p.gears);
  auto mesh = std::make_shared<const GearMeshStiffness>(g);
  const GearboxMatrices m = assemble(p, *mesh);
  const SlowModes slow(m, 400.0);
  REQUIRE(slow.size() >= 1);
  const double rate = 4e5;
  const std::size_t count = 800'000;
  const SampleGridPhasors grid(slow, rate, count);
  double worst = 0;
  for (std::size_t j = 0; j < slow.size(); ++j)
    for (std::size_t i = 0; i < count + 5000; i += 997) {
      const auto expected = std::exp(slow.eigenvalue(j) * (static_cast<double>(i) / rate));
      worst = std::max(worst, std::abs(grid.at(j, i) - expected) / std::abs(expected));
    }
  CHECK(worst < 1e-12);
  // add_state() and state_coordinate() make the state advance() and coordinate() make.
  const SlowModes::Amplitudes c(slow.size(), std::polar(1e-4, 0.7));
  SlowModes::Amplitudes z(slow.size());
  for (std::size_t j = 0; j < slow.size(); ++j) z[j] = c[j] * std::exp(slow.eigenvalue(j) * 1.234567);
  State x{}, y{};
  slow.advance(x, c, 1e3, 1.234567);
  slow.add_state(y, z);
  for (std::size_t i = 0; i < x.size(); ++i) CHECK(y[i] == Approx(x[i]).epsilon(1e-12).margin(1e-30));
  for (int i : {int{theta5}, int{theta10}}) CHECK(slow.state_coordinate(z, i) == Approx(slow.coordinate(c, i, 1.234567)).epsilon(1e-12));
}

TEST_CASE("The state carried by the slow modes equals the full integration's long after", "[twin][twin-periodic]") {
  const GearboxParameters p;
  const OperatingPoint op{10.0, 20.0};
  const GearGeometry g = GearGeometry::from_spec(p.gears);
  MeshStiffnessOptions mo;
  mo.scale = p.mesh_stiffness_scale;
  mo.engagement_ramp_fraction = p.engagement_ramp_fraction;
  auto mesh = std::make_shared<const GearMeshStiffness>(g, mo);
  auto gte = std::make_shared<const GeometricTransmissionError>(g, ToothProfileDeviation{});
  const GearboxMatrices m = assemble(p, *mesh);
  const GearboxDynamics dyn(m, mesh, gte, op.input_speed_hz, op.input_torque_nm);
  const double period = periodic_inputs_period_s(p, {}, op, SimulationOptions{});
  const SlowModes slow(m, op.input_speed_hz * p.gears.pinion_teeth);
  REQUIRE(!slow.empty());
  // Boundaries k·T from the static equilibrium: the anchor at 20 T (0.105 s), the state one
  // period later, and 300 T (1.58 s), past where the transient had died out to the tolerance.
  const std::size_t anchor_k = 20, late_k = 300, per = 64;
  State x = dyn.static_equilibrium();
  State anchor{}, next{}, late{};
  double kinetic = 0;
  std::size_t i = 0;
  integrate_sampled(dyn, x, 0.0, per / period, late_k * per + 1, SimulationOptions::reference(), [&](const State& s, double) {
    if (i == anchor_k * per) anchor = s;
    if (i == (anchor_k + 1) * per) next = s;
    if (i == late_k * per) late = s;
    if (i > (late_k - 1) * per)
      for (int d = 0; d < kDofCount; ++d)
        kinetic += m.mass[d] * s[static_cast<std::size_t>(kDofCount + d)] * s[static_cast<std::size_t>(kDofCount + d)];
    ++i;
  });
  kinetic /= static_cast<double>(per);
  const SlowModes::Amplitudes c = slow.amplitudes(anchor, next, period);
  // Carried from one period after the anchor to 300 T: the slow modes' decay added, and the state
  // read where its mesh phase is the late one's (the pinion's slow turn Δq5 over Ω, to first order).
  const double from = period, to = static_cast<double>(late_k - anchor_k) * period;
  State carried = next;
  const double shift = (slow.coordinate(c, theta5, to) - slow.coordinate(c, theta5, from)) / (2.0 * std::numbers::pi * op.input_speed_hz);
  State rate;
  dyn(next, rate, static_cast<double>(anchor_k + 1) * period);
  for (std::size_t d = 0; d < carried.size(); ++d) carried[d] += rate[d] * shift;
  slow.advance(carried, c, from, to);
  const double tolerance = 1e-3;  // SimulationOptions::periodic_tolerance
  INFO("carried " << std::sqrt(energy(m, carried, late) / kinetic) << ", not carried " << std::sqrt(energy(m, next, late) / kinetic));
  CHECK(energy(m, carried, late) <= tolerance * tolerance * kinetic);
  CHECK(energy(m, next, late) > tolerance * tolerance * kinetic);  // the transient is there to carry: the check rejects it
}

}  // namespace test_twin_slow_modes
