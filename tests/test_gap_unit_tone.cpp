// The ghost form's unit tone as the measurement reduces it (unit_tone_spectra): the synthesis by a
// rotating phasor against a cosine evaluated a sample at a time, and the reduction shared between
// records that differ only in what it does not read (a speed a few parts in 1e9 apart); and its
// cells in closed form (UnitToneCells) against that reduction, cell by cell.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <thread>
#include <vector>

#include <catch2/catch.hpp>

#include "constant_speed_record.hpp"
#include "gearwatch/dsp/order_tracking.hpp"
#include "gearwatch/gap/describe.hpp"
#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/gap/unit_tone.hpp"

namespace test_gap_unit_tone {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using namespace gearwatch::gap;

namespace {

SpectralSummary unit_tone_like(double speed, std::size_t revs, double sample_rate) {
  SpectralSummary like;
  like.speed_hz = speed;
  like.input_revolutions = revs;
  like.sample_rate_hz = sample_rate;
  like.torque_nm = 20;
  return like;
}

/// The reference: the same record with std::cos a sample (the closed form), reduced alike.
SpectralSummary unit_tone_by_cosine(double order, double top_order, const SpectralSummary& like, double samples_per_cycle) {
  const double speed = like.speed_hz;
  const double fs = std::min(like.sample_rate_hz, samples_per_cycle * (top_order + 4) * speed);
  const Record r = test::constant_speed_record(fs, speed, static_cast<int>(like.input_revolutions), [&](double t) {
    return std::cos(2 * std::numbers::pi * order * speed * t);
  });
  return RecordSpectra(r, 0, GearPairSpec{}).summary();
}

/// The largest difference over every line and bin, over the largest of either.
double unit_tone_largest_difference(const SpectralSummary& a, const SpectralSummary& b) {
  double largest = 0, peak = 0;
  auto over = [&](const std::vector<double>& x, const std::vector<double>& y) {
    REQUIRE(x.size() == y.size());
    for (std::size_t k = 0; k < x.size(); ++k) largest = std::max(largest, std::abs(x[k] - y[k])), peak = std::max({peak, x[k], y[k]});
  };
  over(a.input_lines, b.input_lines);
  over(a.output_lines, b.output_lines);
  over(a.broadband, b.broadband);
  return largest / peak;
}

/// Every value within the closed form's bound on its difference from the resampled record (below);
/// `worst` the largest relative difference seen.
bool within_kernel_error(const std::vector<double>& a, const std::vector<double>& b, double& worst) {
  REQUIRE(a.size() == b.size());
  bool ok = true;
  for (std::size_t k = 0; k < a.size(); ++k) {
    const double p = std::max(a[k], b[k]), d = std::abs(a[k] - b[k]);
    ok = ok && d <= 2e-3 * std::sqrt(p) + 1e-6;
    if (p > 0) worst = std::max(worst, d / p);
  }
  return ok;
}

}  // namespace

TEST_CASE("gap unit tone: the phasor synthesis reduces as the cosine a sample does", "[gap_describe][unit_tone]") {
  // Orders off the lines, near one and high; below and at the record's own rate (the cap).
  for (const double order : {4.582, 2.0031, 37.75}) {
    for (const double rate : {50000.0, 2000.0}) {
      const SpectralSummary like = unit_tone_like(9.0, 19, rate);
      const double top = order + 3;
      const double d = unit_tone_largest_difference(RecordSpectra(unit_tone_record(order, top, like, 20), 0, GearPairSpec{}).summary(),
                                                    unit_tone_by_cosine(order, top, like, 20));
      INFO("order " << order << " rate " << rate);
      CHECK(d < 1e-7);  // a float sample's rounding (6e-8) is the scale
    }
  }
}

TEST_CASE("gap unit tone: the tone's angle samples in closed form reduce as the resampled record within the kernel's error",
          "[gap_describe][unit_tone]") {
  // The closed form differs from the resampler's samples by the kernel's pass-band error on the
  // tone, at most 1e-4 of its amplitude (order_tracking.hpp: the Kaiser sinc's ripple; the float
  // table and products add ~1e-6). A line is 2/spr times a revolution's sum, averaged: its complex
  // amplitude moves by at most 2e-4; a broadband half-order bin by at most 2/sqrt(1.5)·1e-4 < 2e-4,
  // its power (|b − mean|², two bins an order) by under 4·(2·2e-4)·sqrt(p) + 4·(4e-4)². Hence per value
  // |Δp| <= 2e-3·sqrt(p) + 1e-6, p the larger of the two.
  for (const double order : {4.582, 2.0031, 37.75, 0.63}) {
    for (const double rate : {50000.0, 2000.0}) {
      for (const std::size_t revs : {std::size_t{19}, std::size_t{26}}) {
        const SpectralSummary like = unit_tone_like(9.0, revs, rate);
        const double top = order + 3;
        const SpectralSummary fast = unit_tone_spectra(order, top, like, GearPairSpec{}, 20);
        const SpectralSummary resampled = RecordSpectra(unit_tone_record(order, top, like, 20), 0, GearPairSpec{}).summary();
        double worst = 0;
        INFO("order " << order << " rate " << rate << " revolutions " << revs);
        CHECK(within_kernel_error(fast.input_lines, resampled.input_lines, worst));
        CHECK(within_kernel_error(fast.output_lines, resampled.output_lines, worst));
        CHECK(within_kernel_error(fast.broadband, resampled.broadband, worst));
        CHECK(fast.input_revolutions == resampled.input_revolutions);
        CHECK(fast.output_revolutions == resampled.output_revolutions);
        WARN("largest relative difference " << worst);
      }
    }
  }
}

TEST_CASE("gap unit tone: a grid whose kernel reaches the record's end is resampled, within the kernel's error",
          "[gap_describe][unit_tone]") {
  // Ten input revolutions an output revolution: the output grid's kernel spans 171 input samples each
  // side, more than the half revolution (50 samples) after the last edge, which 20 input revolutions
  // make the output grid's end too.
  GearPairSpec gears;
  gears.pinion_teeth = 10, gears.gear_teeth = 100;
  const SpectralSummary like = unit_tone_like(9.0, 20, 900.0);
  const Record r = unit_tone_record(1.37, 1.0, like, 20);
  const SpectralSummary fast = RecordSpectra::of_tone(r, gears, 1.37).summary(), resampled = RecordSpectra(r, 0, gears).summary();
  // The input grid (17 samples each side) is the cosine's; the output grid is resampled.
  double worst = 0;
  CHECK(within_kernel_error(fast.input_lines, resampled.input_lines, worst));
  CHECK(within_kernel_error(fast.output_lines, resampled.output_lines, worst));
  CHECK(within_kernel_error(fast.broadband, resampled.broadband, worst));
  WARN("largest relative difference " << worst);
}

TEST_CASE("gap unit tone: records a few parts in 1e9 apart in speed reduce it alike", "[gap_describe][unit_tone]") {
  for (const double rate : {50000.0, 2000.0}) {  // uncapped: the same samples; capped: the rate fixed
    const SpectralSummary a = unit_tone_like(13.499999905770864, 26, rate), b = unit_tone_like(13.499999976479366, 26, rate);
    const double d = unit_tone_largest_difference(unit_tone_spectra(6.37, 12, a, GearPairSpec{}, 20),
                                                  unit_tone_spectra(6.37, 12, b, GearPairSpec{}, 20));
    INFO("rate " << rate);
    CHECK(d < 1e-6);
  }
}

TEST_CASE("gap spectra: a record reduced with the thread's planned transforms, windows and buffers equals one reduced afresh",
          "[gap_describe][unit_tone]") {
  // Two records of different lengths and rates (different transform sizes), each reduced on a new
  // thread (its plan cache empty: every plan made afresh, the Hann windows computed, the separation's
  // buffers allocated) and then twice on this one, between the other's reductions (the second time
  // from the cached plans and windows, in buffers the other record's reduction left longer or
  // shorter): every line and bin the same double.
  const auto tones = [](double speed) {
    return [speed](double t) {
      return std::cos(2 * std::numbers::pi * 25 * speed * t) + 0.3 * std::sin(2 * std::numbers::pi * 4.37 * speed * t) +
             0.01 * std::cos(2 * std::numbers::pi * 1234.5 * t);
    };
  };
  const Record a = test::constant_speed_record(20000.0, 13.5, 24, tones(13.5));
  const Record b = test::constant_speed_record(12800.0, 8.25, 17, tones(8.25));
  for (const Record* r : {&a, &b}) {
    SpectralSummary fresh;
    std::thread([&] { fresh = RecordSpectra(*r, 0, GearPairSpec{}).summary(); }).join();
    for (int round = 0; round < 2; ++round) {
      const SpectralSummary again = RecordSpectra(*r, 0, GearPairSpec{}).summary();
      (void)RecordSpectra(r == &a ? b : a, 0, GearPairSpec{}).summary();
      INFO("record " << (r == &a ? "a" : "b") << ", round " << round);
      REQUIRE(!fresh.input_lines.empty());
      CHECK(again.input_lines == fresh.input_lines);
      CHECK(again.output_lines == fresh.output_lines);
      CHECK(again.broadband == fresh.broadband);
      CHECK(again.input_line_averages == fresh.input_line_averages);
    }
  }
}

namespace {

struct Worst {
  double relative = 0;  // largest |Δp| / max(p, 1e-12) among cells above 1e-6
  double bound_used = 0;  // largest |Δp| / (2e-3·sqrt(p) + 1e-6)
};

/// Every cell up to `top` input orders (what the describer reads of a unit tone: its window's
/// cells lie below the top order it passes) within |Δp| <= 2e-3·sqrt(p) + 1e-6, p the larger.
template <class Cell>
bool cells_within(std::size_t count, const std::vector<double>& reduced, Cell cell, Worst& worst) {
  bool ok = true;
  for (std::size_t i = 0; i < count; ++i) {
    const double a = cell(i), b = i < reduced.size() ? reduced[i] : 0.0;
    const double p = std::max(a, b), d = std::abs(a - b), bound = 2e-3 * std::sqrt(p) + 1e-6;
    if (!(d <= bound)) {
      ok = false;
      UNSCOPED_INFO("cell " << i << ": closed form " << a << ", reduction " << b);
    }
    worst.bound_used = std::max(worst.bound_used, d / bound);
    if (p > 1e-6) worst.relative = std::max(worst.relative, d / p);
  }
  return ok;
}

}  // namespace

TEST_CASE("gap unit tone cells: the closed form equals the reduction within the kernel's error", "[gap_describe][unit_tone]") {
  // Tolerance, fixed before running: the closed form band-limits the output-only signal (tone less
  // the input average) exactly where the reduction resamples it with the Kaiser sinc, whose
  // pass-band ripple is at most 1e-4 of the amplitude (order_tracking.hpp; the float table and
  // products add ~1e-6); the broadband bins follow the output average's harmonics 64 half-order
  // bins each side, the rest adding under 1e-4 of the amplitude through the Hann kernel's 1/d³.
  // As in the test of the tone's angle samples (test_gap_unit_tone.cpp): a line's complex amplitude
  // moves by at most 2e-4 and a bin's by under 4e-4, so per cell |Δp| <= 2e-3·sqrt(p) + 1e-6.
  // Everything else (the input grid with the resampler's leading samples, the averages with their
  // tapers, the transforms, the output grids' leading samples) is the reduction's own arithmetic.
  const GearPairSpec gears{};
  for (const double order : {7.0, 38.02, 38.36, 400.7, 0.63, 12.91}) {
    for (const double rate : {100000.0, 20000.0}) {
      for (const auto& [speed, revs] : {std::pair{9.0, std::size_t{18}}, std::pair{13.5, std::size_t{27}}}) {
        const SpectralSummary like = unit_tone_like(speed, revs, rate);
        const double top = order + 3;
        const SpectralSummary reduced = unit_tone_spectra(order, top, like, gears, 20);
        const UnitToneCells cells(order, top, like, gears, 20);
        INFO("order " << order << ", rate " << rate << ", speed " << speed << ", revolutions " << revs);
        // The closed form throughout, except a tone in the coarse output grid's kernel transition
        // band (order 400.7 at 9 Hz and the 20 kHz cap: that grid's cutoff lies at 23/64 of its
        // Nyquist, 0.18·spr ≈ 399 orders), which the reduction itself follows. At 13.5 Hz the cap
        // puts the cutoff at 266 orders: the tone is above it and leaves that grid.
        CHECK(cells.exact() == !(order > 400 && rate < 50000 && speed < 10));
        const auto upto = static_cast<std::size_t>(std::ceil(top));
        const auto upto_out = static_cast<std::size_t>(std::ceil(top * gears.gear_teeth / gears.pinion_teeth));
        Worst worst;
        CHECK(cells_within(std::min(upto, reduced.input_lines.size()), reduced.input_lines, [&](std::size_t i) { return cells.input_line(i); }, worst));
        CHECK(cells_within(std::min(upto_out, reduced.output_lines.size()), reduced.output_lines, [&](std::size_t i) { return cells.output_line(i); }, worst));
        CHECK(cells_within(std::min(upto, reduced.broadband.size()), reduced.broadband, [&](std::size_t i) { return cells.broadband(i); }, worst));
        // Beyond the reduction's lines and bins: nothing.
        CHECK(cells.input_line(reduced.input_lines.size()) == 0.0);
        CHECK(cells.broadband(reduced.broadband.size()) == 0.0);
        WARN("order " << order << " rate " << rate << " revs " << revs << ": largest |dp|/p " << worst.relative
                      << ", largest share of the bound " << worst.bound_used);
      }
    }
  }
}

}  // namespace test_gap_unit_tone

