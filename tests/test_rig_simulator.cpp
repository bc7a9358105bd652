// The rig simulator (the "truth" gearbox): its integration against the twin's dopri5, and each
// truth effect's signature against a known answer (closed form, or an independent computation).
#include "gearwatch/rig/rig_simulator.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <numeric>

#include <catch2/catch.hpp>

#include "gearwatch/dsp/fft.hpp"
#include "gearwatch/twin/gear_geometry.hpp"
#include "gearwatch/twin/gearbox_model.hpp"
#include "gearwatch/twin/mesh_stiffness.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "gearwatch/dsp/decimation.hpp"
#include "gearwatch/gap/diagnosis.hpp"
#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/types/record.hpp"
#include "order_lines.hpp"

namespace test_rig_simulator {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using Catch::Matchers::Contains;

namespace {

constexpr double kPi = std::numbers::pi;

template <class V>
double relative_rms_error(const std::vector<double>& reference, const V& x) {
  double se = 0, sr = 0;
  for (std::size_t i = 0; i < reference.size(); ++i) {
    const double d = static_cast<double>(x[i]) - reference[i];
    se += d * d;
    sr += reference[i] * reference[i];
  }
  return std::sqrt(se / sr);
}

/// Amplitude of the component at f (Hz) over the whole record (rectangular window: exact when the
/// record holds a whole number of its periods).
template <class V>
double amplitude_at(const V& x, double fs, double f, bool hann = false) {
  std::complex<double> acc = 0;
  const std::complex<double> w = std::polar(1.0, -2.0 * kPi * f / fs);
  std::complex<double> rot = 1;
  const double n = static_cast<double>(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double window = hann ? 1.0 - std::cos(2.0 * kPi * static_cast<double>(i) / n) : 1.0;  // Hann, unit mean
    acc += window * static_cast<double>(x[i]) * rot;
    rot *= w;
    if (i % 1024 == 0) rot /= std::abs(rot);
  }
  return 2.0 * std::abs(acc) / n;
}

/// Welch estimates with a Hann window, 50 % overlap: one-sided PSD of x, and the cross-spectrum
/// S_xy and auto-spectrum S_xx for a transfer estimate H1 = S_xy / S_xx.
struct Welch {
  double df = 0;
  std::vector<double> psd;
  std::vector<std::complex<double>> h1;
};
Welch welch(const std::vector<double>& x, const std::vector<double>* y, double fs, std::size_t n) {
  dsp::RealFft fft(n);
  dsp::RealBuffer in(n);
  dsp::ComplexBuffer fx(n / 2 + 1), fy(n / 2 + 1);
  std::vector<double> win(n), sxx(n / 2 + 1, 0.0);
  std::vector<std::complex<double>> sxy(n / 2 + 1, 0.0);
  double wss = 0;
  for (std::size_t i = 0; i < n; ++i) wss += (win[i] = 0.5 - 0.5 * std::cos(2 * kPi * static_cast<double>(i) / n)) * win[i];
  int segments = 0;
  for (std::size_t start = 0; start + n <= x.size(); start += n / 2, ++segments) {
    double mean = 0;
    for (std::size_t i = 0; i < n; ++i) mean += x[start + i];
    mean /= static_cast<double>(n);
    for (std::size_t i = 0; i < n; ++i) in[i] = (x[start + i] - mean) * win[i];
    fft.forward(in, fx);
    if (y) {
      for (std::size_t i = 0; i < n; ++i) in[i] = (*y)[start + i] * win[i];
      fft.forward(in, fy);
    }
    for (std::size_t k = 0; k <= n / 2; ++k) {
      sxx[k] += std::norm(fx[k]);
      if (y) sxy[k] += std::conj(fx[k]) * fy[k];
    }
  }
  Welch w;
  w.df = fs / static_cast<double>(n);
  for (std::size_t k = 0; k <= n / 2; ++k) {
    w.psd.push_back(2.0 * sxx[k] / (segments * fs * wss));
    if (y) w.h1.push_back(sxy[k] / sxx[k]);
  }
  return w;
}

rig::RigRecord run(const rig::EffectSet& fx, rig::RigRunSettings s, const rig::WearState& wear = {},
                   const rig::SlidingVibration& sliding = {}) {
  return rig::simulate_record(twin::GearboxParameters{}, fx, wear, sliding, s);
}

}  // namespace

TEST_CASE("rig: without effects the fixed-step integration equals the twin's dopri5", "[rig]") {
  // The same 21-DOF equations, two integrators: core's adaptive dopri5 (rel 1e-6) and the rig's
  // classical Runge-Kutta with its steps split where a pair enters or leaves. Fourth order: the
  // error falls 16x per halving of the step.
  const twin::GearboxParameters p;
  twin::SimulationOptions o;
  o.sample_rate_hz = 100000;
  const auto ref = twin::simulate(p, {}, {10.0, 20.0}, 0.1, o);
  rig::RigRunSettings s;
  s.duration_s = 0.1;
  s.channels = 1;
  s.keep_diagnostics = true;
  s.front_end_oversampling = 1;  // the integrators compared at the twin's sample instants
  const auto r100 = run({}, s);
  REQUIRE(r100.acceleration[0].size() == ref.casing_acceleration.size());
  const double e100 = relative_rms_error(ref.casing_acceleration, r100.acceleration[0]);
  s.min_ode_rate_hz = 200000;
  const double e200 = relative_rms_error(ref.casing_acceleration, run({}, s).acceleration[0]);
  INFO("y6 relative RMS error: step 10 us " << e100 << ", 5 us " << e200);
  CHECK(e100 < 4e-3);   // measured 2.8e-3
  CHECK(e200 < 3e-4);   // measured 1.7e-4
  CHECK(e100 / e200 > 10);
  CHECK(relative_rms_error(ref.transmission_error_m, r100.mesh_deflection_m) < 5e-4);  // measured 2.2e-4
}

TEST_CASE("rig: where 10 us steps beat with the mesh at the gear's rate, the fine rate keeps the gear's sidebands at the twin's", "[rig]") {
  // Fixed steps meet each mesh cycle at phases that drift by frac(rate / f_mesh) of a step per
  // cycle, so the steps' error repeats at frac(rate / f_mesh)·f_mesh. At 15.479 Hz that is the
  // gear's rate for 10 µs steps and twice it for 5 µs steps (closed form), so the error sits on
  // the gear's first sidebands (orders n·z2 ± 1) or on its shaft orders (n·z2 ± 2).
  const GearPairSpec gears;
  const double speed = 15.479, torque = 20.0, fs = 100000.0, seconds = 2.0;
  const double f_mesh = speed * gears.pinion_teeth, f_gear = f_mesh / gears.gear_teeth;
  auto beat = [&](double rate) { return (rate / f_mesh - std::floor(rate / f_mesh)) * f_mesh; };
  CHECK(beat(100000.0) == Approx(f_gear).margin(0.01));          // 5.661 against 5.656 Hz
  CHECK(beat(rig::kFineOdeRateHz) == Approx(2 * f_gear).margin(0.02));

  // The rig without effects (perfect profile) against the twin, read as the gap diagnosis reads
  // them: each first-sideband line's log ratio with the diagnosis's floor (60 dB under the twin's
  // total line power) added to both, RMS over the family.
  rig::RigRunSettings s;
  s.speed_hz = speed;
  s.torque_nm = torque;
  s.duration_s = seconds;
  s.sample_rate_hz = fs;
  s.channels = 1;
  const auto coarse = run({}, s);
  s.min_ode_rate_hz = rig::kFineOdeRateHz;
  const auto fine = run({}, s);
  const auto twin_run = twin::simulate_casing_signal(twin::GearboxParameters{}, {}, {speed, torque}, seconds, fs);
  const auto twin = gap::RecordSpectra(single_channel_record(twin_run.acceleration, twin_run.tacho_edges, fs, speed, torque), 0,
                                       gears).summary();
  const double floor = gap::total_input_line_power(twin) * std::pow(10.0, gap::DiagnosisSettings{}.floor_db / 10.0);
  auto sideband_gap_db = [&](const rig::RigRecord& r) {
    const auto m = gap::RecordSpectra(single_channel_record(r.acceleration[0], r.tacho_edges, fs, speed, torque), 0, gears).summary();
    double sum = 0;
    int lines = 0;
    for (std::size_t o = 1; o <= std::min(m.output_lines.size(), twin.output_lines.size()); ++o) {
      if (gap::output_line_family(static_cast<int>(o), gears.gear_teeth) != gap::FamilyKind::output_sidebands) continue;
      const double g = 10.0 * std::log10((m.output_lines[o - 1] + floor) / (twin.output_lines[o - 1] + floor));
      sum += g * g;
      ++lines;
    }
    REQUIRE(lines > 200);
    return std::sqrt(sum / lines);
  };
  const double at_10us = sideband_gap_db(coarse), at_5us = sideband_gap_db(fine);
  INFO("gear's first sidebands, rig against twin: " << at_10us << " dB with 10 us steps, " << at_5us << " dB with 5 us");
  CHECK(at_10us > 1.5);   // measured 2.18 dB: lines 48 dB under the total near 5 kHz, the twin's 90 dB under
  CHECK(at_5us < 0.05);   // measured 0.000 dB: 24 dB lower, under the floor
}

TEST_CASE("rig: shaft eccentricity puts its run-out into the transmission error at exactly that shaft's order", "[rig]") {
  // With the soft couplings of the rig the drive train turns with the run-out (its inertia forces
  // at 10 Hz are tiny): the dynamic TE delta = F/k - e_shaft carries the run-out e at the pinion's
  // first order, in amplitude, and nothing at the next orders. Read over the whole
  // revolutions between the first and last encoder edge.
  const double fs = 5000.0;
  rig::EffectSet fx = rig::EffectSet::parse("eccentricity");
  fx.set("eccentricity.pinion_um", 10);
  fx.set("eccentricity.pinion_phase_rad", 0.7);
  fx.set("eccentricity.gear_um", 0);
  rig::RigRunSettings s;
  s.duration_s = 1.05;
  s.sample_rate_hz = fs;
  s.channels = 1;
  s.settle_s = 1.2;  // the run-out starts at t = 0: let the 22 Hz coupling mode's transient die out
  s.keep_diagnostics = true;
  const auto with = run(fx, s), without = run({}, s);
  auto order_amplitude = [fs](const std::vector<double>& x, const std::vector<double>& edges, double order) {
    const auto first = static_cast<std::size_t>(std::ceil(edges.front())), last = static_cast<std::size_t>(std::floor(edges.back()));
    const double revs = static_cast<double>(edges.size() - 1), span = (edges.back() - edges.front()) / fs;
    const std::vector<double> piece(x.begin() + static_cast<std::ptrdiff_t>(first), x.begin() + static_cast<std::ptrdiff_t>(last));
    return amplitude_at(piece, fs, order * revs / span);
  };
  const double a1 = order_amplitude(with.mesh_deflection_m, with.tacho_edges, 1);
  INFO("TE at the pinion order: " << a1 * 1e6 << " um (run-out 10 um); without: "
                                  << order_amplitude(without.mesh_deflection_m, without.tacho_edges, 1) * 1e6 << " um");
  CHECK(a1 == Approx(10e-6).epsilon(0.02));
  CHECK(order_amplitude(with.mesh_deflection_m, with.tacho_edges, 2) < 0.01 * a1);
  CHECK(order_amplitude(with.mesh_deflection_m, with.tacho_edges, 3) < 0.01 * a1);
  CHECK(order_amplitude(without.mesh_deflection_m, without.tacho_edges, 1) < 0.01 * a1);

  // How far the train turns with the run-out is what the twin's linearised model says: the encoder
  // angle (free end of the input shaft) minus the nominal rotation, fitted by a + b sin + c cos at the
  // shaft frequency, against |q7| of twin::transmission_error_response for 10 um at 10 Hz.
  // Measured: 8.2866e-05 against 8.2868e-05 rad (-0.001 %).
  const auto q = twin::transmission_error_response(twin::assemble(twin::GearboxParameters{}), s.speed_hz);
  const double expected = 10e-6 * std::abs(q[twin::theta7]);
  const std::size_t n = with.input_angle_rad.size();
  Eigen::MatrixXd basis(static_cast<Eigen::Index>(n), 3);
  Eigen::VectorXd deviation(basis.rows());
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / fs, w = 2 * kPi * s.speed_hz;
    basis.row(static_cast<Eigen::Index>(i)) << 1.0, std::sin(w * t), std::cos(w * t);
    deviation[static_cast<Eigen::Index>(i)] = with.input_angle_rad[i] - w * t;
  }
  const Eigen::Vector3d c = basis.colPivHouseholderQr().solve(deviation);
  INFO("encoder angle at the shaft frequency " << std::hypot(c[1], c[2]) << " rad, twin's response " << expected << " rad");
  CHECK(std::hypot(c[1], c[2]) == Approx(expected).epsilon(0.005));
}

