#include "gearwatch/gap/describe.hpp"
#include "gearwatch/gap/unit_tone.hpp"

#include "gearwatch/dsp/window.hpp"
#include "gearwatch/gap/bessel.hpp"
#include "gearwatch/gap/binned.hpp"
#include "gearwatch/gap/candidates.hpp"
#include "gearwatch/numeric/line_search.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <numeric>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

namespace gearwatch::gap {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kUnitToneSamplesPerCycle = 20;  // the angular resampler's interpolation stays exact for a tone this oversampled
constexpr int kMaxTones = 8;  // tones one feature fixed in Hz may hold (a supply's harmonics, a fan's)
// A tone's leakage is followed at most this many input orders each side (a window wider than that
// holds several tones, each followed over its own neighbourhood).
constexpr double kMaxToneReachOrders = 12;

// 10·log10(x) = (10 / ln 10)·ln(x): the searches' inner sums take ln, log10 being ln and more.
constexpr double kDbPerNeper = 10.0 / std::numbers::ln10;

double ratio_db(double measured, double model, double floor) { return 10.0 * std::log10((measured + floor) / (model + floor)); }

// Cells a level-and-slope law in dB acts on: position x (a log frequency or order), the twin's power,
// the measured g and the comparison's floor.
using FloorPoint = std::tuple<double, double, double, double>;

// The squared misfit in g of the law level + slope·x applied to the twin, read through the same
// floor as the comparison (so cells the law takes toward the floor are compressed alike).
double rss_through_floor(const std::vector<FloorPoint>& points, double level, double slope) {
  double sum = 0;
  for (const auto& [x, twin, g, floor] : points) {
    const double d = g - ratio_db(twin * std::pow(10.0, (level + slope * x) / 10), twin, floor);
    sum += d * d;
  }
  return sum;
}

/// The minimum of a unimodal f on [lo, hi] by the shared golden-section search, with `iterations`
/// shrinking steps after the first two points; f there goes to `value` when given.
double golden_min(const std::function<double(double)>& f, double lo, double hi, int iterations = 40,
                  double* value = nullptr) {
  const auto best = numeric::golden_section_maximise([&f](double x) { return -f(x); }, lo, hi, 0.0, iterations + 2);
  if (value) *value = -best.value;
  return best.x;
}

/// Least squares of y on [1, x]: (intercept, slope).
std::pair<double, double> line_fit(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  if (n < 2) return {n == 1 ? y[0] : 0.0, 0.0};
  const double mx = std::accumulate(x.begin(), x.end(), 0.0) / n, my = std::accumulate(y.begin(), y.end(), 0.0) / n;
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) sxx += (x[i] - mx) * (x[i] - mx), sxy += (x[i] - mx) * (y[i] - my);
  const double slope = sxx > 0 ? sxy / sxx : 0.0;
  return {my - slope * mx, slope};
}

/// J0's first zero: below it 2·J1(x)/J0(x) rises monotonically from 0 to infinity.
constexpr double kBesselJ0Zero = 2.404825557695773;
/// A phase modulation's index is read on harmonics whose index n·β stays under this: nearer J0's
/// first zero the carrier vanishes and the ratio's inverse is ill-conditioned, beyond it two-valued.
constexpr double kMaxHarmonicPmIndex = 2.0;

/// The first sidebands of a pure phase modulation of index x, each over the carrier: J1(x)/J0(x);
/// the upper one +, the lower one − (e^{i·x·sin θ} = Σ J_k(x)·e^{ikθ}, J_{−1} = −J1), so
/// u − conj(l) = 2·J1(x)/J0(x)·e^{iψ} where AM gives u + conj(l) = m·e^{iφ}.
double pm_sideband_ratio(double x) { return 2 * std::cyl_bessel_j(1.0, x) / std::cyl_bessel_j(0.0, x); }

/// The index x in [0, J0's first zero) whose 2·J1(x)/J0(x) equals `ratio` (bisection: monotone there).
double pm_index_of_ratio(double ratio) {
  if (!(ratio > 0)) return 0.0;
  double lo = 0, hi = kBesselJ0Zero - 1e-9;
  for (int i = 0; i < 80; ++i) {
    const double mid = (lo + hi) / 2;
    (pm_sideband_ratio(mid) < ratio ? lo : hi) = mid;
  }
  return (lo + hi) / 2;
}

/// One mesh harmonic n and its first sidebands of one shaft: the carrier (measured, complex) and
/// each sideband over its own record's carrier, measured and the twin's.
struct ModulatedHarmonic {
  int n;
  std::complex<double> carrier_m, u_m, l_m, u_t, l_t;
  double carrier_power, excess;  ///< measured carrier power; the sidebands' excess power over the twin's
  double twin_carrier_power = 0;
  std::complex<double> twin_carrier;  ///< the twin's carrier (complex, where phases are known)
  /// The measured carrier too stands over the floor (and, with phases, is not zero): its sidebands
  /// can be read over it. A harmonic that is not readable still carries a predicted comb: a PM
  /// whose index n·β passes J0's zeros, or grows large on the high harmonics, takes the measured
  /// carrier under the floor while its sidebands stand far over the twin's.
  bool readable = true;
};

/// The harmonics whose sidebands are read (ModulatedHarmonic::readable).
std::vector<ModulatedHarmonic> readable_only(const std::vector<ModulatedHarmonic>& hs) {
  std::vector<ModulatedHarmonic> out;
  for (const auto& h : hs)
    if (h.readable) out.push_back(h);
  return out;
}

/// The modulation read off the sidebands' phases, the twin's own subtracted: per harmonic
/// u + conj(l) = m·e^{iφ} (AM) and u − conj(l) = 2·J1(nβ)/J0(nβ)·e^{iψ} (PM of the mesh, nβ on
/// harmonic n), so `am` = m·e^{iφ} and `pm` = β·e^{iψ}, carrier-power-weighted means over the
/// harmonics in order while n·β stays under kMaxHarmonicPmIndex, β the larger of the one read so far
/// and `carrier_beta` (the carriers' loss, pm_index_from_carriers: a record whose lowest harmonics
/// are under the floor would otherwise start beyond J0's zero, where the ratio's inverse reads a
/// small index). Returns the weight used (0: none).
double read_modulation_with_phases(const std::vector<ModulatedHarmonic>& hs, double carrier_beta, std::complex<double>& am,
                                   std::complex<double>& pm) {
  using Complex = std::complex<double>;
  Complex sum_a, sum_b;
  double w = 0;
  for (const auto& h : hs) {
    const double n = static_cast<double>(h.n);
    if (n * carrier_beta > kMaxHarmonicPmIndex || (w > 0 && n * std::abs(sum_b) / w > kMaxHarmonicPmIndex)) break;
    const Complex a = (h.u_m + std::conj(h.l_m)) - (h.u_t + std::conj(h.l_t));
    const Complex b = (h.u_m - std::conj(h.l_m)) - (h.u_t - std::conj(h.l_t));
    const Complex beta = std::abs(b) > 0 ? pm_index_of_ratio(std::abs(b)) / n * b / std::abs(b) : Complex{};
    sum_a += h.carrier_power * a, sum_b += h.carrier_power * beta, w += h.carrier_power;
  }
  if (w > 0) am = sum_a / w, pm = sum_b / w;
  return w;
}

/// Harmonics whose index n·β is at most this hold only their own lines near their carrier: the
/// neighbours' sidebands z orders away (J_z(x) at x ≤ 8, z ≥ 19) are under 1e-4 of them.
constexpr double kMaxCarrierIndex = 8.0;
/// Beside J0's zeros the ratio J1/J0 is ill-conditioned: a phase is read only where |J0(nβ)| is over this.
constexpr double kMinCarrierShare = 0.1;

/// With β known (the carriers' loss) and no harmonic under kMaxHarmonicPmIndex to invert, each
/// harmonic n up to kMaxCarrierIndex still gives the PM's phase: u − conj(l) = 2·J1(nβ)/J0(nβ)·e^{iψ},
/// its sign known; and the AM's u + conj(l) = m·e^{iφ} holds at any index. `pm` = β·e^{iψ}, `am` the
/// carrier-power-weighted mean. Returns the weight used (0: none).
double read_phase_with_known_index(const std::vector<ModulatedHarmonic>& hs, double beta, std::complex<double>& am,
                                   std::complex<double>& pm) {
  using Complex = std::complex<double>;
  Complex sum_a, sum_b;
  double w = 0;
  for (const auto& h : hs) {
    const double x = static_cast<double>(h.n) * beta;
    if (x > kMaxCarrierIndex) break;
    if (std::abs(std::cyl_bessel_j(0.0, x)) < kMinCarrierShare) continue;
    const Complex a = (h.u_m + std::conj(h.l_m)) - (h.u_t + std::conj(h.l_t));
    const Complex b = (h.u_m - std::conj(h.l_m)) - (h.u_t - std::conj(h.l_t));
    sum_a += h.carrier_power * a, sum_b += h.carrier_power * (pm_sideband_ratio(x) < 0 ? -b : b), w += h.carrier_power;
  }
  if (w > 0) am = sum_a / w, pm = std::abs(sum_b) > 0 ? beta * sum_b / std::abs(sum_b) : Complex{beta, 0.0};
  return w;
}

/// One record's lines on the shaft a modulation is read on (measured and the twin's; power and,
/// where known, complex), and whether the phases are known.
struct ShaftSpectra {
  const std::vector<double>& lines_m;
  const std::vector<double>& lines_t;
  const std::vector<std::complex<double>>& cm;
  const std::vector<std::complex<double>>& ct;
  bool with_phase;
};

ShaftSpectra shaft_spectra(const DescribedRecord& src, bool input) {
  const auto& m = *src.measured;
  const auto& t = *src.twin;
  const auto& lines_m = input ? m.input_lines : m.output_lines;
  const auto& lines_t = input ? t.input_lines : t.output_lines;
  const auto& cm = input ? src.measured_input : src.measured_output;
  const auto& ct = input ? src.twin_input : src.twin_output;
  const bool with_phase = !src.measured_input.empty() && !src.twin_input.empty() && cm.size() >= lines_m.size() &&
                          ct.size() >= lines_t.size();
  return {lines_m, lines_t, cm, ct, with_phase};
}

/// The mesh harmonics n (carrier at input order n·zp) whose twin's carrier stands above the floor and
/// whose first sidebands (orders n·z ± 1 of the shaft with z teeth) exist in both records; readable
/// where the measured carrier stands above the floor too.
std::vector<ModulatedHarmonic> modulated_harmonics(const DescribedRecord& src, const ShaftSpectra& s, int zp, int z) {
  using Complex = std::complex<double>;
  const auto& m = *src.measured;
  const auto& t = *src.twin;
  std::vector<ModulatedHarmonic> hs;
  for (int n = 1;; ++n) {
    const std::size_t carrier = static_cast<std::size_t>(n * zp) - 1, upper = static_cast<std::size_t>(n * z), lower = upper - 2;
    if (carrier >= m.input_lines.size() || carrier >= t.input_lines.size() || upper >= s.lines_m.size() ||
        upper >= s.lines_t.size())
      break;
    // Both carriers over the floor: each record's sidebands are read over its own carrier, and a
    // twin's carrier at the floor makes its own ratios (subtracted) meaningless.
    const double pc = m.input_lines[carrier];
    if (!(t.input_lines[carrier] > 100 * src.floor)) continue;
    ModulatedHarmonic h{n, {}, {}, {}, {}, {}, pc, s.lines_m[upper] + s.lines_m[lower] - s.lines_t[upper] - s.lines_t[lower],
                        t.input_lines[carrier], {}};
    h.readable = pc > 100 * src.floor;
    if (s.with_phase) {
      const Complex cmc = src.measured_input[carrier], ctc = src.twin_input[carrier];
      if (std::abs(ctc) == 0) continue;
      h.readable = h.readable && std::abs(cmc) > 0;
      h.carrier_m = cmc, h.twin_carrier = ctc, h.u_t = s.ct[upper] / ctc, h.l_t = s.ct[lower] / ctc;
      if (h.readable) h.u_m = s.cm[upper] / cmc, h.l_m = s.cm[lower] / cmc;
    }
    hs.push_back(h);
  }
  return hs;
}

/// One record's modulation: A (AM, common to the harmonics) and B (PM of the first harmonic), or
/// with powers only the index m_eq; its weight; and where each predicted sideband sits.
struct RecordModulation {
  std::complex<double> a, b;
  double am = 0, pm = kNaN, weight = 0;
  std::vector<std::pair<std::size_t, double>> sideband_power;  // (cell index in the record, predicted power)
};

