#include "gearwatch/acquisition/candump_log.hpp"

#include <charconv>
#include <cstdio>

namespace gearwatch::acquisition {
namespace {

// Above any real capture's clock (the year 33658) and far below what fits whole seconds in 64 bits.
constexpr double kMaxCandumpTimestampS = 1e12;

int hex_value(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

bool parse_hex_bytes(std::string_view hex, CanFrame& frame, std::size_t max_len, std::string& reason) {
  if (hex.size() % 2 != 0) {
    reason = "odd number of hex digits in payload";
    return false;
  }
  if (hex.size() / 2 > max_len) {
    reason = "payload longer than " + std::to_string(max_len) + " bytes";
    return false;
  }
  for (std::size_t i = 0; i < hex.size(); i += 2) {
    const int hi = hex_value(hex[i]);
    const int lo = hex_value(hex[i + 1]);
    if (hi < 0 || lo < 0) {
      reason = "non-hex character in payload";
      return false;
    }
    frame.data[i / 2] = static_cast<std::uint8_t>(hi << 4 | lo);
  }
  frame.len = static_cast<std::uint8_t>(hex.size() / 2);
  return true;
}

// The line without its end-of-line characters and surrounding spaces.
std::string_view trimmed(std::string_view line) {
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r' || line.back() == ' ')) line.remove_suffix(1);
  std::size_t p = 0;
  while (p < line.size() && line[p] == ' ') ++p;
  line.remove_prefix(p);
  return line;
}

// "(seconds.micros)" at the line's start: the frame's time, and the rest of the line after ')'.
bool parse_timestamp(std::string_view line, CanFrame& frame, std::string_view& rest, std::string& reason) {
  if (line.front() != '(') {
    reason = "line does not start with a '(timestamp)'";
    return false;
  }
  const auto close = line.find(')');
  if (close == std::string_view::npos) {
    reason = "timestamp not closed by ')'";
    return false;
  }
  const std::string_view ts = line.substr(1, close - 1);
  double value = 0.0;
  const auto [ptr, ec] = std::from_chars(ts.data(), ts.data() + ts.size(), value);
  if (ec != std::errc{} || ptr != ts.data() + ts.size()) {
    reason = "bad timestamp";
    return false;
  }
  // Seconds since the epoch (or since boot), as candump writes them. from_chars also takes
  // "inf", "nan", "-5" and "1e300": none is a time, and formatting the frame again (a rejected
  // frame is stored as text) could not convert it to whole seconds.
  if (!(value >= 0.0 && value < kMaxCandumpTimestampS)) {
    reason = "timestamp out of range (0 to 1e12 s)";
    return false;
  }
  frame.timestamp_s = value;
  rest = line.substr(close + 1);
  return true;
}

// " iface frame [T|R]": the interface's name, and the frame's text (its first token).
bool parse_interface(std::string_view rest, CandumpLine& out, std::string_view& frame_text, std::string& reason) {
  if (rest.empty() || rest.front() != ' ') {
    reason = "missing interface name";
    return false;
  }
  rest.remove_prefix(1);
  const auto space = rest.find(' ');
  if (space == std::string_view::npos || space == 0) {
    reason = "missing frame after interface name";
    return false;
  }
  out.interface = rest.substr(0, space);
  frame_text = rest.substr(space + 1);
  // Some logs append ' T' / ' R' direction markers; keep only the first token.
  if (const auto sp = frame_text.find(' '); sp != std::string_view::npos) frame_text = frame_text.substr(0, sp);
  return true;
}

// The identifier before '#': 3 hex digits standard, 8 extended (with its error-frame bit).
bool parse_identifier(std::string_view id_text, CanFrame& frame, std::string& reason) {
  std::uint32_t id = 0;
  const auto [ptr, ec] = std::from_chars(id_text.data(), id_text.data() + id_text.size(), id, 16);
  if (ec != std::errc{} || ptr != id_text.data() + id_text.size()) {
    reason = "bad identifier";
    return false;
  }
  if (id_text.size() == 8) {
    frame.extended = true;
    if (id & 0x20000000u) frame.error = true;
    id &= 0x1FFFFFFFu;
  } else if (id_text.size() == 3) {
    if (id > 0x7FFu) {
      reason = "standard identifier above 0x7FF";
      return false;
    }
  } else {
    reason = "identifier must have 3 (standard) or 8 (extended) hex digits";
    return false;
  }
  frame.id = id;
  return true;
}

// After "##": a flags digit and up to 64 bytes of a valid FD length.
bool parse_fd_payload(std::string_view payload, CanFrame& frame, std::string& reason) {
  frame.fd = true;
  if (payload.empty() || hex_value(payload.front()) < 0) {
    reason = "CAN FD frame without a flags digit";
    return false;
  }
  frame.fd_flags = static_cast<std::uint8_t>(hex_value(payload.front()));
  payload.remove_prefix(1);
  if (!parse_hex_bytes(payload, frame, 64, reason)) return false;
  if (!is_valid_fd_length(frame.len)) {
    reason = "CAN FD payload length " + std::to_string(frame.len) + " is not a valid FD length";
    return false;
  }
  return true;
}

// After "#R": a remote frame, optionally with its requested length (one digit 0..8).
bool parse_remote_payload(std::string_view payload, CanFrame& frame, std::string& reason) {
  frame.remote = true;
  frame.len = 0;
  if (payload.size() > 1) {
    const int dlc = hex_value(payload[1]);
    if (dlc < 0 || dlc > 8 || payload.size() > 2) {
      reason = "bad remote-frame length";
      return false;
    }
    frame.len = static_cast<std::uint8_t>(dlc);
  }
  return true;
}

// The text after the identifier's '#': an FD, a remote or a classic frame's payload.
bool parse_payload(std::string_view payload, CanFrame& frame, std::string& reason) {
  if (!payload.empty() && payload.front() == '#') {
    payload.remove_prefix(1);
    return parse_fd_payload(payload, frame, reason);
  }
  if (!payload.empty() && (payload.front() == 'R' || payload.front() == 'r')) return parse_remote_payload(payload, frame, reason);
  // classic: up to 8 bytes, optionally followed by '_' and a raw DLC 9..F (ignored).
  if (const auto us = payload.find('_'); us != std::string_view::npos) payload = payload.substr(0, us);
  return parse_hex_bytes(payload, frame, 8, reason);
}

}  // namespace

std::optional<CandumpLine> parse_candump_line(std::string_view line, std::string& reason) {
  reason.clear();
  line = trimmed(line);
  if (line.empty() || line.front() == '#') return std::nullopt;

  CandumpLine out;
  std::string_view rest;
  if (!parse_timestamp(line, out.frame, rest, reason)) return std::nullopt;
  std::string_view frame_text;
  if (!parse_interface(rest, out, frame_text, reason)) return std::nullopt;
  const auto hash = frame_text.find('#');
  if (hash == std::string_view::npos || hash == 0) {
    reason = "no '#' between identifier and payload";
    return std::nullopt;
  }
  if (!parse_identifier(frame_text.substr(0, hash), out.frame, reason)) return std::nullopt;
  if (!parse_payload(frame_text.substr(hash + 1), out.frame, reason)) return std::nullopt;
  return out;
}

void format_candump_line(const CanFrame& frame, std::string_view interface, std::string& out) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  out.clear();
  char head[64];
  const long long sec = static_cast<long long>(frame.timestamp_s);
  long long usec = static_cast<long long>((frame.timestamp_s - static_cast<double>(sec)) * 1e6 + 0.5);
  long long s = sec;
  if (usec >= 1000000) {
    s += 1;
    usec -= 1000000;
  }
  int n = std::snprintf(head, sizeof head, "(%010lld.%06lld) ", s, usec);
  out.append(head, static_cast<std::size_t>(n));
  out.append(interface);
  out.push_back(' ');
  if (frame.extended) {
    n = std::snprintf(head, sizeof head, "%08X", frame.id | (frame.error ? 0x20000000u : 0u));
  } else {
    n = std::snprintf(head, sizeof head, "%03X", frame.id);
  }
  out.append(head, static_cast<std::size_t>(n));
  out.push_back('#');
  if (frame.fd) {
    out.push_back('#');
    out.push_back(kHex[frame.fd_flags & 0xF]);
  } else if (frame.remote) {
    // As can-utils writes it: a remote frame's length (DLC 1..8) follows the 'R'; without it
    // the line would read back as a remote frame of length 0.
    out.push_back('R');
    if (frame.len > 0 && frame.len <= 8) out.push_back(kHex[frame.len]);
    return;
  }
  for (unsigned i = 0; i < frame.len; ++i) {
    out.push_back(kHex[frame.data[i] >> 4]);
    out.push_back(kHex[frame.data[i] & 0xF]);
  }
}

}  // namespace gearwatch::acquisition