TEST_CASE("rig: a casing mode is a resonance of the bearing-force-to-sensor path at its configured frequency", "[rig]") {
  // The transfer from the vertical bearing force to the casing modes' share of the sensor signal
  // over one hunting period (52 input revolutions: every line of the tooth-error excitation falls
  // on a bin): at every strongly excited line it must equal the closed form
  // sum_k -w^2/m / (w_k^2 - w^2 + 2i zeta w_k w), and peak on the same line as the closed form,
  // within 1 % of the configured mode.
  rig::EffectSet fx = rig::EffectSet::parse("casing,tooth_errors");
  fx.set("casing.mode1_hz", 700);
  fx.set("casing.mode2_hz", 1500);
  fx.set("casing.damping_ratio", 0.03);
  fx.set("casing.modal_mass_kg", 8);
  rig::RigRunSettings s;
  s.duration_s = 5.2;
  s.settle_s = 0.5;
  s.sample_rate_hz = 10000;
  s.channels = 1;
  s.keep_diagnostics = true;
  const auto r = run(fx, s);
  const std::size_t n = r.casing_y_m_s2.size();
  REQUIRE(n == 52000);
  dsp::RealFft fft(n);
  dsp::RealBuffer in(n);
  dsp::ComplexBuffer force(n / 2 + 1), response(n / 2 + 1);
  std::copy(r.bearing_force_y_n.begin(), r.bearing_force_y_n.end(), in.begin());
  fft.forward(in, force);
  std::copy(r.casing_y_m_s2.begin(), r.casing_y_m_s2.end(), in.begin());
  fft.forward(in, response);
  const double df = s.sample_rate_hz / static_cast<double>(n);
  auto closed_form = [](double f) {
    std::complex<double> h = 0;
    for (double fk : {700.0, 1500.0}) {
      const double wk = 2 * kPi * fk, wf = 2 * kPi * f;
      h += -wf * wf / 8.0 / std::complex<double>(wk * wk - wf * wf, 2 * 0.03 * wk * wf);
    }
    return std::abs(h);
  };
  // The tooth-error excitation is strong enough to read the transfer around the first mode.
  for (auto [lo, hi, mode] : {std::tuple{400.0, 1000.0, 700.0}}) {
    double largest = 0;
    for (auto k = static_cast<std::size_t>(lo / df); k <= static_cast<std::size_t>(hi / df); ++k)
      largest = std::max(largest, std::abs(force[k]));
    double f_peak = 0, h_peak = 0, f_closed_peak = 0, h_closed_peak = 0, worst = 0;
    int lines = 0;
    for (auto k = static_cast<std::size_t>(lo / df); k <= static_cast<std::size_t>(hi / df); ++k) {
      const double f = static_cast<double>(k) * df;
      if (std::abs(force[k]) < 0.1 * largest) continue;  // the strong lines only: weak ones carry leakage
      ++lines;
      if (closed_form(f) > h_closed_peak) {
        h_closed_peak = closed_form(f);
        f_closed_peak = f;
      }
      const double h = std::abs(response[k] / force[k]);
      if (h > h_peak) {
        h_peak = h;
        f_peak = f;
      }
      worst = std::max(worst, std::abs(h / closed_form(f) - 1));
    }
    INFO("mode " << mode << " Hz: " << lines << " excited lines, peak at " << f_peak << " Hz (closed form's peak "
                 << f_closed_peak << " Hz, line spacing " << df << " Hz); worst deviation from the closed form " << worst);
    CHECK(lines >= 20);
    CHECK(f_peak == f_closed_peak);
    CHECK(std::abs(f_peak - mode) <= 0.01 * mode);
    CHECK(worst < 0.02);
  }
}

