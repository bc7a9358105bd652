#include "gearwatch/dsp/filter_bank.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <utility>

namespace gearwatch::dsp {

std::vector<double> firwin_lowpass(int taps, double cutoff) {
  std::vector<double> h(static_cast<std::size_t>(taps));
  const double centre = 0.5 * (taps - 1);
  double sum = 0.0;
  for (int n = 0; n < taps; ++n) {
    const double m = n - centre;
    const double x = cutoff * m;
    const double sinc = x == 0.0 ? 1.0 : std::sin(std::numbers::pi * x) / (std::numbers::pi * x);
    const double hamming = 0.54 - 0.46 * std::cos(2.0 * std::numbers::pi * n / (taps - 1));
    h[static_cast<std::size_t>(n)] = cutoff * sinc * hamming;
    sum += h[static_cast<std::size_t>(n)];
  }
  for (double& v : h) v /= sum;
  return h;
}

double filter_bank_row_level(int row) {
  if (row == 0) return 0.0;
  if (row % 2 == 1) return (row + 1) / 2;
  return row / 2 + std::log2(3.0) - 1.0;
}

namespace {

// out[m] = sum_i taps[i] * c[factor*m + phase - i] (causal filter, zero initial state, keeping
// every factor-th output from `phase`): MATLAB filter() followed by x(phase+1:factor:end).
// Several filters of at most kMaxTaps taps run over the same input in one pass (each input
// sample is loaded once). The reductions are written with explicit two-lane vectors because the
// compiler may not reorder floating-point sums on its own; complex products are formed as
// x * (re, re) and x * (im, im) accumulated separately and combined once per output.
using v4d = double __attribute__((vector_size(32)));
constexpr std::size_t kMaxTaps = 26;  // even: taps are consumed two complex samples at a time

template <std::size_t Filters>
struct FusedTaps {
  std::size_t taps = 0;  // common even length (shorter filters zero-padded at the oldest end)
  // Pair p holds taps for input offsets 2p and 2p+1 (oldest first): (re, re, re', re') etc.
  v4d re[Filters][kMaxTaps / 2], im[Filters][kMaxTaps / 2];
};

template <std::size_t Filters>
FusedTaps<Filters> fuse(const std::array<std::span<const Complex>, Filters>& filters) {
  FusedTaps<Filters> f{};
  for (const auto& h : filters) f.taps = std::max(f.taps, h.size());
  f.taps += f.taps % 2;
  for (std::size_t k = 0; k < Filters; ++k)
    for (std::size_t i = 0; i < f.taps; i += 2) {
      auto tap = [&](std::size_t offset) {  // input offset (oldest first) meets tap taps-1-offset
        const std::size_t t = f.taps - 1 - offset;
        return t < filters[k].size() ? filters[k][t] : Complex{};
      };
      const Complex t0 = tap(i), t1 = tap(i + 1);
      f.re[k][i / 2] = v4d{t0.real(), t0.real(), t1.real(), t1.real()};
      f.im[k][i / 2] = v4d{t0.imag(), t0.imag(), t1.imag(), t1.imag()};
    }
  return f;
}

// The vector loop for the steady-state outputs [first, end). Compiled twice (AVX2 and the
// baseline) and chosen at run time: the arithmetic and its order are the same in both, so
// results do not depend on the machine.
template <std::size_t Filters>
__attribute__((always_inline)) inline void fir_body(const Complex* c, const FusedTaps<Filters>& f, std::size_t factor,
                                                    std::size_t phase, Complex* const* out, std::size_t first,
                                                    std::size_t end) {
  const std::size_t pairs = f.taps / 2;
  for (std::size_t m = first; m < end; ++m) {
    const double* x = reinterpret_cast<const double*>(c + (factor * m + phase + 1 - f.taps));
    v4d acc_re[Filters], acc_im[Filters];
    for (std::size_t k = 0; k < Filters; ++k) acc_re[k] = acc_im[k] = v4d{0.0, 0.0, 0.0, 0.0};
    for (std::size_t p = 0; p < pairs; ++p) {
      v4d xv;
      __builtin_memcpy(&xv, x + 4 * p, sizeof xv);
      for (std::size_t k = 0; k < Filters; ++k) {
        acc_re[k] += xv * f.re[k][p];
        acc_im[k] += xv * f.im[k][p];
      }
    }
    for (std::size_t k = 0; k < Filters; ++k) {
      const double rr = acc_re[k][0] + acc_re[k][2], ri = acc_re[k][1] + acc_re[k][3];
      const double ir = acc_im[k][0] + acc_im[k][2], ii = acc_im[k][1] + acc_im[k][3];
      out[k][m] = Complex(rr - ii, ri + ir);
    }
  }
}

__attribute__((target_clones("avx2", "default"))) void fir_body_2(const Complex* c, const FusedTaps<2>& f,
                                                                   std::size_t factor, std::size_t phase,
                                                                   Complex* const* out, std::size_t first,
                                                                   std::size_t end) {
  fir_body<2>(c, f, factor, phase, out, first, end);
}

// out[k][m] = sum_i filters[k][i] * c[factor*m + phase - i] (causal filter, zero initial state,
// keeping every factor-th output from `phase`): MATLAB filter() followed by x(phase+1:factor:end).
// The filters run fused over the same input (each sample loaded once). The reductions are
// written with explicit vectors because the compiler may not reorder floating-point sums itself;
// complex products are accumulated as x * (re, re) and x * (im, im) and combined per output.
template <std::size_t Filters>
void decimating_fir(std::span<const Complex> c, const FusedTaps<Filters>& f,
                    const std::array<std::span<const Complex>, Filters>& filters, std::size_t factor,
                    std::size_t phase, const std::array<Complex*, Filters>& out, std::size_t out_length) {
  // Start-up outputs: part of the (padded) filter still sees the zero initial state.
  std::size_t first = 0;
  while (first < out_length && factor * first + phase + 1 < f.taps) {
    const std::size_t last = factor * first + phase;
    for (std::size_t k = 0; k < Filters; ++k) {
      Complex acc{};
      for (std::size_t i = 0; i <= last && i < filters[k].size(); ++i) acc += filters[k][i] * c[last - i];
      out[k][first] = acc;
    }
    ++first;
  }
  static_assert(Filters == 2, "the ternary split has its own polyphase form (ternary_fir)");
  fir_body_2(c.data(), f, factor, phase, out.data(), first, out_length);
}

// The ternary split's three filters are one prototype u[i] = q[i] e^{2 pi j i/12} modulated by
// w^{i t}, w = e^{2 pi j/6}, t = 0, 1, 2. Grouping the taps by i mod 6 gives six partial sums
// P_r = sum_{i = r mod 6} u[i] c[3m+2-i] (25 complex products instead of 75), and
// out_t = sum_r w^{r t} P_r, a three-point transform of A_r = P_r + P_{r+3} (t = 0, 2) and
// B_r = P_r - P_{r+3} (t = 1).
using v2d = double __attribute__((vector_size(16)));
constexpr std::size_t kTernaryTaps = 25;

struct TernaryPolyphase {
  v2d re[kTernaryTaps], im[kTernaryTaps];  // u[i] as (re, re) and (im, im)
};

TernaryPolyphase ternary_polyphase(std::span<const Complex> first_filter) {
  TernaryPolyphase f{};
  for (std::size_t i = 0; i < kTernaryTaps; ++i) {
    f.re[i] = v2d{first_filter[i].real(), first_filter[i].real()};
    f.im[i] = v2d{first_filter[i].imag(), first_filter[i].imag()};
  }
  return f;
}

template <std::size_t R>
__attribute__((always_inline)) inline void ternary_phase(const double* newest, const TernaryPolyphase& f, v2d& re,
                                                         v2d& im) {
  for (std::size_t i = R; i < kTernaryTaps; i += 6) {
    v2d x;
    __builtin_memcpy(&x, newest - 2 * i, sizeof x);  // c[3m+2-i]
    re += x * f.re[i];
    im += x * f.im[i];
  }
}

__attribute__((always_inline)) inline Complex ternary_sum(v2d re, v2d im) { return Complex(re[0] - im[1], re[1] + im[0]); }

__attribute__((target_clones("avx2", "default"))) void ternary_body(const Complex* c, const TernaryPolyphase& f,
                                                                     Complex* const* out, std::size_t first,
                                                                     std::size_t end) {
  // w^1, w^2 and w^4 as (cos, sin); products written out (std::complex's operator* checks for
  // infinities and NaN through a library call).
  const double h = std::sqrt(3.0) / 2.0;
  auto times = [](const Complex& a, double cr, double ci) {
    return Complex(a.real() * cr - a.imag() * ci, a.real() * ci + a.imag() * cr);
  };
  for (std::size_t m = first; m < end; ++m) {
    const double* newest = reinterpret_cast<const double*>(c + 3 * m + 2);
    v2d re[6] = {}, im[6] = {};
    ternary_phase<0>(newest, f, re[0], im[0]);
    ternary_phase<1>(newest, f, re[1], im[1]);
    ternary_phase<2>(newest, f, re[2], im[2]);
    ternary_phase<3>(newest, f, re[3], im[3]);
    ternary_phase<4>(newest, f, re[4], im[4]);
    ternary_phase<5>(newest, f, re[5], im[5]);
    Complex p[6];
    for (std::size_t r = 0; r < 6; ++r) p[r] = ternary_sum(re[r], im[r]);
    const Complex a0 = p[0] + p[3], a1 = p[1] + p[4], a2 = p[2] + p[5];
    const Complex b0 = p[0] - p[3], b1 = p[1] - p[4], b2 = p[2] - p[5];
    out[0][m] = a0 + a1 + a2;
    out[1][m] = b0 + times(b1, 0.5, h) + times(b2, -0.5, h);
    out[2][m] = a0 + times(a1, -0.5, h) + times(a2, -0.5, -h);
  }
}

// The ternary split (factor 3, phase 2) through the polyphase form; the start-up outputs, whose
// window reaches before the node's first sample, directly.
void ternary_fir(std::span<const Complex> c, const TernaryPolyphase& f,
                 const std::array<std::span<const Complex>, 3>& filters, const std::array<Complex*, 3>& out,
                 std::size_t out_length) {
  std::size_t first = 0;
  while (first < out_length && 3 * first + 2 + 1 < kTernaryTaps) {
    const std::size_t last = 3 * first + 2;
    for (std::size_t k = 0; k < 3; ++k) {
      Complex acc{};
      for (std::size_t i = 0; i <= last && i < filters[k].size(); ++i) acc += filters[k][i] * c[last - i];
      out[k][first] = acc;
    }
    ++first;
  }
  ternary_body(c.data(), f, out.data(), first, out_length);
}

// BandMap::optimum's eligibility, one rule for the optimum and for the gate that skips the bands it
// cannot pick: the band ends inside the usable band, and its power is positive and above the floor.
bool within_usable_band(double high_fraction, double max_high_fraction) { return high_fraction <= max_high_fraction + 1e-12; }
bool above_power_floor(double power, double min_power) { return power >= min_power && power > 0.0; }

}  // namespace

OneThirdBinaryFilterBank::OneThirdBinaryFilterBank() {
  using std::numbers::pi;
  const auto p = firwin_lowpass(17, 0.4);
  low_.resize(17);
  for (int n = 0; n < 17; ++n) low_[static_cast<std::size_t>(n)] = p[static_cast<std::size_t>(n)] * std::polar(1.0, 2.0 * pi * n / 8.0);
  // g[k] = h[(-1-k) mod 16] * (-1)^(k+1) (reference README), k = 0..15.
  high_.resize(16);
  for (int k = 0; k < 16; ++k) {
    const int index = ((-1 - k) % 16 + 16) % 16;
    high_[static_cast<std::size_t>(k)] = low_[static_cast<std::size_t>(index)] * ((k + 1) % 2 == 0 ? 1.0 : -1.0);
  }
  const auto q = firwin_lowpass(25, 0.4 * 2.0 / 3.0);
  for (auto& t : ternary_) t.resize(25);
  for (int n = 0; n < 25; ++n) {
    const Complex h1 = q[static_cast<std::size_t>(n)] * std::polar(1.0, 2.0 * pi * n / 12.0);
    ternary_[0][static_cast<std::size_t>(n)] = h1;
    ternary_[1][static_cast<std::size_t>(n)] = h1 * std::polar(1.0, 2.0 * pi * n / 6.0);
    ternary_[2][static_cast<std::size_t>(n)] = h1 * std::polar(1.0, 2.0 * pi * n / 3.0);
  }
}

double BandMap::band_high_fraction(std::size_t row, std::size_t column) const {
  const std::size_t k = (row + 1) / 2;
  const std::size_t bands = row == 0 ? 1 : row % 2 == 1 ? (std::size_t{1} << k) : 3 * (std::size_t{1} << (k - 1));
  const std::size_t band = column / (columns() / bands);
  return static_cast<double>(band + 1) / static_cast<double>(2 * bands);
}

BandMap::Optimum BandMap::optimum(double max_high_fraction, const BandMap* power, double min_power_fraction) const {
  if (power != nullptr && (power->levels != levels || power->values.size() != values.size()))
    throw std::invalid_argument("BandMap::optimum: power map of another layout");
  const double min_power = power != nullptr ? min_power_fraction * power->at(0, 0) : 0.0;
  Optimum best;
  best.value = -std::numeric_limits<double>::infinity();
  for (std::size_t r = 0; r < rows(); ++r)
    for (std::size_t c = 0; c < columns(); ++c)
      if (at(r, c) > best.value && within_usable_band(band_high_fraction(r, c), max_high_fraction) &&
          (power == nullptr || above_power_floor(power->at(r, c), min_power))) {
        best.found = true;
        best.value = at(r, c);
        best.row = static_cast<int>(r);
        best.first_column = c;
      }
  best.level = filter_bank_row_level(best.row);
  best.bandwidth_fraction = std::pow(2.0, -(best.level + 1.0));
  best.centre_fraction = static_cast<double>(best.first_column) / static_cast<double>(columns() * 2) +
                         std::pow(2.0, -(best.level + 2.0));
  return best;
}

void OneThirdBinaryFilterBank::analyse(std::span<const double> x, int levels, std::span<BandCriterion* const> criteria,
                                       std::span<BandMap> maps, const std::optional<BandGate>& gate) {
  if (levels < 1 || levels > 16) throw std::invalid_argument("filter bank: levels must be 1..16");
  if (maps.size() < criteria.size()) throw std::invalid_argument("filter bank: one map per criterion");
  // The deepest binary node must keep samples after its 16-sample trim.
  if (x.size() < (static_cast<std::size_t>(32) << levels))
    throw std::invalid_argument("filter bank: signal too short for " + std::to_string(levels) + " levels");
  if (gate && gate->power_criterion >= criteria.size())
    throw std::invalid_argument("filter bank: the gate's power criterion is not among the criteria");
  levels_ = levels;
  criteria_ = criteria;
  maps_ = maps;
  gate_ = gate;
  moments_read_ = std::any_of(criteria.begin(), criteria.end(), [](const BandCriterion* c) { return c->reads_moments(); });
  const std::size_t columns = static_cast<std::size_t>(3) << levels;
  for (std::size_t i = 0; i < criteria.size(); ++i) {
    maps[i].levels = levels;
    maps[i].criterion = criteria[i]->name();
    maps[i].values.assign(static_cast<std::size_t>(2 * levels) * columns, 0.0);
  }
  const double mean = std::accumulate(x.begin(), x.end(), 0.0) / static_cast<double>(x.size());
  root_.resize(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) root_[i] = Complex(x[i] - mean, 0.0);
  low_children_.resize(static_cast<std::size_t>(levels) + 1);
  high_children_.resize(static_cast<std::size_t>(levels) + 1);
  std::size_t length = x.size();
  for (int d = 1; d <= levels; ++d) {
    length /= 2;
    low_children_[static_cast<std::size_t>(d)].resize(length);
    high_children_[static_cast<std::size_t>(d)].resize(length);
  }
  ternary_scratch_.resize(x.size() / 3 * 3);

  evaluate(0, 0, 1, 1, true, root_);
  visit(0, 0, root_, x.size());
}

void OneThirdBinaryFilterBank::evaluate(int row, int band, int band_count, int decimation, bool real,
                                        std::span<const Complex> trimmed) {
  FilterBankNode node;
  node.row = row;
  node.level = filter_bank_row_level(row);
  node.band_index = band;
  node.band_count = band_count;
  node.decimation = decimation;
  node.real = real;
  node.samples = trimmed;
  if (criteria_.empty()) return;
  if (moments_read_) {
    moments_ = node_moments(trimmed);
    node.moments = &moments_;
  }
  const std::size_t columns = static_cast<std::size_t>(3) << levels_;
  const std::size_t span = columns / static_cast<std::size_t>(band_count);
  const std::size_t first_column = static_cast<std::size_t>(band) * span;
  auto store = [&](std::size_t i, double value) {
    double* out = &maps_[i].values[static_cast<std::size_t>(row) * columns + first_column];
    std::fill(out, out + span, value);
  };
  if (!gate_) {
    for (std::size_t i = 0; i < criteria_.size(); ++i) store(i, criteria_[i]->evaluate(node));
    return;
  }
  const std::size_t p = gate_->power_criterion;
  const double power = criteria_[p]->evaluate(node);
  store(p, power);
  if (row == 0) gate_min_power_ = gate_->min_power_fraction * power;
  const bool eligible =
      within_usable_band(maps_[p].band_high_fraction(static_cast<std::size_t>(row), first_column), gate_->max_high_fraction) &&
      above_power_floor(power, gate_min_power_);
  for (std::size_t i = 0; i < criteria_.size(); ++i)
    if (i != p) store(i, eligible ? criteria_[i]->evaluate(node) : std::numeric_limits<double>::quiet_NaN());
}

void OneThirdBinaryFilterBank::ternary_split(int depth, int band, std::span<const Complex> node) {
  const std::size_t out_length = node.size() / 3;
  const int row = 2 * (depth + 1);
  const int band_count = 3 << depth;
  const int decimation = 3 << depth;
  const std::array<std::span<const Complex>, 3> filters{ternary_[0], ternary_[1], ternary_[2]};
  static const auto polyphase = ternary_polyphase(ternary_[0]);
  const std::array<Complex*, 3> out{ternary_scratch_.data(), ternary_scratch_.data() + out_length,
                                    ternary_scratch_.data() + 2 * out_length};
  ternary_fir(node, polyphase, filters, out, out_length);
  for (int t = 0; t < 3; ++t) {
    const std::size_t trim = std::min<std::size_t>(16, out_length);  // len(h) - 1, as the reference
    evaluate(row, 3 * band + t, band_count, decimation, false,
             std::span<const Complex>(out[static_cast<std::size_t>(t)], out_length).subspan(trim));
  }
}

void OneThirdBinaryFilterBank::visit(int depth, int band, std::span<const Complex> node, std::size_t) {
  if (depth >= levels_) return;
  const auto child_depth = static_cast<std::size_t>(depth + 1);
  auto& a = low_children_[child_depth];
  auto& d = high_children_[child_depth];
  const std::size_t half = node.size() / 2;
  std::span<Complex> a_span(a.data(), half), d_span(d.data(), half);
  const std::array<std::span<const Complex>, 2> filters{low_, high_};
  static const auto fused = fuse<2>(filters);
  decimating_fir<2>(node, fused, filters, 2, 1, {a.data(), d.data()}, half);
  for (std::size_t m = 0; m < half; m += 2) d_span[m] = -d_span[m];  // (-1)^(m+1): back to baseband
  const int row = 2 * depth + 1;
  const int band_count = 2 << depth;
  const int decimation = 2 << depth;
  evaluate(row, 2 * band, band_count, decimation, false, std::span<const Complex>(a_span).subspan(std::min<std::size_t>(16, half)));
  evaluate(row, 2 * band + 1, band_count, decimation, false, std::span<const Complex>(d_span).subspan(std::min<std::size_t>(15, half)));
  if (depth <= levels_ - 2) ternary_split(depth, band, node);
  visit(depth + 1, 2 * band, a_span, half);
  visit(depth + 1, 2 * band + 1, d_span, half);
}

namespace {

// The raw sums of two samples (re, im, re', im') into lane accumulators: |c|^2 is formed in both
// lanes of its sample, so every product stays lane-wise.
using v4i = long long __attribute__((vector_size(32)));
struct MomentLanes {
  v4d sum, squares, cross, sum4, sum2c;  // c; (re^2, im^2); re im; |c|^4; |c|^2 c
};

__attribute__((always_inline)) inline void accumulate_moments(const Complex* two, MomentLanes& m) {
  v4d x;
  __builtin_memcpy(&x, two, sizeof x);
  const v4i swap{1, 0, 3, 2};
  const v4d squares = x * x;
  const v4d norm = squares + __builtin_shuffle(squares, swap);
  m.sum += x;
  m.squares += squares;
  m.cross += x * __builtin_shuffle(x, swap);
  m.sum4 += norm * norm;
  m.sum2c += norm * x;
}

// Two sets of lane accumulators (independent chains); a tail of fewer than four samples is padded
// with zeros, which add nothing to any sum. Compiled twice like the filters, same arithmetic.
__attribute__((target_clones("avx2", "default"))) NodeMoments moments_body(const Complex* c, std::size_t n) {
  MomentLanes lanes[2] = {};
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    accumulate_moments(c + i, lanes[0]);
    accumulate_moments(c + i + 2, lanes[1]);
  }
  if (i < n) {
    Complex rest[4] = {};
    for (std::size_t k = 0; i + k < n; ++k) rest[k] = c[i + k];
    accumulate_moments(rest, lanes[0]);
    accumulate_moments(rest + 2, lanes[1]);
  }
  const v4d sum = lanes[0].sum + lanes[1].sum, squares = lanes[0].squares + lanes[1].squares;
  const v4d cross = lanes[0].cross + lanes[1].cross, sum4 = lanes[0].sum4 + lanes[1].sum4;
  const v4d sum2c = lanes[0].sum2c + lanes[1].sum2c;
  NodeMoments m;
  m.count = n;
  m.sum = Complex(sum[0] + sum[2], sum[1] + sum[3]);
  const double re2 = squares[0] + squares[2], im2 = squares[1] + squares[3];
  m.sum2 = re2 + im2;
  m.sum_sq = Complex(re2 - im2, 2.0 * (cross[0] + cross[2]));
  m.sum4 = sum4[0] + sum4[2];
  m.sum2c = Complex(sum2c[0] + sum2c[2], sum2c[1] + sum2c[3]);
  return m;
}

// (sum |c - mean|^2, sum |c - mean|^4) in four chains: the second pass where the mean is large.
std::pair<double, double> central_moment_sums(std::span<const Complex> c, Complex mean) {
  double m2[4] = {}, m4[4] = {};
  std::size_t i = 0;
  for (; i + 4 <= c.size(); i += 4)
    for (std::size_t j = 0; j < 4; ++j) {
      const double dr = c[i + j].real() - mean.real(), di = c[i + j].imag() - mean.imag();
      const double p = dr * dr + di * di;
      m2[j] += p;
      m4[j] += p * p;
    }
  for (; i < c.size(); ++i) {
    const double dr = c[i].real() - mean.real(), di = c[i].imag() - mean.imag();
    const double p = dr * dr + di * di;
    m2[0] += p;
    m4[0] += p * p;
  }
  return {(m2[0] + m2[1]) + (m2[2] + m2[3]), (m4[0] + m4[1]) + (m4[2] + m4[3])};
}

// Above this |mean|^2 / mean|c|^2 the central moments are taken about the mean in a second pass:
// below it the raw-sum expansion's terms stay within a few times sum |c - mean|^4, so it loses no
// more than a few roundings.
constexpr double kRawMomentMeanRatio = 1e-2;

// sum |c - mu|^4 = S4 - 4 Re(T mu*) + 4 |mu|^2 S2 + 2 Re(U mu*^2) - 3 n |mu|^4, with
// S2 = sum |c|^2, S4 = sum |c|^4, T = sum |c|^2 c, U = sum c^2 (expanding |c - mu|^2 =
// |c|^2 - 2 Re(c mu*) + |mu|^2 and Re(z)^2 = (|z|^2 + Re(z^2)) / 2).
double central_sum4(const NodeMoments& m, Complex mean) {
  const double mean2 = std::norm(mean), n = static_cast<double>(m.count);
  const double t = m.sum2c.real() * mean.real() + m.sum2c.imag() * mean.imag();  // Re(T mu*)
  const double mr2 = mean.real() * mean.real() - mean.imag() * mean.imag(), mi2 = 2.0 * mean.real() * mean.imag();
  const double u = m.sum_sq.real() * mr2 + m.sum_sq.imag() * mi2;  // Re(U mu*^2)
  return m.sum4 - 4.0 * t + 4.0 * mean2 * m.sum2 + 2.0 * u - 3.0 * n * mean2 * mean2;
}

}  // namespace

