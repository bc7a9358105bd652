#pragma once
// Logging set-up: stderr for interactive commands, journald for the daemon under systemd.
// RateLimitedLog keeps a flood of identical bad-input messages to one line per interval,
// with a count of how many were suppressed.
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>
#include <unordered_map>

#include <spdlog/spdlog.h>

namespace gearwatch::logging {

enum class Sink { stderr_only, journald };

/// Installs the default logger. `level` is an spdlog level name (info, debug, warn...).
void setup(Sink sink, const std::string& level = "info");

/// True when stderr is connected to the journal (systemd sets JOURNAL_STREAM).
bool running_under_journald();

}  // namespace gearwatch::logging