namespace test_gap_uniform_angle {

using namespace gearwatch;

// The shaft separation's resampling of a signal sampled uniformly in input angle against the
// resampler with a tacho every spr samples, which it replaces: the same kernel at positions that
// differ only by the spline's rounding (under 1e-10 samples), so the outputs agree to 1e-9 of the
// signal's peak (fixed before running). Both the spr_out grid (spacing under 1, full band) and the
// output shaft's spr grid (spacing z2/z1 > 1, the kernel widened) are checked.
TEST_CASE("gap spectra: the output shaft's grid resampled from uniform angle samples equals the resampler's",
          "[gap_describe][unit_tone]") {
  const std::size_t spr = 1296, revs = 22;
  const double ratio = 52.0 / 19.0;
  std::vector<float> x(spr * revs);
  for (std::size_t j = 0; j < x.size(); ++j) {
    const double theta = static_cast<double>(j) / static_cast<double>(spr);
    x[j] = static_cast<float>(std::cos(2 * std::numbers::pi * 7.37 * theta) + 0.5 * std::sin(2 * std::numbers::pi * 131.2 * theta) +
                              0.25 * std::cos(2 * std::numbers::pi * 400.1 * theta));
  }
  std::vector<double> edges(revs + 1);
  for (std::size_t r = 0; r <= revs; ++r) edges[r] = static_cast<double>(r * spr);
  dsp::ShaftAngle grid;
  REQUIRE(grid.assign(edges, 1, 1.0).ok());
  const auto out_revs = static_cast<std::size_t>(std::floor(static_cast<double>(revs) / ratio));
  for (std::size_t per_rev : {std::size_t{3600}, spr}) {
    std::vector<double> direct(per_rev * out_revs), resampled(per_rev * out_revs);
    gap::resample_uniform_angle(x, spr, per_rev, out_revs, ratio, direct);
    dsp::AngularResampler resampler;
    resampler.resample(x, grid, per_rev, out_revs, resampled, ratio);
    double largest = 0;
    for (std::size_t j = 0; j < direct.size(); ++j) largest = std::max(largest, std::abs(direct[j] - resampled[j]));
    INFO("samples per revolution " << per_rev);
    CHECK(largest <= 1e-9 * 1.75);
  }
}

}  // namespace test_gap_uniform_angle
