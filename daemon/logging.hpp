#pragma once
// Logging set-up: stderr for interactive commands, journald for the daemon under systemd.
// (Bad input is rate-limited where it is logged: daemon/pipeline.cpp's BadInputLog.)
#include <string>

#include "gearwatch/config/config.hpp"

namespace gearwatch::logging {

enum class Sink { stderr_only, journald };

/// Installs the default logger. `level` is an spdlog level name (info, debug, warn...).
void setup(Sink sink, const std::string& level = "info");
/// The same with the configuration's level.
void setup(Sink sink, config::LogLevel level);

/// The level of a command whose summary is on stdout (replay, gap diagnose): warn where the
/// configuration says info, so the log does not repeat the summary; any other level as configured.
config::LogLevel summary_command_level(config::LogLevel configured);

/// True when stderr is connected to the journal (systemd sets JOURNAL_STREAM).
bool running_under_journald();

/// Where a service command (`run`, `publish`) logs: logging.sink, `auto` deciding by
/// running_under_journald().
Sink service_sink(config::LogSink configured);

}  // namespace gearwatch::logging
