#include "gearwatch/acquisition/record_assembler.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace gearwatch::acquisition {

const char* to_string(ChannelStatus status) noexcept {
  switch (status) {
    case ChannelStatus::missing_from_stream: return "missing_from_stream";
    case ChannelStatus::stopped: return "stopped";
    case ChannelStatus::resumed: return "resumed";
    case ChannelStatus::silent: return "silent";
  }
  return "unknown";
}

const char* to_string(TachoStatus status) noexcept {
  return status == TachoStatus::resumed ? "resumed" : "missing";
}

RecordAssembler::RecordAssembler(const GearboxSpec& rig, Callbacks callbacks) : rig_(rig), callbacks_(std::move(callbacks)) {
  slot_of_channel_.fill(-1);
  for (std::size_t i = 0; i < rig_.channels.size(); ++i) {
    slot_of_channel_.at(static_cast<std::size_t>(rig_.channels[i].number)) = static_cast<int>(i);
    scale_of_slot_.at(i) = rig_.channels[i].scale_m_s2_per_lsb;
  }
  for (const auto& t : rig_.tachos) {
    if (t.ratio_to_input == 1.0 && input_tacho_shaft_ < 0) {
      input_tacho_shaft_ = t.shaft;
      input_edges_per_rev_ = std::max(1, t.edges_per_rev);
    }
  }
}

void RecordAssembler::consume(const AcquisitionEvent& e) {
  switch (e.kind) {
    case EventKind::stream_start:
      on_stream_start(e);
      break;
    case EventKind::samples:
      on_samples(e);
      break;
    case EventKind::tacho_edge:
      on_tacho_edge(e);
      break;
    case EventKind::condition:
      torque_ = e.condition.torque_nm;
      speed_ = e.condition.speed_hz;
      have_condition_ = true;
      break;
    case EventKind::life_counter:
      life_revolutions_ = e.life.revolutions;
      life_index_ = e.index;
      edges_since_life_ = 0;
      break;
    case EventKind::life_counter_reset:
      last_revolutions_.reset();  // a new gear pair counts from its own start
      if (callbacks_.on_life_counter_reset)
        callbacks_.on_life_counter_reset({e.index, e.life.previous_revolutions, e.life.revolutions});
      break;
    case EventKind::dropout: {
      const int slot = e.channel < 8 ? slot_of_channel_[e.channel] : -1;
      if (slot >= 0) next_seen_[static_cast<std::size_t>(slot)] = e.index + e.missing;
      dropout_end_ = std::max(dropout_end_, e.index + e.missing);
      if (callbacks_.on_dropout) callbacks_.on_dropout({e.channel, e.index, e.missing, DropoutCause::protocol});
      break;
    }
  }
}

void RecordAssembler::on_tacho_edge(const AcquisitionEvent& e) {
  if (!in_stream_ || e.channel >= kMaxShafts) return;
  auto& q = edges_[e.channel];
  q.push_back(static_cast<double>(e.index) + e.fraction);
  // Keep only what a record can still need: edges from the record in progress on.
  const double keep_from = static_cast<double>(open_.active ? open_.start : next_start_.value_or(0));
  while (!q.empty() && q.front() < keep_from && q.size() > 1) q.pop_front();
  // The odometer already includes a revolution completed at its own index.
  if (e.channel == input_tacho_shaft_ && (!life_index_ || static_cast<double>(e.index) + e.fraction > static_cast<double>(*life_index_)))
    ++edges_since_life_;
  last_edge_[e.channel] = e.index;
  if (tacho_missing_[e.channel]) {
    tacho_missing_[e.channel] = false;
    if (callbacks_.on_tacho_status) callbacks_.on_tacho_status({e.channel, TachoStatus::resumed, e.index});
  }
  note_progress(e.index, e.index);
  check_silent_channels();
}

void RecordAssembler::note_progress(std::uint64_t first, std::uint64_t last) {
  if (!stream_origin_) stream_origin_ = first;
  latest_index_ = std::max(latest_index_, last);
}

