#pragma once
// Shared by storage's readers (not a public header): a statement's rows as a StoredTable, and
// the small typed column accessors every reader needs.
#include <optional>
#include <string>

#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/storage/stored_table.hpp"

namespace gearwatch::storage::detail {

StoredValue stored_value(const Statement& s, int col);
/// Steps `s` to its end: every row, with the statement's column names.
StoredTable read_table(Statement& s);

inline std::optional<double> optional_double(const Statement& s, int col) {
  if (s.is_null(col)) return std::nullopt;
  return s.get_double(col);
}
inline std::optional<std::int64_t> optional_int(const Statement& s, int col) {
  if (s.is_null(col)) return std::nullopt;
  return s.get_int(col);
}
inline std::string text_or_empty(const Statement& s, int col) { return s.is_null(col) ? std::string{} : s.get_text(col); }

/// True when `object` (a table or view) has `column`.
inline bool has_column(Database& db, const std::string& object, const std::string& column) {
  Statement s(db, "SELECT 1 FROM pragma_table_info(?) WHERE name = ?");
  s.bind(1, object).bind(2, column);
  return s.step();
}

}  // namespace gearwatch::storage::detail
