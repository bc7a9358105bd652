// The rig simulator's campaigns through the daemon: `gearwatch simulate --campaign` writes the
// records, `gearwatch replay` processes them one file per process into one database, and
// `gearwatch query alerts` must name the campaign's wear mechanism (seed §4.3: pitting -> low
// carriers, abrasion -> high carriers; a healthy pair neither).
#include "commands.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "command_runner.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using gearwatch::testing::run_command;

namespace {

struct CampaignResult {
  nlohmann::json alerts;
  nlohmann::json truth;
  fs::path db;
};

// Six records of 2.2 s (one 2 s record each): Mann-Kendall needs five points for p < 0.05, and
// every record past the fifth is one more test a stationary history can fail by chance, so a
// campaign this short keeps the healthy case's false-alarm chance small (about 3 % a channel).
CampaignResult run_campaign(const gearwatch::testing::TempDir& dir, const std::string& name) {
  const auto config = dir / "daemon.toml";
  std::ofstream(config) << "[records]\nlength_s = 2.0\ninterval_s = 600.0\nmin_length_s = 1.0\n";
  const auto out = dir / name;
  auto r = run_command(std::string(GEARWATCH_BINARY) + " simulate --campaign " + name + " --records 6 --seconds 2.2 --out " + out.string());
  INFO(r.err);
  REQUIRE(r.status == 0);
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(out))
    if (e.path().extension() == ".log") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  CampaignResult result;
  result.db = dir / (name + ".db");
  for (const auto& f : files) {
    r = run_command(std::string(GEARWATCH_BINARY) + " replay " + f.string() + " --db " + result.db.string() + " --config " + config.string());
    INFO(f.string() << "\n" << r.err);
    REQUIRE(r.status == 0);
  }
  r = run_command(std::string(GEARWATCH_BINARY) + " query alerts --db " + result.db.string() + " --format json");
  REQUIRE(r.status == 0);
  result.alerts = nlohmann::json::parse(r.out);
  std::ifstream t(out / "truth.json");
  result.truth = nlohmann::json::parse(t);
  return result;
}

/// Raised wear-mechanism alerts per channel.
std::map<int, std::vector<std::string>> raised(const nlohmann::json& alerts) {
  std::map<int, std::vector<std::string>> out;
  for (const auto& a : alerts)
    if (a.at("kind") == "wear_mechanism" && a.at("transition") == "raised") out[a.at("channel").get<int>()].push_back(a.at("value"));
  return out;
}

/// The records' cycles as the daemon stored them equal the truth's.
void check_cycles(const CampaignResult& r) {
  gearwatch::storage::Database d(r.db.string(), gearwatch::storage::Database::Mode::read_only);
  gearwatch::storage::Statement s(d, "SELECT input_revolutions FROM records ORDER BY id");
  std::vector<double> stored;
  while (s.step()) stored.push_back(s.get_double(0));
  REQUIRE(stored.size() == r.truth.at("records").size());
  for (std::size_t k = 0; k < stored.size(); ++k) CHECK(stored[k] == r.truth.at("records")[k].at("cycles").get<double>());
}

}  // namespace

TEST_CASE("rig end to end: a lubricated campaign is identified as fatigue pitting", "[rig][e2e]") {
  const gearwatch::testing::TempDir dir("rig-e2e-lubricated");
  const auto r = run_campaign(dir, "lubricated");
  check_cycles(r);
  const auto by_channel = raised(r.alerts);
  REQUIRE(by_channel.size() == 2);
  for (const auto& [channel, values] : by_channel) {
    INFO("channel " << channel);
    CHECK(values == std::vector<std::string>{"fatigue_pitting"});
  }
  // The truth behind it: pitting grows record by record, past the seed's ~17 % at the end.
  CHECK(r.truth.at("records").back().at("pitting_density").get<double>() > 0.15);
}

TEST_CASE("rig end to end: a dry campaign is identified as abrasive wear", "[rig][e2e]") {
  const gearwatch::testing::TempDir dir("rig-e2e-dry");
  const auto r = run_campaign(dir, "dry");
  check_cycles(r);
  const auto by_channel = raised(r.alerts);
  REQUIRE(by_channel.size() == 2);
  for (const auto& [channel, values] : by_channel) {
    INFO("channel " << channel);
    CHECK(values == std::vector<std::string>{"abrasive_wear"});
  }
  CHECK(r.truth.at("records").back().at("pitting_density").get<double>() == 0);
}

TEST_CASE("rig end to end: a healthy campaign raises no wear alert", "[rig][e2e]") {
  const gearwatch::testing::TempDir dir("rig-e2e-healthy");
  const auto r = run_campaign(dir, "healthy");
  check_cycles(r);
  CHECK(raised(r.alerts).empty());
  for (const auto& rec : r.truth.at("records")) {
    CHECK(rec.at("sliding_pitting_rms_m_s2").get<double>() == 0);
    CHECK(rec.at("sliding_abrasion_rms_m_s2").get<double>() == 0);
  }
}
