#include "gearwatch/dsp/order_tracking.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <tuple>

namespace gearwatch::dsp {

TachoCheck ShaftAngle::assign(std::span<const double> edges, int edges_per_rev,
                              double analysed_revs_per_tacho_rev) {
  total_revs_ = 0.0;
  times_.clear();
  if (edges.empty()) return TachoCheck(SkipReason::no_tacho);
  if (edges_per_rev < 1 || !(analysed_revs_per_tacho_rev > 0.0)) return TachoCheck(SkipReason::tacho_irregular);
  if (edges.size() < static_cast<std::size_t>(edges_per_rev) + 1) return TachoCheck(SkipReason::too_few_edges);
  scratch_.resize(edges.size() - 1);
  for (std::size_t i = 0; i + 1 < edges.size(); ++i) {
    const double d = edges[i + 1] - edges[i];
    if (!std::isfinite(edges[i]) || !std::isfinite(edges[i + 1]) || !(d > 0.0)) return TachoCheck(SkipReason::tacho_irregular);
    scratch_[i] = d;
  }
  // Each interval against the median of the (up to) nine intervals around it: a missed or
  // spurious edge stands out from its neighbours, while a run-up that doubles the speed over the
  // record (a slow change from one interval to the next) is not mistaken for one.
  constexpr std::size_t kNeighbours = 4;
  const std::size_t count = scratch_.size();
  std::array<double, 2 * kNeighbours + 1> local{};
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t first = i >= kNeighbours ? i - kNeighbours : 0, last = std::min(count, i + kNeighbours + 1);
    std::copy(scratch_.begin() + static_cast<std::ptrdiff_t>(first), scratch_.begin() + static_cast<std::ptrdiff_t>(last), local.begin());
    const std::size_t m = last - first;
    std::nth_element(local.begin(), local.begin() + static_cast<std::ptrdiff_t>(m / 2), local.begin() + static_cast<std::ptrdiff_t>(m));
    const double median = local[m / 2];
    if (scratch_[i] < 0.5 * median || scratch_[i] > 1.5 * median) return TachoCheck(SkipReason::tacho_irregular);
  }

  // Cubic spline through (i*h, edges[i]) with uniform knot spacing h and not-a-knot ends (the
  // third derivative is continuous at the second and last-but-one knots). Natural ends (zero
  // curvature) would be wrong whenever the speed drifts or fluctuates and cost ~1e-4 of the
  // energy of a mesh order in leakage; not-a-knot is exact for any cubic time-angle law.
  // Interior rows: M[i-1] + 4 M[i] + M[i+1] = 6 (y[i-1] - 2 y[i] + y[i+1]) / h^2. With
  // M[0] = 2 M[1] - M[2] and M[n-1] = 2 M[n-2] - M[n-3] the first and last rows become 6 M = rhs.
  const std::size_t n = edges.size();
  knot_spacing_ = analysed_revs_per_tacho_rev / edges_per_rev;
  total_revs_ = knot_spacing_ * static_cast<double>(n - 1);
  times_.assign(edges.begin(), edges.end());
  second_deriv_.assign(n, 0.0);
  if (n >= 3) {
    const double h2 = knot_spacing_ * knot_spacing_;
    const bool not_a_knot = n >= 4;  // with 3 knots fall back to natural ends
    scratch_.assign(n, 0.0);          // modified super-diagonal (Thomas algorithm)
    std::vector<double>& c = scratch_;
    std::vector<double>& m = second_deriv_;
    for (std::size_t i = 1; i + 1 < n; ++i) {
      const double rhs = 6.0 * (times_[i - 1] - 2.0 * times_[i] + times_[i + 1]) / h2;
      const bool first = i == 1, last = i + 2 == n;
      const double lower = (first || (last && not_a_knot)) ? 0.0 : 1.0;
      const double diag = not_a_knot && (first || last) ? 6.0 : 4.0;
      const double upper = (last || (first && not_a_knot)) ? 0.0 : 1.0;
      const double denom = diag - lower * (first ? 0.0 : c[i - 1]);
      c[i] = upper / denom;
      m[i] = (rhs - lower * (first ? 0.0 : m[i - 1])) / denom;
    }
    for (std::size_t i = n - 2; i >= 2; --i) m[i - 1] -= c[i - 1] * m[i];
    if (not_a_knot) {
      m[0] = 2.0 * m[1] - m[2];
      m[n - 1] = 2.0 * m[n - 2] - m[n - 3];
    }
  }
  return {};
}

