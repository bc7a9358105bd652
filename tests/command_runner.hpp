#pragma once
// Runs a command line for the tests that drive gearwatch end to end (its CLI, and the
// independent capture generator in tests/capture_gen), and starts child processes for the tests
// that need one running beside them. Not a component: shared test support. Every wait here has a
// deadline: a command or child that outlives it is ended (SIGTERM, then SIGKILL) and the test
// fails where it waited instead of hanging until CTest's timeout kills it without a word.
#include <errno.h>
#include <fcntl.h>
#include <grp.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace gearwatch::testing {

struct CommandResult {
  int status = -1;   ///< exit status (128 when killed by a signal, 124 when it outlived its timeout)
  std::string out;   ///< standard output
  std::string err;   ///< standard error
};

namespace detail {

// In the child, before exec: standard input from /dev/null (nothing may wait for the test's
// own input) and no descriptor of the test's but 0, 1 and 2 (a child holding the test's pipes
// would keep them open after the test).
inline void child_standard_input_and_descriptors() {
  const int null = ::open("/dev/null", O_RDONLY);
  if (null >= 0 && null != 0) {
    ::dup2(null, 0);
    ::close(null);
  }
  const long max = ::sysconf(_SC_OPEN_MAX);
  for (int fd = 3; fd < (max > 0 && max < 65536 ? max : 65536); ++fd) ::close(fd);
}

/// Waits until `pid` exits or `timeout` passes, reaping it: true with its raw status if it exited.
inline bool reap_within(pid_t pid, int& status, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) return true;
    if (r < 0 && errno == ECHILD) {  // reaped elsewhere: nothing to signal, and no exit status known
      status = -1;
      return true;
    }
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

/// The exit code of a raw status (128 + signal); -1 for a child reaped elsewhere.
inline int exit_code(int status) {
  if (status == -1) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// A mutex-guarded list of process ids a test must end if it stops early.
class PidRegistry {
 public:
  void add(pid_t pid) {
    std::lock_guard lock(mutex_);
    pids_.push_back(pid);
  }
  void remove(pid_t pid) {
    std::lock_guard lock(mutex_);
    std::erase(pids_, pid);
  }
  std::vector<pid_t> snapshot() const {
    std::lock_guard lock(mutex_);
    return pids_;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<pid_t> pids_;
};

// The children started by spawn() and not yet reaped, so that a test ending early (a failed
// REQUIRE throws past its waits) still ends them (ChildrenGuard).
inline PidRegistry& children() {
  static PidRegistry registry;
  return registry;
}
inline void forget_child(pid_t pid) { children().remove(pid); }

}  // namespace detail

/// Ends `pid` (or its process group when `group`): SIGTERM, `grace` to exit, then SIGKILL; reaps
/// it. Its exit code (128 + signal when a signal ended it).
inline int terminate_child(pid_t pid, std::chrono::milliseconds grace = std::chrono::seconds(5), bool group = false) {
  int status = 0;
  if (detail::reap_within(pid, status, std::chrono::milliseconds(0))) {
    detail::forget_child(pid);
    return detail::exit_code(status);
  }
  ::kill(group ? -pid : pid, SIGTERM);
  if (!detail::reap_within(pid, status, grace)) {
    ::kill(group ? -pid : pid, SIGKILL);
    detail::reap_within(pid, status, std::chrono::seconds(10));
  }
  detail::forget_child(pid);
  return detail::exit_code(status);
}

/// Runs `command_line` with sh, standard input from /dev/null; its output, error output and exit
/// status. A command still running after `timeout` is ended with its process group (status 124,
/// the error output says so). The default is longer than any test's CTest TIMEOUT (900 s for the
/// long tests), so only a caller's own shorter bound ever ends a command early.
inline CommandResult run_command(const std::string& command_line, std::chrono::seconds timeout = std::chrono::seconds(1200)) {
  static int n = 0;
  const auto err_path = std::filesystem::temp_directory_path() /
                        ("gearwatch-cmd-err-" + std::to_string(::getpid()) + "-" + std::to_string(n++));
  const std::string cmd = command_line + " 2>" + err_path.string();
  CommandResult r;
  int fds[2];
  if (::pipe(fds) != 0) return r;
  const pid_t pid = ::fork();
  if (pid < 0) return r;
  if (pid == 0) {
    ::setpgid(0, 0);  // its own group: a timeout ends the whole pipeline
    ::dup2(fds[1], 1);
    detail::child_standard_input_and_descriptors();
    ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::setpgid(pid, pid);
  ::close(fds[1]);
  ::fcntl(fds[0], F_SETFL, O_NONBLOCK);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::array<char, 4096> buf{};
  int status = 0;
  bool exited = false, eof = false, timed_out = false;
  // Read until the shell has exited and its output is read (a daemon it started that kept the
  // pipe is not waited for), or until the deadline.
  while (!(exited && eof)) {
    pollfd p{fds[0], POLLIN, 0};
    ::poll(&p, 1, 50);
    ssize_t got = 0;
    while ((got = ::read(fds[0], buf.data(), buf.size())) > 0) r.out.append(buf.data(), static_cast<std::size_t>(got));
    if (exited) eof = true;  // the read after the exit took what was left
    else exited = ::waitpid(pid, &status, WNOHANG) == pid;
    if (got == 0 && !exited) std::this_thread::sleep_for(std::chrono::milliseconds(10));  // closed early: no busy poll
    if (!exited && std::chrono::steady_clock::now() > deadline) {
      timed_out = true;
      terminate_child(pid, std::chrono::seconds(5), true);
      break;
    }
  }
  ::close(fds[0]);
  r.status = timed_out ? 124 : (WIFEXITED(status) ? WEXITSTATUS(status) : 128);
  std::ifstream e(err_path);
  r.err.assign(std::istreambuf_iterator<char>(e), {});
  if (timed_out) {
    r.err = "timed out after " + std::to_string(timeout.count()) + " s: " + command_line + "\n" + r.err;
    std::cerr << "run_command: " << r.err << std::flush;
  }
  std::filesystem::remove(err_path);
  return r;
}

/// Starts `binary` (gearwatch by default) with `args`, its stdout and stderr into files, standard
/// input from /dev/null; with `as_user` set, as that uid (and gid). Returns the child's pid at
/// once; wait_exit() or wait_bounded() reaps it, a ChildrenGuard ends it if the test does not.
inline pid_t spawn(const std::vector<std::string>& args, const std::filesystem::path& out, const std::filesystem::path& err,
                   uid_t as_user = 0, const std::string& binary = GEARWATCH_BINARY) {
  const pid_t pid = ::fork();
  if (pid != 0) {
    if (pid > 0) detail::children().add(pid);
    return pid;
  }
  const int o = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const int e = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ::dup2(o, 1);
  ::dup2(e, 2);
  detail::child_standard_input_and_descriptors();
  if (as_user != 0 && (::setgroups(0, nullptr) != 0 || ::setgid(as_user) != 0 || ::setuid(as_user) != 0)) ::_exit(126);
  std::vector<char*> argv{const_cast<char*>(binary.c_str())};
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  ::execv(binary.c_str(), argv.data());
  ::_exit(127);
}

/// Waits up to `timeout` for `pid`: its exit status (128 + signal); -1 when it had not exited by
/// then, after which it is killed (SIGKILL) and reaped, or when something else reaped it.
inline int wait_bounded(pid_t pid, std::chrono::milliseconds timeout) {
  int st = 0;
  if (detail::reap_within(pid, st, timeout)) {
    detail::forget_child(pid);
    return detail::exit_code(st);
  }
  std::cerr << "wait_bounded: pid " << pid << " still running after " << timeout.count() << " ms: killed" << std::endl;
  ::kill(pid, SIGKILL);
  detail::reap_within(pid, st, std::chrono::seconds(10));
  detail::forget_child(pid);
  return -1;
}

/// Waits for `pid` as long as a command may run (run_command's default deadline): its exit status,
/// or 128 + the signal that ended it; -1 when it outlived that and was killed.
inline int wait_exit(pid_t pid) { return wait_bounded(pid, std::chrono::seconds(1200)); }

/// Ends, when it goes out of scope, every child spawn() started and nobody reaped: a test that
/// stops early (a failed REQUIRE) leaves no consumer or daemon running.
class ChildrenGuard {
 public:
  ChildrenGuard() = default;
  ChildrenGuard(const ChildrenGuard&) = delete;
  ChildrenGuard& operator=(const ChildrenGuard&) = delete;
  ~ChildrenGuard() {
    for (const pid_t pid : detail::children().snapshot()) {
      const int code = terminate_child(pid);
      std::cerr << "test ended with child " << pid << " still running: ended it (exit " << code << ")" << std::endl;
    }
  }
};

}  // namespace gearwatch::testing
