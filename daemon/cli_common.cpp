#include "cli_common.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>

#include <nlohmann/json.hpp>

#include "gearwatch/storage/schema.hpp"
#include "vocabulary.hpp"

namespace gearwatch::cli {

config::GearwatchConfig load_config_or_defaults(const std::string& path) {
  try {
    if (path.empty()) return config::parse_config("", "(built-in defaults)");
    return config::load_config(path);
  } catch (const config::ConfigError& e) {
    throw CommandError(e.what());
  }
}

void add_format_option(CLI::App* cmd, std::string& format, const std::string& default_format,
                       const std::vector<std::string>& allowed) {
  format = default_format;
  cmd->add_option("--format", format, "Output format")->check(CLI::IsMember(allowed));
}

std::string dump_json(const nlohmann::json& j, int indent) { return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace); }

std::string printable(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte >= 0x20 && byte != 0x7f) {
      out += c;
      continue;
    }
    char escaped[5];
    std::snprintf(escaped, sizeof escaped, "\\x%02x", byte);
    out += escaped;
  }
  return out;
}

void require_history(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (!fs::exists(status)) throw CommandError("no database at " + path + " (only `run` and `replay` create one)");
  if (fs::is_directory(status)) throw CommandError(path + " is a directory, not a database");
  if (fs::is_regular_file(status) && fs::file_size(path, ec) == 0)
    throw CommandError(path + " is empty: no gearwatch history in it (only `run` and `replay` create one)");
  try {
    storage::Database db(path, storage::Database::Mode::read_only);
    const storage::DatabaseIdentity identity = storage::identify_database(db);
    storage::refuse_foreign_database(path, identity);
    if (identity.kind == storage::DatabaseKind::empty)
      throw CommandError(path + " is an empty database: no gearwatch history in it (only `run` and `replay` create one)");
  } catch (const storage::ForeignDatabase& e) {
    throw CommandError(e.what());  // names the path already
  } catch (const storage::SqliteError& e) {
    throw CommandError("cannot read " + path + ": " + e.what());
  }
}

storage::Database open_history(const std::string& path) {
  require_history(path);
  try {
    return storage::Database(path, storage::Database::Mode::read_only);
  } catch (const storage::SqliteError& e) {
    throw CommandError("cannot read " + path + ": " + e.what());
  }
}

// Such a command stores one transaction and no records, so it may run while the daemon holds the
// database (the model reads the inspections at every record).
WritableHistory open_history_for_writing(const std::string& path, const std::string& command) {
  require_history(path);
  auto lock = storage::DatabaseLock::try_acquire(path);
  if (lock) {
    storage::Database db(path);
    storage::open_and_migrate(db, daemon::acquisition_vocabulary());
    return {std::move(lock), std::move(db)};
  }
  const pid_t holder = storage::DatabaseLock::holder(path);
  const std::string held = "database " + path + " is in use by another gearwatch (pid " +
                           (holder > 0 ? std::to_string(holder) : std::string("unknown")) + ")";
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw CommandError(held + " that has not created it yet; try again in a moment");
  storage::Database db(path, storage::Database::Mode::read_write);
  if (db.user_version() != storage::current_schema_version())
    throw CommandError(held + " at schema version " + std::to_string(db.user_version()) + ", not this gearwatch's " +
                       std::to_string(storage::current_schema_version()) + "; " + command +
                       " does not migrate a database another process holds");
  storage::enable_foreign_keys(db);
  return {std::nullopt, std::move(db)};
}

namespace {

std::string csv_escape(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += "\"\"";
    else out += c;
  }
  return out + "\"";
}

}  // namespace

std::size_t print_table(const storage::StoredTable& table, const std::string& format) {
  const int ncol = static_cast<int>(table.columns.size());
  const std::vector<std::string>& names = table.columns;
  std::vector<std::vector<std::string>> rows;
  nlohmann::json json_rows = nlohmann::json::array();
  for (const auto& stored : table.rows) {
    std::vector<std::string> row;
    nlohmann::json obj = nlohmann::json::object();
    for (std::size_t c = 0; c < names.size(); ++c) {
      const storage::StoredValue& v = stored[c];
      if (storage::is_null(v)) {
        row.emplace_back("");
        obj[names[c]] = nullptr;
      } else if (const auto* i = std::get_if<std::int64_t>(&v)) {
        row.push_back(std::to_string(*i));
        obj[names[c]] = *i;
      } else if (const auto* d = std::get_if<double>(&v)) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.6g", *d);
        row.emplace_back(buf);
        obj[names[c]] = *d;
      } else {
        const auto* t = std::get_if<std::string>(&v);
        std::string text = t ? *t : std::get<storage::Blob>(v).bytes;
        obj[names[c]] = text;
        row.push_back(format == "table" ? printable(text) : std::move(text));
      }
    }
    if (format == "json") json_rows.push_back(std::move(obj));
    else rows.push_back(std::move(row));
  }
  if (format == "json") {
    std::cout << dump_json(json_rows) << "\n";
    return json_rows.size();
  }
  if (format == "csv") {
    for (int c = 0; c < ncol; ++c) std::cout << (c ? "," : "") << csv_escape(names[static_cast<std::size_t>(c)]);
    std::cout << "\n";
    for (const auto& r : rows) {
      for (int c = 0; c < ncol; ++c) std::cout << (c ? "," : "") << csv_escape(r[static_cast<std::size_t>(c)]);
      std::cout << "\n";
    }
    return rows.size();
  }
  std::vector<std::size_t> width(static_cast<std::size_t>(ncol));
  for (int c = 0; c < ncol; ++c) width[static_cast<std::size_t>(c)] = names[static_cast<std::size_t>(c)].size();
  for (const auto& r : rows)
    for (int c = 0; c < ncol; ++c) width[static_cast<std::size_t>(c)] = std::max(width[static_cast<std::size_t>(c)], r[static_cast<std::size_t>(c)].size());
  auto print_row = [&](const std::vector<std::string>& r) {
    for (int c = 0; c < ncol; ++c) {
      const auto& v = r[static_cast<std::size_t>(c)];
      std::cout << (c ? "  " : "") << v << std::string(width[static_cast<std::size_t>(c)] - v.size(), ' ');
    }
    std::cout << "\n";
  };
  print_row(names);
  for (const auto& r : rows) print_row(r);
  if (rows.empty()) std::cout << "(no rows)\n";
  return rows.size();
}

// Written next to the target and renamed over it, so a browser (or a web server publishing DIR)
// never sees half a page.
std::shared_ptr<PageCommandOptions> add_page_command_options(CLI::App* cmd) {
  auto opt = std::make_shared<PageCommandOptions>();
  cmd->add_option("--db", opt->db, "SQLite database (opened read-only)")->required();
  cmd->add_option("--out", opt->out, "Output directory (created if missing)")->required();
  return opt;
}

void write_page(const std::filesystem::path& dir, const std::string& html) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw CommandError("cannot create output directory " + dir.string() + ": " + ec.message());
  if (!fs::is_directory(dir)) throw CommandError("--out " + dir.string() + " is not a directory");
  const fs::path target = dir / "index.html";
  const fs::path temporary = dir / "index.html.tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw CommandError("cannot write " + temporary.string() + ": " + std::strerror(errno));
    out << html;
    out.flush();
    if (!out) {
      const std::string reason = std::strerror(errno);
      fs::remove(temporary, ec);
      throw CommandError("cannot write " + temporary.string() + ": " + reason);
    }
  }
  fs::rename(temporary, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
    throw CommandError("cannot write " + target.string() + ": " + ec.message());
  }
}


}  // namespace gearwatch::cli