NodeMoments node_moments(std::span<const Complex> c) { return moments_body(c.data(), c.size()); }

double KurtosisCriterion::evaluate(const FilterBankNode& node) {
  const auto c = node.samples;
  if (c.empty()) return 0.0;
  const NodeMoments m = node.moments != nullptr ? *node.moments : node_moments(c);
  const double n = static_cast<double>(c.size());
  const Complex mean = m.sum / n;
  double m2 = 0.0, m4 = 0.0;
  if (std::norm(mean) <= kRawMomentMeanRatio * (m.sum2 / n)) {
    m2 = m.sum2 / n - std::norm(mean);
    m4 = central_sum4(m, mean) / n;
  } else {
    const auto [s2, s4] = central_moment_sums(c, mean);
    m2 = s2 / n;
    m4 = s4 / n;
  }
  // An all-zero node has m2 = 0 and returns 0 here.
  if (m2 < std::numeric_limits<double>::epsilon()) return 0.0;
  return m4 / (m2 * m2) - (node.real ? 3.0 : 2.0);
}

double BandPowerCriterion::evaluate(const FilterBankNode& node) {
  if (node.samples.empty()) return 0.0;
  const double sum2 = node.moments != nullptr ? node.moments->sum2 : node_moments(node.samples).sum2;
  return (node.real ? 1.0 : 2.0) * sum2 / static_cast<double>(node.samples.size());
}