TEST_CASE("rig: VFD speed ripple modulates the tacho intervals by the configured depth", "[rig]") {
  // Speed from each encoder interval, fitted by a + b sin + c cos at the ripple frequency: the
  // depth sqrt(b^2+c^2)/a is the configured depth times the interval's averaging,
  // sin(pi f_m T)/(pi f_m T) with T the revolution period.
  rig::EffectSet fx = rig::EffectSet::parse("speed_fluctuation");
  fx.set("speed_fluctuation.depth", 0.02);
  fx.set("speed_fluctuation.frequency_hz", 1.0);
  fx.set("speed_fluctuation.phase_rad", 0.4);
  rig::RigRunSettings s;
  s.duration_s = 4.0;
  s.sample_rate_hz = 5000;
  s.channels = 1;
  const auto r = run(fx, s);
  REQUIRE(r.tacho_edges.size() >= 38);
  Eigen::MatrixXd a(static_cast<Eigen::Index>(r.tacho_edges.size() - 1), 3);
  Eigen::VectorXd speed(a.rows());
  for (Eigen::Index k = 0; k < a.rows(); ++k) {
    const double t0 = r.tacho_edges[static_cast<std::size_t>(k)] / s.sample_rate_hz;
    const double t1 = r.tacho_edges[static_cast<std::size_t>(k) + 1] / s.sample_rate_hz;
    const double tm = 0.5 * (t0 + t1);
    a.row(k) << 1.0, std::sin(2 * kPi * tm), std::cos(2 * kPi * tm);
    speed[k] = 1.0 / (t1 - t0);
  }
  const Eigen::Vector3d c = a.colPivHouseholderQr().solve(speed);
  const double depth = std::hypot(c[1], c[2]) / c[0];
  const double x = kPi * 1.0 / 10.0;
  INFO("mean speed " << c[0] << " Hz, measured depth " << depth);
  CHECK(c[0] == Approx(10.0).epsilon(1e-3));
  CHECK(depth == Approx(0.02 * std::sin(x) / x).epsilon(0.01));
}

TEST_CASE("rig: the sensor noise floor has the configured PSD", "[rig]") {
  rig::EffectSet fx = rig::EffectSet::parse("noise");
  fx.set("noise.psd", 1e-4);
  rig::RigRunSettings s;
  s.duration_s = 0.3;
  s.channels = 2;
  const auto r = run(fx, s);
  for (int c = 0; c < 2; ++c) {
    const std::vector<double> x(r.acceleration[static_cast<std::size_t>(c)].begin(), r.acceleration[static_cast<std::size_t>(c)].end());
    const auto w = welch(x, nullptr, s.sample_rate_hz, 1024);
    // 30-45 kHz: far above the gear pair's own response, so the floor is the sensor's.
    double sum = 0;
    int bins = 0;
    for (std::size_t k = static_cast<std::size_t>(30000 / w.df); k <= static_cast<std::size_t>(45000 / w.df); ++k, ++bins)
      sum += w.psd[k];
    INFO("channel " << c << ": floor " << sum / bins << " (m/s2)^2/Hz over " << bins << " bins");
    CHECK(sum / bins == Approx(1e-4).epsilon(0.03));
  }
}

TEST_CASE("rig: the mounting resonance amplifies the noise floor by the transmissibility at its frequency", "[rig]") {
  // Sliding vibration is off; the sensor noise enters after the mount, so measure the mount on a
  // wide-band structural input instead: abrasion-band sliding noise (22-34 kHz) through the mount
  // at 28 kHz. The PSD ratio with/without the mount at 28 kHz is |T|^2 = (1 + 4 zeta^2)/(4 zeta^2).
  rig::EffectSet with = rig::EffectSet::parse("mounting");
  with.set("mounting.frequency_hz", 28000);
  with.set("mounting.damping_ratio", 0.1);
  rig::RigRunSettings s;
  s.duration_s = 0.3;
  s.channels = 1;
  rig::SlidingVibration sliding;
  sliding.abrasion_rms_m_s2 = 5.0;
  const auto a = run(with, s, {}, sliding), b = run({}, s, {}, sliding);
  const std::vector<double> xa(a.acceleration[0].begin(), a.acceleration[0].end()), xb(b.acceleration[0].begin(), b.acceleration[0].end());
  const auto wa = welch(xa, nullptr, s.sample_rate_hz, 1000), wb = welch(xb, nullptr, s.sample_rate_hz, 1000);
  const std::size_t k = static_cast<std::size_t>(28000 / wa.df);
  double ra = 0, rb = 0;
  for (std::size_t i = k - 2; i <= k + 2; ++i) {
    ra += wa.psd[i];
    rb += wb.psd[i];
  }
  const double expected = (1 + 4 * 0.01) / (4 * 0.01);
  INFO("PSD ratio at 28 kHz " << ra / rb << ", expected " << expected);
  CHECK(ra / rb == Approx(expected).epsilon(0.05));
}

