#include "gearwatch/dsp/speed_estimation.hpp"
#include "gearwatch/dsp/window.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <utility>

namespace gearwatch::dsp {

namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr int kKnotsPerRev = 16;      // angle knots per revolution at the fastest speed tracked
constexpr int kGridPerRev = 16;       // demodulation window centres per revolution
constexpr std::size_t kFloorHalfWidth = 64;  // bins each side of the spectral floor's moving mean
constexpr double kRevsPerFrame = 4.0; // frames resolve the mesh line from its shaft sidebands
constexpr double kMinLineSnr = 1.386; // ln 4: the chosen line's median stands 6 dB above the floor
constexpr double kSteadySpread = 1e-3; // a record's speed spread below which it counts as steady (steady_speed)

// Linear interpolation of y(x) at v, x increasing; clamped outside. `hint` walks forward for
// increasing queries (reset it to 0 for a new sweep).
double interpolate(const std::vector<double>& xs, const std::vector<double>& ys, double v, std::size_t& hint) {
  if (v <= xs.front()) return ys.front();
  if (v >= xs.back()) return ys.back();
  if (hint >= xs.size() - 1 || xs[hint] > v) hint = 0;
  while (hint + 2 < xs.size() && xs[hint + 1] <= v) ++hint;
  const double w = (v - xs[hint]) / (xs[hint + 1] - xs[hint]);
  return ys[hint] + w * (ys[hint + 1] - ys[hint]);
}

std::size_t previous_power_of_two(std::size_t n) {
  std::size_t p = 1;
  while (p * 2 <= n) p *= 2;
  return p;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Median of three neighbours: one frame misled by a transient does not bend the track.
template <class Get, class Set>
void median_of_three(std::size_t n, Get get, Set set) {
  if (n < 3) return;
  std::vector<double> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = get(i);
  for (std::size_t i = 1; i + 1 < n; ++i) set(i, std::max(std::min(v[i - 1], v[i]), std::min(std::max(v[i - 1], v[i]), v[i + 1])));
}

// Σ x[n]·exp(i(p0 + n·dp)) over a knot interval. kLanes rotators, each stepping kLanes samples,
// run side by side: one rotator is a chain of dependent multiplies that leaves the core idle
// between them, and this sum is the estimator's largest cost (three passes over the record).
constexpr std::size_t kLanes = 8;
std::pair<double, double> rotate_and_sum(std::span<const float> x, double p0, double dp) {
  std::array<double, kLanes> zr{}, zi{}, ar{}, ai{};
  for (std::size_t l = 0; l < kLanes; ++l) {
    zr[l] = std::cos(p0 + static_cast<double>(l) * dp);
    zi[l] = std::sin(p0 + static_cast<double>(l) * dp);
  }
  const double rr = std::cos(static_cast<double>(kLanes) * dp), ri = std::sin(static_cast<double>(kLanes) * dp);
  std::size_t n = 0;
  for (; n + kLanes <= x.size(); n += kLanes)
    for (std::size_t l = 0; l < kLanes; ++l) {
      const double v = x[n + l];
      ar[l] += v * zr[l];
      ai[l] += v * zi[l];
      const double t = zr[l] * rr - zi[l] * ri;
      zi[l] = zr[l] * ri + zi[l] * rr;
      zr[l] = t;
    }
  double sr = 0.0, si = 0.0;
  for (std::size_t l = 0; l < kLanes; ++l) {
    sr += ar[l];
    si += ai[l];
  }
  for (std::size_t l = 0; n < x.size(); ++n, ++l) {  // the tail: lane l is at sample n
    sr += x[n] * zr[l];
    si += x[n] * zi[l];
  }
  return {sr, si};
}

// Sizes v to `size` with zeros from `from` on; `written` (where the caller's nonzero values ended
// last time) bounds the zeroing, so a frame's bins above what it reads are not cleared per frame.
void zero_from(std::vector<double>& v, std::size_t size, std::size_t from, std::size_t& written) {
  v.resize(size);  // new elements are zero; those kept beyond `written` still are
  const std::size_t end = std::min(written, size);
  if (from < end) std::fill(v.begin() + static_cast<std::ptrdiff_t>(from), v.begin() + static_cast<std::ptrdiff_t>(end), 0.0);
  written = std::min(from, size);
}

}  // namespace

double SpeedEstimate::angle_at(double sample) const {
  if (knot_samples.size() < 2) throw std::logic_error("SpeedEstimate::angle_at without an estimate");
  std::size_t hint = 0;
  if (sample <= knot_samples.front() || sample >= knot_samples.back()) {
    // Beyond the knots: the end segment's speed carried on.
    const std::size_t i = sample <= knot_samples.front() ? 0 : knot_samples.size() - 2;
    const double slope = (knot_revs[i + 1] - knot_revs[i]) / (knot_samples[i + 1] - knot_samples[i]);
    return knot_revs[i] + slope * (sample - knot_samples[i]);
  }
  const auto it = std::upper_bound(knot_samples.begin(), knot_samples.end(), sample);
  hint = static_cast<std::size_t>(it - knot_samples.begin()) - 1;
  return interpolate(knot_samples, knot_revs, sample, hint);
}

double SpeedEstimate::relative_standard_error(double revolutions) const {
  if (!(revolutions > 0.0)) return std::numeric_limits<double>::infinity();
  return std::sqrt(2.0) * angle_error_rev / revolutions;
}

SpeedEstimator::SpeedEstimator(const SpeedEstimationSettings& s) : settings_(s) {
  if (s.pinion_teeth < 1 || s.gear_teeth < 1) throw std::invalid_argument("speed estimation: tooth counts must be positive");
  if (!(s.min_speed_hz > 0.0 && s.max_speed_hz > s.min_speed_hz))
    throw std::invalid_argument("speed estimation: the speed range must satisfy 0 < min < max");
  if (s.harmonics < 1 || s.harmonics > 10) throw std::invalid_argument("speed estimation: harmonics must be in [1, 10]");
  if (s.iterations < 1 || s.iterations > 10) throw std::invalid_argument("speed estimation: iterations must be in [1, 10]");
  if (!(s.max_phase_noise_rad > 0.0)) throw std::invalid_argument("speed estimation: max_phase_noise_rad must be positive");
}

const SpeedEstimate& SpeedEstimator::estimate(std::span<const float> x, double fs, double nominal_speed_hz) {
  result_.ok = false;
  result_.failure.clear();
  result_.edges.clear();
  result_.knot_samples.clear();
  result_.knot_revs.clear();
  auto fail = [&](const std::string& why) -> const SpeedEstimate& {
    result_.failure = why;
    result_.edges.clear();
    return result_;
  };
  if (!(fs > 0.0) || !std::isfinite(fs)) return fail("bad sample rate");
  double low = settings_.min_speed_hz, high = settings_.max_speed_hz;
  if (std::isfinite(nominal_speed_hz) && nominal_speed_hz > 0.0) {
    low = std::max(low, nominal_speed_hz / 2.0);
    high = std::min(high, nominal_speed_hz * 2.0);
  }
  if (!(high > low)) return fail("the nominal speed lies outside the speed range");
  if (!track_speed(x, fs, low, high)) return result_;
  coarse_angle(x, fs);
  // The estimate measures its own scatter between independent windows (its tolerance against a
  // tacho rests on it): a record must hold at least four of them.
  const double window = 1.0 + static_cast<double>(settings_.gear_teeth) / settings_.pinion_teeth;
  const double revolutions = result_.knot_revs.back() - result_.knot_revs.front();
  if (revolutions < 4.0 * window) {
    char text[160];
    std::snprintf(text, sizeof text, "the record holds %.1f revolutions: a speed estimate needs four demodulation windows (%.1f)",
                  revolutions, 4.0 * window);
    return fail(text);
  }
  const int order = settings_.pinion_teeth * result_.harmonic;
  double noise = 0.0;
  for (int k = 0; k < settings_.iterations; ++k) {
    noise = refine(x, fs, order);
    if (!result_.failure.empty()) return fail(result_.failure);
  }
  result_.phase_noise_rad = noise;
  result_.angle_error_rev = noise / (kTwoPi * order);
  if (!(noise <= settings_.max_phase_noise_rad)) {
    char text[160];
    std::snprintf(text, sizeof text, "the mesh line's phase scatters %.2f rad between windows (limit %.2f): too weak to hold the angle",
                  noise, settings_.max_phase_noise_rad);
    return fail(text);
  }
  if (!synthesise_edges(x.size())) return fail("the estimated angle covers fewer than two revolutions");
  whole_window_span(window);
  const double first = result_.whole_window_first, last = result_.whole_window_last;
  result_.mean_speed_hz = (result_.angle_at(last) - result_.angle_at(first)) * fs / (last - first);
  result_.ok = true;
  return result_;
}

// Two passes of short-time spectra: frames long enough for the slowest speed searched (at most an
// eighth of the record), then frames of four revolutions of the slowest speed found, searched
// around the first track.
bool SpeedEstimator::track_speed(std::span<const float> x, double fs, double low, double high) {
  const std::size_t cap = previous_power_of_two(x.size() / 8);
  if (cap < 256) {
    result_.failure = "record too short for a speed estimate";
    return false;
  }
  // First-pass frames hold four revolutions at a quarter of the highest speed searched: long
  // enough to resolve a mesh line at the speeds a record usually has, short enough that a run-up
  // or a fluctuation barely smears it (frames for the lowest speed of a wide range would span a
  // large part of the record). The second pass sizes its frames from what this one found.
  const std::size_t first_length =
      std::min(next_power_of_two(static_cast<std::size_t>(std::ceil(kRevsPerFrame * fs / std::max(low, high / 4.0)))), cap);
  scan_frames(x, fs, first_length, first_length, nullptr, low, high, coarse_);
  for (auto& f : coarse_) f.speed = std::clamp(f.speed, low, high);
  median_of_three(coarse_.size(), [&](std::size_t i) { return coarse_[i].speed; }, [&](std::size_t i, double v) { coarse_[i].speed = v; });
  double slowest = high;
  for (const auto& f : coarse_) slowest = std::min(slowest, f.speed);
  const std::size_t length =
      std::min(next_power_of_two(static_cast<std::size_t>(std::ceil(kRevsPerFrame * fs / (0.8 * slowest)))), cap);
  scan_frames(x, fs, length, length / 2, &coarse_, low, high, fine_);
  // The line to demodulate, by its SNR against the noise beside it (median over the frames of
  // line_snr: against the neighbourhood's median power, which the line and its shaft sidebands do
  // not move). A line's phase scatters as 1/sqrt(2·SNR), and a line far below the others (a mesh
  // harmonic the profile's wear has made weak, near a cancellation) also wanders with the load;
  // the refinement corrects only what is slow against its window, so an error the first pass puts
  // in stays. At a steady speed the line whose angle is most precise (finest_angle_line): a phase
  // error φ at harmonic h is an angle error φ/(2π·z1·h). When the speed changes, the lowest
  // within 6 dB of the strongest: a higher line's phase swings h times as far, beyond what the
  // coarse track can hand the refinement, and it sits nearer the structure's resonances, whose
  // phase moves with the line's frequency.
  std::vector<double> medians, line_medians;
  for (int h = 0; h < settings_.harmonics; ++h) {
    std::vector<double> snr, line;
    for (const auto& f : fine_) {
      snr.push_back(f.snr[static_cast<std::size_t>(h)]);
      line.push_back(f.line_snr[static_cast<std::size_t>(h)]);
    }
    medians.push_back(median(snr));
    line_medians.push_back(median(line));
  }
  const double highest = *std::max_element(line_medians.begin(), line_medians.end());
  int best = 0;
  const auto strongest = static_cast<std::size_t>(std::max_element(line_medians.begin(), line_medians.end()) - line_medians.begin());
  if (steady_speed(strongest))
    best = finest_angle_line(line_medians);
  else
    while (line_medians[static_cast<std::size_t>(best)] < highest - kMinLineSnr) ++best;
  const double best_snr = medians[static_cast<std::size_t>(best)];
  if (fine_.size() < 2 || best_snr < kMinLineSnr) {
    char text[160];
    std::snprintf(text, sizeof text, "no gear-mesh line found between %.3g and %.3g Hz of shaft speed (best median %.1f dB above the floor)",
                  low, high, 10.0 * best_snr / std::log(10.0));
    result_.failure = text;
    return false;
  }
  result_.harmonic = best + 1;
  std::vector<double> raw;
  for (auto& f : fine_) raw.push_back(f.speed = f.line_speed[static_cast<std::size_t>(best)]);
  median_of_three(fine_.size(), [&](std::size_t i) { return fine_[i].speed; }, [&](std::size_t i, double v) { fine_[i].speed = v; });
  // A line is found at a consistent frequency: most frames within one bin of their neighbours'
  // median. The highest peak of noise lands on any of the hundreds of bins searched, so it almost
  // never agrees with its neighbours.
  const double bin = fs / static_cast<double>(length) / (settings_.pinion_teeth * result_.harmonic);
  std::size_t consistent = 0;
  for (std::size_t i = 0; i < raw.size(); ++i) consistent += std::abs(raw[i] - fine_[i].speed) <= bin ? 1 : 0;
  if (2 * consistent < raw.size()) {
    char text[160];
    std::snprintf(text, sizeof text, "no steady gear-mesh line: only %zu of %zu frames agree with their neighbours within a bin",
                  consistent, raw.size());
    result_.failure = text;
    return false;
  }
  return true;
}

void SpeedEstimator::scan_frames(std::span<const float> x, double fs, std::size_t length, std::size_t hop,
                                 const std::vector<Frame>* guide, double low, double high, std::vector<Frame>& frames) {
  frames.clear();
  std::vector<double> centres, speeds;
  if (guide != nullptr)
    for (const auto& g : *guide) {
      centres.push_back(g.centre);
      speeds.push_back(g.speed);
    }
  // The highest bin any search of this scan reads: mesh harmonic H at the fastest speed a frame
  // may search (the octave checks stay within its range too), plus the parabola's neighbours.
  double fastest = high;
  if (guide != nullptr && !speeds.empty()) fastest = std::min(high, 1.25 * *std::max_element(speeds.begin(), speeds.end()));
  const double df = fs / static_cast<double>(length);
  const double reach = std::min(static_cast<double>(settings_.pinion_teeth) * settings_.harmonics * fastest, 0.45 * fs);
  const auto last_bin = static_cast<std::size_t>(std::ceil(reach / df)) + 4;
  std::size_t hint = 0;
  for (std::size_t start = 0; start + length <= x.size(); start += hop) {
    frame_spectrum(x, start, length, last_bin);
    const double centre = static_cast<double>(start) + 0.5 * static_cast<double>(length);
    double from = low, to = high;
    if (guide != nullptr) {
      // Within 20 % of the first track: wide enough for the speed change within a long frame.
      const double g = interpolate(centres, speeds, centre, hint);
      from = std::max(low, 0.8 * g);
      to = std::min(high, 1.25 * g);
    }
    Frame f = search_frame(fs, length, from, std::max(from, to));
    f.centre = centre;
    frames.push_back(std::move(f));
  }
}

void SpeedEstimator::frame_spectrum(std::span<const float> x, std::size_t start, std::size_t length, std::size_t last_bin) {
  // The two passes use two frame lengths: each keeps its Hann window from record to record.
  std::vector<double>& window = windows_[length];
  if (window.size() != length) window = periodic_hann(length);
  const RealFft& fft = plans_.real(length);
  frame_.resize(length);
  for (std::size_t i = 0; i < length; ++i) frame_[i] = window[i] * x[start + i];
  spectrum_.resize(fft.spectrum_size());
  fft.forward(frame_, spectrum_);
  const std::size_t bins = spectrum_.size();
  // Only the bins the search reads (up to last_bin) get a log-SNR, and only those their floor
  // needs get a power: the mesh harmonics searched lie far below Nyquist, and the logarithm over
  // the whole spectrum was most of the cost. Bins above stay 0 (never read).
  const std::size_t used = std::min(bins, last_bin + 1);
  const std::size_t powered = std::min(bins, used + kFloorHalfWidth);
  zero_from(power_, bins, powered, power_written_);
  for (std::size_t k = 0; k < powered; ++k) power_[k] = std::norm(spectrum_[k]);
  // Log-SNR against a moving mean of the power (the floor), clipped at 0: a harmonic sum of these
  // rewards a shaft speed whose mesh harmonics all stand out, not one very strong line.
  cumulative_.resize(powered + 1);
  cumulative_[0] = 0.0;
  for (std::size_t k = 0; k < powered; ++k) cumulative_[k + 1] = cumulative_[k] + power_[k];
  zero_from(floor_, bins, used, floor_written_);  // the clipped log-SNR per bin
  scored_bins_ = used;
  for (std::size_t k = 0; k < used; ++k) {
    const std::size_t a = k > kFloorHalfWidth ? k - kFloorHalfWidth : 0, b = std::min(bins, k + kFloorHalfWidth + 1);
    const double mean = (cumulative_[b] - cumulative_[a]) / static_cast<double>(b - a);
    floor_[k] = mean > 0.0 && power_[k] > mean ? std::log(power_[k] / mean) : 0.0;
  }
}

// Steady: the speeds of the strongest line (each frame's, refined by the parabola) spread by at
// most kSteadySpread of their median. Not the harmonic search's speeds: where only a few of the
// harmonics searched stand out, its score is flat across a bin of the lowest line, and those speeds
// scatter by that much at a constant speed. A lightly damped resonance (damping ratio ζ ≥ 1 %)
// turns a line's phase by up to δ/ζ when its frequency moves by a fraction δ; at 1e-3 that stays
// under 0.1 rad, whatever line is taken.
bool SpeedEstimator::steady_speed(std::size_t line) const {
  std::vector<double> speeds;
  for (const auto& f : fine_) speeds.push_back(f.line_speed[line]);
  if (speeds.empty()) return false;
  const auto [lo, hi] = std::minmax_element(speeds.begin(), speeds.end());
  return *hi - *lo <= kSteadySpread * median(speeds);
}

// The harmonic (0-based) whose demodulated angle scatters least: the phase of a line of SNR ρ
// scatters as 1/sqrt(2ρ) whatever its order, so the angle error of harmonic h goes as
// 1/(h·sqrt(ρ_h)); the largest ln ρ_h + 2 ln h wins, among lines standing kMinLineSnr above the
// noise (below, the phase is no longer a small, Gaussian error). The strongest line is not the
// best one when a strong low harmonic competes with a somewhat weaker high one (a pitted flank's
// noise masks the upper harmonics partly): at equal SNR the low one's angle is h_high/h_low times
// coarser.
int SpeedEstimator::finest_angle_line(const std::vector<double>& line_log_snr) {
  int best = static_cast<int>(std::max_element(line_log_snr.begin(), line_log_snr.end()) - line_log_snr.begin());
  double best_score = line_log_snr[static_cast<std::size_t>(best)] + 2.0 * std::log(best + 1.0);
  for (std::size_t h = 0; h < line_log_snr.size(); ++h) {
    const double score = line_log_snr[h] + 2.0 * std::log(static_cast<double>(h) + 1.0);
    if (line_log_snr[h] >= kMinLineSnr && score > best_score) {
      best_score = score;
      best = static_cast<int>(h);
    }
  }
  return best;
}

// A line's log-SNR against the noise beside it: the median power of the ±kFloorHalfWidth bins
// around it over ln 2 (the mean of a noise bin's exponentially distributed power), which a few
// lines and sidebands among them do not move; the moving mean of the search's floor holds the
// line itself and stops at ln(2·kFloorHalfWidth + 1) however strong the line.
double SpeedEstimator::line_snr(std::size_t peak) {
  const std::size_t bins = power_.size();
  const std::size_t a = peak > kFloorHalfWidth ? peak - kFloorHalfWidth : 0, b = std::min(bins, peak + kFloorHalfWidth + 1);
  neighbours_.assign(power_.begin() + static_cast<std::ptrdiff_t>(a), power_.begin() + static_cast<std::ptrdiff_t>(b));
  const double noise = median(neighbours_) / std::numbers::ln2;
  return noise > 0.0 && power_[peak] > noise ? std::log(power_[peak] / noise) : 0.0;
}

// The harmonic sum's octave errors. At k times the true speed its harmonics fall on the true mesh
// harmonics k, 2k, ..., which may outscore 1, 2, 3 (a gearbox whose first mesh harmonic is weak);
// at 1/k of it, on a signal with fewer mesh harmonics than searched, the true lines score the same
// at every k-th harmonic. Both are told by the lines in between: a speed's harmonics that are not
// multiples of k (h % k != 0) against those that are, as mean log-SNRs above the 6 dB a line needs
// (noise then scores ~0), over the searched span. At
// the true speed both sets hold lines; at k times too low the first set holds none (taken: k·f when
// it stands below a quarter of the second); at k times too high the lines of f/k in between are
// real (taken: f/k when they stand at least half as high as f's own).
template <class SnrAt>
double SpeedEstimator::resolve_octave(double speed, double low, double high, double top, SnrAt snr_at) const {
  const int z1 = settings_.pinion_teeth;
  // Mean log-SNR of f's harmonics 1..count with (h % k != 0) and with (h % k == 0).
  auto split = [&](double f, int k, int count) {
    double between = 0.0, multiples = 0.0;
    int n_between = 0, n_multiples = 0;
    for (int h = 1; h <= count && z1 * h * f < top; ++h) {
      const double v = std::max(0.0, snr_at(z1 * h * f) - kMinLineSnr);  // lines only, as in the score
      if (h % k == 0) {
        multiples += v;
        ++n_multiples;
      } else {
        between += v;
        ++n_between;
      }
    }
    const bool ok = n_between > 0 && n_multiples > 0;
    return std::pair{ok ? between / n_between : -1.0, ok ? multiples / n_multiples : -1.0};
  };
  for (int k = 3; k >= 2; --k) {  // too low?
    if (speed * k > high) continue;
    const auto [between, multiples] = split(speed, k, settings_.harmonics);
    if (multiples > 0.0 && between >= 0.0 && between < 0.25 * multiples) return speed * k;
  }
  for (int k = 3; k >= 2; --k) {  // too high?
    if (speed / k < low) continue;
    const auto [between, multiples] = split(speed / k, k, settings_.harmonics * k);
    if (multiples > 0.0 && between >= 0.5 * multiples) return speed / k;
  }
  return speed;
}

SpeedEstimator::Frame SpeedEstimator::search_frame(double fs, std::size_t length, double low, double high) {
  const double df = fs / static_cast<double>(length);
  const int z1 = settings_.pinion_teeth, harmonics = settings_.harmonics;
  const double top = 0.45 * fs;
  const std::size_t bins = floor_.size();
  auto snr_at = [&](double hz) {
    const double b = hz / df;
    const auto k = static_cast<std::size_t>(b);
    if (k + 1 >= bins) return 0.0;
    return std::max(floor_[k], floor_[k + 1]);
  };
  // What each bin adds to a speed's score: snr_at's value above the line level, lines only, not
  // noise. Read once per bin here instead of once per harmonic and trial speed below.
  // floor_ is 0 from scored_bins_ on, so are these.
  const std::size_t scored = std::min(scored_bins_, bins - 1);
  zero_from(line_score_, bins, scored, line_score_written_);
  for (std::size_t k = 0; k < scored; ++k) line_score_[k] = std::max(0.0, std::max(floor_[k], floor_[k + 1]) - kMinLineSnr);
  // Weights 0.84^(h-1) (Hermes' subharmonic summation): a speed k times too low also meets the
  // true lines, at harmonics k, 2k, ..., and must not tie with the true one.
  std::array<double, 10> weights{};
  double weight = 1.0;
  for (int h = 1; h <= harmonics; ++h, weight *= 0.84) weights[static_cast<std::size_t>(h - 1)] = weight;
  Frame best;
  double best_score = -1.0;
  const double step = 0.5 * df / (z1 * harmonics);  // the highest harmonic moves half a bin
  for (double f = low; f <= high; f += step) {
    double score = 0.0;
    for (int h = 1; h <= harmonics; ++h) {
      const double hz = z1 * h * f;
      if (hz < top) score += weights[static_cast<std::size_t>(h - 1)] * line_score_[static_cast<std::size_t>(hz / df)];
    }
    if (score > best_score) {
      best_score = score;
      best.speed = f;
    }
  }
  best.speed = resolve_octave(best.speed, low, high, top, snr_at);
  // Each harmonic's line near the chosen speed, refined by a parabola through the log power.
  best.line_speed.assign(static_cast<std::size_t>(harmonics), best.speed);
  best.snr.assign(static_cast<std::size_t>(harmonics), 0.0);
  best.line_snr.assign(static_cast<std::size_t>(harmonics), 0.0);
  for (int h = 1; h <= harmonics; ++h) {
    const double hz = z1 * h * best.speed;
    if (hz >= top) continue;
    const auto centre = static_cast<std::size_t>(std::lround(hz / df));
    std::size_t peak = centre;
    for (std::size_t k = centre > 2 ? centre - 2 : 1; k <= centre + 2 && k + 1 < bins; ++k)
      if (power_[k] > power_[peak]) peak = k;
    if (peak < 1 || peak + 1 >= bins || !(power_[peak] > 0.0)) continue;
    const double a = std::log(power_[peak - 1] + 1e-300), b = std::log(power_[peak]), c = std::log(power_[peak + 1] + 1e-300);
    const double denom = a - 2.0 * b + c;
    const double offset = denom < 0.0 ? std::clamp(0.5 * (a - c) / denom, -0.5, 0.5) : 0.0;
    best.line_speed[static_cast<std::size_t>(h - 1)] = (static_cast<double>(peak) + offset) * df / (z1 * h);
    best.snr[static_cast<std::size_t>(h - 1)] = floor_[peak];
    best.line_snr[static_cast<std::size_t>(h - 1)] = line_snr(peak);
  }
  return best;
}

// The fine track integrated on a uniform grid of knots, kKnotsPerRev per revolution at the
// fastest speed (the speed varies little within a knot interval, so the angle is linear there).
void SpeedEstimator::coarse_angle(std::span<const float> x, double fs) {
  std::vector<double> centres, speeds;
  double fastest = 0.0;
  for (const auto& f : fine_) {
    centres.push_back(f.centre);
    speeds.push_back(f.speed);
    fastest = std::max(fastest, f.speed);
  }
  const auto spacing = std::max<std::size_t>(1, static_cast<std::size_t>(fs / (fastest * kKnotsPerRev)));
  auto& samples = result_.knot_samples;
  auto& revs = result_.knot_revs;
  samples.clear();
  for (std::size_t s = 0; s + 1 < x.size(); s += spacing) samples.push_back(static_cast<double>(s));
  samples.push_back(static_cast<double>(x.size() - 1));
  revs.assign(samples.size(), 0.0);
  std::size_t hint = 0;
  double previous = interpolate(centres, speeds, samples[0], hint);
  for (std::size_t s = 1; s < samples.size(); ++s) {
    const double speed = interpolate(centres, speeds, samples[s], hint);
    revs[s] = revs[s - 1] + 0.5 * (previous + speed) * (samples[s] - samples[s - 1]) / fs;
    previous = speed;
  }
}

// Angle-weighted sums of x·exp(-i2π·order·θ) over each knot interval: ∫ x e^{-i2πmθ} dθ in
// pieces. The rotator is re-seeded at every knot, so its rounding never accumulates.
void SpeedEstimator::demodulate(std::span<const float> x, int order) {
  const auto& samples = result_.knot_samples;
  const auto& revs = result_.knot_revs;
  const std::size_t segments = samples.size() - 1;
  segment_re_.assign(segments, 0.0);
  segment_im_.assign(segments, 0.0);
  for (std::size_t s = 0; s < segments; ++s) {
    const auto first = static_cast<std::size_t>(samples[s]), last = static_cast<std::size_t>(samples[s + 1]);
    const double span = samples[s + 1] - samples[s];
    const double cycles = order * revs[s];
    const double p0 = -kTwoPi * (cycles - std::floor(cycles));
    const double dp = -kTwoPi * order * (revs[s + 1] - revs[s]) / span;
    const auto [ar, ai] = rotate_and_sum(x.subspan(first, last - first), p0, dp);
    const double weight = (revs[s + 1] - revs[s]) / span;  // dθ per sample
    segment_re_[s] = ar * weight;
    segment_im_[s] = ai * weight;
  }
}

// One refinement pass; returns the window phases' scatter (radians).
double SpeedEstimator::refine(std::span<const float> x, double /*fs*/, int order) {
  demodulate(x, order);
  auto& revs = result_.knot_revs;
  const std::size_t knots = revs.size();
  // Cumulative integral C(θ) at the knots, then the one-revolution window on a uniform angle grid.
  std::vector<double> cr(knots, 0.0), ci(knots, 0.0);
  for (std::size_t s = 0; s + 1 < knots; ++s) {
    cr[s + 1] = cr[s] + segment_re_[s];
    ci[s + 1] = ci[s] + segment_im_[s];
  }
  const double start = revs.front(), end = revs.back();
  const double output_rev = static_cast<double>(settings_.gear_teeth) / settings_.pinion_teeth;
  const double half = 0.5 * (1.0 + output_rev);  // the cascade's half length, revolutions
  if (end - start < 2.0 * half) {
    result_.failure = "record shorter than the demodulation window";
    return 0.0;
  }
  const auto points = static_cast<std::size_t>(std::floor((end - start) * kGridPerRev)) + 1;
  std::vector<double> angle(points), b_re(points, 0.0), b_im(points, 0.0);
  std::size_t hi = 0, lo = 0;
  for (std::size_t g = 0; g < points; ++g) {
    angle[g] = start + static_cast<double>(g) / kGridPerRev;
    const double a = std::max(start, angle[g] - 0.5), b = std::min(end, angle[g] + 0.5);
    b_re[g] = interpolate(revs, cr, b, hi) - interpolate(revs, cr, a, lo);
    std::size_t hi2 = hi, lo2 = lo;
    b_im[g] = interpolate(revs, ci, b, hi2) - interpolate(revs, ci, a, lo2);
  }
  // The output-revolution boxcar over the first window's values (trapezoid cumulative sum).
  std::vector<double> dr(points, 0.0), di(points, 0.0);
  for (std::size_t g = 1; g < points; ++g) {
    dr[g] = dr[g - 1] + 0.5 * (b_re[g] + b_re[g - 1]) / kGridPerRev;
    di[g] = di[g - 1] + 0.5 * (b_im[g] + b_im[g - 1]) / kGridPerRev;
  }
  std::vector<double> centres, phase;
  std::size_t h1 = 0, l1 = 0, h2 = 0, l2 = 0;
  for (std::size_t g = 0; g < points; ++g) {
    // Near the ends the windows are cut by the record (the integrals clamp): there the sidebands
    // are no longer nulled exactly, which costs far less than extrapolating the angle.
    const double a = angle[g] - 0.5 * output_rev, b = angle[g] + 0.5 * output_rev;
    const double re = interpolate(angle, dr, b, h1) - interpolate(angle, dr, a, l1);
    const double im = interpolate(angle, di, b, h2) - interpolate(angle, di, a, l2);
    double p = std::atan2(im, re);
    if (!phase.empty()) p += kTwoPi * std::round((phase.back() - p) / kTwoPi);  // unwrap
    centres.push_back(angle[g]);
    phase.push_back(p);
  }
  if (phase.size() < 2) {
    result_.failure = "record shorter than the demodulation window";
    return 0.0;
  }
  // Scatter between independent windows (one window length apart), robustly (MAD).
  const auto lag = static_cast<std::size_t>(std::ceil(2.0 * half * kGridPerRev));
  std::vector<double> diffs;
  for (std::size_t g = 0; g + lag < phase.size(); ++g) diffs.push_back(phase[g + lag] - phase[g]);
  double noise = 0.0;
  if (!diffs.empty()) {
    const double m = median(diffs);
    for (double& d : diffs) d = std::abs(d - m);
    noise = 1.4826 * median(diffs) / std::sqrt(2.0);
  }
  double mean = 0.0;
  for (double p : phase) mean += p;
  mean /= static_cast<double>(phase.size());
  for (double& p : phase) p = (p - mean) / (kTwoPi * order);  // correction, revolutions
  std::size_t hint = 0;
  for (std::size_t s = 0; s < knots; ++s) revs[s] += interpolate(centres, phase, revs[s], hint);
  for (std::size_t s = 0; s + 1 < knots; ++s)
    if (!(revs[s + 1] > revs[s])) {
      result_.failure = "the estimated angle went backwards (mesh line lost)";
      return noise;
    }
  return noise;
}

bool SpeedEstimator::synthesise_edges(std::size_t /*samples*/) {
  const auto& samples = result_.knot_samples;
  auto& revs = result_.knot_revs;
  // Edges only where a whole one-revolution window fits in the record: nearer the ends the window
  // is cut short and the angle is an extrapolation. Angle 0 at the first edge, as a tacho's.
  const double shift = std::ceil(revs.front() + 0.5);
  for (double& r : revs) r -= shift;
  result_.edges.clear();
  std::size_t s = 0;
  for (double k = 0.0; k <= revs.back() - 0.5; k += 1.0) {
    while (s + 2 < revs.size() && revs[s + 1] < k) ++s;
    const double w = (k - revs[s]) / (revs[s + 1] - revs[s]);
    result_.edges.push_back(samples[s] + w * (samples[s + 1] - samples[s]));
  }
  return result_.edges.size() >= 2;
}

// The samples where the angle lies half a demodulation window (`window` revolutions) inside either
// end of the estimate. The record holds at least four windows (estimate), so the span is not empty.
void SpeedEstimator::whole_window_span(double window) {
  const auto& samples = result_.knot_samples;
  const auto& revs = result_.knot_revs;
  auto sample_at = [&](double angle) {
    const auto it = std::lower_bound(revs.begin(), revs.end(), angle);
    const auto i = static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(it - revs.begin(), 1, static_cast<std::ptrdiff_t>(revs.size()) - 1));
    const double w = (angle - revs[i - 1]) / (revs[i] - revs[i - 1]);
    return samples[i - 1] + w * (samples[i] - samples[i - 1]);
  };
  result_.whole_window_first = sample_at(revs.front() + 0.5 * window);
  result_.whole_window_last = sample_at(revs.back() - 0.5 * window);
}

