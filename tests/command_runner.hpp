#pragma once
// Runs a command line for the tests that drive gearwatch end to end (its CLI, and the
// independent capture generator in tests/capture_gen). Not a component: shared test support.
#include <fcntl.h>
#include <grp.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace gearwatch::testing {

struct CommandResult {
  int status = -1;   ///< exit status (128 when killed by a signal)
  std::string out;   ///< standard output
  std::string err;   ///< standard error
};

inline CommandResult run_command(const std::string& command_line) {
  static int n = 0;
  const auto err_path = std::filesystem::temp_directory_path() /
                        ("gearwatch-cmd-err-" + std::to_string(::getpid()) + "-" + std::to_string(n++));
  const std::string cmd = command_line + " 2>" + err_path.string();
  CommandResult r;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  std::size_t got;
  while ((got = std::fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), got);
  const int st = ::pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128;
  std::ifstream e(err_path);
  r.err.assign(std::istreambuf_iterator<char>(e), {});
  std::filesystem::remove(err_path);
  return r;
}

/// Starts `binary` (gearwatch by default) with `args`, its stdout and stderr into files; with
/// `as_user` set, as that uid (and gid). Returns the child's pid at once; wait_exit() reaps it.
inline pid_t spawn(const std::vector<std::string>& args, const std::filesystem::path& out, const std::filesystem::path& err,
                   uid_t as_user = 0, const std::string& binary = GEARWATCH_BINARY) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  const int o = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const int e = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ::dup2(o, 1);
  ::dup2(e, 2);
  if (as_user != 0 && (::setgroups(0, nullptr) != 0 || ::setgid(as_user) != 0 || ::setuid(as_user) != 0)) ::_exit(126);
  std::vector<char*> argv{const_cast<char*>(binary.c_str())};
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  ::execv(binary.c_str(), argv.data());
  ::_exit(127);
}

/// Waits for `pid`: its exit status, or 128 + the signal that ended it.
inline int wait_exit(pid_t pid) {
  int st = 0;
  ::waitpid(pid, &st, 0);
  return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}


}  // namespace gearwatch::testing