TEST_CASE("rig: below its resonance the mount follows the analog transmissibility, not a warped one", "[rig]") {
  // A 40 kHz mount at fs = 100 kHz: the PSD ratio with/without it at f is the analog
  // |T(r)|² = (1 + (2ζr)²)/((1 − r²)² + (2ζr)²), r = f/fn. A bilinear transform prewarped at fn
  // would give 0.9, 1.5 and 2.6 dB at 24, 28 and 32 kHz instead of the analog 3.9, 5.8 and 8.7 dB.
  const double fn = 40000, zeta = 0.05;
  rig::EffectSet with = rig::EffectSet::parse("mounting");
  with.set("mounting.frequency_hz", fn);
  with.set("mounting.damping_ratio", zeta);
  rig::RigRunSettings s;
  s.duration_s = 0.3;
  s.channels = 1;
  rig::SlidingVibration sliding;
  sliding.abrasion_rms_m_s2 = 5.0;  // 22-34 kHz band noise: a wide-band input below the mount
  const auto a = run(with, s, {}, sliding), b = run({}, s, {}, sliding);
  const std::vector<double> xa(a.acceleration[0].begin(), a.acceleration[0].end()), xb(b.acceleration[0].begin(), b.acceleration[0].end());
  const auto wa = welch(xa, nullptr, s.sample_rate_hz, 1000), wb = welch(xb, nullptr, s.sample_rate_hz, 1000);
  for (double f : {24000.0, 28000.0, 32000.0}) {
    const std::size_t k = static_cast<std::size_t>(f / wa.df);
    double ra = 0, rb = 0;
    for (std::size_t i = k - 2; i <= k + 2; ++i) ra += wa.psd[i], rb += wb.psd[i];
    const double r = f / fn, c = 2 * zeta * r;
    const double expected = (1 + c * c) / ((1 - r * r) * (1 - r * r) + c * c);
    INFO(f << " Hz: PSD ratio " << ra / rb << ", analog " << expected);
    CHECK(ra / rb == Approx(expected).epsilon(0.05));
  }
}

TEST_CASE("rig: tooth-to-tooth spacing errors appear tooth by tooth in the synchronous transmission error", "[rig]") {
  // Quasi-static (0.5 Hz): in a tooth's single-contact zone delta + e_n = F/k(s), e_n = -spacing_n,
  // so the mean deflection there, tooth by tooth, is the configured pattern plus a constant.
  const twin::GearboxParameters p;
  const int z1 = p.gears.pinion_teeth, z2 = p.gears.gear_teeth;
  rig::ToothErrorPattern pattern;
  for (int n = 0; n < z1; ++n) pattern.pinion_spacing_m.push_back(3e-6 * std::sin(2 * kPi * 3 * n / z1) + (n == 7 ? 4e-6 : 0.0));
  pattern.pinion_slope_m.assign(static_cast<std::size_t>(z1), 0.0);
  pattern.gear_spacing_m.assign(static_cast<std::size_t>(z2), 0.0);
  pattern.gear_slope_m.assign(static_cast<std::size_t>(z2), 0.0);
  rig::EffectSet fx = rig::EffectSet::parse("tooth_errors");
  fx.set_tooth_pattern(pattern, z1, z2);
  rig::RigRunSettings s;
  s.speed_hz = 0.5;
  s.duration_s = 2.0;
  s.settle_s = 0.5;
  s.sample_rate_hz = 4000;
  s.channels = 1;
  s.keep_diagnostics = true;
  const auto r = run(fx, s);
  const double exit_phase = twin::GearMeshStiffness(twin::GearGeometry::from_spec(p.gears)).double_contact_share();
  std::vector<double> sum(static_cast<std::size_t>(z1), 0.0), count(static_cast<std::size_t>(z1), 0.0);
  // The single-contact zone, less its edges (the pair switch takes a few samples to settle).
  for (std::size_t i = 0; i < r.mesh_cycles.size(); ++i) {
    const double c = std::floor(r.mesh_cycles[i]), phase = r.mesh_cycles[i] - c;
    if (phase < exit_phase + 0.05 || phase > 0.95) continue;
    const auto tooth = static_cast<std::size_t>(((static_cast<long long>(c) % z1) + z1) % z1);
    // The quasi-static F/k(s) is the same for every tooth; subtract it via the no-error run below.
    sum[tooth] += r.mesh_deflection_m[i];
    count[tooth] += 1;
  }
  const auto base = run({}, s);
  std::vector<double> base_sum(static_cast<std::size_t>(z1), 0.0);
  for (std::size_t i = 0; i < base.mesh_cycles.size(); ++i) {
    const double c = std::floor(base.mesh_cycles[i]), phase = base.mesh_cycles[i] - c;
    if (phase < exit_phase + 0.05 || phase > 0.95) continue;
    base_sum[static_cast<std::size_t>(((static_cast<long long>(c) % z1) + z1) % z1)] += base.mesh_deflection_m[i];
  }
  double worst = 0;
  for (int n = 0; n < z1; ++n) {
    const auto k = static_cast<std::size_t>(n);
    REQUIRE(count[k] > 10);
    const double measured = (sum[k] - base_sum[k]) / count[k];
    worst = std::max(worst, std::abs(measured - pattern.pinion_spacing_m[k]));
  }
  INFO("worst tooth error of the recovered pattern: " << worst * 1e6 << " um (pattern RMS ~2.2 um)");
  CHECK(worst < 0.05e-6);
}

