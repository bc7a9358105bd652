#include "record_processing.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <set>

#include "gearwatch/storage/alert_history.hpp"
#include "gearwatch/storage/processing_history.hpp"
#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::daemon {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double value_or_nan(const dsp::ChannelAnalysis& a, dsp::Indicator indicator) { return a.value(indicator).value_or(kNaN); }

double selected_centre(const dsp::ChannelAnalysis& a) {
  for (const auto& b : a.band_selections)
    if (b.criterion == dsp::BandSelectionCriterion::ics2) return b.centre_hz;
  return kNaN;
}

double selected_value(const dsp::ChannelAnalysis& a) {
  for (const auto& b : a.band_selections)
    if (b.criterion == dsp::BandSelectionCriterion::ics2) return b.value;
  return kNaN;
}



dsp::SpeedEstimationSettings speed_estimation_settings(const GearboxSpec& rig) {
  dsp::SpeedEstimationSettings s;
  s.pinion_teeth = rig.gears.pinion_teeth;
  s.gear_teeth = rig.gears.gear_teeth;
  s.min_speed_hz = rig.min_speed_hz;
  s.max_speed_hz = rig.max_speed_hz;
  return s;
}

// The carrier band this record's analysis could not look at: skipped as above 0.45·fs.
std::optional<dsp::CarrierBand> unseen_band(const dsp::ChannelAnalysis& a) {
  auto above = [&](dsp::Indicator indicator) {
    const auto* s = a.skip_reason(indicator);
    return s != nullptr && s->reason == dsp::SkipReason::band_above_nyquist;
  };
  const bool pitting = above(dsp::Indicator::ics2_low_band), abrasion = above(dsp::Indicator::ics2_high_band);
  if (pitting == abrasion) return std::nullopt;
  return pitting ? dsp::CarrierBand::pitting : dsp::CarrierBand::abrasion;
}

// Adds `p` to the gear pair's wear baseline unless that is complete: both bands with `wanted`
// finite values, or `cap` records (a band the records cannot see never fills).
void extend_wear_baseline(std::vector<dsp::WearHistoryPoint>& base, const dsp::WearHistoryPoint& p, std::size_t wanted,
                          std::size_t cap) {
  std::size_t low = 0, high = 0;
  for (const auto& b : base) low += std::isfinite(b.ics2_low), high += std::isfinite(b.ics2_high);
  if (wanted > 0 && (low < wanted || high < wanted) && base.size() < cap) base.push_back(p);
}

}  // namespace

RecordProcessor::RecordProcessor(const config::GearwatchConfig& config, ProcessorMemory memory)
    : config_(config),
      channels_(config.rig, config.processing, channel_worker_count(config.daemon.channel_workers)),
      estimator_(speed_estimation_settings(config.rig)),
      history_(std::move(memory.wear_history)),
      alerts_(std::move(memory.alerts)),
      baselines_(std::move(memory.baselines)) {
  // The stored history holds the whole gear pair's life: its first records are the baseline.
  for (const auto& [channel, points] : history_)
    for (const auto& p : points)
      extend_wear_baseline(wear_baseline_[channel], p, static_cast<std::size_t>(config_.processing.wear_baseline_records),
                           static_cast<std::size_t>(config_.processing.trend_window_records));
}

void RecordProcessor::check_thresholds(int channel, const dsp::ChannelAnalysis& a, storage::RecordResult& out) {
  const auto& cfg = config_.alerts;
  const auto n = static_cast<std::size_t>(cfg.baseline_records);
  for (const auto& name : cfg.watched_indicators) {
    const auto v = a.value(name);
    if (!v || !std::isfinite(*v)) continue;
    auto& base = baselines_[{channel, name}];
    if (base.size() < n) {
      base.push_back(*v);
      continue;
    }
    double mean = 0.0, m2 = 0.0;
    for (double x : base) mean += x;
    mean /= static_cast<double>(n);
    for (double x : base) m2 += (x - mean) * (x - mean);
    // A baseline of identical values has no scatter: a relative floor keeps it from alerting on
    // the last digit.
    const double sd = std::max(std::sqrt(m2 / static_cast<double>(n - 1)), 1e-3 * std::abs(mean));
    const double limit = mean + cfg.threshold_sigma * sd;
    const bool above = *v > limit;
    char text[256];
    std::snprintf(text, sizeof text, "channel %d: %s = %.4g, %s its baseline %.4g ± %.3g (first %zu records) + %.3g sd = %.4g",
                  channel, name.c_str(), *v, above ? "above" : "back below", mean, sd, n, cfg.threshold_sigma, limit);
    if (auto e = alerts_.observe(AlertKey{AlertKind::indicator_threshold, channel, name}, above, name, text,
                                 AlertHysteresis{cfg.threshold_raise_after_records, cfg.threshold_clear_after_records}))
      out.alerts.push_back(std::move(*e));
  }
}

