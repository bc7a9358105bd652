// `gearwatch commission --capture BASELINE`: the twin fitted to a gear pair it has never seen
// (docs/twin.md, "Commissioning"). The twin is built from [gears] (gear bodies from the geometry
// where [twin] does not give them); its mesh-stiffness scale is fitted to the baseline's spectral
// shape (the thesis's §5.3 step, made independent of the sensor's sensitivity) and its casing path
// gain to the baseline's RMS_SA; the other records of the capture check the fit at their own
// speed and torque. Prints the fitted [twin] table and writes it with --write.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include <nlohmann/json.hpp>

#include "capture_records.hpp"
#include "cli_common.hpp"
#include "commands.hpp"
#include "gearwatch/config/twin_config.hpp"
#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "model_thread.hpp"
#include "record_processing.hpp"

namespace gearwatch::cli {
namespace {

struct CommissionOptions {
  std::string capture, config, write, format = "table";
  std::vector<std::string> checks;  ///< captures whose records check the fit (held out of it)
  double cutoff_hz = 2000.0;
};

/// One record of the capture as the commissioning sees it.
struct MeasuredRecord {
  std::string capture;
  std::uint64_t start_index = 0;
  double sample_rate_hz = 0, duration_s = 0, speed_hz = 0, torque_nm = 0;
  double rms_sa = 0;         ///< RMS_SA(N) by the measurement pipeline
  double low_band_rms = 0;   ///< casing RMS below the cutoff
};

/// The twin at one record's operating point and rate.
struct TwinReading {
  double rms_sa = 0, low_band_rms = 0;
};

/// One record after the fit: measured against the commissioned twin.
struct CheckedRecord {
  MeasuredRecord measured;
  double simulated_rms_sa = 0;
  double error() const { return simulated_rms_sa / measured.rms_sa - 1.0; }
};

constexpr double kMeshScaleLow = 0.5, kMeshScaleHigh = 1.5;  // the thesis's plausible range (§5.3)
constexpr double kTargetError = 0.05;                        // RMS_SA sim vs measured on the baseline

class Commissioning {
 public:
  explicit Commissioning(const CommissionOptions& o) : options_(o), config_(load_config_or_defaults(o.config)) {}

  void run() {
    measure_records();
    build_twin_from_gears();
    fit_mesh_stiffness_scale();
    fit_casing_path_gain();
    check_records();
    print();
    if (!options_.write.empty()) write_twin_table();
  }

 private:
  // Step 1: the captures' records through the daemon's own record processing.
  void measure_records() {
    measured_ = measure_capture(options_.capture);
    if (measured_.empty())
      throw CommandError(options_.capture + ": no record with RMS_SA, speed and torque on channel " +
                         std::to_string(daemon::model_channel(config_)) + " (the model's channel): nothing to commission on");
    fitted_records_ = measured_.size();
    for (const std::string& check : options_.checks)
      for (MeasuredRecord& m : measure_capture(check)) measured_.push_back(m);
  }

  std::vector<MeasuredRecord> measure_capture(const std::string& capture) const {
    std::vector<Record> records;
    try {
      records = daemon::read_capture_records(capture, config_);
    } catch (const std::exception& e) {
      throw CommandError(e.what());
    }
    std::vector<MeasuredRecord> out;
    const int channel = daemon::model_channel(config_);
    daemon::RecordProcessor processor(config_);
    std::uint64_t sequence = 0;
    for (const Record& r : records) {
      const storage::RecordResult result = processor.process(r, true, ++sequence);
      const auto in = daemon::model_input(result, config_);
      std::size_t slot = r.channel_numbers.size();
      for (std::size_t i = 0; i < r.channel_numbers.size(); ++i)
        if (r.channel_numbers[i] == channel) slot = i;
      if (slot == r.channel_numbers.size() || !in.observation.rms_sa) continue;
      MeasuredRecord m;
      m.capture = capture;
      m.start_index = r.start_index;
      m.sample_rate_hz = r.sample_rate_hz;
      m.duration_s = r.duration_s();
      m.speed_hz = in.observation.speed_hz;
      m.torque_nm = in.observation.torque_nm;
      m.rms_sa = *in.observation.rms_sa;
      if (!(m.rms_sa > 0) || !std::isfinite(m.speed_hz) || !std::isfinite(m.torque_nm)) continue;
      const std::vector<double> x(r.channels[slot].begin(), r.channels[slot].end());
      m.low_band_rms = twin::lowpass_rms(x, m.sample_rate_hz, options_.cutoff_hz);
      out.push_back(m);
    }
    return out;
  }