void RecordAssembler::check_silent_channels() {
  // Between channels, place_samples sees one fall behind the others. When none delivers at all,
  // only the tacho's clock shows the stream going on without them. They are reported, and the
  // record in progress waits as before: when samples come back, a dropout cuts it as usual.
  bool any_active = false;
  for (std::size_t slot = 0; slot < rig_.channels.size(); ++slot) {
    if (slot_state_[slot] != SlotState::active || silence_reported_[slot]) continue;
    any_active = true;
    if (latest_index_ <= next_seen_[slot].value_or(*stream_origin_) + slack_) return;
  }
  if (!any_active) return;
  for (std::size_t slot = 0; slot < rig_.channels.size(); ++slot) {
    if (slot_state_[slot] != SlotState::active || silence_reported_[slot]) continue;
    silence_reported_[slot] = true;
    ++counters_.channels_stopped;
    const auto status = next_seen_[slot] ? ChannelStatus::stopped : ChannelStatus::silent;
    if (callbacks_.on_channel_status)
      callbacks_.on_channel_status({rig_.channels[slot].number, status, next_seen_[slot].value_or(*stream_origin_)});
  }
}

void RecordAssembler::check_tachos() {
  // A gearbox at rest (the speed frame below the rig's range) has no edges to miss.
  if (have_condition_ && !(speed_ >= rig_.min_speed_hz)) return;
  for (const auto& t : rig_.tachos) {
    if (t.shaft < 0 || t.shaft >= kMaxShafts) continue;
    const auto shaft = static_cast<std::size_t>(t.shaft);
    if (tacho_missing_[shaft]) continue;
    const std::uint64_t since = last_edge_[shaft].value_or(*stream_origin_);
    if (latest_index_ <= since + tacho_silence_limit_[shaft]) continue;
    tacho_missing_[shaft] = true;
    ++counters_.tachos_missing;
    if (callbacks_.on_tacho_status) callbacks_.on_tacho_status({t.shaft, TachoStatus::missing, since});
  }
}

