#pragma once
// The state of a simulated gear pair's flanks at a cycle count, and the interface every wear truth
// gives it through (wear_truth.hpp: the linear and Archard laws; wear_truth_forms.hpp: the other
// forms). Kept apart so a truth's own code needs nothing but this and the twin's geometry.
#include "gearwatch/twin/transmission_error.hpp"

namespace gearwatch::rig {

struct WearState {
  double cycles = 0;                        ///< pinion (input) revolutions since installation
  twin::ToothProfileDeviation profile;      ///< mean wear depth root → tip (uniform over the teeth), m
  double mean_wear_depth_m = 0;             ///< mean over the pinion's active profile
  double combined_mean_wear_depth_m = 0;    ///< pinion + gear mean: what the twin's model reports as its mean
  double pitting_density = 0;               ///< pitted fraction of the active flank area, 0..1
  double roughness = 0;                     ///< abrasion roughness index (1 = a sandpaper-roughened flank)
  double k_wear = 0;                        ///< wear coefficient in force at this cycle count
  double k_pitting = 0;                     ///< pitting coefficient in force at this cycle count
};

class WearTruth {
 public:
  virtual ~WearTruth() = default;
  virtual WearState at(double cycles) const = 0;
};

}  // namespace gearwatch::rig
