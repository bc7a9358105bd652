// `gearwatch commission --capture BASELINE`: the twin fitted to a gear pair it has never seen
// (docs/twin.md, "Commissioning"). The twin is built from [gears] (gear bodies from the geometry
// where [twin] does not give them); its mesh-stiffness scale is fitted to the pattern of the
// baseline's mesh harmonics (the thesis's §5.3 step, made independent of the sensor's sensitivity;
// twin::fit_mesh_pattern) and its casing path gain to the baseline's RMS_SA; the other records of
// the capture check the fit at their own speed and torque. Prints the fitted [twin] table, what the
// baseline says about the scale, and writes the table with --write.
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
#include "gearwatch/dsp/record_analyzer.hpp"
#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/mesh_pattern_fit.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "model_thread.hpp"
#include "record_processing.hpp"

namespace gearwatch::cli {
namespace {

struct CommissionOptions {
  std::string capture, config, write, format = "table";
  std::vector<std::string> checks;  ///< captures whose records check the fit (held out of it)
};

/// One record of the capture as the commissioning sees it.
struct MeasuredRecord {
  std::string capture;
  std::uint64_t start_index = 0;
  double sample_rate_hz = 0, duration_s = 0, speed_hz = 0, torque_nm = 0;
  double rms_sa = 0;                  ///< RMS_SA(N) by the measurement pipeline
  std::vector<double> mesh_harmonics;  ///< gmf_harmonic_1.. of the input TSA (NaN: not computed)
  double harmonic_floor = 0;           ///< white-noise amplitude of one order in that TSA (0: unknown)
};

/// The twin at one record's operating point and rate.
struct TwinReading {
  double rms_sa = 0;
  std::vector<double> mesh_harmonics;
};

/// One record after the fit: measured against the commissioned twin.
struct CheckedRecord {
  MeasuredRecord measured;
  double simulated_rms_sa = 0;
  double error() const { return simulated_rms_sa / measured.rms_sa - 1.0; }
};

constexpr double kTargetError = 0.05;  // RMS_SA sim vs measured on the baseline

/// gmf_harmonic_1..count of an indicator list (NaN where absent).
template <typename Lookup>
std::vector<double> mesh_harmonics(int count, const Lookup& value) {
  std::vector<double> out(static_cast<std::size_t>(count), std::nan(""));
  for (int h = 1; h <= count; ++h)
    if (const std::optional<double> v = value("gmf_harmonic_" + std::to_string(h))) out[static_cast<std::size_t>(h - 1)] = *v;
  return out;
}

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
      read_mesh_harmonics(result, channel, m);
      out.push_back(m);
    }
    return out;
  }

  // The record's mesh harmonics and their floor: white noise of the residual's RMS σ gives one
  // order of an average over n samples an amplitude of about 2σ/√n.
  void read_mesh_harmonics(const storage::RecordResult& result, int channel, MeasuredRecord& m) const {
    for (const storage::ChannelResult& c : result.channels) {
      if (c.channel != channel) continue;
      auto value = [&](const std::string& name) -> std::optional<double> {
        for (const auto& [n, v] : c.values)
          if (n == name) return v;
        return std::nullopt;
      };
      m.mesh_harmonics = mesh_harmonics(config_.processing.stored_gmf_harmonics, value);
      const double samples = m.duration_s * m.sample_rate_hz;
      if (const auto residual = value(dsp::to_string(dsp::Indicator::rms_residual)); residual && samples > 0)
        m.harmonic_floor = 2.0 * *residual / std::sqrt(samples);
    }
  }

  // Step 2: the twin of the configured gear pair, unfitted (scale 1, gain 1).
  void build_twin_from_gears() {
    params_ = daemon::model_twin_parameters(config_);
    params_.mesh_stiffness_scale = 1.0;
    params_.casing_path_gain = 1.0;
  }

  TwinReading simulate(const twin::GearboxParameters& p, const MeasuredRecord& m) const {
    GearboxSpec rig = config_.rig;
    rig.sample_rate_hz = m.sample_rate_hz;
    const double seconds = config_.model.simulation_revolutions / m.speed_hz;
    const twin::OperatingPoint op{m.speed_hz, m.torque_nm};
    TwinReading t;
    try {
      const dsp::ChannelAnalysis a = twin::simulated_analysis(p, {}, op, seconds, rig, config_.processing);
      const std::optional<double> rms_sa = a.value(dsp::Indicator::rms_sa);
      if (!rms_sa) throw twin::TwinParameterError("the analyser gives no RMS_SA of the twin's signal");
      t.rms_sa = *rms_sa;
      t.mesh_harmonics = mesh_harmonics(config_.processing.stored_gmf_harmonics, [&](const std::string& n) { return a.value(n); });
    } catch (const std::exception& e) {
      throw CommandError(std::string("commission: the twin cannot be run at ") + std::to_string(m.speed_hz) + " Hz: " + e.what());
    }
    return t;
  }

  // Step 3: the scale whose mesh-harmonic pattern (gain removed) is nearest the baseline's. The
  // ratio of a low band's RMS to RMS_SA, fitted before, does not see the scale: at the usual
  // speeds that band holds the first mesh harmonics, which are RMS_SA itself.
  void fit_mesh_stiffness_scale() {
    const twin::MeshHarmonicsAt twin_harmonics = [&](double scale) {
      twin::GearboxParameters p = params_;
      p.mesh_stiffness_scale = scale;
      ++simulations_;
      return simulate(p, baseline()).mesh_harmonics;
    };
    try {
      pattern_ = twin::fit_mesh_pattern(baseline().mesh_harmonics, baseline().harmonic_floor, twin_harmonics);
    } catch (const std::invalid_argument& e) {
      throw CommandError(std::string("commission: ") + e.what());
    }
    params_.mesh_stiffness_scale = pattern_.scale;
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

  nlohmann::json scale_evidence_json() const {
    return {{"value", pattern_.scale},
            {"nearest", pattern_.nearest_scale},
            {"evidence", twin::to_string(pattern_.evidence)},
            {"identified", pattern_.evidence == twin::MeshScaleEvidence::identified},
            {"interval", {pattern_.interval_low, pattern_.interval_high}},
            {"harmonics", pattern_.harmonics},
            {"misfit_ln_rms", pattern_.misfit_ln_rms},
            {"harmonic_floor", baseline().harmonic_floor},
            {"scan", pattern_.scan}};
  }

  std::string harmonic_list() const {
    std::string list;
    for (int h : pattern_.harmonics) list += (list.empty() ? "" : ",") + std::to_string(h);
    return list;
  }

  // What the baseline says about the scale, in one line.
  std::string scale_evidence_text() const {
    char line[400];
    const twin::MeshPatternFit& f = pattern_;
    const std::size_t n = f.harmonics.size();
    switch (f.evidence) {
      case twin::MeshScaleEvidence::identified:
        std::snprintf(line, sizeof line,
                      "mesh stiffness scale %.3f from the pattern of mesh harmonics %s (ln misfit %.3f rms); scales %.3f-%.3f fit as well "
                      "(95 %% profile interval)",
                      f.scale, harmonic_list().c_str(), f.misfit_ln_rms, f.interval_low, f.interval_high);
        break;
      case twin::MeshScaleEvidence::too_few_harmonics:
        std::snprintf(line, sizeof line,
                      "mesh stiffness scale NOT IDENTIFIED: only %zu mesh harmonics stand 10x above the baseline's noise floor (3 needed); "
                      "left at %.3f",
                      n, f.scale);
        break;
      case twin::MeshScaleEvidence::minimum_at_bound:
        std::snprintf(line, sizeof line,
                      "mesh stiffness scale NOT IDENTIFIED: the pattern of mesh harmonics %s is nearest at %.3f, an end of the plausible "
                      "range (ln misfit %.3f rms); scales %.3f-%.3f fit as well; kept at %.3f",
                      harmonic_list().c_str(), f.nearest_scale, f.misfit_ln_rms, f.interval_low, f.interval_high, f.scale);
        break;
      case twin::MeshScaleEvidence::interval_reaches_bound:
        std::snprintf(line, sizeof line,
                      "mesh stiffness scale NOT IDENTIFIED: scales %.3f-%.3f fit the pattern of mesh harmonics %s as well as the nearest, "
                      "%.3f (ln misfit %.3f rms); the baseline cannot tell them apart; kept at %.3f",
                      f.interval_low, f.interval_high, harmonic_list().c_str(), f.nearest_scale, f.misfit_ln_rms, f.scale);
        break;
    }
    return line;
  }

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
    if (pattern_.evidence != twin::MeshScaleEvidence::identified)
      text += std::string("# mesh_stiffness_scale not identified by the baseline (") + twin::to_string(pattern_.evidence) + ")\n";
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
                       {"mesh_stiffness_scale", scale_evidence_json()},
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
    std::printf("%s\n", scale_evidence_text().c_str());
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
  twin::MeshPatternFit pattern_;
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
  add_format_option(cmd, o->format);
  cmd->callback([o] { Commissioning(*o).run(); });
}

}  // namespace gearwatch::cli
