#pragma once
// Test helper: the power of whole input orders of a record at a constant, known speed, by a
// plain DFT over whole revolutions (no order tracking), for checking simulated records.
#include <cmath>
#include <complex>
#include <cstddef>
#include <numbers>
#include <ostream>
#include <vector>

#include <catch2/catch.hpp>

namespace gearwatch::test {

/// Peak-amplitude² of orders 1..max_order over `revolutions` revolutions of `samples_per_rev`
/// samples (an integer at the record's speed), from the first sample.
template <class V>
std::vector<double> order_line_power(const V& x, std::size_t samples_per_rev, std::size_t revolutions, int max_order) {
  const std::size_t n = samples_per_rev * revolutions;
  std::vector<double> power(static_cast<std::size_t>(max_order), 0.0);
  for (int k = 1; k <= max_order; ++k) {
    const double w = 2.0 * std::numbers::pi * k / static_cast<double>(samples_per_rev);
    std::complex<double> s = 0, rotor = 1, step = std::polar(1.0, -w);
    for (std::size_t i = 0; i < n; ++i) {
      s += static_cast<double>(x[i]) * rotor;
      rotor *= step;
      if (i % 4096 == 4095) rotor = std::polar(1.0, -w * static_cast<double>(i + 1));  // keep |rotor| = 1
    }
    power[static_cast<std::size_t>(k - 1)] = std::norm(2.0 * s / static_cast<double>(n));
  }
  return power;
}

/// Σ of the orders that are neither a mesh harmonic nor one of its first sidebands.
inline double shaft_order_power(const std::vector<double>& power, int teeth) {
  double sum = 0;
  for (std::size_t i = 0; i < power.size(); ++i) {
    const int k = static_cast<int>(i) + 1, r = k % teeth;
    if (r != 0 && r != 1 && r != teeth - 1) sum += power[i];
  }
  return sum;
}

/// Σ of the mesh harmonics' first sidebands (orders n·teeth ± 1) over the first mesh harmonic's line, dB.
inline double first_sideband_db_re_mesh(const std::vector<double>& power, int teeth) {
  double sum = 0;
  for (std::size_t i = 0; i < power.size(); ++i) {
    const int r = (static_cast<int>(i) + 1) % teeth;
    if (r == 1 || r == teeth - 1) sum += power[i];
  }
  return 10.0 * std::log10(sum / power[static_cast<std::size_t>(teeth - 1)]);
}

/// shaft_order_power over the first mesh harmonic's line, dB.
inline double shaft_order_db_re_mesh(const std::vector<double>& power, int teeth) {
  return 10.0 * std::log10(shaft_order_power(power, teeth) / power[static_cast<std::size_t>(teeth - 1)]);
}

/// One figure (dB re the first mesh harmonic, e.g. first_sideband_db_re_mesh) of the three records
/// a front-end test compares: read at 4×, by the automatic factor, and at a reference factor.
struct FrontEndFigure {
  double four, automatic, reference;
};
template <class Figure>
FrontEndFigure front_end_figure(Figure figure, const std::vector<double>& four, const std::vector<double>& automatic,
                                const std::vector<double>& reference, int teeth) {
  return {figure(four, teeth), figure(automatic, teeth), figure(reference, teeth)};
}
inline std::ostream& operator<<(std::ostream& o, const FrontEndFigure& f) {
  return o << "4x " << f.four << " dB, automatic " << f.automatic << " dB, reference " << f.reference << " dB";
}

/// A perfect pair's order lines read at 4×, by the automatic factor (0) and at `reference_factor`
/// (`lines(factor)` gives them), with their first sidebands' and shaft orders' figures.
struct FrontEndComparison {
  std::vector<double> four, automatic, reference;
  FrontEndFigure sidebands, shaft;
};
template <class Lines>
FrontEndComparison compare_front_ends(Lines lines, int reference_factor, int teeth) {
  FrontEndComparison c{lines(4), lines(0), lines(reference_factor), {}, {}};
  c.sidebands = front_end_figure(first_sideband_db_re_mesh, c.four, c.automatic, c.reference, teeth);
  c.shaft = front_end_figure(shaft_order_db_re_mesh, c.four, c.automatic, c.reference, teeth);
  return c;
}
inline std::ostream& operator<<(std::ostream& o, const FrontEndComparison& c) {
  return o << "first sidebands re the first mesh harmonic: " << c.sidebands << "; shaft orders: " << c.shaft;
}

/// What a 20 kHz record of a perfect pair must show (8 Hz, 2 500 samples a revolution): read at 4×
/// (80 kHz) the mesh's lines fold onto the first sidebands (above −40 dB) and the shaft orders
/// (above −20 dB); the automatic front-end keeps the sidebands below −60 dB and the first two mesh
/// harmonics (orders 19 and 38) at the reference's level within 0.01 dB. Each caller adds its own
/// measured bounds on the shaft orders.
inline void check_front_end_folding_at_20_khz(const FrontEndComparison& c) {
  CHECK(c.sidebands.four > -40.0);
  CHECK(c.shaft.four > -20.0);
  CHECK(c.sidebands.automatic < -60.0);
  for (int k : {19, 38}) CHECK(10 * std::log10(c.automatic[k - 1] / c.reference[k - 1]) == Approx(0).margin(0.01));
}

}  // namespace gearwatch::test
