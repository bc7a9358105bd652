#pragma once
// Wear campaigns for the rig simulator: the thesis's two endurance tests (Table 3.1) and a healthy
// reference, or a campaign file (docs/campaign-file.md); the records they produce, in cycle order;
// and the truth.json that records what was simulated (the daemon never reads it).
#include <array>
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

/// The two families random_campaign() draws from.
enum class CampaignRegime { lubricated_like, dry_like };
const char* to_string(CampaignRegime regime);

/// What random_campaign() drew besides the settings themselves: the targets its derived values
/// (k0, η, the pit sites) were solved for.
struct RandomCampaignDraw {
  bool drawn = false;                  ///< false: not a random campaign
  std::uint64_t seed = 0;
  CampaignRegime regime = CampaignRegime::lubricated_like;
  double final_depth_target_um = 0;    ///< combined mean wear depth at max_cycles (k0 is scaled to it)
  double final_density_target = 0;     ///< pitting density at max_cycles (η is solved for it; 0: no pitting)
  double pit_site_oversupply = 0;      ///< sites = ceil(oversupply · density target · area / a_max)
  double pit_growth_cycles = 0;        ///< cycles a pit takes from a0 to a_max before contamination
};

struct CampaignSpec {
  std::string name;
  double max_cycles = 0;                       ///< pinion cycles at the end of the test
  double stop_interval_cycles = 0;             ///< the rig stopped (and was measured) every this many cycles
  double torque_nm = 20;                       ///< motor torque (until the load change, if any)
  double load_change_cycles = -1;              ///< the torque becomes torque_after_nm here (< 0: never)
  double torque_after_nm = 20;
  std::vector<double> measurement_speeds_hz;   ///< one record per speed at each measured stop
  int records = 20;                            ///< measured stops (compressed from the test's)
  double seconds = 10;
  double sample_rate_hz = 100000;
  int channels = 2;
  /// The rig's integration rate (sub-steps per sample: ceil(this / sample rate)). Its fixed steps
  /// leave an error pattern drifting at frac(step rate / f_mesh)·f_mesh about the mesh harmonics;
  /// where those harmonics are strong (fast pairs) a finer rate keeps it out of the residual.
  double integration_rate_hz = kDefaultIntegrationRateHz;
  WearModelSettings wear;
  double pitting_gain_m_s2 = 0;                ///< sliding-vibration RMS per unit pitting density
  double roughness_gain_m_s2 = 0;              ///< sliding-vibration RMS per unit roughness index
  SlidingVibration bands;                      ///< carrier bands (its RMS fields are unused here)
  std::string effects = "none";                ///< "all", "none" or a list
  std::map<std::string, double> effect_values; ///< parameters fixed by the file ("effect.key")
  RandomCampaignDraw random;                   ///< set by random_campaign()

  TorqueSchedule torque_schedule() const { return {torque_nm, load_change_cycles, torque_after_nm}; }
};

/// The built-in campaigns: the thesis's two endurance tests and a healthy reference.
enum class BuiltinCampaign : std::uint8_t { lubricated, dry, healthy };
inline constexpr std::array kAllBuiltinCampaigns{BuiltinCampaign::lubricated, BuiltinCampaign::dry, BuiltinCampaign::healthy};
/// Its name ("lubricated", "dry", "healthy"), as the command line and campaign.name say it.
const char* to_string(BuiltinCampaign campaign) noexcept;

CampaignSpec builtin_campaign(BuiltinCampaign campaign);
/// The built-in campaign's TOML text (what docs/campaign-file.md shows).
std::string builtin_campaign_text(BuiltinCampaign campaign);
/// The same by name; throws CampaignError for a name that is not built in.
CampaignSpec builtin_campaign(const std::string& name);
std::string builtin_campaign_text(const std::string& name);
/// Parses a campaign; `source` names it in errors. Unknown keys, wrong types and impossible values
/// are refused with the key and its line.
CampaignSpec parse_campaign(const std::string& toml_text, const std::string& source);
CampaignSpec load_campaign_file(const std::string& path);

/// A campaign drawn from `seed` over the truth forms of wear_truth_forms.hpp (docs/rig-simulator.md,
/// "Random campaigns": the draws and their ranges): lubricated-like or dry-like, regime-dependent
/// or constant K, Weibull pitting (lubricated-like), an optional contamination, an optional load
/// change. name = "random-<seed>"; the same seed gives the same campaign. The derived values (k0,
/// η, the number of pit sites) are solved on the default gear pair (twin::GearboxParameters{}).
CampaignSpec random_campaign(std::uint64_t seed);

struct PlannedRecord {
  int index = 0;
  double cycles = 0;
  double speed_hz = 0;
  double torque_nm = 0;    ///< the campaign's torque at this record's cycles (the record runs and is written at it)
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

/// The effects of a campaign: its list, parameters drawn from `seed` when `seeded`, then the
/// campaign's fixed values (what `simulate --campaign` uses).
EffectSet campaign_effects(const CampaignSpec& spec, bool seeded, std::uint64_t seed);
/// What record `plan` is made from: the wear state, the sliding vibration at the campaign's gains,
/// the life counter.
RecordTruth record_truth(const CampaignSpec& spec, const PlannedRecord& plan, const WearState& wear);
/// The rig run of record `plan` (its speed and torque, the campaign's length, rate and channels;
/// noise seed derived from `seed` and the record's index), as `simulate --campaign` runs it.
RigRunSettings record_run_settings(const CampaignSpec& spec, const PlannedRecord& plan, std::uint64_t seed);

/// truth.json: the campaign, the seed, the effects with their parameters, and per record its
/// cycles, life counter, wear state, coefficients and sliding-vibration strength.
std::string truth_json(const CampaignSpec& spec, const EffectSet& effects, std::uint64_t seed, bool seeded,
                       const std::vector<RecordTruth>& records, int pinion_teeth, int gear_teeth);

}  // namespace gearwatch::rig
