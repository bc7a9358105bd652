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

// The tree's filters are modulated real prototypes: binary h[k] = p[k] w^k and
// g[k] = p[15-k] w^(3(k+1)) (w = e^{j pi/4}; the reference's g[k] = h[15-k] (-1)^(k+1)), ternary
// t_t[i] = q[i] v^i e^{2 pi j i t/6} (v = e^{j pi/6}). With the node modulated once,
// y[i] = w^-i c[i] (z[i] = v^-i c[i]), every product is a real tap times a complex sample, half
// the arithmetic of the complex taps, and the modulation is put back once per output:
//   a[m] = w^n sum_k p[k] y[n-k],  (-1)^(m+1) d[m] = (-j)^m sum_k p[15-k] j^k y[n-k]  (n = 2m+1),
//   out_t[m] = v^n sum_r e^{2 pi j r t/6} Q_r,  Q_r = sum_{i = r mod 6} q[i] z[n-i]   (n = 3m+2).
// Outputs are those of MATLAB filter() (causal, zero initial state) kept at x(n+1:factor:end);
// windows reaching before the node's first sample read zeros. The sums are written with explicit
// vectors (the compiler may not reorder floating-point sums), lane-wise, so the AVX2 and baseline
// builds give the same results.
using v4d = double __attribute__((vector_size(32)));
// swap(x) below is __builtin_shufflevector(x, x, 1, 0, 3, 2): each of two complex samples' real and
// imaginary parts swapped (that builtin, not __builtin_shuffle, is understood by GCC and Clang alike).
constexpr std::size_t kTernaryTaps = 25;
constexpr std::size_t kBlockOutputs = 256;  // outputs per modulated block (the block stays in L1)

// e^{j pi k/4} and e^{j pi k/6} with the quarter turns exact.
const std::array<Complex, 8>& eighth_turns() {
  static const double h = std::sqrt(0.5);
  static const std::array<Complex, 8> t{Complex(1, 0),  Complex(h, h),   Complex(0, 1),  Complex(-h, h),
                                        Complex(-1, 0), Complex(-h, -h), Complex(0, -1), Complex(h, -h)};
  return t;
}
const std::array<Complex, 12>& twelfth_turns() {
  static const double c = std::sqrt(3.0) / 2.0;
  static const std::array<Complex, 12> t{Complex(1, 0),   Complex(c, 0.5),   Complex(0.5, c),  Complex(0, 1),
                                         Complex(-0.5, c), Complex(-c, 0.5),  Complex(-1, 0),   Complex(-c, -0.5),
                                         Complex(-0.5, -c), Complex(0, -1),   Complex(0.5, -c), Complex(c, -0.5)};
  return t;
}

// a b written out (std::complex's operator* checks for infinities and NaN through a library call).
inline Complex times(const Complex& a, const Complex& b) {
  return Complex(a.real() * b.real() - a.imag() * b.imag(), a.real() * b.imag() + a.imag() * b.real());
}

// out[t] = conj(turns[(first + t) mod P]) c[first + t] for t < count, zero before c's first sample.
// Two samples a vector: (a, b) (cr - j ci) = x (cr, cr) + swap(x) (ci, -ci), the products and sums
// of the scalar form in the same order.
template <std::size_t P>
struct TurnPairs {
  v4d re[P], im[P];  // for the pair whose first sample has phase ph
};

template <std::size_t P>
TurnPairs<P> turn_pairs(const std::array<Complex, P>& turns) {
  TurnPairs<P> t{};
  for (std::size_t ph = 0; ph < P; ++ph) {
    const Complex u = std::conj(turns[ph]), v = std::conj(turns[(ph + 1) % P]);
    t.re[ph] = v4d{u.real(), u.real(), v.real(), v.real()};
    t.im[ph] = v4d{-u.imag(), u.imag(), -v.imag(), v.imag()};
  }
  return t;
}

