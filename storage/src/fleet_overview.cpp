// The fleet page's reader (fleet_overview.hpp): one read-only transaction over the fleet schema.
#include "gearwatch/storage/fleet_overview.hpp"

#include <map>
#include <memory>

#include <pqxx/pqxx>

#include "fleet_errors.hpp"

namespace gearwatch::storage::fleet {

namespace {

// Times as the local database writes them: ISO 8601 UTC to the second.
std::string iso(const std::string& column) {
  return "to_char(" + column + R"( AT TIME ZONE 'UTC', 'YYYY-MM-DD"T"HH24:MI:SS"Z"'))";
}

template <class T>
std::optional<T> optional_of(const pqxx::field& f) {
  if (f.is_null()) return std::nullopt;
  return f.as<T>();
}

void check_schema(pqxx::transaction_base& t) {
  if (t.exec("SELECT to_regclass('fleet.schema_version')")[0][0].is_null())
    throw FleetRefusedError("fleet database: it holds no fleet schema (`gearwatch fleet ingest` creates it)");
  const auto r = t.exec("SELECT version FROM fleet.schema_version");
  const int found = r.empty() ? 0 : r[0][0].as<int>();
  if (found > current_fleet_schema_version())
    throw FleetRefusedError("fleet database: schema version " + std::to_string(found) + " is newer than this gearwatch's (" +
                            std::to_string(current_fleet_schema_version()) + "); use a newer gearwatch");
  if (found < current_fleet_schema_version())
    throw FleetRefusedError("fleet database: schema version " + std::to_string(found) +
                            " is older than this gearwatch's; start `gearwatch fleet ingest` on it once to migrate it");
}

std::map<std::int64_t, GearboxOverview> read_gearboxes(pqxx::transaction_base& t, std::vector<std::int64_t>& order) {
  std::map<std::int64_t, GearboxOverview> out;
  const auto rows = t.exec("SELECT g.id, g.site, g.name, coalesce(g.state, ''), coalesce(g.version, ''), " + iso("g.last_seen") + ", " +
                           "(SELECT " + iso("max(r.record_time)") + " FROM fleet.records r WHERE r.gearbox_id = g.id) "
                           "FROM fleet.gearboxes g ORDER BY g.site, g.name");
  for (const auto& row : rows) {
    GearboxOverview g;
    g.site = row[1].c_str();
    g.gearbox = row[2].c_str();
    g.state = row[3].c_str();
    g.version = row[4].c_str();
    g.last_seen = row[5].c_str();
    g.last_record_time = optional_of<std::string>(row[6]);
    const auto id = row[0].as<std::int64_t>();
    order.push_back(id);
    out.emplace(id, std::move(g));
  }
  return out;
}

void read_active_alerts(pqxx::transaction_base& t, std::map<std::int64_t, GearboxOverview>& boxes) {
  const auto rows = t.exec("SELECT gearbox_id, kind, severity, subject, value, message, " + iso("since") +
                           ", CASE WHEN channel < 0 THEN NULL ELSE channel END "
                           "FROM fleet.alert_state WHERE active ORDER BY gearbox_id, since, kind, channel, subject");
  for (const auto& row : rows) {
    ActiveAlert a{row[1].c_str(), row[2].c_str(), row[3].c_str(), row[4].c_str(), row[5].c_str(), row[6].c_str(),
                  optional_of<int>(row[7])};
    boxes.at(row[0].as<std::int64_t>()).active_alerts.push_back(std::move(a));
  }
}

void read_verdicts(pqxx::transaction_base& t, std::map<std::int64_t, GearboxOverview>& boxes) {
  const auto rows = t.exec("SELECT DISTINCT ON (v.gearbox_id, v.channel) v.gearbox_id, v.channel, v.mechanism, " + iso("m.record_time") +
                           " FROM fleet.wear_verdicts v JOIN fleet.messages m USING (gearbox_id, message_id) "
                           "ORDER BY v.gearbox_id, v.channel, v.message_id DESC");
  for (const auto& row : rows)
    boxes.at(row[0].as<std::int64_t>()).verdicts.push_back({row[1].as<int>(), row[2].c_str(), row[3].c_str()});
}

RemainingLife life_of(const pqxx::row& row, int first) {
  return {optional_of<double>(row[first]), optional_of<double>(row[first + 1]), optional_of<double>(row[first + 2]),
          optional_of<double>(row[first + 3])};
}

void read_models(pqxx::transaction_base& t, std::map<std::int64_t, GearboxOverview>& boxes) {
  const auto life = [](const char* mode) {
    const std::string m = std::string("(forecast->'") + mode + "'->>'";
    return m + "limit')::float8, " + m + "cycles_left')::float8, " + m + "cycles_left_low')::float8, " + m + "cycles_left_high')::float8";
  };
  const auto rows = t.exec("SELECT DISTINCT ON (gearbox_id) gearbox_id, cycles, wear_max_depth_m, pitting_mean, "
                           "coalesce((forecast->>'valid')::boolean, false), coalesce(forecast->>'failure', ''), " +
                           life("wear") + ", " + life("pitting") +
                           " FROM fleet.model_states WHERE advanced ORDER BY gearbox_id, model_run_id DESC");
  for (const auto& row : rows) {
    auto& g = boxes.at(row[0].as<std::int64_t>());
    g.cycles = optional_of<double>(row[1]);
    g.wear_max_depth_m = optional_of<double>(row[2]);
    g.pitting_mean = optional_of<double>(row[3]);
    g.forecast_valid = row[4].as<bool>();
    g.forecast_failure = row[5].c_str();
    g.wear = life_of(row, 6);
    g.pitting = life_of(row, 10);
  }
}

void read_trends(pqxx::transaction_base& t, const OverviewRequest& q, std::map<std::int64_t, GearboxOverview>& boxes) {
  const auto rows = t.exec_params(
      "SELECT gearbox_id, record_id, input_revolutions, value FROM ("
      "  SELECT v.gearbox_id, v.record_id, r.input_revolutions, v.value,"
      "         row_number() OVER (PARTITION BY v.gearbox_id ORDER BY v.record_id DESC) AS newest"
      "  FROM fleet.indicator_values v JOIN fleet.records r USING (gearbox_id, record_id)"
      "  WHERE v.name = $1 AND v.channel = $2 AND v.value IS NOT NULL) n "
      "WHERE newest <= $3 ORDER BY gearbox_id, record_id",
      q.trend_indicator, q.trend_channel, q.trend_points);
  for (const auto& row : rows)
    boxes.at(row[0].as<std::int64_t>()).trend.push_back({row[1].as<std::int64_t>(), optional_of<double>(row[2]), row[3].as<double>()});
}

void read_lost(pqxx::transaction_base& t, std::map<std::int64_t, GearboxOverview>& boxes) {
  const auto rows = t.exec("SELECT gearbox_id, reason, count(*), sum(missing) FROM fleet.lost_ids WHERE missing > 0 "
                           "GROUP BY gearbox_id, reason ORDER BY gearbox_id, reason");
  for (const auto& row : rows) {
    auto& u = boxes.at(row[0].as<std::int64_t>()).undelivered;
    u.lost_ranges += row[2].as<std::int64_t>();
    u.lost += row[3].as<std::int64_t>();
    if (const auto reason = parse_lost_reason(row[1].c_str())) u.lost_reasons.push_back(*reason);
  }
}

// The holes by name: the reader keys gearboxes by id, the holes name site and gearbox.
void read_missing(pqxx::transaction_base& t, std::map<std::int64_t, GearboxOverview>& boxes) {
  const auto holes = detail::read_holes(t);
  for (auto& [id, g] : boxes)
    for (const auto& h : holes)
      if (h.site == g.site && h.gearbox == g.gearbox) {
        ++g.undelivered.missing_ranges;
        g.undelivered.missing += h.to - h.from + 1;
      }
}

}  // namespace

std::vector<GearboxOverview> load_fleet_overview(const std::string& connection, const OverviewRequest& request) {
  const auto c = detail::connect(connection);
  return detail::translated([&] {
    pqxx::transaction<pqxx::isolation_level::repeatable_read, pqxx::readwrite_policy::read_only> t(*c);
    check_schema(t);
    std::vector<std::int64_t> order;
    auto boxes = read_gearboxes(t, order);
    read_active_alerts(t, boxes);
    read_verdicts(t, boxes);
    read_models(t, boxes);
    read_trends(t, request, boxes);
    read_lost(t, boxes);
    read_missing(t, boxes);
    std::vector<GearboxOverview> out;
    for (const auto id : order) out.push_back(std::move(boxes.at(id)));
    return out;
  });
}

std::optional<ArrivalLag> load_arrival_lag(const std::string& connection) {
  const auto c = detail::connect(connection);
  return detail::translated([&]() -> std::optional<ArrivalLag> {
    pqxx::read_transaction t(*c);
    if (t.exec("SELECT to_regclass('fleet.messages')")[0][0].is_null()) return std::nullopt;
    const auto r = t.exec(
        "SELECT count(*), percentile_cont(0.5) WITHIN GROUP (ORDER BY extract(epoch FROM received_at - record_time)), "
        "percentile_cont(0.99) WITHIN GROUP (ORDER BY extract(epoch FROM received_at - record_time)) FROM fleet.messages");
    return ArrivalLag{r[0][0].as<std::int64_t>(), optional_of<double>(r[0][1]), optional_of<double>(r[0][2])};
  });
}

}  // namespace gearwatch::storage::fleet