/// Reads a record's modulation off its harmonics (with the phases where known, else from the
/// sidebands' excess power). False: the record holds none to read.
bool read_record_modulation(const std::vector<ModulatedHarmonic>& hs, bool with_phase, double carrier_beta, RecordModulation& p) {
  double w = with_phase ? read_modulation_with_phases(hs, carrier_beta, p.a, p.b) : 0.0;
  if (with_phase && w <= 0 && carrier_beta > 0) w = read_phase_with_known_index(hs, carrier_beta, p.a, p.b);
  double w_all = 0, excess = 0;
  for (const auto& h : hs) w_all += h.carrier_power, excess += h.excess;
  if (w_all <= 0 || (with_phase && w <= 0)) return false;
  if (with_phase) {
    p.weight = w;
    p.am = std::abs(p.a), p.pm = std::abs(p.b);
  } else {
    p.weight = w_all;
    p.am = std::sqrt(std::max(0.0, 2 * excess / w_all));  // both sidebands m²/4 of the carrier
  }
  return true;
}

/// Line k of a mesh harmonic modulated in amplitude by a = m·e^{iφ} and in phase by x·e^{iψ}
/// (x = n·β on harmonic n), over its unmodulated carrier: (1 + m·cos(θ + φ))·e^{i·x·sin(θ + ψ)} =
/// Σ_k c_k·e^{ikθ}, c_k = J_k(x)·e^{ikψ} + a/2·J_{k−1}(x)·e^{i(k−1)ψ} + conj(a)/2·J_{k+1}(x)·e^{i(k+1)ψ}
/// (Jacobi–Anger, J_{−k} = (−1)^k·J_k).
std::complex<double> modulated_line(int k, double x, std::complex<double> a, std::complex<double> unit_psi) {
  auto term = [&](int j) {
    const double jj = (j < 0 && (-j) % 2 == 1 ? -1.0 : 1.0) * std::cyl_bessel_j(static_cast<double>(std::abs(j)), x);
    return jj * std::pow(unit_psi, j);
  };
  return term(k) + a / 2.0 * term(k - 1) + std::conj(a) / 2.0 * term(k + 1);
}

/// A harmonic's measured carrier shows its own modulated carrier C·c0 alone when it stands over the
/// floor, c0 is not near one of J0's zeros, and no neighbour's comb reaches it (harmonic n + 1's
/// lines reach (n + 1)·β + 4 orders from its carrier, zp orders away).
bool carrier_shows_itself(const ModulatedHarmonic& h, std::complex<double> c0, double beta, int zp) {
  return h.readable && std::abs(c0) >= kMinCarrierShare && static_cast<double>(h.n + 1) * beta + 4 < zp;
}

/// The record's mesh angle against the twin's, in input revolutions modulo one tooth: the δ whose
/// rotation 2π·n·zp·δ best aligns the twin's carriers times c0 with the measured carriers that show
/// themselves (weighted by their power; a grid over the tooth, refined). 0 when none does.
double record_mesh_offset(const std::vector<ModulatedHarmonic>& hs, double beta, std::complex<double> a,
                          std::complex<double> unit_psi, int zp) {
  struct Reading {
    double n, phase, weight;
  };
  std::vector<Reading> readings;
  for (const auto& h : hs) {
    const std::complex<double> c0 = modulated_line(0, static_cast<double>(h.n) * beta, a, unit_psi);
    if (carrier_shows_itself(h, c0, beta, zp) && std::abs(h.twin_carrier) > 0)
      readings.push_back({static_cast<double>(h.n), std::arg(h.carrier_m / (c0 * h.twin_carrier)), std::norm(h.carrier_m)});
  }
  if (readings.empty()) return 0.0;
  const double tooth = 1.0 / zp;
  auto misalignment = [&](double delta) {
    double sum = 0;
    for (const auto& r : readings) sum -= r.weight * std::cos(r.phase - 2 * std::numbers::pi * r.n * zp * delta);
    return sum;
  };
  constexpr int kSteps = 360;
  double best = 0, best_value = misalignment(0.0);
  for (int i = 1; i < kSteps; ++i)
    if (const double v = misalignment(tooth * i / kSteps); v < best_value) best_value = v, best = tooth * i / kSteps;
  return golden_min(misalignment, best - tooth / kSteps, best + tooth / kSteps);
}

/// The phase of a harmonic's unmodulated carrier: the measured carrier over c0 where it shows
/// itself (carrier_shows_itself), else the twin's carrier rotated by the record's mesh offset.
std::complex<double> own_carrier_phase(const ModulatedHarmonic& h, std::complex<double> c0, double beta, int zp, double offset) {
  if (carrier_shows_itself(h, c0, beta, zp)) return std::abs(c0) > 0 ? h.carrier_m / c0 : h.carrier_m;
  return h.twin_carrier * std::polar(1.0, 2 * std::numbers::pi * static_cast<double>(h.n) * zp * offset);
}

/// The input lines of a record whose input-synchronous vibration is modulated at the input shaft's
/// order, with phases: every twin line k (its complex value, turned by the record's mesh offset;
/// a mesh carrier's as own_carrier_phase gives it) spread to k + j by c_j(k·β/zp) (modulated_line:
/// a PM re-times the line at index k·β/zp, the mesh harmonic n's nβ being the case k = n·zp; an AM
/// gives it a/2 each side), out to |j| ≤ x + 4, summed. Lines under the floor are kept in place
/// unspread (their spread is under it). `reached`: the lines some spread line reaches.
std::vector<std::complex<double>> retimed_input_lines(const std::vector<ModulatedHarmonic>& hs, const ShaftSpectra& s,
                                                      const RecordModulation& p, int zp, double floor, double offset,
                                                      std::vector<bool>& reached) {
  using Complex = std::complex<double>;
  const std::size_t size = std::min(s.lines_m.size(), s.ct.size());
  const double beta = std::abs(p.b);
  const Complex unit_psi = beta > 0 ? p.b / beta : Complex{1.0, 0.0};
  std::vector<Complex> value(size);
  std::vector<bool> spread(size, false);
  for (std::size_t i = 0; i < size; ++i) {
    value[i] = s.ct[i] * std::polar(1.0, 2 * std::numbers::pi * static_cast<double>(i + 1) * offset);
    spread[i] = std::norm(s.ct[i]) > floor;
  }
  for (const auto& h : hs) {
    const auto i = static_cast<std::size_t>(h.n * zp) - 1;
    if (i >= size) continue;
    const double x = static_cast<double>(h.n) * beta;
    const Complex phase = own_carrier_phase(h, modulated_line(0, x, p.a, unit_psi), beta, zp, offset);
    value[i] = std::abs(phase) > 0 ? std::sqrt(h.twin_carrier_power) * phase / std::abs(phase) : Complex{};
    spread[i] = true;
  }
  std::vector<Complex> out(size);
  reached.assign(size, false);
  // e^{ikψ} for |k| up to the largest reach + 1, looked up by k + top.
  const int top = static_cast<int>(std::ceil(static_cast<double>(size) * beta / zp)) + 5;
  std::vector<Complex> psi_power(static_cast<std::size_t>(2 * top + 1));
  for (int k = -top; k <= top; ++k) psi_power[static_cast<std::size_t>(k + top)] = std::polar(1.0, k * std::arg(unit_psi));
  auto psi = [&](int k) { return psi_power[static_cast<std::size_t>(k + top)]; };
  std::vector<double> j;
  for (std::size_t i = 0; i < size; ++i) {
    if (!spread[i]) continue;
    const double x = static_cast<double>(i + 1) * beta / zp;
    const int reach = static_cast<int>(std::ceil(x)) + 4;
    bessel_j_up_to(reach + 1, x, j);
    auto jk = [&](int k) { return (k < 0 && (-k) % 2 == 1 ? -1.0 : 1.0) * j[static_cast<std::size_t>(std::abs(k))]; };
    for (int k = -reach; k <= reach; ++k) {
      const long at = static_cast<long>(i) + k;
      if (at < 0 || at >= static_cast<long>(size)) continue;
      const Complex c = jk(k) * psi(k) + p.a / 2.0 * jk(k - 1) * psi(k - 1) + std::conj(p.a) / 2.0 * jk(k + 1) * psi(k + 1);
      out[static_cast<std::size_t>(at)] += value[i] * c;
      reached[static_cast<std::size_t>(at)] = true;
    }
  }
  for (std::size_t i = 0; i < size; ++i)
    if (!spread[i]) out[i] += value[i];
  return out;
}

/// The predicted powers of a record with modulation `p` on the cells of `kind` (and the carriers,
/// input lines) it changes. With the phases, at the input shaft's order: every input line re-timed
/// (retimed_input_lines; the carriers thus the twin's times |c_0|²: a PM of index x leaves one
/// J0(x)², which for the mesh's higher harmonics is most of its gap). At the output shaft's order:
/// every line of each mesh harmonic's modulated spectrum, the unmodulated carrier C times c_k out to
/// where J_k(x) is negligible (|k| > x + 4), plus the twin's own line there in the nearest
/// harmonic's phase, C as own_carrier_phase gives it. A line several harmonics reach (a PM whose
/// index passes half the teeth, as a re-timed record's high harmonics) holds their complex sum.
/// Without phases, the first sidebands from the one index (m²/4 of the carrier each).
std::vector<std::pair<std::size_t, double>> predicted_sideband_powers(const std::vector<ModulatedHarmonic>& hs,
                                                                      const ShaftSpectra& s, int z, const RecordModulation& p,
                                                                      const std::vector<FeatureDescriber::Cell>& cells,
                                                                      FeatureDescriber::CellKind kind, int zp, double floor) {
  using Complex = std::complex<double>;
  std::vector<double> power(s.lines_m.size(), kNaN), carrier_power;
  if (s.with_phase && z == zp) {
    const double beta = std::abs(p.b);
    const Complex unit_psi = beta > 0 ? p.b / beta : Complex{1.0, 0.0};
    std::vector<bool> reached;
    const auto lines = retimed_input_lines(hs, s, p, zp, floor, record_mesh_offset(hs, beta, p.a, unit_psi, zp), reached);
    for (std::size_t i = 0; i < lines.size(); ++i)
      if (reached[i]) power[i] = std::norm(lines[i]);
  } else if (s.with_phase) {
    std::vector<Complex> modulated(s.lines_m.size()), own(s.lines_m.size());
    std::vector<int> nearest(s.lines_m.size(), std::numeric_limits<int>::max());
    const double beta = std::abs(p.b);
    const Complex unit_psi = beta > 0 ? p.b / beta : Complex{1.0, 0.0};
    const double offset = record_mesh_offset(hs, beta, p.a, unit_psi, zp);
    for (const auto& h : hs) {
      const double x = static_cast<double>(h.n) * beta;
      const Complex c0 = modulated_line(0, x, p.a, unit_psi);
      const Complex phase = own_carrier_phase(h, c0, beta, zp, offset);
      const Complex carrier = std::abs(phase) > 0 ? std::sqrt(h.twin_carrier_power) * phase / std::abs(phase) : Complex{};
      const int reach = static_cast<int>(std::ceil(x)) + 4;
      const bool on_shaft = z == zp;  // the carrier is one of this shaft's lines (input shaft)
      for (int k = -reach; k <= reach; ++k) {
        if (k == 0 && !on_shaft) continue;
        const long at = static_cast<long>(h.n) * z + k - 1;
        if (at < 0 || at >= static_cast<long>(s.lines_m.size())) continue;
        const auto i = static_cast<std::size_t>(at);
        modulated[i] += carrier * modulated_line(k, x, p.a, unit_psi);
        if (std::abs(k) < nearest[i]) {  // the twin's own line, once, in the nearest harmonic's phase
          nearest[i] = std::abs(k);
          own[i] = k != 0 && std::abs(h.twin_carrier) > 0 && i < s.ct.size() ? s.ct[i] / h.twin_carrier * carrier : Complex{};
        }
      }
      if (!on_shaft) carrier_power.push_back(h.twin_carrier_power * std::norm(c0));
    }
    for (std::size_t i = 0; i < power.size(); ++i)
      if (nearest[i] != std::numeric_limits<int>::max()) power[i] = std::norm(modulated[i] + own[i]);
  } else {
    for (const auto& h : hs) {
      if (!h.readable) continue;
      const std::size_t upper = static_cast<std::size_t>(h.n * z), lower = upper - 2;
      power[upper] = s.lines_t[upper] + p.am * p.am / 4 * h.carrier_power;
      power[lower] = s.lines_t[lower] + p.am * p.am / 4 * h.carrier_power;
    }
  }
  std::vector<std::pair<std::size_t, double>> out;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (cells[i].kind == kind && cells[i].index < power.size() && std::isfinite(power[cells[i].index]))
      out.emplace_back(i, power[cells[i].index]);
    if (cells[i].kind == FeatureDescriber::CellKind::input_line && !carrier_power.empty())
      for (std::size_t j = 0; j < hs.size(); ++j)
        if (cells[i].index == static_cast<std::size_t>(hs[j].n * zp) - 1) out.emplace_back(i, carrier_power[j]);
  }
  return out;
}

