#pragma once
// Cuts records out of the decoded event stream (processing thread): a record of length L starts
// every interval I on the sample clock (thesis §3.2.2). A record never spans a dropout: it is cut at
// the dropout (kept if at least min_length long, otherwise rejected). After a rejected one, a new
// record starts right after the dropout when a full L fits before the next scheduled start; else the
// schedule continues. A configured channel that the stream does not announce, or whose frames
// stop for more than the slack (1 s), is left out of the records (reported through
// on_channel_status) while the other channels' records go on; it rejoins at the next record
// after its frames come back. When no channel delivers at all, the tacho's edges show the stream
// going on without them: every channel is reported silent (or stopped) once the edges are more
// than the slack past its last sample, and resumed at its next samples. A configured tacho whose edges stop while the samples go
// on is reported missing (on_tacho_status), and back when its edges return.
// A record's input revolutions are checked before they leave: the input tacho's speed must agree
// with the speed frame (kEdgeRateTolerance) and the count must not go backwards within a stream;
// a record that fails carries no revolutions, only the reason (Record::cycle_fault).
// Deterministic: the same event sequence always gives the same records, which is what lets a
// live run and a replay of its capture produce identical databases.
#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/acquisition/events.hpp"
#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/types/dropout_cause.hpp"
#include "gearwatch/types/record.hpp"

namespace gearwatch::acquisition {

struct StreamInfo {
  std::uint16_t stream_id = 0;
  std::uint32_t sample_rate_hz = 0;
  std::uint8_t channel_count = 0;
  std::uint64_t sequence = 0;       ///< 1 for the first stream of this run, then 2, 3...
};

struct DropoutInfo {
  int channel = 0;                  ///< protocol channel number
  std::uint64_t first_missing = 0;  ///< unwrapped sample index
  std::uint64_t missing = 0;        ///< samples
  DropoutCause cause = DropoutCause::protocol;
};

struct LifeCounterReset {
  std::uint64_t index = 0;
  std::uint64_t previous_revolutions = 0;
  std::uint64_t revolutions = 0;
};

/// A configured channel's presence in the stream changed.
enum class ChannelStatus : std::uint8_t {
  missing_from_stream,  ///< the stream header announces fewer channels than this channel's number
  stopped,              ///< its frames stopped: more than the slack (1 s) behind the other channels or the tacho
  resumed,              ///< its frames came back; it is in records again from the next one
  silent,               ///< announced, but no frame of it in this stream while the tacho went on for more than the slack
};
inline constexpr std::array kAllChannelStatuses{ChannelStatus::missing_from_stream, ChannelStatus::stopped,
                                                ChannelStatus::resumed, ChannelStatus::silent};
const char* to_string(ChannelStatus status) noexcept;

struct ChannelStatusChange {
  int channel = 0;                  ///< protocol channel number
  ChannelStatus status = ChannelStatus::stopped;
  std::uint64_t index = 0;          ///< sample index where it was noticed (stream start, last sample held, first sample back)
};

/// A configured tacho's edges stopped while the samples went on, or came back.
enum class TachoStatus : std::uint8_t {
  missing,  ///< no edge for longer than two edge intervals at rig.min_speed_hz (at least the slack) while samples arrive
  resumed,  ///< its edges came back
};
inline constexpr std::array kAllTachoStatuses{TachoStatus::missing, TachoStatus::resumed};
const char* to_string(TachoStatus status) noexcept;

struct TachoStatusChange {
  int shaft = 0;                    ///< protocol shaft number
  TachoStatus status = TachoStatus::missing;
  std::uint64_t index = 0;          ///< its last edge (or the stream's first index) when missing; the edge when resumed
};

/// Largest relative difference allowed between the input tacho's speed over a record (edges /
/// edges_per_rev / time) and the speed frame's: above a motor's slip under load and a record's
/// speed variation, below the error of an edges_per_rev that is wrong by one in ten.
inline constexpr double kEdgeRateTolerance = 0.1;

struct AssemblerCounters {
  std::uint64_t records_complete = 0;
  std::uint64_t records_cut = 0;      ///< cut at a dropout or stream end, analysed
  std::uint64_t records_rejected = 0; ///< shorter than min_length: stored, not analysed
  std::uint64_t ring_dropouts = 0;        ///< discontinuities caused by ring overflow
  std::uint64_t ring_dropout_samples = 0;
  std::uint64_t records_restarted_after_dropout = 0;  ///< records started right after a dropout that cut a too-short one
  std::uint64_t channels_stopped = 0;             ///< channels cut out of records because their frames stopped (or never came)
  std::uint64_t tachos_missing = 0;               ///< times a configured tacho's edges stopped while samples went on
  std::uint64_t cycle_count_faults = 0;           ///< records whose revolutions failed their check (not used)
};

class RecordAssembler {
 public:
  struct Callbacks {
    /// A finished record. `analysable` is false when it is shorter than min_length.
    std::function<void(Record&&, bool analysable)> on_record;
    std::function<void(const StreamInfo&)> on_stream;
    std::function<void(const DropoutInfo&)> on_dropout;
    std::function<void(const LifeCounterReset&)> on_life_counter_reset;
    std::function<void(const ChannelStatusChange&)> on_channel_status;
    std::function<void(const TachoStatusChange&)> on_tacho_status;
  };

