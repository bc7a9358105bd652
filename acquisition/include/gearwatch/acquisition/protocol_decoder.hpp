#pragma once
// Rig CAN protocol v1 decoder (docs/can-protocol.md): validates each frame against the
// receiver rules and turns it into AcquisitionEvents on one 64-bit sample clock.
// Runs on the acquisition thread; counters are atomics so any thread may read them.
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "gearwatch/acquisition/can_frame.hpp"
#include "gearwatch/acquisition/events.hpp"

namespace gearwatch::acquisition {

struct ProtocolIds {
  std::uint32_t vibration_base = 0x100;  ///< + channel 0..7
  std::uint32_t tacho_base = 0x180;      ///< + shaft 0..3
  std::uint32_t stream_header = 0x1F0;
  std::uint32_t operating_condition = 0x1F1;
  std::uint32_t life_counter = 0x1F2;
};

/// Every way a frame can be rejected or a stream can be disturbed, counted.
struct DecoderCounters {
  std::atomic<std::uint64_t> frames{0};              ///< frames seen
  std::atomic<std::uint64_t> sample_frames{0};
  std::atomic<std::uint64_t> samples{0};             ///< samples accepted
  std::atomic<std::uint64_t> malformed_frames{0};    ///< payload does not fit its layout
  std::atomic<std::uint64_t> unknown_ids{0};         ///< ids outside the protocol (and RTR/error/extended frames)
  std::atomic<std::uint64_t> unconfigured_channel_frames{0};  ///< protocol channels not in the config
  std::atomic<std::uint64_t> frames_before_header{0};///< dropped: no stream header seen yet
  std::atomic<std::uint64_t> dropouts{0};            ///< forward index jumps
  std::atomic<std::uint64_t> dropout_samples{0};     ///< samples missing in those jumps
  std::atomic<std::uint64_t> duplicates{0};          ///< repeated or backward sample frames, dropped
  std::atomic<std::uint64_t> tacho_edges{0};
  std::atomic<std::uint64_t> tacho_out_of_order{0};  ///< edges not strictly increasing, dropped
  std::atomic<std::uint64_t> stream_changes{0};      ///< stream starts after the first
  std::atomic<std::uint64_t> life_counter_resets{0}; ///< odometer went backwards
  std::atomic<std::uint64_t> unsupported_version{0}; ///< headers with protocol_version != 1
};

/// What kind of bad input a frame (or a capture line) was; stored as rejected_frames.kind.
enum class RejectKind : std::uint8_t {
  malformed_frame,      ///< payload does not fit its layout
  unknown_frame,        ///< extended, remote or error frame
  duplicate_frame,      ///< repeated or out-of-order sample frame
  tacho_out_of_order,   ///< tacho edge not after the previous one
  life_counter_reset,   ///< odometer went backwards (the frame is used: reported, not dropped)
  unsupported_version,  ///< stream header of another protocol version
  malformed_line,       ///< a capture-file line that is not a candump frame
};
inline constexpr std::array kAllRejectKinds{RejectKind::malformed_frame,     RejectKind::unknown_frame,
                                            RejectKind::duplicate_frame,     RejectKind::tacho_out_of_order,
                                            RejectKind::life_counter_reset,  RejectKind::unsupported_version,
                                            RejectKind::malformed_line};
const char* to_string(RejectKind kind) noexcept;

struct FrameRejection {
  RejectKind kind = RejectKind::malformed_frame;
  std::string reason;   ///< one line for the rate-limited log and the rejected_frames table
};

/// Why a frame was rejected (nullopt when accepted).
using RejectReason = std::optional<FrameRejection>;

class ProtocolDecoder {
 public:
  using EventSink = std::function<void(const AcquisitionEvent&)>;

  /// `channel_mask`: bit c set when vibration channel c is configured; others are counted, not decoded.
  /// `shaft_mask`: likewise for tacho shafts.
  ProtocolDecoder(ProtocolIds ids, std::uint8_t channel_mask, std::uint8_t shaft_mask, EventSink sink);

  /// Decodes one frame. Never throws. Returns the reason when the frame was rejected.
  RejectReason decode(const CanFrame& frame);

  const DecoderCounters& counters() const noexcept { return counters_; }
  bool in_stream() const noexcept { return in_stream_; }

 private:
  std::uint64_t unwrap(std::uint32_t index) noexcept;
  RejectReason on_samples(const CanFrame& frame, unsigned channel);
  RejectReason on_tacho(const CanFrame& frame, unsigned shaft);
  RejectReason on_header(const CanFrame& frame);
  RejectReason on_condition(const CanFrame& frame);
  RejectReason on_life_counter(const CanFrame& frame);

  ProtocolIds ids_;
  std::uint8_t channel_mask_;
  std::uint8_t shaft_mask_;
  EventSink sink_;
  DecoderCounters counters_;

  bool in_stream_ = false;
  std::uint16_t stream_id_ = 0;
  std::uint32_t sample_rate_hz_ = 0;
  bool have_reference_ = false;
  std::uint64_t reference_index_ = 0;   ///< latest unwrapped index seen, for unwrapping
  std::array<std::optional<std::uint64_t>, 8> next_index_{};
  std::array<std::optional<double>, 4> last_edge_{};
  std::optional<std::uint64_t> last_life_counter_;
  AcquisitionEvent scratch_;
};

}  // namespace gearwatch::acquisition
