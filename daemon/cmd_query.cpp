// `gearwatch query alerts|active|indicators|health|updates|predictions|inspections|records|gaps|rejected --db FILE
//  [--since T] [--until T] [--channel C] [--name N] [--limit N] [--format table|csv|json]`.
#include <optional>
#include <string>
#include <vector>

#include "cli_common.hpp"
#include "gearwatch/storage/staff_queries.hpp"
#include "utc_time.hpp"

namespace gearwatch::cli {

namespace {

// The views' words through their one to_string, in the order the help lists them.
std::vector<std::string> view_words() {
  std::vector<std::string> words;
  for (auto v : storage::kAllQueryViews) words.emplace_back(storage::to_string(v));
  return words;
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
      ->check(CLI::IsMember(view_words()));
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
      const storage::QueryView view = *storage::parse_query_view(opt->what);  // CLI::IsMember let only views in
      switch (storage::query_view_availability(db, view)) {
        case storage::QueryViewAvailability::available: break;
        case storage::QueryViewAvailability::needs_schema_4:
          throw CommandError("this database has no " + std::string(view == storage::QueryView::updates ? "k_updates" : "predictions") +
                             " view yet: it was written by an older gearwatch (schema before version 4); open it once with this one");
        case storage::QueryViewAvailability::needs_schema_8:
          throw CommandError("this database's predictions view has no interval coverage yet: it was written by an older gearwatch"
                             " (schema before version 8); open it once with this one");
      }
      storage::QueryFilter filter{since, until, std::nullopt, opt->name, opt->limit};
      if (opt->channel >= 0) {
        if (!storage::has_channel(view)) throw CommandError("--channel applies to alerts, active, indicators and gaps only");
        filter.channel = opt->channel;
      }
      if (!opt->name.empty() && view != storage::QueryView::indicators) throw CommandError("--name applies to `query indicators` only");
      print_table(storage::query_view(db, view, filter), opt->format);
    } catch (const storage::SqliteError& e) {
      throw CommandError(e.what());
    }
  });
}

}  // namespace gearwatch::cli
