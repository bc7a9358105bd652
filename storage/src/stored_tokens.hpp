#pragma once
// Shared by storage's typed readers (not a public header): a stored token back to its enum, and
// whether a table or view exists in a database that may be older than the newest schema.
#include <array>
#include <cstddef>
#include <stdexcept>
#include <string>

#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/types/token.hpp"

namespace gearwatch::storage::detail {

/// The stored token back to its enum through the enum's one to_string (from_token).
template <class Enum, std::size_t N>
Enum enum_of(const std::array<Enum, N>& all, const std::string& token, const char* domain, const std::string& row) {
  if (const auto value = from_token(all, token)) return *value;
  throw std::runtime_error(row + ": '" + token + "' is not a " + domain + " this gearwatch knows");
}

/// True when `name` is a table or a view of `db`.
inline bool has_object(Database& db, const char* name) {
  Statement s(db, "SELECT 1 FROM sqlite_master WHERE name = ? AND type IN ('table', 'view')");
  s.bind(1, name);
  return s.step();
}

}  // namespace gearwatch::storage::detail
