#include "gearwatch/gap/candidates.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <iterator>
#include <numbers>
#include <set>
#include <stdexcept>
#include <string>

#include "gearwatch/dsp/order_tracking.hpp"
#include "gearwatch/gap/bessel.hpp"

namespace gearwatch::gap {
namespace {

using FK = FamilyKind;


double transmissibility_power(double f, double fn, double zeta) {
  const double r = f / fn;
  const double a = 1.0 - r * r, b = 2.0 * zeta * r;
  return (1.0 + b * b) / (a * a + b * b);
}

/// The twin's mesh-harmonic powers interpolated log-linearly in order (flat beyond the ends):
/// the transfer path a per-tooth pattern's lines pass through.
class MeshEnvelope {
 public:
  MeshEnvelope(const SpectralSummary& s, int z1) : z1_(z1) {
    for (std::size_t n = 1; n * z1 <= s.input_lines.size(); ++n)
      log_p_.push_back(std::log(std::max(s.input_lines[n * z1 - 1], 1e-300)));
  }
  double at(double order) const {
    if (log_p_.empty()) return 0.0;
    const double x = order / z1_ - 1.0;
    if (x <= 0) {
      // Below the first harmonic the path keeps falling as it does from harmonic 2 to 1 (the casing
      // response to a transmission error falls steeply below the first modes), in log-log.
      const double slope = log_p_.size() > 1 ? std::clamp((log_p_[1] - log_p_[0]) / std::log(2.0), 0.0, 8.0) : 0.0;
      return std::exp(log_p_.front() + slope * std::log(std::max(order, 1e-3) / z1_));
    }
    const auto i = static_cast<std::size_t>(x);
    if (i + 1 >= log_p_.size()) return std::exp(log_p_.back());
    const double t = x - static_cast<double>(i);
    return std::exp((1 - t) * log_p_[i] + t * log_p_[i + 1]);
  }

 private:
  int z1_;
  std::vector<double> log_p_;
};

/// J0, by its series where the index is small (most lines: the library's is slow, and this form
/// asks for it at every line of every record at every trial value).
double bessel_j0(double z) {
  const double q = z * z / 4.0;
  if (q < 0.01) return 1.0 - q + q * q / 4.0 - q * q * q / 36.0;  // next term q⁴/576 < 2e-11
  return std::cyl_bessel_j(0.0, z);
}

/// dsp::tracking_residual_share read off a table in log x: each call simulates 400 revolutions of
/// tacho edges (3 ms), and the speed-fluctuation form asks at every record and trial frequency.
/// Below the table it falls as x⁴ (the cubic spline's error for a slow deviation); above x = 2 the
/// edges hold only an alias and the share is 1.
double tracking_residual(double x) {
  constexpr double kLow = 0.01, kHigh = 2.0;
  constexpr int kPoints = 131;
  static const std::vector<double> log_share = [] {
    std::vector<double> t;
    for (int i = 0; i < kPoints; ++i)
      t.push_back(std::log(dsp::tracking_residual_share(kLow * std::pow(kHigh / kLow, static_cast<double>(i) / (kPoints - 1)))));
    return t;
  }();
  if (!(x > 0)) return 0.0;
  if (x > kHigh) return 1.0;
  if (x <= kLow) return std::exp(log_share.front()) * std::pow(x / kLow, 4);
  const double u = std::log(x / kLow) / std::log(kHigh / kLow) * (kPoints - 1);
  const auto i = std::min(static_cast<std::size_t>(u), static_cast<std::size_t>(kPoints - 2));
  const double w = u - static_cast<double>(i);
  return std::exp((1 - w) * log_share[i] + w * log_share[i + 1]);
}

}  // namespace

double speed_fluctuation_input_order(const std::vector<double>& values) noexcept {
  return values.size() > 3 && values[3] > 0 && std::isfinite(values[3]) ? values[3] : 0.0;
}

namespace {

/// One effect's form applied to the spectra `s`, starting from `twin` (the twin's spectra with the
/// effects of the earlier stages): a step per family of forms.
class EffectApplier {
 public:
  EffectApplier(const AppliedEffect& e, const SpectralSummary& twin, SpectralSummary& s, const GearPairSpec& gears)
      : e_(e), v_(e.values), twin_(twin), s_(s), gears_(gears), z1_(gears.pinion_teeth), z2_(gears.gear_teeth),
        out_speed_(s.speed_hz * z1_ / z2_) {}

  void apply() {
    switch (e_.effect) {
      case CandidateEffect::casing_mode:
      case CandidateEffect::mount_resonance: return resonance();
      case CandidateEffect::noise_floor: return noise_floor();
      case CandidateEffect::eccentricity:
        if (twin_.run_out_response) return run_out_through_twin(*twin_.run_out_response);
        return run_out_sidebands();
      case CandidateEffect::tooth_errors: return tooth_errors();
      case CandidateEffect::speed_fluctuation:
      case CandidateEffect::load_fluctuation: return fluctuation();
      case CandidateEffect::tip_relief:
        return mesh_gain([&](int n) { return static_cast<std::size_t>(n) <= v_.size() ? v_[static_cast<std::size_t>(n - 1)] : 0.0; });
      case CandidateEffect::misalignment: return mesh_gain([&](int) { return v_[0]; });
      case CandidateEffect::backlash: return mesh_gain([&](int n) { return v_[0] * n; });
    }
  }

