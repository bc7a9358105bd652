#pragma once
// Replaying a capture that is already (partly) in the database — a replay killed mid-write and
// started again, or the same file given twice, by any path — continues after the records
// committed from it instead of storing them a second time. A capture is identified by what it
// is, not by how its path is spelt: its content identity (a hash of its first MiB, see
// identify_capture), stored with each run. Runs stored before the identity was (schema < 6) are
// matched by their path, resolved against the current directory. Records are cut
// deterministically from the stream (acquisition/record_assembler.hpp), so a record is found again
// by the stream's position in the capture (its sequence and stream id) and its first sample
// index; it is taken for the stored one only if its content agrees too: the length, the life
// counter (input revolutions), the operating point (speed, torque) and, when the stored record
// was analysed, the RMS of its first channel (`rms_raw`). A different capture written later to
// the same path therefore is stored, not skipped.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <tuple>

#include "gearwatch/types/record.hpp"

namespace gearwatch::daemon {

/// What a capture file is, whatever path it was given by.
struct CaptureIdentity {
  std::string path;        ///< its canonical absolute path (symlinks resolved): what runs.source shows
  std::string content_id;  ///< "fnv1a64:<16 hex digits>:<bytes hashed>" over its first MiB; "" when unreadable
};

/// The identity of the capture at `path`. A file that cannot be read, and anything but a regular
/// file (a FIFO a capture is streamed through cannot be read twice), gets an empty content_id:
/// nothing of it is read here, and a run from it is never resumed by identity.
CaptureIdentity identify_capture(const std::string& path);

class ReplayResume {
 public:
  /// Reads what earlier runs and replays of `capture` committed to `database`. A missing
  /// database means nothing is stored yet.
  static ReplayResume load(const std::string& database, const CaptureIdentity& capture);

  /// True when this record (of the stream with this sequence in the capture) is already stored.
  /// A stored record that is shorter (cut by a stop) does not count: the new run completes it.
  bool stored(std::uint64_t sequence, const Record& record) const;
  /// True when `index` of this stream lies before the end of the last record stored from it:
  /// events there (gaps, life-counter resets) were stored with those records.
  bool before_resume_point(std::uint64_t sequence, std::uint16_t stream_id, std::uint64_t index) const;

  std::size_t records_stored() const noexcept { return records_.size(); }

 private:
  using StreamKey = std::pair<std::uint64_t, std::uint16_t>;
  struct Stored {
    std::uint64_t sample_count = 0;
    std::optional<double> input_revolutions, speed_hz, torque_nm;
    int rms_channel = -1;  ///< protocol channel of rms_raw (-1: not analysed, no RMS stored)
    double rms_raw = 0.0;
  };
  std::map<std::tuple<std::uint64_t, std::uint16_t, std::uint64_t>, Stored> records_;
  std::map<StreamKey, std::uint64_t> stored_until_;  ///< first sample index after the last stored record
};

}  // namespace gearwatch::daemon
