#pragma once
// Thin RAII layer over the SQLite C API.
// Threading: one Database (connection) per thread. A Database and its Statements must only be
// used from the thread that opened it; the daemon's writer thread owns the writing connection,
// and readers (CLI, sqlite3) open their own.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

struct sqlite3;
struct sqlite3_stmt;

namespace gearwatch::storage {

class SqliteError : public std::runtime_error {
 public:
  SqliteError(int code, const std::string& what) : std::runtime_error(what), code_(code) {}
  int code() const noexcept { return code_; }
  /// SQLITE_BUSY/LOCKED, SQLITE_FULL, SQLITE_IOERR: worth retrying later with the same data.
  bool transient() const noexcept;

 private:
  int code_;
};

class Database {
 public:
  enum class Mode { read_write_create, read_write, read_only };
  Database(const std::string& path, Mode mode = Mode::read_write_create, int busy_timeout_ms = 5000);
  ~Database();
  Database(Database&& other) noexcept;
  Database& operator=(Database&& other) noexcept;
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  void exec(std::string_view sql);
  std::int64_t last_insert_rowid() const noexcept;
  /// Rows changed by the last INSERT, UPDATE or DELETE on this connection.
  int changes() const noexcept;
  int user_version();
  void set_user_version(int v);
  sqlite3* handle() const noexcept { return db_; }
  const std::string& path() const noexcept { return path_; }

 private:
  sqlite3* db_ = nullptr;
  std::string path_;
};

/// The type of a value in the current row (SQLite's storage classes).
enum class ColumnType { integer, real, text, blob, null };
/// "integer", "real", "text", "blob" or "null".
const char* to_string(ColumnType type) noexcept;

class Statement {
 public:
  Statement(Database& db, std::string_view sql);
  ~Statement();
  Statement(Statement&& other) noexcept;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& bind(int index, std::int64_t v);
  Statement& bind(int index, int v) { return bind(index, static_cast<std::int64_t>(v)); }
  Statement& bind(int index, std::uint64_t v) { return bind(index, static_cast<std::int64_t>(v)); }
  Statement& bind(int index, double v);          ///< NaN/Inf are stored as NULL
  Statement& bind(int index, std::string_view v);
  Statement& bind(int index, const char* v) { return bind(index, std::string_view{v}); }
  Statement& bind(int index, const std::string& v) { return bind(index, std::string_view{v}); }
  Statement& bind_null(int index);
  /// The bytes as a BLOB (copied: the caller's buffer may go away before the statement runs).
  Statement& bind_blob(int index, const void* data, std::size_t bytes);
  template <typename T>
  Statement& bind(int index, const std::optional<T>& v) { return v ? bind(index, *v) : bind_null(index); }

  /// Returns true while a row is available.
  bool step();
  /// Steps a statement that returns no rows, then resets it for reuse.
  void run();
  void reset();

  int column_count() const noexcept;
  bool is_null(int col) const noexcept;
  std::int64_t get_int(int col) const noexcept;
  double get_double(int col) const noexcept;
  std::string get_text(int col) const;
  /// A BLOB's bytes (empty for NULL or a zero-length BLOB).
  std::string get_blob(int col) const;
  std::string column_name(int col) const;
  /// The type of the current row's value in `col`.
  ColumnType column_type(int col) const noexcept;

 private:
  sqlite3_stmt* stmt_ = nullptr;
  sqlite3* db_ = nullptr;
};

/// Rolls back in its destructor unless commit() was called (SQLiteCpp-style).
class Transaction {
 public:
  explicit Transaction(Database& db);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit();

 private:
  Database& db_;
  bool done_ = false;
};

/// A nested part of a transaction (SAVEPOINT): rolled back to its start in the destructor
/// unless released, so one failing part of a message does not take the rest with it.
class Savepoint {
 public:
  explicit Savepoint(Database& db);
  ~Savepoint();
  Savepoint(const Savepoint&) = delete;
  Savepoint& operator=(const Savepoint&) = delete;
  void release();

 private:
  Database& db_;
  bool done_ = false;
};

}  // namespace gearwatch::storage
