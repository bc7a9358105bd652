// Rig-simulator campaigns: the record plan, the campaign file's refusals (key and line), and the
// `gearwatch simulate --campaign` command: truth.json against the captures, determinism, the
// free-space check, and the single-capture form with --physics rig.
#include "gearwatch/rig/campaign.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "command_runner.hpp"
#include "gearwatch/wear/wear_loop.hpp"
#include "temp_dir.hpp"

namespace test_rig_campaign {  // this file's own: the test files compile together (unity build)

namespace fs = std::filesystem;
using gearwatch::testing::run_command;
using Catch::Matchers::Contains;

namespace {

std::string gearwatch_cmd(const std::string& args) { return std::string(GEARWATCH_BINARY) + " " + args; }

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The values of the life-counter frames (0x1F2, u64 little-endian) of a candump log, in order.
std::vector<std::uint64_t> life_counters(const fs::path& log) {
  std::ifstream in(log);
  std::vector<std::uint64_t> out;
  std::string line;
  while (std::getline(in, line)) {
    const auto at = line.find(" 1F2#");
    if (at == std::string::npos) continue;
    const std::string hex = line.substr(at + 5, 16);
    std::uint64_t v = 0;
    for (int b = 7; b >= 0; --b) v = (v << 8) | std::stoul(hex.substr(static_cast<std::size_t>(2 * b), 2), nullptr, 16);
    out.push_back(v);
  }
  return out;
}

gearwatch::rig::CampaignSpec parse(const std::string& text) { return gearwatch::rig::parse_campaign(text, "test.toml"); }

}  // namespace

TEST_CASE("rig campaign: records at the test's stops, in cycle order, one per measurement speed", "[rig][campaign]") {
  auto c = gearwatch::rig::builtin_campaign("lubricated");
  CHECK(c.max_cycles == 3250000);
  CHECK(c.stop_interval_cycles == 100000);
  CHECK(c.torque_nm == 20);
  c.records = 20;
  const auto plan = gearwatch::rig::plan_records(c);
  REQUIRE(plan.size() == 20);
  CHECK(plan.front().cycles == 0);
  CHECK(plan.back().cycles == 3200000);  // the last stop (33 stops: 0 .. 3.2 M)
  for (std::size_t i = 1; i < plan.size(); ++i) {
    CHECK(plan[i].cycles > plan[i - 1].cycles);
    CHECK(std::fmod(plan[i].cycles, 100000.0) == 0);
    CHECK(plan[i].file_name > plan[i - 1].file_name);
  }
  c.measurement_speeds_hz = {10, 2};
  c.records = 3;
  const auto two = gearwatch::rig::plan_records(c);
  REQUIRE(two.size() == 6);
  CHECK(two[0].cycles == two[1].cycles);
  CHECK(two[1].speed_hz == 2);
  auto dry = gearwatch::rig::builtin_campaign("dry");
  CHECK(dry.max_cycles == 38000);
  CHECK(dry.torque_nm == 5);
  dry.records = 20;  // more records than the dry test's 8 stops: evenly spaced cycles
  const auto dense = gearwatch::rig::plan_records(dry);
  CHECK(dense.back().cycles == 38000);
  CHECK(dense[1].cycles == std::round(38000.0 / 19));
}

TEST_CASE("rig campaign: integration_rate_hz sets the rig's integration steps of every record, 10 us unless given",
          "[rig][campaign]") {
  const std::string head = "[campaign]\nmax_cycles = 1000\n";
  const auto plain = parse(head);
  const auto plan = gearwatch::rig::plan_records(plain);
  REQUIRE(!plan.empty());
  CHECK(gearwatch::rig::record_run_settings(plain, plan.front(), 7).min_ode_rate_hz == 100000);
  const auto fine = parse(head + "integration_rate_hz = 200000\n");
  CHECK(gearwatch::rig::record_run_settings(fine, plan.front(), 7).min_ode_rate_hz == 200000);
  CHECK_THROWS_WITH(parse(head + "integration_rate_hz = 10000\n"), Contains("line 3") && Contains("campaign.integration_rate_hz"));
}

TEST_CASE("rig campaign: a campaign file with unknown keys, wrong types or impossible values is refused with key and line",
          "[rig][campaign]") {
  const std::string head = "[campaign]\nmax_cycles = 1000\n";
  CHECK_THROWS_WITH(parse(head + "recods = 5\n"), Contains("test.toml line 3") && Contains("campaign.recods") && Contains("not a known key"));
  CHECK_THROWS_WITH(parse(head + "records = \"ten\"\n"), Contains("line 3") && Contains("campaign.records must be an integer"));
  CHECK_THROWS_WITH(parse(head + "torque_nm = -5\n"), Contains("line 3") && Contains("campaign.torque_nm"));
  CHECK_THROWS_WITH(parse(head + "stop_interval_cycles = 5000\n"), Contains("line 3") && Contains("stop_interval_cycles"));
  CHECK_THROWS_WITH(parse(head + "channels = 3\n"), Contains("campaign.channels"));
  CHECK_THROWS_WITH(parse(head + "[wear]\nk_pitting = \"high\"\n"), Contains("line 4") && Contains("wear.k_pitting must be a number"));
  CHECK_THROWS_WITH(parse(head + "[[wear.phase]]\nfrom_cycles = 500\nk_wear = 1e-12\n[[wear.phase]]\nfrom_cycles = 100\nk_wear = 1e-12\n"),
                    Contains("line 7") && Contains("wear.phase.from_cycles"));
  CHECK_THROWS_WITH(parse(head + "[wear]\nlaw = \"paris\"\n"), Contains("line 4") && Contains("wear.law") && Contains("archard"));
  CHECK_THROWS_WITH(parse(head + "[wear]\nlaw = 1\n"), Contains("line 4") && Contains("wear.law must be a string"));
  CHECK(parse(head + "[wear]\nlaw = \"archard\"\n").wear.law == gearwatch::rig::WearLaw::archard);
  CHECK(parse(head).wear.law == gearwatch::rig::WearLaw::linear);
  CHECK_THROWS_WITH(parse(head + "[sliding]\npitting_band_hz = [9000, 3000]\n"), Contains("line 4") && Contains("sliding.pitting_band_hz"));
  CHECK_THROWS_WITH(parse(head + "[effects]\nenabled = [\"casing\", \"wobble\"]\n"), Contains("line 4") && Contains("wobble"));
  CHECK_THROWS_WITH(parse(head + "[effects.casing]\nmode1_hz = 9000\n"),
                    Contains("line 4") && Contains("casing.mode1_hz") && Contains("[20, 5000]"));
  CHECK_THROWS_WITH(parse(head + "[effects.casing]\nmode_hz = 900\n"), Contains("line 4") && Contains("effects.casing.mode_hz"));
  CHECK_THROWS_WITH(parse(head + "[extra]\nx = 1\n"), Contains("line 3") && Contains("extra"));
  CHECK_THROWS_WITH(parse("[campaign]\nmax_cycles = 1000\nrecords = 5\nrecords = 6\n"), Contains("line 4"));
  CHECK_THROWS_WITH(parse("[campaign]\nrecords = 5\n"), Contains("campaign.max_cycles is required"));
  // A complete file is accepted, fixed effect parameters kept.
  const auto ok = parse(head + "records = 4\n[effects]\nenabled = [\"casing\"]\n[effects.casing]\nmode1_hz = 900\n");
  CHECK(ok.records == 4);
  CHECK(ok.effects == "casing");
  CHECK(ok.effect_values.at("casing.mode1_hz") == 900);
}

TEST_CASE("rig campaign: truth.json matches the records: cycles in each capture's life counter, wear state per record",
          "[rig][campaign]") {
  const gearwatch::testing::TempDir dir("rig-campaign");
  const auto out = dir / "dry";
  const auto r = run_command(gearwatch_cmd("simulate --campaign dry --records 3 --seconds 0.3 --channels 1 --out " + out.string()));
  INFO(r.err);
  REQUIRE(r.status == 0);
  const auto truth = nlohmann::json::parse(read_file(out / "truth.json"));
  CHECK(truth.at("campaign").at("name") == "dry");
  REQUIRE(truth.at("records").size() == 3);
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(out))
    if (e.path().extension() == ".log") files.push_back(e.path().filename().string());
  std::sort(files.begin(), files.end());
  REQUIRE(files.size() == 3);
  // The dry test: 38 000 cycles, 8 stops 5 000 apart; 3 records at stops 0, 4 and 7 (round(k * 7 / 2)).
  const double expected_cycles[] = {0, 20000, 35000};
  double last_depth = -1;
  for (std::size_t k = 0; k < 3; ++k) {
    const auto& rec = truth.at("records")[k];
    CHECK(rec.at("file") == files[k]);
    CHECK(rec.at("cycles").get<double>() == expected_cycles[k]);
    CHECK(rec.at("life_counter_revolutions").get<std::uint64_t>() == static_cast<std::uint64_t>(expected_cycles[k]));
    const auto counters = life_counters(out / files[k]);
    REQUIRE(counters.size() >= 1);
    CHECK(counters.front() == static_cast<std::uint64_t>(expected_cycles[k]));
    // 0.3 s at 10 Hz: the counter ends 2 revolutions on (the last one sent after sample 0.2 s).
    CHECK(counters.back() <= static_cast<std::uint64_t>(expected_cycles[k]) + 3);
    // Wear by the Archard model, K = 1e-13 m²/N at 5 N m: the depth grows with the cycles.
    const double depth = rec.at("mean_wear_depth_um").get<double>();
    CHECK(depth > last_depth);
    last_depth = depth;
    CHECK(rec.at("k_wear").get<double>() == 1e-13);
    CHECK(rec.at("pitting_density").get<double>() == 0);
  }
  const auto& last = truth.at("records")[2];
  const auto& profile = last.at("wear_profile_pinion_um_root_to_tip");
  // The same as the project's blue loop run by hand to the same stops (the truth's steps stop there too).
  gearwatch::wear::WearLoopOptions o;
  o.k_wear_si = 1e-13;
  o.operating_point = {10.0, 5.0};
  gearwatch::wear::BlueLoop reference(gearwatch::twin::GearboxParameters{}, o);
  REQUIRE(reference.run_until(20000));
  REQUIRE(reference.run_until(35000));
  const auto expected = gearwatch::wear::to_profile_deviation(reference.state()).pinion;
  REQUIRE(profile.size() == expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) CHECK(profile[i].get<double>() == Approx(expected[i] * 1e6).epsilon(1e-12));
  CHECK(last.at("combined_mean_wear_depth_um").get<double>() ==
        Approx(gearwatch::wear::summarise(reference.state()).combined_mean_depth_m * 1e6).epsilon(1e-12));
  CHECK(truth.at("campaign").at("wear_law") == "archard");
  CHECK(truth.at("effects").at("enabled") == nlohmann::json::array({"noise"}));
  CHECK(truth.at("effects").at("parameters").at("noise.psd").at("value") == 4e-5);
}

