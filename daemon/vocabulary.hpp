#pragma once
// The stored enumerations of the layers above core (docs/storage.md, "One source of truth"):
// every writable open of the database hands these to storage with core's own.
#include "gearwatch/acquisition/protocol_decoder.hpp"
#include "gearwatch/acquisition/record_assembler.hpp"
#include "gearwatch/storage/schema.hpp"

namespace gearwatch::daemon {

inline storage::Vocabulary acquisition_vocabulary() {
  storage::Vocabulary v;
  for (auto k : acquisition::kAllRejectKinds) v["rejected_frame_kind"].emplace_back(acquisition::to_string(k));
  for (auto c : acquisition::kAllDropoutCauses) v[storage::kDropoutCauseDomain].emplace_back(acquisition::to_string(c));
  return v;
}

}  // namespace gearwatch::daemon
