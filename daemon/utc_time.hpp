#pragma once
// The one parser of the times staff type on the command line (`query --since/--until`).
#include <string>

namespace gearwatch::cli {

/// The forms accepted, as listed in the error message and docs/cli.md.
inline constexpr const char* kAcceptedTimeForms =
    "2026-11-01, 2026-11-01T08:00, 2026-11-01T08:00:30 or 2026-11-01T08:00:30.250 (UTC; a space for the T and a trailing Z "
    "are allowed)";

/// Parses a UTC time given to `option` and returns it in the form the database stores
/// (2026-11-01T08:00:30.250Z), so it compares as text with the stored times. A malformed or
/// impossible time (month 13, 30 February, 24:00) is a CommandError naming the option, the text
/// and the accepted forms.
std::string parse_utc_time(const std::string& text, const std::string& option);

}  // namespace gearwatch::cli
