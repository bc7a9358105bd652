#pragma once
// libpqxx's exceptions turned into the fleet store's two (fleet_store.hpp): the connection is gone
// (retry later) or the database refused (retrying will not help). Shared by the writers and the
// page's reader; internal to storage/.
#include <memory>
#include <string>
#include <vector>

#include <pqxx/pqxx>

#include "gearwatch/storage/fleet_store.hpp"

namespace gearwatch::storage::fleet::detail {

/// A server message as one line: PostgreSQL's own end in newlines and may span several.
inline std::string one_line(std::string what) {
  while (!what.empty() && (what.back() == '\n' || what.back() == ' ')) what.pop_back();
  for (char& c : what)
    if (c == '\n') c = ' ';
  return what;
}

/// A connection to the fleet database, or FleetConnectionError in one line.
inline std::unique_ptr<pqxx::connection> connect(const std::string& connection) {
  try {
    return std::make_unique<pqxx::connection>(connection);
  } catch (const std::exception& e) {
    throw FleetConnectionError("fleet database: cannot connect: " + one_line(e.what()));
  }
}

template <class F>
auto translated(F&& f) {
  try {
    return f();
  } catch (const pqxx::broken_connection& e) {
    throw FleetConnectionError(std::string("fleet database: connection lost: ") + e.what());
  } catch (const pqxx::in_doubt_error& e) {
    throw FleetConnectionError(std::string("fleet database: commit in doubt: ") + e.what());
  } catch (const pqxx::sql_error& e) {
    throw FleetRefusedError(one_line(e.what()));
  }
}

/// Every gearbox's holes (FleetStore::holes) inside the caller's transaction, so the fleet page
/// reads them at the same moment as the rest (defined in fleet_store.cpp).
std::vector<MessageHole> read_holes(pqxx::transaction_base& t);

}  // namespace gearwatch::storage::fleet::detail
