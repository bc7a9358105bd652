// The optional [twin] table of the config file.
#include "gearwatch/config/twin_config.hpp"

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "gearwatch/config/config.hpp"
#include "temp_dir.hpp"

namespace test_twin_config {  // this file's own: the test files compile together (unity build)

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

namespace {

struct CommentedKey {
  std::string name;
  std::string value;  ///< the default as the example prints it
};

// The `# key = value` lines of the example's [twin] table, in file order.
std::vector<CommentedKey> commented_twin_keys(const std::string& text) {
  std::vector<CommentedKey> keys;
  std::istringstream in(text);
  bool in_twin = false;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line[0] == '[') in_twin = line.rfind("[twin]", 0) == 0;
    if (!in_twin || line.rfind("# ", 0) != 0) continue;
    std::istringstream words(line.substr(2));
    CommentedKey key;
    std::string equals;
    if (words >> key.name >> equals >> key.value && equals == "=") keys.push_back(key);
  }
  return keys;
}

}  // namespace

TEST_CASE("docs #33: the example config lists every twin key with its default and loads them as written once uncommented",
          "[twin][config]") {
  const std::string example_path = std::string(GEARWATCH_SOURCE_DIR) + "/config/gearwatch.example.toml";
  std::ifstream in(example_path);
  REQUIRE(in);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();

  const auto keys = commented_twin_keys(text);
  const auto& table = twin::parameter_table();
  REQUIRE(keys.size() == table.size());
  const twin::GearboxParameters defaults;
  for (std::size_t i = 0; i < keys.size(); ++i) {
    INFO(keys[i].name << " = " << keys[i].value);
    CHECK(keys[i].name == table[i].name);
    CHECK(std::stod(keys[i].value) == defaults.*(table[i].field));  // printed exactly, not rounded
  }

  // A copy with every [twin] key uncommented, kt12 changed: the twin loader returns what is written,
  // and the daemon's own loader still accepts the file.
  std::string copy = text;
  for (const auto& key : keys) {
    const std::string commented = "# " + key.name + " = " + key.value;
    const auto at = copy.find(commented);
    REQUIRE(at != std::string::npos);
    const std::string value = key.name == "kt12" ? "1500.0" : key.value;
    copy.replace(at, commented.size(), key.name + " = " + value);
  }
  gearwatch::testing::TempDir dir("twin-example");
  const auto copy_path = (dir / "gearwatch.toml").string();
  std::ofstream(copy_path) << copy;
  const auto loaded = config::load_twin_parameters(copy_path);
  for (std::size_t i = 0; i < keys.size(); ++i) {
    INFO(keys[i].name);
    const double written = keys[i].name == "kt12" ? 1500.0 : std::stod(keys[i].value);
    CHECK(loaded.*(table[i].field) == written);
  }
  CHECK(loaded.kt12 == 1500.0);
  CHECK(loaded.kt23 == defaults.kt23);
  CHECK_NOTHROW(config::load_config(copy_path));
}

}  // namespace test_twin_config