TEST_CASE("rig campaign: the same seed writes the same files, effects drawn at random stay in range", "[rig][campaign]") {
  const gearwatch::testing::TempDir dir("rig-campaign-seed");
  auto make = [&](const std::string& name, int seed) {
    const auto r = run_command(gearwatch_cmd("simulate --campaign healthy --records 2 --seconds 0.2 --channels 1 --effects all --seed " +
                                             std::to_string(seed) + " --out " + (dir / name).string()));
    INFO(r.err);
    REQUIRE(r.status == 0);
  };
  make("a", 5);
  make("b", 5);
  make("c", 6);
  for (const auto& e : fs::directory_iterator(dir / "a")) {
    const auto name = e.path().filename();
    CHECK(read_file(dir / "a" / name) == read_file(dir / "b" / name));
    if (name.extension() == ".log") CHECK(read_file(dir / "a" / name) != read_file(dir / "c" / name));
  }
  const auto truth = nlohmann::json::parse(read_file(dir / "a" / "truth.json"));
  CHECK(truth.at("effect_parameters_drawn_at_random") == true);
  CHECK(truth.at("effects").at("enabled").size() == gearwatch::rig::all_effects().size());
  for (const auto& [name, p] : truth.at("effects").at("parameters").items()) {
    const auto* info = gearwatch::rig::find_effect_parameter(name);
    REQUIRE(info);
    CHECK(p.at("value").get<double>() >= info->low);
    CHECK(p.at("value").get<double>() <= info->high);
  }
  CHECK(truth.at("effects").at("tooth_pattern_um").at("pinion_spacing").size() == 19);
}

