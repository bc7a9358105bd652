#include "gap_monitor.hpp"

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace gearwatch::daemon {

std::vector<AlertEvent> observe_twin_drift(AlertTracker& tracker, const gap::GapReport& report, AlertHysteresis hysteresis) {
  std::vector<AlertEvent> out;
  for (const gap::FamilyGap& g : report.before) {
    if (!g.resolved) continue;
    const AlertKey key{AlertKind::twin_drift, -1, gap::to_string(g.family)};
    const AlertState* st = tracker.state(key);
    char distance[32];
    std::snprintf(distance, sizeof distance, "%.1f dB", g.distance_db);
    const std::string value = st && st->active ? st->value : std::string(distance);
    std::string attribution = "no candidate effect explains it";
    for (const auto effect : report.chosen)
      for (const auto& c : report.candidates)
        if (c.effect == effect && std::find(c.explains.begin(), c.explains.end(), g.family) != c.explains.end()) {
          attribution = std::string("attributed to ") + gap::to_string(effect);
          break;
        }
    char text[400];
    if (g.significant)
      std::snprintf(text, sizeof text,
                    "the twin and the gearbox differ in %s by %s (%.1f to %.1f dB) on held-out records at %.6g cycles; %s",
                    gap::to_string(g.family), distance, g.distance_interval_db.low, g.distance_interval_db.high,
                    report.input_revolutions, attribution.c_str());
    else
      std::snprintf(text, sizeof text, "the gap in %s is within its interval again (%s) at %.6g cycles", gap::to_string(g.family),
                    distance, report.input_revolutions);
    if (auto e = tracker.observe(key, g.significant, value, text, hysteresis)) out.push_back(std::move(*e));
  }
  return out;
}

GapSchedule::GapSchedule(std::size_t every_records, std::size_t training, std::size_t held_out)
    : every_(every_records), training_(training), held_out_(held_out) {
  if (every_ == 0 || training_ == 0 || held_out_ == 0)
    throw std::invalid_argument("gap schedule: every_records, training_records and held_out_records must be at least 1");
}

double twin_rms_sa_wear_elasticity(const TwinCounterpart& twin, const Record& measured, const wear::WearState& state,
                                   int channel, const GearPairSpec& gears, int harmonics) {
  auto rms_sa_at = [&](double scale) {
    wear::WearState scaled = state;
    for (auto& d : scaled.pinion_depth_m) d *= scale;
    for (auto& d : scaled.gear_depth_m) d *= scale;
    const auto rms = gap::rms_sa_of_record(twin(measured, scaled), channel, gears, harmonics);
    if (!rms)
      throw std::invalid_argument("twin RMS_SA(" + std::to_string(harmonics) + ") is not positive at wear depths x" +
                                  std::to_string(scale) + ": no K_wear sensitivity");
    return *rms;
  };
  return gap::rms_sa_wear_elasticity(rms_sa_at(gap::kElasticityDepthLow), rms_sa_at(gap::kElasticityDepthHigh));
}

std::optional<Record> kept_gap_record(const Record& record, int channel) {
  const auto it = std::find(record.channel_numbers.begin(), record.channel_numbers.end(), channel);
  if (it == record.channel_numbers.end()) return std::nullopt;
  const auto slot = static_cast<std::size_t>(it - record.channel_numbers.begin());
  if (slot >= record.channels.size()) return std::nullopt;
  Record kept;
  kept.stream_id = record.stream_id;
  kept.sample_rate_hz = record.sample_rate_hz;
  kept.start_index = record.start_index;
  kept.channels = {record.channels[slot]};
  kept.channel_numbers = {channel};
  kept.tacho_edges = record.tacho_edges;
  kept.torque_nm = record.torque_nm;
  kept.speed_hz = record.speed_hz;
  kept.input_revolutions = record.input_revolutions;
  return kept;
}

std::uint64_t GapSchedule::next_due_position() const noexcept {
  // Due when since_last reaches every_ and added reaches the window: both grow by one per record.
  const auto window = static_cast<std::int64_t>(training_ + held_out_);
  const std::int64_t wait = std::max<std::int64_t>(
      {static_cast<std::int64_t>(every_) - static_cast<std::int64_t>(since_last_), window - static_cast<std::int64_t>(added_), 1});
  return added_ + static_cast<std::uint64_t>(wait);
}

void GapSchedule::drop_through(std::uint64_t position) {
  while (!samples_.empty() && samples_.front().position <= position) samples_.pop_front();
}

GapSchedule::Step GapSchedule::add(GapSample sample) {
  const std::uint64_t window = training_ + held_out_;
  sample.position = ++added_;
  ++since_last_;
  Step step;
  step.position = added_;
  step.due = since_last_ >= every_ && added_ >= window;
  if (step.due) since_last_ = 0;
  // The next diagnosis (after this one, when due) uses the positions (next - window, next].
  const std::uint64_t next = next_due_position();
  step.keep = added_ + window > next;
  step.drop_through_position = next > window ? next - window : 0;
  if (step.due || step.keep) samples_.push_back(std::move(sample));
  drop_through(step.due ? (added_ > window ? added_ - window : 0) : step.drop_through_position);
  return step;
}

void GapSchedule::restore(std::uint64_t records_added, std::uint64_t since_diagnosis, std::vector<GapSample> kept) {
  added_ = records_added;
  since_last_ = since_diagnosis;
  samples_.clear();
  const std::uint64_t window = training_ + held_out_;
  const std::uint64_t next = next_due_position();
  for (auto& s : kept)
    if (s.position <= added_ && s.position + window > next) samples_.push_back(std::move(s));
}

std::pair<std::vector<const GapSample*>, std::vector<const GapSample*>> GapSchedule::split() const {
  std::pair<std::vector<const GapSample*>, std::vector<const GapSample*>> out;
  const std::size_t window = training_ + held_out_;
  const std::size_t from = samples_.size() > window ? samples_.size() - window : 0;
  const std::size_t n_held = std::min(held_out_, samples_.size() - from);
  for (std::size_t i = from; i < samples_.size(); ++i)
    (i + n_held < samples_.size() ? out.first : out.second).push_back(&samples_[i]);
  return out;
}

GapRun run_gap_diagnosis(const GapHooks& hooks, const std::vector<const GapSample*>& training,
                         const std::vector<const GapSample*>& held_out, double model_k_wear, const GearPairSpec& gears,
                         int rms_sa_harmonics) {
  // Each counterpart carries its sample's place in `kept` as its stream_key (which the diagnosis
  // does not read): the rerun the diagnosis asks for names the counterpart it stands for, and
  // stream ids and start indices alone repeat across captures (each replayed one per process
  // may start at index 0 of stream 1).
  std::vector<const GapSample*> kept;
  auto input_of = [&](const GapSample* s) {
    gap::DiagnosisInput in{*s->measured, hooks.twin(*s->measured, s->state)};
    kept.push_back(s);
    in.twin.stream_key = static_cast<std::int64_t>(kept.size());
    return in;
  };
  std::vector<gap::DiagnosisInput> training_inputs, held_out_inputs;
  for (const GapSample* s : training) training_inputs.push_back(input_of(s));
  for (const GapSample* s : held_out) held_out_inputs.push_back(input_of(s));
  GapCallContext context;
  if (hooks.rerun)
    context.rerun_twin = [&hooks, kept](gap::CandidateEffect effect, const std::vector<double>& values, const Record& like,
                                        double duration_s) {
      if (like.stream_key < 1 || static_cast<std::size_t>(like.stream_key) > kept.size())
        throw std::invalid_argument("gap: no kept record for a twin rerun");
      const GapSample* s = kept[static_cast<std::size_t>(like.stream_key - 1)];
      return hooks.rerun(*s->measured, s->state, effect, values, duration_s);
    };
  GapRun run;
  // K_wear with and without the chosen effects: the twin's wear states came from the model's K_wear.
  if (model_k_wear > 0) {
    try {
      // Channel 0: a counterpart is the twin's one casing channel.
      for (const GapSample* s : held_out)
        context.rms_sa_wear_elasticities.push_back(
            twin_rms_sa_wear_elasticity(hooks.twin, *s->measured, s->state, 0, gears, rms_sa_harmonics));
      context.reference_k_wear = model_k_wear;
    } catch (const std::invalid_argument& e) {
      // The report goes on without K_wear: the twin's RMS_SA cannot tell it here.
      context.rms_sa_wear_elasticities.clear();
      run.k_wear_skipped = e.what();
    }
  }
  run.report = hooks.diagnose(training_inputs, held_out_inputs, context);
  return run;
}

}  // namespace gearwatch::daemon
