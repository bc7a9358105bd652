#include "gearwatch/gap/unit_tone.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include "gearwatch/dsp/envelope.hpp"
#include "gearwatch/dsp/fft.hpp"
#include "gearwatch/dsp/order_tracking.hpp"
#include "gearwatch/dsp/tsa.hpp"
#include "gearwatch/gap/describe.hpp"

namespace gearwatch::gap {
namespace {

using Complex = std::complex<double>;
constexpr double kPi = std::numbers::pi;
// SynchronousSeparation's end taper (its default): the averages are taken as it takes them.
constexpr double kEndTaper = dsp::kSynchronousEndTaperFraction;
// The output grid's gear-ratio fraction makes a grid of z_pinion/gcd · spr points; beyond this the
// reduction itself is cheaper.
constexpr std::size_t kMaxFineGrid = std::size_t{1} << 22;
// A tone within this factor of the coarse output grid's cutoff sits in its kernel's transition band.
constexpr double kTransition = 0.8;
// Half-order bins each side of a broadband bin whose components it follows (half_bin_power).
constexpr double kBlockReach = 64;

/// Σ_{i<N} e^{i2π·x·i/N}: a Dirichlet kernel, its limit where the denominator vanishes.
Complex geometric(std::size_t count, double x) {
  const auto n = static_cast<double>(count);
  const double s = std::sin(kPi * x / n);
  const Complex turn = std::polar(1.0, kPi * x * (n - 1) / n);
  if (std::abs(s) < 1e-13) return turn * (n * std::cos(kPi * x) / std::cos(kPi * x / n));
  return turn * (std::sin(kPi * x) / s);
}

/// Harmonics 0 .. ⌈spr/2⌉ − 1 of one revolution's samples, per sample (spectrum / spr).
std::vector<Complex> harmonics(const std::vector<double>& revolution) {
  thread_local dsp::FftPlanCache plans;
  const auto& fft = plans.real(revolution.size());
  dsp::RealBuffer in(revolution.begin(), revolution.end());
  dsp::ComplexBuffer spectrum(fft.spectrum_size());
  fft.forward(in, spectrum);
  std::vector<Complex> h((revolution.size() + 1) / 2);
  for (std::size_t k = 0; k < h.size(); ++k) h[k] = spectrum[k] / static_cast<double>(revolution.size());
  return h;
}

/// Σ_k t_k e^{i2πkθ} over k < `count` (a real signal's harmonics: t_0 + 2 Re Σ_{k≥1}).
double trig_sum(const std::vector<Complex>& t, std::size_t count, double theta) {
  double v = t[0].real();
  const Complex step = std::polar(1.0, 2 * kPi * theta);
  Complex z = 1.0;
  for (std::size_t k = 1; k < count; ++k) {
    z *= step;
    v += 2 * (t[k] * z).real();
  }
  return v;
}

}  // namespace

namespace detail {

DirichletSum::DirichletSum(std::size_t count) : n_(static_cast<double>(count)), count_(count) {}

void DirichletSum::add(double at, std::complex<double> amplitude) {
  at_.push_back(at);
  amplitude_.push_back(amplitude);
  lead_.push_back(amplitude * std::sin(kPi * at) * std::polar(1.0, kPi * at * (n_ - 1) / n_));
}

std::complex<double> DirichletSum::at_line(double line) const {
  // sin(π(at − line)) = (−1)^line·sin(π·at) and the phase e^{iπ(at − line)(N−1)/N} split into the
  // component's part (lead) and the line's (factor): one sine a term.
  const auto whole = static_cast<long long>(line);
  const Complex factor = std::polar(whole % 2 == 0 ? 1.0 : -1.0, -kPi * line * (n_ - 1) / n_);
  Complex sum{};
  for (std::size_t c = 0; c < at_.size(); ++c) {
    const double s = std::sin(kPi * (at_[c] - line) / n_);
    if (std::abs(s) < 1e-9) sum += amplitude_[c] * geometric(count_, at_[c] - line) / factor;
    else sum += lead_[c] / s;
  }
  return factor * sum;
}

}  // namespace detail

double unit_tone_sample_rate(double top_order, const SpectralSummary& like, double samples_per_cycle) noexcept {
  return std::min(like.sample_rate_hz, samples_per_cycle * (top_order + 4) * like.speed_hz);
}

void unit_tone_samples(double order, double speed_hz, double sample_rate_hz, std::span<float> out) {
  // A rotating phasor, set exactly every kExact samples: one std::cos a sample costs as much as the
  // reduction's resampling, and the rotation's rounding over kExact steps stays orders under the
  // float the sample is stored in.
  constexpr std::size_t kExact = 256;
  const double step = 2 * kPi * order * speed_hz / sample_rate_hz;
  const Complex rotation = std::polar(1.0, step);
  Complex z;
  for (std::size_t i = 0; i < out.size(); ++i) {
    z = i % kExact == 0 ? std::polar(1.0, step * static_cast<double>(i)) : z * rotation;
    out[i] = static_cast<float>(z.real());
  }
}

UnitToneCells::UnitToneCells(double order, double top_order, const SpectralSummary& like, const GearPairSpec& gears,
                             double samples_per_cycle, std::optional<UnitToneReads> reads)
    : order_(order), gears_(gears) {
  exact_ = set_up(like, top_order, samples_per_cycle, reads);
  if (!exact_) fallback_ = unit_tone_spectra(order, top_order, like, gears, samples_per_cycle);
}

bool UnitToneCells::set_up(const SpectralSummary& like, double top_order, double samples_per_cycle,
                           const std::optional<UnitToneReads>& reads) {
  if (gears_.pinion_teeth < 1 || gears_.gear_teeth < 1 || !(like.speed_hz > 0)) return false;
  speed_ = like.speed_hz;
  fs_ = unit_tone_sample_rate(top_order, like, samples_per_cycle);
  const std::size_t revs = like.input_revolutions;
  n_ = static_cast<std::size_t>((static_cast<double>(revs) + 0.5) * fs_ / speed_);
  std::vector<double> edges(revs + 1);
  for (std::size_t k = 0; k <= revs; ++k) edges[k] = static_cast<double>(k) * fs_ / speed_;
  const ReductionGrid grid = reduction_grid(edges, fs_, gears_);
  revs_ = grid.input_revolutions, out_revs_ = grid.output_revolutions, spr_ = grid.spr, spr_out_ = grid.spr_out;
  k_in_ = grid.k_in, k_out_ = grid.k_out;
  ratio_ = static_cast<double>(gears_.gear_teeth) / gears_.pinion_teeth;
  if (revs_ < 3 || static_cast<std::size_t>(gears_.pinion_teeth / std::gcd(gears_.pinion_teeth, gears_.gear_teeth)) * spr_ > kMaxFineGrid)
    return false;
  // Every check that sends the tone to the reduction comes before the closed form's set-up, which
  // would otherwise be paid on top of the reduction.
  const std::size_t part_size = std::min(revs_ * spr_, 4 * spr_);
  if ((reads && !cheaper_than_reduction(*reads)) || !grids_fit(part_size)) return false;
  // The input grid's leading revolution as the resampler makes it (its kernel reads zeros before the
  // record's start): from the record's head only.
  dsp::ShaftAngle angle;
  if (!angle.assign(edges, 1, 1.0).ok()) return false;
  const double per_rev = fs_ / speed_;
  std::vector<float> head(std::min(n_, static_cast<std::size_t>(std::ceil(per_rev)) + 64));
  unit_tone_samples(order_, speed_, fs_, head);
  dsp::AngularResampler resampler;
  std::vector<double> head_in(spr_);
  resampler.resample(head, angle, spr_, 1, head_in, 1.0);
  const double reach = resampler.interpolator().taps() / 2.0 + 1, spacing = per_rev / static_cast<double>(spr_);
  delta_in_.clear();
  for (std::size_t j = 0; j < spr_ && static_cast<double>(j) * spacing < reach; ++j)
    delta_in_.push_back(head_in[j] - std::cos(2 * kPi * order_ * static_cast<double>(j) / static_cast<double>(spr_)));
  input_average();
  // The output-only signal's head on the input grid (the leading revolution the resampler's, float as stored).
  std::vector<float> part(part_size);
  for (std::size_t j = 0; j < part.size(); ++j)
    part[j] = static_cast<float>((j < spr_ ? head_in[j] : std::cos(2 * kPi * order_ * static_cast<double>(j) / static_cast<double>(spr_))) -
                                 tsa_in_[j % spr_]);
  output_average(part);
  set_lines();
  return true;
}

bool UnitToneCells::cheaper_than_reduction(const UnitToneReads& reads) const {
  // Costs in units of the reduction's cost per sample of the record: the set-up resamples a
  // revolution and transforms the gear ratio's fine grid; a Dirichlet or block term (a sine and a few
  // complex products) costs a tenth of a reduced sample.
  constexpr double kSetUp = 0.25, kTerm = 0.1;
  const auto spr = static_cast<double>(spr_), samples = static_cast<double>(revs_) * spr;
  const double bin_terms = 2 * static_cast<double>(revs_ - 1) * (kBlockReach * ratio_ + 3);  // two half-order bins
  const double terms = static_cast<double>(reads.lines) * spr + static_cast<double>(reads.broadband) * bin_terms;
  return kSetUp * samples + kTerm * terms < samples;
}

void UnitToneCells::input_average() {
  const double f = order_;
  const auto spr = static_cast<double>(spr_);
  // Plain sums: the cosine's over the revolutions is a geometric series at each position.
  const Complex sum = geometric(revs_, f * static_cast<double>(revs_));
  const std::size_t n = revs_ * spr_;
  const auto ramp = std::min(n / 2, static_cast<std::size_t>(std::ceil(0.5 * kEndTaper * static_cast<double>(n))));
  auto value = [&](std::size_t j) {
    return std::cos(2 * kPi * f * static_cast<double>(j) / spr) + (j < delta_in_.size() ? delta_in_[j] : 0.0);
  };
  // SynchronousSeparation's tapered average, its plain sums from the series, the ramps sample by sample.
  std::vector<double> plain(spr_);
  for (std::size_t i = 0; i < spr_; ++i)
    plain[i] = (std::polar(1.0, 2 * kPi * f * static_cast<double>(i) / spr) * sum).real() + (i < delta_in_.size() ? delta_in_[i] : 0.0);
  std::vector<double> weight(spr_, static_cast<double>(revs_));
  auto reweight = [&](std::size_t j) {
    const double w = dsp::tukey_weight(j, n, kEndTaper);
    plain[j % spr_] -= (1.0 - w) * value(j);
    weight[j % spr_] -= 1.0 - w;
  };
  for (std::size_t j = 0; j < ramp; ++j) {
    reweight(j);
    if (n - 1 - j != j) reweight(n - 1 - j);
  }
  for (std::size_t i = 0; i < spr_; ++i) plain[i] /= weight[i];
  tsa_in_ = std::move(plain);
  t_ = harmonics(tsa_in_);
}


namespace {

/// The interpolator resample_uniform_angle uses for a grid of `samples_per_rev` a revolution of a
/// shaft turning once every `per_rev` input revolutions, `spr` samples an input revolution.
dsp::BandLimitedInterpolator grid_kernel(double per_rev, std::size_t spr, std::size_t samples_per_rev) {
  const double spacing = per_rev * static_cast<double>(spr) / static_cast<double>(samples_per_rev);
  const double cutoff = spacing <= 1.0 ? 1.0 : std::floor(64.0 / spacing) / 64.0;
  dsp::BandLimitedInterpolator interpolator;
  interpolator.set_cutoff(std::max(cutoff, 1.0 / 64.0));
  return interpolator;
}

/// Hann-windowed DFT over 2·spr samples of e^{i2π·mu·i/spr} at half-order bin j: three Dirichlet kernels.
Complex hann_bin(double mu, double j, std::size_t spr) {
  const std::size_t n = 2 * spr;
  const double x = 2 * mu - j;
  return 0.5 * geometric(n, x) - 0.25 * geometric(n, x + 1) - 0.25 * geometric(n, x - 1);
}

}  // namespace

std::vector<double> UnitToneCells::grid_head(const std::vector<float>& part, std::size_t samples_per_rev,
                                             std::size_t harmonics_kept, double tone) const {
  const dsp::BandLimitedInterpolator interpolator = grid_kernel(ratio_, spr_, samples_per_rev);
  const double reach = interpolator.taps() / 2.0 + 1, per_input_rev = static_cast<double>(spr_);
  const double step = ratio_ / static_cast<double>(samples_per_rev);
  std::vector<double> delta;
  for (std::size_t j = 0;; ++j) {
    const double t = static_cast<double>(j) * step * per_input_rev;  // resample_uniform_angle's position
    if (t >= reach) break;
    const double theta = t / per_input_rev;
    delta.push_back(interpolator(part, t) - (tone * std::cos(2 * kPi * order_ * theta) - trig_sum(t_, harmonics_kept, theta)));
  }
  return delta;
}

bool UnitToneCells::grids_fit(std::size_t part_size) const {
  // Each output grid ends with its kernel inside the output-only signal (else the reduction reads
  // zeros there, which this does not follow), and the heads' kernels inside the output-only
  // signal's head (`part_size` samples).
  for (const std::size_t per : {spr_out_, spr_}) {
    const double reach = grid_kernel(ratio_, spr_, per).taps() / 2.0 + 1;
    const double last = static_cast<double>(out_revs_ * per - 1) * (ratio_ / static_cast<double>(per)) * static_cast<double>(spr_);
    if (last + reach + 1 > static_cast<double>(revs_ * spr_) || 2 * reach + 2 > static_cast<double>(part_size)) return false;
  }
  // The output shaft's grid (spr a revolution, ratio input revolutions): a tone in its kernel's
  // transition band is followed by the reduction itself.
  const double limit = grid_kernel(ratio_, spr_, spr_).cutoff() * static_cast<double>(spr_) / 2;
  return !(order_ > kTransition * limit && order_ < limit / kTransition);
}

void UnitToneCells::output_average(const std::vector<float>& part) {
  delta_out_ = grid_head(part, spr_out_, t_.size(), 1.0);
  // The output shaft's grid: the kernel's cutoff keeps the input average's harmonics under
  // cutoff·spr/2, and the tone when it lies there (grids_fit keeps it out of the transition band).
  const double limit = grid_kernel(ratio_, spr_, spr_).cutoff() * static_cast<double>(spr_) / 2;
  const double tone = order_ < limit ? 1.0 : 0.0;
  const std::size_t kept = std::min(t_.size(), static_cast<std::size_t>(std::ceil(limit)));
  const std::vector<double> delta_lp = grid_head(part, spr_, kept, tone);
  // Positions ratio·j/spr input revolutions fall on the grid of (z_pinion/g)·spr points a revolution.
  const auto g = static_cast<std::size_t>(std::gcd(gears_.pinion_teeth, gears_.gear_teeth));
  const std::size_t p_in = static_cast<std::size_t>(gears_.pinion_teeth) / g, p_out = static_cast<std::size_t>(gears_.gear_teeth) / g;
  const std::size_t fine = p_in * spr_;
  thread_local dsp::FftPlanCache plans;
  const auto& fft = plans.real(fine);
  dsp::ComplexBuffer spectrum(fft.spectrum_size());
  for (std::size_t k = 0; k < kept && k < spectrum.size(); ++k) spectrum[k] = t_[k];
  dsp::RealBuffer average_on_fine(fine);
  fft.inverse(spectrum, average_on_fine);
  std::vector<double> grid(out_revs_ * spr_);
  constexpr std::size_t kExact = 256;
  const double step = 2 * kPi * order_ * ratio_ / static_cast<double>(spr_);
  const Complex rotation = std::polar(1.0, step);
  Complex z;
  for (std::size_t j = 0, p = 0; j < grid.size(); ++j, p = (p + p_out) % fine) {
    z = j % kExact == 0 ? std::polar(1.0, step * static_cast<double>(j)) : z * rotation;
    grid[j] = tone * z.real() - average_on_fine[p] + (j < delta_lp.size() ? delta_lp[j] : 0.0);
  }
  std::vector<double> tsa_out(spr_);
  dsp::tapered_synchronous_average(grid, spr_, kEndTaper, tsa_out);
  o_ = harmonics(tsa_out);
  for (std::size_t m = 0; m < o_.size(); m += p_out) o_[m] = 0;  // DC and the orders both shafts share stay with the input
}

void UnitToneCells::set_lines() {
  // A component e^{i2π·nu·θ} of weight w on R revolutions of N samples puts w·2·G_R(nu·R)/(R·N)
  // · G_N(nu − k) on line k (G the Dirichlet kernels of geometric()).
  const auto r_in = static_cast<double>(revs_), r_out = static_cast<double>(out_revs_);
  input_lines_ = detail::DirichletSum(spr_);
  auto in = [&](double nu, Complex w) {
    input_lines_.add(nu, w * 2.0 * geometric(revs_, nu * r_in) / (r_in * static_cast<double>(spr_)));
  };
  in(order_, 0.5);
  in(-order_, 0.5);
  // Less the output shaft's average upsampled onto the input grid: harmonic m is input order m/ratio.
  for (std::size_t m = 1; m < o_.size(); ++m)
    if (o_[m] != Complex{}) in(static_cast<double>(m) / ratio_, -o_[m]), in(-static_cast<double>(m) / ratio_, -std::conj(o_[m]));
  output_lines_ = detail::DirichletSum(spr_out_);
  auto out = [&](double nu, Complex w) {
    output_lines_.add(nu, w * 2.0 * geometric(out_revs_, nu * r_out) / (r_out * static_cast<double>(spr_out_)));
  };
  out(order_ * ratio_, 0.5);
  out(-order_ * ratio_, 0.5);
  // Less the input shaft's average, band-limited: its harmonic k is output order k·ratio.
  out(0.0, -t_[0].real());
  for (std::size_t k = 1; k < t_.size(); ++k)
    out(static_cast<double>(k) * ratio_, -t_[k]), out(-static_cast<double>(k) * ratio_, -std::conj(t_[k]));
}

namespace {
/// A line's share of a grid head's correction: `delta` (the resampler's leading samples less the
/// closed form) through the per-revolution DFT at `order`, averaged over `revolutions`.
Complex head_correction(const std::vector<double>& delta, double order, std::size_t samples_per_rev, std::size_t revolutions) {
  const auto spr = static_cast<double>(samples_per_rev);
  Complex sum;
  for (std::size_t j = 0; j < delta.size(); ++j)
    sum += 2.0 / (spr * static_cast<double>(revolutions)) * delta[j] * std::polar(1.0, -2 * kPi * order * static_cast<double>(j) / spr);
  return sum;
}
}  // namespace

double UnitToneCells::input_line(std::size_t index) const {
  if (!exact_) return index < fallback_.input_lines.size() ? fallback_.input_lines[index] : 0.0;
  if (index >= k_in_) return 0.0;
  const auto k = static_cast<double>(index + 1);
  return std::norm(input_lines_.at_line(k) + head_correction(delta_in_, k, spr_, revs_));
}

double UnitToneCells::output_line(std::size_t index) const {
  if (!exact_) return index < fallback_.output_lines.size() ? fallback_.output_lines[index] : 0.0;
  if (index >= k_out_ || output_line_is_mesh(static_cast<int>(index + 1), gears_.gear_teeth)) return 0.0;
  const auto m = static_cast<double>(index + 1);
  return std::norm(output_lines_.at_line(m) + head_correction(delta_out_, m, spr_out_, out_revs_));
}

double UnitToneCells::half_bin_power(std::size_t j) const {
  const std::size_t blocks = revs_ - 1;
  const auto bin = static_cast<double>(j), spr = static_cast<double>(spr_);
  std::vector<Complex> x(blocks);
  // Block b starts at input revolution b: a component at order mu turns by e^{i2π·mu} a block.
  auto add = [&](double mu, Complex amplitude) {
    const Complex v = amplitude * hann_bin(mu, bin, spr_), turn = std::polar(1.0, 2 * kPi * mu);
    Complex z = 1.0;
    for (std::size_t b = 0; b < blocks; ++b, z *= turn) x[b] += v * z;
  };
  add(order_, 0.5);
  add(-order_, 0.5);
  // The output shaft's average, over the harmonics within kBlockReach half-order bins of this one:
  // the Hann kernel falls as 1/d³, so those beyond add under 1e-4 of the tone's amplitude together.
  const double reach = kBlockReach * ratio_ / 2;
  const auto last = static_cast<long long>(o_.size()) - 1;
  const long long up_from = std::max(1LL, static_cast<long long>(std::ceil(bin * ratio_ / 2 - reach)));
  const long long up_to = std::min(last, static_cast<long long>(std::floor(bin * ratio_ / 2 + reach)));
  for (long long m = up_from; m <= up_to; ++m)
    if (o_[m] != Complex{}) add(static_cast<double>(m) / ratio_, -o_[m]);
  const long long down_to = std::min(last, static_cast<long long>(std::floor(reach - bin * ratio_ / 2)));
  for (long long m = 1; m <= down_to; ++m)
    if (o_[m] != Complex{}) add(-static_cast<double>(m) / ratio_, -std::conj(o_[m]));
  // The leading samples' correction, in the first block only (the input average, the same in every
  // block, leaves the blocks' deviations from their mean alone).
  for (std::size_t i = 0; i < delta_in_.size(); ++i) {
    const double w = 0.5 - 0.5 * std::cos(2 * kPi * static_cast<double>(i) / (2 * spr));
    x[0] += w * delta_in_[i] * std::polar(1.0, -2 * kPi * bin * static_cast<double>(i) / (2 * spr));
  }
  const double scale = 4.0 / (2 * spr) / std::sqrt(1.5);
  Complex mean{};
  for (auto& v : x) mean += (v *= scale);
  mean /= static_cast<double>(blocks);
  double power = 0;
  for (const auto& v : x) power += std::norm(v - mean);
  return power / std::max(1.0, static_cast<double>(blocks) - 1.0);
}

double UnitToneCells::broadband(std::size_t index) const {
  if (!exact_) return index < fallback_.broadband.size() ? fallback_.broadband[index] : 0.0;
  if (index >= k_in_) return 0.0;
  return half_bin_power(2 * (index + 1)) + half_bin_power(2 * (index + 1) + 1);
}

}  // namespace gearwatch::gap
