#include "gearwatch/storage/stored_table.hpp"

#include "stored_rows.hpp"

namespace gearwatch::storage {

std::optional<double> number_of(const StoredValue& v) {
  if (const auto* i = std::get_if<std::int64_t>(&v)) return static_cast<double>(*i);
  if (const auto* d = std::get_if<double>(&v)) return *d;
  return std::nullopt;
}

std::optional<std::size_t> StoredTable::column(const std::string& name) const {
  for (std::size_t i = 0; i < columns.size(); ++i)
    if (columns[i] == name) return i;
  return std::nullopt;
}

namespace detail {

StoredValue stored_value(const Statement& s, int col) {
  switch (s.column_type(col)) {
    case ColumnType::null: return std::monostate{};
    case ColumnType::integer: return s.get_int(col);
    case ColumnType::real: return s.get_double(col);
    case ColumnType::text: return s.get_text(col);
    case ColumnType::blob: return Blob{s.get_blob(col)};
  }
  return std::monostate{};
}

StoredTable read_table(Statement& s) {
  StoredTable t;
  for (int i = 0; i < s.column_count(); ++i) t.columns.push_back(s.column_name(i));
  while (s.step()) {
    std::vector<StoredValue> row;
    row.reserve(t.columns.size());
    for (int i = 0; i < s.column_count(); ++i) row.push_back(stored_value(s, i));
    t.rows.push_back(std::move(row));
  }
  return t;
}

}  // namespace detail
}  // namespace gearwatch::storage