template <std::size_t P>
__attribute__((always_inline)) inline void modulate_pairs(const Complex* x, std::size_t pairs, std::size_t phase,
                                                          const TurnPairs<P>& t, Complex* out) {
  for (std::size_t j = 0; j < pairs; ++j) {
    v4d v;
    __builtin_memcpy(&v, x + 2 * j, sizeof v);
    const v4d y = v * t.re[phase] + __builtin_shufflevector(v, v, 1, 0, 3, 2) * t.im[phase];
    __builtin_memcpy(reinterpret_cast<double*>(out + 2 * j), &y, sizeof y);
    phase = phase + 2 >= P ? phase + 2 - P : phase + 2;
  }
}

__attribute__((target_clones("avx2", "default"))) void modulate_pairs_8(const Complex* x, std::size_t pairs,
                                                                        std::size_t phase, const TurnPairs<8>& t,
                                                                        Complex* out) {
  modulate_pairs(x, pairs, phase, t, out);
}
__attribute__((target_clones("avx2", "default"))) void modulate_pairs_12(const Complex* x, std::size_t pairs,
                                                                         std::size_t phase, const TurnPairs<12>& t,
                                                                         Complex* out) {
  modulate_pairs(x, pairs, phase, t, out);
}

template <std::size_t P>
void modulate(std::span<const Complex> c, std::ptrdiff_t first, std::size_t count, const std::array<Complex, P>& turns,
              Complex* out) {
  static const TurnPairs<P> pairs = turn_pairs(turns);
  std::size_t t = 0;
  for (; t < count && first + static_cast<std::ptrdiff_t>(t) < 0; ++t) out[t] = Complex{};
  if (t == count) return;
  const auto start = static_cast<std::size_t>(first + static_cast<std::ptrdiff_t>(t));
  const std::size_t phase = start % P, n = (count - t) / 2;
  if constexpr (P == 8) modulate_pairs_8(c.data() + start, n, phase, pairs, out + t);
  else modulate_pairs_12(c.data() + start, n, phase, pairs, out + t);
  for (std::size_t k = t + 2 * n; k < count; ++k) out[k] = times(c[start + (k - t)], std::conj(turns[(start + k - t) % P]));
}

// The prototype is linear-phase (p[k] = p[16-k]), so the taps are folded: each product takes the sum
// of the two samples sharing a tap. Window offset o holds y[n-17+o] (k = 17-o). The low half pairs
// o with 18-o; the high half's taps p[15-k] j^k pair k with 14-k (o with 20-o), where j^(14-k) is
// j^k for odd k (lanes 0-1) and -j^k for even k (lanes 2-3), so the mirror's even lanes are negated.
struct BinaryTaps {
  v4d low[5];   // pairs from o = 1, 3, 5, 7 folded with o' = 17, 15, 13, 11 (and 16, 14, 12, 10); o = 9 alone
  v4d high[5];  // pairs from o = 2, 4, 6, 8 folded with (-, 17), (16, 15), (14, 13), (12, 11); o = 10 alone
};

BinaryTaps binary_taps(std::span<const double> p) {
  auto high = [&](std::size_t k) {
    const double sign = ((k % 2 == 0 ? k : k - 1) / 2) % 2 == 0 ? 1.0 : -1.0;
    return sign * p[15 - k];
  };
  BinaryTaps f{};
  for (std::size_t i = 0; i < 4; ++i) {
    f.low[i] = v4d{p[16 - 2 * i], p[16 - 2 * i], p[15 - 2 * i], p[15 - 2 * i]};
    f.high[i] = v4d{high(15 - 2 * i), high(15 - 2 * i), high(14 - 2 * i), high(14 - 2 * i)};
  }
  f.low[4] = v4d{p[8], p[8], 0.0, 0.0};
  f.high[4] = v4d{high(7), high(7), 0.0, 0.0};
  return f;
}

// Window offsets o and o + 1 as one vector (an out parameter: returning a vector type warns of the
// baseline ABI).
__attribute__((always_inline)) inline void load_pair(const Complex* y, std::size_t o, v4d& v) {
  __builtin_memcpy(&v, y + o, sizeof v);
}