 private:
  /// A gain in dB on each mesh harmonic n (the forms that change the mesh force's harmonics).
  template <class GainDb>
  void mesh_gain(GainDb gain_db_of_harmonic) {
    for (std::size_t n = 1; n * z1_ <= s_.input_lines.size(); ++n)
      s_.input_lines[n * z1_ - 1] *= std::pow(10.0, gain_db_of_harmonic(static_cast<int>(n)) / 10.0);
  }

  /// The power gain of the casing's modes or of the mount's resonance at f Hz.
  double resonance_gain(const BearingForcePath* path, double f) const {
    return e_.effect == CandidateEffect::casing_mode ? casing_modes_gain(path->at(f), f, v_[0], v_[1], v_[2], v_[3])
                                                     : transmissibility_power(f, v_[0], v_[1]);
  }

  void resonance() {
    const BearingForcePath* path = twin_.bearing_force_path.get();
    if (e_.effect == CandidateEffect::casing_mode && path == nullptr)
      throw std::invalid_argument("casing_mode needs the twin's bearing-force path on its spectra");
    // A bin 120 dB under the twin's total stays under the comparison's floor (60 dB down) unless
    // the casing lifts it a thousandfold in amplitude, when the strong lines beside it say so to
    // the fit already. The noise-free twin has most of its bins there; skipping them saves work.
    const double total = total_input_line_power(twin_);
    const double too_small_to_move = 1e-12 * total;
    auto scale = [&](double& power, double f) {
      if (power > too_small_to_move) power *= resonance_gain(path, f);
    };
    for (std::size_t k = 1; k <= s_.input_lines.size(); ++k) {
      scale(s_.input_lines[k - 1], k * s_.speed_hz);
      // The broadband bin holds orders [k, k + 1).
      scale(s_.broadband[k - 1], (k + 0.5) * s_.speed_hz);
    }
    for (std::size_t m = 1; m <= s_.output_lines.size(); ++m) scale(s_.output_lines[m - 1], m * out_speed_);
  }

  void noise_floor() {
    // A white floor of one-sided PSD S is white in Hz, not in orders: a bin one shaft order wide
    // is `speed` Hz wide and holds 2·S·speed (peak-amplitude² convention, as a tone of amplitude A
    // holds A²). A synchronous line is the mean of R one-revolution DFTs, each bin a shaft order
    // wide; the output shaft's orders are z1/z2 as wide in Hz as the input's.
    const double per_input_order = noise_floor_per_order_bin(v_[0], s_.speed_hz);
    for (auto& b : s_.broadband) b += per_input_order;
    for (auto& p : s_.input_lines) p += per_input_order / std::max(1.0, s_.input_line_averages);
    const double per_output_order = noise_floor_per_order_bin(v_[0], out_speed_);
    for (std::size_t m = 1; m <= s_.output_lines.size(); ++m)
      if (m % static_cast<std::size_t>(z2_) != 0)
        s_.output_lines[m - 1] += per_output_order / std::max(1.0, s_.output_line_averages);
  }

  /// The twin's own response to each run-out, line by line (lower and upper sidebands apart, each
  /// through the twin's dynamics at its own frequency). A run-out e at phase φ changes line k by
  /// e·(cos φ·R0 + sin φ·R1); its power, over the phase the lines' powers cannot tell, is
  /// e²·(|R0|² + |R1|²)/2, and its cross term with the twin's own line averages out.
  void run_out_through_twin(const RunOutResponse& r) {
    add_run_out_response(s_.input_lines, r.input_per_m, false);
    add_run_out_response(s_.output_lines, r.output_per_m, true);
  }

  void add_run_out_response(std::vector<double>& lines, const std::array<std::vector<std::complex<double>>, 4>& per_m,
                            bool output) const {
    std::size_t n = lines.size();
    for (const auto& d : per_m) n = std::min(n, d.size());
    const double pinion = v_[0] * v_[0] / 2, gear = v_[1] * v_[1] / 2;
    for (std::size_t k = 0; k < n; ++k) {
      if (output && output_line_is_mesh(static_cast<int>(k + 1), z2_)) continue;
      lines[k] += pinion * (std::norm(per_m[0][k]) + std::norm(per_m[1][k])) +
                  gear * (std::norm(per_m[2][k]) + std::norm(per_m[3][k]));
    }
  }