storage::AlertUpdate RecordProcessor::life_counter_reset(std::uint64_t previous_revolutions, std::uint64_t revolutions) {
  history_.clear();  // a new gear pair, or a fault: never merge histories
  wear_baseline_.clear();
  baselines_.clear();
  storage::AlertUpdate u;
  u.alerts = alerts_.clear_all(AlertKind::wear_mechanism, "life counter reset: the wear verdict belonged to the previous gear pair");
  for (auto& e : alerts_.clear_all(AlertKind::indicator_threshold, "life counter reset: a new baseline is taken"))
    u.alerts.push_back(std::move(e));
  for (auto& [key, state] : alerts_.states())
    if (key.kind == AlertKind::carrier_band_jump) alerts_.mutable_state(key).marker = 0.0;
  u.alerts.push_back(alerts_.occurrence(
      AlertKey{AlertKind::life_counter_reset, -1}, std::to_string(revolutions),
      "life counter went backwards from " + std::to_string(previous_revolutions) + " to " + std::to_string(revolutions) +
          " revolutions: new gear pair or front-end fault; history not merged"));
  u.alert_states = alerts_.take_changed();
  return u;
}

storage::AlertUpdate RecordProcessor::definite_presence(AlertKind kind, int subject, bool present, const std::string& how,
                                                        const std::string& message) {
  storage::AlertUpdate u;
  if (auto e = alerts_.observe(AlertKey{kind, subject}, !present, how, message, AlertHysteresis{1, 1}))
    u.alerts.push_back(std::move(*e));
  u.alert_states = alerts_.take_changed();
  return u;
}

storage::AlertUpdate RecordProcessor::sensor_presence(int channel, bool present, const std::string& how,
                                                      const std::string& message) {
  // Presence events are definite (the stream header, or frames stopping past the slack): no
  // hysteresis beyond the assembler's own.
  return definite_presence(AlertKind::sensor_missing, channel, present, how, message);
}

storage::AlertUpdate RecordProcessor::tacho_presence(int shaft, bool present, const std::string& how,
                                                     const std::string& message) {
  // Definite like a channel's presence: the assembler already waited two edge intervals.
  return definite_presence(AlertKind::tacho_missing, shaft, present, how, message);
}

storage::AlertUpdate RecordProcessor::stream_sample_rate(std::uint32_t stream_rate_hz, const std::string& message) {
  storage::AlertUpdate u;
  const bool differs = static_cast<double>(stream_rate_hz) != config_.rig.sample_rate_hz;
  if (auto e = alerts_.observe(AlertKey{AlertKind::sample_rate_mismatch, -1}, differs, std::to_string(stream_rate_hz), message,
                               AlertHysteresis{1, 1}))
    u.alerts.push_back(std::move(*e));
  u.alert_states = alerts_.take_changed();
  return u;
}

