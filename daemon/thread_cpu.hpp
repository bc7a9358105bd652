#pragma once
// The CPU time the calling thread has used (CLOCK_THREAD_CPUTIME_ID), in nanoseconds. The daemon's
// counters add it up per thread, so a replay can say where its time went (bench/bench_replay.cpp).
#include <cstdint>
#include <ctime>

namespace gearwatch::daemon {

inline std::uint64_t thread_cpu_ns() {
  timespec t{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<std::uint64_t>(t.tv_sec) * 1000000000ULL + static_cast<std::uint64_t>(t.tv_nsec);
}

}  // namespace gearwatch::daemon