/// J0(x) on [0, kMaxCarrierIndex] from a table at 1e-3 steps, linearly interpolated (error under
/// 2e-7): the carriers' fit asks for it at every harmonic of every record at every trial β, and
/// the library's Bessel function is slow.
double j0_tabled(double x) {
  constexpr double kStep = 1e-3;
  static const std::vector<double> table = [] {
    std::vector<double> t(static_cast<std::size_t>(kMaxCarrierIndex / kStep) + 2);
    for (std::size_t i = 0; i < t.size(); ++i) t[i] = std::cyl_bessel_j(0.0, static_cast<double>(i) * kStep);
    return t;
  }();
  const double u = x / kStep;
  const auto i = std::min(static_cast<std::size_t>(u), table.size() - 2);
  const double f = u - static_cast<double>(i);
  return table[i] + f * (table[i + 1] - table[i]);
}

/// The PM index β of the mesh fundamental that the mesh carriers' loss shows: under a PM of the mesh
/// harmonic n keeps J0(nβ)² of its power (an AM leaves it whole). Least squares of the measured over
/// the twin's carrier power (the comparison's floor added to both) against J0(nβ)², over every
/// record's harmonics whose twin carrier stands 100 times over the floor and whose index nβ is at
/// most kMaxCarrierIndex (a mean over them: the set shrinks as β grows); on a grid in log β, then
/// refined. 0 when no β fits better than none does.
double pm_index_from_carriers(const std::vector<DescribedRecord>& sources, int zp) {
  struct Carrier {
    double n, ratio, floor_share;  // measured/twin with the floor; the floor over twin + floor
  };
  std::vector<Carrier> carriers;
  for (const auto& src : sources) {
    const auto& m = src.measured->input_lines;
    const auto& t = src.twin->input_lines;
    for (std::size_t n = 1; n * static_cast<std::size_t>(zp) <= std::min(m.size(), t.size()); ++n) {
      const double pt = t[n * static_cast<std::size_t>(zp) - 1], pm = m[n * static_cast<std::size_t>(zp) - 1];
      if (pt > 100 * src.floor) carriers.push_back({static_cast<double>(n), (pm + src.floor) / (pt + src.floor), src.floor / (pt + src.floor)});
    }
  }
  auto cost = [&](double beta) {
    double sum = 0;
    std::size_t count = 0;
    for (const auto& c : carriers) {
      const double x = c.n * beta;
      if (x > kMaxCarrierIndex) continue;
      const double j0 = j0_tabled(x);
      const double d = c.ratio - (j0 * j0 * (1 - c.floor_share) + c.floor_share);
      sum += d * d, ++count;
    }
    return count >= 2 ? sum / static_cast<double>(count) : std::numeric_limits<double>::infinity();
  };
  constexpr double kLowest = 0.005, kHighest = 3.0;
  constexpr int kSteps = 240;
  double best = 0, best_cost = cost(0.0);
  for (int i = 0; i <= kSteps; ++i) {
    const double beta = kLowest * std::pow(kHighest / kLowest, static_cast<double>(i) / kSteps);
    const double c = cost(beta);
    if (c < best_cost) best_cost = c, best = beta;
  }
  if (best <= 0) return 0.0;
  const double step = std::pow(kHighest / kLowest, 1.0 / kSteps);
  return golden_min(cost, best / step, best * step);
}

/// The modulation form's description: the AM and PM indices and the AM's share of the first
/// sidebands' excess power at the mesh fundamental (which one dominates).
FeatureDescription modulation_description(FeatureShaft shaft, double am, double pm) {
  FeatureDescription d;
  d.kind = DescriptionKind::modulation;
  d.shaft = shaft;
  const double pm_ratio = std::isfinite(pm) ? pm_sideband_ratio(std::min(pm, kMaxHarmonicPmIndex)) : kNaN;
  const double am_share = std::isfinite(pm_ratio) && am * am + pm_ratio * pm_ratio > 0 ? am * am / (am * am + pm_ratio * pm_ratio) : kNaN;
  d.parameters = {{"am_index", am}, {"pm_index_rad", pm}, {"am_power_share", am_share}};
  return d;
}

/// The normalised second-order band-pass's power: 1 at r = 1, ½ at its half-power points.
double band_pass(double hz, double fn, double zeta) {
  const double r = hz / fn, a = 1 - r * r, b = 2 * zeta * r;
  return b * b / (a * a + b * b);
}

/// The band-pass as a 1-order broadband bin sees it (binned.hpp): its two half-order Hann bins
/// centred at `first_hz` and first_hz + half_bin_hz.
double binned_band_pass(double first_hz, double half_bin_hz, double fn, double zeta) {
  return binned_average(first_hz, half_bin_hz, fn, zeta, [&](double hz) { return band_pass(hz, fn, zeta); });
}

}  // namespace

Record unit_tone_record(double order, double top_order, const SpectralSummary& like, double samples_per_cycle) {
  const double speed = like.speed_hz;
  const double fs = unit_tone_sample_rate(top_order, like, samples_per_cycle);
  const std::size_t revs = like.input_revolutions;
  Record r;
  r.sample_rate_hz = fs;
  r.speed_hz = speed;
  r.torque_nm = like.torque_nm;
  std::vector<float> x(static_cast<std::size_t>((static_cast<double>(revs) + 0.5) * fs / speed));
  unit_tone_samples(order, speed, fs, x);
  r.channels = {std::move(x)};
  r.channel_numbers = {0};
  for (std::size_t k = 0; k <= revs; ++k) r.tacho_edges[0].push_back(static_cast<double>(k) * fs / speed);
  return r;
}

SpectralSummary unit_tone_spectra(double order, double top_order, const SpectralSummary& like, const GearPairSpec& gears,
                                  double samples_per_cycle) {
  // The record's tone is known in closed form on the angle grid: the interpolation is skipped.
  return RecordSpectra::of_tone(unit_tone_record(order, top_order, like, samples_per_cycle), gears, order).summary();
}

namespace {

// The description of the tones found, ordered by place (input orders for a ghost, Hz for tones
// fixed in Hz): each tone's place and power (m²/s⁴); the first names the feature.
FeatureDescription tone_description(const GapFeature& f, bool fixed_in_hz, double to_input,
                                    const std::vector<std::pair<double, double>>& found) {
  FeatureDescription d;
  const double place = found.empty() ? f.hz : found.front().first, amplitude = found.empty() ? 0.0 : std::sqrt(found.front().second);
  if (!fixed_in_hz) {
    d.kind = DescriptionKind::ghost_line;
    d.shaft = f.shaft;
    d.parameters = {{"order", place / to_input}, {"amplitude_m_s2", amplitude}};
    return d;
  }
  d.kind = DescriptionKind::fixed_tone;
  d.parameters = {{"frequency_hz", place}, {"amplitude_m_s2", amplitude}, {"fundamental_hz", place},
                  {"harmonic", 1.0}, {"supply_hz", 0.0}, {"tones", static_cast<double>(found.size())}};
  for (std::size_t k = 0; k < found.size(); ++k) {
    const std::string name = "tone_" + std::to_string(k + 1);
    d.parameters.emplace_back(name + "_hz", found[k].first);
    d.parameters.emplace_back(name + "_amplitude_m_s2", std::sqrt(found[k].second));
    d.parameters.emplace_back(name + "_harmonic", 1.0);
  }
  return d;
}

}  // namespace

FeatureDescriber::FeatureDescriber(const std::vector<DescribedRecord>& records, const GearPairSpec& gears, DescriptionSettings settings)
    : sources_(records), gears_(gears), settings_(settings) {
  const double ratio = static_cast<double>(gears.pinion_teeth) / gears.gear_teeth;  // input orders per output order
  for (const auto& src : sources_) {
    if (!src.measured || !src.twin) throw std::invalid_argument("FeatureDescriber: a record without spectra");
    const auto& m = *src.measured;
    const auto& t = *src.twin;
    RecordCells r{&src, m.speed_hz, src.floor, {}};
    for (std::size_t k = 0; k < std::min(m.input_lines.size(), t.input_lines.size()); ++k)
      r.cells.push_back({CellKind::input_line, k, k + 1.0, (k + 1.0) * m.speed_hz, t.input_lines[k], m.input_lines[k]});
    for (std::size_t k = 0; k < std::min(m.broadband.size(), t.broadband.size()); ++k)
      r.cells.push_back({CellKind::broadband, k, k + 1.5, (k + 1.5) * m.speed_hz, t.broadband[k], m.broadband[k]});
    for (std::size_t j = 0; j < std::min(m.output_lines.size(), t.output_lines.size()); ++j) {
      if (output_line_is_mesh(static_cast<int>(j + 1), gears.gear_teeth)) continue;
      const double o = (j + 1.0) * ratio;
      r.cells.push_back({CellKind::output_line, j, o, o * m.speed_hz, t.output_lines[j], m.output_lines[j]});
    }
    records_.push_back(std::move(r));
  }
  for (const auto& src : sources_) {
    floors_.push_back(compare_floors(*src.measured, *src.twin, settings_.floor));
    // No expectation is computed for a diagnosis with the local peaks off: it does not read it.
    local_.push_back(settings_.local.enabled ? local_expectation(*src.measured, *src.twin, floors_.back().acquisition, settings_.local)
                                             : std::vector<double>{});
  }
  floor_ = floor_change();
  tilt_ = path_tilt();
  carrier_pm_index_ = pm_index_from_carriers(sources_, gears_.pinion_teeth);
  modulation_input_ = modulation(FeatureShaft::input);
  modulation_output_ = modulation(FeatureShaft::output);
}

double FeatureDescriber::g_of(std::size_t r, std::size_t c, double measured) const {
  return ratio_db(measured, records_[r].cells[c].twin, records_[r].floor);
}

FeatureDescriber::Window FeatureDescriber::window_of(const GapFeature& f) const {
  const double ratio = static_cast<double>(gears_.pinion_teeth) / gears_.gear_teeth;
  const double to_input = f.shaft == FeatureShaft::output ? ratio : 1.0;
  Window w;
  for (std::size_t r = 0; r < records_.size(); ++r) {
    const double speed = records_[r].speed_hz;
    double lo = f.order_low * to_input, hi = f.order_high * to_input;
    if (f.movement == FeatureMovement::fixed_in_hz) lo = f.hz_low / speed, hi = f.hz_high / speed;
    const double margin = std::max(2.0, (hi - lo) / 2);
    lo -= margin, hi += margin;
    const auto& cells = records_[r].cells;
    for (std::size_t c = 0; c < cells.size(); ++c)
      if (cells[c].order >= lo && cells[c].order <= hi) w.emplace_back(r, c);
  }
  return w;
}

FeatureDescriber::Fit FeatureDescriber::floor_change() const {
  std::vector<double> x, y;
  for (const auto& r : records_)
    for (const auto& c : r.cells)
      if (c.kind == CellKind::broadband && c.twin >= 10 * r.floor && c.measured > 0 && c.hz > 0)
        x.push_back(std::log10(c.hz / 1000.0)), y.push_back(ratio_db(c.measured, c.twin, r.floor));
  // Plain variables, not a structured binding: the lambdas below capture them (C++20 allows
  // capturing a binding, clang 14 does not).
  double level = 0, slope = 0;
  std::tie(level, slope) = line_fit(x, y);
  // The comparison's floor compresses g where the twin's bins sit near it: the line's least squares
  // over the bins clear of it starts, then the RSS in g itself over every bin above the floor.
  std::vector<FloorPoint> bins;  // log10(f/1 kHz), twin, g, floor
  for (const auto& r : records_)
    for (const auto& c : r.cells)
      if (c.kind == CellKind::broadband && c.twin >= r.floor && c.hz > 0)
        bins.emplace_back(std::log10(c.hz / 1000.0), c.twin, ratio_db(c.measured, c.twin, r.floor), r.floor);
  if (x.size() < 2 && !bins.empty()) {  // nothing clear of the floor: start from g itself
    x.clear(), y.clear();
    for (const auto& [lx, t, g, fl] : bins) x.push_back(lx), y.push_back(g);
    std::tie(level, slope) = line_fit(x, y);
  }
  auto rss = [&](double l, double s) { return rss_through_floor(bins, l, s); };
  for (int round = 0; round < 6 && !bins.empty(); ++round) {
    const double span = 4.0 / (1 << round);
    level = golden_min([&](double l) { return rss(l, slope); }, level - span, level + span, 30);
    slope = golden_min([&](double s) { return rss(level, s); }, slope - span, slope + span, 30);
  }
  Fit fit;
  fit.description.kind = DescriptionKind::floor_change;
  fit.description.parameters = {{"level_db", level}, {"slope_db_per_decade", slope}};
  fit.complexity = 2;
  fit.predict = [this, level, slope](std::size_t r, std::size_t i) {
    const Cell& c = records_[r].cells[i];
    if (c.kind != CellKind::broadband || !(c.hz > 0)) return c.twin;
    return c.twin * std::pow(10.0, (level + slope * std::log10(c.hz / 1000.0)) / 10);
  };
  return fit;
}

