#pragma once
// What the daemon's periodic gap diagnosis keeps between records (schema version 7, docs/gap.md,
// "Persistence"): the schedule's counters per gear pair and the records the next diagnosis can use,
// each with the wear state the model had reached at it. Written in the transaction of the record's
// model run, read back when the model thread starts, so replays one capture per process reach the
// diagnosis with the same records as one long replay.
#include <cstdint>
#include <optional>
#include <vector>

#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/types/record.hpp"
#include "gearwatch/types/wear_state.hpp"

namespace gearwatch::storage {

/// The schedule's counters for one gear pair: records added since the pair was installed (or the
/// gap step first ran on it) and records since the last diagnosis.
struct GapScheduleCounters {
  std::uint64_t records_added = 0;
  std::uint64_t since_diagnosis = 0;
};

/// One record kept for a coming diagnosis. `record` holds one channel (the compared one) with the
/// tacho edges of every shaft, its rate, stream id, start index, speed, torque and life position:
/// what the diagnosis reads of it. Samples are stored as the float32 they are, edges and the state's
/// doubles exactly, so the record and state read back are the ones written.
struct KeptGapRecord {
  std::uint64_t position = 0;         ///< 1 for the first record the schedule added for this pair, then 2, 3, ...
  std::uint64_t stream_sequence = 0;  ///< the run's stream sequence (identifies the stored record with start_index)
  Record record;
  wear::WearState state;
};

/// What one record changes: the counters after it, the record itself when a coming diagnosis can
/// use it, and the kept rows no coming diagnosis can use (this pair's at or before
/// `drop_through_position`, and every other pair's).
struct GapScheduleUpdate {
  std::int64_t gear_pair = 0;
  GapScheduleCounters counters;
  std::optional<KeptGapRecord> keep;
  std::uint64_t drop_through_position = 0;
};

/// Writes `update` inside the caller's transaction (the model run's). Throws SqliteError.
void write_gap_schedule_update(Database& db, const GapScheduleUpdate& update, std::optional<std::int64_t> record_id,
                               std::optional<std::int64_t> model_run_id);

struct StoredGapSchedule {
  bool found = false;                 ///< counters were stored for this pair
  GapScheduleCounters counters;
  std::vector<KeptGapRecord> kept;    ///< by position, oldest first
};

/// The counters and kept records of `gear_pair`. A database older than schema version 7 has none.
/// Throws std::runtime_error naming the row when a stored record cannot be read.
StoredGapSchedule load_gap_schedule(Database& db, std::int64_t gear_pair);

/// True when the database has the gap schedule's tables (schema version 7 or later).
bool has_gap_schedule_tables(Database& db);

}  // namespace gearwatch::storage
