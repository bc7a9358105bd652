#pragma once
// Helpers shared by the subcommands: config loading with the one-line error contract,
// logging set-up, and printing query results as table, CSV or JSON.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "commands.hpp"
#include "gearwatch/config/config.hpp"
#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::cli {

/// Loads FILE, or the built-in defaults when `path` is empty. ConfigError -> CommandError.
config::GearwatchConfig load_config_or_defaults(const std::string& path);

/// Runs `sql` (with optional text bindings) and prints every row in `format`
/// (table | csv | json). Returns the number of rows.
std::size_t print_query(storage::Database& db, const std::string& sql, const std::vector<std::string>& bindings,
                        const std::string& format);

/// Writes DIR/index.html (DIR created if missing) through a temporary file renamed over it, so a
/// browser or a web server publishing DIR never sees half a page. CommandError on failure.
void write_page(const std::filesystem::path& dir, const std::string& html);

/// The --db FILE --out DIR of a command that writes a page from the database.
struct PageCommandOptions {
  std::string db, out;
};

/// Adds the required --db (opened read-only) and --out (created if missing) to `cmd`.
std::shared_ptr<PageCommandOptions> add_page_command_options(CLI::App* cmd);

/// Opens the database at `path` read-only and returns `load(db)`. A missing path, a directory, an
/// unreadable database or a load error becomes a CommandError naming it; a CommandError from
/// `load` passes unchanged.
template <class Load>
auto load_page_data(const std::string& path, Load&& load) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw CommandError("no database at " + path);
  if (std::filesystem::is_directory(path, ec)) throw CommandError(path + " is a directory, not a database");
  try {
    storage::Database db(path, storage::Database::Mode::read_only);
    return std::forward<Load>(load)(db);
  } catch (const CommandError&) {
    throw;
  } catch (const storage::SqliteError& e) {
    throw CommandError("cannot read " + path + ": " + e.what());
  } catch (const std::runtime_error& e) {
    throw CommandError(e.what());
  }
}

/// Adds --format with the allowed values.
void add_format_option(CLI::App* cmd, std::string& format, const std::string& default_format = "table");

}  // namespace gearwatch::cli
