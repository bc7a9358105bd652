#pragma once
// The protocol decoder as the configuration describes it: ids from [protocol], decoded
// channels and shafts from [[channels]] and [[tachos]]. One place for the daemon, replay,
// simulate and the twin's tuning command.
#include "gearwatch/acquisition/protocol_decoder.hpp"
#include "gearwatch/config/config.hpp"

namespace gearwatch::daemon {

inline acquisition::ProtocolIds protocol_ids(const config::GearwatchConfig& c) {
  return {c.protocol.vibration_base_id, c.protocol.tacho_base_id, c.protocol.stream_header_id,
          c.protocol.operating_condition_id, c.protocol.life_counter_id};
}

inline acquisition::ProtocolDecoder make_decoder(const config::GearwatchConfig& c, acquisition::ProtocolDecoder::EventSink sink) {
  std::uint8_t channels = 0, shafts = 0;
  for (const auto& ch : c.rig.channels) channels |= static_cast<std::uint8_t>(1u << ch.number);
  for (const auto& t : c.rig.tachos) shafts |= static_cast<std::uint8_t>(1u << t.shaft);
  return acquisition::ProtocolDecoder(protocol_ids(c), channels, shafts, std::move(sink));
}

}  // namespace gearwatch::daemon
