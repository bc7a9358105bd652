#pragma once
// Which occurrence of a repeated problem is logged: the first few, then every thousandth, so a
// flood shows how it began and how large it grew without filling the journal. Shared by the
// storage writer and the daemon's threads (header-only; no logging library here).
#include <cstdint>

namespace gearwatch {

/// Occurrences logged one by one before thinning starts.
inline constexpr std::uint64_t kLogFirstOccurrences = 10;
/// After those, one occurrence in this many is logged (with the running count).
inline constexpr std::uint64_t kLogEveryOccurrences = 1000;

/// True when the n-th occurrence (from 1) is to be logged.
constexpr bool log_occurrence(std::uint64_t n) noexcept {
  return n <= kLogFirstOccurrences || n % kLogEveryOccurrences == 0;
}

/// The same thinning for a problem whose later occurrences add nothing (each is the same kind of
/// record issue): only the first, then every thousandth.
constexpr bool log_first_occurrence(std::uint64_t n) noexcept { return n == 1 || n % kLogEveryOccurrences == 0; }

}  // namespace gearwatch
