// A unit tone's cells in closed form (UnitToneCells) against the reduction of its record
// (unit_tone_spectra), cell by cell.
#include <algorithm>
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include "gearwatch/gap/describe.hpp"
#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/gap/unit_tone.hpp"

namespace test_gap_unit_tone_cells {

using namespace gearwatch;
using namespace gearwatch::gap;

namespace {

SpectralSummary like_record(double speed, std::size_t revs, double sample_rate) {
  SpectralSummary like;
  like.speed_hz = speed;
  like.input_revolutions = revs;
  like.sample_rate_hz = sample_rate;
  like.torque_nm = 20;
  return like;
}

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
        const SpectralSummary like = like_record(speed, revs, rate);
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

}  // namespace test_gap_unit_tone_cells