  /// A run-out is a once-per-revolution transmission error: it modulates the mesh force (AM, the
  /// same share at every harmonic) and turns the pinion against the tacho (PM of index n·b at
  /// harmonic n, as the mesh phase is n·z1 times the pinion's angle). The mean of a modulated
  /// line's two first sidebands is ((a² + (n·b)²)/4)·P(n·GMF), whatever the phase between them.
  static double run_out_sideband_share(const RunOutSensitivity& r, double run_out_m, std::size_t n) {
    const double am = r.am_per_m * run_out_m, pm = r.pm_per_harmonic_per_m * run_out_m * static_cast<double>(n);
    return (am * am + pm * pm) / 4.0;
  }

  void run_out_sidebands() {
    for (std::size_t n = 1; n * z1_ <= twin_.input_lines.size(); ++n) {
      const double mesh_power = twin_.input_lines[n * z1_ - 1];
      const double ai = run_out_sideband_share(twin_.pinion_run_out, v_[0], n);
      const double ao = run_out_sideband_share(twin_.gear_run_out, v_[1], n);
      for (int side : {-1, 1}) {
        const auto ki = static_cast<std::ptrdiff_t>(n * z1_) + side;
        if (ki >= 1 && ki <= static_cast<std::ptrdiff_t>(s_.input_lines.size())) s_.input_lines[ki - 1] += ai * mesh_power;
        const auto ko = static_cast<std::ptrdiff_t>(n * z2_) + side;
        if (ko >= 1 && ko <= static_cast<std::ptrdiff_t>(s_.output_lines.size())) s_.output_lines[ko - 1] += ao * mesh_power;
      }
    }
  }

  void tooth_errors() {
    const MeshEnvelope env(twin_, z1_);
    for (std::size_t k = 1; k <= s_.input_lines.size(); ++k)
      if (k % static_cast<std::size_t>(z1_) != 0) s_.input_lines[k - 1] += v_[0] * env.at(static_cast<double>(k));
    for (std::size_t m = 1; m <= s_.output_lines.size(); ++m)
      if (m % static_cast<std::size_t>(z2_) != 0) s_.output_lines[m - 1] += v_[1] * env.at(static_cast<double>(m) * z1_ / z2_);
    // The pairing of pinion and gear teeth repeats only after z1·z2 meshes (the hunting period):
    // what the pairs add together is synchronous with neither shaft and stays in the residual,
    // through the same transfer path.
    for (std::size_t k = 1; k <= s_.broadband.size(); ++k) s_.broadband[k - 1] += v_[2] * env.at(static_cast<double>(k) + 0.5);
  }

  /// A speed ripple of depth d at f_m turns the shaft d/x rad ahead and back (x = f_m over the
  /// shaft's speed); the one-edge tacho follows all but the share r(x) of that angle, which stays
  /// in the tracked signal as a phase modulation of index order·(d/x)·r(x). On top, a share μ of
  /// every line is amplitude-modulated (ripple_am_share). The load ripple's form is one phase
  /// modulation growing with order, a share 1 − exp(−(β·order)²).
  struct ModulatedShare {
    bool speed;
    double pm_per_order, mu;
    const std::vector<double>& v;
    double operator()(double order) const {
      if (!speed) return 1.0 - std::exp(-(v[0] * order) * (v[0] * order));
      const double carrier = bessel_j0(pm_per_order * order);
      return 1.0 - (1.0 - mu) * carrier * carrier;
    }
  };

  /// The share μ of every line a speed ripple amplitude-modulates (the third value): the transfer
  /// path in Hz sees the speed change. A ripple whose phase part is nil is no speed ripple (the
  /// choice rule in diagnosis.cpp): a pure AM is the shaft-order load ripple's.
  double ripple_am_share() const { return v_.size() > 2 ? v_[2] : 0.0; }

  /// A modulation locked to a shaft's order x (in input orders): PM index pm_per_order·order, and a
  /// share am_share of each line amplitude-modulated.
  struct LockedModulation {
    double pm_per_order, am_share, input_order;
  };

  /// The powers below which a line is left alone and a moved tone is dropped.
  struct MoveThresholds {
    double too_small_to_move, negligible;
  };

  void fluctuation() {
    const bool speed = e_.effect == CandidateEffect::speed_fluctuation;
    const double locked_order = speed_fluctuation_input_order(v_);
    if (!speed && locked_order > 0) return load_ripple_at_shaft_order(locked_order);
    const double x = locked_order > 0 ? locked_order : v_[1] / s_.speed_hz;
    const double pm_per_order = speed ? v_[0] / x * tracking_residual(x) : 0.0;
    const ModulatedShare share{speed, pm_per_order, speed ? ripple_am_share() : 0.0, v_};
    // The family comparison floors lines 60 dB below the twin's total (DiagnosisSettings::floor_db);
    // a tone 10 dB below that cannot lift a line off the floor even if all of it landed there, and
    // following a tone through both averages is most of this form's cost.
    const double total = total_input_line_power(twin_);
    // A line 90 dB below the total cannot move a bin: all of it in one bin at the floor (60 dB
    // down) is 0.004 dB. The twin has no noise, so most of its lines are that far down.
    const MoveThresholds limits{1e-9 * total, 1e-7 * total};
    if (locked_order > 0) {
      const bool input_locked = std::abs(x - 1.0) < 1e-12;
      spread_over_sidebands(s_.input_lines, twin_.input_lines, 1, 1, {share.pm_per_order, share.mu, x}, limits, input_locked);
      spread_over_sidebands(s_.output_lines, twin_.output_lines, z1_, z2_, {share.pm_per_order, share.mu, x}, limits,
                            !input_locked);
      return;
    }
    move_to_sidebands(s_.input_lines, twin_.input_lines, 1, 1, share, x, limits);
    move_to_sidebands(s_.output_lines, twin_.output_lines, z1_, z2_, share, x, limits);
  }