__attribute__((always_inline)) inline void binary_sums(const Complex* y, const BinaryTaps& f, v4d& lo, v4d& hi) {
  using v4l = long long __attribute__((vector_size(32)));
  const v4l negate_even = v4l{0, 0, 1, 1} << 63;  // the sign bits of lanes 2-3 (an exact negation)
  const v4d zero{0.0, 0.0, 0.0, 0.0};
  v4d a, m;
  load_pair(y, 9, a);
  lo = a * f.low[4];
  for (std::size_t i = 0; i < 4; ++i) {
    load_pair(y, 2 * i + 1, a);
    load_pair(y, 16 - 2 * i, m);
    lo += (a + __builtin_shufflevector(m, m, 2, 3, 0, 1)) * f.low[i];
  }
  load_pair(y, 10, a);
  hi = a * f.high[4];
  load_pair(y, 2, a);
  load_pair(y, 16, m);
  const v4d last = __builtin_shufflevector(m, zero, 4, 5, 2, 3);  // (0, y[17])
  hi += (a + reinterpret_cast<v4d>(reinterpret_cast<v4l>(last) ^ negate_even)) * f.high[0];
  for (std::size_t i = 1; i < 4; ++i) {
    load_pair(y, 2 * i + 2, a);
    load_pair(y, 17 - 2 * i, m);
    const v4d mirror = __builtin_shufflevector(m, m, 2, 3, 0, 1);
    hi += (a + reinterpret_cast<v4d>(reinterpret_cast<v4l>(mirror) ^ negate_even)) * f.high[i];
  }
}

// The rotations of outputs m and m + 1 as pair tables indexed by m mod 4: w^(2m+1) for the low
// half, (-j)^m (exact) for the high one.
struct BinaryTurns {
  v4d low_re[4], low_im[4], high_re[4], high_im[4];
};

BinaryTurns binary_turns() {
  const auto& w = eighth_turns();
  const std::array<Complex, 4> minus_j{Complex(1, 0), Complex(0, -1), Complex(-1, 0), Complex(0, 1)};
  BinaryTurns t{};
  for (std::size_t m = 0; m < 4; ++m) {
    const Complex a = w[(2 * m + 1) % 8], b = w[(2 * m + 3) % 8], c = minus_j[m], d = minus_j[(m + 1) % 4];
    t.low_re[m] = v4d{a.real(), a.real(), b.real(), b.real()};
    t.low_im[m] = v4d{-a.imag(), a.imag(), -b.imag(), b.imag()};
    t.high_re[m] = v4d{c.real(), c.real(), d.real(), d.real()};
    t.high_im[m] = v4d{-c.imag(), c.imag(), -d.imag(), d.imag()};
  }
  return t;
}

// Outputs [m0, m0 + count) of both halves; y holds the modulated node from index 2 m0 - 16. Two
// outputs at a time, so their sums, rotations and stores are vector operations (the same
// products and sums as one output at a time: s (cr + j ci) = s (cr, cr) + swap(s) (-ci, ci)).
__attribute__((target_clones("avx2", "default"))) void binary_block(const Complex* y, const BinaryTaps& f,
                                                                    const BinaryTurns& turns, std::size_t m0,
                                                                    std::size_t count, Complex* a, Complex* d) {
  std::size_t j = 0;
  for (; j + 2 <= count; j += 2) {
    v4d lo0, hi0, lo1, hi1;
    binary_sums(y + 2 * j, f, lo0, hi0);
    binary_sums(y + 2 * j + 2, f, lo1, hi1);
    const v4d low = __builtin_shufflevector(lo0, lo1, 0, 1, 4, 5) + __builtin_shufflevector(lo0, lo1, 2, 3, 6, 7);
    // even-k part + j odd-k part: (hi[2] - hi[1], hi[3] + hi[0]) of each
    const v4d high = __builtin_shufflevector(hi0, hi1, 2, 3, 6, 7) +
                     __builtin_shufflevector(hi0, hi1, 1, 0, 5, 4) * v4d{-1.0, 1.0, -1.0, 1.0};
    const std::size_t m = m0 + j, phase = m % 4;
    const v4d low_out = low * turns.low_re[phase] + __builtin_shufflevector(low, low, 1, 0, 3, 2) * turns.low_im[phase];
    const v4d high_out = high * turns.high_re[phase] + __builtin_shufflevector(high, high, 1, 0, 3, 2) * turns.high_im[phase];
    __builtin_memcpy(reinterpret_cast<double*>(a + m), &low_out, sizeof low_out);
    __builtin_memcpy(reinterpret_cast<double*>(d + m), &high_out, sizeof high_out);
  }
  if (j < count) {  // an odd last output
    v4d lo, hi;
    binary_sums(y + 2 * j, f, lo, hi);
    const std::size_t m = m0 + j, phase = m % 4;
    const Complex low(lo[0] + lo[2], lo[1] + lo[3]), high(hi[2] - hi[1], hi[3] + hi[0]);
    a[m] = Complex(low.real() * turns.low_re[phase][0] + low.imag() * turns.low_im[phase][0],
                   low.imag() * turns.low_re[phase][1] + low.real() * turns.low_im[phase][1]);
    d[m] = Complex(high.real() * turns.high_re[phase][0] + high.imag() * turns.high_im[phase][0],
                   high.imag() * turns.high_re[phase][1] + high.real() * turns.high_im[phase][1]);
  }
}

