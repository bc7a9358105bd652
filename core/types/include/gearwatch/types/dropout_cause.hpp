#pragma once
// Why samples are missing from a stream, a dropout (acquisition's record assembler finds the
// holes; the processing side stores each as a dropout event). The tokens cross into the database
// (vocabulary domain gap_cause, a released name kept: docs/storage.md, "Stored names") and storage
// reads them back, so this enum is their single source of truth for both. Existing tokens never
// change spelling.
#include <array>
#include <cstdint>

namespace gearwatch::acquisition {

enum class DropoutCause : std::uint8_t {
  protocol = 0,       ///< the stream's own sample indices skip (lost on the bus, in the kernel or the front-end)
  ring_overflow = 1,  ///< the daemon's frame ring was full and dropped frames
};
inline constexpr std::array kAllDropoutCauses{DropoutCause::protocol, DropoutCause::ring_overflow};
/// The stored tokens: protocol, ring_overflow.
const char* to_string(DropoutCause cause) noexcept;

}  // namespace gearwatch::acquisition
