#pragma once
// A known fleet for the fleet page (docs/fleet.md, "Fleet page"): five gearboxes written through the
// fleet store's typed writers, each built so that one field of the page's order decides its place.
//   plant2/gbPit      alarm (wear_mechanism) active, channel 0 fatigue_pitting, 2.0 M pitting cycles left
//   plant2/gbWarn<&>  warning active, an info alert raised and cleared, abrasive_wear, no model run,
//                     ids 6-8 answered gone (not_held): 3 lost in 1 range
//   plant1/gbLife     nothing active, verdict none, 0.8 M pitting cycles left (0.6–1.1 M)
//   plant1/gbQuiet    nothing active, verdict none, 5 M pitting / 9 M wear cycles left, a 4-record trend
//   plant1/gbOff      offline, nothing arrived but its status, which says ids up to 3 were sent:
//                     3 missing in 1 range
// Worst first: gbPit, gbWarn<&>, gbLife, gbQuiet, gbOff.
#include <string>
#include <vector>

#include "gearwatch/storage/fleet_store.hpp"

namespace gearwatch::testing {

inline const std::vector<std::string> kFleetWorstFirst{"plant2/gbPit", "plant2/gbWarn<&>", "plant1/gbLife", "plant1/gbQuiet",
                                                       "plant1/gbOff"};

namespace fleet_fixture {
using namespace storage::fleet;

inline MessageHeader header(const std::string& site, const std::string& gearbox, std::int64_t message_id, std::int64_t record_id) {
  char time[32];
  std::snprintf(time, sizeof time, "2026-11-20T10:%02d:00Z", static_cast<int>(message_id % 60));
  return {site, gearbox, message_id, record_id, time};
}

inline RecordMessage record(const std::string& site, const std::string& gearbox, std::int64_t id, double cycles, double ics2) {
  RecordMessage r;
  r.header = header(site, gearbox, id, id);
  r.stream_sequence = 1;
  r.start_index = id * 1000;
  r.duration_s = 10.0;
  r.analysed = true;
  r.speed_hz = 25.0;
  r.torque_nm = 20.0;
  r.input_revolutions = cycles;
  r.indicators = {{0, "ics2_low_band", ics2}, {0, "rms_sa", 1.5}, {1, "ics2_low_band", 100.0 + ics2}};
  return r;
}

inline ModelMessage model(const std::string& site, const std::string& gearbox, std::int64_t message_id, double cycles,
                          const std::string& forecast_json) {
  ModelMessage m;
  m.header = header(site, gearbox, message_id, message_id - 1);
  m.model_run_id = message_id;
  m.gear_pair = 1;
  m.advanced = true;
  m.cycles = cycles;
  m.k_wear = 3e-17;
  m.wear_max_depth_m = 4.2e-6;
  m.pitting_mean = 0.05;
  m.forecast_json = forecast_json;
  return m;
}

inline std::string forecast(double pit_left, double pit_low, double pit_high, double wear_left) {
  return R"({"valid":true,"failure":"","pitting":{"limit":0.17,"cycles_left":)" + std::to_string(pit_left) +
         R"(,"cycles_left_low":)" + std::to_string(pit_low) + R"(,"cycles_left_high":)" + std::to_string(pit_high) +
         R"(},"wear":{"limit":2e-05,"cycles_left":)" + std::to_string(wear_left) + R"(,"cycles_left_low":null,"cycles_left_high":null}})";
}

inline AlertMessage alert(const std::string& site, const std::string& gearbox, std::int64_t id, AlertTransition t, const char* severity,
                          const char* kind, std::optional<int> channel, const char* value) {
  AlertMessage a;
  a.header = header(site, gearbox, id, id - 1);
  a.transition = t;
  a.severity = severity;
  a.kind = kind;
  a.channel = channel;
  a.value = value;
  a.message = std::string(kind) + " " + value;
  return a;
}

inline WearMessage verdict(const std::string& site, const std::string& gearbox, std::int64_t id, const char* mechanism) {
  WearMessage w;
  w.header = header(site, gearbox, id, id - 1);
  w.verdicts = {{0, mechanism, 6, 0.01, 0.4, "fixture"}};
  return w;
}

}  // namespace fleet_fixture

/// Writes the known fleet into a migrated fleet database.
inline void write_known_fleet(storage::fleet::FleetStore& store) {
  using namespace fleet_fixture;
  const auto raised = AlertTransition::raised, cleared = AlertTransition::cleared;
  std::vector<Message> m;
  for (int i = 1; i <= 4; ++i) m.push_back(record("plant1", "gbQuiet", i, 1e5 * i, 10.0 * i));
  m.push_back(verdict("plant1", "gbQuiet", 5, "none"));
  m.push_back(model("plant1", "gbQuiet", 6, 4e5, forecast(5e6, 4e6, 6e6, 9e6)));
  m.push_back(record("plant1", "gbLife", 1, 2e6, 40.0));
  m.push_back(verdict("plant1", "gbLife", 2, "none"));
  m.push_back(model("plant1", "gbLife", 3, 2e6, forecast(8e5, 6e5, 1.1e6, 7e6)));
  m.push_back(record("plant2", "gbPit", 1, 3e6, 80.0));
  m.push_back(verdict("plant2", "gbPit", 2, "fatigue_pitting"));
  m.push_back(alert("plant2", "gbPit", 3, raised, "alarm", "wear_mechanism", 0, "fatigue_pitting"));
  m.push_back(model("plant2", "gbPit", 4, 3e6, forecast(2e6, 1.5e6, 2.6e6, 8e6)));
  m.push_back(record("plant2", "gbWarn<&>", 1, 1e6, 30.0));
  m.push_back(verdict("plant2", "gbWarn<&>", 2, "abrasive_wear"));
  m.push_back(alert("plant2", "gbWarn<&>", 3, raised, "info", "life_counter_reset", std::nullopt, "0"));
  m.push_back(alert("plant2", "gbWarn<&>", 4, raised, "warning", "wear_mechanism", 0, "abrasive_wear"));
  m.push_back(alert("plant2", "gbWarn<&>", 5, cleared, "info", "life_counter_reset", std::nullopt, "0"));
  m.push_back(GoneMessage{"plant2", "gbWarn<&>", {{6, 8, OutboxGoneReason::not_held}}});
  m.push_back(StatusMessage{"plant1", "gbOff", "offline", "0.1.0", 11, 3});
  for (const auto& outcome : store.write_batch(m))
    if (!outcome.written) throw std::runtime_error("fleet fixture refused: " + outcome.refusal);
}

}  // namespace gearwatch::testing