FeatureDescriber::Fit FeatureDescriber::path_tilt() const {
  std::vector<double> x, y;
  // Mesh harmonics above the comparison's floor: log2(harmonic), twin, g, floor.
  std::vector<FloorPoint> lines;
  for (const auto& r : records_)
    for (const auto& c : r.cells)
      if (c.kind == CellKind::input_line && (c.index + 1) % static_cast<std::size_t>(gears_.pinion_teeth) == 0 &&
          c.twin >= 10 * r.floor && c.measured > 0) {
        const double octaves = std::log2((c.index + 1.0) / gears_.pinion_teeth), g = ratio_db(c.measured, c.twin, r.floor);
        x.push_back(octaves), y.push_back(g), lines.emplace_back(octaves, c.twin, g, r.floor);
      }
  double level = 0, tilt = 0;  // captured below: not a structured binding (see floor_change)
  std::tie(level, tilt) = line_fit(x, y);
  // The comparison's floor compresses g where a tilt takes a harmonic toward it (a falling tilt on
  // the high harmonics, 10 dB over the floor: −12 dB reads about −8), so the line through g reads
  // the tilt flat. As for the floor's fit: the line starts, then the RSS in g of the tilt through
  // the same floor.
  auto rss = [&](double l, double t) { return rss_through_floor(lines, l, t); };
  // Level and tilt trade off over harmonics all on one side of the first (log2 n from 0 to 4 or
  // more), so one at a time creeps: the tilt by golden section, the best level for each.
  if (lines.size() >= 2) {
    const double l0 = level, t0 = tilt;
    auto best_level = [&](double t) { return golden_min([&](double l) { return rss(l, t); }, l0 - 6, l0 + 6, 40); };
    tilt = golden_min([&](double t) { return rss(best_level(t), t); }, t0 - 4, t0 + 4, 40);
    level = best_level(tilt);
  }
  Fit fit;
  fit.description.kind = DescriptionKind::path_tilt;
  fit.description.parameters = {{"tilt_db_per_octave", tilt}, {"level_db", level}};
  fit.complexity = 2;
  fit.predict = [this, level, tilt](std::size_t r, std::size_t i) {
    const Cell& c = records_[r].cells[i];
    const double mesh_hz = gears_.pinion_teeth * records_[r].speed_hz;
    return c.twin * std::pow(10.0, (level + tilt * std::log2(c.hz / mesh_hz)) / 10);
  };
  return fit;
}

FeatureDescriber::Fit FeatureDescriber::modulation(FeatureShaft shaft) const {
  const bool input = shaft == FeatureShaft::input;
  const int zp = gears_.pinion_teeth, z = input ? gears_.pinion_teeth : gears_.gear_teeth;
  const CellKind kind = input ? CellKind::input_line : CellKind::output_line;
  std::vector<RecordModulation> per(records_.size());
  double am_sum = 0, pm_sum = 0, weight_sum = 0;
  bool phases = true;
  for (std::size_t r = 0; r < records_.size(); ++r) {
    const DescribedRecord& src = *records_[r].source;
    const ShaftSpectra s = shaft_spectra(src, input);
    phases = phases && s.with_phase;
    const std::vector<ModulatedHarmonic> hs = modulated_harmonics(src, s, zp, z);
    RecordModulation& p = per[r];
    if (!read_record_modulation(readable_only(hs), s.with_phase, carrier_pm_index_, p)) continue;
    p.sideband_power = predicted_sideband_powers(hs, s, z, p, records_[r].cells, kind, zp, src.floor);
    am_sum += p.weight * p.am, pm_sum += p.weight * (s.with_phase ? p.pm : 0.0), weight_sum += p.weight;
  }
  Fit fit;
  const double am = weight_sum > 0 ? am_sum / weight_sum : 0.0;
  const double pm = weight_sum > 0 && phases ? pm_sum / weight_sum : kNaN;
  fit.description = modulation_description(shaft, am, pm);
  fit.complexity = 2;
  // Each record's cell → predicted power (the twin's elsewhere).
  std::vector<std::vector<double>> predicted(records_.size());
  for (std::size_t r = 0; r < records_.size(); ++r) {
    predicted[r].assign(records_[r].cells.size(), kNaN);
    for (const auto& [i, power] : per[r].sideband_power) predicted[r][i] = power;
  }
  fit.predict = twin_elsewhere(std::move(predicted));
  return fit;
}

FeatureDescriber::Prediction FeatureDescriber::twin_elsewhere(std::vector<std::vector<double>> predicted) const {
  return [this, predicted = std::move(predicted)](std::size_t r, std::size_t i) {
    const double p = predicted[r][i];
    return std::isfinite(p) ? p : records_[r].cells[i].twin;
  };
}

namespace {

/// The resonance form's search over (f_n, ζ, G dB) on a window's cells: a grid over f_n in the
/// feature's band and ζ from 0.002 to 0.3 (log), the gain by golden section at each point, then a
/// pattern search around the best. The RSS of g is evaluated thousands of times: the measured side's
/// g is fixed and the band-pass depends on (f_n, ζ) alone, so both are computed once (per window,
/// per (f_n, ζ)) and each evaluation is the same sum on the same values. The cells' twin power,
/// floor, twin + floor and Hz are laid out side by side for that sum (the same operations as g_of
/// on the model's power, so the same values).
class ResonanceSearch {
 public:
  struct Cells {
    std::vector<double> g_measured, twin, floor, hz;
    /// Empty: each cell sees the band-pass at hz. Else each cell is a 1-order broadband bin whose
    /// half-order bins sit at hz and hz + half_bin_hz (binned_band_pass).
    std::vector<double> half_bin_hz;
  };
  static double pass(const Cells& c, std::size_t e, double fn, double zeta) {
    return c.half_bin_hz.empty() ? band_pass(c.hz[e], fn, zeta) : binned_band_pass(c.hz[e], c.half_bin_hz[e], fn, zeta);
  }
  struct Best {
    double fn, zeta, gain_db;
  };
  explicit ResonanceSearch(Cells cells) : c_(std::move(cells)), pass_(c_.hz.size()), below_(c_.hz.size()) {
    for (std::size_t e = 0; e < below_.size(); ++e) below_[e] = c_.twin[e] + c_.floor[e];
  }

  Best run(double lo, double hi, double start_fn) {
    bf_ = start_fn;
    constexpr int kF = 24, kZeta = 12;
    for (int i = 0; i <= kF; ++i)
      for (int j = 0; j <= kZeta; ++j)
        try_point(lo + (hi - lo) * i / kF, 0.002 * std::pow(150.0, static_cast<double>(j) / kZeta));
    double step_f = (hi - lo) / kF, step_lz = std::log(150.0) / kZeta;
    for (int it = 0; it < 30; ++it) {
      bool moved = false;
      for (const auto& [df, dlz] : {std::pair{1.0, 0.0}, {-1.0, 0.0}, {0.0, 1.0}, {0.0, -1.0}}) {
        // Each step from the best as it stands when the step is taken (the best moves within a round).
        const double fn = bf_ + df * step_f, zeta = bz_ * std::exp(dlz * step_lz);
        if (!(fn > 0) || zeta < 1e-4 || zeta > 1) continue;
        moved = try_point(fn, zeta) || moved;
      }
      if (!moved) step_f /= 2, step_lz /= 2;
    }
    return {bf_, bz_, bg_};
  }

 private:
  static constexpr double kGainLow = -30, kGainHigh = 40;

  // Whether (f_n, ζ) beats the best so far; it then becomes the best.
  bool try_point(double fn, double zeta) {
    double v = 0;
    const double g = best_gain_once(fn, zeta, v);
    if (!(v < best_)) return false;
    best_ = v, bf_ = fn, bz_ = zeta, bg_ = g;
    return true;
  }
  void set_pass(double fn, double zeta) {
    if (fn == pass_fn_ && zeta == pass_zeta_) return;
    for (std::size_t e = 0; e < pass_.size(); ++e) pass_[e] = pass(c_, e, fn, zeta);
    pass_fn_ = fn, pass_zeta_ = zeta;
  }
  // The cell's modelled g for a gain's 10^(G/10) − 1: rising with it (the band-pass is ≥ 0).
  double g_model(std::size_t e, double gm1) const {
    return kDbPerNeper * std::log((c_.twin[e] * (1 + gm1 * pass_[e]) + c_.floor[e]) / below_[e]);
  }
  double rss(double fn, double zeta, double gain_db) {
    set_pass(fn, zeta);
    const double gm1 = std::pow(10.0, gain_db / 10) - 1;
    double s = 0;
    for (std::size_t e = 0; e < pass_.size(); ++e) {
      const double d = c_.g_measured[e] - g_model(e, gm1);
      s += d * d;
    }
    return s;
  }
  // The best gain at (f_n, ζ) and the RSS there (the search's own evaluation of it).
  double best_gain(double fn, double zeta, double& v) {
    return golden_min([&](double g) { return rss(fn, zeta, g); }, kGainLow, kGainHigh, 20, &v);
  }
  // Whether no gain in the search's range can bring (f_n, ζ) under `bound`: each cell's modelled g
  // rises with the gain, so its misfit is at least its distance to the range the gains' ends give
  // it, and the sum of those is under every RSS the gain's search could evaluate. A point that
  // cannot beat the best so far changes nothing in the search, and its gain's search is skipped.
  // The margin keeps the rounding of the two sums (1e-16 relative) from deciding.
  bool cannot_beat(double fn, double zeta, double bound) {
    if (!std::isfinite(bound)) return false;
    set_pass(fn, zeta);
    const double low = std::pow(10.0, kGainLow / 10) - 1, high = std::pow(10.0, kGainHigh / 10) - 1;
    double least = 0;
    for (std::size_t e = 0; e < pass_.size(); ++e) {
      const double gm = c_.g_measured[e], below_end = g_model(e, low), above_end = g_model(e, high);
      const double d = gm < below_end ? below_end - gm : gm > above_end ? gm - above_end : 0.0;
      least += d * d;
      if (least * (1 - 1e-9) > bound) return true;
    }
    return false;
  }
  // A pattern step back lands on the point just left (or on a grid point), whose (f_n, ζ) give the
  // same gain and RSS: those already searched are looked up (the same numbers, exact keys).
  double best_gain_once(double fn, double zeta, double& v) {
    for (const auto& s : searched_)
      if (s[0] == fn && s[1] == zeta) return v = s[3], s[2];
    if (cannot_beat(fn, zeta, best_)) return v = std::numeric_limits<double>::infinity(), 0.0;
    const double g = best_gain(fn, zeta, v);
    searched_.push_back({fn, zeta, g, v});
    return g;
  }

  Cells c_;
  std::vector<double> pass_, below_;
  double pass_fn_ = kNaN, pass_zeta_ = kNaN;
  std::vector<std::array<double, 4>> searched_;  // f_n, ζ, gain, RSS
  double bf_ = 0, bz_ = 0.02, bg_ = 0, best_ = std::numeric_limits<double>::infinity();
};

}  // namespace

FeatureDescriber::Fit FeatureDescriber::resonance(const GapFeature& f, const Window& w) const {
  ResonanceSearch::Cells cells;
  for (const auto& [r, i] : w) {
    const Cell& c = records_[r].cells[i];
    cells.g_measured.push_back(g_of(r, i, c.measured));
    cells.twin.push_back(c.twin), cells.floor.push_back(records_[r].floor), cells.hz.push_back(c.hz);
  }
  double lo = f.hz_low, hi = f.hz_high;
  if (!(hi > lo) || !(lo > 0)) lo = std::max(1.0, f.hz * 0.9), hi = f.hz * 1.1;
  const auto [bf, bz, bg] = ResonanceSearch(std::move(cells)).run(lo, hi, f.hz);
  Fit fit;
  fit.description.kind = DescriptionKind::resonance;
  fit.description.parameters = {{"frequency_hz", bf}, {"damping_ratio", bz}, {"gain_db", bg}};
  fit.complexity = 3;
  const double gm1 = std::pow(10.0, bg / 10) - 1;
  fit.predict = [this, fn = bf, zeta = bz, gm1](std::size_t r, std::size_t i) {
    const Cell& c = records_[r].cells[i];
    return c.twin * (1 + gm1 * band_pass(c.hz, fn, zeta));
  };
  return fit;
}

