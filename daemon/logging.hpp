#pragma once
// Logging set-up: stderr for interactive commands, journald for the daemon under systemd.
// (Bad input is rate-limited where it is logged: daemon/pipeline.cpp's BadInputLog.)
#include <string>

namespace gearwatch::logging {

enum class Sink { stderr_only, journald };

/// Installs the default logger. `level` is an spdlog level name (info, debug, warn...).
void setup(Sink sink, const std::string& level = "info");

/// True when stderr is connected to the journal (systemd sets JOURNAL_STREAM).
bool running_under_journald();

}  // namespace gearwatch::logging