TEST_CASE("rig: tip relief lowers the high mesh harmonics of the transmission error as the quasi-static solution predicts", "[rig]") {
  // Reference: for each mesh phase solve sum_i k_i max(delta + e_i, 0) = F by bisection (e_i the
  // relief of the pair at s_i), then the DFT over one mesh period. The rig runs at 0.05 Hz.
  const twin::GearboxParameters p;
  const auto g = twin::GearGeometry::from_spec(p.gears);
  const twin::GearMeshStiffness mesh(g);
  const double amount = 8e-6, length = 0.2, torque = 20.0;
  const double force = torque / g.base_radius_pinion;
  auto relief = [&](double u) { return amount * std::max(0.0, (u - (1 - length)) / length); };
  auto quasi_static = [&](bool relieved, int harmonic) {
    const int n = 4000;
    std::complex<double> acc = 0;
    for (int i = 0; i < n; ++i) {
      const double phase = (i + 0.5) / n;
      double pos[3];
      const int pairs = mesh.pairs_in_contact(phase, pos);
      auto total = [&](double delta) {
        double f = 0;
        for (int j = 0; j < pairs; ++j) {
          const double e = relieved ? -(relief(g.profile_fraction_pinion(pos[j])) + relief(g.profile_fraction_gear(pos[j]))) : 0.0;
          f += mesh.pair_stiffness(pos[j]) * std::max(delta + e, 0.0);
        }
        return f;
      };
      double lo = 0, hi = 1e-3;
      for (int it = 0; it < 100; ++it) ((total(0.5 * (lo + hi)) < force) ? lo : hi) = 0.5 * (lo + hi);
      acc += 0.5 * (lo + hi) * std::polar(1.0, -2 * kPi * harmonic * phase);
    }
    return 2.0 * std::abs(acc) / n;
  };
  rig::EffectSet fx = rig::EffectSet::parse("tip_relief");
  fx.set("tip_relief.amount_um", 8);
  fx.set("tip_relief.length_fraction", 0.2);
  rig::RigRunSettings s;
  s.speed_hz = 0.05;  // mesh harmonics up to 7 (6.7 Hz) stay well below the 22 Hz coupling mode
  s.torque_nm = torque;
  s.settle_s = 1.0;
  s.duration_s = 2.0 / (0.05 * 19);  // two mesh periods
  s.sample_rate_hz = 2000;
  s.channels = 1;
  s.keep_diagnostics = true;
  const auto a = run(fx, s), b = run({}, s);
  auto simulated = [&](const rig::RigRecord& r, int h) {
    std::complex<double> acc = 0;
    for (std::size_t i = 0; i < r.mesh_cycles.size(); ++i)
      acc += r.mesh_deflection_m[i] * std::polar(1.0, -2 * kPi * h * r.mesh_cycles[i]);
    return 2.0 * std::abs(acc) / static_cast<double>(r.mesh_cycles.size());
  };
  double high_relief = 0, high_step = 0;
  for (int h = 1; h <= 7; ++h) {
    const double expected_db = 20 * std::log10(quasi_static(true, h) / quasi_static(false, h));
    const double measured_db = 20 * std::log10(simulated(a, h) / simulated(b, h));
    INFO("harmonic " << h << ": relief/step " << measured_db << " dB, quasi-static " << expected_db << " dB");
    CHECK(measured_db == Approx(expected_db).margin(0.3));
    if (h >= 4) {
      high_relief += std::pow(simulated(a, h), 2);
      high_step += std::pow(simulated(b, h), 2);
    }
  }
  // Harmonics 4-7 together: the relief removes most of the step's high-order content.
  CHECK(high_relief < 0.5 * high_step);
}

TEST_CASE("rig: misalignment raises the mean transmission error by half the face separation", "[rig]") {
  // With the flanks separating by beta z across the face and the whole face loaded,
  // F = k (c - beta b / 2): the mean deflection grows by beta b / 2 at the same load.
  rig::EffectSet fx = rig::EffectSet::parse("misalignment");
  fx.set("misalignment.angle_mrad", 0.05);
  rig::RigRunSettings s;
  s.speed_hz = 0.5;
  s.settle_s = 0.5;
  s.duration_s = 1.0;
  s.sample_rate_hz = 2000;
  s.channels = 1;
  s.keep_diagnostics = true;
  const auto a = run(fx, s), b = run({}, s);
  const double shift = (std::accumulate(a.mesh_deflection_m.begin(), a.mesh_deflection_m.end(), 0.0) -
                        std::accumulate(b.mesh_deflection_m.begin(), b.mesh_deflection_m.end(), 0.0)) /
                       static_cast<double>(a.mesh_deflection_m.size());
  const double expected = 0.5 * 0.05e-3 * twin::GearboxParameters{}.gears.face_width_m;
  INFO("mean deflection shift " << shift * 1e6 << " um, expected " << expected * 1e6 << " um");
  CHECK(shift == Approx(expected).epsilon(0.01));
}

TEST_CASE("rig: sliding vibration adds its RMS in its carrier band, modulated at the gear mesh", "[rig]") {
  rig::RigRunSettings s;
  s.duration_s = 0.3;
  s.channels = 1;
  rig::SlidingVibration sliding;
  sliding.pitting_rms_m_s2 = 2.0;
  const auto a = run({}, s, {}, sliding), b = run({}, s);
  std::vector<double> d(a.acceleration[0].size());
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = a.acceleration[0][i] - b.acceleration[0][i];
  double ss = 0;
  for (double v : d) ss += v * v;
  CHECK(std::sqrt(ss / d.size()) == Approx(2.0).epsilon(0.03));
  // The carrier band is two Butterworth sections each side of 3-9 kHz: the share of power in the
  // thesis's pitting band 2-13 kHz is that of |H(f)|^2 = 1/((1 + (3k/f)^4)^2 (1 + (f/9k)^4)^2).
  const auto w = welch(d, nullptr, s.sample_rate_hz, 1000);
  double in_band = 0, total = 0, expected_in = 0, expected_total = 0;
  for (std::size_t k = 1; k < w.psd.size(); ++k) {
    const double f = static_cast<double>(k) * w.df;
    const double h2 = 1.0 / (std::pow(1 + std::pow(3000 / f, 4), 2) * std::pow(1 + std::pow(f / 9000, 4), 2));
    total += w.psd[k];
    expected_total += h2;
    if (f >= 2000 && f <= 13000) {
      in_band += w.psd[k];
      expected_in += h2;
    }
  }
  INFO("share in 2-13 kHz: " << in_band / total << ", expected " << expected_in / expected_total);
  CHECK(in_band / total == Approx(expected_in / expected_total).margin(0.01));
  // Cyclostationary at the mesh: the squared envelope carries the mesh frequency (190 Hz).
  std::vector<double> sq(d.size());
  for (std::size_t i = 0; i < d.size(); ++i) sq[i] = d[i] * d[i];
  const double mean_sq = ss / d.size();
  CHECK(amplitude_at(sq, s.sample_rate_hz, 190.0) > 0.3 * mean_sq);
  CHECK(amplitude_at(sq, s.sample_rate_hz, 173.0) < 0.1 * mean_sq);
}

TEST_CASE("rig: an effect parameter outside its range is refused with its name", "[rig]") {
  rig::EffectSet fx;
  CHECK_THROWS_WITH(fx.set("casing.mode1_hz", 9000), Contains("casing.mode1_hz") && Contains("[20, 5000]"));
  CHECK_THROWS_WITH(fx.set("noise.psd", -1), Contains("noise.psd"));
  CHECK_THROWS_WITH(fx.set("eccentricity.shaft_um", 1), Contains("eccentricity.shaft_um"));
  CHECK_THROWS_WITH(rig::EffectSet::parse("casing,wobble"), Contains("wobble"));
  CHECK_NOTHROW(fx.set("casing.mode1_hz", 5000));
}

