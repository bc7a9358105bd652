#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/dsp/window.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <complex>
#include <map>
#include <numbers>
#include <numeric>
#include <optional>
#include <span>
#include <stdexcept>

#include "gearwatch/dsp/fft.hpp"
#include "gearwatch/dsp/order_tracking.hpp"
#include "gearwatch/dsp/tsa.hpp"

namespace gearwatch::gap {
namespace {

// The synchronous mean of each line's per-revolution DFT ([rev * lines + line]) over the chosen
// revolutions. Plain, not weighted: Hann weights over so few revolutions widen the leakage of the
// other shaft's tones instead of narrowing it (4 output revolutions cannot separate a tone 0.2
// output orders from a line).
std::vector<std::complex<double>> mean_over_revolutions(const std::vector<std::complex<double>>& dft,
                                                        const std::vector<std::size_t>& revolutions, std::size_t lines) {
  std::vector<std::complex<double>> mean(lines);
  for (std::size_t r : revolutions)
    for (std::size_t k = 0; k < lines; ++k) mean[k] += dft[r * lines + k];
  for (auto& m : mean) m /= static_cast<double>(revolutions.size());
  return mean;
}

// Revolutions (or blocks) 0 .. n−1: the summary over the whole record.
std::vector<std::size_t> every_revolution(std::size_t n) {
  std::vector<std::size_t> v(n);
  std::iota(v.begin(), v.end(), std::size_t{0});
  return v;
}

// Lines above this fraction of the sample rate sit in the anti-alias roll-off of any front-end
// and of the resampler's kernel; they are left out rather than compared.
constexpr double kUsableBandFraction = 0.45;
// Transform sizes a thread keeps planned before it plans afresh (a diagnosis uses a handful).
constexpr std::size_t kMaxCachedPlans = 64;

void per_revolution_dft(const dsp::RealBuffer& angle, std::size_t spr, std::size_t revs, std::size_t lines,
                        const dsp::RealFft& fft, std::vector<std::complex<double>>& out) {
  dsp::RealBuffer in(spr);
  dsp::ComplexBuffer spectrum(fft.spectrum_size());
  out.assign(revs * lines, {});
  const double scale = 2.0 / static_cast<double>(spr);  // peak amplitude of a synchronous sinusoid
  for (std::size_t r = 0; r < revs; ++r) {
    std::copy(angle.begin() + static_cast<std::ptrdiff_t>(r * spr),
              angle.begin() + static_cast<std::ptrdiff_t>((r + 1) * spr), in.begin());
    fft.forward(in, spectrum);
    for (std::size_t k = 1; k <= lines; ++k) out[r * lines + k - 1] = spectrum[k] * scale;
  }
}

/// Whether an order lies within kSidebandOrders of a mesh harmonic n·z (n ≥ 1), the harmonic excluded.
bool is_sideband_order(int order, int teeth) noexcept {
  if (teeth <= 2 * kSidebandOrders || order % teeth == 0 || order < teeth - kSidebandOrders) return false;
  const int from_below = order % teeth;
  return from_below <= kSidebandOrders || teeth - from_below <= kSidebandOrders;
}

/// The record's `channel`, checked: a sample rate, the channel present, every sample finite.
const std::vector<float>& checked_channel(const Record& record, int channel) {
  if (!(record.sample_rate_hz > 0)) throw std::invalid_argument("record has no sample rate");
  if (channel < 0 || static_cast<std::size_t>(channel) >= record.channels.size())
    throw std::invalid_argument("record has no channel " + std::to_string(channel));
  const auto& x = record.channels[static_cast<std::size_t>(channel)];
  for (float v : x)
    if (!std::isfinite(v)) throw std::invalid_argument("record has non-finite samples");
  return x;
}

/// The whole revolutions of each shaft and the input shaft's mean speed over its whole revolutions.
struct WholeRevolutions {
  std::size_t input = 0, output = 0;
  double speed_hz = 0;
};

WholeRevolutions whole_revolutions(const dsp::ShaftAngle& angle, double ratio, double sample_rate_hz,
                                   std::size_t min_revolutions) {
  WholeRevolutions r;
  const double total = angle.total_revolutions();
  r.input = static_cast<std::size_t>(std::floor(total + 1e-9));
  r.output = static_cast<std::size_t>(std::floor(total / ratio + 1e-9));
  if (r.input < min_revolutions)
    throw std::invalid_argument("record too short: " + std::to_string(r.input) + " whole input revolutions, need " +
                                std::to_string(min_revolutions));
  if (r.output < 2)
    throw std::invalid_argument("record too short: " + std::to_string(r.output) +
                                " whole output revolutions, need 2 for the output shaft's lines");
  const double seconds = (angle.time_at(static_cast<double>(r.input)) - angle.time_at(0.0)) / sample_rate_hz;
  r.speed_hz = static_cast<double>(r.input) / seconds;
  return r;
}

/// Samples per revolution of each shaft's angle domain and the lines each keeps.
struct AngleResolution {
  std::size_t spr = 0, spr_out = 0, k_in = 0, k_out = 0;
};

AngleResolution angle_resolution(const dsp::ShaftAngle& angle, double sample_rate_hz, double speed_hz, double ratio) {
  AngleResolution a;
  // Resolution: the angle domain keeps the whole acquired band at the slowest revolution.
  std::vector<double> per_rev;
  angle.speed_per_revolution(sample_rate_hz, per_rev);
  const double slowest = per_rev.empty() ? speed_hz : *std::min_element(per_rev.begin(), per_rev.end());
  a.spr = dsp::next_smooth_size(static_cast<std::size_t>(std::ceil(sample_rate_hz / slowest)));
  const double top_hz = kUsableBandFraction * sample_rate_hz;
  a.k_in = std::min(a.spr / 2 - 1, static_cast<std::size_t>(std::floor(top_hz / speed_hz)));
  // The output shaft turns z2/z1 times slower: as many more samples per revolution keep the band.
  a.spr_out = dsp::next_smooth_size(static_cast<std::size_t>(std::ceil(a.spr * ratio)));
  a.k_out = std::min(a.spr_out / 2 - 1, static_cast<std::size_t>(std::floor(top_hz / (speed_hz / ratio))));
  return a;
}

/// The signal split by shaft: the input shaft's part (input revolutions, spr each), the output
/// shaft's part (output revolutions, spr_out each) and the residual that holds neither.
struct ShaftParts {
  dsp::RealBuffer input_only, output_only, residual;
};

/// x on a shaft's angle grid: `revolutions` × spr samples, one revolution `per_rev` input
/// revolutions. For a record holding cos(2π·order·θ) alone (θ in input revolutions from the first
/// edge, constant speed: `tone_order`), the samples are that cosine, except where the resampler's
/// kernel reads past either end of the record (zeros there): the leading revolution, and the
/// whole grid should the kernel reach the record's end. Those come from the resampler, so the
/// grid differs from the resampler's only by the kernel's pass-band error on the tone.
void to_angle(const std::vector<float>& x, const dsp::ShaftAngle& angle, std::size_t spr, std::size_t revolutions,
              double per_rev, std::optional<double> tone_order, dsp::AngularResampler& resampler, dsp::RealBuffer& out) {
  if (!tone_order) {
    resampler.resample(x, angle, spr, revolutions, out, per_rev);
    return;
  }
  resampler.resample(x, angle, spr, 1, std::span<double>(out).first(spr), per_rev);
  const double reach = resampler.interpolator().taps() / 2.0 + 1;  // input samples the kernel reads each side
  const bool inside = angle.time_at(per_rev) - angle.time_at(0.0) >= reach &&
                      angle.time_at(static_cast<double>(revolutions) * per_rev) + reach <= static_cast<double>(x.size());
  if (!inside) {
    resampler.resample(x, angle, spr, revolutions, out, per_rev);
    return;
  }
  // A rotating phasor, set exactly every kExact samples (one std::cos a sample would cost about
  // what the interpolation it replaces does).
  constexpr std::size_t kExact = 256;
  const double step = 2 * std::numbers::pi * *tone_order * per_rev / static_cast<double>(spr);
  const std::complex<double> rotation = std::polar(1.0, step);
  std::complex<double> z;
  for (std::size_t j = spr; j < revolutions * spr; ++j) {
    z = (j - spr) % kExact == 0 ? std::polar(1.0, step * static_cast<double>(j)) : z * rotation;
    out[j] = z.real();
  }
}

/// separate_shafts' intermediate signals: each shaft's angle grid, and the output shaft's part on the input's.
struct SeparationScratch {
  dsp::RealBuffer in_angle, out_angle, output_part;
  std::vector<float> output_only;
};

/// Each shaft's lines are read with the other shaft's synchronous part removed: an input line is
/// not periodic on the output shaft (and vice versa), so with a few revolutions its leakage
/// would not average out and a change on one shaft would show on the other.
ShaftParts separate_shafts(const std::vector<float>& x, const dsp::ShaftAngle& angle, const AngleResolution& a,
                           const WholeRevolutions& revs, double ratio, const GearPairSpec& gears,
                           std::optional<double> tone_order, dsp::FftPlanCache& plans) {
  const std::size_t spr = a.spr;
  dsp::AngularResampler resampler;
  // The intermediate signals, each written whole before it is read: kept by the thread between
  // records (a diagnosis reduces thousands of unit tones) rather than allocated and zeroed each time.
  thread_local SeparationScratch scratch;
  auto& [in_angle, out_angle, output_part, output_only] = scratch;
  in_angle.resize(revs.input * spr);
  out_angle.resize(revs.output * spr);
  ShaftParts parts{dsp::RealBuffer(in_angle.size()), dsp::RealBuffer(revs.output * a.spr_out),
                   dsp::RealBuffer(in_angle.size())};
  to_angle(x, angle, spr, revs.input, 1.0, tone_order, resampler, in_angle);
  to_angle(x, angle, spr, revs.output, ratio, tone_order, resampler, out_angle);
  dsp::SynchronousSeparation separation;
  separation.separate(in_angle, out_angle, spr, gears.pinion_teeth, gears.gear_teeth, plans, parts.residual);
  const std::vector<double> tsa_in(separation.input_tsa().begin(), separation.input_tsa().end());
  output_part.resize(in_angle.size());
  output_only.resize(in_angle.size());
  // Revolution by revolution: the synchronous average's index without a division per sample.
  for (std::size_t r = 0, j = 0; r < revs.input; ++r)
    for (std::size_t i = 0; i < spr; ++i, ++j) {
      output_part[j] = in_angle[j] - tsa_in[i];
      output_only[j] = static_cast<float>(output_part[j]);
    }
  resample_uniform_angle(output_only, spr, a.spr_out, revs.output, ratio, parts.output_only);
  // Second pass: the output shaft's average taken without the input lines (the first pass took it
  // from the raw signal, where an input line 0.2 output orders from an output line leaks in as 1/R),
  // so that the residual holds neither shaft's lines.
  resample_uniform_angle(output_only, spr, spr, revs.output, ratio, out_angle);
  separation.separate(output_part, out_angle, spr, gears.pinion_teeth, gears.gear_teeth, plans, parts.residual);
  for (std::size_t r = 0, j = 0; r < revs.input; ++r)
    for (std::size_t i = 0; i < spr; ++i, ++j) parts.input_only[j] = tsa_in[i] + parts.residual[j];
  return parts;
}

/// Broadband: 2-revolution Hann blocks of the residual, 50 % overlap, bins 1 .. 2·k_in + 1.
void broadband_block_dft(const dsp::RealBuffer& residual, std::size_t spr, std::size_t blocks, std::size_t k_in,
                         dsp::FftPlanCache& plans, std::vector<std::complex<double>>& out) {
  const std::size_t n = 2 * spr;
  const auto& fft2 = plans.real(n);
  dsp::RealBuffer in(n);
  dsp::ComplexBuffer spectrum(fft2.spectrum_size());
  // The windows of the block lengths this thread has used (bounded as the plans are): a diagnosis
  // reduces thousands of unit tones at a handful of lengths, and a cosine a sample is a visible
  // share of a unit tone's reduction.
  thread_local std::map<std::size_t, std::vector<double>> windows;
  if (windows.size() > kMaxCachedPlans) windows.clear();
  auto [at, fresh] = windows.try_emplace(n);
  std::vector<double>& window = at->second;
  if (fresh) window = dsp::periodic_hann(n);
  // Peak-amplitude scale of a bin-centred tone (2/Σw), and the window's noise bandwidth (1.5
  // bins) so that a tone's power summed over the bins it spreads into counts once.
  const double scale = 4.0 / static_cast<double>(n) / std::sqrt(1.5);
  const std::size_t bins = 2 * k_in + 1;
  out.assign(blocks * bins, {});
  for (std::size_t b = 0; b < blocks; ++b) {
    for (std::size_t i = 0; i < n; ++i) in[i] = residual[b * spr + i] * window[i];
    fft2.forward(in, spectrum);
    for (std::size_t j = 1; j <= bins; ++j) out[b * bins + j - 1] = spectrum[j] * scale;
  }
}
}  // namespace

void resample_uniform_angle(std::span<const float> x, std::size_t spr, std::size_t samples_per_rev,
                            std::size_t revolutions, double per_rev, std::span<double> out) {
  if (spr == 0 || samples_per_rev == 0 || !(per_rev > 0)) throw std::invalid_argument("resample_uniform_angle: empty grid");
  const std::size_t count = samples_per_rev * revolutions;
  if (out.size() < count) throw std::invalid_argument("resample_uniform_angle: output too small");
  // The cutoff as the resampler sets it, from a spline of the grid's edges (the same line), so that
  // the kernel is the one it would use even where the spacing sits on a quantisation step.
  const std::size_t input_revs = x.size() / spr;
  std::vector<double> edges(input_revs + 1);
  for (std::size_t r = 0; r <= input_revs; ++r) edges[r] = static_cast<double>(r * spr);
  dsp::ShaftAngle grid;
  if (!grid.assign(edges, 1, 1.0).ok() || static_cast<double>(revolutions) * per_rev > grid.total_revolutions() + 1e-9)
    throw std::invalid_argument("resample_uniform_angle: more revolutions than the signal holds");
  double slowest = 0.0;
  for (std::size_t r = 0; r < revolutions; ++r)
    slowest = std::max(slowest, grid.time_at(static_cast<double>(r + 1) * per_rev) - grid.time_at(static_cast<double>(r) * per_rev));
  const double spacing = slowest / static_cast<double>(samples_per_rev);
  const double cutoff = spacing <= 1.0 ? 1.0 : std::floor(64.0 / spacing) / 64.0;
  dsp::BandLimitedInterpolator interpolator;  // the resampler's parameters (the kernel tables are shared)
  interpolator.set_cutoff(std::max(cutoff, 1.0 / 64.0));
  const double step = per_rev / static_cast<double>(samples_per_rev);
  const auto per_input_rev = static_cast<double>(spr);
  constexpr std::size_t kBlock = 1024;
  std::array<double, kBlock> times{};
  for (std::size_t j = 0; j < count; j += kBlock) {
    const std::size_t m = std::min(kBlock, count - j);
    for (std::size_t k = 0; k < m; ++k) times[k] = static_cast<double>(j + k) * step * per_input_rev;
    interpolator.interpolate(x, std::span<const double>(times.data(), m), out.subspan(j, m));
  }
}

ReductionGrid reduction_grid(std::span<const double> tacho_edges, double sample_rate_hz, const GearPairSpec& gears,
                             std::size_t min_revolutions) {
  dsp::ShaftAngle angle;
  const auto check = angle.assign(tacho_edges, 1, 1.0);
  if (!check.ok()) throw std::invalid_argument("record's input tacho is unusable: " + check.reason);
  const double ratio = static_cast<double>(gears.gear_teeth) / gears.pinion_teeth;
  const WholeRevolutions revs = whole_revolutions(angle, ratio, sample_rate_hz, min_revolutions);
  const AngleResolution a = angle_resolution(angle, sample_rate_hz, revs.speed_hz, ratio);
  return {revs.input, revs.output, a.spr, a.spr_out, a.k_in, a.k_out, revs.speed_hz};
}

FamilyKind input_line_family(int order, int pinion_teeth) noexcept {
  if (order % pinion_teeth == 0) return FamilyKind::mesh_harmonics;
  return is_sideband_order(order, pinion_teeth) ? FamilyKind::input_sidebands : FamilyKind::input_shaft_orders;
}

bool output_line_is_mesh(int order, int gear_teeth) noexcept { return order % gear_teeth == 0; }

FamilyKind output_line_family(int order, int gear_teeth) noexcept {
  return is_sideband_order(order, gear_teeth) ? FamilyKind::output_sidebands : FamilyKind::output_shaft_orders;
}

RecordSpectra::RecordSpectra(const Record& record, int channel, const GearPairSpec& gears,
                             std::size_t min_revolutions, int edges_per_rev)
    : RecordSpectra(record, channel, gears, min_revolutions, edges_per_rev, std::nullopt) {}

RecordSpectra RecordSpectra::of_tone(const Record& record, const GearPairSpec& gears, double order) {
  return RecordSpectra(record, 0, gears, 4, 1, order);
}

RecordSpectra::RecordSpectra(const Record& record, int channel, const GearPairSpec& gears, std::size_t min_revolutions,
                             int edges_per_rev, std::optional<double> tone_order)
    : sample_rate_hz_(record.sample_rate_hz), torque_nm_(record.torque_nm), pinion_teeth_(gears.pinion_teeth), gear_teeth_(gears.gear_teeth) {
  const auto& x = checked_channel(record, channel);
  dsp::ShaftAngle angle;
  const auto check = angle.assign(record.tacho_edges[0], edges_per_rev, 1.0);
  if (!check.ok()) throw std::invalid_argument("record's input tacho is unusable: " + check.reason);
  const double ratio = static_cast<double>(gears.gear_teeth) / gears.pinion_teeth;
  const WholeRevolutions revs = whole_revolutions(angle, ratio, sample_rate_hz_, min_revolutions);
  in_revs_ = revs.input;
  out_revs_ = revs.output;
  speed_hz_ = revs.speed_hz;
  const AngleResolution a = angle_resolution(angle, sample_rate_hz_, speed_hz_, ratio);
  k_in_ = a.k_in;
  k_out_ = a.k_out;
  // The plans of the sizes this thread has reduced before: a diagnosis reduces hundreds of records
  // (the describer a unit tone per trial) at a handful of sizes, and FFTW_ESTIMATE gives the same plan,
  // so the same arithmetic, for a size however often it is planned. Per thread: FFTW's plans may be
  // executed from any thread, but the cache's map is not shared. Bounded: records of many lengths
  // (a daemon's months) would otherwise keep a plan of each.
  thread_local dsp::FftPlanCache plans;
  if (plans.size() > kMaxCachedPlans) plans.clear();
  const ShaftParts parts = separate_shafts(x, angle, a, revs, ratio, gears, tone_order, plans);
  per_revolution_dft(parts.input_only, a.spr, in_revs_, k_in_, plans.real(a.spr), in_dft_);
  per_revolution_dft(parts.output_only, a.spr_out, out_revs_, k_out_, plans.real(a.spr_out), out_dft_);
  blocks_ = in_revs_ - 1;
  broadband_block_dft(parts.residual, a.spr, blocks_, k_in_, plans, block_dft_);
}

double total_input_line_power(const SpectralSummary& s) noexcept {
  return std::accumulate(s.input_lines.begin(), s.input_lines.end(), 0.0);
}

BearingForcePath::BearingForcePath(double lowest_hz, double points_per_octave, std::vector<std::complex<double>> ratio)
    : lowest_hz_(lowest_hz), points_per_octave_(points_per_octave), ratio_(std::move(ratio)) {
  if (!(lowest_hz > 0) || !(points_per_octave > 0) || ratio_.empty())
    throw std::invalid_argument("bearing-force path: a positive lowest frequency, step and at least one point are needed");
}

double BearingForcePath::highest_hz() const noexcept {
  return lowest_hz_ * std::exp2(static_cast<double>(ratio_.size() - 1) / points_per_octave_);
}

std::complex<double> BearingForcePath::at(double hz) const noexcept {
  if (!(hz > lowest_hz_)) return ratio_.front();
  const double x = points_per_octave_ * std::log2(hz / lowest_hz_);
  const auto i = static_cast<std::size_t>(x);
  if (i + 1 >= ratio_.size()) return ratio_.back();
  const double t = x - static_cast<double>(i);
  return (1 - t) * ratio_[i] + t * ratio_[i + 1];
}

SpectralSummary RecordSpectra::summary(const std::vector<std::size_t>& input_revs,
                                       const std::vector<std::size_t>& output_revs,
                                       const std::vector<std::size_t>& blocks) const {
  // Lvalues on both sides, so that a given draw is read where it is, not copied.
  std::vector<std::size_t> all_in, all_out, all_blocks;
  const auto& ir = input_revs.empty() ? (all_in = every_revolution(in_revs_)) : input_revs;
  const auto& orv = output_revs.empty() ? (all_out = every_revolution(out_revs_)) : output_revs;
  SpectralSummary s;
  s.speed_hz = speed_hz_;
  s.torque_nm = torque_nm_;
  s.sample_rate_hz = sample_rate_hz_;
  s.pinion_run_out = pinion_run_out_;
  s.gear_run_out = gear_run_out_;
  s.bearing_force_path = bearing_force_path_;
  s.run_out_response = run_out_response_;
  s.input_revolutions = ir.size();
  s.output_revolutions = orv.size();
  s.input_lines.assign(k_in_, 0.0);
  s.broadband.assign(k_in_, 0.0);
  const auto mean = mean_over_revolutions(in_dft_, ir, k_in_);
  s.input_line_averages = static_cast<double>(ir.size());
  for (std::size_t k = 0; k < k_in_; ++k) s.input_lines[k] = std::norm(mean[k]);
  const auto& bl = blocks.empty() ? (all_blocks = every_revolution(blocks_)) : blocks;
  const std::size_t bins = 2 * k_in_ + 1;
  std::vector<std::complex<double>> block_mean(bins);
  for (std::size_t b : bl)
    for (std::size_t j = 0; j < bins; ++j) block_mean[j] += block_dft_[b * bins + j];
  for (auto& m : block_mean) m /= static_cast<double>(bl.size());
  std::vector<double> power(bins, 0.0);
  for (std::size_t b : bl)
    for (std::size_t j = 0; j < bins; ++j) power[j] += std::norm(block_dft_[b * bins + j] - block_mean[j]);
  const double dof = std::max(1.0, static_cast<double>(bl.size()) - 1.0);
  // Half-order bin j (order j/2) belongs to the 1-order bin k = floor(j/2): orders [k, k+1).
  for (std::size_t j = 2; j <= bins; ++j) s.broadband[j / 2 - 1] += power[j - 1] / dof;
  const auto mean_out = mean_over_revolutions(out_dft_, orv, k_out_);
  s.output_line_averages = static_cast<double>(orv.size());
  s.output_lines.assign(k_out_, 0.0);
  for (std::size_t m = 0; m < k_out_; ++m)
    if (!output_line_is_mesh(static_cast<int>(m + 1), gear_teeth_)) s.output_lines[m] = std::norm(mean_out[m]);
  return s;
}

std::vector<std::complex<double>> RecordSpectra::input_line_means() const {
  return mean_over_revolutions(in_dft_, every_revolution(in_revs_), k_in_);
}

std::vector<std::complex<double>> RecordSpectra::output_line_means() const {
  return mean_over_revolutions(out_dft_, every_revolution(out_revs_), k_out_);
}

std::shared_ptr<const RunOutResponse> run_out_response(const RecordSpectra& without,
                                                       const std::array<const RecordSpectra*, 4>& with_unit,
                                                       double unit_m) {
  if (!(unit_m > 0) || !std::isfinite(unit_m)) throw std::invalid_argument("run-out response: the unit run-out must be finite and > 0");
  auto r = std::make_shared<RunOutResponse>();
  const auto input_lines = without.input_line_means(), output_lines = without.output_line_means();
  for (std::size_t i = 0; i < with_unit.size(); ++i) {
    if (with_unit[i] == nullptr) throw std::invalid_argument("run-out response: a run with a run-out is missing");
    auto difference = [&](const std::vector<std::complex<double>>& with, const std::vector<std::complex<double>>& base) {
      std::vector<std::complex<double>> d(std::min(with.size(), base.size()));
      for (std::size_t k = 0; k < d.size(); ++k) d[k] = (with[k] - base[k]) / unit_m;
      return d;
    };
    r->input_per_m[i] = difference(with_unit[i]->input_line_means(), input_lines);
    r->output_per_m[i] = difference(with_unit[i]->output_line_means(), output_lines);
  }
  return r;
}

std::uint64_t RecordSpectra::next_identity() noexcept {
  static std::atomic<std::uint64_t> next{1};
  return next.fetch_add(1, std::memory_order_relaxed);
}

RecordSpectra::BootstrapDraw RecordSpectra::draw_bootstrap(std::mt19937_64& rng, std::size_t block) const {
  auto draw = [&](std::size_t n) {
    std::vector<std::size_t> v;
    v.reserve(n);
    const std::size_t b = std::max<std::size_t>(1, std::min(block, n));
    std::uniform_int_distribution<std::size_t> start(0, n - 1);
    while (v.size() < n) {
      const std::size_t s = start(rng);
      for (std::size_t j = 0; j < b && v.size() < n; ++j) v.push_back((s + j) % n);
    }
    return v;
  };
  BootstrapDraw d;
  d.blocks = draw(blocks_);
  d.output_revs = draw(out_revs_);
  d.input_revs = draw(in_revs_);
  return d;
}

SpectralSummary RecordSpectra::bootstrap(std::mt19937_64& rng, std::size_t block) const {
  const BootstrapDraw d = draw_bootstrap(rng, block);
  return summary(d.input_revs, d.output_revs, d.blocks);
}

ToneReach ToneReach::orders(double orders, const GearPairSpec& gears) {
  const double n = std::max(1.0, std::ceil(orders));
  const double out_per_in = gears.pinion_teeth > 0 ? static_cast<double>(gears.gear_teeth) / gears.pinion_teeth : 1.0;
  return {static_cast<int>(n) + 1, static_cast<int>(std::ceil(n * out_per_in)) + 1, 2 * static_cast<int>(n) + 1};
}

void add_tone_to_broadband(SpectralSummary& s, double order, double power, int half_bins) {
  if (!(power > 0)) return;
  const int count = 2 * std::max(1, half_bins);
  const double centre = 2.0 * order;  // in half-order bins
  const auto first = static_cast<long>(std::floor(centre)) - (count / 2 - 1);
  std::vector<double> weights(static_cast<std::size_t>(count));
  double total = 0;
  // d steps by whole bins, so sin(π·d) only changes sign from one bin to the next.
  const double sine_at_first = std::sin(std::numbers::pi * (centre - static_cast<double>(first)));
  for (int i = 0; i < count; ++i) {
    const double d = centre - static_cast<double>(first + i);
    const double sine = i % 2 == 0 ? sine_at_first : -sine_at_first;
    // Hann kernel's power at d bins from the tone: (sinc(d)/(1 − d²))².
    double w;
    if (std::abs(d) < 1e-9) w = 1.0;
    else if (std::abs(std::abs(d) - 1.0) < 1e-9) w = 0.25;
    else w = std::pow(sine / (std::numbers::pi * d) / (1.0 - d * d), 2);
    weights[static_cast<std::size_t>(i)] = w;
    total += w;
  }
  for (int i = 0; i < count; ++i) {
    const long j = first + i;
    const long k = j / 2;  // 1-order bin [k, k+1)
    if (j >= 2 && k >= 1 && k <= static_cast<long>(s.broadband.size()))
      s.broadband[static_cast<std::size_t>(k - 1)] += power * weights[static_cast<std::size_t>(i)] / total;
  }
}

void add_non_synchronous_tone(SpectralSummary& s, double input_order, double power, const GearPairSpec& gears,
                              double negligible_power, ToneReach reach) {
  if (!(power > 0) || !(input_order > 0)) return;
  // B/(B − 1) for the B = R − 1 broadband blocks RecordSpectra cuts from R input revolutions.
  const double broadband_bias = s.input_revolutions > 2 ? (s.input_revolutions - 1.0) / (s.input_revolutions - 2.0) : 1.0;
  if (power <= negligible_power || gears.pinion_teeth < 1 || gears.gear_teeth < 1) {
    add_tone_to_broadband(s, input_order, power * broadband_bias, reach.broadband_bins);
    return;
  }
  using Complex = std::complex<double>;
  // The mean over R revolutions from angle 0 of e^{i2π·x·φ} read at order k is e^{iπRΔ}·sinc(RΔ)
  // = (e^{i2πRΔ} − 1)/(i2πRΔ), Δ = x − k. R is whole, so along integer k only the 1/Δ changes, and
  // e^{i2πRx} itself steps by a fixed rotation from one x to the next (x = k·ratio or m/ratio).
  struct Kernel {
    double revolutions, x;
    Complex turn;  // e^{i2πRx}
    Complex operator()(double k) const {
      const double delta = x - k;
      const double phase = std::numbers::pi * revolutions * delta;
      if (std::abs(phase) < 1e-6) return std::polar(1.0 - phase * phase / 6.0, phase);  // sinc's series
      const Complex d = turn - 1.0;  // d / (i·2·phase), without a complex division
      return Complex(d.imag(), -d.real()) * (0.5 / phase);
    }
    // The same mean read for a tone at `next_x`, whose e^{i2πR·next_x} is this one's turned by `step`.
    Kernel stepped_to(double next_x, Complex step) const { return {revolutions, next_x, turn * step}; }
  };
  auto kernel_at = [](double r, double x) { return Kernel{r, x, std::polar(1.0, 2 * std::numbers::pi * r * x)}; };
  const double ratio = static_cast<double>(gears.gear_teeth) / gears.pinion_teeth;  // output orders per input order
  const auto r_in = static_cast<double>(s.input_revolutions), r_out = static_cast<double>(s.output_revolutions);
  const double output_order = input_order * ratio;
  const auto shared = static_cast<long>(gears.gear_teeth / std::gcd(gears.pinion_teeth, gears.gear_teeth));
  // Beyond three orders a line holds below 1/(3π·R)² of the tone (1e-3 for R = 4): by default the
  // neighbours suffice. Input orders ⌊x⌋ − (n − 1) … ⌊x⌋ + n, output orders likewise (fewer near order 1).
  const long n_in = std::max(1, reach.input_lines), n_out = std::max(1, reach.output_lines);
  const long k0 = std::max(1L, static_cast<long>(std::floor(input_order)) - (n_in - 1)), k1 = static_cast<long>(std::floor(input_order)) + n_in;
  const long m0 = std::max(1L, static_cast<long>(std::floor(output_order)) - (n_out - 1)), m1 = static_cast<long>(std::floor(output_order)) + n_out;
  // 1. The input synchronous average takes d_k; 2. the output one, of what is left, c_m (it leaves the
  // orders both shafts share to the input side); 3. the input lines are read off the tone less the
  // output average's part, the output lines off the tone less the input average's part (= c_m).
  std::vector<Complex> input_average(static_cast<std::size_t>(k1 - k0 + 1)), output_average(static_cast<std::size_t>(m1 - m0 + 1));
  double removed = 0;
  const Kernel tone_on_input = kernel_at(r_in, input_order), tone_on_output = kernel_at(r_out, output_order);
  for (long k = k0; k <= k1; ++k) {
    input_average[k - k0] = tone_on_input(static_cast<double>(k));
    removed += std::norm(input_average[k - k0]);
  }
  std::vector<Kernel> input_line_on_output(input_average.size());  // the input average's line k seen by the output average
  input_line_on_output[0] = kernel_at(r_out, static_cast<double>(k0) * ratio);
  const Complex output_step = std::polar(1.0, 2 * std::numbers::pi * r_out * ratio);
  for (long k = k0 + 1; k <= k1; ++k)
    input_line_on_output[k - k0] = input_line_on_output[k - k0 - 1].stepped_to(static_cast<double>(k) * ratio, output_step);
  for (long m = m0; m <= m1; ++m) {
    Complex c{};
    if (m % shared != 0) {
      c = tone_on_output(static_cast<double>(m));
      for (long k = k0; k <= k1; ++k) c -= input_average[k - k0] * input_line_on_output[k - k0](static_cast<double>(m));
    }
    output_average[m - m0] = c;
    removed += std::norm(c);
    if (m <= static_cast<long>(s.output_lines.size()) && !output_line_is_mesh(static_cast<int>(m), gears.gear_teeth))
      s.output_lines[static_cast<std::size_t>(m - 1)] += power * std::norm(c);
  }
  std::vector<Complex> input_line = input_average;
  Kernel output_line_on_input = kernel_at(r_in, static_cast<double>(m0) / ratio);
  const Complex input_step = std::polar(1.0, 2 * std::numbers::pi * r_in / ratio);
  for (long m = m0; m <= m1; ++m) {
    if (m > m0) output_line_on_input = output_line_on_input.stepped_to(static_cast<double>(m) / ratio, input_step);
    if (output_average[m - m0] == Complex{}) continue;
    for (long k = k0; k <= k1; ++k) input_line[k - k0] -= output_average[m - m0] * output_line_on_input(static_cast<double>(k));
  }
  for (long k = k0; k <= k1 && k <= static_cast<long>(s.input_lines.size()); ++k)
    s.input_lines[static_cast<std::size_t>(k - 1)] += power * std::norm(input_line[k - k0]);
  add_tone_to_broadband(s, input_order, power * std::max(0.0, 1.0 - removed) * broadband_bias, reach.broadband_bins);
}

}  // namespace gearwatch::gap
