// The daemon's gap step: the twin_drift alert over known sequences of reports, the schedule that
// picks training and held-out records, and the model thread running an injected diagnosis
// (a test double returning known reports: the diagnosis itself is tested on its own) every N
// records, storing the reports with their alerts, which survive a restart.
#include "gap_monitor.hpp"

#include <cmath>
#include <map>
#include <mutex>
#include <numbers>
#include <thread>

#include <catch2/catch.hpp>

#include "capture_writer.hpp"
#include "gap_diagnoser.hpp"
#include "gearwatch/twin/gearbox_parameters.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "gap_report_fixture.hpp"
#include "gearwatch/rig/rig_simulator.hpp"
#include "gearwatch/storage/gap_reports.hpp"
#include "gearwatch/storage/sqlite.hpp"
#include "model_thread.hpp"
#include "pipeline.hpp"
#include "temp_dir.hpp"

namespace test_gap_monitor {  // this file's own: the test files compile together (unity build)

using namespace gearwatch;
using gap::FamilyKind;

namespace {

// The known report with each family's significance set as given (distance kept).
gap::GapReport with_significant(std::map<FamilyKind, bool> significant, double distance_scale = 1.0) {
  gap::GapReport r = testing::known_gap_report();
  for (auto& g : r.before) {
    const auto it = significant.find(g.family);
    g.significant = it != significant.end() && it->second;
    g.distance_db *= distance_scale;
  }
  return r;
}

std::map<std::string, std::string> transitions(const std::vector<AlertEvent>& events) {
  std::map<std::string, std::string> out;
  for (const auto& e : events) out[e.key.subject] = std::string(to_string(e.transition)) + " " + e.value;
  return out;
}

}  // namespace

TEST_CASE("twin drift: a newly significant family raises a warning once, with its distance, and clears when no longer significant",
          "[twin_drift][alerts]") {
  AlertTracker tracker;
  const AlertHysteresis h{1, 1};
  // Report 1: the known report has input_sidebands, output_sidebands and fixed_frequency significant.
  auto events = daemon::observe_twin_drift(tracker, testing::known_gap_report(), h);
  CHECK(transitions(events) == std::map<std::string, std::string>{{"fixed_frequency", "raised 12.6 dB"},
                                                                  {"input_sidebands", "raised 2.1 dB"},
                                                                  {"output_sidebands", "raised 4.8 dB"}});
  for (const auto& e : events) {
    CHECK(e.key.kind == AlertKind::twin_drift);
    CHECK(e.key.channel == -1);
    CHECK(e.severity == AlertSeverity::warning);
  }
  CHECK(events.size() == 3);
  const auto fixed = std::find_if(events.begin(), events.end(), [](const AlertEvent& e) { return e.key.subject == "fixed_frequency"; });
  CHECK(fixed->message.find("attributed to casing_mode") != std::string::npos);
  const auto output = std::find_if(events.begin(), events.end(), [](const AlertEvent& e) { return e.key.subject == "output_sidebands"; });
  CHECK(output->message.find("no candidate effect explains it") != std::string::npos);
  // Report 2: the same families, distances 20 % larger: still raised, nothing new for staff.
  events = daemon::observe_twin_drift(
      tracker, with_significant({{FamilyKind::input_sidebands, true}, {FamilyKind::output_sidebands, true}, {FamilyKind::fixed_frequency, true}}, 1.2), h);
  CHECK(events.empty());
  CHECK(tracker.state({AlertKind::twin_drift, -1, "fixed_frequency"})->value == "12.6 dB");
  // Report 3: the fixed-frequency gap is gone, the mesh harmonics are new.
  events = daemon::observe_twin_drift(
      tracker, with_significant({{FamilyKind::input_sidebands, true}, {FamilyKind::output_sidebands, true}, {FamilyKind::mesh_harmonics, true}}), h);
  CHECK(transitions(events) == std::map<std::string, std::string>{{"fixed_frequency", "cleared 12.6 dB"},
                                                                  {"mesh_harmonics", "raised 1.2 dB"}});
  CHECK(events.size() == 2);
  // Report 4: the fixed-frequency gap is back: raised again, with today's distance.
  events = daemon::observe_twin_drift(
      tracker, with_significant({{FamilyKind::input_sidebands, true}, {FamilyKind::output_sidebands, true}, {FamilyKind::mesh_harmonics, true},
                                 {FamilyKind::fixed_frequency, true}}, 2.0), h);
  CHECK(transitions(events) == std::map<std::string, std::string>{{"fixed_frequency", "raised 25.2 dB"}});
}

TEST_CASE("twin drift: hysteresis in reports, and an unresolved family neither raises nor clears", "[twin_drift][alerts]") {
  AlertTracker tracker;
  const AlertHysteresis h{2, 3};
  const auto on = with_significant({{FamilyKind::fixed_frequency, true}});
  const auto off = with_significant({});
  CHECK(daemon::observe_twin_drift(tracker, on, h).empty());          // once: not yet
  CHECK(daemon::observe_twin_drift(tracker, off, h).empty());         // the run is broken
  CHECK(daemon::observe_twin_drift(tracker, on, h).empty());
  CHECK(transitions(daemon::observe_twin_drift(tracker, on, h)) ==    // twice in a row: raised
        std::map<std::string, std::string>{{"fixed_frequency", "raised 12.6 dB"}});
  gap::GapReport unresolved = on;
  unresolved.before[5] = testing::unresolved_gap(FamilyKind::fixed_frequency, "fixed_frequency needs records at >= 2 speeds");
  for (int i = 0; i < 5; ++i) CHECK(daemon::observe_twin_drift(tracker, unresolved, h).empty());
  CHECK(tracker.state({AlertKind::twin_drift, -1, "fixed_frequency"})->active);
  CHECK(daemon::observe_twin_drift(tracker, off, h).empty());
  CHECK(daemon::observe_twin_drift(tracker, off, h).empty());
  CHECK(transitions(daemon::observe_twin_drift(tracker, off, h)) ==   // three absent in a row: cleared
        std::map<std::string, std::string>{{"fixed_frequency", "cleared 12.6 dB"}});
  // The output shaft orders are unresolved in every report of this test: never observed.
  CHECK(tracker.state({AlertKind::twin_drift, -1, "output_shaft_orders"}) == nullptr);
}

TEST_CASE("gap schedule: every N records, the newest training + held-out records, held out the newest", "[twin_drift][daemon]") {
  daemon::GapSchedule schedule(3, 2, 1);
  std::vector<bool> due;
  for (std::uint64_t i = 1; i <= 9; ++i) {
    daemon::GapSample s;
    s.start_index = i;
    due.push_back(schedule.add(s).due);
    if (due.back()) {
      const auto [training, held_out] = schedule.split();
      REQUIRE(training.size() == 2);
      REQUIRE(held_out.size() == 1);
      CHECK(training[0]->start_index == i - 2);
      CHECK(training[1]->start_index == i - 1);
      CHECK(held_out[0]->start_index == i);
    }
  }
  CHECK(due == std::vector<bool>{false, false, true, false, false, true, false, false, true});
  CHECK_THROWS_AS(daemon::GapSchedule(0, 2, 1), std::invalid_argument);
}

namespace {

struct Call {
  std::vector<std::uint64_t> training, held_out;
  std::vector<std::uint64_t> twin_training;  ///< start indices of the twin counterparts handed over
  std::vector<double> wear_cycles;           ///< the wear state's cycles of each counterpart, training then held out
  bool rerun = false;                        ///< the call could re-run the twin
  bool k_wear = false;                       ///< the call asked for K_wear
};

// A diagnosis double: notes what it was given, returns the next of the given reports.
struct ScriptedDiagnosis {
  std::vector<gap::GapReport> reports;
  std::vector<Call> calls;
  daemon::GapHooks hooks() {
    daemon::GapHooks h;
    h.diagnose = [this](const std::vector<gap::DiagnosisInput>& training, const std::vector<gap::DiagnosisInput>& held_out,
                        const daemon::GapCallContext& context) {
      Call c;
      c.rerun = static_cast<bool>(context.rerun_twin);
      c.k_wear = context.reference_k_wear.has_value();
      for (const auto& d : training) {
        c.training.push_back(d.measured.start_index);
        c.twin_training.push_back(d.twin.start_index);
        c.wear_cycles.push_back(d.twin.speed_hz);
      }
      for (const auto& d : held_out) {
        c.held_out.push_back(d.measured.start_index);
        c.wear_cycles.push_back(d.twin.speed_hz);
      }
      calls.push_back(c);
      if (calls.size() > reports.size()) throw std::invalid_argument("records too short");
      return reports[calls.size() - 1];
    };
    // The counterpart marks what it made: start index + 1000000, the wear state's cycles in speed_hz.
    h.twin = [](const Record& measured, const wear::WearState& state) {
      Record twin = measured;
      twin.start_index = measured.start_index + 1000000;
      twin.speed_hz = state.cycles;
      return twin;
    };
    return h;
  }
};

daemon::ModelInput input_at(double cycles) {
  daemon::ModelInput in;
  in.start_index = static_cast<std::uint64_t>(cycles);
  in.observation = {0, cycles, 10, 5, std::nullopt, std::nullopt};
  auto record = std::make_shared<Record>();
  record->start_index = in.start_index;
  record->sample_rate_hz = 1000;
  record->channels = {std::vector<float>(100, 0.5f)};
  record->channel_numbers = {0};
  record->input_revolutions = cycles;
  in.samples = record;
  return in;
}

}  // namespace

TEST_CASE("model thread: every N records the injected diagnosis gets the newest records with their twin counterparts, and reports and "
          "twin_drift alerts are stored and survive a restart",
          "[twin_drift][daemon][model]") {
  const testing::TempDir dir("gap-model");
  const auto db = dir / "a.db";
  auto cfg = config::parse_config("[model]\nforecast_horizon_cycles = 100000.0\n"
                                  "[gap]\nenabled = true\nevery_records = 2\ntraining_records = 2\nheld_out_records = 1\n"
                                  "drift_clear_after_reports = 1\n",
                                  "test");
  cfg.storage.database = db.string();
  ScriptedDiagnosis script;
  script.reports = {testing::known_gap_report(),
                    with_significant({{FamilyKind::input_sidebands, true}, {FamilyKind::output_sidebands, true}}, 1.5),
                    with_significant({{FamilyKind::input_sidebands, true}, {FamilyKind::output_sidebands, true}}, 1.5)};
  script.reports[1].input_revolutions = 5000;
  {
    storage::StorageWriter writer(storage::WriterOptions{db.string(), 5000, 256, 512, 200, 30000, 60.0, {}, std::nullopt});
    writer.start();
    daemon::ModelThread model(cfg, writer, true, script.hooks());
    model.start();
    for (double cycles : {1000.0, 2000.0, 3000.0, 4000.0, 5000.0}) model.submit(input_at(cycles));
    // One without samples (gap disabled upstream, or a record the processing could not pass on): not counted.
    auto bare = input_at(6000.0);
    bare.samples.reset();
    model.submit(bare);
    model.stop();
    writer.stop();
    CHECK(model.counters().gap_reports == 2);
    CHECK(model.counters().gap_failures == 0);
    CHECK(model.counters().gap_k_wear_skipped == 2);  // counted, and the reports still stored
  }
  REQUIRE(script.calls.size() == 2);
  CHECK(script.calls[0].training == std::vector<std::uint64_t>{1000, 2000});
  CHECK(script.calls[0].held_out == std::vector<std::uint64_t>{3000});
  CHECK(script.calls[0].twin_training == std::vector<std::uint64_t>{1001000, 1002000});
  // Each counterpart is simulated at the wear state the model reached at its own record.
  CHECK(script.calls[0].wear_cycles == std::vector<double>{1000, 2000, 3000});
  // An injected counterpart brings no configured rerun; its records have no tacho, so the twin's
  // RMS_SA elasticity cannot be read and the report goes without K_wear.
  CHECK_FALSE(script.calls[0].rerun);
  CHECK_FALSE(script.calls[0].k_wear);
  CHECK(script.calls[1].training == std::vector<std::uint64_t>{3000, 4000});
  CHECK(script.calls[1].held_out == std::vector<std::uint64_t>{5000});

  {
    storage::Database d(db.string(), storage::Database::Mode::read_only);
    const auto stored = storage::load_gap_reports(d);
    REQUIRE(stored.size() == 2);
    CHECK(stored[0].report.input_revolutions == 123456.789);
    CHECK(stored[1].report.input_revolutions == 5000);
    // The report is tied to the newest record it used; no record rows exist here (the model was fed directly).
    CHECK_FALSE(stored[0].context.record_id);
    storage::Statement a(d, "SELECT subject, transition, value FROM alerts WHERE kind = 'twin_drift' ORDER BY id");
    std::vector<std::string> rows;
    while (a.step()) rows.push_back(a.get_text(0) + " " + a.get_text(1) + " " + a.get_text(2));
    CHECK(rows == std::vector<std::string>{"input_sidebands raised 2.1 dB", "output_sidebands raised 4.8 dB",
                                           "fixed_frequency raised 12.6 dB", "fixed_frequency cleared 12.6 dB"});
    storage::Statement active(d, "SELECT group_concat(subject, ',') FROM (SELECT subject FROM active_alerts WHERE kind = 'twin_drift' ORDER BY subject)");
    REQUIRE(active.step());
    CHECK(active.get_text(0) == "input_sidebands,output_sidebands");
  }

  // A new process: the raised families are not raised again by the same findings.
  ScriptedDiagnosis again;
  again.reports = {script.reports[2]};
  {
    storage::StorageWriter writer(storage::WriterOptions{db.string(), 5000, 256, 512, 200, 30000, 60.0, {}, std::nullopt});
    writer.start();
    daemon::ModelThread model(cfg, writer, true, again.hooks());
    model.start();
    for (double cycles : {7000.0, 8000.0, 9000.0}) model.submit(input_at(cycles));
    model.stop();
    writer.stop();
    CHECK(model.counters().gap_reports == 1);
  }
  storage::Database d(db.string(), storage::Database::Mode::read_only);
  storage::Statement count(d, "SELECT count(*), (SELECT count(*) FROM gap_report_runs) FROM alerts WHERE kind = 'twin_drift'");
  REQUIRE(count.step());
  CHECK(count.get_int(0) == 4);
  CHECK(count.get_int(1) == 3);
}

TEST_CASE("model thread: a diagnosis that throws is counted and stores nothing",
          "[twin_drift][daemon][model]") {
  const testing::TempDir dir("gap-model-fail");
  const auto db = dir / "a.db";
  auto cfg = config::parse_config("[gap]\nenabled = true\nevery_records = 1\ntraining_records = 1\nheld_out_records = 1\n", "test");
  cfg.storage.database = db.string();
  ScriptedDiagnosis script;  // no reports: every call throws
  {
    storage::StorageWriter writer(storage::WriterOptions{db.string(), 5000, 256, 512, 200, 30000, 60.0, {}, std::nullopt});
    writer.start();
    daemon::ModelThread model(cfg, writer, true, script.hooks());
    model.start();
    for (double cycles : {1000.0, 2000.0, 3000.0}) model.submit(input_at(cycles));
    model.stop();
    writer.stop();
    CHECK(model.counters().gap_failures == 2);
    CHECK(model.counters().gap_reports == 0);
    CHECK(model.counters().handled == 3);
  }
  {
    storage::Database d(db.string(), storage::Database::Mode::read_only);
    CHECK(storage::load_gap_reports(d).empty());
  }
}

TEST_CASE("config: [gap] keys with their defaults, ranges and file:line errors", "[twin_drift][config]") {
  const auto defaults = config::parse_config("", "d.toml");
  CHECK_FALSE(defaults.gap.enabled);
  CHECK(defaults.gap.every_records == 50);
  CHECK(defaults.gap.training_records == 4);
  CHECK(defaults.gap.held_out_records == 2);
  CHECK(defaults.gap.drift_raise_after_reports == 1);
  CHECK(defaults.gap.drift_clear_after_reports == 2);
  CHECK(defaults.gap.rerun_twin);
  CHECK_FALSE(config::parse_config("[gap]\nrerun_twin = false\n", "c.toml").gap.rerun_twin);
  CHECK_THROWS_WITH(config::parse_config("[gap]\nrerun_twin = 1\n", "c.toml"), "c.toml:2: key 'gap.rerun_twin': expected true or false");
  // Off, the daemon binds no rerun: misalignment and tip relief keep their spectral forms.
  CHECK_FALSE(daemon::make_twin_rerun(twin::GearboxParameters{}, config::parse_config("[gap]\nrerun_twin = false\n", "c.toml")));
  CHECK(daemon::make_twin_rerun(twin::GearboxParameters{}, defaults));
  const auto c = config::parse_config("[gap]\nenabled = true\nevery_records = 7\nbootstrap_resamples = 50\nseed = 9\n", "c.toml");
  CHECK(c.gap.enabled);
  CHECK(c.gap.every_records == 7);
  CHECK(c.gap.bootstrap_resamples == 50);
  CHECK(c.gap.seed == 9);
  CHECK_THROWS_WITH(config::parse_config("[gap]\nevry_records = 7\n", "c.toml"), "c.toml:2: key 'gap.evry_records': unknown key");
  CHECK_THROWS_WITH(config::parse_config("[gap]\n\nenabled = \"yes\"\n", "c.toml"), "c.toml:3: key 'gap.enabled': expected true or false");
  CHECK_THROWS_WITH(config::parse_config("[gap]\nheld_out_records = 0\n", "c.toml"),
                    "c.toml:2: key 'gap.held_out_records': value 0 is outside [1, 64]");
  CHECK_THROWS_WITH(config::parse_config("[gap]\nevery_records = 2.5\n", "c.toml"), "c.toml:2: key 'gap.every_records': expected an integer");
  CHECK_THROWS_WITH(config::parse_config("[model]\nenabled = false\n[gap]\nenabled = true\n", "c.toml"),
                    Catch::Contains("c.toml:4: key 'gap.enabled'"));
  // The compared channel: the gap channel, else the model's, else the first configured. The records
  // handed to the diagnosis carry that channel alone, at index 0.
  const auto settings = daemon::gap_diagnosis_settings(c);
  CHECK(settings.channel == 0);
  CHECK(settings.bootstrap_resamples == 50);
  CHECK(settings.seed == 9u);
  CHECK(daemon::gap_channel(c) == 0);
  CHECK(daemon::gap_channel(config::parse_config("[model]\nchannel = 1\n", "m.toml")) == 1);
  CHECK(daemon::gap_diagnosis_settings(config::parse_config("[model]\nchannel = 1\n", "m.toml")).channel == 0);
  CHECK(daemon::gap_channel(config::parse_config("[model]\nchannel = 1\n[gap]\nchannel = 0\n", "m.toml")) == 0);
}

TEST_CASE("gap step: the twin's RMS_SA wear elasticity is read from counterparts at wear depths x0.8 and x1.25",
          "[twin_drift][daemon][kwear]") {
  // A counterpart whose first two mesh harmonics (orders 19 and 38) have amplitude (depth / 1 µm)^e:
  // RMS_SA(2) ∝ depth^e, so the central difference in log returns e itself.
  const double fs = 10240, speed = 10;
  auto counterpart_with = [&](double e) {
    return daemon::TwinCounterpart([=](const Record&, const wear::WearState& state) {
      const double a = std::pow(state.pinion_depth_m.at(0) / 1e-6, e);
      const auto n = static_cast<std::size_t>(20.5 * fs / speed);
      std::vector<float> x(n);
      for (std::size_t i = 0; i < n; ++i) {
        const double t = static_cast<double>(i) / fs;
        x[i] = static_cast<float>(a * std::cos(2 * std::numbers::pi * 19 * speed * t) + 0.5 * a * std::cos(2 * std::numbers::pi * 38 * speed * t + 0.3));
      }
      std::vector<double> edges;
      for (int k = 0; k <= 20; ++k) edges.push_back(k * fs / speed);
      return single_channel_record(std::move(x), std::move(edges), fs, speed, 20);
    });
  };
  wear::WearState state;
  state.pinion_depth_m = {2e-6, 1e-6};
  state.gear_depth_m = {1e-6};
  const Record measured;
  for (double e : {-0.62, 0.11, 1.0}) {
    INFO("e = " << e);
    CHECK(daemon::twin_rms_sa_wear_elasticity(counterpart_with(e), measured, state, 0, GearPairSpec{}, 2) ==
          Approx(e).margin(1e-4));
  }
  // A counterpart with no tacho cannot be read: refused with the reason, which the model thread
  // turns into a report without K_wear.
  const daemon::TwinCounterpart silent = [](const Record&, const wear::WearState&) { return Record{}; };
  CHECK_THROWS_AS(daemon::twin_rms_sa_wear_elasticity(silent, measured, state, 0, GearPairSpec{}, 2), std::invalid_argument);
}

TEST_CASE("gap step: the twin counterpart of a record has its length (2 s at most), rate, channel and operating point, with the tacho at its speed",
          "[twin_drift][daemon]") {
  auto cfg = config::parse_config("[model]\nchannel = 1\n", "test");
  const daemon::TwinCounterpart counterpart = daemon::make_twin_counterpart(twin::GearboxParameters{}, cfg);
  Record measured;
  measured.sample_rate_hz = 20000;
  measured.start_index = 12345;
  measured.channels = {std::vector<float>(4000, 0.0f), std::vector<float>(4000, 0.0f)};
  measured.channel_numbers = {0, 1};
  measured.speed_hz = 20;
  measured.torque_nm = 15;
  measured.input_revolutions = 5000;
  const Record twin = counterpart(measured, wear::WearState{});
  REQUIRE(twin.channels.size() == 1);
  CHECK(twin.channel_numbers == std::vector<int>{1});
  CHECK(std::abs(static_cast<double>(twin.channels[0].size()) - 4000.0) <= 1.0);
  CHECK(twin.sample_rate_hz == 20000);
  CHECK(twin.start_index == 12345);
  CHECK(twin.speed_hz == 20);
  CHECK(twin.torque_nm == 15);
  CHECK(twin.input_revolutions == 5000.0);
  // One edge per input revolution: 0.2 s at 20 Hz is 4 revolutions, 1000 samples apart.
  const auto& edges = twin.tacho_edges[0];
  REQUIRE(edges.size() >= 3);
  const double spacing = (edges.back() - edges.front()) / static_cast<double>(edges.size() - 1);
  CHECK(spacing == Approx(1000.0).epsilon(0.01));
  double energy = 0;
  for (float v : twin.channels[0]) energy += static_cast<double>(v) * v;
  CHECK(std::isfinite(energy));
  CHECK(energy > 0);
  // A 10 s record at 20 Hz: 20 revolutions take 1 s, so the counterpart is 2 s (gap::twin_duration_s).
  Record long_record = measured;
  long_record.channels = {std::vector<float>(200000, 0.0f), std::vector<float>(200000, 0.0f)};
  CHECK(std::abs(static_cast<double>(counterpart(long_record, wear::WearState{}).channels[0].size()) - 40000.0) <= 1.0);

  SECTION("re-run with a candidate's addition: the twin simulated with that addition, as long as asked, sample for sample") {
    const auto rerun = daemon::make_twin_rerun(twin::GearboxParameters{}, cfg);
    REQUIRE(rerun);
    twin::SimulationOptions options;
    options.sample_rate_hz = 20000;
    options.face_misalignment_rad = 1e-4;
    const double duration_s = measured.duration_s() / 2;
    const auto direct = twin::simulate_casing_signal(twin::GearboxParameters{}, {}, {20, 15}, duration_s, options);
    REQUIRE(direct.acceleration.size() == static_cast<std::size_t>(std::lround(duration_s * 20000)));
    const Record misaligned = rerun(measured, wear::WearState{}, gap::CandidateEffect::misalignment, {1e-4}, duration_s);
    CHECK(misaligned.channel_numbers == std::vector<int>{1});
    CHECK(misaligned.start_index == 12345);
    REQUIRE(misaligned.channels[0].size() == direct.acceleration.size());
    CHECK(misaligned.channels[0] == direct.acceleration);
    CHECK(misaligned.channels[0] != twin.channels[0]);
    CHECK_THROWS_AS(rerun(measured, wear::WearState{}, gap::CandidateEffect::casing_mode, {1.0}, duration_s), std::invalid_argument);
  }
}

// A silent 0.2 s record at 20 kHz with its own stream stamps: what the twin's runs are keyed on
// (speed, torque, rate, length) apart from the stamps each copy must carry.
Record stamped_record(double speed_hz, std::uint64_t start_index, std::uint16_t stream_id) {
  Record r;
  r.sample_rate_hz = 20000;
  r.start_index = start_index;
  r.stream_id = stream_id;
  r.channels = {std::vector<float>(4000, 0.0f)};
  r.channel_numbers = {1};
  r.speed_hz = speed_hz;
  r.torque_nm = 15;
  r.input_revolutions = static_cast<double>(start_index) / 1000;
  return r;
}

TEST_CASE("gap step: records the twin cannot tell apart share their counterpart and reruns, each stamped as its own record",
          "[twin_drift][daemon]") {
  const auto cfg = config::parse_config("[model]\nchannel = 1\n", "test");
  // Two records at 20 Hz (one steady run), one at 25 Hz; one wear state for all, as gap diagnose has.
  std::vector<daemon::GapSample> samples;
  for (const auto& r : {stamped_record(20, 1000, 1), stamped_record(20, 5000, 2), stamped_record(25, 9000, 3)})
    samples.push_back({std::make_shared<const Record>(r), wear::WearState{}, 0, r.start_index, samples.size() + 1});
  const auto shared = daemon::share_twin_runs(samples);
  const auto plain_twin = daemon::make_twin_counterpart(twin::GearboxParameters{}, cfg);
  const auto plain_rerun = daemon::make_twin_rerun(twin::GearboxParameters{}, cfg);
  const auto shared_twin = daemon::make_twin_counterpart(twin::GearboxParameters{}, cfg, shared);
  const auto shared_rerun = daemon::make_twin_rerun(twin::GearboxParameters{}, cfg, shared);
  // The reference: each record's own simulation, unshared.
  for (const auto& s : samples) {
    const Record& m = *s.measured;
    const Record a = shared_twin(m, s.state), b = plain_twin(m, s.state);
    CHECK(a.channels == b.channels);
    CHECK(a.tacho_edges == b.tacho_edges);
    CHECK(a.start_index == m.start_index);
    CHECK(a.stream_id == m.stream_id);
    CHECK(a.input_revolutions == m.input_revolutions);
    const Record c = shared_rerun(m, s.state, gap::CandidateEffect::misalignment, {1e-4}, 0.1);
    const Record d = plain_rerun(m, s.state, gap::CandidateEffect::misalignment, {1e-4}, 0.1);
    CHECK(c.channels == d.channels);
    CHECK(c.start_index == m.start_index);
    CHECK(c.stream_id == m.stream_id);
  }
  // Kept: the 20 Hz records' counterpart and rerun, once each; the 25 Hz record's runs are not kept.
  CHECK(daemon::kept_twin_runs(*shared) == 2);
  // Another addition is a run of its own.
  (void)shared_rerun(*samples[0].measured, samples[0].state, gap::CandidateEffect::misalignment, {2e-4}, 0.1);
  CHECK(daemon::kept_twin_runs(*shared) == 3);
}

TEST_CASE("gap bench: counterparts kept across diagnoses on several threads are each record's own simulation, stamped as it",
          "[twin_drift][daemon][gap_bench_jobs]") {
  const auto cfg = config::parse_config("[model]\nchannel = 1\n", "test");
  // Two diagnoses' records at 20 Hz (other stamps, the same basis) and one at 25 Hz.
  const std::vector<Record> records{stamped_record(20, 1000, 1), stamped_record(20, 5000, 2), stamped_record(25, 9000, 3)};
  const auto kept = daemon::share_twin_counterparts_across_diagnoses();
  const auto plain_twin = daemon::make_twin_counterpart(twin::GearboxParameters{}, cfg);
  const auto kept_twin = daemon::make_twin_counterpart(twin::GearboxParameters{}, cfg, kept);
  // Four threads ask for every counterpart at once, as draws side by side do.
  constexpr int kThreads = 4;
  std::vector<std::vector<Record>> got(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      for (const auto& r : records) got[t].push_back(kept_twin(r, wear::WearState{}));
    });
  for (auto& t : threads) t.join();
  // The reference: each record's own simulation, not kept.
  for (std::size_t i = 0; i < records.size(); ++i) {
    const Record& m = records[i];
    const Record reference = plain_twin(m, wear::WearState{});
    for (int t = 0; t < kThreads; ++t) {
      const Record& a = got[t][i];
      CHECK(a.channels == reference.channels);
      CHECK(a.tacho_edges == reference.tacho_edges);
      CHECK(a.sample_rate_hz == reference.sample_rate_hz);
      CHECK(a.start_index == m.start_index);
      CHECK(a.stream_id == m.stream_id);
      CHECK(a.speed_hz == m.speed_hz);
      CHECK(a.input_revolutions == m.input_revolutions);
    }
  }
  // One run per basis (20 Hz, 25 Hz), however many records and threads asked.
  CHECK(daemon::kept_twin_runs(*kept) == 2);
  // Reruns follow each diagnosis's fits: simulated as without the store, and not kept.
  const auto kept_rerun = daemon::make_twin_rerun(twin::GearboxParameters{}, cfg, kept);
  const auto plain_rerun = daemon::make_twin_rerun(twin::GearboxParameters{}, cfg);
  const Record c = kept_rerun(records[0], wear::WearState{}, gap::CandidateEffect::misalignment, {1e-4}, 0.1);
  const Record d = plain_rerun(records[0], wear::WearState{}, gap::CandidateEffect::misalignment, {1e-4}, 0.1);
  CHECK(c.channels == d.channels);
  CHECK(c.start_index == records[0].start_index);
  CHECK(daemon::kept_twin_runs(*kept) == 2);
}

