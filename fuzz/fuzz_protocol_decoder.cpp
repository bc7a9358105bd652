// libFuzzer target: the protocol v1 frame decoder (acquisition ProtocolDecoder::decode).
// The input is a sequence of frames (see next_frame); the first byte chooses the configured
// channels and shafts. Beyond "never crashes" (ASan, UBSan), it checks that what the decoder
// hands downstream agrees with its own counters and with the receiver rules: sample and dropout
// events of a channel tile its sample clock without overlap, tacho edges strictly increase.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <optional>

#include "gearwatch/acquisition/protocol_decoder.hpp"

namespace acq = gearwatch::acquisition;

namespace {

[[noreturn]] void violated(const char* what) {
  std::fprintf(stderr, "fuzz_protocol_decoder: invariant violated: %s\n", what);
  std::abort();
}

// One frame from the input: [id selector][flags][len][payload]. The id selector lands on the
// protocol's ids most of the time (that is where the decoder's logic is), and anywhere else
// otherwise; flags give fd, extended, remote and error; the payload is zero-padded.
bool next_frame(const std::uint8_t*& p, const std::uint8_t* end, acq::CanFrame& f) {
  if (end - p < 3) return false;
  const std::uint8_t selector = *p++, flags = *p++, len = *p++;
  static constexpr std::uint32_t protocol_ids[] = {0x100, 0x101, 0x102, 0x107, 0x180, 0x181, 0x183,
                                                   0x1F0, 0x1F1, 0x1F2, 0x0FF, 0x108, 0x184, 0x1F3};
  f = acq::CanFrame{};
  f.id = selector < 224 ? protocol_ids[selector % std::size(protocol_ids)] : 0x100u + (selector & 0x1F) * 8u;
  f.fd = flags & 1;
  f.extended = (flags & 0x0E) == 0x02;
  f.remote = (flags & 0x0E) == 0x04;
  f.error = (flags & 0x0E) == 0x06;
  f.len = static_cast<std::uint8_t>(len % 65);
  const std::size_t available = static_cast<std::size_t>(end - p);
  const std::size_t take = f.len < available ? f.len : available;
  for (std::size_t i = 0; i < take; ++i) f.data[i] = p[i];
  p += take;
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t channel_mask = data[0] | 0x01, shaft_mask = (data[0] >> 4) | 0x01;
  struct Seen {
    std::uint64_t samples = 0, sample_events = 0, dropouts = 0, dropout_samples = 0, edges = 0, stream_starts = 0, resets = 0;
    std::optional<std::uint64_t> next_index[8];
    std::optional<double> last_edge[4];
  } seen;
  acq::ProtocolDecoder decoder(acq::ProtocolIds{}, channel_mask, shaft_mask, [&](const acq::AcquisitionEvent& e) {
    switch (e.kind) {
      case acq::EventKind::samples: {
        if (e.channel >= 8 || !(channel_mask & (1u << e.channel))) violated("samples of an unconfigured channel");
        if (e.count == 0 || e.count > acq::kMaxSamplesPerEvent) violated("sample event count out of range");
        auto& next = seen.next_index[e.channel];
        if (next && e.index != *next) violated("sample events of a channel do not continue its clock");
        next = e.index + e.count;
        seen.samples += e.count;
        ++seen.sample_events;
        break;
      }
      case acq::EventKind::dropout: {
        auto& next = seen.next_index[e.channel];
        if (e.channel >= 8 || !next || e.index != *next || e.missing == 0) violated("a dropout that does not start where the channel stopped");
        next = e.index + e.missing;
        ++seen.dropouts;
        seen.dropout_samples += e.missing;
        break;
      }
      case acq::EventKind::tacho_edge: {
        if (e.channel >= 4 || !(shaft_mask & (1u << e.channel))) violated("edge of an unconfigured shaft");
        if (!(e.fraction >= 0.0 && e.fraction < 1.0)) violated("edge fraction outside [0, 1)");
        const double position = static_cast<double>(e.index) + e.fraction;
        auto& last = seen.last_edge[e.channel];
        if (last && !(position > *last)) violated("tacho edges not strictly increasing");
        last = position;
        ++seen.edges;
        break;
      }
      case acq::EventKind::stream_start:
        if (e.sample_rate_hz == 0) violated("a stream with sample rate 0");
        for (auto& n : seen.next_index) n.reset();
        for (auto& l : seen.last_edge) l.reset();
        ++seen.stream_starts;
        break;
      case acq::EventKind::life_counter_reset:
        if (!(e.life.revolutions < e.life.previous_revolutions)) violated("a life-counter reset that does not go backwards");
        ++seen.resets;
        break;
      default:
        break;
    }
  });

  const std::uint8_t* p = data + 1;
  const std::uint8_t* end = data + size;
  acq::CanFrame frame;
  std::uint64_t decoded = 0, rejected = 0;
  while (next_frame(p, end, frame)) {
    ++decoded;
    if (auto reason = decoder.decode(frame)) ++rejected;  // compiles whatever the reason's type
  }

  const auto& c = decoder.counters();
  if (c.frames != decoded) violated("frames counter != frames decoded");
  if (c.samples != seen.samples) violated("samples counter != samples handed downstream");
  if (c.sample_frames < seen.sample_events) violated("fewer sample frames counted than sample events");
  if (c.dropouts != seen.dropouts || c.dropout_samples != seen.dropout_samples) violated("dropout counters != dropout events");
  if (c.tacho_edges != seen.edges) violated("tacho_edges counter != edge events");
  if (c.life_counter_resets != seen.resets) violated("life_counter_resets counter != reset events");
  if (seen.stream_starts != (seen.stream_starts ? 1 + c.stream_changes : 0)) violated("stream starts != 1 + stream_changes");
  if (decoder.in_stream() != (seen.stream_starts > 0)) violated("in_stream() disagrees with the stream starts seen");
  // Every rejection is counted under one of the rejection counters.
  const std::uint64_t rejection_counters = c.malformed_frames + c.duplicates + c.tacho_out_of_order +
                                           c.unsupported_version + c.life_counter_resets + c.unknown_ids;
  if (rejected > rejection_counters) violated("a rejected frame that no counter counts");
  if (rejected > decoded) violated("more rejections than frames");
  return 0;
}