FeatureDescription FeatureDescriber::local_resonance(const GapFeature& f, const Window& w, const FeatureDescription& none) const {
  if (!settings_.local.enabled || f.movement == FeatureMovement::fixed_in_orders) return none;
  ResonanceSearch::Cells cells;
  std::vector<std::size_t> record_of;
  double core_before = 0;
  std::size_t core = 0;
  for (const auto& [r, i] : w) {
    const Cell& c = records_[r].cells[i];
    if (c.kind != CellKind::broadband || c.index >= local_[r].size()) continue;
    const double expected = local_[r][c.index];
    if (!(expected > 0) || !(c.measured > 0)) continue;
    // One-sided, as the local test: a bin under its neighbourhood says only that nothing lifts it.
    const double g = std::max(0.0, 10 * std::log10(c.measured / expected)), half_bin = records_[r].speed_hz / 2;
    cells.g_measured.push_back(g), cells.twin.push_back(expected), cells.floor.push_back(0.0);
    cells.hz.push_back((c.order - 0.5) * records_[r].speed_hz), cells.half_bin_hz.push_back(half_bin);
    record_of.push_back(r);
    if (g >= settings_.min_feature_db) core_before += g * g, ++core;
  }
  if (core == 0) return none;
  double lo = f.hz_low, hi = f.hz_high;
  if (!(hi > lo) || !(lo > 0)) lo = std::max(1.0, f.hz * 0.9), hi = f.hz * 1.1;
  const auto [bf, bz, bg] = ResonanceSearch(cells).run(lo, hi, f.hz);
  const double gm1 = std::pow(10.0, bg / 10) - 1;
  const auto& g_measured = cells.g_measured;
  double rss = 0, core_sq = 0;
  std::set<std::size_t> lifted;  // records where the resonance lifts a bin that rises
  for (std::size_t e = 0; e < g_measured.size(); ++e) {
    const double predicted = 10 * std::log10(1 + gm1 * ResonanceSearch::pass(cells, e, bf, bz)), d = g_measured[e] - predicted;
    rss += d * d;
    if (g_measured[e] < settings_.min_feature_db) continue;
    core_sq += d * d;
    if (predicted >= settings_.min_feature_db) lifted.insert(record_of[e]);
  }
  if (!(std::sqrt(core_sq / static_cast<double>(core)) < settings_.min_feature_db)) return none;  // its gap stays
  // A resonance of the machine is in every record whose band holds it: seen in as many as the finder
  // asks of a local peak (LocalPeakSettings::min_record_share), not in one bin's chance rise.
  if (lifted.size() < settings_.local.records_needed(records_.size())) return none;
  FeatureDescription d;
  d.kind = DescriptionKind::resonance;
  d.parameters = {{"frequency_hz", bf}, {"damping_ratio", bz}, {"gain_db", bg}};
  d.gap_db = std::sqrt(core_before / static_cast<double>(core));
  d.residual_db = std::sqrt(rss / static_cast<double>(g_measured.size()));
  return d;
}

std::vector<double> FeatureDescriber::tone_response(double place, bool in_hz, const Window& w) const {
  // One unit-power tone per record, as RecordSpectra sees it, read on the window's cells in its order.
  std::vector<double> out(w.size(), 0.0);
  std::size_t e = 0;
  while (e < w.size()) {
    const std::size_t r = w[e].first;
    // The tone sits in the measured record: its share of each line turns on that record's whole
    // revolutions (sinc(R·Δ)), which the twin's record, simulated for its own length, need not share.
    const SpectralSummary& t = *records_[r].source->measured;
    SpectralSummary unit;
    unit.speed_hz = t.speed_hz, unit.input_revolutions = t.input_revolutions, unit.output_revolutions = t.output_revolutions;
    unit.input_lines.assign(t.input_lines.size(), 0.0);
    unit.output_lines.assign(t.output_lines.size(), 0.0);
    unit.broadband.assign(t.broadband.size(), 0.0);
    // The tone's leakage followed over the whole window: a strong tone stands tens of dB over lines
    // several orders away, further than the default reach (ToneReach) follows it.
    const double order = in_hz ? place / records_[r].speed_hz : place;
    double reach = 0;
    for (std::size_t x = e; x < w.size() && w[x].first == r; ++x) reach = std::max(reach, std::abs(records_[r].cells[w[x].second].order - order));
    add_non_synchronous_tone(unit, order, 1.0, gears_, 0.0, ToneReach::orders(std::min(reach + 1, kMaxToneReachOrders), gears_));
    for (; e < w.size() && w[e].first == r; ++e) {
      const Cell& c = records_[r].cells[w[e].second];
      const auto& v = c.kind == CellKind::input_line ? unit.input_lines : c.kind == CellKind::output_line ? unit.output_lines : unit.broadband;
      out[e] = c.index < v.size() ? v[c.index] : 0.0;
    }
  }
  return out;
}

namespace {
/// A unit tone's cells (UnitToneCells) shared between records alike in what it reads of them. In
/// samples its record is the same at any speed (the rate follows the speed, up to the record's own):
/// records with the same whole revolutions, samples a revolution and order (each to kSame) reduce
/// it alike, so the twin's records at one speed and several loads (speeds a few parts in 1e9 apart)
/// share one.
class SharedUnitTones {
 public:
  explicit SharedUnitTones(const GearPairSpec& gears) : gears_(gears) {}
  /// `reads`: the cells the caller reads of it, by which it is reduced or taken in closed form.
  const UnitToneCells& of(double order, double top_order, const SpectralSummary& like, const UnitToneReads& reads) {
    const double per_rev = samples_per_revolution(top_order, like);
    for (const auto& [key, unit] : done_)
      if (key.top_order == top_order && key.revolutions == like.input_revolutions &&
          std::abs(key.samples_per_revolution - per_rev) <= kSame * per_rev && std::abs(key.order - order) <= kSame * order)
        return unit;
    done_.emplace_back(std::piecewise_construct, std::forward_as_tuple(Key{order, top_order, like.input_revolutions, per_rev}),
                       std::forward_as_tuple(order, top_order, like, gears_, kUnitToneSamplesPerCycle, reads));
    return done_.back().second;
  }

 private:
  static constexpr double kSame = 1e-6;
  struct Key {
    double order, top_order;
    std::size_t revolutions;
    double samples_per_revolution;
  };
  static double samples_per_revolution(double top_order, const SpectralSummary& like) {
    return std::min(like.sample_rate_hz / like.speed_hz, kUnitToneSamplesPerCycle * (top_order + 4));
  }
  const GearPairSpec& gears_;
  std::deque<std::pair<Key, UnitToneCells>> done_;  // stable references
};
}  // namespace

std::vector<double> FeatureDescriber::tone_as_measured(double place, bool in_hz, const Window& w) const {
  SharedUnitTones shared(gears_);
  std::vector<double> out(w.size(), 0.0);
  std::size_t e = 0;
  while (e < w.size()) {
    const std::size_t r = w[e].first;
    const double order = in_hz ? place / records_[r].speed_hz : place;
    std::size_t end = e;
    double top = order;
    UnitToneReads reads;
    for (; end < w.size() && w[end].first == r; ++end) {
      const Cell& c = records_[r].cells[w[end].second];
      top = std::max(top, c.order);
      ++(c.kind == CellKind::broadband ? reads.broadband : reads.lines);
    }
    // The measured record's revolutions; only the window's cells are computed.
    const UnitToneCells& unit = shared.of(order, top + 1, *records_[r].source->measured, reads);
    for (; e < end; ++e) {
      const Cell& c = records_[r].cells[w[e].second];
      out[e] = c.kind == CellKind::input_line ? unit.input_line(c.index)
               : c.kind == CellKind::output_line ? unit.output_line(c.index) : unit.broadband(c.index);
    }
  }
  return out;
}

/// One search for a feature's tones (FeatureDescriber::tones) over its window: the measured g, the
/// twin's power with the tones found so far (the base), and the tones found.
class FeatureDescriber::ToneSearch {
 public:
  ToneSearch(const FeatureDescriber& d, const GapFeature& f, const Window& w, bool fixed_in_hz);
  /// Adds the best tone at a time while another pays for itself, refitting the others with it.
  void run(int max_tones);
  /// The tones found, ordered by place, and the prediction with them on the window's cells.
  Fit result();

 private:
  struct Tone {
    double place = 0, power = 0, rss = std::numeric_limits<double>::infinity();
    std::vector<double> unit;
  };
  double g_of(std::size_t e, double power) const { return d_.g_of(w_[e].first, w_[e].second, power); }
  double rss_of(const std::vector<double>& unit, double power) const;
  double rss_with_base() const;
  double bic(double rss, std::size_t k) const;
  bool on_a_line(double place) const;
  bool free_place(double place) const;
  void fit_power(Tone& t) const;
  Tone at(double place) const;
  const std::vector<double>& unit_response(double place) const;
  Tone best_on_grid() const;
  void refine(Tone& t, double first_step) const;
  double largest_change(const Tone& t) const;
  void add_to_base(const Tone& t, double sign);
  void refit_together();
  Tone as_measured_at(double place) const;
  Tone refined_on_a_lattice(Tone start) const;
  void halve_as_measured(Tone& t, double first_step, double last_step) const;
  double interpolated_place(double near) const;
  void ghost_as_measured();
  void tones_as_measured();
  void move_over_weaker(Tone& best, double place, std::size_t from);
  void try_supply_harmonic(Tone& best, std::size_t from);
  void joint_powers();
  void drop_tones_that_do_not_pay();

  const FeatureDescriber& d_;
  const GapFeature& f_;
  const Window& w_;
  const bool fixed_in_hz_;
  const std::size_t n_;
  double ratio_ = 0, to_input_ = 0, top_ = 0, lo_ = 0, hi_ = 0, step_ = 0, separation_ = 0, top_speed_ = 0;
  double resolved_hz_ = std::numeric_limits<double>::infinity();  // 1/T of the longest record (whole revolutions)
  double input_revolutions_ = 0, output_revolutions_ = 0;  // the longest record's
  std::vector<double> g_, base_;  // measured g; the twin's power with the tones found so far
  // Each cell's squared misfit with the base alone: a trial tone leaves most cells' power as it is
  // (bitwise: its leakage there under the base's last digit), and those cells' terms are then the
  // same numbers without a logarithm each (rss_of).
  std::vector<double> base_sq_;
  void set_base_sq();
  std::vector<Tone> found_;
  mutable std::map<double, std::vector<double>> responses_;  // tone_response by place (unit_response)
  // tone_as_measured by place: the rounds over the tones and the halving steps come back to places
  // already reduced (a tone's own place each round), and each reduction resamples a record.
  mutable std::map<double, std::vector<double>> measured_responses_;
};

FeatureDescriber::ToneSearch::ToneSearch(const FeatureDescriber& d, const GapFeature& f, const Window& w, bool fixed_in_hz)
    : d_(d), f_(f), w_(w), fixed_in_hz_(fixed_in_hz), n_(w.size()) {
  ratio_ = static_cast<double>(d.gears_.pinion_teeth) / d.gears_.gear_teeth;
  to_input_ = f.shaft == FeatureShaft::output ? ratio_ : 1.0;
  double total = 0, top_speed = 0;
  for (const auto& r : d.records_) {
    const SpectralSummary& t = *r.source->twin;
    const SpectralSummary& m = *r.source->measured;  // the record the tone is in
    total = std::max(total, total_input_line_power(t)), top_speed = std::max(top_speed, r.speed_hz);
    input_revolutions_ = std::max(input_revolutions_, static_cast<double>(m.input_revolutions));
    if (m.input_revolutions > 0) resolved_hz_ = std::min(resolved_hz_, r.speed_hz / static_cast<double>(m.input_revolutions));
    output_revolutions_ = std::max(output_revolutions_, static_cast<double>(m.output_revolutions));
  }
  top_ = std::log10(std::max(total, 1e-300));
  // Places: input orders (a ghost) or Hz (a tone) across the feature's extent, 0.05 input orders apart
  // (at the fastest record in Hz), then refined by halving. Tones are told apart one broadband bin
  // (one order) apart: nearer, a second tone would only reshape the first one's leakage.
  // A ghost is searched within two orders of the feature's centre: its |g|-weighted centre sits by the
  // tone, while its extent grows with how far the tone's leakage stands over the minimum.
  lo_ = fixed_in_hz ? f.hz_low : f.order_low * to_input_, hi_ = fixed_in_hz ? f.hz_high : f.order_high * to_input_;
  if (!fixed_in_hz) lo_ = std::max(lo_, f.order * to_input_ - 2), hi_ = std::min(hi_, f.order * to_input_ + 2);
  step_ = fixed_in_hz ? 0.05 * top_speed : 0.05, separation_ = fixed_in_hz ? top_speed : 1.0;
  top_speed_ = top_speed;
  g_.resize(n_), base_.resize(n_);
  for (std::size_t e = 0; e < n_; ++e) {
    const auto [r, i] = w[e];
    g_[e] = d.g_of(r, i, d.records_[r].cells[i].measured), base_[e] = d.records_[r].cells[i].twin;
  }
  set_base_sq();
}

void FeatureDescriber::ToneSearch::set_base_sq() {
  base_sq_.resize(n_);
  for (std::size_t e = 0; e < n_; ++e) {
    const double dg = g_[e] - g_of(e, base_[e]);
    base_sq_[e] = dg * dg;
  }
}

double FeatureDescriber::ToneSearch::rss_of(const std::vector<double>& unit, double power) const {
  double s = 0;
  for (std::size_t e = 0; e < n_; ++e) {
    const double model = base_[e] + power * unit[e];
    if (model == base_[e]) {
      s += base_sq_[e];
      continue;
    }
    const double dg = g_[e] - g_of(e, model);
    s += dg * dg;
  }
  return s;
}

double FeatureDescriber::ToneSearch::rss_with_base() const {
  double s = 0;
  for (std::size_t e = 0; e < n_; ++e) s += std::pow(g_[e] - g_of(e, base_[e]), 2);
  return s;
}

double FeatureDescriber::ToneSearch::bic(double rss, std::size_t k) const {
  const double res2 = d_.settings_.resolution_db * d_.settings_.resolution_db, nn = static_cast<double>(n_);
  return nn * std::log(std::max(rss / nn, res2)) + 2.0 * static_cast<double>(k) * std::log(nn);
}

