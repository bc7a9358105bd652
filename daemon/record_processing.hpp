#pragma once
// Turns an assembled record into what is stored for it. Runs on the processing thread.
#include "gearwatch/config/config.hpp"
#include "gearwatch/record.hpp"
#include "gearwatch/storage/messages.hpp"

namespace gearwatch::daemon {

class RecordProcessor {
 public:
  explicit RecordProcessor(const config::GearwatchConfig& config);
  /// Never throws on bad data: problems become skipped indicators with a reason.
  storage::RecordResult process(const Record& record, bool analysable, std::uint64_t stream_sequence);

 private:
  config::GearwatchConfig config_;
};

}  // namespace gearwatch::daemon
