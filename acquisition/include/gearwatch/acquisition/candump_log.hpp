#pragma once
// can-utils' `candump -L` log format, one frame a line:
//   (1700000000.123456) can0 100#0102030405060708        classic data frame
//   (1700000000.123456) can0 100#R                        classic remote frame
//   (1700000000.123456) can0 100##1<hex payload>          CAN FD frame, flags nibble first
// Parsing and formatting only; no I/O. The parser never throws: a bad line yields a reason.
#include <optional>
#include <string>
#include <string_view>

#include "gearwatch/acquisition/can_frame.hpp"

namespace gearwatch::acquisition {

struct CandumpLine {
  CanFrame frame;
  std::string_view interface;  ///< points into the parsed line
};

/// Parses one line. On failure returns std::nullopt and sets `reason` (never throws).
/// Blank lines and lines starting with '#' are not frames: they return nullopt with reason empty.
std::optional<CandumpLine> parse_candump_line(std::string_view line, std::string& reason);

/// Formats a frame as a `candump -L` line without the trailing newline.
/// `out` is cleared first; reusing one string avoids an allocation per line.
void format_candump_line(const CanFrame& frame, std::string_view interface, std::string& out);

}  // namespace gearwatch::acquisition