struct TernaryTaps {
  // Group pairs (1, 0), (3, 2), (5, 4): the sample pair (z[n-i-1], z[n-i]) for taps i + 1 and i.
  v4d pair01[5], pair23[4], pair45[4];
};

TernaryTaps ternary_taps(std::span<const double> q) {
  auto tap = [&](std::size_t i) { return i < q.size() ? q[i] : 0.0; };
  TernaryTaps f{};
  for (std::size_t g = 0; g < 5; ++g) f.pair01[g] = v4d{tap(6 * g + 1), tap(6 * g + 1), tap(6 * g), tap(6 * g)};
  for (std::size_t g = 0; g < 4; ++g) {
    f.pair23[g] = v4d{tap(6 * g + 3), tap(6 * g + 3), tap(6 * g + 2), tap(6 * g + 2)};
    f.pair45[g] = v4d{tap(6 * g + 5), tap(6 * g + 5), tap(6 * g + 4), tap(6 * g + 4)};
  }
  return f;
}

__attribute__((always_inline)) inline void ternary_sums(const Complex* z, const TernaryTaps& f, std::size_t j, v4d& s01,
                                                        v4d& s23, v4d& s45) {
  const Complex* newest = z + 24 + 3 * j;  // z[n - 1]: (z[n-i-1], z[n-i]) starts at newest - i
  v4d x;
  s01 = s23 = s45 = v4d{0.0, 0.0, 0.0, 0.0};
  for (std::size_t g = 0; g < 5; ++g) {
    __builtin_memcpy(&x, newest - 6 * g, sizeof x);
    s01 += x * f.pair01[g];
  }
  for (std::size_t g = 0; g < 4; ++g) {
    __builtin_memcpy(&x, newest - 6 * g - 2, sizeof x);
    s23 += x * f.pair23[g];
    __builtin_memcpy(&x, newest - 6 * g - 4, sizeof x);
    s45 += x * f.pair45[g];
  }
}

// A complex rotation of two outputs (s (cr + j ci) = s (cr, cr) + swap(s) (-ci, ci): the products and
// sums of the scalar form), and the pair tables of the ternary split: the three-point transform's
// constants and v^(3m+2) for outputs m and m + 1, by m mod 4.
struct PairTurn {
  v4d re, im;
};
PairTurn pair_turn(const Complex& a, const Complex& b) {
  return {v4d{a.real(), a.real(), b.real(), b.real()}, v4d{-a.imag(), a.imag(), -b.imag(), b.imag()}};
}
struct TernaryTurns {
  PairTurn w1, w2, w4, out[4];
};
TernaryTurns ternary_turns() {
  const auto& v = twelfth_turns();
  TernaryTurns t{};
  t.w1 = pair_turn(v[2], v[2]);
  t.w2 = pair_turn(v[4], v[4]);
  t.w4 = pair_turn(v[8], v[8]);
  for (std::size_t m = 0; m < 4; ++m) t.out[m] = pair_turn(v[(3 * m + 2) % 12], v[(3 * m + 5) % 12]);
  return t;
}

__attribute__((always_inline)) inline void rotate(const v4d& s, const PairTurn& t, v4d& r) {
  r = s * t.re + __builtin_shufflevector(s, s, 1, 0, 3, 2) * t.im;
}