/// A ghost sits off the shafts' integer orders: a tone on one is a line the synchronous averages
/// keep. On one means within the records' resolution: its phase drifts less than a quarter of a
/// cycle against the line over the longest record (the average then keeps over 80 % of it).
bool FeatureDescriber::ToneSearch::on_a_line(double place) const {
  if (fixed_in_hz_) return false;
  const double out = place / ratio_;
  return std::abs(place - std::round(place)) * input_revolutions_ < 0.25 ||
         std::abs(out - std::round(out)) * output_revolutions_ < 0.25;
}

bool FeatureDescriber::ToneSearch::free_place(double place) const {
  if (on_a_line(place) || !(place > 0)) return false;
  for (const auto& t : found_)
    if (std::abs(t.place - place) < separation_) return false;
  return true;
}

void FeatureDescriber::ToneSearch::fit_power(Tone& t) const {
  const double lp = golden_min([&](double x) { return rss_of(t.unit, std::pow(10.0, x)); }, top_ - 14, top_ + 2, 36);
  t.power = std::pow(10.0, lp), t.rss = rss_of(t.unit, t.power);
}

FeatureDescriber::ToneSearch::Tone FeatureDescriber::ToneSearch::at(double place) const {
  Tone t;
  t.place = place, t.unit = unit_response(place);
  fit_power(t);
  return t;
}

/// A tone's unit response depends on its place and the window alone, not on the tones found: each
/// tone added searches the same grid again, so every place's response is computed once.
const std::vector<double>& FeatureDescriber::ToneSearch::unit_response(double place) const {
  auto it = responses_.find(place);
  if (it == responses_.end()) it = responses_.emplace(place, d_.tone_response(place, fixed_in_hz_, w_)).first;
  return it->second;
}

FeatureDescriber::ToneSearch::Tone FeatureDescriber::ToneSearch::best_on_grid() const {
  Tone best;
  for (double place = lo_; place <= hi_ + 1e-9; place += step_)
    if (free_place(place))
      if (Tone t = at(place); t.rss < best.rss) best = std::move(t);
  return best;
}

/// Moves `t` to a better free place nearby, by halving steps from `first_step`.
void FeatureDescriber::ToneSearch::refine(Tone& t, double first_step) const {
  for (double s = first_step; s > step_ / 128; s /= 2)
    for (double place : {t.place - s, t.place + s})
      if (free_place(place))
        if (Tone moved = at(place); moved.rss < t.rss) t = std::move(moved);
}

/// The largest change of g a tone makes on a cell of the window, over the base.
double FeatureDescriber::ToneSearch::largest_change(const Tone& t) const {
  double largest = 0;
  for (std::size_t e = 0; e < n_; ++e) largest = std::max(largest, g_of(e, base_[e] + t.power * t.unit[e]) - g_of(e, base_[e]));
  return largest;
}

void FeatureDescriber::ToneSearch::add_to_base(const Tone& t, double sign) {
  for (std::size_t e = 0; e < n_; ++e) base_[e] += sign * t.power * t.unit[e];
  set_base_sq();
}

/// The powers again, each with the others in place (their leakage overlaps); and the places: a
/// tone placed before a stronger neighbour was in the base sat where that neighbour's leakage
/// pulled it (a supply's 100 Hz, placed before 150 Hz, sat toward it).
void FeatureDescriber::ToneSearch::refit_together() {
  for (int pass = 0; pass < 2 && found_.size() > 1; ++pass)
    for (std::size_t i = 0; i < found_.size(); ++i) {
      add_to_base(found_[i], -1);
      Tone t = std::move(found_[i]);
      found_.erase(found_.begin() + static_cast<std::ptrdiff_t>(i));  // free_place then ignores it
      fit_power(t);
      refine(t, step_);
      add_to_base(t, 1);
      found_.insert(found_.begin() + static_cast<std::ptrdiff_t>(i), std::move(t));
    }
}

void FeatureDescriber::ToneSearch::run(int max_tones) {
  double current = rss_with_base();
  for (int j = 0; j < max_tones; ++j) {
    Tone best = best_on_grid();
    if (best.unit.empty()) break;
    refine(best, step_ / 2);
    // Another tone only where it pays for its two parameters (the same criterion as the rule's) and
    // changes some cell by the practical minimum: weaker, the finder could not have seen it.
    if (!found_.empty() && !(bic(best.rss, found_.size() + 1) < bic(current, found_.size()))) break;
    if (!found_.empty() && largest_change(best) < d_.settings_.min_feature_db) break;
    add_to_base(best, 1);
    found_.push_back(std::move(best));
    refit_together();
    current = found_.size() > 1 ? rss_with_base() : found_.back().rss;
  }
}

/// A ghost's power and its prediction from the tone as the measurement reduces it. The search's
/// tone model (add_non_synchronous_tone) places the tone well but leaves out what the shafts'
/// averages, subtracted in input angle, leave in the broadband blocks: a pedestal a few orders out
/// that a power fitted in the log chases, and that, for a strong tone, keeps cells at the practical
/// minimum the form does not reach. The power then comes from the line's own power, which the
/// reduction conserves: the tone's excess summed over the window's cells (the blocks' scale already
/// counts the Hann window's noise bandwidth, so a tone's power summed over its bins is its power)
/// over the share of a unit tone the same cells hold. Lines count with the bins: how the tone's power
/// splits between the averages and the blocks turns on its order to a thousandth (a tone whole
/// periods over the record leaves the averages nothing), the sum does not. A line under twice the
/// twin's power (the 3 dB practical minimum) is left out of both sums: on a line the twin holds, the
/// excess would be the cross term of the two, not the tone's.
FeatureDescriber::ToneSearch::Tone FeatureDescriber::ToneSearch::as_measured_at(double place) const {
  Tone t;
  auto it = measured_responses_.find(place);
  if (it == measured_responses_.end()) it = measured_responses_.emplace(place, d_.tone_as_measured(place, fixed_in_hz_, w_)).first;
  t.place = place, t.unit = it->second;
  double excess = 0, share = 0;
  for (std::size_t e = 0; e < n_; ++e) {
    const auto [r, i] = w_[e];
    const Cell& c = d_.records_[r].cells[i];
    if (c.kind != CellKind::broadband && !(c.measured >= 2 * c.twin)) continue;
    excess += c.measured - base_[e], share += t.unit[e];
  }
  t.power = share > 0 ? std::max(0.0, excess / share) : 0.0;
  t.rss = rss_of(t.unit, t.power);
  return t;
}

/// A ghost's order from the lines beside it, in every record: a shaft's average over R whole
/// revolutions reads a tone at order k + δ on its lines k and k + 1 as |sinc(R·δ)| and |sinc(R·(1 − δ))|,
/// whose ratio is δ/(1 − δ) whatever R (R whole), so δ = ρ/(1 + ρ), ρ the amplitudes' ratio (the
/// rectangular window's interpolation). Read on both shafts' lines (the gear's lie 0.37 input order
/// apart) where the tone holds both lines (each at least twice the twin's), about the line nearest
/// `near` that holds most; the records' readings weighted by the power read. NaN: no pair.
double FeatureDescriber::ToneSearch::interpolated_place(double near) const {
  double sum = 0, weight = 0;
  for (const auto& rec : d_.records_) {
    const SpectralSummary& m = *rec.source->measured;
    const SpectralSummary& t = *rec.source->twin;
    const double to_place = fixed_in_hz_ ? rec.speed_hz : 1.0;  // a place per input order
    for (const bool input : {true, false}) {
      const double per = input ? 1.0 : ratio_;  // input orders per order of this shaft
      const auto& lm = input ? m.input_lines : m.output_lines;
      const auto& lt = input ? t.input_lines : t.output_lines;
      auto excess = [&](long k) {  // the tone's power on line k (0: not the tone's, or none)
        if (k < 1 || k > static_cast<long>(std::min(lm.size(), lt.size()))) return 0.0;
        if (!input && output_line_is_mesh(static_cast<int>(k), d_.gears_.gear_teeth)) return 0.0;
        const double pm = lm[static_cast<std::size_t>(k - 1)], pt = lt[static_cast<std::size_t>(k - 1)];
        return pm >= 2 * pt ? pm - pt : 0.0;
      };
      const long k0 = static_cast<long>(std::floor(near / to_place / per));
      long k = k0;
      for (long j = k0 - 1; j <= k0 + 2; ++j)
        if (excess(j) > excess(k)) k = j;
      // The twin's power on line k where the tone's share there cannot be read (infinite: a gear
      // mesh line, which the output average does not keep).
      auto held = [&](long line) {
        if (line < 1 || line > static_cast<long>(std::min(lm.size(), lt.size()))) return 0.0;
        if (!input && output_line_is_mesh(static_cast<int>(line), d_.gears_.gear_teeth)) return std::numeric_limits<double>::infinity();
        return excess(line) > 0 ? 0.0 : lt[static_cast<std::size_t>(line - 1)];
      };
      const double a = excess(k), below = excess(k - 1), above = excess(k + 1);
      if (!(a > 0) || !(std::max(below, above) > 0)) continue;
      // The tone's side of line k is the side of the larger neighbour (its share falls as 1/distance).
      // A neighbour the twin's line outweighs may hide the larger share (a ghost beside a mesh
      // harmonic): the side is then not told by these lines, and they give no reading.
      if ((below == 0 && held(k - 1) >= above) || (above == 0 && held(k + 1) >= below)) continue;
      const double rho = std::sqrt(std::max(below, above) / a);
      const double delta = rho / (1 + rho);
      sum += (a + std::max(below, above)) * (static_cast<double>(k) + (above >= below ? delta : -delta)) * per * to_place;
      weight += a + std::max(below, above);
    }
  }
  return weight > 0 ? sum / weight : kNaN;
}

/// A ghost's misfit against its place dips every 1/R order (R the records' revolutions, tens: a
/// tone's share of each line is sinc(R·Δ)); a start (the search's place, the lines' interpolation)
/// can stand several dips from the tone's (on closed-form records over input orders 4-7, the
/// interpolation up to 0.065 order off). So, as for tones fixed in Hz, each start's neighbourhood is
/// scanned at a quarter of the longest record's 1/R (each dip's basin sampled), here over
/// kGhostScanSpan, then refined by halving. The lattice is fixed in orders, so two starts near each
/// other share their places (and the cache of tones as measured).
constexpr double kGhostScanSpan = 0.075;

FeatureDescriber::ToneSearch::Tone FeatureDescriber::ToneSearch::refined_on_a_lattice(Tone start) const {
  const double step = 1 / (4 * std::max(input_revolutions_, 1.0));
  const long first = std::lround((start.place - kGhostScanSpan) / step), last = std::lround((start.place + kGhostScanSpan) / step);
  for (long k = first; k <= last; ++k)
    if (const double place = static_cast<double>(k) * step; free_place(place))
      if (Tone moved = as_measured_at(place); moved.rss < start.rss) start = std::move(moved);
  halve_as_measured(start, step / 2, step / 64);
  return start;
}

/// Moves `t` to a better free place nearby with the tone as measured, by halving steps from
/// `first_step` while over `last_step` (refine, with as_measured_at for the search's model).
void FeatureDescriber::ToneSearch::halve_as_measured(Tone& t, double first_step, double last_step) const {
  for (double s = first_step; s > last_step; s /= 2)
    for (double place : {t.place - s, t.place + s})
      if (free_place(place))
        if (Tone moved = as_measured_at(place); moved.rss < t.rss) t = std::move(moved);
}

/// The ghost's place refined and its power taken with the tone as measured (above): how its power
/// splits between the averages and the blocks turns on the place to a thousandth of an order, which
/// the search's model does not hold. Started from the lines' interpolation and from the search's
/// place, each refined (refined_on_a_lattice), the better end kept. Each start is refined before they
/// are compared: a start a few hundredths of an order from the tone can read worse than the search's
/// place in a wrong dip, and better than it once refined.
void FeatureDescriber::ToneSearch::ghost_as_measured() {
  if (fixed_in_hz_ || found_.size() != 1) return;
  Tone t = std::move(found_.front());
  found_.clear();  // free_place then ignores it
  add_to_base(t, -1);
  Tone best = refined_on_a_lattice(as_measured_at(t.place));
  if (const double at = interpolated_place(t.place); std::isfinite(at) && std::abs(at - t.place) <= 1 && free_place(at))
    if (Tone moved = refined_on_a_lattice(as_measured_at(at)); moved.rss < best.rss) best = std::move(moved);
  if (best.power > 0) t = std::move(best);
  add_to_base(t, 1);
  found_.push_back(std::move(t));
}

