#include "gearwatch/alerts.hpp"

#include <catch2/catch.hpp>

#include <set>
#include <string>

namespace test_alerts {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;

TEST_CASE("alerts: every kind, severity and transition has one distinct token", "[alerts]") {
  std::set<std::string> kinds;
  for (auto k : kAllAlertKinds) kinds.insert(to_string(k));
  CHECK(kinds.size() == kAllAlertKinds.size());
  CHECK(kinds.count("wear_mechanism") == 1);
  CHECK(kinds.count("sensor_missing") == 1);
  CHECK(kinds.count("unknown") == 0);
  std::set<std::string> severities;
  for (auto s : kAllAlertSeverities) severities.insert(to_string(s));
  CHECK(severities == std::set<std::string>{"info", "warning", "alarm"});
  std::set<std::string> transitions;
  for (auto t : kAllAlertTransitions) transitions.insert(to_string(t));
  CHECK(transitions == std::set<std::string>{"raised", "cleared", "event"});
  CHECK(severity_of(AlertKind::sensor_missing) == AlertSeverity::alarm);
  CHECK(severity_of(AlertKind::wear_mechanism) == AlertSeverity::warning);
}

TEST_CASE("alerts: a lasting condition is raised once, changes are events, clearing waits for clear_after", "[alerts]") {
  AlertTracker t;
  const AlertKey key{AlertKind::wear_mechanism, 0};
  const AlertHysteresis h{1, 3};
  auto observe = [&](bool present, const char* value) { return t.observe(key, present, value, "msg", h); };

  CHECK_FALSE(observe(false, "none"));  // nothing raised, nothing to clear
  auto e = observe(true, "fatigue_pitting");
  REQUIRE(e);
  CHECK(e->transition == AlertTransition::raised);
  CHECK(e->value == "fatigue_pitting");
  CHECK(e->severity == AlertSeverity::warning);
  // The same verdict on later records: nothing new.
  for (int i = 0; i < 5; ++i) CHECK_FALSE(observe(true, "fatigue_pitting"));
  // The verdict changes while raised: staff hear of it once.
  e = observe(true, "both");
  REQUIRE(e);
  CHECK(e->transition == AlertTransition::raised);
  CHECK(e->value == "both");
  CHECK_FALSE(observe(true, "both"));
  // Two records without the condition, then it is back: no clear (hysteresis 3), no new raise.
  CHECK_FALSE(observe(false, "none"));
  CHECK_FALSE(observe(false, "none"));
  CHECK_FALSE(observe(true, "both"));
  // Three in a row clear it, with the value that was raised.
  CHECK_FALSE(observe(false, "none"));
  CHECK_FALSE(observe(false, "none"));
  e = observe(false, "none");
  REQUIRE(e);
  CHECK(e->transition == AlertTransition::cleared);
  CHECK(e->value == "both");
  CHECK(e->severity == AlertSeverity::info);
  CHECK_FALSE(t.state(key)->active);
}

TEST_CASE("alerts: raise_after needs that many observations in a row", "[alerts]") {
  AlertTracker t;
  const AlertKey key{AlertKind::sensor_saturated, 1};
  const AlertHysteresis h{3, 1};
  CHECK_FALSE(t.observe(key, true, "clipped_samples", "m", h));
  CHECK_FALSE(t.observe(key, true, "clipped_samples", "m", h));
  CHECK_FALSE(t.observe(key, false, "", "m", h));  // the run is broken: count starts again
  CHECK_FALSE(t.observe(key, true, "clipped_samples", "m", h));
  CHECK_FALSE(t.observe(key, true, "clipped_samples", "m", h));
  const auto e = t.observe(key, true, "clipped_samples", "m", h);
  REQUIRE(e);
  CHECK(e->key.channel == 1);
  CHECK(e->transition == AlertTransition::raised);
}

TEST_CASE("alerts: state handed out and reloaded continues exactly (a restart raises nothing again)", "[alerts]") {
  const AlertKey key{AlertKind::wear_mechanism, 0};
  const AlertHysteresis h{1, 3};
  AlertTracker first;
  REQUIRE(first.observe(key, true, "abrasive_wear", "m", h));
  CHECK_FALSE(first.observe(key, false, "none", "m", h));
  const auto changed = first.take_changed();
  REQUIRE(changed.size() == 1);
  CHECK(changed[0].second.active);
  CHECK(changed[0].second.consecutive_absent == 1);
  CHECK(first.take_changed().empty());  // nothing changed since

  // A new process with the stored state: the same verdict raises nothing, and the clear count
  // continues from 1 (two more absent records clear it, not three).
  AlertTracker second({{changed[0].first, changed[0].second}});
  CHECK(second.take_changed().empty());
  CHECK_FALSE(second.observe(key, true, "abrasive_wear", "m", h));
  CHECK_FALSE(second.observe(key, false, "none", "m", h));
  CHECK_FALSE(second.observe(key, false, "none", "m", h));
  const auto e = second.observe(key, false, "none", "m", h);
  REQUIRE(e);
  CHECK(e->transition == AlertTransition::cleared);

  AlertTracker third({{changed[0].first, changed[0].second}});
  CHECK_FALSE(third.observe(key, false, "none", "m", h));
  REQUIRE(third.observe(key, false, "none", "m", h));  // 1 stored + 2 = 3
}

TEST_CASE("alerts: clear_all ends every raised alert of a kind, occurrences are events", "[alerts]") {
  AlertTracker t;
  REQUIRE(t.observe({AlertKind::wear_mechanism, 0}, true, "fatigue_pitting", "m", {}));
  REQUIRE(t.observe({AlertKind::wear_mechanism, 1}, true, "abrasive_wear", "m", {}));
  REQUIRE(t.observe({AlertKind::sensor_missing, 1}, true, "stopped", "m", {}));
  const auto cleared = t.clear_all(AlertKind::wear_mechanism, "new gear pair");
  REQUIRE(cleared.size() == 2);
  CHECK(cleared[0].transition == AlertTransition::cleared);
  CHECK(cleared[0].value == "fatigue_pitting");
  CHECK(cleared[1].value == "abrasive_wear");
  CHECK(t.state({AlertKind::sensor_missing, 1})->active);  // other kinds untouched
  const auto ev = t.occurrence({AlertKind::life_counter_reset, -1}, "1000", "reset");
  CHECK(ev.transition == AlertTransition::event);
  CHECK(ev.severity == AlertSeverity::warning);
  // After the clear, the same verdict raises again (it is a new pair's verdict).
  CHECK(t.observe({AlertKind::wear_mechanism, 0}, true, "fatigue_pitting", "m", {}));
}

}  // namespace test_alerts
