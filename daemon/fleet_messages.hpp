#pragma once
// What the fleet consumer makes of one MQTT message (docs/fleet.md): the topic's levels checked
// against the prefix and the allowed gearboxes, the payload checked as UTF-8, as JSON and against
// its topic's documented schema (docs/mqtt/<topic>.schema.json), and turned into the typed value
// the fleet store writes — or a reject with its reason and a one-line detail.
#include <set>
#include <string>
#include <utility>
#include <variant>

#include "gearwatch/storage/fleet_store.hpp"

namespace gearwatch::daemon {

namespace fleet = storage::fleet;

using FleetMessage = fleet::Message;

struct FleetRejection {
  fleet::RejectReason reason;
  std::string detail;
};

/// Which messages the consumer takes: those under `prefix`, from the listed gearboxes ("site/name";
/// an empty list takes every gearbox).
struct FleetAcceptance {
  std::string prefix;
  std::set<std::string> gearboxes;
};

std::variant<FleetMessage, FleetRejection> parse_fleet_message(const FleetAcceptance& accept, const std::string& topic,
                                                               const std::string& payload);

/// A resend request (<prefix>/<site>/<gearbox>/resend): a consumer's, not data; the consumer
/// passes over them (its own among them, since it subscribes to the whole prefix).
bool is_resend_request(const FleetAcceptance& accept, const std::string& topic);

/// True when `text` is well-formed UTF-8 (no overlong forms, no surrogates, nothing past U+10FFFF).
bool is_utf8(const std::string& text) noexcept;
/// `text` with every byte that is not part of well-formed UTF-8 replaced by '?' (for log lines and details).
std::string utf8_or_replaced(const std::string& text);

}  // namespace gearwatch::daemon