/// Tones fixed in Hz as the measurement reduces them (as the ghost's, above): each tone's place
/// refined and its power taken from the lines' and bins' excess with the others in the base, twice
/// round (their leakage overlaps). A strong tone's record leaves a pedestal orders wide where the
/// output shaft's averages, subtracted in input angle, held its leakage: the search's model leaves
/// it out, so the search placed a tone where the pedestal sits and pulled its neighbours toward it.
/// Then the tones that no longer pay for themselves with the pedestal explained are dropped.
void FeatureDescriber::ToneSearch::tones_as_measured() {
  if (!fixed_in_hz_ || found_.empty()) return;
  std::sort(found_.begin(), found_.end(), [](const Tone& a, const Tone& b) { return a.power > b.power; });
  for (int pass = 0; pass < 2; ++pass, joint_powers())
    for (std::size_t i = 0; i < found_.size(); ++i) {
      add_to_base(found_[i], -1);
      Tone t = std::move(found_[i]);
      found_.erase(found_.begin() + static_cast<std::ptrdiff_t>(i));  // free_place then ignores it
      Tone best = as_measured_at(t.place);
      const double at = interpolated_place(t.place);
      const bool read = std::isfinite(at) && std::abs(at - t.place) <= separation_ / 2;
      if (read) move_over_weaker(best, at, i);
      // A line's share of the tone, sinc(R·Δ), swings from one zero to the next as the tone moves by
      // 1/T Hz (T the record's whole revolutions): the misfit over the window has a minimum every
      // 1/T or so, and halving steps settle in whichever is nearest. The lines' reading is off by
      // the other tones' leakage on them, a fraction of 1/T: so on the first round the places within
      // half a grid step of it are scanned at a quarter of the longest record's 1/T (each minimum's
      // basin sampled) before the halving; weaker tones in the way go with the move (the search put
      // them where this tone's misplaced leakage was unexplained).
      if (read && pass == 0 && std::isfinite(resolved_hz_) && resolved_hz_ > 0)
        for (double place = at - step_ / 2; place <= at + step_ / 2; place += resolved_hz_ / 4) move_over_weaker(best, place, i);
      halve_as_measured(best, std::min(step_ / 2, resolved_hz_ / 8), step_ / 128);
      try_supply_harmonic(best, i);
      if (best.power > 0) t = std::move(best);
      add_to_base(t, 1);
      found_.insert(found_.begin() + static_cast<std::ptrdiff_t>(i), std::move(t));
    }
  drop_tones_that_do_not_pay();
}

/// The tones' powers together, as the measurement adds them: least squares of the lines' and bins'
/// excess over the twin (the cells as_measured_at sums) on the tones' responses, powers ≥ 0
/// (coordinate descent). Each tone's power alone from the excess over the whole window counts its
/// neighbours' misfit with it, which for tones tens of dB over the twin outweighs its own.
void FeatureDescriber::ToneSearch::joint_powers() {
  if (found_.size() < 2) return;
  std::vector<double> y(n_, 0.0);
  for (std::size_t e = 0; e < n_; ++e) {
    const Cell& c = d_.records_[w_[e].first].cells[w_[e].second];
    if (c.kind == CellKind::broadband || c.measured >= 2 * c.twin) y[e] = c.measured - c.twin;
  }
  auto used = [&](std::size_t e) { return y[e] != 0.0; };
  for (auto& t : found_) add_to_base(t, -1);
  for (int sweep = 0; sweep < 50; ++sweep)
    for (std::size_t i = 0; i < found_.size(); ++i) {
      double num = 0, den = 0;
      for (std::size_t e = 0; e < n_; ++e) {
        if (!used(e)) continue;
        double others = 0;
        for (std::size_t j = 0; j < found_.size(); ++j)
          if (j != i) others += found_[j].power * found_[j].unit[e];
        num += found_[i].unit[e] * (y[e] - others), den += found_[i].unit[e] * found_[i].unit[e];
      }
      found_[i].power = den > 0 ? std::max(0.0, num / den) : 0.0;
    }
  for (auto& t : found_) add_to_base(t, 1);
  for (auto& t : found_) t.rss = rss_with_base();
}

/// `best` moved to `place` where that fits the window better. Weaker tones (found_ from `from` on,
/// strongest first) within the separation of `place` go with the move: the search placed them where
/// the stronger tone's misplaced leakage was unexplained.
void FeatureDescriber::ToneSearch::move_over_weaker(Tone& best, double place, std::size_t from) {
  if (on_a_line(place) || !(place > 0)) return;
  std::vector<Tone> blockers;
  for (std::size_t j = 0; j < found_.size();) {
    if (std::abs(found_[j].place - place) >= separation_) { ++j; continue; }
    if (j < from) {  // a stronger tone is there
      for (auto& b : blockers) add_to_base(b, 1), found_.push_back(std::move(b));
      return;
    }
    add_to_base(found_[j], -1);
    blockers.push_back(std::move(found_[j]));
    found_.erase(found_.begin() + static_cast<std::ptrdiff_t>(j));
  }
  if (Tone moved = as_measured_at(place); moved.rss < best.rss) {
    best = std::move(moved);
    return;
  }
  for (auto& b : blockers) add_to_base(b, 1), found_.push_back(std::move(b));
}

/// `best` tried on the nearest harmonic of a 50 or 60 Hz supply within the supply tolerance: mains
/// pick-up sits there (a grid holds its frequency to a fraction of a hertz), while the halving
/// steps stop in whichever of the misfit's minima, about 1/T apart, is nearest, and another tone's
/// leakage on the lines can put the nearest one off the harmonic. Kept where it fits the window better.
void FeatureDescriber::ToneSearch::try_supply_harmonic(Tone& best, std::size_t from) {
  if (!fixed_in_hz_) return;
  const double tolerance = d_.settings_.supply_tolerance_orders * top_speed_;
  for (const double supply : {50.0, 60.0}) {
    const double k = std::round(best.place / supply);
    if (k >= 1 && k <= d_.settings_.max_supply_harmonic && best.place != k * supply && std::abs(best.place - k * supply) <= tolerance)
      move_over_weaker(best, k * supply, from);
  }
}

/// The weakest tone dropped while the others explain the window as well by the BIC (the search's
/// criterion), or while it changes no cell by the practical minimum; the others' powers stay.
void FeatureDescriber::ToneSearch::drop_tones_that_do_not_pay() {
  while (found_.size() > 1) {
    const auto weakest = std::min_element(found_.begin(), found_.end(), [](const Tone& a, const Tone& b) { return a.power < b.power; });
    const double with = rss_with_base();
    add_to_base(*weakest, -1);
    const double without = rss_with_base();
    if (bic(without, found_.size() - 1) <= bic(with, found_.size()) || largest_change(*weakest) < d_.settings_.min_feature_db) {
      found_.erase(weakest);
      continue;
    }
    add_to_base(*weakest, 1);
    break;
  }
}

FeatureDescriber::Fit FeatureDescriber::ToneSearch::result() {
  ghost_as_measured();
  tones_as_measured();
  std::sort(found_.begin(), found_.end(), [](const Tone& a, const Tone& b) { return a.place < b.place; });
  Fit fit;
  fit.complexity = 2 * static_cast<int>(std::max<std::size_t>(1, found_.size()));
  std::vector<std::pair<double, double>> places;
  for (const auto& t : found_) places.emplace_back(t.place, t.power);
  fit.description = tone_description(f_, fixed_in_hz_, to_input_, places);
  // The prediction on the window's cells (the twin's elsewhere).
  std::vector<std::vector<double>> predicted(d_.records_.size());
  for (std::size_t r = 0; r < d_.records_.size(); ++r) predicted[r].assign(d_.records_[r].cells.size(), kNaN);
  for (std::size_t e = 0; e < n_; ++e) predicted[w_[e].first][w_[e].second] = base_[e];
  fit.predict = d_.twin_elsewhere(std::move(predicted));
  return fit;
}

FeatureDescriber::Fit FeatureDescriber::tones(const GapFeature& f, const Window& w, bool fixed_in_hz, int max_tones) const {
  ToneSearch search(*this, f, w, fixed_in_hz);
  search.run(max_tones);
  return search.result();
}

FeatureDescription FeatureDescriber::describe_floor(const GapFeature& f) const {
  struct Band {
    double x, y, middle;  // log10(geometric centre / 1 kHz), g, arithmetic centre (its median bin), Hz
  };
  std::vector<Band> bands;
  for (const auto& floors : floors_)
    for (std::size_t b = 0; b < floors.bands.size(); ++b) {
      const double centre = std::sqrt(floors.bands[b].hz_low * floors.bands[b].hz_high);
      if (centre >= f.hz_low && centre <= f.hz_high)
        bands.push_back({std::log10(centre / 1000.0), floors.gap_db(b), 0.5 * (floors.bands[b].hz_low + floors.bands[b].hz_high)});
    }
  FeatureDescription none;
  if (bands.empty()) return none;
  // A change that begins at a corner inside the extent (a step): a band's floor is the median of
  // its bins, so a band reads the change when its median bin (its middle in Hz) lies above the
  // corner, and hardly at all when under it, whatever share of its upper bins the change covers.
  // The corner is tried under each band's middle, lowest first (under all of them: the change over
  // the whole extent); the bands under it are predicted unchanged.
  std::sort(bands.begin(), bands.end(), [](const Band& a, const Band& b) { return a.middle < b.middle; });
  struct Line {
    double level = 0, slope = 0, rss = std::numeric_limits<double>::infinity();
    std::size_t from = 0;  // the first band the change covers
  };
  auto line_from = [&](std::size_t from) {
    std::vector<double> x, y;
    for (std::size_t i = from; i < bands.size(); ++i) x.push_back(bands[i].x), y.push_back(bands[i].y);
    // A slope needs a span: over less than an octave it trades off with the level (a single band's
    // line would be any line), so there the change is a level alone.
    const double span = *std::max_element(x.begin(), x.end()) - *std::min_element(x.begin(), x.end());
    Line l;
    l.from = from;
    std::tie(l.level, l.slope) = line_fit(x, y);
    if (span < std::log10(2.0)) l.level = std::accumulate(y.begin(), y.end(), 0.0) / static_cast<double>(y.size()), l.slope = 0;
    l.rss = 0;
    for (std::size_t i = 0; i < bands.size(); ++i) {
      const double d = bands[i].y - (i < from ? 0.0 : l.level + l.slope * bands[i].x);
      l.rss += d * d;
    }
    return l;
  };
  // A corner is one more parameter: kept when it lowers the BIC (as the rule of the forms counts it).
  const double n = static_cast<double>(bands.size()), res2 = settings_.resolution_db * settings_.resolution_db;
  auto bic = [&](const Line& l) { return n * std::log(std::max(l.rss / n, res2)) + (l.from > 0 ? 3.0 : 2.0) * std::log(n); };
  Line best = line_from(0);
  for (std::size_t from = 1; from < bands.size(); ++from)
    if (bands[from].middle > bands[from - 1].middle)
      if (Line l = line_from(from); bic(l) < bic(best)) best = l;
  double gap_sq = 0, core_sq = 0;
  std::size_t core = 0;
  for (std::size_t i = 0; i < bands.size(); ++i) {
    const double d = bands[i].y - (i < best.from ? 0.0 : best.level + best.slope * bands[i].x);
    gap_sq += bands[i].y * bands[i].y;
    if (std::abs(bands[i].y) >= settings_.min_feature_db) core_sq += d * d, ++core;
  }
  none.gap_db = std::sqrt(gap_sq / n);
  // The rule as for the other forms: the line must bring the bands at the practical minimum under it.
  if (core == 0 || !(std::sqrt(core_sq / static_cast<double>(core)) < settings_.min_feature_db)) return none;
  FeatureDescription d;
  d.kind = DescriptionKind::floor_change;
  d.parameters = {{"level_db", best.level}, {"slope_db_per_decade", best.slope}};
  // The corner lies between the middles of the last band under it and the first over it.
  const double corner = best.from > 0 ? std::sqrt(bands[best.from - 1].middle * bands[best.from].middle) : 0.0;
  if (best.from > 0) d.parameters.emplace_back("corner_hz", corner);
  if (const double psd = white_floor_psd(f, corner); std::isfinite(psd)) d.parameters.emplace_back("white_psd_m2_s4_per_hz", psd);
  d.gap_db = none.gap_db;
  d.residual_db = std::sqrt(best.rss / n);
  return d;
}