inline double ShaftAngle::spline_at(double u) const {
  std::size_t i = u <= 0.0 ? 0 : static_cast<std::size_t>(u);
  if (i >= times_.size() - 1) i = times_.size() - 2;
  const double h = knot_spacing_;
  const double b = (u - static_cast<double>(i));  // fraction within the interval
  const double a = 1.0 - b;
  return a * times_[i] + b * times_[i + 1] +
         ((a * a * a - a) * second_deriv_[i] + (b * b * b - b) * second_deriv_[i + 1]) * h * h / 6.0;
}

double ShaftAngle::time_at(double revs) const {
  if (times_.empty()) throw std::logic_error("ShaftAngle::time_at before a successful assign()");
  return spline_at(revs / knot_spacing_);
}

void ShaftAngle::times_at(double step, std::size_t first, std::span<double> out) const {
  if (times_.empty()) throw std::logic_error("ShaftAngle::times_at before a successful assign()");
  // spline_at for each position, its knot interval's constants hoisted: the positions rise with
  // k, so they fall in runs on one interval, and a run's loop has no lookups (it vectorises).
  const std::size_t m = out.size(), last = times_.size() - 2;
  for (std::size_t k = 0; k < m; ++k) out[k] = static_cast<double>(first + k) * step / knot_spacing_;
  const double h = knot_spacing_;
  for (std::size_t k = 0; k < m;) {
    std::size_t i = out[k] <= 0.0 ? 0 : static_cast<std::size_t>(out[k]);
    std::size_t end = k + 1;
    if (i >= last) {
      i = last;
      end = m;
    } else {
      while (end < m && out[end] < static_cast<double>(i + 1)) ++end;
    }
    const double t0 = times_[i], t1 = times_[i + 1], m0 = second_deriv_[i], m1 = second_deriv_[i + 1];
    const double base = static_cast<double>(i);
    for (std::size_t j = k; j < end; ++j) {
      const double b = out[j] - base;
      const double a = 1.0 - b;
      out[j] = a * t0 + b * t1 + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * h * h / 6.0;
    }
    k = end;
  }
}

void ShaftAngle::speed_per_revolution(double sample_rate_hz, std::vector<double>& out) const {
  out.clear();
  const auto revs = static_cast<std::size_t>(std::floor(total_revs_ + 1e-9));
  double previous = time_at(0.0);
  for (std::size_t r = 1; r <= revs; ++r) {
    const double t = time_at(static_cast<double>(r));
    out.push_back(sample_rate_hz / (t - previous));
    previous = t;
  }
}

namespace {
double bessel_i0(double x) {
  // Power series; converges fast for the arguments used here (beta <= ~20).
  double sum = 1.0, term = 1.0;
  const double q = x * x / 4.0;
  for (int k = 1; k < 60; ++k) {
    term *= q / (static_cast<double>(k) * k);
    sum += term;
    if (term < 1e-17 * sum) break;
  }
  return sum;
}
}  // namespace

BandLimitedInterpolator::BandLimitedInterpolator(int zero_crossings, int phases, double kaiser_beta)
    : zero_crossings_(zero_crossings), phases_(phases), beta_(kaiser_beta) {
  if (zero_crossings < 2 || phases < 2) throw std::invalid_argument("BandLimitedInterpolator: bad size");
  set_cutoff(1.0);
}

