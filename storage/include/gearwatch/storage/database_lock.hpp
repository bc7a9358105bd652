#pragma once
// One writer per database (docs/storage.md, "One writer per database"). A process that stores
// records (`run`, `replay`) holds an exclusive flock(2) on the file `<database>.lock` for its
// whole life, with its pid written in it. The kernel releases the lock when the process ends,
// however it ends (kill -9 included), so a lock is never stale; the file itself stays.
#include <optional>
#include <stdexcept>
#include <string>
#include <sys/types.h>

namespace gearwatch::storage {

/// The database is held by another process; what() is one line naming its pid.
class DatabaseInUse : public std::runtime_error {
 public:
  DatabaseInUse(const std::string& what, pid_t holder) : std::runtime_error(what), holder_(holder) {}
  pid_t holder() const noexcept { return holder_; }  ///< 0 when the holder has not written its pid yet

 private:
  pid_t holder_;
};

class DatabaseLock {
 public:
  /// Takes the lock of `database` without waiting. Throws DatabaseInUse when another process
  /// (or another lock in this one) holds it, std::runtime_error when the lock file cannot be made.
  static DatabaseLock acquire(const std::string& database);
  /// As acquire(), but returns nothing when the lock is held elsewhere.
  static std::optional<DatabaseLock> try_acquire(const std::string& database);
  /// The pid written in the lock file of `database` (0 when none can be read).
  static pid_t holder(const std::string& database);
  static std::string lock_path(const std::string& database) { return database + ".lock"; }

  DatabaseLock(DatabaseLock&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }
  DatabaseLock& operator=(DatabaseLock&& other) noexcept;
  DatabaseLock(const DatabaseLock&) = delete;
  DatabaseLock& operator=(const DatabaseLock&) = delete;
  ~DatabaseLock();

 private:
  explicit DatabaseLock(int fd) : fd_(fd) {}
  int fd_ = -1;
};

}  // namespace gearwatch::storage
