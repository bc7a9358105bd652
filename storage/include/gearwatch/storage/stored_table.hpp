#pragma once
// Rows of a staff view as stored (docs/storage.md): the views are the staff's interface, so what
// `gearwatch query`, `gearwatch twin state` and the report's listing of the twin's tables show is
// each view's columns as they are, every value with its SQLite storage class as a C++ type.
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace gearwatch::storage {

/// One stored value: NULL, INTEGER, REAL, or TEXT (a BLOB is held as its bytes in a Blob).
struct Blob {
  std::string bytes;
  bool operator==(const Blob&) const = default;
};
using StoredValue = std::variant<std::monostate, std::int64_t, double, std::string, Blob>;

inline bool is_null(const StoredValue& v) { return std::holds_alternative<std::monostate>(v); }
/// The value as a number (INTEGER or REAL), nullopt otherwise.
std::optional<double> number_of(const StoredValue& v);

struct StoredTable {
  std::vector<std::string> columns;
  std::vector<std::vector<StoredValue>> rows;
  /// The column's index, or nullopt when the table has no such column.
  std::optional<std::size_t> column(const std::string& name) const;
};

}  // namespace gearwatch::storage