namespace {
/// The kernel's table for `half` taps each side (from the zero crossings and the cutoff), `phases`,
/// β and the cutoff: (phases + 1) rows × 2·half taps, then the same values again as phases row
/// pairs, each four taps of row p followed by the same four of row p + 1 (interpolate() reads both
/// rows' four taps with one load).
std::vector<float> kaiser_sinc_table(int phases, double beta, double cutoff, int half) {
  const int taps = 2 * half;
  const std::size_t rows_size = static_cast<std::size_t>(phases + 1) * taps;
  std::vector<float> table(rows_size + static_cast<std::size_t>(phases) * 2 * taps, 0.0f);
  const double i0_beta = bessel_i0(beta);
  std::vector<double> row(static_cast<std::size_t>(taps));
  for (int p = 0; p <= phases; ++p) {
    const double frac = static_cast<double>(p) / phases;
    double sum = 0.0;
    for (int m = 0; m < taps; ++m) {
      // tap m multiplies sample floor(t) - half + 1 + m, at distance u from t
      const double u = frac + half - 1 - m;
      const double v = cutoff * u;
      const double sinc = std::abs(v) < 1e-12 ? 1.0 : std::sin(std::numbers::pi * v) / (std::numbers::pi * v);
      const double r = u / half;
      const double window = std::abs(r) >= 1.0 ? 0.0 : bessel_i0(beta * std::sqrt(1.0 - r * r)) / i0_beta;
      row[m] = cutoff * sinc * window;
      sum += row[m];
    }
    // Unit DC gain at every phase: removes the small phase-dependent ripple of the truncated kernel.
    for (int m = 0; m < taps; ++m)
      table[static_cast<std::size_t>(p) * taps + static_cast<std::size_t>(m)] = static_cast<float>(row[m] / sum);
  }
  for (std::size_t p = 0; p < static_cast<std::size_t>(phases); ++p)
    for (std::size_t m = 0; m < static_cast<std::size_t>(taps); ++m) {
      float* pair = table.data() + rows_size + 2 * (p * taps + m - m % 4) + m % 4;
      pair[0] = table[p * taps + m];
      pair[4] = table[(p + 1) * taps + m];
    }
  return table;
}

/// The tables built so far, shared by every interpolator of the process: a table depends only on
/// its four parameters, and the resampler quantises the cutoff to 64 values, while the gap
/// diagnosis builds a resampler per record it reduces (thousands), each rebuilding the same few
/// tables (hundreds of thousands of Bessel evaluations each) otherwise. Never freed: at most a
/// few dozen tables (each its rows plus their row-pair copy).
std::shared_ptr<const std::vector<float>> shared_kaiser_sinc_table(int zero_crossings, int phases, double beta, double cutoff,
                                                                   int half) {
  using Key = std::tuple<int, int, double, double>;
  static std::mutex mutex;
  static std::map<Key, std::shared_ptr<const std::vector<float>>> tables;
  const Key key{zero_crossings, phases, beta, cutoff};
  {
    std::lock_guard lock(mutex);
    if (auto it = tables.find(key); it != tables.end()) return it->second;
  }
  auto table = std::make_shared<const std::vector<float>>(kaiser_sinc_table(phases, beta, cutoff, half));
  std::lock_guard lock(mutex);
  return tables.emplace(key, std::move(table)).first->second;
}
}  // namespace

void BandLimitedInterpolator::set_cutoff(double cutoff) {
  if (!(cutoff > 0.0 && cutoff <= 1.0)) throw std::invalid_argument("BandLimitedInterpolator: cutoff in (0,1]");
  if (cutoff == cutoff_) return;
  cutoff_ = cutoff;
  int half = static_cast<int>(std::ceil(zero_crossings_ / cutoff));
  half += half % 2;  // taps_ a multiple of 4 for the four-lane loop (extra taps are window zeros)
  taps_ = 2 * half;
  table_ = shared_kaiser_sinc_table(zero_crossings_, phases_, beta_, cutoff, half);
}

inline BandLimitedInterpolator::Position BandLimitedInterpolator::locate(double t) const {
  const double floor_t = std::floor(t);
  const auto base = static_cast<std::ptrdiff_t>(floor_t);
  const double phase_pos = (t - floor_t) * phases_;
  auto p = static_cast<int>(phase_pos);
  if (p >= phases_) p = phases_ - 1;
  return {base - taps_ / 2 + 1, table_->data() + static_cast<std::size_t>(p) * taps_, phase_pos - p};
}

double BandLimitedInterpolator::operator()(std::span<const float> x, double t) const {
  const auto [first, row0, w] = locate(t);
  const float* row1 = row0 + taps_;
  const auto n = static_cast<std::ptrdiff_t>(x.size());
  double acc0 = 0.0, acc1 = 0.0;
  if (first >= 0 && first + taps_ <= n) {
    using v4f = float __attribute__((vector_size(16)));
    const float* xs = x.data() + first;
    v4f a0{0, 0, 0, 0}, a1{0, 0, 0, 0};
    for (int m = 0; m < taps_; m += 4) {
      v4f xv, r0, r1;
      __builtin_memcpy(&xv, xs + m, sizeof xv);
      __builtin_memcpy(&r0, row0 + m, sizeof r0);
      __builtin_memcpy(&r1, row1 + m, sizeof r1);
      a0 += r0 * xv;
      a1 += r1 * xv;
    }
    acc0 = static_cast<double>(a0[0]) + a0[1] + a0[2] + a0[3];
    acc1 = static_cast<double>(a1[0]) + a1[1] + a1[2] + a1[3];
  } else {
    for (int m = 0; m < taps_; ++m) {
      const std::ptrdiff_t k = first + m;
      if (k < 0 || k >= n) continue;
      acc0 += row0[m] * x[static_cast<std::size_t>(k)];
      acc1 += row1[m] * x[static_cast<std::size_t>(k)];
    }
  }
  return acc0 + w * (acc1 - acc0);
}

