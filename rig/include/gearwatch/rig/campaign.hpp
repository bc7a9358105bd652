#pragma once
// Wear campaigns for the rig simulator: the thesis's two endurance tests (Table 3.1) and a healthy
// reference, or a campaign file (docs/campaign-file.md); the records they produce, in cycle order;
// and the truth.json that records what was simulated (the daemon never reads it).
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "gearwatch/rig/effects.hpp"
#include "gearwatch/rig/rig_simulator.hpp"
#include "gearwatch/rig/wear_truth.hpp"

namespace gearwatch::rig {

/// A campaign file that cannot be used: the message names the file, the line and the key.
struct CampaignError : std::invalid_argument {
  explicit CampaignError(const std::string& what) : std::invalid_argument(what) {}
};

struct CampaignSpec {
  std::string name;
  double max_cycles = 0;                       ///< pinion cycles at the end of the test
  double stop_interval_cycles = 0;             ///< the rig stopped (and was measured) every this many cycles
  double torque_nm = 20;
  std::vector<double> measurement_speeds_hz;   ///< one record per speed at each measured stop
  int records = 20;                            ///< measured stops (compressed from the test's)
  double seconds = 10;
  double sample_rate_hz = 100000;
  int channels = 2;
  WearModelSettings wear;
  double pitting_gain_m_s2 = 0;                ///< sliding-vibration RMS per unit pitting density
  double roughness_gain_m_s2 = 0;              ///< sliding-vibration RMS per unit roughness index
  SlidingVibration bands;                      ///< carrier bands (its RMS fields are unused here)
  std::string effects = "none";                ///< "all", "none" or a list
  std::map<std::string, double> effect_values; ///< parameters fixed by the file ("effect.key")
};

/// "lubricated", "dry", "healthy"; throws CampaignError for another name.
CampaignSpec builtin_campaign(const std::string& name);
/// The built-in campaign's TOML text (what docs/campaign-file.md shows).
std::string builtin_campaign_text(const std::string& name);
/// Parses a campaign; `source` names it in errors. Unknown keys, wrong types and impossible values
/// are refused with the key and its line.
CampaignSpec parse_campaign(const std::string& toml_text, const std::string& source);
CampaignSpec load_campaign_file(const std::string& path);

struct PlannedRecord {
  int index = 0;
  double cycles = 0;
  double speed_hz = 0;
  std::string file_name;   ///< sorts in cycle order
};

/// The records in cycle order: `records` stops spread over the test's stops (multiples of the
/// stop interval from 0 to max_cycles, evenly picked; evenly spaced cycles when more records than
/// stops are asked), one record per measurement speed at each.
std::vector<PlannedRecord> plan_records(const CampaignSpec& spec);

/// Bytes one record's capture takes (protocol-v1 FD candump log), from its line lengths.
std::uint64_t estimated_capture_bytes(double seconds, double sample_rate_hz, int channels, double speed_hz);

/// What a record was made from.
struct RecordTruth {
  PlannedRecord plan;
  WearState wear;
  SlidingVibration sliding;
  std::uint64_t life_counter = 0;   ///< input revolutions at the record's first sample
};

/// truth.json: the campaign, the seed, the effects with their parameters, and per record its
/// cycles, life counter, wear state, coefficients and sliding-vibration strength.
std::string truth_json(const CampaignSpec& spec, const EffectSet& effects, std::uint64_t seed, bool seeded,
                       const std::vector<RecordTruth>& records, int pinion_teeth, int gear_teeth);

}  // namespace gearwatch::rig
