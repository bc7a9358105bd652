#pragma once
// The staff's queries (`gearwatch query`, docs/cli.md): each view of the schema a staff question
// reads, with the filters the command offers. Rows come back as the view has them
// (StoredTable): the views are the staff's interface.
#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/storage/stored_table.hpp"

namespace gearwatch::storage {

enum class QueryView { alerts, active, indicators, health, updates, predictions, inspections, records, gaps, rejected };
inline constexpr std::array kAllQueryViews{QueryView::alerts,      QueryView::active,      QueryView::indicators, QueryView::health,
                                           QueryView::updates,     QueryView::predictions, QueryView::inspections,
                                           QueryView::records,     QueryView::gaps,        QueryView::rejected};
/// The command's word for the view ("alerts", "active", ...).
const char* to_string(QueryView view) noexcept;
/// The view of a command word, nullopt when there is none.
std::optional<QueryView> parse_query_view(const std::string& word);
/// True when the view's rows are per channel (so --channel applies).
bool has_channel(QueryView view) noexcept;

/// What a database lacks for a view, when it is older than the view.
enum class QueryViewAvailability {
  available,
  needs_schema_4,  ///< k_updates / predictions do not exist yet
  needs_schema_8,  ///< predictions has no interval coverage yet
};
QueryViewAvailability query_view_availability(Database& db, QueryView view);

struct QueryFilter {
  std::string since, until;             ///< ISO 8601 UTC, "" for no bound (until is exclusive)
  std::optional<std::int64_t> channel;  ///< only for views with has_channel()
  std::string name;                     ///< indicators only: "" for every indicator
  std::optional<std::int64_t> limit;    ///< at most this many rows, the newest
};

/// The view's rows in time order, filtered. Throws std::invalid_argument for a channel or
/// name filter the view does not take, SqliteError when the database cannot answer.
StoredTable query_view(Database& db, QueryView view, const QueryFilter& filter);

}  // namespace gearwatch::storage
