#pragma once
// One column of a query on a test's database, read-only, each value as text ("NULL" for null):
// what an end-to-end test compares against after driving the binary. Not a component.
#include <filesystem>
#include <string>
#include <vector>

#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::testing {

inline std::vector<std::string> column(const std::filesystem::path& db, const std::string& sql) {
  storage::Database d(db.string(), storage::Database::Mode::read_only);
  storage::Statement s(d, sql);
  std::vector<std::string> out;
  while (s.step()) out.push_back(s.is_null(0) ? "NULL" : s.get_text(0));
  return out;
}

}  // namespace gearwatch::testing
