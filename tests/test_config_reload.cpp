// What SIGHUP applies and what it says needs a restart (daemon/config_reload.hpp).
#include "config_reload.hpp"

#include <catch2/catch.hpp>

namespace test_config_reload {  // this file's own: the test files compile together (unity build)

using gearwatch::daemon::join_keys;
using gearwatch::daemon::plan_reload;

namespace {

const char* kStarted =
    "[logging]\nlevel = \"info\"\n"
    "[records]\nlength_s = 1.0\ninterval_s = 1.0\n"
    "[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n"
    "[[channels]]\nnumber = 1\nname = \"casing_x\"\nscale = 0.01\n";

gearwatch::config::GearwatchConfig running() { return gearwatch::config::parse_config(kStarted, "started.toml"); }

}  // namespace

TEST_CASE("config reload: the same file changes nothing", "[reload]") {
  const auto plan = plan_reload(kStarted, running(), kStarted, "plant.toml");
  CHECK(plan.apply.empty());
  CHECK(plan.restart_required.empty());
  CHECK(join_keys(plan.restart_required) == "none");
}

TEST_CASE("config reload: the log level is applied, every other change is named as needing a restart", "[reload]") {
  const std::string edited =
      "[logging]\nlevel = \"debug\"\n"
      "[records]\nlength_s = 2.0\ninterval_s = 2.0\n"
      "[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n"
      "[[channels]]\nnumber = 1\nname = \"casing_x\"\nscale = 0.02\n"
      "[alerts]\nthreshold_sigma = 5.0\n";
  const auto plan = plan_reload(kStarted, running(), edited, "plant.toml");
  CHECK(plan.next.logging.level == gearwatch::config::LogLevel::debug);
  CHECK(plan.apply == std::vector<gearwatch::daemon::ReloadableKey>{gearwatch::daemon::ReloadableKey::logging_level});
  CHECK(std::string(to_string(gearwatch::daemon::ReloadableKey::logging_level)) == "logging.level");
  // Sorted; an array entry by position; a key added counts as changed.
  CHECK(plan.restart_required ==
        std::vector<std::string>{"alerts.threshold_sigma", "channels[1].scale", "records.interval_s", "records.length_s"});
  CHECK(join_keys(plan.restart_required) == "alerts.threshold_sigma, channels[1].scale, records.interval_s, records.length_s");
}

TEST_CASE("config reload: a removed key and a removed channel need a restart", "[reload]") {
  const std::string edited =
      "[records]\nlength_s = 1.0\n"
      "[[channels]]\nnumber = 0\nname = \"casing_y\"\nscale = 0.01\n";
  auto plan = plan_reload(kStarted, running(), edited, "plant.toml");
  // logging.level is gone from the file: its default, "info", is what is in force already.
  CHECK(plan.apply.empty());
  CHECK(plan.restart_required ==
        std::vector<std::string>{"channels[1].name", "channels[1].number", "channels[1].scale", "records.interval_s"});
}

TEST_CASE("config reload: a level applied by an earlier reload is not applied again", "[reload]") {
  auto now = running();
  now.logging.level = gearwatch::config::LogLevel::warn;  // what the first SIGHUP applied
  const std::string edited = std::string(kStarted).replace(std::string(kStarted).find("\"info\""), 6, "\"warn\"");
  const auto plan = plan_reload(kStarted, now, edited, "plant.toml");
  CHECK(plan.apply.empty());
  CHECK(plan.restart_required.empty());
}

TEST_CASE("config reload: an invalid new file is refused with file, line and key", "[reload]") {
  const std::string broken = "[records]\nlength_s = 1.0\ninterval_s = \"often\"\n";
  CHECK_THROWS_WITH(plan_reload(kStarted, running(), broken, "plant.toml"),
                    "plant.toml:3: key 'records.interval_s': expected a number");
}

}  // namespace test_config_reload
