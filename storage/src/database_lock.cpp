#include "gearwatch/storage/database_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <string>

namespace gearwatch::storage {
namespace {

// The descriptor of an open lock file, closed on every path out (RAII for the one descriptor).
class FileDescriptor {
 public:
  explicit FileDescriptor(int fd) : fd_(fd) {}
  ~FileDescriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  int get() const noexcept { return fd_; }
  int release() noexcept {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }

 private:
  int fd_;
};

pid_t read_pid(int fd) {
  char text[32] = {};
  const ssize_t n = ::pread(fd, text, sizeof text - 1, 0);
  if (n <= 0) return 0;
  return static_cast<pid_t>(std::strtol(text, nullptr, 10));
}

// Replaces the file's content with our pid: staff (and a refused second writer) read who holds it.
void write_pid(int fd) {
  const std::string text = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, text.data(), text.size(), 0) != static_cast<ssize_t>(text.size())) {
    // The lock holds without the pid; a refused writer then says the pid is unknown.
  }
}

}  // namespace

std::optional<DatabaseLock> DatabaseLock::try_acquire(const std::string& database) {
  const std::string path = lock_path(database);
  FileDescriptor fd(::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644));
  if (fd.get() < 0)
    throw std::runtime_error("cannot open the lock file " + path + " of database " + database + ": " + std::strerror(errno));
  while (::flock(fd.get(), LOCK_EX | LOCK_NB) != 0) {
    if (errno == EINTR) continue;
    if (errno == EWOULDBLOCK) return std::nullopt;
    throw std::runtime_error("cannot lock " + path + ": " + std::strerror(errno));
  }
  write_pid(fd.get());
  return DatabaseLock(fd.release());
}

DatabaseLock DatabaseLock::acquire(const std::string& database) {
  if (auto lock = try_acquire(database)) return std::move(*lock);
  const pid_t pid = holder(database);
  throw DatabaseInUse("database " + database + " is in use by another gearwatch (pid " +
                          (pid > 0 ? std::to_string(pid) : std::string("unknown")) +
                          "); one process writes a database at a time: stop that one first",
                      pid);
}

pid_t DatabaseLock::holder(const std::string& database) {
  FileDescriptor fd(::open(lock_path(database).c_str(), O_RDONLY | O_CLOEXEC));
  return fd.get() < 0 ? 0 : read_pid(fd.get());
}

DatabaseLock& DatabaseLock::operator=(DatabaseLock&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

DatabaseLock::~DatabaseLock() {
  if (fd_ >= 0) ::close(fd_);  // closing the last descriptor releases the flock
}

}  // namespace gearwatch::storage