TEST_CASE("rig campaign: refusals name the cause and write nothing", "[rig][campaign]") {
  const gearwatch::testing::TempDir dir("rig-campaign-refuse");
  // Far more than any disk: refused before the directory is created.
  const auto big = dir / "big";
  auto r = run_command(gearwatch_cmd("simulate --campaign lubricated --records 100000 --seconds 3600 --out " + big.string()));
  CHECK(r.status != 0);
  CHECK_THAT(r.err, Contains("MB free") && Contains("nothing written"));
  CHECK_FALSE(fs::exists(big));
  // A campaign file with a parameter out of its range: the key and the line.
  const auto file = dir / "bad.toml";
  std::ofstream(file) << "[campaign]\nmax_cycles = 1000\n[effects]\nenabled = [\"mounting\"]\n[effects.mounting]\nfrequency_hz = 90000\n";
  r = run_command(gearwatch_cmd("simulate --campaign " + file.string() + " --out " + (dir / "x").string()));
  CHECK(r.status != 0);
  CHECK_THAT(r.err, Contains("line 6") && Contains("mounting.frequency_hz"));
  CHECK_FALSE(fs::exists(dir / "x"));
  // Archard wear that passes the wear loop's 0.5 mm depth limit before the last stop: refused
  // before anything is written (the truth is computed for every record first).
  const auto worn = dir / "worn.toml";
  std::ofstream(worn) << "[campaign]\nmax_cycles = 38000\nrecords = 3\ntorque_nm = 5.0\n"
                         "[wear]\nlaw = \"archard\"\n[[wear.phase]]\nfrom_cycles = 0\nk_wear = 1.0e-10\n";
  r = run_command(gearwatch_cmd("simulate --campaign " + worn.string() + " --seconds 0.2 --out " + (dir / "w").string()));
  CHECK(r.status != 0);
  CHECK_THAT(r.err, Contains("depth limit") && Contains("nothing written"));
  CHECK_FALSE(fs::exists(dir / "w"));
  r = run_command(gearwatch_cmd("simulate --campaign dry --effects casing,wobble --out " + (dir / "y").string()));
  CHECK(r.status != 0);
  CHECK_THAT(r.err, Contains("wobble"));
  r = run_command(gearwatch_cmd("simulate --campaign nowhere.toml --out " + (dir / "z").string()));
  CHECK(r.status != 0);
  CHECK_THAT(r.err, Contains("nowhere.toml"));
  r = run_command(gearwatch_cmd("simulate --out " + (dir / "f.log").string() + " --effects casing"));
  CHECK(r.status != 0);
  CHECK_THAT(r.err, Contains("--physics rig"));
}

TEST_CASE("rig campaign: the single-capture form with --physics rig carries the rig's channels and encoder", "[rig][campaign]") {
  const gearwatch::testing::TempDir dir("rig-single");
  const auto cap = dir / "one.log";
  const auto r = run_command(gearwatch_cmd("simulate --physics rig --effects all --seed 2 --duration 0.3 --speed 10 --torque 20 --out " +
                                           cap.string() + " --start-revs 1234"));
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK_THAT(r.out, Contains("30000 samples x 2 channels") && Contains("3 tacho edges"));
  CHECK(life_counters(cap).front() == 1234);
}

}  // namespace test_rig_campaign