  // Step 2: the twin of the configured gear pair, unfitted (scale 1, gain 1).
  void build_twin_from_gears() {
    params_ = daemon::model_twin_parameters(config_);
    params_.mesh_stiffness_scale = 1.0;
    params_.casing_path_gain = 1.0;
  }

  TwinReading simulate(const twin::GearboxParameters& p, const MeasuredRecord& m) const {
    RigSpec rig = config_.rig;
    rig.sample_rate_hz = m.sample_rate_hz;
    const double seconds = config_.model.simulation_revolutions / m.speed_hz;
    const twin::OperatingPoint op{m.speed_hz, m.torque_nm};
    TwinReading t;
    try {
      t.rms_sa = twin::simulated_rms_sa(p, {}, op, seconds, rig, config_.processing);
      const twin::CasingSignal s = twin::simulate_casing_signal(p, {}, op, seconds, m.sample_rate_hz);
      t.low_band_rms = twin::lowpass_rms(std::vector<double>(s.acceleration.begin(), s.acceleration.end()), m.sample_rate_hz,
                                         options_.cutoff_hz);
    } catch (const std::exception& e) {
      throw CommandError(std::string("commission: the twin cannot be run at the baseline: ") + e.what());
    }
    return t;
  }

  // log(low-band RMS / RMS_SA): independent of any gain on the path, so the scale is fitted to the
  // spectrum's shape and the gain to its level.
  double shape_mismatch(double scale) {
    twin::GearboxParameters p = params_;
    p.mesh_stiffness_scale = scale;
    ++simulations_;
    const TwinReading t = simulate(p, baseline());
    return std::log(t.low_band_rms / t.rms_sa) - std::log(baseline().low_band_rms / baseline().rms_sa);
  }

  // Step 3: bisection on the shape mismatch over the plausible range; outside it, the nearer end.
  void fit_mesh_stiffness_scale() {
    double a = kMeshScaleLow, b = kMeshScaleHigh;
    double fa = shape_mismatch(a), fb = shape_mismatch(b);
    if (fa * fb > 0) {
      params_.mesh_stiffness_scale = std::abs(fa) < std::abs(fb) ? a : b;
      scale_at_bound_ = true;
      shape_residual_ = std::min(std::abs(fa), std::abs(fb));
      return;
    }
    double m = 0.5 * (a + b), fm = 0;
    for (int i = 0; i < 12; ++i) {
      m = 0.5 * (a + b);
      fm = shape_mismatch(m);
      if (std::abs(fm) < 0.005) break;
      if ((fm > 0) == (fa > 0)) {
        a = m;
        fa = fm;
      } else {
        b = m;
      }
    }
    params_.mesh_stiffness_scale = m;
    shape_residual_ = std::abs(fm);
  }

  // Step 4: RMS_SA is proportional to the path gain, so the gain is the ratio at the fitted scale.
  void fit_casing_path_gain() {
    ++simulations_;
    const TwinReading t = simulate(params_, baseline());
    params_.casing_path_gain = baseline().rms_sa / t.rms_sa;
    try {
      params_.validate();
    } catch (const std::exception& e) {
      throw CommandError(std::string("commission: the fitted twin is not physical: ") + e.what());
    }
  }

  // Step 5: every record (the baseline first) against the commissioned twin.
  void check_records() {
    for (const MeasuredRecord& m : measured_) {
      ++simulations_;
      checked_.push_back({m, simulate(params_, m).rms_sa});
    }
  }

  const MeasuredRecord& baseline() const { return measured_.front(); }
  bool baseline_within_target() const { return std::abs(checked_.front().error()) <= kTargetError; }

  nlohmann::json fitted_table() const {
    nlohmann::json t;
    for (const char* name : {"m5", "I5", "m10", "I10", "mesh_stiffness_scale", "casing_path_gain"}) {
      const twin::ParameterInfo* info = twin::find_parameter(name);
      t[name] = params_.*(info->field);
    }
    return t;
  }

  std::string twin_table_text() const {
    std::string text = "[twin]   # gearwatch commission --capture " + options_.capture + "\n";
    const nlohmann::json table = fitted_table();
    for (const auto& [name, value] : table.items()) {
      char line[160];
      std::snprintf(line, sizeof line, "%s = %.9g   # %s\n", name.c_str(), value.get<double>(), twin::find_parameter(name)->unit);
      text += line;
    }
    return text;
  }