  /// A ripple locked to a shaft's order (once per revolution of that shaft, whatever the speed):
  /// line k of order o is phase-modulated with index m = o·(d/x)·r(x), and by Jacobi–Anger holds
  /// J_j(m)² of its power j·x orders away (x the ripple's input order, r(x) what the tacho's edges
  /// leave of it; for the input shaft x = 1, which one edge per revolution meets at one phase, r = 1).
  /// The AM share μ sends μ/2 to each first sideband. The sidebands are whole orders of the shaft the
  /// ripple follows, so they land on that shaft's lines. Assumption: the line's phase and the
  /// ripple's are independent (powers add where sidebands of neighbouring lines meet).
  void spread_over_sidebands(std::vector<double>& lines, const std::vector<double>& twin_lines, int num, int den,
                             const LockedModulation& mod, const MoveThresholds& limits, bool own_shaft) {
    const double pm_per_order = mod.pm_per_order, mu = mod.am_share, x = mod.input_order;
    std::vector<double> jn;  // J_0 … J_K of the line at hand, reused from line to line
    for (std::size_t k = 1; k <= lines.size(); ++k) {
      const double power = twin_lines[k - 1];
      if (!(power > limits.too_small_to_move)) continue;
      const double order = static_cast<double>(k) * num / den;
      const double index = pm_per_order * order;
      bessel_j_up_to(1 + static_cast<int>(std::min(index + 3.0, 64.0)), index, jn);
      lines[k - 1] -= power * (1.0 - (1.0 - mu) * jn[0] * jn[0]);
      for (std::size_t j = 1; j < jn.size(); ++j) {
        const double p = power * ((1.0 - mu) * jn[j] * jn[j] + (j == 1 ? mu / 2 : 0.0));
        if (j > 1 && p < limits.negligible * 1e-3) break;
        for (int side : {-1, 1}) {
          // On a whole order of the shaft the ripple follows, the tone is that shaft's line (its
          // synchronous average takes all of it; an output order a multiple of z2 is read on the
          // input side; the input average's share of an output order, under 1/(π·R·Δ)², is left
          // out); elsewhere it is followed through both averages.
          const auto m = static_cast<std::ptrdiff_t>(k) + side * static_cast<std::ptrdiff_t>(j);
          if (own_shaft) add_to_line(num == den, m, p);
          else add_non_synchronous_tone(s_, order + side * static_cast<double>(j) * x, p, gears_, limits.negligible);
        }
      }
    }
  }

  /// The modulated share leaves line k (order k·num/den) for sidebands f_m away (in orders: f_m /
  /// speed), half each side (x orders away); being off the integer orders they land mostly in the
  /// broadband part, and partly in the neighbouring lines (a few dB on sidebands 40 dB below a
  /// mesh harmonic).
  void move_to_sidebands(std::vector<double>& lines, const std::vector<double>& twin_lines, int num, int den,
                         const ModulatedShare& share, double x, const MoveThresholds& limits) {
    for (std::size_t k = 1; k <= lines.size(); ++k) {
      const double power = twin_lines[k - 1];
      if (!(power > limits.too_small_to_move)) continue;
      const double order = static_cast<double>(k) * num / den;
      const double moved = power * share(order);
      lines[k - 1] -= moved;
      add_non_synchronous_tone(s_, order - x, moved / 2, gears_, limits.negligible);
      add_non_synchronous_tone(s_, order + x, moved / 2, gears_, limits.negligible);
    }
  }