TEST_CASE("rig: random effect parameters lie in their ranges and repeat for a seed", "[rig]") {
  rig::EffectSet a = rig::EffectSet::parse("all"), b = rig::EffectSet::parse("all"), c = rig::EffectSet::parse("all");
  a.randomise(42);
  b.randomise(42);
  c.randomise(43);
  CHECK(a.active_parameters() == b.active_parameters());
  CHECK(a.active_parameters() != c.active_parameters());
  for (const auto& [name, value] : a.active_parameters()) {
    const auto* info = rig::find_effect_parameter(name);
    REQUIRE(info);
    CHECK(value >= info->low);
    CHECK(value <= info->high);
  }
  const auto pa = a.tooth_pattern(19, 52);
  double ss = 0;
  for (double v : pa.pinion_spacing_m) ss += v * v;
  CHECK(std::sqrt(ss / 19) == Approx(a.get("tooth_errors.spacing_rms_um") * 1e-6).epsilon(1e-9));
  CHECK(pa.pinion_spacing_m == b.tooth_pattern(19, 52).pinion_spacing_m);
}

TEST_CASE("rig: a record is identical for a seed and differs for another", "[rig]") {
  rig::EffectSet fx = rig::EffectSet::parse("all");
  fx.randomise(7);
  rig::RigRunSettings s;
  s.duration_s = 0.05;
  s.seed = 3;
  rig::SlidingVibration sliding;
  sliding.pitting_rms_m_s2 = 1;
  sliding.abrasion_rms_m_s2 = 1;
  const auto a = run(fx, s, {}, sliding), b = run(fx, s, {}, sliding);
  s.seed = 4;
  const auto c = run(fx, s, {}, sliding);
  CHECK(a.acceleration == b.acceleration);
  CHECK(a.tacho_edges == b.tacho_edges);
  CHECK(a.acceleration != c.acceleration);
}

TEST_CASE("rig: built-in wear truth follows its closed forms", "[rig]") {
  rig::WearModelSettings w;
  w.phases = {{0, 2e-12}, {1e6, 5e-13}};
  w.torque_nm = 10;
  w.reference_torque_nm = 20;
  w.pitting_onset_cycles = 5e5;
  w.k_pitting = 0.04;
  w.pitting_exponent = 2;
  w.max_pitting = 0.3;
  w.initial_roughness = 1;
  w.runin_cycles = 2e5;
  w.roughness_per_um = 0.1;
  const rig::BuiltinWearTruth truth(w, GearPairSpec{});
  const auto s = truth.at(3e6);
  // Amplitude: (10/20) (2e-12 * 1e6 + 5e-13 * 2e6) = 1.5e-6 m at the sliding extreme.
  const double amplitude = 0.5 * (2e-12 * 1e6 + 5e-13 * 2e6);
  CHECK(*std::max_element(s.profile.pinion.begin(), s.profile.pinion.end()) == Approx(amplitude).epsilon(1e-12));
  CHECK(*std::max_element(s.profile.gear.begin(), s.profile.gear.end()) == Approx(amplitude * 19.0 / 52.0).epsilon(1e-12));
  CHECK(s.k_wear == 5e-13);
  CHECK(s.pitting_density == Approx(0.04 * 2.5 * 2.5));
  CHECK(s.roughness == Approx(std::exp(-15.0) + 0.1 * s.mean_wear_depth_m * 1e6));
  CHECK(truth.at(4e5).pitting_density == 0);
  CHECK(truth.at(1e8).pitting_density == 0.3);
  // Linear in cycles within a phase.
  CHECK(truth.at(5e5).mean_wear_depth_m == Approx(0.5 * truth.at(1e6).mean_wear_depth_m));
}

TEST_CASE("rig: the Archard wear truth is the project's blue loop with K switched at each phase", "[rig]") {
  // Direct reference: core's wear::BlueLoop run by hand at the same operating point, K set at the
  // phase boundary. The truth must give the same profiles, asked in order or out of order.
  rig::WearModelSettings w;
  w.law = rig::WearLaw::archard;
  w.phases = {{0, 1e-12}, {3000, 3e-12}};
  w.torque_nm = 5;
  w.pitting_onset_cycles = 1000;
  w.k_pitting = 0.1;
  w.initial_roughness = 0.5;
  w.runin_cycles = 1000;
  w.roughness_per_um = 0.1;
  const twin::GearboxParameters params;
  const auto truth = rig::make_wear_truth(w, params, 10.0);

  wear::WearLoopOptions o;
  o.k_wear_si = 1e-12;
  o.operating_point = {10.0, 5.0};
  wear::BlueLoop reference(params, o);
  REQUIRE(reference.run_until(2000));
  const auto at_2000 = reference.state();
  REQUIRE(reference.run_until(3000));
  reference.set_coefficients(3e-12, 0.0);
  REQUIRE(reference.run_until(5000));
  const auto at_5000 = reference.state();

  const auto a = truth->at(2000), b = truth->at(5000);
  CHECK(a.profile.pinion == wear::to_profile_deviation(at_2000).pinion);
  CHECK(b.profile.pinion == wear::to_profile_deviation(at_5000).pinion);
  CHECK(b.profile.gear == wear::to_profile_deviation(at_5000).gear);
  CHECK(a.k_wear == 1e-12);
  CHECK(b.k_wear == 3e-12);
  CHECK(b.combined_mean_wear_depth_m == wear::summarise(at_5000).combined_mean_depth_m);
  CHECK(b.mean_wear_depth_m == wear::summarise(at_5000).pinion_mean_depth_m);
  // Out of order: the truth runs again from the start.
  CHECK(truth->at(2000).profile.pinion == a.profile.pinion);
  // Three times the K from 3000 on: the 2000 cycles after the switch wear about 3 x 2000 / 2000
  // times the first 2000 (profile feedback changes the force a little).
  const double first = wear::summarise(at_2000).combined_mean_depth_m;
  const double after = b.combined_mean_wear_depth_m - truth->at(3000).combined_mean_wear_depth_m;
  CHECK(after / first == Approx(3.0).epsilon(0.05));
  // Pitting and roughness follow the built-in laws on top of the Archard depth.
  CHECK(b.pitting_density == Approx(0.1 * std::pow(4000 / 1e6, 1.5)).epsilon(1e-12));
  CHECK(b.roughness == Approx(0.5 * std::exp(-5.0) + 0.1 * b.mean_wear_depth_m * 1e6).epsilon(1e-12));
  // The linear law is the default and stays what it was.
  CHECK(dynamic_cast<const rig::BuiltinWearTruth*>(rig::make_wear_truth(rig::WearModelSettings{}, params, 10.0).get()) != nullptr);
}

