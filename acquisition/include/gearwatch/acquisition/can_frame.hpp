#pragma once
// A CAN or CAN FD frame as it arrives from SocketCAN or a candump log. Plain value, no I/O.
#include <array>
#include <cstdint>

namespace gearwatch::acquisition {

struct CanFrame {
  std::uint32_t id = 0;          ///< 11-bit (or 29-bit when `extended`) identifier
  std::uint8_t len = 0;          ///< payload length in bytes (0..8 classic, 0..64 FD)
  std::uint8_t fd_flags = 0;     ///< CAN FD flags (BRS = 0x01, ESI = 0x02)
  bool fd = false;               ///< true for a CAN FD frame
  bool extended = false;         ///< 29-bit identifier
  bool remote = false;           ///< RTR (classic only)
  bool error = false;            ///< error frame (CAN_ERR_FLAG)
  double timestamp_s = 0.0;      ///< receive time (log or kernel), informational only
  std::array<std::uint8_t, 64> data{};
};

/// Valid CAN FD payload lengths are 0..8, 12, 16, 20, 24, 32, 48, 64.
constexpr bool is_valid_fd_length(unsigned len) noexcept {
  return len <= 8 || len == 12 || len == 16 || len == 20 || len == 24 || len == 32 || len == 48 || len == 64;
}

}  // namespace gearwatch::acquisition
