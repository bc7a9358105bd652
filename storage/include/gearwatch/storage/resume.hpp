#pragma once
// What a process that starts on an existing database continues from (docs/storage.md,
// "Resuming"): the records earlier runs stored from a capture, so a replay given it again does
// not store them twice; and the analysed records the model has not handled yet, so a crash
// between a record's commit and its model run loses none of the model's work.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/storage/messages.hpp"
#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::storage {

/// One stored run: what it read, as it was stored.
struct StoredRun {
  std::int64_t id = 0;
  std::string source;                     ///< interface name or capture path
  std::optional<std::string> capture_id;  ///< the capture's content identity (schema 6 on; none before)
};

/// Every run, oldest first.
std::vector<StoredRun> load_runs(Database& db);

/// One record a run stored, with what tells it apart from another record at the same place.
struct StoredRunRecord {
  std::uint64_t stream_sequence = 0;
  std::uint16_t stream_id = 0;
  std::uint64_t start_index = 0, sample_count = 0;
  std::optional<double> input_revolutions, speed_hz, torque_nm;
  std::optional<int> rms_channel;  ///< the lowest channel with an rms_raw value (none: not analysed)
  double rms_raw = 0.0;
};

/// The records of run `run_id`, in storage order.
std::vector<StoredRunRecord> load_run_records(Database& db, std::int64_t run_id);

/// An analysed record as the processing thread submitted it, read back: the stored id, and of
/// RecordResult the fields the model reads (stream sequence and start index, cycles, speed,
/// torque, the indicator values of one channel; a NULL value reads as NaN, as it was written).
struct StoredAnalysedRecord {
  std::int64_t record_id = 0;
  std::uint32_t sample_rate_hz = 0;  ///< its stream header's rate (the twin simulates its counterpart at it)
  RecordResult record;
};

/// The analysed records committed after the record of the newest model run (every analysed
/// record when there is no model run yet), oldest first: those the model has not handled. Only
/// `channel`'s indicator values are read (the model reads one channel; a long backlog stays small).
std::vector<StoredAnalysedRecord> load_records_after_newest_model_run(Database& db, int channel);

}  // namespace gearwatch::storage