void RecordAssembler::on_stream_start(const AcquisitionEvent& e) {
  if (open_.active) finalize(RecordEnd::stream_end);
  in_stream_ = true;
  stream_.stream_id = e.stream_id;
  stream_.sample_rate_hz = e.sample_rate_hz;
  stream_.channel_count = e.channel_count;
  ++stream_.sequence;
  const double fs = e.sample_rate_hz;
  length_ = std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(rig_.schedule.length_s * fs)));
  interval_ = std::max(length_, static_cast<std::size_t>(std::llround(rig_.schedule.interval_s * fs)));
  min_length_ = static_cast<std::size_t>(std::llround(rig_.schedule.min_length_s * fs));
  slack_ = static_cast<std::size_t>(fs);  // a channel more than 1 s behind the others has stopped
  for (const auto& t : rig_.tachos) {
    if (t.shaft < 0 || t.shaft >= kMaxShafts) continue;
    // Two edge intervals at the slowest speed the rig runs at, and never less than the slack.
    const double edge_hz = rig_.min_speed_hz * t.ratio_to_input * std::max(1, t.edges_per_rev);
    const double limit = edge_hz > 0 ? std::ceil(2.0 * fs / edge_hz) : 0.0;
    tacho_silence_limit_[static_cast<std::size_t>(t.shaft)] =
        std::max<std::uint64_t>(slack_, limit < 1e15 ? static_cast<std::uint64_t>(limit) : std::uint64_t{1'000'000'000'000'000});
  }
  stream_origin_.reset();
  latest_index_ = 0;
  last_edge_.fill(std::nullopt);
  silence_reported_.fill(false);
  last_revolutions_.reset();
  edge_rate_fault_.clear();
  next_start_.reset();
  scheduled_start_.reset();
  dropout_end_ = 0;
  next_seen_.fill(std::nullopt);
  for (auto& p : pending_) p.clear();
  for (auto& q : edges_) q.clear();
  have_condition_ = false;
  // The odometer reading and the edges counted since it carry over: the shaft did not stop
  // turning because the front-end restarted its stream. The new stream's clock is unrelated to
  // the old one, so every edge of it counts from here (until the next life-counter frame).
  life_index_.reset();
  if (callbacks_.on_stream) callbacks_.on_stream(stream_);
  // Honour the header: configured channels beyond its channel count are not in this stream.
  for (std::size_t slot = 0; slot < rig_.channels.size(); ++slot) {
    const bool announced = rig_.channels[slot].number < static_cast<int>(e.channel_count);
    slot_state_[slot] = SlotState::active;
    if (!announced) set_slot_state(slot, SlotState::absent, ChannelStatus::missing_from_stream, 0);
  }
}

void RecordAssembler::set_slot_state(std::size_t slot, SlotState state, ChannelStatus status, std::uint64_t index) {
  slot_state_[slot] = state;
  if (status == ChannelStatus::stopped && silence_reported_[slot]) {
    silence_reported_[slot] = false;  // already reported by the tacho's clock; the slot state tracks it now
    return;
  }
  if (status == ChannelStatus::stopped) ++counters_.channels_stopped;
  if (callbacks_.on_channel_status) callbacks_.on_channel_status({rig_.channels[slot].number, status, index});
}

void RecordAssembler::open_record(std::uint64_t start) {
  open_.active = true;
  open_.start = start;
  open_.cut = length_;
  open_.buffers.resize(rig_.channels.size());
  for (auto& b : open_.buffers) {
    b.clear();
    b.reserve(length_);
  }
  open_.regular_next = scheduled_start_ ? *scheduled_start_ : start + interval_;
  // A channel whose frames came back joins now, at a record boundary, never in mid-record.
  for (std::size_t slot = 0; slot < rig_.channels.size(); ++slot)
    if (slot_state_[slot] == SlotState::rejoining) slot_state_[slot] = SlotState::active;
  open_.torque = torque_;
  open_.speed = speed_;
  open_.have_condition = have_condition_;
  open_.revolutions.reset();
  if (life_revolutions_) {
    // Edges already received past the record's first sample are not yet revolutions at its start.
    std::uint64_t ahead = 0;
    if (input_tacho_shaft_ >= 0)
      for (double edge : edges_[static_cast<std::size_t>(input_tacho_shaft_)])
        if (edge > static_cast<double>(start)) ++ahead;
    const std::uint64_t counted = edges_since_life_ > ahead ? edges_since_life_ - ahead : 0;
    open_.revolutions = static_cast<double>(*life_revolutions_) +
                        static_cast<double>(counted) / static_cast<double>(input_edges_per_rev_);
  }
}

std::size_t RecordAssembler::filled_min() const noexcept {
  std::size_t m = std::numeric_limits<std::size_t>::max();
  bool any = false;
  for (std::size_t slot = 0; slot < open_.buffers.size(); ++slot) {
    if (slot_state_[slot] != SlotState::active) continue;
    m = std::min(m, open_.buffers[slot].size());
    any = true;
  }
  return any ? m : 0;
}

void RecordAssembler::on_samples(const AcquisitionEvent& e) {
  if (!in_stream_ || e.channel >= 8) return;
  const int slot = slot_of_channel_[e.channel];
  if (slot < 0 || e.count == 0) return;
  const auto s = static_cast<std::size_t>(slot);

  // Continuity as seen after the ring: a jump the decoder did not announce was lost in the ring.
  if (next_seen_[s] && e.index > *next_seen_[s]) {
    const std::uint64_t missing = e.index - *next_seen_[s];
    ++counters_.ring_dropouts;
    counters_.ring_dropout_samples += missing;
    if (callbacks_.on_dropout) callbacks_.on_dropout({e.channel, *next_seen_[s], missing, DropoutCause::ring_overflow});
    dropout_end_ = std::max(dropout_end_, e.index);
  }
  next_seen_[s] = e.index + e.count;
  note_progress(e.index, e.index + e.count);
  check_tachos();
  if (silence_reported_[s]) {
    silence_reported_[s] = false;
    if (callbacks_.on_channel_status) callbacks_.on_channel_status({e.channel, ChannelStatus::resumed, e.index});
  }
  if (slot_state_[s] == SlotState::absent) set_slot_state(s, SlotState::rejoining, ChannelStatus::resumed, e.index);
  if (slot_state_[s] == SlotState::rejoining && open_.active) {
    pending_[s].push_back(e);  // for the next record; what falls before its start is dropped there
    return;
  }
  place_samples(s, e, 0);
}

void RecordAssembler::place_samples(std::size_t s, const AcquisitionEvent& e, std::size_t offset) {
  const std::uint64_t first = e.index;
  const std::size_t count = e.count;
  while (offset < count) {
    const std::uint64_t idx = first + offset;
    if (!open_.active) {
      if (!next_start_) next_start_ = idx;
      if (idx + (count - offset) <= *next_start_) return;  // before the next scheduled record
      // Start at the schedule, or later when the samples at the scheduled start are missing.
      std::uint64_t start = std::max(*next_start_, idx);
      if (scheduled_start_ && start + length_ > *scheduled_start_) {
        // The restart after a dropout no longer fits a whole record before the schedule: keep to it.
        next_start_ = scheduled_start_;
        scheduled_start_.reset();
        if (idx + (count - offset) <= *next_start_) return;
        start = std::max(*next_start_, idx);
      } else if (scheduled_start_) {
        ++counters_.records_restarted_after_dropout;
      }
      open_record(start);
    }
    auto& buf = open_.buffers[s];
    const std::uint64_t expected = open_.start + buf.size();
    const std::size_t target = std::min(open_.cut, length_);
    if (buf.size() >= target) {
      // This channel is ahead of the others: keep the rest for the next record.
      AcquisitionEvent rest = e;
      rest.index = idx;
      rest.count = static_cast<std::uint8_t>(count - offset);
      std::copy(e.samples.begin() + static_cast<std::ptrdiff_t>(offset), e.samples.begin() + static_cast<std::ptrdiff_t>(count),
                rest.samples.begin());
      pending_[s].push_back(rest);
      if (filled_min() >= target) {
        // Every channel has reached the (possibly dropout-shortened) end.
        finalize(open_.cut < length_ ? RecordEnd::cut_at_dropout : RecordEnd::complete);
        flush_pending();
      } else if (idx > open_.start + target + slack_) {
        // Another channel fell silent for longer than the slack: it is cut out of the record
        // (and of the next ones until its frames come back); the channels that deliver keep
        // their record.
        for (std::size_t k = 0; k < open_.buffers.size(); ++k)
          if (slot_state_[k] == SlotState::active && open_.buffers[k].size() < target)
            set_slot_state(k, SlotState::absent, ChannelStatus::stopped, open_.start + open_.buffers[k].size());
        finalize(open_.cut < length_ ? RecordEnd::cut_at_dropout : RecordEnd::complete);
        flush_pending();
      }
      return;
    }
    if (idx < expected) {  // overlaps what this record already holds (a re-anchored start)
      offset += static_cast<std::size_t>(std::min<std::uint64_t>(expected - idx, count - offset));
      continue;
    }
    if (idx > expected) {
      bool empty = true;
      for (std::size_t k = 0; k < open_.buffers.size(); ++k)
        empty = empty && (slot_state_[k] != SlotState::active || open_.buffers[k].empty());
      if (empty) {
        open_.start = idx;  // nothing collected yet: the record simply starts after the hole
      } else {
        open_.cut = std::min(open_.cut, buf.size());
        continue;  // re-evaluate against the shortened target
      }
    }
    const std::size_t take = std::min(target - buf.size(), count - offset);
    const double scale = scale_of_slot_[s];
    for (std::size_t i = 0; i < take; ++i) buf.push_back(static_cast<float>(e.samples[offset + i] * scale));
    offset += take;
    if (filled_min() >= std::min(open_.cut, length_)) {
      finalize(open_.cut < length_ ? RecordEnd::cut_at_dropout : RecordEnd::complete);
      flush_pending();
    }
  }
}

void RecordAssembler::flush_pending() {
  for (std::size_t s = 0; s < pending_.size(); ++s) {
    if (pending_[s].empty()) continue;
    std::vector<AcquisitionEvent> held;
    held.swap(pending_[s]);
    for (const auto& ev : held) place_samples(s, ev, 0);
  }
}

void RecordAssembler::finalize(RecordEnd end) {
  const std::size_t n = std::min({open_.cut, length_, filled_min()});
  // Samples already handed to this record past n are dropped with it: a restart can only begin
  // where every channel still has its samples.
  std::size_t consumed = n;
  for (const auto& b : open_.buffers) consumed = std::max(consumed, b.size());
  if (end == RecordEnd::complete && n < length_) end = RecordEnd::stream_end;
  Record r;
  r.stream_id = stream_.stream_id;
  r.sample_rate_hz = stream_.sample_rate_hz;
  r.start_index = open_.start;
  r.end = end;
  for (std::size_t slot = 0; slot < open_.buffers.size(); ++slot) {
    if (slot_state_[slot] != SlotState::active) continue;  // absent from the stream, or stopped
    r.channels.push_back(std::move(open_.buffers[slot]));
    r.channels.back().resize(n);
    r.channel_numbers.push_back(rig_.channels[slot].number);
  }
  const double lo = static_cast<double>(open_.start);
  const double hi = lo + static_cast<double>(n);
  for (int shaft = 0; shaft < kMaxShafts; ++shaft) {
    for (double edge : edges_[static_cast<std::size_t>(shaft)])
      if (edge >= lo && edge < hi) r.tacho_edges[static_cast<std::size_t>(shaft)].push_back(edge - lo);
  }
  if (open_.have_condition) {
    r.torque_nm = open_.torque;
    r.speed_hz = open_.speed;
  }
  r.input_revolutions = open_.revolutions;
  if (!r.input_revolutions && life_revolutions_ && life_index_ && *life_index_ >= open_.start && input_tacho_shaft_ >= 0) {
    // The first odometer reading came inside the record: count back to the record's start.
    std::uint64_t between = 0;
    for (double edge : edges_[static_cast<std::size_t>(input_tacho_shaft_)])
      if (edge > lo && edge <= static_cast<double>(*life_index_)) ++between;
    r.input_revolutions = static_cast<double>(*life_revolutions_) - static_cast<double>(between) / input_edges_per_rev_;
  }
  check_cycle_count(r);
  const bool analysable = n >= min_length_ && n > 0;
  if (!analysable) ++counters_.records_rejected;
  else if (end == RecordEnd::complete) ++counters_.records_complete;
  else ++counters_.records_cut;
  next_start_ = open_.regular_next;
  scheduled_start_.reset();
  if (!analysable && end == RecordEnd::cut_at_dropout) {
    // A too-short record cut at a dropout would cost a whole interval of monitoring: start again
    // right after the dropout when a full record fits before the schedule's next start.
    const std::uint64_t restart = std::max(open_.start + consumed, dropout_end_);
    if (restart + length_ <= open_.regular_next) {
      next_start_ = restart;
      scheduled_start_ = open_.regular_next;
    }
  }
  open_.active = false;
  open_.buffers.clear();
  if (callbacks_.on_record) callbacks_.on_record(std::move(r), analysable);
}

void RecordAssembler::check_cycle_count(Record& r) {
  if (!r.input_revolutions) return;
  char detail[320];
  const double revolutions = *r.input_revolutions;
  // The tacho against the speed frame: a wrong edges_per_rev scales every count made from it.
  // A record too short (or too slow) to hold two edges keeps the verdict of the stream's last one.
  if (input_tacho_shaft_ >= 0 && open_.have_condition && open_.speed >= rig_.min_speed_hz) {
    const auto& edges = r.tacho_edges[static_cast<std::size_t>(input_tacho_shaft_)];
    if (edges.size() >= 2 && edges.back() > edges.front()) {
      const double tacho_hz = static_cast<double>(edges.size() - 1) / input_edges_per_rev_ /
                              ((edges.back() - edges.front()) / r.sample_rate_hz);
      edge_rate_fault_.clear();
      if (std::abs(tacho_hz / open_.speed - 1.0) > kEdgeRateTolerance) {
        std::snprintf(detail, sizeof detail,
                      "input tacho gives %.6g Hz with edges_per_rev = %d, the speed frame %.6g Hz (more than %.0f%% apart)",
                      tacho_hz, input_edges_per_rev_, static_cast<double>(open_.speed), kEdgeRateTolerance * 100.0);
        edge_rate_fault_ = detail;
      }
    }
  }
  if (!edge_rate_fault_.empty()) {
    std::snprintf(detail, sizeof detail, "%s: revolutions %.10g not used", edge_rate_fault_.c_str(), revolutions);
    r.cycle_fault = CycleCountFault::edge_rate_mismatch;
  } else if (revolutions < 0.0 || (last_revolutions_ && revolutions < *last_revolutions_)) {
    std::snprintf(detail, sizeof detail, "input revolutions %.10g at the record's start, %.10g at the previous record's in this stream: not used",
                  revolutions, last_revolutions_.value_or(0.0));
    r.cycle_fault = CycleCountFault::went_backwards;
  }
  if (r.cycle_fault == CycleCountFault::none) {
    last_revolutions_ = revolutions;
    return;
  }
  ++counters_.cycle_count_faults;
  r.cycle_fault_detail = detail;
  r.input_revolutions.reset();  // a count that failed its check must not place the record in the pair's life
}

void RecordAssembler::finish() {
  if (open_.active) finalize(RecordEnd::stream_end);
}

}  // namespace gearwatch::acquisition
