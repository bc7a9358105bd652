#pragma once
// Where a long end-to-end test is and since when: each step's elapsed time on stderr at once (not
// through Catch's buffered report, which is lost when CTest kills a test at its timeout), and a
// watchdog that ends the test before that timeout with the step it stopped in. Not a component:
// test support for the fleet and MQTT tests.
#include <signal.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "command_runner.hpp"

namespace gearwatch::testing {

/// Processes the watchdog kills besides spawn()'s children: servers a test started (a broker, a
/// postmaster), registered while they run.
inline detail::PidRegistry& servers() {
  static detail::PidRegistry registry;
  return registry;
}
inline void register_server(pid_t pid) { servers().add(pid); }
inline void unregister_server(pid_t pid) { servers().remove(pid); }

class StepLog {
 public:
  /// `limit`: when the watchdog ends the test (below its CTest TIMEOUT).
  StepLog(const std::string& test, std::chrono::seconds limit) : test_(test.size() > 60 ? test.substr(0, 57) + "..." : test) {
    watchdog_ = std::thread([this, limit] { watch(limit); });
  }
  StepLog(const StepLog&) = delete;
  StepLog& operator=(const StepLog&) = delete;
  ~StepLog() {
    {
      std::lock_guard lock(mutex_);
      done_ = true;
    }
    wake_.notify_all();
    watchdog_.join();
  }
  /// Says that `what` begins, with the seconds since the test began.
  void operator()(const std::string& what) {
    std::lock_guard lock(mutex_);
    step_ = what;
    step_at_ = seconds();
    std::cerr << line("+" + format(step_at_) + " s: " + what) << std::flush;
  }

 private:
  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }
  static std::string format(double s) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f", s);
    return buf;
  }
  std::string line(const std::string& text) const { return "[" + test_ + "] " + text + "\n"; }
  // Past the limit: names the step, ends every child and server the test started, exits 1.
  void watch(std::chrono::seconds limit) {
    std::unique_lock lock(mutex_);
    if (wake_.wait_for(lock, limit, [&] { return done_; })) return;
    std::cerr << line("watchdog: still running after " + std::to_string(limit.count()) + " s, in the step begun at +" + format(step_at_) +
                      " s: " + step_ + "; ending its children and servers")
              << std::flush;
    std::vector<pid_t> pids = detail::children().snapshot();
    const std::vector<pid_t> server_list = servers().snapshot();
    pids.insert(pids.end(), server_list.begin(), server_list.end());
    for (const pid_t pid : pids) ::kill(pid, SIGKILL);
    std::fflush(nullptr);  // what Catch has reported so far (std::cout goes through C's stdout)
    std::_Exit(1);
  }

  std::string test_;
  const std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
  std::mutex mutex_;
  std::condition_variable wake_;
  bool done_ = false;
  std::string step_ = "(start)";
  double step_at_ = 0;
  std::thread watchdog_;
};

}  // namespace gearwatch::testing
