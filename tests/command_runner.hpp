#pragma once
// Runs a command line for the tests that drive gearwatch end to end (its CLI, and the
// independent capture generator in tests/capture_gen). Not a component: shared test support.
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

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

}  // namespace gearwatch::testing