// The three bands of outputs m (lanes 0-1) and m + 1 (lanes 2-3) from the partial sums Q_0..Q_5:
// the three-point transform of A_r = Q_r + Q_r+3 and B_r = Q_r - Q_r+3, then v^(3m+2).
__attribute__((always_inline)) inline void ternary_outputs(const v4d (&q)[6], const TernaryTurns& turns,
                                                           const PairTurn& turn, v4d (&o)[3]) {
  const v4d a0 = q[0] + q[3], a1 = q[1] + q[4], a2 = q[2] + q[5];
  const v4d b0 = q[0] - q[3], b1 = q[1] - q[4], b2 = q[2] - q[5];
  v4d r1, r2;
  rotate(a0 + a1 + a2, turn, o[0]);
  rotate(b1, turns.w1, r1);
  rotate(b2, turns.w2, r2);
  rotate(b0 + r1 + r2, turn, o[1]);
  rotate(a1, turns.w2, r1);
  rotate(a2, turns.w4, r2);
  rotate(a0 + r1 + r2, turn, o[2]);
}

// The six tap groups' sums of output a (lanes 0-1) and output b (lanes 2-3): of each pair of sums,
// lanes 2, 3, 6, 7 are the even-tap group's, lanes 0, 1, 4, 5 the odd one's.
__attribute__((always_inline)) inline void ternary_groups(const v4d& a01, const v4d& a23, const v4d& a45, const v4d& b01,
                                                          const v4d& b23, const v4d& b45, v4d q[6]) {
  q[0] = __builtin_shufflevector(a01, b01, 2, 3, 6, 7), q[1] = __builtin_shufflevector(a01, b01, 0, 1, 4, 5);
  q[2] = __builtin_shufflevector(a23, b23, 2, 3, 6, 7), q[3] = __builtin_shufflevector(a23, b23, 0, 1, 4, 5);
  q[4] = __builtin_shufflevector(a45, b45, 2, 3, 6, 7), q[5] = __builtin_shufflevector(a45, b45, 0, 1, 4, 5);
}

// Outputs [m0, m0 + count) of the three bands; z holds the modulated node from index 3 m0 - 23.
// Two outputs at a time: lanes 0-1 output m, lanes 2-3 output m + 1.
__attribute__((target_clones("avx2", "default"))) void ternary_block(const Complex* z, const TernaryTaps& f,
                                                                     const TernaryTurns& turns, std::size_t m0,
                                                                     std::size_t count, Complex* const* out) {
  std::size_t j = 0;
  for (; j + 2 <= count; j += 2) {
    v4d s01a, s23a, s45a, s01b, s23b, s45b;
    ternary_sums(z, f, j, s01a, s23a, s45a);
    ternary_sums(z, f, j + 1, s01b, s23b, s45b);
    v4d q[6];
    ternary_groups(s01a, s23a, s45a, s01b, s23b, s45b, q);
    const std::size_t m = m0 + j;
    v4d o[3];
    ternary_outputs(q, turns, turns.out[m % 4], o);
    for (std::size_t k = 0; k < 3; ++k) __builtin_memcpy(reinterpret_cast<double*>(out[k] + m), &o[k], sizeof o[k]);
  }
  if (j < count) {  // an odd last output: the same arithmetic in the first lanes
    v4d s01, s23, s45;
    ternary_sums(z, f, j, s01, s23, s45);
    v4d q[6];
    ternary_groups(s01, s23, s45, s01, s23, s45, q);
    const std::size_t m = m0 + j;
    v4d o[3];
    ternary_outputs(q, turns, turns.out[m % 4], o);
    for (std::size_t k = 0; k < 3; ++k) out[k][m] = Complex(o[k][0], o[k][1]);
  }
}

// The raw sums of two samples (re, im, re', im') into lane accumulators: |c|^2 is formed in both
// lanes of its sample, so every product stays lane-wise.
struct MomentLanes {
  v4d sum, squares, cross, sum4, sum2c;  // c; (re^2, im^2); re im; |c|^4; |c|^2 c
};
struct MomentSums {
  MomentLanes lanes[2];  // two independent chains
  std::size_t count;
};

