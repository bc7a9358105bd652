// The 21-DOF model: assembly, modal analysis, integration checks, bad input (thesis Eqs. 5.1–5.7).
#include "gearwatch/twin/gearbox_model.hpp"

#include <cmath>
#include <complex>
#include <cstdint>
#include <numbers>

#include <catch2/catch.hpp>

#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/modal_analysis.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "gearwatch/twin/integration.hpp"

namespace test_gearbox_model {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::twin;

TEST_CASE("2-DOF modal analysis matches the closed form", "[twin]") {
  // m1 = 1 on k1 = 100 to ground, m2 = 2 coupled by k2 = 50:
  // det(K − ω²M) = 2ω⁴ − 350ω² + 5000 = 0.
  Eigen::VectorXd m(2);
  m << 1, 2;
  Eigen::MatrixXd k(2, 2);
  k << 150, -50, -50, 50;
  Eigen::VectorXd f;
  Eigen::MatrixXd shapes;
  solve_modes(m, k, f, shapes);
  const double d = std::sqrt(350.0 * 350.0 - 4 * 2 * 5000.0);
  const double w1 = std::sqrt((350.0 - d) / 4.0), w2 = std::sqrt((350.0 + d) / 4.0);
  CHECK(f[0] == Approx(w1 / (2 * std::numbers::pi)).epsilon(1e-12));
  CHECK(f[1] == Approx(w2 / (2 * std::numbers::pi)).epsilon(1e-12));
  CHECK(shapes.col(0).dot(m.cwiseProduct(shapes.col(0))) == Approx(1.0).epsilon(1e-12));  // mass-normalised
}

TEST_CASE("1-DOF torsional reduction of the mesh matches its analytic frequency", "[twin]") {
  // Shafts and couplings almost free, bearings and shafts almost rigid: the mesh mode tends to
  // ω² = k̄ (r_b1²/I5 + r_b2²/I10). Residual coupling: 1e-6/1e2 torsional and 3.6e8/1e14 translational,
  // so 1e-4 relative is ample.
  GearboxParameters p;
  for (double GearboxParameters::*f : {&GearboxParameters::kt12, &GearboxParameters::kt23, &GearboxParameters::kt35,
                                       &GearboxParameters::kt57, &GearboxParameters::kt810, &GearboxParameters::kt10_12,
                                       &GearboxParameters::kt12_13})
    p.*f = 1e-6;
  for (const auto& info : parameter_table()) {
    const std::string n = info.name;
    if ((n[0] == 'k' && (n[1] == 'x' || n[1] == 'y'))) p.*(info.field) = 1e14;
  }
  const GearboxMatrices m = assemble(p);
  const GearGeometry g = GearGeometry::from_spec(p.gears);
  const double omega2 = m.mean_mesh_stiffness * (std::pow(g.base_radius_pinion, 2) / p.I5 + std::pow(g.base_radius_gear, 2) / p.I10);
  const auto modes = modal_analysis(p, m);
  const Mode* mesh_mode = nullptr;
  for (const auto& mode : modes)
    if (mode.dominant_element == "mesh" && mode.dominant_share > 0.99) mesh_mode = &mode;
  REQUIRE(mesh_mode != nullptr);
  CHECK(mesh_mode->frequency_hz == Approx(std::sqrt(omega2) / (2 * std::numbers::pi)).epsilon(1e-4));
}

TEST_CASE("Mesh mode of free gear bodies: k̄ over the reduced mass of rotation and translation", "[twin]") {
  // Every structural spring almost zero (1e-6 in N/m and N·m/rad): the pinion and the gear are free
  // rigid bodies joined only by the mesh spring k̄ along the line of action. The mesh compression
  // δ = r_b1 θ5 − r_b2 θ10 + (cos α)(y10 − y5) + (sin α)(x5 − x10), and each body's acceleration
  // per unit mesh force along its coordinates adds up to δ̈ = −F (r_b1²/I5 + r_b2²/I10 + (cos²α +
  // sin²α)(1/m5 + 1/m10)), so the one elastic mode has ω² = k̄ / m_eq with
  //   1/m_eq = r_b1²/I5 + r_b2²/I10 + 1/m5 + 1/m10.
  // This checks the translational part of the mesh direction g, which the torsional reduction
  // above does not see. The 1e-6 springs perturb ω² by ~1e-14 relative; the eigen-solver's double
  // precision error on the largest eigenvalue is ~1e-15 relative, so 1e-9 is ample.
  GearboxParameters p;
  for (const auto& info : parameter_table()) {
    const std::string n = info.name;
    if (n[0] == 'k') p.*(info.field) = 1e-6;
  }
  const GearboxMatrices m = assemble(p);
  const GearGeometry g = GearGeometry::from_spec(p.gears);
  const double inverse_reduced_mass = std::pow(g.base_radius_pinion, 2) / p.I5 + std::pow(g.base_radius_gear, 2) / p.I10 +
                                      1.0 / p.m5 + 1.0 / p.m10;
  const double expected_hz = std::sqrt(m.mean_mesh_stiffness * inverse_reduced_mass) / (2 * std::numbers::pi);
  const auto modes = modal_analysis(p, m);
  CHECK(modes.back().frequency_hz == Approx(expected_hz).epsilon(1e-9));
  CHECK(modes.back().dominant_element == "mesh");
  // Every other mode is a rigid-body motion up to the 1e-6 springs (sqrt(1e-6/I5) = 0.016 Hz) and
  // round-off (~1e-15 of the largest eigenvalue): far below 1 Hz.
  for (std::size_t i = 0; i + 1 < modes.size(); ++i) CHECK(modes[i].frequency_hz < 1.0);
}

TEST_CASE("Modal analysis of the calibrated model: one rigid-body mode, energies sum to one", "[twin]") {
  const GearboxParameters p;
  const auto modes = modal_analysis(p);
  REQUIRE(modes.size() == 21);
  CHECK(modes[0].frequency_hz < 1e-3);
  CHECK(modes[1].frequency_hz > 1.0);
  for (std::size_t i = 1; i < modes.size(); ++i) {
    double sum = 0;
    for (const auto& [name, share] : modes[i].strain_energy) sum += share;
    CHECK(sum == Approx(1.0).epsilon(1e-9));
    // Rayleigh quotient: modal strain energy = ½ω² for a mass-normalised shape.
    const GearboxMatrices m = assemble(p);
    const Eigen::VectorXd phi = modes[i].shape;
    const double omega = 2 * std::numbers::pi * modes[i].frequency_hz;
    CHECK(0.5 * phi.dot(m.linearised_stiffness() * phi) == Approx(0.5 * omega * omega).epsilon(1e-8));
  }
}

TEST_CASE("Integrator conserves energy of the undamped linear model", "[twin]") {
  GearboxParameters p;
  p.structural_damping_ratio = 0;
  p.mesh_damping_ratio = 0;
  const GearGeometry g = GearGeometry::from_spec(p.gears);
  auto mesh = std::make_shared<const GearMeshStiffness>(g);
  const GearboxMatrices m = assemble(p, *mesh);
  const GearboxDynamics dyn(m, mesh, nullptr, 0.0, 0.0, MeshModel::constant_mean);
  State x{};
  x[theta5] = 1e-5;
  x[y5] = 1e-7;
  x[kDofCount + theta1] = 0.1;
  x[kDofCount + x10] = 1e-3;
  const double e0 = dyn.linear_energy(x);
  SimulationOptions o;
  o.relative_tolerance = 1e-10;
  o.absolute_tolerance = 1e-16;
  double worst = 0;
  integrate_sampled(dyn, x, 0.0, 20000.0, 2001, o, [&](const State& s, double) {
    worst = std::max(worst, std::abs(dyn.linear_energy(s) - e0) / e0);
  });
  // dopri5 is not symplectic; at rel. tolerance 1e-10 over 0.1 s (≈ 900 periods of the mesh mode)
  // the drift stays below 1e-6.
  CHECK(worst < 1e-6);
}

TEST_CASE("Forced response at resonance matches the direct complex FRF", "[twin]") {
  const GearboxParameters p;
  const GearGeometry g = GearGeometry::from_spec(p.gears);
  auto mesh = std::make_shared<const GearMeshStiffness>(g);
  const GearboxMatrices m = assemble(p, *mesh);
  GearboxDynamics dyn(m, mesh, nullptr, 0.0, 0.0, MeshModel::constant_mean);
  const auto modes = modal_analysis(p, m);
  const double f = modes[4].frequency_hz;  // the 430 Hz pedestal mode
  HarmonicLoad load;
  load.amplitude[y6] = 10.0;  // N
  load.frequency_hz = f;
  dyn.set_harmonic_load(load);
  // Reference: X = (K − ω²M + iωC)⁻¹ F with C = C_struct + μ k̄ g gᵀ, solved directly.
  const double w = 2 * std::numbers::pi * f;
  Eigen::Matrix<std::complex<double>, 21, 21> a;
  const Matrix21 c = m.damping + m.mesh_damping_time_constant * m.mean_mesh_stiffness * m.mesh * m.mesh.transpose();
  const Matrix21 k = m.linearised_stiffness();
  for (int i = 0; i < 21; ++i)
    for (int j = 0; j < 21; ++j)
      a(i, j) = std::complex<double>(k(i, j) - (i == j ? w * w * m.mass[i] : 0.0), w * c(i, j));
  Eigen::Matrix<std::complex<double>, 21, 1> rhs = Eigen::Matrix<std::complex<double>, 21, 1>::Zero();
  rhs[y6] = 10.0;
  // The free-free chain is singular at ω = 0 only; at 430 Hz the complex system is regular.
  const Eigen::Matrix<std::complex<double>, 21, 1> x_ref = a.partialPivLu().solve(rhs);
  // Simulate 0.3 s (ζ = 0.05: the transient decays as e^{-ζωt} = e^{-40}) and project the last
  // 40 periods on sin/cos at 64 samples per period.
  State x{};
  SimulationOptions o;
  o.relative_tolerance = 1e-9;
  o.absolute_tolerance = 1e-16;
  const double rate = 64 * f;
  const std::size_t total = static_cast<std::size_t>(0.3 * rate);
  const std::size_t first = total - 40 * 64;
  double ss = 0, sc = 0;
  std::size_t i = 0;
  integrate_sampled(dyn, x, 0.0, rate, total, o, [&](const State& s, double t) {
    if (i++ >= first) {
      ss += s[y6] * std::sin(w * t);
      sc += s[y6] * std::cos(w * t);
    }
  });
  const double amplitude = 2.0 * std::hypot(ss, sc) / (40 * 64);
  // Exact projection over whole periods; integrator error ~1e-8: 1e-4 relative is ample.
  CHECK(amplitude == Approx(std::abs(x_ref[y6])).epsilon(1e-4));
}

TEST_CASE("Non-physical parameters are rejected with the parameter's name", "[twin]") {
  GearboxParameters p;
  p.kt23 = -5;
  CHECK_THROWS_WITH(assemble(p), Catch::Contains("kt23"));
  p = GearboxParameters{};
  p.m5 = 0;
  CHECK_THROWS_AS(assemble(p), TwinParameterError);
  p = GearboxParameters{};
  p.I13 = std::nan("");
  CHECK_THROWS_AS(assemble(p), TwinParameterError);
  Eigen::VectorXd m(2);
  m << 1, 0;
  Eigen::VectorXd f;
  Eigen::MatrixXd s;
  CHECK_THROWS_AS(solve_modes(m, Eigen::MatrixXd::Identity(2, 2), f, s), TwinParameterError);
}

TEST_CASE("A divergent integration is stopped with a clear error", "[twin]") {
  const GearboxParameters p;
  const GearGeometry g = GearGeometry::from_spec(p.gears);
  auto mesh = std::make_shared<const GearMeshStiffness>(g);
  GearboxMatrices m = assemble(p, *mesh);
  m.damping *= -40.0;  // negative damping: every mode grows exponentially
  const GearboxDynamics dyn(m, mesh, nullptr, 0.0, 0.0, MeshModel::constant_mean);
  State x{};
  x[y5] = 1e-8;
  std::size_t samples = 0;
  CHECK_THROWS_AS(integrate_sampled(dyn, x, 0.0, 10000.0, 100000, SimulationOptions{},
                                    [&](const State&, double) { ++samples; }),
                  TwinDivergenceError);
  CHECK(samples < 100000);  // stopped early, nothing written past the divergence
  State bad{};
  bad[3] = std::nan("");
  CHECK_THROWS_AS(integrate_sampled(dyn, bad, 0.0, 1000.0, 10, SimulationOptions{}, [](const State&, double) {}),
                  TwinDivergenceError);
}

TEST_CASE("Face misalignment: the mesh force of a Winkler face whose flanks separate across it", "[twin]") {
  // Flanks separating linearly by w across the face, each face element a spring k/b: a pair
  // compressed by c touches over the width where c − w ξ > 0 (ξ the face position / b), so
  //   c < w:  F = ∫₀^{c/w} k (c − w ξ) dξ = k c² / (2w)      (part of the face loaded)
  //   c ≥ w:  F = ∫₀^1 k (c − w ξ) dξ = k (c − w/2)           (the whole face)
  // with k the pair's stiffness: summed over the pairs in contact, K = Σ k_i. At rest (zero
  // velocities) no damping acts, so the mesh force is exactly these.
  const GearboxParameters p;
  const GearGeometry geometry = GearGeometry::from_spec(p.gears);
  auto mesh = std::make_shared<const GearMeshStiffness>(geometry, MeshStiffnessOptions{});
  const GearboxMatrices m = assemble(p, *mesh);
  GearboxDynamics dynamics(m, mesh, nullptr, 10.0, 5.0);
  const double w = 4e-6;  // 0.2 mrad over the 20 mm face
  dynamics.set_face_misalignment(w);
  // A state whose mesh deflection δ = gᵀq is c: q along g.
  auto state_with_deflection = [&](double c) {
    State x{};
    const double gg = m.mesh.dot(m.mesh);
    for (int i = 0; i < kDofCount; ++i) x[static_cast<std::size_t>(i)] = c * m.mesh[i] / gg;
    return x;
  };
  for (double t : {0.0, 0.0013, 0.0031}) {  // single and double contact along the mesh cycle
    for (double c : {0.5e-6, 2e-6, 3.9e-6, 4.1e-6, 8e-6}) {
      const auto ms = dynamics.mesh_state(state_with_deflection(c), t);
      REQUIRE(ms.deflection == Approx(c).epsilon(1e-12));
      const double expected = c < w ? ms.stiffness * c * c / (2 * w) : ms.stiffness * (c - w / 2);
      CHECK(ms.force == Approx(expected).epsilon(1e-12));
    }
  }
  // Aligned (the thesis's twin): F = K c; and the addition refuses a negative or non-finite width.
  dynamics.set_face_misalignment(0.0);
  const auto aligned = dynamics.mesh_state(state_with_deflection(2e-6), 0.0);
  CHECK(aligned.force == Approx(aligned.stiffness * 2e-6).epsilon(1e-12));
  CHECK_THROWS_AS(dynamics.set_face_misalignment(-1e-6), TwinParameterError);
  CHECK_THROWS_AS(dynamics.set_face_misalignment(std::nan("")), TwinParameterError);
  SimulationOptions bad;
  bad.face_misalignment_rad = -1e-4;
  CHECK_THROWS_AS(simulate(p, ToothProfileDeviation{}, {10.0, 5.0}, 0.01, bad), TwinParameterError);
}

TEST_CASE("twin: below the couplings' modes a transmission error turns the train instead of loading the mesh", "[twin]") {
  // A slow error e at the mesh: the mesh force stays nearly 0, so r_b1 q5 − r_b2 q10 ≈ −e, and each
  // side of the train, rigid at 0.5 Hz, is accelerated by the same force: −ω² J_in q_in = −r_b1 F,
  // −ω² J_out q_out = r_b2 F. Hence q_in = −e (r_b1/J_in) / (r_b1²/J_in + r_b2²/J_out), and
  // q_out = e (r_b2/J_out) / (the same).
  const GearboxParameters p;
  const auto m = assemble(p);
  const double r1 = m.mesh[theta5], r2 = -m.mesh[theta10];
  const double j_in = p.I1 + p.I2 + p.I3 + p.I5 + p.I7, j_out = p.I8 + p.I10 + p.I12 + p.I13;
  const double sum = r1 * r1 / j_in + r2 * r2 / j_out;
  const auto q = transmission_error_response(m, 0.5);
  CHECK(q[theta5].real() == Approx(-(r1 / j_in) / sum).epsilon(0.01));
  CHECK(q[theta10].real() == Approx((r2 / j_out) / sum).epsilon(0.01));
  CHECK(std::abs(q[theta1] - q[theta5]) < 0.01 * std::abs(q[theta5]));  // the input side turns as one
  CHECK(std::abs(m.mesh.cast<std::complex<double>>().dot(q) + 1.0) < 0.01);  // the mesh hardly deflects
  CHECK_THROWS_AS(transmission_error_response(m, 0.0), TwinParameterError);
  CHECK_THROWS_AS(transmission_error_response(m, std::nan("")), TwinParameterError);
}

TEST_CASE("One DOF's acceleration equals that row of the full right-hand side and the dense M^-1 (F - g f - C v - K q)", "[twin]") {
  // The sensor front-end reads ÿ6 alone eight times per sample: it must be operator()'s row, with
  // the time-varying mesh, a worn profile and a harmonic load, at states scattered about the static
  // equilibrium (±1 µm, ±0.5 mm/s). And the sparse rows operator() sums must be the dense K and C.
  const GearboxParameters p;
  const GearGeometry g = GearGeometry::from_spec(p.gears);
  auto mesh = std::make_shared<const GearMeshStiffness>(g);
  const GearboxMatrices m = assemble(p, *mesh);
  ToothProfileDeviation wear;
  for (int i = 0; i <= 10; ++i) wear.pinion.push_back(3e-6 * std::abs(i - 5) / 5.0);
  auto gte = std::make_shared<const GeometricTransmissionError>(g, wear);
  GearboxDynamics dyn(m, mesh, gte, 10.0, 20.0);
  HarmonicLoad load;
  for (int d = 0; d < kDofCount; ++d) load.amplitude[d] = 0.5 + d;
  load.frequency_hz = 37.0;
  dyn.set_harmonic_load(load);
  Vector21 external = Vector21::Zero();
  external[theta1] = 20.0;
  external[theta13] = -dyn.brake_torque_nm();
  State x = dyn.static_equilibrium();
  std::uint64_t state = 99;
  auto uniform = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0 - 0.5;
  };
  double worst_row = 0, worst_dense = 0;
  for (int trial = 0; trial < 20; ++trial) {
    State y = x;
    for (int i = 0; i < kDofCount; ++i) {
      y[static_cast<std::size_t>(i)] += 2e-6 * uniform();
      y[static_cast<std::size_t>(kDofCount + i)] += 1e-3 * uniform();
    }
    const double t = 0.013 * trial + 1e-4 * uniform();
    State dy{};
    dyn(y, dy, t);
    const Eigen::Map<const Vector21> q(y.data()), v(y.data() + kDofCount);
    const double f = dyn.mesh_state(y, t).force;
    const Vector21 harmonic = load.amplitude * std::sin(2.0 * std::numbers::pi * load.frequency_hz * t);
    const Vector21 terms = external - m.mesh * f - m.damping * v - m.stiffness * q + harmonic;
    // The scale the rounding acts on: each row's largest term.
    const Vector21 scale = external.cwiseAbs() + (m.mesh * f).cwiseAbs() + (m.damping.cwiseAbs() * v.cwiseAbs()) +
                           (m.stiffness.cwiseAbs() * q.cwiseAbs()) + harmonic.cwiseAbs();
    for (int d = 0; d < kDofCount; ++d) {
      const double full = dy[static_cast<std::size_t>(kDofCount + d)];
      worst_row = std::max(worst_row, std::abs(dyn.acceleration(y, t, d) - full));
      worst_dense = std::max(worst_dense, std::abs(full - terms[d] / m.mass[d]) / (scale[d] / m.mass[d]));
    }
  }
  INFO("largest difference of a row " << worst_row << ", largest relative difference to the dense product " << worst_dense);
  CHECK(worst_row == 0.0);       // the same terms in the same order
  CHECK(worst_dense < 1e-14);    // the same terms, summed in another order
}

}  // namespace test_gearbox_model