double FeatureDescriber::white_floor_psd(const GapFeature& f, double corner_hz) const {
  // The noise_floor candidate's form on the floors: each band's measured floor per 1-order bin is
  // the twin's plus the acquisition's plus 2·S·speed (noise_floor_per_order_bin), one S for every
  // record; fitted in the log over the bands centred in the feature's extent, as describe_floor's.
  struct Band {
    double base, per_psd, g;  // twin + acquisition; power per unit PSD; measured g
  };
  std::vector<Band> bands;
  for (std::size_t r = 0; r < floors_.size(); ++r)
    for (std::size_t b = 0; b < floors_[r].bands.size(); ++b) {
      const FloorBand& band = floors_[r].bands[b];
      const double centre = std::sqrt(band.hz_low * band.hz_high);
      if (centre >= std::max(f.hz_low, corner_hz) && centre <= f.hz_high && band.twin + floors_[r].acquisition > 0)
        bands.push_back({band.twin + floors_[r].acquisition, noise_floor_per_order_bin(1.0, records_[r].speed_hz), floors_[r].gap_db(b)});
    }
  if (bands.empty()) return kNaN;
  auto residuals = [&](double psd, double& rss, double& core_sq, std::size_t& core) {
    rss = core_sq = 0, core = 0;
    for (const auto& b : bands) {
      const double d = b.g - 10 * std::log10((b.base + psd * b.per_psd) / b.base);
      rss += d * d;
      if (std::abs(b.g) >= settings_.min_feature_db) core_sq += d * d, ++core;
    }
  };
  // Added noise only raises a floor: the PSD that brings each band's base to its measured floor
  // bounds the search (log-spaced golden section between a thousandth of the least and ten times the largest).
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  for (const auto& b : bands) {
    const double need = b.base * (std::pow(10.0, b.g / 10) - 1) / b.per_psd;
    if (need > 0) lo = std::min(lo, need), hi = std::max(hi, need);
  }
  if (!(hi > 0)) return kNaN;
  double rss = 0, core_sq = 0;
  std::size_t core = 0;
  const double lp = golden_min([&](double x) { residuals(std::pow(10.0, x), rss, core_sq, core); return rss; },
                               std::log10(lo) - 3, std::log10(hi) + 1, 60);
  residuals(std::pow(10.0, lp), rss, core_sq, core);
  // The rule of the forms, over every band of the feature and not only those at the practical
  // minimum: white noise raises every band alike, so it must not lift the feature's quiet bands
  // (a change confined to part of them is not white) any more than leave its raised ones.
  if (core == 0 || !(std::sqrt(rss / static_cast<double>(bands.size())) < settings_.min_feature_db)) return kNaN;
  return std::pow(10.0, lp);
}

FeatureDescription FeatureDescriber::chosen_form(const std::vector<Fit>& fits, const Window& w) const {
  FeatureDescription none;
  if (w.empty()) return none;
  double gap_sq = 0;
  std::size_t core = 0;
  for (const auto& [r, i] : w) {
    const double g = g_of(r, i, records_[r].cells[i].measured);
    gap_sq += g * g;
    core += std::abs(g) >= settings_.min_feature_db ? 1 : 0;
  }
  const double n = static_cast<double>(w.size());
  none.gap_db = std::sqrt(gap_sq / n);
  if (core == 0) return none;
  FeatureDescription best = none;
  double best_bic = std::numeric_limits<double>::infinity();
  for (const auto& fit : fits) {
    double rss = 0, core_sq = 0;
    for (const auto& [r, i] : w) {
      const double g = g_of(r, i, records_[r].cells[i].measured), d = g - g_of(r, i, fit.predict(r, i));
      rss += d * d;
      if (std::abs(g) >= settings_.min_feature_db) core_sq += d * d;
    }
    if (!(std::sqrt(core_sq / static_cast<double>(core)) < settings_.min_feature_db)) continue;  // its gap stays
    const double res2 = settings_.resolution_db * settings_.resolution_db;
    const double bic = n * std::log(std::max(rss / n, res2)) + fit.complexity * std::log(n);
    if (bic < best_bic) {
      best_bic = bic;
      best = fit.description;
      best.gap_db = none.gap_db;
      best.residual_db = std::sqrt(rss / n);
    }
  }
  return best;
}

FeatureDescription FeatureDescriber::describe(const GapFeature& f) const {
  const Window w = window_of(f);
  // The gap first: a window without a cell at the practical minimum is described by no form, so
  // the local forms' searches are not run for it.
  const FeatureDescription none = chosen_form({}, w);
  // A tone adds power to the cells it reaches (the twin's, plus a share that is never negative), so
  // its predicted gap is never under 0 dB: where no cell rises by the practical minimum, every core
  // cell stays at least that far from it and no tone form can remove the gap. Their searches, the
  // costliest of the forms, are not run there (a feature where the measurement falls under the twin).
  bool core = false, rises = false;
  for (const auto& [r, i] : w) {
    const double g = g_of(r, i, records_[r].cells[i].measured);
    core = core || std::abs(g) >= settings_.min_feature_db;
    rises = rises || g >= settings_.min_feature_db;
  }
  if (!core) return local_resonance(f, w, none);
  std::vector<Fit> fits{floor_, tilt_, modulation_input_, modulation_output_};
  // The local forms where they can be the one cause: a resonance within an octave (the forms' ζ
  // ≤ 0.3 keeps its 3 dB band there for gains up to 10 dB), a tone fixed in Hz within four input
  // orders (a weak one's leakage reaches three lines each side).
  double top_speed = 0;
  for (const auto& r : records_) top_speed = std::max(top_speed, r.speed_hz);
  if (f.hz_high <= 2 * f.hz_low) fits.push_back(resonance(f, w));
  if (rises) {
    // A ghost (searched about the feature's centre, below) on every feature not fixed in Hz: a tone's
    // leakage stands over the practical minimum as far as the tone stands over the twin, so a strong
    // one spreads a feature over tens of orders, and its |g|-weighted centre, shifting with speed as
    // the leakage's skew does, can make it move with neither.
    if (f.movement != FeatureMovement::fixed_in_hz) fits.push_back(tones(f, w, false, 1));
    // Tones fixed in Hz: up to kMaxTones in a feature fixed in Hz (supply pick-up and its harmonics
    // join into one band), each within four input orders of the next; else one.
    const double hz_width = f.hz_high - f.hz_low;
    if (f.movement == FeatureMovement::fixed_in_hz && hz_width <= kMaxTones * 4 * top_speed) fits.push_back(tones(f, w, true, kMaxTones));
    else if (f.movement != FeatureMovement::fixed_in_orders && hz_width <= 4 * top_speed) fits.push_back(tones(f, w, true, 1));
  }
  // A narrow resonance between the lines stands mostly under the comparison's floor, where no form
  // against the twin can reach it while a line or bin of its window is over the practical minimum:
  // when none removes the gap, its bins against their neighbourhood are asked.
  const FeatureDescription chosen = chosen_form(fits, w);
  return chosen.kind == DescriptionKind::none ? local_resonance(f, w, chosen) : chosen;
}

void FeatureDescriber::join_resonance_flanks(std::vector<GapFeature>& features) const {
  auto shares_a_speed = [](const GapFeature& a, const GapFeature& b) {
    for (const auto& x : a.seen_in)
      for (const auto& y : b.seen_in)
        if (std::abs(x.speed_hz - y.speed_hz) <= 1e-9 * std::max(x.speed_hz, y.speed_hz)) return true;
    return false;
  };
  auto resonant = [](const GapFeature& f) { return f.description.kind == DescriptionKind::resonance; };
  // A flank seen at one speed only may as well be described as a tone there (one line's excess):
  // such features are offered too, the joint window deciding.
  auto one_speed = [](const GapFeature& f) {
    for (const auto& s : f.seen_in)
      if (std::abs(s.speed_hz - f.seen_in.front().speed_hz) > 1e-9 * s.speed_hz) return false;
    return !f.seen_in.empty();
  };
  auto offered = [&](const GapFeature& f) { return resonant(f) || one_speed(f); };
  // After each join the pairs are tried again from the first: a pair neither of whose features
  // changed gives the same joint band and window, whose description (a function of those alone) is
  // kept rather than fitted again.
  std::map<std::tuple<double, double, double, Window>, FeatureDescription> described;
  for (bool joined = true; joined;) {
    joined = false;
    for (std::size_t i = 0; i < features.size() && !joined; ++i)
      for (std::size_t j = i + 1; j < features.size() && !joined; ++j) {
        if (!offered(features[i]) || !offered(features[j]) || shares_a_speed(features[i], features[j])) continue;
        GapFeature u = joined_features(features[i], features[j], gears_, settings_.min_speed_ratio);
        if (!(u.hz_high <= 2 * u.hz_low)) continue;
        // The joint sightings are read in Hz (a resonance is fixed there); their spread in Hz is
        // the resonance's width, which the movement rule's one bin does not hold.
        double slow = std::numeric_limits<double>::infinity(), fast = 0;
        for (const auto& s : u.seen_in) slow = std::min(slow, s.speed_hz), fast = std::max(fast, s.speed_hz);
        u.movement = fast >= slow * settings_.min_speed_ratio ? FeatureMovement::fixed_in_hz : FeatureMovement::undetermined;
        const GapFeature in_hz = [&] { GapFeature h = u; h.movement = FeatureMovement::fixed_in_hz; return h; }();
        const Window w = window_of(in_hz);
        auto joint = [&] { return chosen_form({floor_, tilt_, modulation_input_, modulation_output_, resonance(in_hz, w)}, w); };
        if (std::isfinite(in_hz.hz_low) && std::isfinite(in_hz.hz_high) && std::isfinite(in_hz.hz)) {  // an ordered key
          auto key = std::make_tuple(in_hz.hz_low, in_hz.hz_high, in_hz.hz, w);
          auto it = described.find(key);
          if (it == described.end()) it = described.emplace(std::move(key), joint()).first;
          u.description = it->second;
        } else {
          u.description = joint();
        }
        if (!resonant(u)) continue;
        features[i] = std::move(u);
        features.erase(features.begin() + static_cast<std::ptrdiff_t>(j));
        joined = true;
      }
  }
  std::stable_sort(features.begin(), features.end(),
                   [](const GapFeature& a, const GapFeature& b) { return std::abs(a.size_db) > std::abs(b.size_db); });
}

namespace {
/// The frequencies of a fixed-tone description's tones (tone_k_hz; frequency_hz for a single one).
std::vector<double> tone_frequencies(const FeatureDescription& d) {
  const double count = d.parameter("tones");
  if (!(count >= 1)) return {d.parameter("frequency_hz")};
  std::vector<double> out;
  for (int k = 1; k <= static_cast<int>(count); ++k) out.push_back(d.parameter("tone_" + std::to_string(k) + "_hz"));
  return out;
}
void set_parameter(FeatureDescription& d, const std::string& name, double v) {
  for (auto& [n, value] : d.parameters)
    if (n == name) value = v;
}
}  // namespace

void FeatureDescriber::describe_all(std::vector<GapFeature>& features) const {
  for (auto& f : features) f.description = describe(f);
  join_resonance_flanks(features);
  // Tones: supply pick-up when near a harmonic of 50 or 60 Hz (the base more of them sit on), else
  // harmonics of the lowest tone they are integer multiples of; counted over every tone of every
  // feature (a supply's harmonics may sit in one feature or several).
  double top_speed = 0;
  for (const auto& r : records_) top_speed = std::max(top_speed, r.speed_hz);
  const double tol = settings_.supply_tolerance_orders * top_speed;
  std::vector<FeatureDescription*> described;
  std::vector<double> all;
  for (auto& f : features)
    if (f.description.kind == DescriptionKind::fixed_tone) {
      described.push_back(&f.description);
      for (double hz : tone_frequencies(f.description)) all.push_back(hz);
    }
  auto harmonic_of = [&](double hz, double base) {
    const double k = std::round(hz / base);
    return k >= 1 && k <= settings_.max_supply_harmonic && std::abs(hz - k * base) <= tol ? k : 0.0;
  };
  int on50 = 0, on60 = 0;
  for (double hz : all) on50 += harmonic_of(hz, 50) > 0, on60 += harmonic_of(hz, 60) > 0;
  const double supply = on50 == 0 && on60 == 0 ? 0.0 : on60 > on50 ? 60.0 : 50.0;
  double lowest = std::numeric_limits<double>::infinity();
  for (double hz : all)
    if (supply == 0 || harmonic_of(hz, supply) == 0) lowest = std::min(lowest, hz);
  auto harmonic = [&](double hz) -> std::pair<double, double> {  // (fundamental, harmonic number); 0: neither
    if (const double k = supply > 0 ? harmonic_of(hz, supply) : 0.0; k > 0) return {supply, k};
    if (std::isfinite(lowest)) {
      const double k = std::round(hz / lowest);
      if (k >= 1 && std::abs(hz - k * lowest) <= tol) return {lowest, k};
    }
    return {0.0, 0.0};
  };
  for (auto* d : described) {
    const auto hz = tone_frequencies(*d);
    const bool listed = d->parameter("tones") >= 1;
    double supply_power = 0, power = 0;
    for (std::size_t k = 0; k < hz.size(); ++k) {
      const auto [base, h] = harmonic(hz[k]);
      const std::string name = "tone_" + std::to_string(k + 1);
      const double a = listed ? d->parameter(name + "_amplitude_m_s2") : d->parameter("amplitude_m_s2");
      power += a * a, supply_power += supply > 0 && base == supply ? a * a : 0.0;
      if (listed) set_parameter(*d, name + "_harmonic", h);
    }
    // The description is supply pick-up when the supply's harmonics carry most of its tones' power.
    const auto [base, h] = harmonic(hz.front());
    if (base > 0) set_parameter(*d, "fundamental_hz", base), set_parameter(*d, "harmonic", h);
    if (2 * supply_power > power && power > 0) set_parameter(*d, "supply_hz", supply);
  }
}

}  // namespace gearwatch::gap
