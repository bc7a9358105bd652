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

bool GapSchedule::add(GapSample sample) {
  samples_.push_back(std::move(sample));
  while (samples_.size() > training_ + held_out_) samples_.pop_front();
  ++since_last_;
  if (since_last_ < every_ || samples_.size() < training_ + held_out_) return false;
  since_last_ = 0;
  return true;
}

std::pair<std::vector<const GapSample*>, std::vector<const GapSample*>> GapSchedule::split() const {
  std::pair<std::vector<const GapSample*>, std::vector<const GapSample*>> out;
  const std::size_t n_training = samples_.size() > held_out_ ? samples_.size() - held_out_ : 0;
  for (std::size_t i = 0; i < samples_.size(); ++i) (i < n_training ? out.first : out.second).push_back(&samples_[i]);
  return out;
}

}  // namespace gearwatch::daemon
