#include "record_processing.hpp"

#include <cmath>
#include <limits>

#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::daemon {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double value_or_nan(const dsp::ChannelAnalysis& a, const std::string& name) { return a.value(name).value_or(kNaN); }

double selected_centre(const dsp::ChannelAnalysis& a) {
  for (const auto& b : a.band_selections)
    if (b.criterion == "ics2") return b.centre_hz;
  return kNaN;
}

}  // namespace

RecordProcessor::RecordProcessor(const config::GearwatchConfig& config, WearHistory history)
    : config_(config), analyzer_(config.rig, config.processing), history_(std::move(history)) {}

void RecordProcessor::reset_history() {
  history_.clear();
  last_mechanism_.clear();
  last_jumps_.clear();
}

storage::RecordResult RecordProcessor::process(const Record& record, bool analysable, std::uint64_t stream_sequence) {
  storage::RecordResult out;
  out.stream_sequence = stream_sequence;
  out.start_index = record.start_index;
  out.sample_count = record.sample_count();
  out.duration_s = record.duration_s();
  out.end_reason = to_string(record.end);
  out.analysed = analysable;
  out.torque_nm = record.torque_nm;
  out.speed_hz = record.speed_hz;
  out.input_revolutions = record.input_revolutions;
  if (!analysable) {
    out.reject_reason = record.end == RecordEnd::cut_at_gap ? "shorter than records.min_length_s after a gap"
                                                             : "shorter than records.min_length_s at stream end";
    return out;
  }
  for (std::size_t c = 0; c < record.channels.size(); ++c) {
    const int channel = record.channel_numbers.at(c);
    const dsp::ChannelAnalysis a = analyzer_.analyze(record, c);
    storage::ChannelResult ch;
    ch.channel = channel;
    for (const auto& v : a.indicators) ch.values.emplace_back(v.name, v.value);
    if (a.mean_speed_hz > 0) ch.values.emplace_back("input_speed_hz", a.mean_speed_hz);
    if (a.samples_per_revolution > 0) {
      ch.values.emplace_back("tsa_averages_input", a.tsa_averages_input);
      ch.values.emplace_back("tsa_averages_output", a.tsa_averages_output);
      ch.values.emplace_back("samples_per_revolution", static_cast<double>(a.samples_per_revolution));
    }
    for (const auto& s : a.skipped) ch.skipped.emplace_back(s.name, dsp::to_string(s.reason));
    for (const auto& b : a.band_selections) ch.bands.push_back({b.criterion, b.level, b.centre_hz, b.bandwidth_hz, b.value});

    // Wear mechanism over the history of this gear pair (needs a place in its life).
    if (record.input_revolutions) {
      auto& h = history_[channel];
      h.push_back({*record.input_revolutions, value_or_nan(a, "ics2_low_band"), value_or_nan(a, "ics2_high_band"),
                   selected_centre(a)});
      const auto window = static_cast<std::size_t>(config_.processing.trend_window_records);
      if (h.size() > window) h.erase(h.begin(), h.end() - static_cast<std::ptrdiff_t>(window));
      const auto verdict = dsp::identify_wear_mechanism(h, config_.processing);
      storage::WearAssessment w;
      w.channel = channel;
      w.mechanism = dsp::to_string(verdict.mechanism);
      w.points = verdict.low_band.points;
      w.low_band_p = verdict.low_band.p_value;
      w.high_band_p = verdict.high_band.p_value;
      w.low_band_rho = verdict.low_band.spearman_rho;
      w.high_band_rho = verdict.high_band.spearman_rho;
      w.band_jumps = verdict.band_jumps.size();
      w.evidence = verdict.evidence;
      const bool wear = verdict.mechanism == dsp::WearMechanism::fatigue_pitting ||
                        verdict.mechanism == dsp::WearMechanism::abrasive_wear || verdict.mechanism == dsp::WearMechanism::both;
      auto& last = last_mechanism_[channel];
      if (wear && last != w.mechanism)
        out.alerts.emplace_back("wear_mechanism", "channel " + std::to_string(channel) + ": " + w.mechanism + " identified — " + verdict.evidence);
      last = w.mechanism;
      auto& jumps = last_jumps_[channel];
      if (verdict.band_jumps.size() > jumps && !verdict.band_jumps.empty()) {
        const auto& j = verdict.band_jumps.back();
        out.alerts.emplace_back("carrier_band_jump", "channel " + std::to_string(channel) + ": ICS2-selected carrier band moved from " +
                                                         std::to_string(static_cast<long>(j.from_hz)) + " Hz to " +
                                                         std::to_string(static_cast<long>(j.to_hz)) + " Hz");
      }
      jumps = verdict.band_jumps.size();
      out.assessments.push_back(std::move(w));
    } else {
      ch.skipped.emplace_back("wear_mechanism", "no_life_counter");
    }
    out.channels.push_back(std::move(ch));
  }
  return out;
}

WearHistory load_wear_history(const std::string& database_path) {
  WearHistory history;
  storage::Database db(database_path, storage::Database::Mode::read_only);
  storage::Statement st(db, R"SQL(
    SELECT r.input_revolutions, lo.channel, lo.value, hi.value,
           (SELECT b.centre_hz FROM band_selections b WHERE b.record_id = r.id AND b.channel = lo.channel AND b.criterion = 'ics2')
    FROM records r
    JOIN indicator_values lo ON lo.record_id = r.id AND lo.name = 'ics2_low_band'
    LEFT JOIN indicator_values hi ON hi.record_id = r.id AND hi.channel = lo.channel AND hi.name = 'ics2_high_band'
    WHERE r.analysed = 1 AND r.input_revolutions IS NOT NULL
      AND r.created_at >= coalesce((SELECT max(detected_at) FROM life_counter_events), '')
    ORDER BY r.id)SQL");
  while (st.step()) {
    auto col = [&](int i) { return st.is_null(i) ? kNaN : st.get_double(i); };
    history[static_cast<int>(st.get_int(1))].push_back({st.get_double(0), col(2), col(3), col(4)});
  }
  return history;
}

}  // namespace gearwatch::daemon