double speed_tolerance(const SpeedEstimate& estimate, double revolutions, int pinion_teeth) {
  const double resolution = 4.0 * estimate.relative_standard_error(revolutions);
  const double slip = 0.1 / (static_cast<double>(pinion_teeth) * revolutions);
  return std::max(resolution, slip);
}

SpeedCheck check_tacho(std::span<const double> tacho_edges, double input_revs_per_edge, const SpeedEstimate& estimate,
                       double fs, int pinion_teeth) {
  SpeedCheck c;
  if (tacho_edges.size() < 2 || !(fs > 0.0)) return c;
  const double span = tacho_edges.back() - tacho_edges.front();
  const double tacho_revs = static_cast<double>(tacho_edges.size() - 1) * input_revs_per_edge;
  c.tacho_speed_hz = tacho_revs * fs / span;
  if (!estimate.ok) return c;
  // Compared over the tacho edges where the estimate's whole window fits (its angle near the ends
  // is less exact); the whole record's when fewer than two edges lie there.
  const auto from = std::lower_bound(tacho_edges.begin(), tacho_edges.end(), estimate.whole_window_first);
  const auto to = std::upper_bound(tacho_edges.begin(), tacho_edges.end(), estimate.whole_window_last);
  const bool inside = to - from >= 2;
  const double first = inside ? *from : tacho_edges.front(), last = inside ? *(to - 1) : tacho_edges.back();
  const double inner_revs = static_cast<double>(inside ? to - from - 1 : static_cast<std::ptrdiff_t>(tacho_edges.size()) - 1) *
                            input_revs_per_edge;
  const double signal_revs = estimate.angle_at(last) - estimate.angle_at(first);
  c.signal_speed_hz = signal_revs * fs / (last - first);
  c.relative_difference = (inner_revs - signal_revs) / signal_revs;
  c.tolerance = speed_tolerance(estimate, signal_revs, pinion_teeth);
  c.mismatch = std::abs(c.relative_difference) > c.tolerance;
  c.gross = std::abs(c.relative_difference) > kGrossSpeedDifference;
  c.source = c.mismatch && !c.gross ? SpeedSource::signal_estimate : SpeedSource::tacho;
  return c;
}

}  // namespace gearwatch::dsp
