#pragma once
// The reasons a daemon gives on resend_gone (docs/fleet.md): one vocabulary for the outbox that
// names them and the fleet store that records them.
#include <cstdint>

namespace gearwatch::storage {

/// Why ids asked for again cannot be sent: the outbox no longer holds them (pruned beyond the
/// newest 2 x limit, or dropped at the limit), or the broker refused them (sending again would be
/// refused again).
enum class OutboxGoneReason : std::uint8_t { not_held, refused };
const char* to_string(OutboxGoneReason reason) noexcept;

}  // namespace gearwatch::storage
