#include "gearwatch/acquisition/protocol_decoder.hpp"

#include <cstring>

namespace gearwatch::acquisition {
namespace {

template <typename T>
T read_le(const std::uint8_t* p) noexcept {
  // All protocol integers are little-endian; this host is too (x86_64/aarch64 Linux), but keep
  // the byte order explicit so the decoder is right everywhere.
  std::make_unsigned_t<T> v = 0;
  for (std::size_t i = 0; i < sizeof(T); ++i) v |= static_cast<std::make_unsigned_t<T>>(p[i]) << (8 * i);
  T out;
  std::memcpy(&out, &v, sizeof out);
  return out;
}

float read_f32(const std::uint8_t* p) noexcept {
  const std::uint32_t bits = read_le<std::uint32_t>(p);
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

FrameRejection reject(RejectKind kind, std::string reason) { return {kind, std::move(reason)}; }

}  // namespace

const char* to_string(RejectKind kind) noexcept {
  switch (kind) {
    case RejectKind::malformed_frame: return "malformed_frame";
    case RejectKind::unknown_frame: return "unknown_frame";
    case RejectKind::duplicate_frame: return "duplicate_frame";
    case RejectKind::tacho_out_of_order: return "tacho_out_of_order";
    case RejectKind::life_counter_reset: return "life_counter_reset";
    case RejectKind::unsupported_version: return "unsupported_version";
    case RejectKind::malformed_line: return "malformed_line";
  }
  return "unknown";
}

ProtocolDecoder::ProtocolDecoder(ProtocolIds ids, std::uint8_t channel_mask, std::uint8_t shaft_mask, EventSink sink)
    : ids_(ids), channel_mask_(channel_mask), shaft_mask_(shaft_mask), sink_(std::move(sink)) {}

std::uint64_t ProtocolDecoder::unwrap(std::uint32_t index) noexcept {
  if (!have_reference_) {
    have_reference_ = true;
    reference_index_ = index;
    return index;
  }
  // The nearest 64-bit value with these low 32 bits: a u32 wrap-around (~12 h at 100 kHz) is
  // normal and must not look like a jump.
  const auto delta = static_cast<std::int32_t>(index - static_cast<std::uint32_t>(reference_index_));
  const std::int64_t candidate = static_cast<std::int64_t>(reference_index_) + delta;
  return candidate < 0 ? index : static_cast<std::uint64_t>(candidate);
}

RejectReason ProtocolDecoder::decode(const CanFrame& frame) {
  counters_.frames.fetch_add(1, std::memory_order_relaxed);
  if (frame.extended || frame.remote || frame.error) {
    counters_.unknown_ids.fetch_add(1, std::memory_order_relaxed);
    return reject(RejectKind::unknown_frame, "not a protocol frame (extended, remote or error frame)");
  }
  const std::uint32_t id = frame.id;
  if (id >= ids_.vibration_base && id < ids_.vibration_base + 8) return on_samples(frame, id - ids_.vibration_base);
  if (id >= ids_.tacho_base && id < ids_.tacho_base + 4) return on_tacho(frame, id - ids_.tacho_base);
  if (id == ids_.stream_header) return on_header(frame);
  if (id == ids_.operating_condition) return on_condition(frame);
  if (id == ids_.life_counter) return on_life_counter(frame);
  counters_.unknown_ids.fetch_add(1, std::memory_order_relaxed);
  return std::nullopt;  // unknown ids are normal on a shared bus: counted, not logged
}

RejectReason ProtocolDecoder::on_samples(const CanFrame& frame, unsigned channel) {
  if (frame.len < 4 || (frame.len - 4) % 2 != 0) {
    counters_.malformed_frames.fetch_add(1, std::memory_order_relaxed);
    return reject(RejectKind::malformed_frame,
                  "vibration frame of " + std::to_string(frame.len) + " bytes does not fit u32 index + i16 samples");
  }
  const unsigned n = (frame.len - 4u) / 2u;
  if (!(channel_mask_ & (1u << channel))) {
    counters_.unconfigured_channel_frames.fetch_add(1, std::memory_order_relaxed);
    return std::nullopt;
  }
  if (!in_stream_) {
    counters_.frames_before_header.fetch_add(1, std::memory_order_relaxed);
    return std::nullopt;
  }
  counters_.sample_frames.fetch_add(1, std::memory_order_relaxed);
  if (n == 0) return std::nullopt;
  const std::uint64_t first = unwrap(read_le<std::uint32_t>(frame.data.data()));
  auto& next = next_index_[channel];
  if (next) {
    if (first < *next) {
      counters_.duplicates.fetch_add(1, std::memory_order_relaxed);
      return reject(RejectKind::duplicate_frame, "channel " + std::to_string(channel) +
                                                     ": repeated or out-of-order frame at index " + std::to_string(first) +
                                                     " (expected " + std::to_string(*next) + "), dropped");
    }
    if (first > *next) {
      const std::uint64_t missing = first - *next;
      counters_.dropouts.fetch_add(1, std::memory_order_relaxed);
      counters_.dropout_samples.fetch_add(missing, std::memory_order_relaxed);
      AcquisitionEvent dropout;
      dropout.kind = EventKind::dropout;
      dropout.channel = static_cast<std::uint8_t>(channel);
      dropout.index = *next;
      dropout.missing = missing;
      sink_(dropout);
    }
  }
  next = first + n;
  if (first + n > reference_index_) reference_index_ = first + n - 1;

  scratch_.kind = EventKind::samples;
  scratch_.channel = static_cast<std::uint8_t>(channel);
  scratch_.count = static_cast<std::uint8_t>(n);
  scratch_.index = first;
  for (unsigned i = 0; i < n; ++i) scratch_.samples[i] = read_le<std::int16_t>(frame.data.data() + 4 + 2 * i);
  counters_.samples.fetch_add(n, std::memory_order_relaxed);
  sink_(scratch_);
  return std::nullopt;
}

RejectReason ProtocolDecoder::on_tacho(const CanFrame& frame, unsigned shaft) {
  if (frame.len != 8) {
    counters_.malformed_frames.fetch_add(1, std::memory_order_relaxed);
    return reject(RejectKind::malformed_frame, "tacho frame of " + std::to_string(frame.len) + " bytes (must be 8)");
  }
  if (!(shaft_mask_ & (1u << shaft))) {
    counters_.unconfigured_channel_frames.fetch_add(1, std::memory_order_relaxed);
    return std::nullopt;
  }
  if (!in_stream_) {
    counters_.frames_before_header.fetch_add(1, std::memory_order_relaxed);
    return std::nullopt;
  }
  const std::uint64_t whole = unwrap(read_le<std::uint32_t>(frame.data.data()));
  const double fraction = read_le<std::uint32_t>(frame.data.data() + 4) / 4294967296.0;
  const double position = static_cast<double>(whole) + fraction;
  auto& last = last_edge_[shaft];
  if (last && position <= *last) {
    counters_.tacho_out_of_order.fetch_add(1, std::memory_order_relaxed);
    return reject(RejectKind::tacho_out_of_order, "shaft " + std::to_string(shaft) + ": tacho edge not after the previous one, dropped");
  }
  last = position;
  counters_.tacho_edges.fetch_add(1, std::memory_order_relaxed);
  AcquisitionEvent edge;
  edge.kind = EventKind::tacho_edge;
  edge.channel = static_cast<std::uint8_t>(shaft);
  edge.index = whole;
  edge.fraction = fraction;
  sink_(edge);
  return std::nullopt;
}

RejectReason ProtocolDecoder::on_header(const CanFrame& frame) {
  if (frame.len != 8) {
    counters_.malformed_frames.fetch_add(1, std::memory_order_relaxed);
    return reject(RejectKind::malformed_frame, "stream header of " + std::to_string(frame.len) + " bytes (must be 8)");
  }
  const auto rate = read_le<std::uint32_t>(frame.data.data());
  const std::uint8_t channels = frame.data[4];
  const std::uint8_t version = frame.data[5];
  const auto stream = read_le<std::uint16_t>(frame.data.data() + 6);
  if (version != 1) {
    counters_.unsupported_version.fetch_add(1, std::memory_order_relaxed);
    return reject(RejectKind::unsupported_version,
                  "stream header with protocol version " + std::to_string(version) + " (this receiver speaks 1)");
  }
  if (rate == 0) {
    counters_.malformed_frames.fetch_add(1, std::memory_order_relaxed);
    return reject(RejectKind::malformed_frame, "stream header with sample rate 0");
  }
  if (in_stream_ && stream == stream_id_ && rate == sample_rate_hz_) return std::nullopt;  // periodic repeat
  if (in_stream_) counters_.stream_changes.fetch_add(1, std::memory_order_relaxed);
  in_stream_ = true;
  stream_id_ = stream;
  sample_rate_hz_ = rate;
  next_index_.fill(std::nullopt);
  last_edge_.fill(std::nullopt);
  // A new stream's clock need not continue the old one. Until its first sample frame, frames
  // placed at "the latest index" (life counter, condition without index) belong at its start:
  // index 0 is not after any of its samples, never the old stream's latest index.
  have_reference_ = false;
  reference_index_ = 0;
  AcquisitionEvent start;
  start.kind = EventKind::stream_start;
  start.stream_id = stream;
  start.sample_rate_hz = rate;
  start.channel_count = channels;
  sink_(start);
  return std::nullopt;
}

RejectReason ProtocolDecoder::on_condition(const CanFrame& frame) {
  if (frame.len != 8 && frame.len != 12) {
    counters_.malformed_frames.fetch_add(1, std::memory_order_relaxed);
    return reject(RejectKind::malformed_frame,
                  "operating-condition frame of " + std::to_string(frame.len) + " bytes (must be 8 or 12)");
  }
  if (!in_stream_) {
    counters_.frames_before_header.fetch_add(1, std::memory_order_relaxed);
    return std::nullopt;
  }
  AcquisitionEvent c;
  c.kind = EventKind::condition;
  c.condition.torque_nm = read_f32(frame.data.data());
  c.condition.speed_hz = read_f32(frame.data.data() + 4);
  c.index = frame.len == 12 ? unwrap(read_le<std::uint32_t>(frame.data.data() + 8)) : reference_index_;
  sink_(c);
  return std::nullopt;
}

RejectReason ProtocolDecoder::on_life_counter(const CanFrame& frame) {
  if (frame.len != 8) {
    counters_.malformed_frames.fetch_add(1, std::memory_order_relaxed);
    return reject(RejectKind::malformed_frame, "life-counter frame of " + std::to_string(frame.len) + " bytes (must be 8)");
  }
  if (!in_stream_) {
    counters_.frames_before_header.fetch_add(1, std::memory_order_relaxed);
    return std::nullopt;
  }
  const auto revs = read_le<std::uint64_t>(frame.data.data());
  RejectReason reason;
  if (last_life_counter_ && revs < *last_life_counter_) {
    counters_.life_counter_resets.fetch_add(1, std::memory_order_relaxed);
    AcquisitionEvent reset;
    reset.kind = EventKind::life_counter_reset;
    reset.index = reference_index_;
    reset.life.revolutions = revs;
    reset.life.previous_revolutions = *last_life_counter_;
    sink_(reset);
    reason = reject(RejectKind::life_counter_reset, "life counter went backwards from " + std::to_string(*last_life_counter_) +
                                                        " to " + std::to_string(revs) +
                                                        " revolutions: gear change or front-end fault, recorded");
  }
  last_life_counter_ = revs;
  AcquisitionEvent life;
  life.kind = EventKind::life_counter;
  life.index = reference_index_;
  life.life.revolutions = revs;
  life.life.previous_revolutions = 0;
  sink_(life);
  return reason;
}

}  // namespace gearwatch::acquisition