  /// A load ripple locked to a shaft's order x (in input orders): once a revolution of that shaft the
  /// mesh force rises and falls by the share m (a bent shaft, a misaligned coupling, an eccentric
  /// load). The twin's vibration is the mesh's response, in proportion to its force, so every line
  /// is x(t)·(1 + m·cos(2π·x·θ)): the carrier stays, each first sideband x away gets m²/4 of its
  /// power, and no phase part (the encoder's angle is the shaft's). Broadband bins, smooth over the
  /// orders a sideband moves them, keep their place and gain m²/2.
  void load_ripple_at_shaft_order(double x) {
    const double m = v_.size() > 2 ? v_[2] : 0.0, side_share = m * m / 4.0;
    const bool input_locked = std::abs(x - 1.0) < 1e-12;
    const double total = total_input_line_power(twin_);
    const MoveThresholds limits{1e-9 * total, 1e-7 * total};
    auto sidebands = [&](const std::vector<double>& twin_lines, int num, int den, bool own_shaft) {
      for (std::size_t k = 1; k <= twin_lines.size(); ++k) {
        if (!(twin_lines[k - 1] > limits.too_small_to_move)) continue;
        const double p = twin_lines[k - 1] * side_share;
        const double order = static_cast<double>(k) * num / den;
        for (int side : {-1, 1}) {
          if (own_shaft) add_to_line(num == den, static_cast<std::ptrdiff_t>(k) + side, p);
          else add_non_synchronous_tone(s_, order + side * x, p, gears_, limits.negligible);
        }
      }
    };
    sidebands(twin_.input_lines, 1, 1, input_locked);
    sidebands(twin_.output_lines, z1_, z2_, !input_locked);
    for (std::size_t k = 0; k < s_.broadband.size() && k < twin_.broadband.size(); ++k)
      s_.broadband[k] += twin_.broadband[k] * 2 * side_share;
  }

  /// Power on whole order m of the input (or output) shaft's lines; nothing at or below order 0.
  void add_to_line(bool input, std::ptrdiff_t m, double power) {
    if (m < 1) return;
    if (!input && m % z2_ == 0) return add_to_line(true, m / z2_ * z1_, power);
    auto& lines = input ? s_.input_lines : s_.output_lines;
    if (m <= static_cast<std::ptrdiff_t>(lines.size())) lines[static_cast<std::size_t>(m - 1)] += power;
  }

