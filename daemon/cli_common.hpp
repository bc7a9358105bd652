#pragma once
// Helpers shared by the subcommands: config loading with the one-line error contract,
// logging set-up, and printing query results as table, CSV or JSON.
#include <optional>
#include <string>

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

/// Adds --format with the allowed values.
void add_format_option(CLI::App* cmd, std::string& format, const std::string& default_format = "table");

}  // namespace gearwatch::cli
