#pragma once
// The gear pair's wear state as the blue loop (wear/wear_loop.hpp) leaves it and its summary:
// plain values, stored with the model's runs and the gap diagnosis's kept records.
#include <vector>

namespace gearwatch::wear {

/// The wear state of the pair (every tooth alike), root → tip at uniform profile fractions.
struct WearState {
  double cycles = 0;                    ///< pinion revolutions
  std::vector<double> pinion_depth_m;
  std::vector<double> gear_depth_m;
  std::vector<double> pinion_pitting;   ///< pitting density D per pinion profile point, in [0, 1]
};

/// Mean depths and the pinion's share (the thesis reports about 73 %), mean pitting density.
struct WearSummary {
  double cycles = 0;
  double pinion_mean_depth_m = 0;
  double gear_mean_depth_m = 0;
  double combined_mean_depth_m = 0;     ///< pinion + gear: the mean profile change the mesh sees
  double pinion_share = 0;              ///< pinion / combined
  double mean_pitting_density = 0;      ///< over the pinion's active profile
  double max_pitting_density = 0;
  double max_pitting_fraction = 0;      ///< profile fraction (0 root .. 1 tip) of the maximum
};

}  // namespace gearwatch::wear
