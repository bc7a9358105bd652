#pragma once
// Helpers shared by the subcommands: config loading with the one-line error contract,
// logging set-up, and printing query results as table, CSV or JSON.
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "gearwatch/config/config.hpp"
#include "gearwatch/storage/database_lock.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/storage/stored_table.hpp"

namespace gearwatch::cli {

/// Loads FILE, or the built-in defaults when `path` is empty. ConfigError -> CommandError.
config::GearwatchConfig load_config_or_defaults(const std::string& path);

/// Prints every row of `table` in `format` (table | csv | json). Returns the number of rows.
std::size_t print_table(const storage::StoredTable& table, const std::string& format);

/// Writes DIR/index.html (DIR created if missing) through a temporary file renamed over it, so a
/// browser or a web server publishing DIR never sees half a page. CommandError on failure.
void write_page(const std::filesystem::path& dir, const std::string& html);

/// The --db FILE --out DIR of a command that writes a page from the database.
struct PageCommandOptions {
  std::string db, out;
};

/// Adds the required --db (opened read-only) and --out (created if missing) to `cmd`.
std::shared_ptr<PageCommandOptions> add_page_command_options(CLI::App* cmd);

/// The one gate of every command that reads an existing history (query, report, gap report,
/// twin state, inspect): refuses with a one-line CommandError a missing path, a directory, an
/// empty file or database, and another application's database. Only `run` and `replay` create one.
void require_history(const std::string& path);

/// require_history, then the database opened read-only.
storage::Database open_history(const std::string& path);

/// A history opened for a command that adds rows to it without storing records (`inspect`,
/// `gap diagnose --db`): one transaction, so it may run while the daemon writes the database.
struct WritableHistory {
  std::optional<storage::DatabaseLock> lock;  ///< held to the end of the command when it was free
  storage::Database db;
};

/// require_history(), then: with the writer lock free, the lock is held while the database may be
/// migrated; with it held by another process, the database is written only as that process left
/// it — at this build's schema version, never migrated under it (CommandError naming the pid and
/// `command` otherwise).
WritableHistory open_history_for_writing(const std::string& path, const std::string& command);

/// Opens the history at `path` read-only (open_history) and returns `load(db)`. An unreadable
/// database or a load error becomes a CommandError naming it; a CommandError from `load` passes
/// unchanged.
template <class Load>
auto load_page_data(const std::string& path, Load&& load) {
  try {
    storage::Database db = open_history(path);
    return std::forward<Load>(load)(db);
  } catch (const CommandError&) {
    throw;
  } catch (const storage::SqliteError& e) {
    throw CommandError("cannot read " + path + ": " + e.what());
  } catch (const std::runtime_error& e) {
    throw CommandError(e.what());
  }
}

/// A command-line option's tokens and the enum values they stand for, in the order --help lists
/// them. The option stays text for CLI11 (its check: CLI::IsMember(tokens_of(table))); the code
/// reads the enum (value_of), so nothing compares the text.
template <class Enum>
using TokenTable = std::vector<std::pair<std::string, Enum>>;

template <class Enum>
std::vector<std::string> tokens_of(const TokenTable<Enum>& table) {
  std::vector<std::string> out;
  for (const auto& [token, value] : table) out.push_back(token);
  return out;
}

/// The value of `token` in the table, or nullopt (an option whose other values are free text).
template <class Enum>
std::optional<Enum> find_value(const TokenTable<Enum>& table, const std::string& token) {
  for (const auto& [t, value] : table)
    if (t == token) return value;
  return std::nullopt;
}

/// The value of a token CLI11 has checked against tokens_of(table); std::logic_error otherwise.
template <class Enum>
Enum value_of(const TokenTable<Enum>& table, const std::string& token) {
  if (const auto value = find_value(table, token)) return *value;
  throw std::logic_error("'" + token + "' is not one of the option's tokens");
}

/// Adds --format with the allowed values (the help lists exactly these).
void add_format_option(CLI::App* cmd, std::string& format, const std::string& default_format = "table",
                       const std::vector<std::string>& allowed = {"table", "csv", "json"});

/// `j` as JSON text (indent 1). Text that is not valid UTF-8 (a file name, a capture line) has each
/// invalid byte replaced by U+FFFD, so the output is always valid JSON (docs/cli.md).
std::string dump_json(const nlohmann::json& j, int indent = 1);

/// `text` for a terminal table: each control character (C0 and DEL; an escape sequence in a
/// capture line, a tab) written as \xHH, so stored text cannot move the cursor or recolour the
/// terminal.
std::string printable(const std::string& text);

}  // namespace gearwatch::cli
