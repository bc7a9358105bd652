#pragma once
// The gap figure of each family between measured spectra and model spectra (the twin, or the twin
// with candidate effects): the RMS over the family's lines/bins of 10·log10 of the power ratio, and
// its share of the energy difference. With records at two or more speeds, the line-by-line ratios
// are first split into a part that follows the order (one value per line) and a part that stays
// in Hz (one value per Hz band): the Hz part is the fixed-frequency family, the order families
// are what remains.
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/types/gap_report.hpp"

namespace gearwatch::gap {

struct GapPair {
  const SpectralSummary* measured;
  const SpectralSummary* model;
  double floor;   ///< power added to both before the ratio: bins below it compare as equal
};

struct FixedBand {
  double low_hz = 0, high_hz = 0;
  double gain_db = 0;   ///< measured over model, the Hz-fixed part
};

struct GapEvaluation {
  std::array<double, kAllFamilyKinds.size()> sum_sq{}, count{}, energy{};
  std::array<bool, kAllFamilyKinds.size()> resolved{};
  std::vector<FixedBand> fixed_bands;
  double distance_db(std::size_t family) const { return count[family] > 0 ? std::sqrt(sum_sq[family] / count[family]) : 0.0; }
  double energy_share(std::size_t family) const;
};

/// The interval of a distance from its bootstrap draws: their central `coverage` spread about
/// their median, placed on the estimate, and never below 0 dB. A redrawn record averages fewer
/// distinct revolutions than the full one, so its noise-borne line power and hence its distance are
/// biased (up for lines near the floor, down for the broadband part); the draws' own percentiles
/// can then lie wholly on one side of the estimate they stand for. The spread is what the draws
/// tell; the centre is the estimate's. `draws` empty: the point.
Interval bootstrap_interval(std::vector<double> draws, double estimate, double coverage = 0.90);

class GapEvaluator {
 public:
  GapEvaluator(const GearPairSpec& gears, double bands_per_octave = 12, double min_speed_ratio = 1.05);
  /// decompose: split off the Hz-fixed part (only when the pairs cover ≥ 2 speeds; otherwise the
  /// fixed_frequency family is unresolved and the order families keep the whole ratio).
  GapEvaluation evaluate(const std::vector<GapPair>& pairs, bool decompose) const;
  /// "" when the pairs resolve the fixed-frequency family, else why not.
  std::string fixed_frequency_reason(const std::vector<GapPair>& pairs) const;

 private:
  /// One line or bin of one pair, as the evaluation compares it.
  struct Point {
    std::size_t key;     // line identity across records: shaft side and order
    double hz;
    double g;            // 10·log10 ratio
    double model;        // model power
    double measured;
    std::size_t family;
    double speed = 0;
    bool informative = false;  // above the floor in either spectrum: carries information on the ratio
    int band = -1;
  };
  void collect_points(const std::vector<GapPair>& pairs, std::size_t max_order, std::size_t keys_per_load,
                      std::vector<double>& loads) const;

  GearPairSpec gears_;
  double bands_per_octave_;
  double min_speed_ratio_;
  // Scratch reused from one evaluation to the next: a fit evaluates thousands of times, and a
  // fresh buffer of tens of thousands of points each time costs more in page faults than the
  // arithmetic. An evaluator is therefore used by one thread at a time.
  mutable std::vector<Point> points_;
  mutable std::vector<double> line_, line_n_;
};

}  // namespace gearwatch::gap