  void print() const {
    if (options_.format == "json") {
      nlohmann::json records = nlohmann::json::array();
      for (const auto& c : checked_)
        records.push_back({{"capture", c.measured.capture}, {"start_index", c.measured.start_index}, {"speed_hz", c.measured.speed_hz},
                           {"torque_nm", c.measured.torque_nm}, {"sample_rate_hz", c.measured.sample_rate_hz},
                           {"measured_rms_sa", c.measured.rms_sa}, {"simulated_rms_sa", c.simulated_rms_sa},
                           {"error", c.error()}});
      nlohmann::json j{{"capture", options_.capture},
                       {"gears", {{"pinion_teeth", params_.gears.pinion_teeth}, {"gear_teeth", params_.gears.gear_teeth},
                                  {"module_m", params_.gears.module_m}, {"face_width_m", params_.gears.face_width_m}}},
                       {"twin", fitted_table()},
                       {"mesh_stiffness_scale_at_bound", scale_at_bound_},
                       {"shape_residual", shape_residual_},
                       {"simulations", simulations_},
                       {"baseline_within_target", baseline_within_target()},
                       {"target_error", kTargetError},
                       {"records", records}};
      std::printf("%s\n", dump_json(j).c_str());
      return;
    }
    std::printf("gear pair: %d/%d teeth, module %.4g mm, face %.4g mm\n", params_.gears.pinion_teeth, params_.gears.gear_teeth,
                params_.gears.module_m * 1e3, params_.gears.face_width_m * 1e3);
    std::printf("baseline: record at sample %llu, %.3f Hz, %.2f N m, %.0f Hz sampling\n",
                static_cast<unsigned long long>(baseline().start_index), baseline().speed_hz, baseline().torque_nm,
                baseline().sample_rate_hz);
    if (scale_at_bound_)
      std::printf("mesh stiffness scale: the baseline's spectral shape is outside what %.1f-%.1f gives; kept at the nearer end %.2f "
                  "(log-ratio residual %.3f)\n",
                  kMeshScaleLow, kMeshScaleHigh, params_.mesh_stiffness_scale, shape_residual_);
    std::printf("%-12s %10s %10s %14s %14s %9s\n", "record", "speed Hz", "torque Nm", "RMS_SA meas", "RMS_SA twin", "error");
    for (std::size_t i = 0; i < checked_.size(); ++i) {
      const auto& c = checked_[i];
      const std::string label = i == 0 ? "baseline" : i < fitted_records_ ? "same capture" : "check";
      std::printf("%-12s %10.3f %10.2f %14.5g %14.5g %8.2f%%\n", label.c_str(),
                  c.measured.speed_hz, c.measured.torque_nm, c.measured.rms_sa, c.simulated_rms_sa, 100 * c.error());
    }
    std::printf("baseline RMS_SA within %.0f %%: %s (%d twin runs)\n\n%s", 100 * kTargetError,
                baseline_within_target() ? "yes" : "NO", simulations_, twin_table_text().c_str());
  }

  // Written whole or not at all: a temporary file beside the target, renamed over it.
  void write_twin_table() const {
    const std::filesystem::path target(options_.write);
    const std::filesystem::path temp = target.string() + ".tmp";
    {
      std::ofstream out(temp, std::ios::binary | std::ios::trunc);
      out << twin_table_text();
      out.flush();
      if (!out) {
        std::error_code ec;
        std::filesystem::remove(temp, ec);
        throw CommandError("cannot write " + options_.write);
      }
    }
    std::error_code ec;
    std::filesystem::rename(temp, target, ec);
    if (ec) {
      std::filesystem::remove(temp, ec);
      throw CommandError("cannot write " + options_.write + ": " + ec.message());
    }
  }

  CommissionOptions options_;
  config::GearwatchConfig config_;
  std::vector<MeasuredRecord> measured_;   ///< the baseline capture's records, then the checks'
  std::size_t fitted_records_ = 0;          ///< how many of them come from the baseline capture
  std::vector<CheckedRecord> checked_;
  twin::GearboxParameters params_;
  bool scale_at_bound_ = false;
  double shape_residual_ = 0;
  int simulations_ = 0;
};

}  // namespace

void register_commission(CLI::App& app) {
  auto o = std::make_shared<CommissionOptions>();
  auto* cmd = app.add_subcommand("commission", "Fit the twin to a gear pair it has not seen, from a baseline capture");
  cmd->add_option("--capture", o->capture, "Baseline capture (candump -L, protocol v1); its first record is the baseline")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--config", o->config, "Configuration whose [gears], [[channels]], [records] and [processing] apply");
  cmd->add_option("--check", o->checks, "Further captures whose records check the fitted twin (not used in the fit)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--write", o->write, "Write the fitted [twin] table to this file (whole or not at all)");
  cmd->add_option("--cutoff", o->cutoff_hz, "Upper edge of the low band whose RMS sets the spectral shape, Hz")
      ->check(CLI::Range(100.0, 20000.0));
  add_format_option(cmd, o->format);
  cmd->callback([o] { Commissioning(*o).run(); });
}

}  // namespace gearwatch::cli