TEST_CASE("pipeline: a replay hands each analysed record's samples to the gap step, and each report is tied to its newest record",
          "[twin_drift][daemon][pipeline]") {
  const testing::TempDir dir("gap-pipeline");
  daemon::CaptureSettings cs;
  cs.duration_s = 4.0;
  cs.signal.sample_rate_hz = 20000;
  cs.start_revolutions = 1000;
  daemon::write_synthetic_capture(cs, (dir / "cap.log").string());
  auto cfg = config::parse_config("[records]\nlength_s = 1.0\ninterval_s = 1.0\nmin_length_s = 0.5\n"
                                  "[model]\nforecast_horizon_cycles = 100000.0\n"
                                  "[gap]\nenabled = true\nevery_records = 2\ntraining_records = 1\nheld_out_records = 1\n",
                                  "test");
  cfg.acquisition.source = config::SourceKind::candump;
  cfg.acquisition.capture = (dir / "cap.log").string();
  cfg.storage.database = (dir / "a.db").string();
  struct Seen {
    std::size_t samples = 0, channels = 0;
    double rate = 0;
    std::optional<double> revolutions;
  };
  std::vector<Seen> seen;
  daemon::GapHooks hooks;
  hooks.diagnose = [&](const std::vector<gap::DiagnosisInput>& training, const std::vector<gap::DiagnosisInput>& held_out,
                       const daemon::GapCallContext&) {
    for (const auto* list : {&training, &held_out})
      for (const auto& d : *list) seen.push_back({d.measured.sample_count(), d.measured.channels.size(), d.measured.sample_rate_hz,
                                                  d.measured.input_revolutions});
    gap::GapReport r = testing::known_gap_report();
    r.input_revolutions = held_out.back().measured.input_revolutions.value_or(-1);
    return r;
  };
  hooks.twin = [](const Record& measured, const wear::WearState&) { return measured; };
  const auto result = daemon::run_pipeline(cfg, daemon::PipelineMode::replay, hooks);
  REQUIRE(result.exit_status == 0);
  REQUIRE(result.records_analysed == 4);
  // Two diagnoses (records 2 and 4), each of one training and one held-out record: 1 s, 20 kHz, the compared channel.
  REQUIRE(seen.size() == 4);
  for (const auto& s : seen) {
    CHECK(s.samples == 20000);
    CHECK(s.channels == 1);  // the compared channel alone: what the gap step keeps (kept_gap_record)
    CHECK(s.rate == 20000);
  }
  storage::Database d(cfg.storage.database, storage::Database::Mode::read_only);
  // Each report belongs to the newest record it used: that record's life position is the report's.
  storage::Statement s(d, "SELECT g.input_revolutions, r.input_revolutions, r.start_index FROM gap_report_runs g"
                          " JOIN records r ON r.id = g.record_id ORDER BY g.id");
  std::vector<std::uint64_t> starts;
  while (s.step()) {
    CHECK(s.get_double(0) == s.get_double(1));
    starts.push_back(static_cast<std::uint64_t>(s.get_int(2)));
  }
  CHECK(starts == std::vector<std::uint64_t>{20000, 60000});
  // The life positions handed over are the stored records' (the first report's held-out record is the second).
  REQUIRE(seen[1].revolutions);
  storage::Statement second(d, "SELECT input_revolutions FROM records WHERE start_index = 20000");
  REQUIRE(second.step());
  CHECK(*seen[1].revolutions == second.get_double(0));
}

