#pragma once
// Description of the monitored gearbox (GearboxSpec): the gear pair, the sensors and how records
// are cut. "rig" in code is rig/, the truth simulator; the configuration keeps its [rig] table.
// Defaults are the thesis's UNSW spur rig (§3.2.1, Table 5.1; 52 teeth on the gear, see
// docs/config.md). Plain values; parsing lives in config/.
#include <cstdint>
#include <string>
#include <vector>

namespace gearwatch {

struct GearPairSpec {
  int pinion_teeth = 19;
  int gear_teeth = 52;
  double module_m = 2.0e-3;
  double pressure_angle_deg = 20.0;
  double face_width_m = 20.0e-3;
  double youngs_modulus_pa = 205.0e9;
  double poisson_ratio = 0.29;
  double density_kg_m3 = 7850.0;
  double addendum_coefficient = 1.0;
  double dedendum_coefficient = 1.25;
};

struct ChannelSpec {
  int number = 0;                     ///< protocol channel c (frame id base + c)
  std::string name = "casing_y";
  double scale_m_s2_per_lsb = 0.01;   ///< physical scaling of one i16 step
};

struct TachoSpec {
  int shaft = 0;                      ///< protocol shaft s (frame id base + s)
  std::string name = "input";
  int edges_per_rev = 1;
  /// Speed ratio of this shaft to the input (pinion) shaft: 1 for input, z1/z2 for output.
  double ratio_to_input = 1.0;
};

struct RecordSchedule {
  double length_s = 10.0;             ///< the thesis: 10 s records
  double interval_s = 600.0;          ///< one record every interval (start to start)
  double min_length_s = 2.0;          ///< a record cut at a dropout is analysed only if this long
};

struct GearboxSpec {
  GearPairSpec gears;
  double sample_rate_hz = 100000.0;
  std::vector<ChannelSpec> channels{ChannelSpec{0, "casing_y", 0.01}, ChannelSpec{1, "casing_x", 0.01}};
  std::vector<TachoSpec> tachos{TachoSpec{}};
  RecordSchedule schedule;
  double min_speed_hz = 0.5;          ///< records outside [min,max] input speed are not analysed
  double max_speed_hz = 60.0;

  double gear_ratio() const { return static_cast<double>(gears.gear_teeth) / gears.pinion_teeth; }
};

}  // namespace gearwatch