TEST_CASE("rig: brake torque ripple moves the shaft as the VFD's PI speed loop on the rigid drive predicts", "[rig]") {
  // Far below the drive train's torsional modes the train turns as one body of inertia
  // J = sum of the input inertias + sum of the output inertias x ratio^2 (referred to the input).
  // The brake's ripple T_b m sin(wt), T_b = T / ratio, is T m sin(wt) at the input; the PI loop
  // (K_i = J wc^2, K_p = 2 zeta J wc, zeta = 0.7) holds the motor's angle, so the angle deviation
  // is theta(s) = -T m / (J (s^2 + 2 zeta wc s + wc^2)): amplitude T m / (J |wc^2 - w^2 + 2j zeta wc w|).
  const twin::GearboxParameters p;
  const auto matrices = twin::assemble(p);
  const auto g = twin::GearGeometry::from_spec(p.gears);
  const double ratio = g.base_radius_pinion / g.base_radius_gear;
  double j = 0;
  for (int i : {twin::theta1, twin::theta2, twin::theta3, twin::theta5, twin::theta7}) j += matrices.mass[i];
  for (int i : {twin::theta8, twin::theta10, twin::theta12, twin::theta13}) j += matrices.mass[i] * ratio * ratio;
  // The encoder sits at the free end of the input shaft, the loop holds the motor: the shaft's
  // twist under the ripple it carries (about J wc^2 / k_shaft of the angle, 0.6 % with a 2 Hz loop)
  // is not in the rigid model, so the loop is set to its slowest, 0.5 Hz (0.04 %).
  const double torque = 20.0, depth = 0.1, loop_hz = 0.5, zeta = 0.7;
  for (double f : {0.5, 1.0}) {
    rig::EffectSet fx = rig::EffectSet::parse("load_fluctuation");
    fx.set("load_fluctuation.depth", depth);
    fx.set("load_fluctuation.frequency_hz", f);
    fx.set("load_fluctuation.speed_loop_hz", loop_hz);
    rig::RigRunSettings s;
    s.duration_s = 6.0;
    s.sample_rate_hz = 2000;
    s.channels = 1;
    s.torque_nm = torque;
    s.keep_diagnostics = true;
    const auto r = run(fx, s);
    // The encoder angle minus the nominal rotation, fitted by a + b sin + c cos at f over the last
    // 4 s (whole periods; the loop's transient, decay rate zeta wc = 2.2/s, is down to 1e-2 by then).
    const auto n = r.input_angle_rad.size();
    const std::size_t first = n - static_cast<std::size_t>(4.0 * s.sample_rate_hz);
    Eigen::MatrixXd a(static_cast<Eigen::Index>(n - first), 3);
    Eigen::VectorXd y(a.rows());
    for (std::size_t i = first; i < n; ++i) {
      const double t = static_cast<double>(i) / s.sample_rate_hz;
      const auto row = static_cast<Eigen::Index>(i - first);
      a.row(row) << 1.0, std::sin(2 * kPi * f * t), std::cos(2 * kPi * f * t);
      y[row] = r.input_angle_rad[i] - 2 * kPi * s.speed_hz * t;
    }
    const Eigen::Vector3d c = a.colPivHouseholderQr().solve(y);
    const double w = 2 * kPi * f, wc = 2 * kPi * loop_hz;
    const double expected = torque * depth / (j * std::abs(std::complex<double>(wc * wc - w * w, 2 * zeta * wc * w)));
    INFO("f = " << f << " Hz: angle ripple " << std::hypot(c[1], c[2]) << " rad, closed form " << expected << " rad (J = " << j << ")");
    // Measured: 9.4552 against 9.4359 rad at 0.5 Hz (+0.21 %), 3.2306 against 3.2191 rad at 1 Hz (+0.35 %).
    CHECK(std::hypot(c[1], c[2]) == Approx(expected).epsilon(0.01));
  }
}

TEST_CASE("rig: with the torque reversed the back flanks carry it, a clearance further on", "[rig]") {
  // Backlash: a pair whose deflection falls below -clearance pushes back with the front flanks'
  // stiffness. Reversing the torque must then mirror the mesh about -clearance/2: the same
  // stiffness and load, so the mean deflection is -clearance - (mean deflection under +T), the
  // mean mesh force the negative of +T's, and every sample on the back flanks (below -clearance).
  // The reversed run starts from the mirrored equilibrium, inside the gap, and closes it while
  // settling. Measured: -43.3211 against -43.3212 um (40 um), the same 2e-6 at 120 um.
  auto mean = [](const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size()); };
  auto simulate = [](double torque, double clearance_m) {
    rig::EffectSet fx = rig::EffectSet::parse("backlash");
    fx.set("backlash.clearance_um", clearance_m * 1e6);
    rig::RigRunSettings s;
    s.duration_s = 0.3;  // 57 mesh cycles at 10 Hz
    s.settle_s = 0.5;
    s.sample_rate_hz = 50000;
    s.channels = 1;
    s.torque_nm = torque;
    s.keep_diagnostics = true;
    return run(fx, s);
  };
  const auto g = twin::GearGeometry::from_spec(twin::GearboxParameters{}.gears);
  for (double clearance : {40e-6, 120e-6}) {
    const auto forward = simulate(20.0, clearance), reversed = simulate(-20.0, clearance);
    const double d_forward = mean(forward.mesh_deflection_m), d_reversed = mean(reversed.mesh_deflection_m);
    INFO("clearance " << clearance * 1e6 << " um: mean deflection +T " << d_forward * 1e6 << " um, -T " << d_reversed * 1e6 << " um");
    CHECK(d_forward > 0);
    CHECK(d_reversed == Approx(-clearance - d_forward).epsilon(1e-4));
    CHECK(mean(reversed.mesh_force_n) == Approx(-mean(forward.mesh_force_n)).epsilon(1e-3));  // measured 1.2e-4, 1.4e-4
    CHECK(*std::max_element(reversed.mesh_deflection_m.begin(), reversed.mesh_deflection_m.end()) < -clearance);
    CHECK(*std::max_element(reversed.mesh_force_n.begin(), reversed.mesh_force_n.end()) < 0);
    // The mean force is T / r_b1 either way.
    CHECK(mean(forward.mesh_force_n) == Approx(20.0 / g.base_radius_pinion).epsilon(1e-3));
  }
}

TEST_CASE("rig: eccentric shafts give the lines of the twin with the same shaft run-out", "[rig]") {
  // The rig's run-out and the twin's (SimulationOptions::shaft_run_out, the gap diagnosis's source
  // of the eccentricity form) are two implementations of one transmission error, integrated by
  // different schemes. At 8 Hz, 20 N·m, the first sidebands of mesh harmonics 2–5 (orders 37/39,
  // 56/58, 75/77, 94/96), 37–74 dB above the twin's without a run-out. Measured: within 0.35 dB
  // (order 37, the weakest), 0.06–0.24 dB at the others.
  const double fs = 50000, seconds = 2.0, speed = 8;
  const double pinion_m = 6.6e-6, pinion_phase = 1.0, gear_m = 12.5e-6, gear_phase = 2.0;
  rig::EffectSet fx = rig::EffectSet::parse("eccentricity");
  fx.set("eccentricity.pinion_um", pinion_m * 1e6);
  fx.set("eccentricity.pinion_phase_rad", pinion_phase);
  fx.set("eccentricity.gear_um", gear_m * 1e6);
  fx.set("eccentricity.gear_phase_rad", gear_phase);
  rig::RigRunSettings s;
  s.speed_hz = speed;
  s.duration_s = seconds;
  s.sample_rate_hz = fs;
  s.channels = 1;
  const auto rig_record = run(fx, s);
  auto twin_record = [&](const twin::ShaftRunOut& run_out) {
    twin::SimulationOptions o;
    o.sample_rate_hz = fs;
    o.shaft_run_out = run_out;
    return twin::simulate_casing_signal(twin::GearboxParameters{}, {}, {speed, 20.0}, seconds, o).acceleration;
  };
  const auto with = twin_record({pinion_m, pinion_phase, gear_m, gear_phase}), without = twin_record({});
  const auto samples_per_rev = static_cast<std::size_t>(fs / speed);
  auto lines = [&](const auto& x) { return gearwatch::test::order_line_power(x, samples_per_rev, 15, 100); };
  const auto rig_lines = lines(rig_record.acceleration[0]), twin_lines = lines(with), plain = lines(without);
  for (int k : {37, 39, 56, 58, 75, 77, 94, 96}) {
    const auto i = static_cast<std::size_t>(k - 1);
    INFO("order " << k << ": rig " << 10 * std::log10(rig_lines[i]) << " dB, twin with the run-out "
                  << 10 * std::log10(twin_lines[i]) << " dB, without " << 10 * std::log10(plain[i]) << " dB");
    CHECK(10 * std::log10(twin_lines[i] / plain[i]) > 20.0);
    CHECK(10 * std::log10(rig_lines[i] / twin_lines[i]) == Approx(0).margin(0.5));
  }
}