namespace {

// A rig-simulator record (the truth, with the given effects) as the processing thread hands it to
// the model: one channel, the input encoder as tacho, the operating point and life position.
daemon::ModelInput rig_input(const rig::EffectSet& effects, double speed_hz, double cycles, std::uint64_t seed) {
  rig::RigRunSettings run;
  run.speed_hz = speed_hz;
  run.torque_nm = 20.0;
  run.duration_s = 2.0;
  run.sample_rate_hz = 50000.0;
  run.channels = 1;
  run.seed = seed;
  const auto r = rig::simulate_record(twin::GearboxParameters{}, effects, {}, {}, run);
  auto record = std::make_shared<Record>(single_channel_record(r.acceleration[0], r.tacho_edges, r.sample_rate_hz, speed_hz, 20.0));
  record->start_index = static_cast<std::uint64_t>(cycles);
  record->input_revolutions = cycles;
  daemon::ModelInput in;
  in.start_index = record->start_index;
  in.observation = {0, cycles, speed_hz, 20.0, std::nullopt, std::nullopt};
  in.samples = record;
  return in;
}

// Runs the model thread with the daemon's own binding of the diagnosis (no injected hooks) on four
// rig records at four speeds: the two older train, the two newest are held out.
std::vector<storage::StoredGapReport> diagnose_through_daemon(const testing::TempDir& dir, const rig::EffectSet& effects) {
  const auto db = dir / "gap.db";
  auto cfg = config::parse_config("[gap]\nenabled = true\nevery_records = 4\ntraining_records = 2\nheld_out_records = 2\n", "test");
  cfg.storage.database = db.string();
  {
    storage::StorageWriter writer(storage::WriterOptions{db.string(), 5000, 256, 512, 200, 30000, 60.0, {}, std::nullopt});
    writer.start();
    daemon::ModelThread model(cfg, writer, true);
    model.start();
    std::uint64_t seed = 7;
    for (const auto& [speed, cycles] : std::vector<std::pair<double, double>>{{8, 1000}, {14, 2000}, {11, 3000}, {17, 4000}})
      model.submit(rig_input(effects, speed, cycles, seed++));
    model.stop();
    writer.stop();
    CHECK(model.counters().gap_failures == 0);
    CHECK(model.counters().gap_reports == 1);
  }
  storage::Database d(db.string(), storage::Database::Mode::read_only);
  return storage::load_gap_reports(d);
}

}  // namespace