__attribute__((always_inline)) inline void accumulate_moments(const Complex* two, MomentLanes& m) {
  v4d x;
  __builtin_memcpy(&x, two, sizeof x);
  const v4d squares = x * x;
  const v4d norm = squares + __builtin_shufflevector(squares, squares, 1, 0, 3, 2);
  m.sum += x;
  m.squares += squares;
  m.cross += x * __builtin_shufflevector(x, x, 1, 0, 3, 2);
  m.sum4 += norm * norm;
  m.sum2c += norm * x;
}

// Adds n samples to the sums; a tail of fewer than four is padded with zeros, which add nothing
// to any sum. Compiled twice like the filters, same arithmetic.
__attribute__((target_clones("avx2", "default"))) void add_moments(const Complex* c, std::size_t n, MomentSums& s) {
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    accumulate_moments(c + i, s.lanes[0]);
    accumulate_moments(c + i + 2, s.lanes[1]);
  }
  if (i < n) {
    Complex rest[4] = {};
    for (std::size_t k = 0; i + k < n; ++k) rest[k] = c[i + k];
    accumulate_moments(rest, s.lanes[0]);
    accumulate_moments(rest + 2, s.lanes[1]);
  }
  s.count += n;
}

NodeMoments moments_of(const MomentSums& s) {
  const MomentLanes& l0 = s.lanes[0];
  const MomentLanes& l1 = s.lanes[1];
  const v4d sum = l0.sum + l1.sum, squares = l0.squares + l1.squares;
  const v4d cross = l0.cross + l1.cross, sum4 = l0.sum4 + l1.sum4, sum2c = l0.sum2c + l1.sum2c;
  NodeMoments m;
  m.count = s.count;
  m.sum = Complex(sum[0] + sum[2], sum[1] + sum[3]);
  const double re2 = squares[0] + squares[2], im2 = squares[1] + squares[3];
  m.sum2 = re2 + im2;
  m.sum_sq = Complex(re2 - im2, 2.0 * (cross[0] + cross[2]));
  m.sum4 = sum4[0] + sum4[2];
  m.sum2c = Complex(sum2c[0] + sum2c[2], sum2c[1] + sum2c[3]);
  return m;
}

// Where one node's split writes: the two binary halves (the high one already back at baseband,
// (-1)^(m+1)) and, when `third[0]` is set, the three ternary bands; with `sums`, the moments of
// the five bands after their trims (16, 15, 16, 16, 16 samples, as the reference).
struct SplitTargets {
  Complex* low = nullptr;
  Complex* high = nullptr;
  std::size_t half = 0;
  std::array<Complex*, 3> third{};
  std::size_t third_length = 0;
  std::array<MomentSums, 5>* sums = nullptr;
};

std::size_t band_trim(std::size_t band, std::size_t length) { return std::min<std::size_t>(band == 1 ? 15 : 16, length); }

// The moments of outputs [m0, m0 + count) of a band, from its trim on, while the block is in cache.
void add_block_moments(const SplitTargets& t, std::size_t band, const Complex* out, std::size_t length, std::size_t m0,
                       std::size_t count) {
  const std::size_t from = std::max(m0, band_trim(band, length));
  if (t.sums != nullptr && from < m0 + count) add_moments(out + from, m0 + count - from, (*t.sums)[band]);
}

