// `gearwatch query alerts|active|indicators|health|updates|predictions|inspections|records|gaps|rejected --db FILE
//  [--since T] [--until T] [--channel C] [--name N] [--limit N] [--format table|csv|json]`.
#include <map>
#include <optional>

#include "cli_common.hpp"
#include "utc_time.hpp"

namespace gearwatch::cli {

namespace {

bool has_table(storage::Database& db, const std::string& name) {
  storage::Statement s(db, "SELECT 1 FROM sqlite_master WHERE name = ?");
  s.bind(1, name);
  return s.step();
}

bool has_column(storage::Database& db, const std::string& table, const std::string& column) {
  storage::Statement s(db, "SELECT 1 FROM pragma_table_info(?) WHERE name = ?");
  s.bind(1, table).bind(2, column);
  return s.step();
}

}  // namespace

void register_query(CLI::App& app) {
  struct Options {
    std::string what, db, since, until, format, name;
    std::optional<long long> limit;
    int channel = -1;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("query", "Staff queries on the database");
  cmd->add_option("what", opt->what, "alerts | active | indicators | health | updates | predictions | inspections | records | gaps | rejected")
      ->required()
      ->check(CLI::IsMember({"alerts", "active", "indicators", "health", "updates", "predictions", "inspections", "records", "gaps", "rejected"}));
  cmd->add_option("--db", opt->db, "SQLite database written by `run` or `replay`")->required();
  cmd->add_option("--since", opt->since, "Only rows at or after this UTC time (ISO 8601: 2026-11-01, 2026-11-01T08:00, 2026-11-01T08:00:30)");
  cmd->add_option("--until", opt->until, "Only rows before this UTC time (same forms as --since)");
  cmd->add_option("--channel", opt->channel, "alerts, active, indicators, gaps: only this channel")->check(CLI::Range(0, 255));
  cmd->add_option("--name", opt->name, "indicators: only this indicator name");
  cmd->add_option("--limit", opt->limit, "At most this many rows, the newest (1 or more)");
  add_format_option(cmd, opt->format);
  cmd->callback([opt] {
    // Checked before the database is opened: a malformed filter must never read as "no rows".
    const std::string since = opt->since.empty() ? "" : parse_utc_time(opt->since, "--since");
    const std::string until = opt->until.empty() ? "" : parse_utc_time(opt->until, "--until");
    if (opt->limit && *opt->limit < 1) throw CommandError("--limit " + std::to_string(*opt->limit) + ": give 1 or more rows");
    storage::Database db = open_history(opt->db);
    try {
      // What each query reads, and the column --since filters on.
      struct Source {
        const char* sql;
        const char* time_col;
        const char* channel_col = nullptr;  ///< nullptr: the rows are not per channel
      };
      static const std::map<std::string, Source> sources{
          {"alerts", {"SELECT id, created_at, severity, kind, channel, subject, transition, value, record_id, message FROM alerts", "created_at", "channel"}},
          {"active", {"SELECT kind, channel, subject, value, raised_at, updated_at FROM active_alerts", "updated_at", "channel"}},
          {"indicators",
           {"SELECT record_id, created_at, cycles, speed_hz, torque_nm, channel, name, value FROM indicators", "created_at", "channel"}},
          {"health", {"SELECT * FROM acquisition_health", "taken_at"}},
          {"inspections", {"SELECT id, entered_at, cycles, pitted_area_fraction, wear_depth_m, note FROM inspections", "entered_at"}},
          {"records", {"SELECT * FROM record_status", "created_at"}},
          {"gaps",
           {"SELECT g.id, g.detected_at, s.run_id, s.stream_id, g.channel, g.first_missing_index, g.missing_samples, g.cause"
            " FROM gap_events g JOIN streams s ON s.id = g.stream_key",
            "detected_at", "channel"}},
          {"rejected", {"SELECT id, received_at, run_id, kind, reason, frame FROM rejected_frames", "received_at"}},
          {"updates",
           {"SELECT id, created_at, gear_pair, cycles, kind, triggered_by, outcome, old_value, new_value, applies_from_cycles,"
            " iterations, measured, simulated_before, simulated_after, correlation_before, correlation_after, record_id, evidence"
            " FROM k_updates",
            "created_at"}},
          {"predictions",
           {"SELECT run_id, created_at, record_id, gear_pair, cycles, speed_hz, torque_nm, k_wear, k_pitting, rms_sa_measured,"
            " rms_sa_simulated, ics2_low, ics2_density_estimate, wear_mean_m, wear_max_m, pitting_mean, pitting_max, wear_limit_m,"
            " wear_cycles_left, wear_cycles_left_low, wear_cycles_left_high, pitting_limit, pitting_cycles_left,"
            " pitting_cycles_left_low, pitting_cycles_left_high, interval_coverage, forecast_flags, issues, detail, forecast_evidence"
            " FROM predictions",
            "created_at"}},
      };
      if ((opt->what == "updates" && !has_table(db, "k_updates")) || (opt->what == "predictions" && !has_table(db, "predictions")))
        throw CommandError("this database has no " + std::string(opt->what == "updates" ? "k_updates" : "predictions") +
                           " view yet: it was written by an older gearwatch (schema before version 4); open it once with this one");
      const Source& source = sources.at(opt->what);
      std::string sql = source.sql;
      if (opt->what == "predictions" && !has_column(db, "predictions", "interval_coverage"))
        throw CommandError("this database's predictions view has no interval coverage yet: it was written by an older gearwatch"
                           " (schema before version 8); open it once with this one");
      const std::string time_col = source.time_col;
      std::vector<std::string> bind;
      std::vector<std::string> where;
      if (!since.empty()) {
        where.push_back(time_col + " >= ?");
        bind.push_back(since);
      }
      if (!until.empty()) {
        where.push_back(time_col + " < ?");
        bind.push_back(until);
      }
      if (opt->channel >= 0) {
        if (!source.channel_col) throw CommandError("--channel applies to alerts, active, indicators and gaps only");
        where.push_back(std::string(source.channel_col) + " = " + std::to_string(opt->channel));
      }
      if (!opt->name.empty()) {
        if (opt->what != "indicators") throw CommandError("--name applies to `query indicators` only");
        where.push_back("name = ?");
        bind.push_back(opt->name);
      }
      for (std::size_t i = 0; i < where.size(); ++i) sql += (i ? " AND " : " WHERE ") + where[i];
      if (opt->limit) sql = "SELECT * FROM (" + sql + " ORDER BY " + time_col + " DESC LIMIT " + std::to_string(*opt->limit) + ") ORDER BY " + time_col;
      print_query(db, sql, bind, opt->format);
    } catch (const storage::SqliteError& e) {
      throw CommandError(e.what());
    }
  });
}

}  // namespace gearwatch::cli