  RecordAssembler(const GearboxSpec& rig, Callbacks callbacks);

  void consume(const AcquisitionEvent& event);
  /// End of input (replay EOF or shutdown): the record in progress ends as `stream_end`.
  void finish();

  const AssemblerCounters& counters() const noexcept { return counters_; }

 private:
  struct Open {
    bool active = false;
    std::uint64_t start = 0;
    std::size_t cut = 0;                      ///< valid length limit (L, or the first dropout)
    std::vector<std::vector<float>> buffers;  ///< one per configured channel
    float torque = 0, speed = 0;
    bool have_condition = false;
    std::optional<double> revolutions;
    std::uint64_t regular_next = 0;           ///< the schedule's next start after this record
  };
  enum class SlotState : std::uint8_t { active, absent, rejoining };

  void on_stream_start(const AcquisitionEvent& e);
  void on_samples(const AcquisitionEvent& e);
  void place_samples(std::size_t slot, const AcquisitionEvent& e, std::size_t offset);
  void flush_pending();
  void open_record(std::uint64_t start);
  void finalize(RecordEnd end);
  std::size_t filled_min() const noexcept;
  void set_slot_state(std::size_t slot, SlotState state, ChannelStatus status, std::uint64_t index);
  void note_progress(std::uint64_t first, std::uint64_t last);
  void on_tacho_edge(const AcquisitionEvent& e);
  void check_silent_channels();
  void check_tachos();
  void check_cycle_count(Record& r);

  GearboxSpec rig_;
  Callbacks callbacks_;
  AssemblerCounters counters_;
  std::array<int, 8> slot_of_channel_{};
  std::array<double, 8> scale_of_slot_{};
  int input_tacho_shaft_ = -1;
  int input_edges_per_rev_ = 1;

  StreamInfo stream_;
  bool in_stream_ = false;
  std::size_t length_ = 0, interval_ = 0, min_length_ = 0, slack_ = 0;
  std::optional<std::uint64_t> next_start_;
  std::optional<std::uint64_t> scheduled_start_;  ///< the schedule's start while a restart after a dropout is pending
  std::uint64_t dropout_end_ = 0;                     ///< first index after the latest dropout (any channel)
  std::array<SlotState, 8> slot_state_{};
  std::array<std::optional<std::uint64_t>, 8> next_seen_{};
  std::array<std::deque<double>, kMaxShafts> edges_{};
  std::array<std::vector<AcquisitionEvent>, 8> pending_{};  ///< samples past the open record, per slot
  Open open_;

  float torque_ = 0, speed_ = 0;
  bool have_condition_ = false;
  std::optional<std::uint64_t> life_revolutions_;
  std::optional<std::uint64_t> life_index_;
  std::uint64_t edges_since_life_ = 0;

  std::array<bool, 8> silence_reported_{};       ///< per slot: reported by the tacho's clock, not cut out
  std::optional<std::uint64_t> stream_origin_;  ///< first sample-clock index seen in this stream
  std::uint64_t latest_index_ = 0;              ///< newest sample-clock index seen in this stream
  std::array<std::optional<std::uint64_t>, kMaxShafts> last_edge_{};  ///< per shaft, this stream
  std::array<std::uint64_t, kMaxShafts> tacho_silence_limit_{};       ///< samples without an edge before it is missing
  std::array<bool, kMaxShafts> tacho_missing_{};  ///< kept across streams: the alarm clears on its next edge
  std::optional<double> last_revolutions_;        ///< the previous record's checked count, this stream
  std::string edge_rate_fault_;                   ///< the stream's last edge-rate check, when it failed
};

}  // namespace gearwatch::acquisition
