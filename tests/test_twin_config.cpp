// The optional [twin] table of the config file.
#include "gearwatch/config/twin_config.hpp"

#include <catch2/catch.hpp>

using namespace gearwatch;

TEST_CASE("[twin] overrides parameters, errors name the key and its line", "[twin]") {
  const auto p = config::twin_parameters_from_toml("[rig]\nx = 1\n[twin]\nkt12 = 1500.0\nmesh_damping_ratio = 0.1\n", "f.toml");
  CHECK(p.kt12 == 1500.0);
  CHECK(p.mesh_damping_ratio == 0.1);
  CHECK(p.kt23 == twin::GearboxParameters{}.kt23);  // untouched keys keep the calibrated default
  CHECK(config::twin_parameters_from_toml("[rig]\n").kt12 == twin::GearboxParameters{}.kt12);
  CHECK_THROWS_WITH(config::twin_parameters_from_toml("[twin]\nkt12 = 1.0\nbogus = 2\n", "f.toml"),
                    "f.toml line 3: [twin].bogus: unknown key");
  CHECK_THROWS_WITH(config::twin_parameters_from_toml("[twin]\n\nm5 = -1.0\n", "f.toml"),
                    Catch::StartsWith("f.toml line 3: [twin].m5: ") && Catch::Contains("positive"));
  CHECK_THROWS_WITH(config::twin_parameters_from_toml("[twin]\nI1 = \"heavy\"\n", "f.toml"),
                    "f.toml line 2: [twin].I1: expected a number");
  CHECK_THROWS_AS(config::load_twin_parameters("/nonexistent/gearwatch.toml"), config::TwinConfigError);
}