namespace {
using v4f = float __attribute__((vector_size(16)));
using v8f = float __attribute__((vector_size(32)));
constexpr std::size_t kLanes = 4;    // positions summed side by side
constexpr std::size_t kChunk = 256;  // positions located, then summed, a chunk at a time

// The sums of `count` positions (a multiple of kLanes); a group of kLanes whose first sample
// pointer is null is left alone. Both phase rows in one eight-lane vector (one load from the row
// pairs: row 0 in lanes 0-3, row 1 in lanes 4-7) against the four samples twice: each lane takes
// the same products in the same order as operator()'s two four-lane sums, and the AVX2 clone does
// in one instruction what the baseline does in two. The AVX2 target has no FMA, so no product is
// fused into its sum.
__attribute__((target_clones("avx2", "default"))) void interior_sums(const float* const* xs, const float* const* pairs,
                                                                     std::size_t count, int taps, v8f* acc) {
  for (std::size_t k = 0; k < count; k += kLanes) {
    if (xs[k] == nullptr) continue;
    v8f a[kLanes] = {};
    for (int m = 0; m < taps; m += 4) {
      for (std::size_t l = 0; l < kLanes; ++l) {
        v4f xv;
        v8f r;
        __builtin_memcpy(&xv, xs[k + l] + m, sizeof xv);
        __builtin_memcpy(&r, pairs[k + l] + 2 * m, sizeof r);
        a[l] += r * __builtin_shufflevector(xv, xv, 0, 1, 2, 3, 0, 1, 2, 3);
      }
    }
    for (std::size_t l = 0; l < kLanes; ++l) acc[k + l] = a[l];
  }
}
}  // namespace

void BandLimitedInterpolator::interpolate(std::span<const float> x, std::span<const double> t, std::span<double> out) const {
  if (out.size() < t.size()) throw std::invalid_argument("BandLimitedInterpolator: output too small");
  const auto n = static_cast<std::ptrdiff_t>(x.size());
  const float* rows = table_->data();
  const float* pair_rows = rows + static_cast<std::size_t>(phases_ + 1) * taps_;
  std::array<const float*, kChunk> pairs{}, xs{};
  std::array<double, kChunk> w{};
  std::array<v8f, kChunk> a{};
  const std::size_t whole = t.size() - t.size() % kLanes;
  for (std::size_t c = 0; c < whole; c += kChunk) {
    const std::size_t count = std::min(kChunk, whole - c);
    for (std::size_t k = 0; k < count; k += kLanes) {
      bool interior = true;
      for (std::size_t l = 0; l < kLanes; ++l) {
        const Position at = locate(t[c + k + l]);
        w[k + l] = at.w;
        pairs[k + l] = pair_rows + 2 * (at.row0 - rows);
        interior = interior && at.first >= 0 && at.first + taps_ <= n;
        xs[k + l] = interior ? x.data() + at.first : nullptr;
      }
      if (!interior) xs[k] = nullptr;  // the group goes through operator() below
    }
    interior_sums(xs.data(), pairs.data(), count, taps_, a.data());
    for (std::size_t k = 0; k < count; k += kLanes) {
      for (std::size_t l = 0; l < kLanes; ++l) {
        if (xs[k] == nullptr) {
          out[c + k + l] = (*this)(x, t[c + k + l]);
          continue;
        }
        const v8f& s = a[k + l];
        const double acc0 = static_cast<double>(s[0]) + s[1] + s[2] + s[3];
        const double acc1 = static_cast<double>(s[4]) + s[5] + s[6] + s[7];
        out[c + k + l] = acc0 + w[k + l] * (acc1 - acc0);
      }
    }
  }
  for (std::size_t k = whole; k < t.size(); ++k) out[k] = (*this)(x, t[k]);
}