TEST_CASE("daemon's gap diagnosis end to end: rig tooth errors withheld from the twin are found, stored and raise twin drift",
          "[twin_drift][daemon][model][gap_e2e]") {
  const testing::TempDir dir("gap-e2e-tooth");
  rig::EffectSet effects;
  effects.enable(rig::Effect::tooth_errors);
  const auto reports = diagnose_through_daemon(dir, effects);
  REQUIRE(reports.size() == 1);
  const auto& report = reports[0].report;
  CHECK(report.training_records == 2);
  CHECK(report.held_out_records == 2);
  // The truth's effect is the first chosen, and a family tooth errors act on is significant.
  REQUIRE_FALSE(report.chosen.empty());
  CHECK(report.chosen.front() == gap::CandidateEffect::tooth_errors);
  // The daemon binds the twin rerun (`rerun_twin` defaults to true): misalignment and tip relief were
  // fitted over their grids, so they carry the grid's values, not their spectral forms' gains.
  for (const auto& c : report.candidates) {
    if (c.effect == gap::CandidateEffect::misalignment) CHECK(c.parameters.front().first == "angle_rad");
    if (c.effect == gap::CandidateEffect::tip_relief) CHECK(c.parameters.front().first == "amount_m");
  }
  bool own_family_significant = false;
  for (const auto& g : report.before)
    if (g.significant && (g.family == gap::FamilyKind::input_shaft_orders || g.family == gap::FamilyKind::output_shaft_orders ||
                          g.family == gap::FamilyKind::input_sidebands || g.family == gap::FamilyKind::output_sidebands))
      own_family_significant = true;
  CHECK(own_family_significant);
  storage::Database d((dir / "gap.db").string(), storage::Database::Mode::read_only);
  storage::Statement s(d, "SELECT count(*) FROM alerts WHERE kind = 'twin_drift' AND transition = 'raised'");
  REQUIRE(s.step());
  CHECK(s.get_int(0) >= 1);
}

TEST_CASE("daemon's gap diagnosis end to end: the rig without effects gives a report with no significant family and no alert",
          "[twin_drift][daemon][model][gap_e2e]") {
  const testing::TempDir dir("gap-e2e-none");
  const auto reports = diagnose_through_daemon(dir, rig::EffectSet{});
  REQUIRE(reports.size() == 1);
  for (const auto& g : reports[0].report.before) {
    INFO(gap::to_string(g.family) << " " << g.distance_db << " dB");
    CHECK_FALSE(g.significant);
  }
  CHECK(reports[0].report.chosen.empty());
  storage::Database d((dir / "gap.db").string(), storage::Database::Mode::read_only);
  storage::Statement s(d, "SELECT count(*) FROM alerts WHERE kind = 'twin_drift'");
  REQUIRE(s.step());
  CHECK(s.get_int(0) == 0);
}

}  // namespace test_gap_monitor