// The record's shaft angle: the tacho's, checked against the signal's estimate; the estimate's
// when there is no tacho or the two disagree (the estimate is then the better angle: a tacho whose
// mean speed is off slips the mesh phase through the record and wrecks the averages silently,
// while the estimate has just passed its own consistency checks).
RecordSpeed RecordProcessor::establish_speed(const Record& record, storage::RecordResult& out) {
  RecordSpeed speed;
  const TachoSpec* tacho = dsp::input_tacho(config_.rig, record);
  const std::vector<double>* edges = tacho != nullptr ? &record.tacho_edges[static_cast<std::size_t>(tacho->shaft)] : nullptr;
  const double revs_per_edge = tacho != nullptr ? 1.0 / (tacho->edges_per_rev * tacho->ratio_to_input) : 0.0;
  double nominal = std::isfinite(record.speed_hz) && record.speed_hz > 0 ? record.speed_hz : kNaN;
  if (!std::isfinite(nominal) && edges != nullptr && edges->size() >= 2)
    nominal = static_cast<double>(edges->size() - 1) * revs_per_edge * record.sample_rate_hz / (edges->back() - edges->front());
  const dsp::SpeedEstimate* estimate = nullptr;
  for (const auto& channel : record.channels) {
    const dsp::SpeedEstimate& e = estimator_.estimate(channel, record.sample_rate_hz, nominal);
    if (e.ok) {
      estimate = &e;
      break;
    }
    speed.estimate_failure = e.failure;
  }
  if (estimate != nullptr) {
    speed.estimate_failure.clear();
    out.estimated_speed_hz = estimate->mean_speed_hz;
  }
  if (tacho == nullptr) {
    if (estimate != nullptr) {
      speed.source = dsp::SpeedSource::signal_estimate;
      speed.estimated_edges = estimate->edges;
    }
    return speed;
  }
  speed.source = dsp::SpeedSource::tacho;
  if (estimate == nullptr) return speed;  // nothing to check the tacho against
  const dsp::SpeedCheck check =
      dsp::check_tacho(*edges, revs_per_edge, *estimate, record.sample_rate_hz, config_.rig.gears.pinion_teeth);
  observe_speed_check(check, out);
  if (check.source == dsp::SpeedSource::signal_estimate) {
    speed.source = dsp::SpeedSource::signal_estimate;
    speed.estimated_edges = estimate->edges;
  }
  return speed;
}

std::optional<AlertEvent> observe_speed_mismatch(AlertTracker& alerts, const dsp::SpeedCheck& check) {
  char value[32], text[320];
  std::snprintf(value, sizeof value, "%+.2g", check.relative_difference);
  std::snprintf(text, sizeof text,
                "tacho mean speed %.6g Hz, vibration signal %.6g Hz: %+.4f %% (tolerance %.4f %%)%s", check.tacho_speed_hz,
                check.signal_speed_hz, 100.0 * check.relative_difference, 100.0 * check.tolerance,
                !check.mismatch ? "; the tacho agrees again"
                : check.gross   ? "; too far apart for a tacho's error (another line followed?): the record is analysed on the tacho"
                                : "; the record is analysed on the signal's estimate");
  return alerts.observe_measured(AlertKey{AlertKind::tacho_speed_mismatch, -1}, check.mismatch, check.relative_difference, value,
                                 text, AlertHysteresis{1, 1}, kSpeedMismatchReraiseChange);
}

void RecordProcessor::observe_speed_check(const dsp::SpeedCheck& check, storage::RecordResult& out) {
  if (auto e = observe_speed_mismatch(alerts_, check)) out.alerts.push_back(std::move(*e));
}

void RecordProcessor::observe_cycle_count(const Record& record, storage::RecordResult& out) {
  // Only a record that has a count, or had one refused, tells whether the count is sound.
  const bool fault = record.cycle_fault != CycleCountFault::none;
  if (!fault && !record.input_revolutions) return;
  const std::string message = fault ? record.cycle_fault_detail : "input revolutions consistent with the tacho and the speed frame again";
  if (auto e = alerts_.observe(AlertKey{AlertKind::cycle_count_fault, -1}, fault, to_string(record.cycle_fault), message,
                               AlertHysteresis{1, 1}))
    out.alerts.push_back(std::move(*e));
}

void RecordProcessor::observe_channel_alerts(int channel, const dsp::ChannelAnalysis& a, storage::RecordResult& out) {
  const AlertHysteresis sensor{1, config_.alerts.sensor_clear_after_records};
  bool flat_line = false, clipped = false;
  for (const auto& s : a.skipped) {
    flat_line = flat_line || s.reason == dsp::SkipReason::flat_line;
    clipped = clipped || s.reason == dsp::SkipReason::clipped_samples;
  }
  const std::string ch = "channel " + std::to_string(channel);
  if (auto e = alerts_.observe(AlertKey{AlertKind::sensor_flat_line, channel}, flat_line, dsp::to_string(dsp::SkipReason::flat_line),
                               flat_line ? ch + ": the signal is constant — dead sensor, cable or front-end channel"
                                         : ch + ": the signal varies again",
                               sensor))
    out.alerts.push_back(std::move(*e));
  if (auto e = alerts_.observe(AlertKey{AlertKind::sensor_saturated, channel}, clipped, dsp::to_string(dsp::SkipReason::clipped_samples),
                               clipped ? ch + ": more than processing.max_clipped_fraction of the samples at full scale"
                                       : ch + ": no longer saturated",
                               sensor))
    out.alerts.push_back(std::move(*e));
  // A channel that delivers a record is present, whatever the stream said before.
  if (const auto* st = alerts_.state(AlertKey{AlertKind::sensor_missing, channel}); st && st->active)
    if (auto e = alerts_.observe(AlertKey{AlertKind::sensor_missing, channel}, false, "", ch + ": delivers samples again",
                                 AlertHysteresis{1, 1}))
      out.alerts.push_back(std::move(*e));
}

