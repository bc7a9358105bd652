#pragma once
// The fleet page (docs/fleet.md, "Fleet page"): every gearbox of the fleet database on one
// self-contained HTML page (inline CSS and SVG, no scripts, no network) — its status, each
// channel's wear verdict, its active alerts, its remaining life and a small trend — worst first.
#include <string>
#include <tuple>
#include <vector>

#include "gearwatch/storage/fleet_overview.hpp"

namespace gearwatch::report {

struct FleetPageData {
  std::string database;      ///< the connection as shown (no password)
  std::string generated_at;  ///< ISO 8601 UTC
  storage::fleet::OverviewRequest trend;
  std::vector<storage::fleet::GearboxOverview> gearboxes;
};

/// How urgent a gearbox is, compared field by field (smaller = worse, listed first): the most
/// severe active alert (an info alert counts as none), whether a wear verdict names a mechanism,
/// the shortest remaining life of a valid forecast, whether it is offline.
struct FleetUrgency {
  int alert_rank = 2;           ///< 0 alarm, 1 warning, 2 otherwise
  int verdict_rank = 1;         ///< 0: a channel's verdict names a wear mechanism
  double shortest_life = 1e300; ///< the fewest cycles left to any limit (none: 1e300)
  int offline_rank = 1;         ///< 0: offline
  auto key() const { return std::tuple(alert_rank, verdict_rank, shortest_life, offline_rank); }
};
FleetUrgency urgency_of(const storage::fleet::GearboxOverview& g);

/// The gearboxes worst first (ties in the database's site/name order).
std::vector<storage::fleet::GearboxOverview> worst_first(std::vector<storage::fleet::GearboxOverview> gearboxes);

/// A number of cycles as staff read it: 1234 → "1234", 2.35e6 → "2.35 M".
std::string format_cycles(double cycles);

std::string render_fleet_page_html(const FleetPageData& data);

}  // namespace gearwatch::report