void AngularResampler::resample(std::span<const float> x, const ShaftAngle& angle, std::size_t samples_per_rev,
                                std::size_t revolutions, std::span<double> out, double angle_revs_per_rev) {
  const std::size_t count = samples_per_rev * revolutions;
  if (out.size() < count) throw std::invalid_argument("AngularResampler: output too small");
  if (!(angle_revs_per_rev > 0.0)) throw std::invalid_argument("AngularResampler: bad revolution scale");
  if (static_cast<double>(revolutions) * angle_revs_per_rev > angle.total_revolutions() + 1e-9)
    throw std::invalid_argument("AngularResampler: more revolutions than the tacho covers");
  // Largest output spacing in input samples = slowest revolution / samples_per_rev.
  double slowest = 0.0;
  for (std::size_t r = 0; r < revolutions; ++r)
    slowest = std::max(slowest, angle.time_at(static_cast<double>(r + 1) * angle_revs_per_rev) -
                                    angle.time_at(static_cast<double>(r) * angle_revs_per_rev));
  const double spacing = slowest / static_cast<double>(samples_per_rev);
  // Quantised so that records at nearly the same speed reuse the table.
  const double cutoff = spacing <= 1.0 ? 1.0 : std::floor(64.0 / spacing) / 64.0;
  interpolator_.set_cutoff(std::max(cutoff, 1.0 / 64.0));
  const double step = angle_revs_per_rev / static_cast<double>(samples_per_rev);
  constexpr std::size_t kBlock = 1024;  // positions computed, then interpolated, a block at a time
  times_.resize(kBlock);
  for (std::size_t j = 0; j < count; j += kBlock) {
    const std::size_t m = std::min(kBlock, count - j);
    const std::span<double> t(times_.data(), m);
    angle.times_at(step, j, t);
    interpolator_.interpolate(x, t, out.subspan(j, m));
  }
}

namespace {

/// The tracked angle's error for a deviation of `deviation` revolutions at `ratio`, Hann-weighted
/// over the middle revolutions (the spline's ends are not-a-knot), correlated with e^{−2πi·at·θ}:
/// the sine's coefficient at `at`, over the deviation.
std::complex<double> tracking_error_at(double ratio, double at) {
  // Unit speed (one revolution per unit of time), 1000 samples per revolution, a deviation of 1e-3
  // revolutions: small enough that the edges stay regular, large against the spline's rounding.
  constexpr double kSamples = 1000, kDeviation = 1e-3;
  constexpr int kRevolutions = 400;
  const double w = 2.0 * std::numbers::pi * ratio;
  auto angle = [&](double t) { return t + kDeviation * std::sin(w * t); };
  std::vector<double> edges;
  edges.reserve(kRevolutions + 1);
  double t = 0;
  for (int m = 0; m <= kRevolutions; ++m) {
    for (int iteration = 0; iteration < 30; ++iteration) t -= (angle(t) - m) / (1.0 + kDeviation * w * std::cos(w * t));
    edges.push_back(t * kSamples);
  }
  ShaftAngle tracked;
  if (!tracked.assign(edges, 1, 1.0).ok()) throw std::logic_error("tracking residual: synthetic edges refused");
  // The error's component at the deviation's frequency, Hann-weighted over the middle revolutions
  // (the spline's ends are not-a-knot, and the aliases at other frequencies must not leak in).
  constexpr double kFirst = 20, kLast = kRevolutions - 20, kStep = 1.0 / 64;
  const double w_at = 2.0 * std::numbers::pi * at;
  std::complex<double> sum = 0;
  double weights = 0;
  for (double revs = kFirst; revs <= kLast; revs += kStep) {
    const double hann = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * (revs - kFirst) / (kLast - kFirst));
    const double error = angle(tracked.time_at(revs) / kSamples) - revs;
    sum += hann * error * std::polar(1.0, -w_at * revs);
    weights += hann;
  }
  // e^{iwθ}'s part of sin(wθ) is 1/(2i): the sine's coefficient is 2i·sum/weights.
  return std::complex<double>(0.0, 2.0) * sum / weights / kDeviation;
}

}  // namespace

double tracking_residual_share(double ratio) {
  if (!(ratio > 0 && ratio <= 16)) throw std::invalid_argument("tracking residual: the ratio must lie in (0, 16]");
  return std::abs(tracking_error_at(ratio, ratio));
}

double tracking_error_component(double ratio, double at) {
  if (!(ratio > 0 && ratio <= 16) || !(at > 0 && at <= 16))
    throw std::invalid_argument("tracking error: the ratio and the order must lie in (0, 16]");
  return tracking_error_at(ratio, at).real();
}

}  // namespace gearwatch::dsp