void RecordProcessor::assess_wear(int channel, double cycles, const dsp::ChannelAnalysis& a, storage::RecordResult& out) {
  auto& h = history_[channel];
  h.push_back({cycles, value_or_nan(a, dsp::Indicator::ics2_low_band), value_or_nan(a, dsp::Indicator::ics2_high_band), selected_centre(a),
               selected_value(a)});
  const auto window = static_cast<std::size_t>(config_.processing.trend_window_records);
  auto& base = wear_baseline_[channel];
  extend_wear_baseline(base, h.back(), static_cast<std::size_t>(config_.processing.wear_baseline_records), window);
  if (h.size() > window) h.erase(h.begin(), h.end() - static_cast<std::ptrdiff_t>(window));
  const auto verdict = dsp::identify_wear_mechanism(h, config_.processing, unseen_band(a), base);
  storage::WearAssessment w;
  w.channel = channel;
  w.mechanism = verdict.mechanism;
  w.points = verdict.low_band.points;
  w.low_band_p = verdict.low_band.p_value;
  w.high_band_p = verdict.high_band.p_value;
  w.low_band_rho = verdict.low_band.spearman_rho;
  w.high_band_rho = verdict.high_band.spearman_rho;
  w.band_jumps = verdict.band_jumps.size();
  w.evidence = verdict.evidence;
  w.unseen_band = verdict.unseen_band;

  const std::string ch = "channel " + std::to_string(channel);
  const bool wear = dsp::is_wear(verdict.mechanism);
  const std::string token = dsp::to_string(verdict.mechanism);
  if (auto e = alerts_.observe(AlertKey{AlertKind::wear_mechanism, channel}, wear, token,
                               wear ? ch + ": " + token + " identified — " + verdict.evidence
                                    : ch + ": no wear trend any more (" + token + ") — " + verdict.evidence,
                               AlertHysteresis{1, config_.alerts.wear_clear_after_records}))
    out.alerts.push_back(std::move(*e));
  // Band jumps are occurrences; the marker remembers the last one reported, so neither a later
  // record nor a restarted process reports it again.
  if (!verdict.band_jumps.empty()) {
    const auto& j = verdict.band_jumps.back();
    auto& state = alerts_.mutable_state(AlertKey{AlertKind::carrier_band_jump, channel});
    if (j.cycles > state.marker) {
      state.marker = j.cycles;
      char text[256];
      std::snprintf(text, sizeof text, ": ICS2-selected carrier band moved from %.0f Hz to %.0f Hz at %.6g cycles (ICS2 %.3g -> %.3g)",
                    j.from_hz, j.to_hz, j.cycles, j.from_ics2, j.to_ics2);
      out.alerts.push_back(alerts_.occurrence(AlertKey{AlertKind::carrier_band_jump, channel},
                                              std::to_string(static_cast<long>(j.to_hz)), ch + text));
    }
  }
  out.assessments.push_back(std::move(w));
}