TEST_CASE("rig: under a driving torque the clearance is never crossed, so backlash leaves the record unchanged", "[rig]") {
  // Why the gap bench cannot see backlash (docs/gap.md): the back flanks touch only when a pair's
  // compression falls below -clearance, and under a steady driving torque the mesh never even loses
  // contact. Down to a twenty-fifth of the bench's lighter load (5 N·m), with its worn profile (2 µm
  // at the sliding extremes), at its slowest speed and the prior's smallest clearance (20 µm), the
  // total mesh force stays positive and the records with and without the clearance are the same
  // samples. Measured least mesh force over its mean T / r_b1: 0.99, 0.93 and 0.61 at 5, 1 and
  // 0.2 N·m (276, 52 and 6.9 N): the worn profile's share of the deflection grows as the load falls.
  rig::WearModelSettings w;
  w.torque_nm = 20;
  w.phases = {{0.0, 2e-6 / 1e6}};
  const rig::WearState wear = rig::BuiltinWearTruth(w, GearPairSpec{}).at(1e6);
  rig::EffectSet backlash = rig::EffectSet::parse("backlash");
  backlash.set("backlash.clearance_um", 20);
  const auto g = twin::GearGeometry::from_spec(twin::GearboxParameters{}.gears);
  for (double torque : {5.0, 1.0, 0.2}) {
    rig::RigRunSettings s;
    s.speed_hz = 8;
    s.torque_nm = torque;
    s.duration_s = 0.5;
    s.sample_rate_hz = 50000;
    s.channels = 1;
    s.keep_diagnostics = true;
    const auto with = run(backlash, s, wear), without = run(rig::EffectSet{}, s, wear);
    const double least = *std::min_element(with.mesh_force_n.begin(), with.mesh_force_n.end());
    INFO(torque << " N m: least mesh force " << least << " N, mean " << torque / g.base_radius_pinion << " N");
    CHECK(least > 0.5 * torque / g.base_radius_pinion);
    CHECK(with.acceleration[0] == without.acceleration[0]);
    CHECK(with.mesh_deflection_m == without.mesh_deflection_m);
  }
}

namespace {
/// As the twin's (test_twin_simulation.cpp): orders 1..max_order of 2 s of a perfect pair at 8 Hz and
/// 20 N·m, at `fs` (a whole number of samples a revolution), through a front-end of `oversampling`.
std::vector<double> front_end_order_lines(double fs, int oversampling, int max_order) {
  rig::RigRunSettings run;
  run.speed_hz = 8;
  run.torque_nm = 20;
  run.duration_s = 2;
  run.sample_rate_hz = fs;
  run.channels = 1;
  run.front_end_oversampling = oversampling;
  const auto r = rig::simulate_record(twin::GearboxParameters{}, rig::EffectSet{}, rig::WearState{}, {}, run);
  REQUIRE(r.acceleration[0].size() == static_cast<std::size_t>(2 * fs));
  return gearwatch::test::order_line_power(r.acceleration[0], static_cast<std::size_t>(fs / 8.0), 15, max_order);
}
}  // namespace

TEST_CASE("The rig's record is what an anti-aliased front-end gives: the mesh's lines above fs/2 do not fold onto the shaft orders", "[rig][front-end]") {
  // As the twin's (test_twin_simulation.cpp): 8 Hz at 100 kHz, a perfect pair, so the orders
  // between the mesh harmonics and their first sidebands hold only folding and the integrator's
  // noise; the same integration steps read once per sample, by the default front-end (4×) and at 32×.
  auto lines = [](int oversampling) { return front_end_order_lines(100000, oversampling, 40); };
  REQUIRE(rig::RigRunSettings{}.front_end_oversampling == 0);  // automatic: 4 at 100 kHz
  REQUIRE(gearwatch::dsp::front_end_oversampling(100000) == 4);
  const auto direct = lines(1), front_end = lines(4), reference = lines(32);
  auto shaft_db = [](const std::vector<double>& l) { return gearwatch::test::shaft_order_db_re_mesh(l, 19); };
  INFO("shaft orders re the first mesh harmonic: read once per sample " << shaft_db(direct) << " dB, front-end 4x "
                                                                          << shaft_db(front_end) << " dB, 32x " << shaft_db(reference) << " dB");
  // Measured −19.1, −42.4 and −46.6 dB: the rig's fixed 10 µs Runge–Kutta steps leave a higher
  // floor than the twin's dopri5 (−72.8 dB), and 4× reads 4 dB above it.
  CHECK(shaft_db(direct) > -25.0);
  CHECK(shaft_db(front_end) < -40.0);
  CHECK(shaft_db(reference) < -44.0);
  CHECK(shaft_db(front_end) - shaft_db(reference) < 6.0);
  for (int k : {19, 38}) CHECK(10 * std::log10(front_end[k - 1] / reference[k - 1]) == Approx(0).margin(0.01));
}

TEST_CASE("At 20 kHz the rig's front-end reads at 400 kHz: 4x would leave folded lines on the first sidebands", "[rig][front-end]") {
  // As the twin's (test_twin_simulation.cpp): 8 Hz at 20 kHz, a perfect pair; the same 10 µs steps
  // read at 4×, by the default (20×) and at 64×.
  auto lines = [](int oversampling) { return front_end_order_lines(20000, oversampling, 60); };
  const auto c = gearwatch::test::compare_front_ends(lines, 64, 19);
  INFO(c << " (reference 64x)");
  // Measured: first sidebands −33.4 (4×), −72.6 (automatic) and −63.6 dB (64×); shaft orders
  // −13.6, −40.8 and −44.2 dB (the 10 µs Runge–Kutta steps' floor, as at 100 kHz: −42.4 and −46.6).
  gearwatch::test::check_front_end_folding_at_20_khz(c);
  CHECK(c.shaft.automatic < -38.0);
  CHECK(c.shaft.automatic - c.shaft.reference < 6.0);
}

}  // namespace test_rig_simulator