double Ics2Criterion::evaluate(const FilterBankNode& node) {
  const auto spr = static_cast<std::size_t>(samples_per_rev_);
  const auto decimation = static_cast<std::size_t>(node.decimation);
  // The shortest stretch with a whole number of node samples and of revolutions.
  const std::size_t g = std::gcd(spr, decimation);
  const std::size_t unit = spr / g;                  // node samples in decimation/g revolutions
  const double revs_per_unit = static_cast<double>(decimation / g);
  // A smooth count keeps the transform fast (a large prime factor would make it many times slower);
  // it drops at most a few percent of the node.
  const std::size_t available = node.samples.size() / unit;
  const std::size_t units = available == 0 ? 0 : previous_smooth_size(available);
  if (units == 0) return 0.0;
  const std::size_t n = units * unit;
  const double revolutions = static_cast<double>(units) * revs_per_unit;
  if (node.real && whole_signal_value_) return *whole_signal_value_;
  if (node.real) {
    const RealFft& fft = plans_->real(n);
    real_.resize(n);
    for (std::size_t i = 0; i < n; ++i) real_[i] = node.samples[i].real();
    apply_tukey_taper(real_, kEnvelopeTaperFraction);
    spectrum_.resize(fft.spectrum_size());
    fft.forward(real_, spectrum_);
    return envelope_->full_band_ics2(real_, spectrum_, static_cast<std::size_t>(revolutions), parameters_).value;
  }
  return envelope_->complex_ics2(node.samples.subspan(0, n), revolutions, parameters_).value;
}

}  // namespace gearwatch::dsp