storage::RecordResult RecordProcessor::process(const Record& record, bool analysable, std::uint64_t stream_sequence) {
  storage::RecordResult out;
  out.stream_sequence = stream_sequence;
  out.start_index = record.start_index;
  out.sample_count = record.sample_count();
  out.duration_s = record.duration_s();
  out.end_reason = record.end;
  out.analysed = analysable;
  out.torque_nm = record.torque_nm;
  out.speed_hz = record.speed_hz;
  out.input_revolutions = record.input_revolutions;
  observe_cycle_count(record, out);
  if (!analysable) {
    out.reject_reason = record.end == RecordEnd::cut_at_dropout ? "shorter than records.min_length_s after a gap"
                                                             : "shorter than records.min_length_s at stream end";
    out.alert_states = alerts_.take_changed();
    return out;
  }
  const RecordSpeed speed = establish_speed(record, out);
  out.speed_source = speed.source;
  // The channels are analysed in parallel; what follows (alerts, wear history) goes in channel order.
  std::vector<dsp::ChannelAnalysis> analyses = channels_.analyze(record, speed.estimated_edges);
  for (std::size_t c = 0; c < record.channels.size(); ++c) {
    const int channel = record.channel_numbers.at(c);
    dsp::ChannelAnalysis& a = analyses[c];
    if (!speed.estimate_failure.empty())
      for (auto& s : a.skipped)
        if (s.reason == dsp::SkipReason::no_tacho) s.detail = "no speed estimate from the signal either: " + speed.estimate_failure;
    storage::ChannelResult ch;
    ch.channel = channel;
    for (const auto& v : a.indicators) ch.values.emplace_back(v.name, v.value);
    if (a.mean_speed_hz > 0) ch.values.emplace_back(dsp::to_string(dsp::Indicator::input_speed_hz), a.mean_speed_hz);
    if (a.samples_per_revolution > 0) {
      ch.values.emplace_back("tsa_averages_input", a.tsa_averages_input);
      ch.values.emplace_back("tsa_averages_output", a.tsa_averages_output);
      ch.values.emplace_back("samples_per_revolution", static_cast<double>(a.samples_per_revolution));
    }
    for (const auto& s : a.skipped) ch.skipped.push_back({s.name, dsp::to_string(s.reason), s.detail});
    for (const auto& n : a.notes) ch.notes.push_back({n.name, dsp::to_string(n.note), n.detail});
    for (const auto& b : a.band_selections) ch.bands.push_back({dsp::to_string(b.criterion), b.level, b.centre_hz, b.bandwidth_hz, b.value});
    observe_channel_alerts(channel, a, out);
    check_thresholds(channel, a, out);
    // Wear mechanism over the history of this gear pair (needs a place in its life).
    if (record.input_revolutions) assess_wear(channel, *record.input_revolutions, a, out);
    else if (record.cycle_fault != CycleCountFault::none)
      ch.skipped.push_back({"wear_mechanism", dsp::to_string(dsp::SkipReason::cycle_count_fault), record.cycle_fault_detail});
    else ch.skipped.push_back({"wear_mechanism", dsp::to_string(dsp::SkipReason::no_life_counter), ""});
    out.channels.push_back(std::move(ch));
  }
  out.alert_states = alerts_.take_changed();
  return out;
}

WearHistory load_wear_history(const std::string& database_path) {
  WearHistory history;
  storage::Database db(database_path, storage::Database::Mode::read_only);
  for (const auto& p : storage::load_gear_pair_ics2_history(db))
    history[static_cast<int>(p.channel)].push_back({p.cycles, p.low_band.value_or(kNaN), p.high_band.value_or(kNaN),
                                                    p.selected_centre_hz.value_or(kNaN), p.selected_value.value_or(kNaN)});
  return history;
}

AlertStates load_alert_states(const std::string& database_path) {
  storage::Database db(database_path, storage::Database::Mode::read_only);
  return storage::load_alert_states(db);
}

IndicatorBaselines load_baselines(const std::string& database_path, const config::AlertSettings& settings) {
  IndicatorBaselines baselines;
  storage::Database db(database_path, storage::Database::Mode::read_only);
  const std::set<std::string> watched(settings.watched_indicators.begin(), settings.watched_indicators.end());
  const auto n = static_cast<std::size_t>(settings.baseline_records);
  for (auto& v : storage::load_gear_pair_indicator_values(db)) {
    if (!watched.count(v.name)) continue;
    auto& base = baselines[{static_cast<int>(v.channel), v.name}];
    if (base.size() < n) base.push_back(v.value);
  }
  return baselines;
}

ProcessorMemory load_processor_memory(const std::string& database_path, const config::AlertSettings& settings) {
  return {load_wear_history(database_path), load_alert_states(database_path), load_baselines(database_path, settings)};
}

}  // namespace gearwatch::daemon
