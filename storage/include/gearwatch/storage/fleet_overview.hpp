#pragma once
// The fleet page's reader (docs/fleet.md, "Fleet page"): per gearbox of the fleet database, what
// staff look at first — its status, its active alerts, each channel's newest wear verdict, the
// newest model run's remaining life, and a short trend of one indicator. One read-only transaction,
// so the page shows one moment of a database the consumer keeps writing. SQL in fleet_overview.cpp.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/storage/fleet_store.hpp"
#include "gearwatch/types/indicator.hpp"

namespace gearwatch::storage::fleet {

struct ActiveAlert {
  std::string kind, severity, subject, value, message, raised_at;
  std::optional<int> channel;
};

struct ChannelVerdict {
  int channel = 0;
  std::string mechanism, record_time;  ///< the newest wear verdict of the channel
};

/// Cycles left to one limit with the interval's near and far ends (docs/model.md); empty: beyond
/// the forecast's horizon, or no forecast.
struct RemainingLife {
  std::optional<double> limit, cycles_left, cycles_left_low, cycles_left_high;
};

struct TrendPoint {
  std::int64_t record_id = 0;
  std::optional<double> cycles;  ///< input revolutions at the record
  double value = 0;
};

/// Ids of a gearbox that did not arrive (docs/fleet.md, "Lost messages"): holes the consumer
/// still asks for, and ranges the daemon answered it cannot send.
struct UndeliveredMessages {
  std::int64_t missing = 0, missing_ranges = 0;  ///< holes below the newest id known sent, asked for again
  std::int64_t lost = 0, lost_ranges = 0;        ///< fleet.lost_ids: the ranges' ids not stored since
  std::vector<LostReason> lost_reasons;          ///< the distinct reasons of those ranges
};

struct GearboxOverview {
  std::string site, gearbox, state, version, last_seen;
  std::optional<std::string> last_record_time;
  std::vector<ActiveAlert> active_alerts;
  std::vector<ChannelVerdict> verdicts;
  // The newest model run (all empty without one).
  std::optional<double> cycles, wear_max_depth_m, pitting_mean;
  bool forecast_valid = false;
  RemainingLife wear, pitting;
  std::string forecast_failure;  ///< why the forecast is not valid, as published
  std::vector<TrendPoint> trend;  ///< oldest first
  UndeliveredMessages undelivered;
};

struct OverviewRequest {
  std::string trend_indicator = dsp::to_string(dsp::Indicator::ics2_low_band);  ///< any stored name (docs/dsp.md)
  int trend_channel = 0;
  int trend_points = 60;  ///< the newest this many records
};

/// Every gearbox the fleet database knows, in the database's order (site, name). Throws
/// FleetConnectionError when the server cannot be reached and FleetRefusedError when the database
/// holds no fleet schema or one of a newer gearwatch (fleet_store.hpp).
std::vector<GearboxOverview> load_fleet_overview(const std::string& connection, const OverviewRequest& request);

/// How late the fleet database is: its stored messages and the lag from each message's
/// record_time (when its gearbox stored it) to the consumer's transaction that stored it.
struct ArrivalLag {
  std::int64_t messages = 0;
  std::optional<double> p50_s, p99_s;
};
/// Empty when the database holds no fleet schema yet (a consumer has not started on it).
std::optional<ArrivalLag> load_arrival_lag(const std::string& connection);

}  // namespace gearwatch::storage::fleet