  const AppliedEffect& e_;
  const std::vector<double>& v_;
  const SpectralSummary& twin_;
  SpectralSummary& s_;
  const GearPairSpec& gears_;
  const int z1_, z2_;
  const double out_speed_;
};

void apply_one(const AppliedEffect& e, const SpectralSummary& twin, SpectralSummary& s, const GearPairSpec& gears) {
  EffectApplier(e, twin, s, gears).apply();
}

}  // namespace

std::shared_ptr<const BearingForcePath> bearing_force_path(const twin::GearboxMatrices& matrices, double highest_hz) {
  if (!(highest_hz > 1.0) || !std::isfinite(highest_hz))
    throw std::invalid_argument("bearing-force path: the highest frequency must be finite and above 1 Hz");
  // The casing carries the bearings through their grounded springs; the vertical ones act on the
  // vertical sensor (the twin's record is ÿ6). The structural springs join vertical DOFs only to
  // vertical DOFs or the ground, so the vertical rows of K q sum to the grounded springs' forces
  // (a spring between two of them adds +k(a − b) to one row and −k(a − b) to the other).
  const Eigen::Matrix<std::complex<double>, 1, twin::kDofCount> grounded_vertical =
      matrices.stiffness.middleRows(twin::y4, twin::y11 - twin::y4 + 1).colwise().sum().cast<std::complex<double>>();
  constexpr double kLowestHz = 1.0, kPointsPerOctave = 96.0;
  const auto points = static_cast<std::size_t>(std::ceil(kPointsPerOctave * std::log2(highest_hz / kLowestHz))) + 1;
  std::vector<std::complex<double>> ratio(points);
  for (std::size_t i = 0; i < points; ++i) {
    const auto q = twin::transmission_error_response(matrices, kLowestHz * std::exp2(static_cast<double>(i) / kPointsPerOctave));
    const std::complex<double> force = grounded_vertical * q;
    // A sensor DOF at rest (an antiresonance of ÿ6) leaves the line at the floor whatever the gain.
    ratio[i] = std::abs(q[twin::y6]) > 0 ? force / q[twin::y6] : std::complex<double>(0.0);
  }
  return std::make_shared<const BearingForcePath>(kLowestHz, kPointsPerOctave, std::move(ratio));
}

CasingModeTerm::CasingModeTerm(double mode_hz, double damping_ratio, double modal_mass_kg, double residue_phase_rad) noexcept
    : wc2_(std::pow(2.0 * std::numbers::pi * mode_hz, 2)),
      two_zeta_wc_(2.0 * damping_ratio * 2.0 * std::numbers::pi * mode_hz),
      residue_(std::polar(1.0 / modal_mass_kg, residue_phase_rad)) {}

std::complex<double> CasingModeTerm::operator()(std::complex<double> bearing_force_ratio, double f_hz) const noexcept {
  // η̈c + 2ζωc η̇c + ωc² ηc = F/m for the mode, the sensor reading ÿ6 + η̈c: relative to ÿ6 = −ω² y6,
  // η̈c / ÿ6 = (F/y6)/m · 1/(ωc² − ω² + 2iζωcω), the residue's phase on top.
  const double w = 2.0 * std::numbers::pi * f_hz;
  const double re = wc2_ - w * w, im = two_zeta_wc_ * w;
  const std::complex<double> inverse(re / (re * re + im * im), -im / (re * re + im * im));
  return residue_ * bearing_force_ratio * inverse;
}

double casing_modes_gain(std::complex<double> bearing_force_ratio, double f_hz, double mode1_hz, double mode2_hz,
                         double damping_ratio, double modal_mass_kg) noexcept {
  const CasingModeTerm first(mode1_hz, damping_ratio, modal_mass_kg), second(mode2_hz, damping_ratio, modal_mass_kg);
  return std::norm(1.0 + first(bearing_force_ratio, f_hz) + second(bearing_force_ratio, f_hz));
}

RunOutSensitivity run_out_sensitivity(const twin::GearboxMatrices& matrices, const GearPairSpec& gears, bool gear_shaft,
                                      double input_speed_hz, double torque_nm) {
  if (!std::isfinite(input_speed_hz) || input_speed_hz <= 0)
    throw std::invalid_argument("run-out sensitivity: the input speed must be positive and finite");
  const double ratio = gear_shaft ? static_cast<double>(gears.pinion_teeth) / gears.gear_teeth : 1.0;
  const auto q = twin::transmission_error_response(matrices, ratio * input_speed_hz);
  RunOutSensitivity r;
  const double pinion_base_radius = matrices.mesh[twin::theta5];
  if (std::isfinite(torque_nm) && torque_nm > 0 && pinion_base_radius > 0) {
    const double mean_deflection = torque_nm / pinion_base_radius / matrices.mean_mesh_stiffness;
    r.am_per_m = std::abs(matrices.mesh.cast<std::complex<double>>().dot(q) + 1.0) / mean_deflection;
  }
  // Above the tacho shaft's own order the edges hold only an alias and the share is 1 (to 5e-4 up to
  // 16 orders); a gear turning faster than that (a 16:1 step-up) is taken at 16.
  r.pm_per_harmonic_per_m =
      gears.pinion_teeth * std::abs(q[twin::theta5]) * dsp::tracking_residual_share(std::min(ratio, 16.0));
  return r;
}

double noise_floor_per_order_bin(double psd_per_hz, double shaft_speed_hz) noexcept { return 2.0 * psd_per_hz * shaft_speed_hz; }

double load_key(double torque_nm) noexcept { return std::isfinite(torque_nm) ? std::round(torque_nm * 100) / 100 : -1.0; }

std::vector<double> values_at_load(const CandidateForm& form, const std::vector<double>& values, double torque_nm) {
  if (!form.per_load) return values;
  const std::size_t group = form.parameters.size() + 1;
  if (values.size() < group) return {};
  const double load = load_key(torque_nm);
  std::size_t first = 0;
  for (std::size_t g = 0; g + group <= values.size(); g += group)
    if (std::abs(values[g] - load) < std::abs(values[first] - load)) first = g;
  return {values.begin() + static_cast<std::ptrdiff_t>(first + 1), values.begin() + static_cast<std::ptrdiff_t>(first + group)};
}

std::vector<std::string> parameter_names(const CandidateForm& form, const std::vector<double>& values) {
  std::vector<std::string> names;
  if (form.per_load) {
    const std::size_t group = form.parameters.size() + 1;
    for (std::size_t i = 0; i < values.size(); ++i) {
      const std::string prefix = "load_" + std::to_string(i / group + 1) + "_";
      names.push_back(i % group == 0 ? prefix + "nm" : prefix + form.parameters[i % group - 1].name);
    }
    return names;
  }
  for (std::size_t i = 0; i < values.size(); ++i)
    names.push_back(i < form.parameters.size()                                  ? form.parameters[i].name
                    : i == 3 && (form.effect == CandidateEffect::speed_fluctuation ||
                                 form.effect == CandidateEffect::load_fluctuation)      ? "modulation_input_order"
                                                                                  : "value_" + std::to_string(i));
  return names;
}

std::vector<ParameterBound> parameters_at_bounds(CandidateEffect effect, const std::vector<double>& values,
                                                 double sample_rate_hz, bool rerun) {
  std::vector<ParameterBound> out;
  if (rerun) {
    // The grid's range along each parameter: the fit picks grid points and refines inside the range.
    const auto grid = rerun_grid(effect);
    const auto names = rerun_parameter_names(effect);
    for (std::size_t j = 0; !grid.empty() && j < values.size() && j < grid.front().size() && j < names.size(); ++j) {
      double low = grid.front()[j], high = low;
      for (const auto& g : grid) low = std::min(low, g[j]), high = std::max(high, g[j]);
      if (low == high) continue;
      if (values[j] <= low) out.push_back({names[j], low, false});
      if (values[j] >= high) out.push_back({names[j], high, true});
    }
    return out;
  }
  const CandidateForm form = candidate_form(effect, sample_rate_hz);
  const auto names = parameter_names(form, values);
  const std::size_t group = form.per_load ? form.parameters.size() + 1 : form.parameters.size();
  // The fit clamps its unit coordinate to [0, 1], and its descent stops when its simplex's costs
  // agree, so a fit pressing on an end stops at it or within a sliver of the range: a thousandth of
  // it (the fit's starts lie at least 1/44 of it inside).
  constexpr double kAtEnd = 1e-3;
  for (std::size_t i = 0; i < values.size() && group > 0; ++i) {
    if (!form.per_load && i >= group) break;  // values past the form's (a locked ripple's order) have no range
    const std::size_t within = i % group;
    if (form.per_load && within == 0) continue;
    const std::size_t k = form.per_load ? within - 1 : within;
    if (k >= form.parameters.size()) continue;
    const auto& par = form.parameters[k];
    const double u = par.log_scale ? (std::log(values[i]) - std::log(par.low)) / (std::log(par.high) - std::log(par.low))
                                   : (values[i] - par.low) / (par.high - par.low);
    if (!std::isfinite(u)) continue;
    if (u <= kAtEnd) out.push_back({names[i], par.low, false});
    if (u >= 1 - kAtEnd) out.push_back({names[i], par.high, true});
  }
  return out;
}

std::vector<std::vector<double>> rerun_grid(CandidateEffect effect) {
  std::vector<std::vector<double>> grid;
  if (effect == CandidateEffect::misalignment)
    for (int i = 0; i < 9; ++i) grid.push_back({0.01e-3 * std::pow(100.0, i / 8.0)});  // rad
  if (effect == CandidateEffect::tip_relief)
    for (double amount_um : {2.0, 4.0, 8.0, 16.0, 32.0})
      for (double length : {0.1, 0.2, 0.4}) grid.push_back({amount_um * 1e-6, length});
  return grid;
}

void add_rerun_effect(CandidateEffect effect, const std::vector<double>& values, twin::ToothProfileDeviation& profile,
                      twin::SimulationOptions& options) {
  const auto names = rerun_parameter_names(effect);
  if (names.empty()) throw std::invalid_argument(std::string("no twin rerun for ") + to_string(effect));
  if (values.size() != names.size())
    throw std::invalid_argument(std::string("twin rerun for ") + to_string(effect) + ": " + std::to_string(names.size()) +
                                " values expected, got " + std::to_string(values.size()));
  if (effect == CandidateEffect::misalignment) options.face_misalignment_rad = values[0];
  if (effect == CandidateEffect::eccentricity) options.shaft_run_out = {values[0], values[2], values[1], values[3]};
  if (effect == CandidateEffect::tip_relief) profile = twin::with_linear_tip_relief(profile, values[0], values[1]);
}

std::vector<double> rerun_grid_ratios(CandidateEffect effect) {
  // Read off the grid itself, so the refinement's step follows any change of the grid.
  const auto grid = rerun_grid(effect);
  std::vector<double> ratios;
  for (std::size_t j = 0; !grid.empty() && j < grid.front().size(); ++j) {
    std::set<double> along;
    for (const auto& point : grid) along.insert(point[j]);
    ratios.push_back(along.size() > 1 ? *std::next(along.begin()) / *along.begin() : 1.0);
  }
  return ratios;
}

std::vector<std::string> rerun_parameter_names(CandidateEffect effect) {
  if (effect == CandidateEffect::misalignment) return {"angle_rad"};
  if (effect == CandidateEffect::tip_relief) return {"amount_m", "length_fraction"};
  if (effect == CandidateEffect::eccentricity) return {"pinion_run_out_m", "gear_run_out_m", "pinion_phase_rad", "gear_phase_rad"};
  return {};
}

std::array<std::vector<double>, 5> run_out_response_reruns() {
  const double u = kRunOutResponseUnitM, quarter = std::numbers::pi / 2;
  return {{{0.0, 0.0, 0.0, 0.0}, {u, 0.0, 0.0, 0.0}, {u, 0.0, quarter, 0.0}, {0.0, u, 0.0, 0.0}, {0.0, u, 0.0, quarter}}};
}

int tip_relief_harmonics(double sample_rate_hz) {
  // Harmonics below 0.45·fs at 1 Hz input speed with 19 teeth would be thousands; the gains are
  // only fitted where a training record has the harmonic, so bound the list at what a 2 Hz record
  // (the thesis's slowest step) holds for a 19-tooth pinion.
  return std::max(1, static_cast<int>(0.45 * sample_rate_hz / (2.0 * 19.0)));
}

CandidateForm candidate_form(CandidateEffect effect, double sample_rate_hz) {
  const double top = 0.45 * sample_rate_hz;
  switch (effect) {
    case CandidateEffect::casing_mode:
      // Foundation modes from 10 Hz to the band's top (the thesis's Table 5.4 lists them at 13–1714 Hz),
      // light damping to ζ = 0.2, a modal mass from a bracket to a bedplate.
      return {effect,
              {{"mode1_hz", 10.0, top, true, 8},
               {"mode2_hz", 10.0, top, true, 8},
               {"damping_ratio", 0.002, 0.2, true, 2},
               {"modal_mass_kg", 0.1, 1000.0, true, 3}},
              {FK::fixed_frequency, FK::mesh_harmonics, FK::input_sidebands, FK::output_sidebands, FK::broadband,
               FK::input_shaft_orders, FK::output_shaft_orders},
              2,
              false,
              true};
    case CandidateEffect::mount_resonance:
      return {effect,
              {{"frequency_hz", std::min(5000.0, top), std::max(6000.0, 1.5 * sample_rate_hz), true, 16},
               {"damping_ratio", 0.005, 0.3, true, 4}},
              {FK::fixed_frequency, FK::mesh_harmonics, FK::input_sidebands, FK::output_sidebands, FK::broadband},
              2};
    case CandidateEffect::noise_floor:
      return {effect,
              {{"psd_per_hz", 1e-18, 1e3, true, 22}},
              {FK::broadband, FK::input_shaft_orders, FK::output_shaft_orders, FK::input_sidebands,
               FK::output_sidebands},
              3};
    case CandidateEffect::eccentricity:
      // Run-outs from a tenth of a micrometre (nothing shows) to 0.3 mm (a bent shaft).
      return {effect,
              {{"pinion_run_out_m", 1e-7, 3e-4, true, 7}, {"gear_run_out_m", 1e-7, 3e-4, true, 7}},
              {FK::input_sidebands, FK::output_sidebands},
              0};
    case CandidateEffect::tooth_errors:
      return {effect,
              {{"input_line_gain", 1e-9, 1e3, true, 8}, {"output_line_gain", 1e-9, 1e3, true, 8},
               {"residual_gain", 1e-9, 1e3, true, 6}},
              {FK::input_shaft_orders, FK::output_shaft_orders, FK::input_sidebands, FK::output_sidebands},
              0,
              true};
    case CandidateEffect::speed_fluctuation:
      return {effect,
              {{"depth", 1e-4, 0.1, true, 8}, {"modulation_frequency_hz", 0.1, 20, true, 16}, {"am_share", 1e-5, 0.99, true, 2}},
              {FK::broadband, FK::mesh_harmonics, FK::input_sidebands, FK::output_sidebands}, 1};
    case CandidateEffect::load_fluctuation:
      // The AM index of a load ripple locked to a shaft's order (the third value; the first two then
      // 0): from half a percent of the mean mesh force, under what a line comparison shows, to half
      // of it, beyond which the teeth near unloading once a revolution (contact loss: backlash's).
      return {effect,
              {{"phase_deviation_per_order_rad", 1e-5, 0.5, true, 12}, {"modulation_frequency_hz", 0.1, 20, true, 16},
               {"am_index", 5e-3, 0.5, true, 6}},
              {FK::broadband, FK::mesh_harmonics, FK::input_sidebands, FK::output_sidebands}, 1};
    case CandidateEffect::tip_relief: {
      // One gain per mesh harmonic the band holds at the slowest speed the diagnosis accepts
      // (the fit leaves harmonics no training record reaches at 0 dB).
      CandidateForm f{effect, {}, {FK::mesh_harmonics}, 0, true};
      for (int n = 1; n <= tip_relief_harmonics(sample_rate_hz); ++n)
        f.parameters.push_back({"harmonic_" + std::to_string(n) + "_gain_db", -60, 60, false, 1});
      return f;
    }
    case CandidateEffect::misalignment:
      // The spectral fallback acts on the mesh harmonics only; the rerun twin's stiffer-with-load
      // mesh also moves the mesh resonance, which stays in Hz.
      return {effect, {{"mesh_gain_db", -40, 40, false, 17}}, {FK::mesh_harmonics, FK::fixed_frequency}, 0};
    case CandidateEffect::backlash:
      return {effect, {{"gain_db_per_harmonic", 0.0, 3.0, false, 16}}, {FK::mesh_harmonics}, 0};
  }
  throw std::invalid_argument("unknown candidate effect");
}

SpectralSummary apply_effects(const std::vector<AppliedEffect>& effects, const SpectralSummary& twin,
                              const GearPairSpec& gears) {
  std::vector<const AppliedEffect*> order;
  for (const auto& e : effects) order.push_back(&e);
  std::stable_sort(order.begin(), order.end(), [&](const AppliedEffect* a, const AppliedEffect* b) {
    return candidate_form(a->effect, twin.sample_rate_hz).stage < candidate_form(b->effect, twin.sample_rate_hz).stage;
  });
  SpectralSummary s = twin;
  for (const AppliedEffect* e : order) {
    const SpectralSummary before = s;
    const auto form = candidate_form(e->effect, twin.sample_rate_hz);
    if (form.per_load) apply_one({e->effect, values_at_load(form, e->values, twin.torque_nm)}, before, s, gears);
    else apply_one(*e, before, s, gears);
  }
  return s;
}

}  // namespace gearwatch::gap
