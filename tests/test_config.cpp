#include "gearwatch/config/config.hpp"

#include <fstream>

#include <catch2/catch.hpp>

#include "gearwatch/types/token.hpp"

namespace test_config {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::config;

namespace {
std::string error_of(const std::string& text) {
  try {
    parse_config(text, "test.toml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST_CASE("config: an empty file gives the thesis rig's defaults", "[config]") {
  const auto c = parse_config("", "empty.toml");
  CHECK(c.rig.gears.pinion_teeth == 19);
  CHECK(c.rig.gears.gear_teeth == 52);  // §3.2.1; Table 5.1's "20" is a typesetting slip
  CHECK(c.rig.gears.module_m == 2e-3);
  CHECK(c.rig.gears.pressure_angle_deg == 20.0);
  CHECK(c.rig.gears.face_width_m == 20e-3);
  CHECK(c.rig.gears.youngs_modulus_pa == 205e9);
  CHECK(c.rig.gears.poisson_ratio == 0.29);
  CHECK(c.rig.sample_rate_hz == 100000.0);
  CHECK(c.rig.schedule.length_s == 10.0);  // thesis §3.2.2: 10 s records
  CHECK(c.rig.channels.size() == 2);
  CHECK(c.rig.tachos.size() == 1);
  CHECK(c.protocol.vibration_base_id == 0x100);
  CHECK(c.protocol.life_counter_id == 0x1F2);
  CHECK(c.acquisition.source == SourceKind::socketcan);
}

TEST_CASE("config: values are read with their units", "[config]") {
  const auto c = parse_config(R"(
[gears]
module_mm = 3
face_width_mm = 25.5
youngs_modulus_gpa = 210
[[channels]]
number = 3
name = "bearing"
scale = 0.002
[[tachos]]
shaft = 1
edges_per_rev = 60
ratio_to_input = 0.365
[records]
length_s = 4
interval_s = 300
[acquisition]
source = "candump"
capture = "x.log"
[protocol]
vibration_base_id = 0x200
)",
                              "t.toml");
  CHECK(c.rig.gears.module_m == Approx(3e-3));
  CHECK(c.rig.gears.face_width_m == Approx(25.5e-3));
  CHECK(c.rig.gears.youngs_modulus_pa == Approx(210e9));
  REQUIRE(c.rig.channels.size() == 1);
  CHECK(c.rig.channels[0].number == 3);
  CHECK(c.rig.channels[0].scale_m_s2_per_lsb == 0.002);
  CHECK(c.rig.tachos[0].edges_per_rev == 60);
  CHECK(c.rig.tachos[0].ratio_to_input == 0.365);
  CHECK(c.rig.schedule.interval_s == 300);
  CHECK(c.acquisition.source == SourceKind::candump);
  CHECK(c.protocol.vibration_base_id == 0x200);
}

TEST_CASE("config: a bad file names the file, the line and the key", "[config]") {
  CHECK(error_of("[records]\nlength_s = 10\nlenght_s = 5\n") == "test.toml:3: key 'records.lenght_s': unknown key");
  CHECK(error_of("\n[records]\nlength_s = \"ten\"\n") == "test.toml:3: key 'records.length_s': expected a number");
  CHECK(error_of("[rig]\nsample_rate_hz = -5\n") == "test.toml:2: key 'rig.sample_rate_hz': value -5 is outside [100, 1e+07]");
  CHECK(error_of("[records]\nlength_s = 10\ninterval_s = 5\n") ==
        "test.toml:3: key 'records.interval_s': must be at least length_s (records do not overlap)");
  CHECK(error_of("[[channels]]\nnumber = 0\n[[channels]]\nnumber = 0\n") ==
        "test.toml:4: key 'channels.number': channel 0 configured twice");
  CHECK(error_of("[[channels]]\nnumber = 9\n") == "test.toml:2: key 'channels.number': value 9 is outside [0, 7]");
  CHECK(error_of("[acquisition]\nsource = \"serial\"\n") ==
        "test.toml:2: key 'acquisition.source': expected \"socketcan\" or \"candump\", got \"serial\"");
  CHECK(error_of("[storag]\ndatabase = \"x\"\n") == "test.toml:1: key 'storag': unknown table or key");
  CHECK(error_of("[gears]\npinion_teeth = 19.5\n") == "test.toml:2: key 'gears.pinion_teeth': expected an integer");
  // TOML syntax errors keep the parser's description and line.
  const std::string syntax = error_of("[records]\nlength_s = = 3\n");
  CHECK(syntax.rfind("test.toml:2: ", 0) == 0);
}

TEST_CASE("config: a missing file is an error naming it", "[config]") {
  try {
    load_config("does-not-exist.toml");
    FAIL("no error");
  } catch (const ConfigError& e) {
    CHECK(std::string(e.what()) == "does-not-exist.toml: cannot open config file");
  }
}

TEST_CASE("config: the shipped configuration files parse", "[config]") {
  for (const char* rel : {"/config/gearwatch.example.toml", "/systemd/gearwatch.toml"}) {
    const std::string path = std::string(GEARWATCH_SOURCE_DIR) + rel;
    INFO(path);
    const auto c = load_config(path);
    CHECK(c.rig.gears.pinion_teeth == 19);
    CHECK(c.rig.gears.gear_teeth == 52);
  }
  // The example says "an empty file gives exactly these values": check that it does.
  const auto example = load_config(std::string(GEARWATCH_SOURCE_DIR) + "/config/gearwatch.example.toml");
  const auto empty = parse_config("", "empty");
  CHECK(example.rig.sample_rate_hz == empty.rig.sample_rate_hz);
  CHECK(example.rig.schedule.length_s == empty.rig.schedule.length_s);
  CHECK(example.rig.schedule.interval_s == empty.rig.schedule.interval_s);
  CHECK(example.rig.schedule.min_length_s == empty.rig.schedule.min_length_s);
  CHECK(example.rig.channels.size() == empty.rig.channels.size());
  CHECK(example.acquisition.ring_capacity_samples == empty.acquisition.ring_capacity_samples);
  CHECK(example.storage.queue_capacity == empty.storage.queue_capacity);
  CHECK(example.daemon.processing_nice == empty.daemon.processing_nice);
  const auto& p = example.processing;
  const auto& d = empty.processing;
  CHECK(p.samples_per_revolution == d.samples_per_revolution);
  CHECK(p.rms_sa_harmonics == d.rms_sa_harmonics);
  CHECK(p.stored_gmf_harmonics == d.stored_gmf_harmonics);
  CHECK(p.ics2_harmonics == d.ics2_harmonics);
  CHECK(p.ics2_tolerance_bins == d.ics2_tolerance_bins);
  CHECK(p.pitting_band.low_hz == d.pitting_band.low_hz);
  CHECK(p.pitting_band.high_hz == d.pitting_band.high_hz);
  CHECK(p.abrasion_band.low_hz == d.abrasion_band.low_hz);
  CHECK(p.abrasion_band.high_hz == d.abrasion_band.high_hz);
  CHECK(p.filter_bank_levels == d.filter_bank_levels);
  CHECK(p.kurtogram_band_selection == d.kurtogram_band_selection);
  CHECK(p.mean_carrier_ranges.size() == d.mean_carrier_ranges.size());
  CHECK(p.min_revolutions_for_tsa == d.min_revolutions_for_tsa);
  CHECK(p.max_clipped_fraction == d.max_clipped_fraction);
  CHECK(p.trend_significance == d.trend_significance);
  CHECK(p.trend_window_records == d.trend_window_records);
  CHECK(p.band_jump_persistence_records == d.band_jump_persistence_records);
  CHECK(p.band_jump_sigma == d.band_jump_sigma);
  CHECK(p.wear_baseline_records == d.wear_baseline_records);
  CHECK(p.flat_line_max_std_lsb == d.flat_line_max_std_lsb);
  CHECK(p.residual_rms_floor == d.residual_rms_floor);
  CHECK(p.band_energy_floor_db == d.band_energy_floor_db);
  CHECK(example.alerts.wear_clear_after_records == empty.alerts.wear_clear_after_records);
  CHECK(example.alerts.sensor_clear_after_records == empty.alerts.sensor_clear_after_records);
  CHECK(example.alerts.baseline_records == empty.alerts.baseline_records);
  CHECK(example.alerts.threshold_sigma == empty.alerts.threshold_sigma);
  CHECK(example.alerts.threshold_raise_after_records == empty.alerts.threshold_raise_after_records);
  CHECK(example.alerts.threshold_clear_after_records == empty.alerts.threshold_clear_after_records);
  CHECK(example.alerts.watched_indicators == empty.alerts.watched_indicators);
  const auto& m = example.model;
  const auto& md = empty.model;
  CHECK(m.enabled == md.enabled);
  CHECK(m.channel == md.channel);
  CHECK(m.initial_k_wear == md.initial_k_wear);
  CHECK(m.initial_k_pitting == md.initial_k_pitting);
  CHECK(m.update_threshold == md.update_threshold);
  CHECK(m.convergence_tolerance == md.convergence_tolerance);
  CHECK(m.max_wear_iterations == md.max_wear_iterations);
  CHECK(m.correlation_threshold == md.correlation_threshold);
  CHECK(m.pitting_interval_cycles == md.pitting_interval_cycles);
  CHECK(m.simulation_revolutions == md.simulation_revolutions);
  CHECK(m.min_torque_nm == md.min_torque_nm);
  CHECK(m.max_torque_nm == md.max_torque_nm);
  CHECK(m.wear_limit_fraction == md.wear_limit_fraction);
  CHECK(m.pitting_limit == md.pitting_limit);
  CHECK(m.forecast_horizon_cycles == md.forecast_horizon_cycles);
  CHECK(m.remaining_life_alert_cycles == md.remaining_life_alert_cycles);
  CHECK(m.remaining_life_raise_after_records == md.remaining_life_raise_after_records);
  CHECK(m.remaining_life_clear_after_records == md.remaining_life_clear_after_records);
  CHECK(m.queue_capacity == md.queue_capacity);
  CHECK(m.force_model == md.force_model);
  CHECK(m.prior_log_k_wear_sd == md.prior_log_k_wear_sd);
  CHECK(m.log_k_drift_per_million_cycles == md.log_k_drift_per_million_cycles);
  CHECK(m.rms_sa_relative_sd_floor == md.rms_sa_relative_sd_floor);
  CHECK(m.inspection_area_relative_sd == md.inspection_area_relative_sd);
  CHECK(m.disagreement_records == md.disagreement_records);
  CHECK(m.ics2_onset_records == md.ics2_onset_records);
}

TEST_CASE("config: [model] keys, and the errors that name them", "[config][model]") {
  const auto c = parse_config("[model]\nupdate_threshold = 0.08\npitting_limit = 0.2\nchannel = 1\nforce_model = \"dynamic\"\n", "m.toml");
  CHECK(c.model.update_threshold == 0.08);
  CHECK(c.model.pitting_limit == 0.2);
  CHECK(c.model.channel == 1);
  CHECK(c.model.force_model == gearwatch::wear::ForceModel::dynamic);
  CHECK_THROWS_WITH(parse_config("[model]\nchannel = 5\n", "m.toml"),
                    Catch::Contains("key 'model.channel'") && Catch::Contains("not a configured"));
  CHECK_THROWS_WITH(parse_config("[model]\nconvergence_tolerance = 0.1\n", "m.toml"),
                    Catch::Contains("model.convergence_tolerance") && Catch::Contains("update_threshold"));
  CHECK_THROWS_WITH(parse_config("[model]\nwear_limit_fraction = 0.5\n", "m.toml"), Catch::Contains("model.wear_limit_fraction"));
  CHECK_THROWS_WITH(parse_config("[model]\nforce_model = \"fast\"\n", "m.toml"), Catch::Contains("model.force_model"));
  CHECK_THROWS_WITH(parse_config("[model]\nupdate_treshold = 0.05\n", "m.toml"), Catch::Contains("unknown key"));
  // The pitting growth law is opt-in: off unless the file says true.
  CHECK_FALSE(parse_config("", "m.toml").model.pitting_growth_law);
  CHECK(parse_config("[model]\npitting_growth_law = true\n", "m.toml").model.pitting_growth_law);
  CHECK(parse_config("", "m.toml").model.pitting_exponent_from_inspections);
  CHECK_FALSE(parse_config("[model]\npitting_exponent_from_inspections = false\n", "m.toml").model.pitting_exponent_from_inspections);
  CHECK_THROWS_WITH(parse_config("[model]\npitting_growth_law = 1\n", "m.toml"),
                    "m.toml:2: key 'model.pitting_growth_law': expected true or false");
}

TEST_CASE("config: logging.sink and model.force_model are read once into their enums", "[config]") {
  CHECK(parse_config("", "e.toml").logging.sink == LogSink::automatic);
  CHECK(parse_config("", "e.toml").model.force_model == gearwatch::wear::ForceModel::quasi_static);
  CHECK(parse_config("[logging]\nsink = \"auto\"\n", "l.toml").logging.sink == LogSink::automatic);
  CHECK(parse_config("[logging]\nsink = \"journald\"\n", "l.toml").logging.sink == LogSink::journald);
  CHECK(parse_config("[logging]\nsink = \"stderr\"\n", "l.toml").logging.sink == LogSink::standard_error);
  CHECK(parse_config("[model]\nforce_model = \"quasi-static\"\n", "m.toml").model.force_model == gearwatch::wear::ForceModel::quasi_static);
  // A bad value: one line naming the file, the line, the key and what it may be.
  CHECK_THROWS_WITH(parse_config("[logging]\nsink = \"syslog\"\n", "l.toml"),
                    Catch::Equals("l.toml:2: key 'logging.sink': expected auto, journald or stderr"));
  CHECK_THROWS_WITH(parse_config("[logging]\nsink = 3\n", "l.toml"),
                    Catch::Equals("l.toml:2: key 'logging.sink': expected auto, journald or stderr"));
  CHECK_THROWS_WITH(parse_config("[model]\nforce_model = \"quasi_static\"\n", "m.toml"),
                    Catch::Equals("m.toml:2: key 'model.force_model': expected \"quasi-static\" or \"dynamic\""));
  // The tokens are each value's to_string, and back; none other is read.
  for (LogSink s : kAllLogSinks) CHECK(gearwatch::from_token(kAllLogSinks, to_string(s)) == s);
  for (gearwatch::wear::ForceModel m : gearwatch::wear::kAllForceModels) CHECK(gearwatch::from_token(gearwatch::wear::kAllForceModels, gearwatch::wear::to_string(m)) == m);
}

TEST_CASE("config: [processing] sets the signal-processing settings", "[config]") {
  const auto c = parse_config(R"(
[processing]
rms_sa_harmonics = 6
pitting_band_hz = [2500, 12000]
abrasion_band_hz = [21000, 36000]
mean_carrier_ranges_hz = [[0, 20000], [1000, 45000]]
filter_bank_levels = 5
trend_significance = 0.01
)",
                              "p.toml");
  CHECK(c.processing.rms_sa_harmonics == 6);  // the thesis's choice for severe profile change (§7.4.2)
  CHECK(c.processing.pitting_band.low_hz == 2500);
  CHECK(c.processing.abrasion_band.high_hz == 36000);
  REQUIRE(c.processing.mean_carrier_ranges.size() == 2);
  CHECK(c.processing.mean_carrier_ranges[1].low_hz == 1000);
  CHECK(c.processing.filter_bank_levels == 5);
  CHECK(c.processing.trend_significance == 0.01);
  const auto d = parse_config("", "d.toml");
  CHECK(d.processing.pitting_band.low_hz == 2000);   // thesis §4.4
  CHECK(d.processing.abrasion_band.low_hz == 20000);
  CHECK(error_of("[processing]\npitting_band_hz = [13000, 2000]\n") ==
        "test.toml:2: key 'processing.pitting_band_hz': needs 0 <= low_hz < high_hz");
  CHECK(error_of("[processing]\nabrasion_band_hz = 3\n") == "test.toml:2: key 'processing.abrasion_band_hz': expected [low_hz, high_hz]");
  CHECK(error_of("[processing]\nabrasion_band_hz = [2, \"x\"]\n") ==
        "test.toml:2: key 'processing.abrasion_band_hz': expected [low_hz, high_hz]");
}

TEST_CASE("config: processing.wear_baseline_records is read, 0 turns it off, and values outside 0 or [10, 200] are refused",
          "[config]") {
  CHECK(parse_config("", "d.toml").processing.wear_baseline_records == 50);
  CHECK(parse_config("[processing]\nwear_baseline_records = 30\n", "p.toml").processing.wear_baseline_records == 30);
  CHECK(parse_config("[processing]\nwear_baseline_records = 0\n", "p.toml").processing.wear_baseline_records == 0);
  CHECK_THAT(error_of("[processing]\nwear_baseline_records = 5\n"), Catch::Contains("wear_baseline_records must be 0 or in [10, 200]"));
  CHECK_THAT(error_of("[processing]\nwear_baseline_records = 500\n"), Catch::Contains("processing.wear_baseline_records"));
  CHECK_THAT(error_of("[processing]\nwear_baseline_records = 2.5\n"), Catch::Contains("processing.wear_baseline_records"));
}

// Found by fuzz_config: an integer a double cannot hold exactly (toml++'s value<double>() gives
// nothing for it) in a band aborted the parse with std::bad_optional_access. It is a number: it is
// read as the nearest double, and the band is then judged like any other.
TEST_CASE("config: a band edge written as a huge integer is read as a number", "[config][fuzz]") {
  const auto c = parse_config("[processing]\nmean_carrier_ranges_hz = [[0, 300], [0, 5100000200100002000]]\n", "p.toml");
  REQUIRE(c.processing.mean_carrier_ranges.size() == 2);
  CHECK(c.processing.mean_carrier_ranges[1].high_hz == static_cast<double>(5100000200100002000LL));
  CHECK(error_of("[processing]\npitting_band_hz = [5100000200100002000, 300]\n") ==
        "test.toml:2: key 'processing.pitting_band_hz': needs 0 <= low_hz < high_hz");
}

}  // namespace test_config