// One pass over the node for both splits: chunks of 6 blocks' inputs feed 3 binary and 2 ternary
// blocks, so the node is read from memory once and every band's moments are taken from cache.
void split_node(std::span<const Complex> c, const SplitTargets& t) {
  static const BinaryTaps binary = binary_taps(firwin_lowpass(17, 0.4));
  static const BinaryTurns binary_rotations = binary_turns();
  static const TernaryTaps ternary = ternary_taps(firwin_lowpass(25, 0.4 * 2.0 / 3.0));
  static const TernaryTurns ternary_rotations = ternary_turns();
  std::array<Complex, 3 * kBlockOutputs + 23> scratch;
  for (std::size_t chunk = 0; 6 * kBlockOutputs * chunk < c.size(); ++chunk) {
    for (std::size_t m0 = 3 * kBlockOutputs * chunk; m0 < std::min(3 * kBlockOutputs * (chunk + 1), t.half);
         m0 += kBlockOutputs) {
      const std::size_t count = std::min(kBlockOutputs, t.half - m0);
      modulate(c, 2 * static_cast<std::ptrdiff_t>(m0) - 16, 2 * count + 16, eighth_turns(), scratch.data());
      binary_block(scratch.data(), binary, binary_rotations, m0, count, t.low, t.high);
      add_block_moments(t, 0, t.low, t.half, m0, count);
      add_block_moments(t, 1, t.high, t.half, m0, count);
    }
    if (t.third[0] == nullptr) continue;
    for (std::size_t m0 = 2 * kBlockOutputs * chunk; m0 < std::min(2 * kBlockOutputs * (chunk + 1), t.third_length);
         m0 += kBlockOutputs) {
      const std::size_t count = std::min(kBlockOutputs, t.third_length - m0);
      modulate(c, 3 * static_cast<std::ptrdiff_t>(m0) - 23, 3 * count + 23, twelfth_turns(), scratch.data());
      ternary_block(scratch.data(), ternary, ternary_rotations, m0, count, t.third.data());
      for (std::size_t k = 0; k < 3; ++k) add_block_moments(t, 2 + k, t.third[k], t.third_length, m0, count);
    }
  }
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

  evaluate(0, 0, 1, 1, true, root_, nullptr);
  visit(0, 0, root_, x.size());
}

void OneThirdBinaryFilterBank::evaluate(int row, int band, int band_count, int decimation, bool real,
                                        std::span<const Complex> trimmed, const NodeMoments* moments) {
  FilterBankNode node;
  node.row = row;
  node.level = filter_bank_row_level(row);
  node.band_index = band;
  node.band_count = band_count;
  node.decimation = decimation;
  node.real = real;
  node.samples = trimmed;
  if (criteria_.empty()) return;
  NodeMoments own;
  if (moments_read_ && moments == nullptr) {
    own = node_moments(trimmed);
    moments = &own;
  }
  node.moments = moments;
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

void OneThirdBinaryFilterBank::visit(int depth, int band, std::span<const Complex> node, std::size_t) {
  if (depth >= levels_) return;
  const auto child_depth = static_cast<std::size_t>(depth + 1);
  SplitTargets targets;
  targets.low = low_children_[child_depth].data();
  targets.high = high_children_[child_depth].data();
  targets.half = node.size() / 2;
  const bool ternary = depth <= levels_ - 2;
  if (ternary) {
    targets.third_length = node.size() / 3;
    for (std::size_t t = 0; t < 3; ++t) targets.third[t] = ternary_scratch_.data() + t * targets.third_length;
  }
  std::array<MomentSums, 5> sums{};
  if (moments_read_) targets.sums = &sums;
  split_node(node, targets);
  std::array<NodeMoments, 5> moments;
  for (std::size_t b = 0; b < 5; ++b) moments[b] = moments_of(sums[b]);
  const NodeMoments* given = moments_read_ ? moments.data() : nullptr;
  auto band_samples = [&](const Complex* out, std::size_t length, std::size_t b) {
    return std::span<const Complex>(out, length).subspan(band_trim(b, length));
  };
  const int row = 2 * depth + 1;
  for (std::size_t b = 0; b < 2; ++b)
    evaluate(row, 2 * band + static_cast<int>(b), 2 << depth, 2 << depth, false,
             band_samples(b == 0 ? targets.low : targets.high, targets.half, b), given ? given + b : nullptr);
  if (ternary)
    for (std::size_t t = 0; t < 3; ++t)
      evaluate(row + 1, 3 * band + static_cast<int>(t), 3 << depth, 3 << depth, false,
               band_samples(targets.third[t], targets.third_length, 2 + t), given ? given + 2 + t : nullptr);
  const std::span<const Complex> a(targets.low, targets.half), d(targets.high, targets.half);
  visit(depth + 1, 2 * band, a, targets.half);
  visit(depth + 1, 2 * band + 1, d, targets.half);
}

namespace {

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

NodeMoments node_moments(std::span<const Complex> c) {
  MomentSums sums{};
  add_moments(c.data(), c.size(), sums);
  return moments_of(sums);
}

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
