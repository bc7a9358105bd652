#pragma once
// Turns an assembled record into what is stored for it: the indicators of every channel
// (dsp::RecordAnalyzer) and the wear-mechanism assessment over the gear pair's history (§4.4).
// Runs on the processing thread; owns the analyzer's FFT plans and scratch.
#include <map>
#include <string>
#include <vector>

#include "gearwatch/config/config.hpp"
#include "gearwatch/dsp/record_analyzer.hpp"
#include "gearwatch/dsp/wear_mechanism.hpp"
#include "gearwatch/record.hpp"
#include "gearwatch/storage/messages.hpp"

namespace gearwatch::daemon {

/// Per protocol channel: the (cycles, ICS2 low, ICS2 high, selected band) history.
using WearHistory = std::map<int, std::vector<dsp::WearHistoryPoint>>;

class RecordProcessor {
 public:
  explicit RecordProcessor(const config::GearwatchConfig& config, WearHistory history = {});
  /// Never throws on bad data: problems become skipped indicators with a reason.
  storage::RecordResult process(const Record& record, bool analysable, std::uint64_t stream_sequence);
  /// A new gear pair (the life counter went backwards): its history starts empty.
  void reset_history();
  const WearHistory& history() const noexcept { return history_; }

 private:
  config::GearwatchConfig config_;
  dsp::RecordAnalyzer analyzer_;
  WearHistory history_;
  std::map<int, std::string> last_mechanism_;
  std::map<int, std::size_t> last_jumps_;
};

/// The wear history of the gear pair now installed, from an existing database: analysed
/// records with a cycle count since the last life-counter reset. Empty for a new database.
WearHistory load_wear_history(const std::string& database_path);

}  // namespace gearwatch::daemon
