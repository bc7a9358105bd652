#pragma once
// The daemon's configuration file (TOML). Every key has a default for the thesis's rig, so an
// empty file is valid; docs/config.md lists the keys. A bad file is refused as a whole with
// ConfigError naming the file, line and key, before anything starts.
#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "gearwatch/dsp/record_analyzer.hpp"
#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/wear/force_model.hpp"
#include "gearwatch/wear/k_wear_rule.hpp"

namespace gearwatch::config {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ProtocolSettings {
  std::uint32_t vibration_base_id = 0x100;
  std::uint32_t tacho_base_id = 0x180;
  std::uint32_t stream_header_id = 0x1F0;
  std::uint32_t operating_condition_id = 0x1F1;
  std::uint32_t life_counter_id = 0x1F2;
};

enum class SourceKind { socketcan, candump };
inline constexpr std::array kAllSourceKinds{SourceKind::socketcan, SourceKind::candump};
/// The token of acquisition.source.
const char* to_string(SourceKind kind) noexcept;

struct AcquisitionSettings {
  SourceKind source = SourceKind::socketcan;
  std::string interface = "can0";
  std::string capture;                              ///< candump log when source = candump
  std::uint64_t ring_capacity_samples = 1u << 23;   ///< ~42 s of 2 channels at 100 kHz
  std::uint64_t receive_buffer_bytes = 8u << 20;
  std::uint32_t reopen_initial_ms = 100;
  std::uint32_t reopen_max_ms = 5000;
};

struct StorageSettings {
  std::string database = "gearwatch.db";
  std::uint32_t busy_timeout_ms = 5000;
  std::uint32_t queue_capacity = 256;              ///< messages between processing and the writer
  std::uint32_t retry_initial_ms = 200;            ///< backoff when the disk is full or the db locked
  std::uint32_t retry_max_ms = 30000;
};

/// The MQTT publisher (docs/mqtt.md): off by default. Credentials never live in this file:
/// `password_file` names a file (or, relative, a systemd credential under
/// $CREDENTIALS_DIRECTORY) holding "username:password" on its first line.
/// Which process delivers the outbox to the broker (mqtt.sender, docs/mqtt.md).
enum class MqttSender : std::uint8_t {
  daemon,     ///< "daemon": the daemon's own sender thread (its unit then needs IP: the drop-in)
  publisher,  ///< "publisher": `gearwatch publish` in its own unit; the daemon only fills the outbox
};
inline constexpr std::array kAllMqttSenders{MqttSender::daemon, MqttSender::publisher};
constexpr const char* to_string(MqttSender sender) noexcept {
  switch (sender) {
    case MqttSender::daemon: return "daemon";
    case MqttSender::publisher: return "publisher";
  }
  return "unknown";
}

struct MqttSettings {
  bool enabled = false;
  MqttSender sender = MqttSender::daemon;
  std::string host = "localhost";
  std::uint32_t port = 1883;
  std::string prefix = "gearwatch";
  std::string site = "site";
  std::string gearbox = "gearbox";                 ///< this gearbox's id in every topic and payload
  std::string client_id;                           ///< "" = "gearwatch-<site>-<gearbox>"
  std::uint32_t keepalive_s = 30;
  std::string password_file;                       ///< "" = no authentication
  std::string ca_file;                             ///< "" = no TLS
  std::string cert_file, key_file;                 ///< client certificate and key (TLS)
  std::uint64_t outbox_limit = 100000;             ///< undelivered messages kept; beyond, the oldest are dropped
  std::uint32_t inflight = 20;                     ///< messages published and not yet acknowledged
  std::uint32_t reconnect_initial_ms = 500;
  std::uint32_t reconnect_max_ms = 30000;
  double drain_timeout_s = 5.0;                    ///< at stop, how long to wait for the outbox to empty
};

/// Where the daemon logs (logging.sink).
enum class LogSink : std::uint8_t {
  automatic,       ///< "auto": the journal when stderr is connected to it (under systemd), else stderr
  journald,
  standard_error,  ///< "stderr"
};
inline constexpr std::array kAllLogSinks{LogSink::automatic, LogSink::journald, LogSink::standard_error};
constexpr const char* to_string(LogSink sink) noexcept {
  switch (sink) {
    case LogSink::automatic: return "auto";
    case LogSink::journald: return "journald";
    case LogSink::standard_error: return "stderr";
  }
  return "unknown";
}

/// The spdlog level the daemon logs at (logging.level). `warning` is spdlog's own name for `warn`,
/// accepted and kept as written.
enum class LogLevel : std::uint8_t { trace, debug, info, warning, warn, error, critical, off };
inline constexpr std::array kAllLogLevels{LogLevel::trace, LogLevel::debug,    LogLevel::info, LogLevel::warning,
                                          LogLevel::warn,  LogLevel::error, LogLevel::critical, LogLevel::off};
/// The level's name as written in the file, which spdlog reads too (spdlog::level::from_str).
constexpr const char* to_string(LogLevel level) noexcept {
  switch (level) {
    case LogLevel::trace: return "trace";
    case LogLevel::debug: return "debug";
    case LogLevel::info: return "info";
    case LogLevel::warning: return "warning";
    case LogLevel::warn: return "warn";
    case LogLevel::error: return "error";
    case LogLevel::critical: return "critical";
    case LogLevel::off: return "off";
  }
  return "unknown";
}

struct LoggingSettings {
  LogLevel level = LogLevel::info;
  LogSink sink = LogSink::automatic;               ///< auto | journald | stderr
  double rate_limit_s = 10.0;                      ///< one line per kind of bad input per interval
};

struct DaemonSettings {
  double health_interval_s = 60.0;                 ///< acquisition_health snapshot period
  double watchdog_margin = 0.5;                    ///< ping at this fraction of WatchdogSec
  int processing_nice = 10;                        ///< nice value of the processing thread (0 = unchanged)
  /// Threads analysing the channels of a record in parallel, the processing thread included
  /// (0 = the hardware threads, at most 8; 1 = one channel after another).
  unsigned channel_workers = 0;
};

/// Hysteresis of the alerts (docs/daemon.md "Alerts"): consecutive records a condition must be
/// absent before its alert clears. Raising is immediate: the wear verdict already integrates a
/// significant trend over many records, and a dead sensor must be reported at once.
struct AlertSettings {
  int wear_clear_after_records = 3;
  int sensor_clear_after_records = 1;
  /// Indicator thresholds against the gearbox's own baseline: the first `baseline_records`
  /// analysed records of the gear pair give each watched indicator's mean and standard
  /// deviation; a value above mean + threshold_sigma x sd for threshold_raise_after records in a
  /// row raises `indicator_threshold`, threshold_clear_after records below clear it.
  int baseline_records = 10;
  double threshold_sigma = 6.0;
  int threshold_raise_after_records = 2;
  int threshold_clear_after_records = 3;
  std::vector<std::string> watched_indicators{dsp::to_string(dsp::Indicator::rms_raw), dsp::to_string(dsp::Indicator::kurtosis_raw),
                                              dsp::to_string(dsp::Indicator::rms_sa), dsp::to_string(dsp::Indicator::ics2_low_band),
                                              dsp::to_string(dsp::Indicator::ics2_high_band)};
};

/// The digital twin's updating and prediction (docs/model.md): the model thread of the daemon.
struct ModelConfig {
  bool enabled = true;
  int channel = -1;                                 ///< accelerometer feeding the model; -1 = the first configured
  double initial_k_wear = 3.55e-10;                 ///< thesis's unit (read as MPa⁻¹, docs/wear.md); §7.4.1's first calibration
  double initial_k_pitting = 0.0;                   ///< SI (docs/wear.md); two pitted-area inspections calibrate it
  double update_threshold = 0.05;                   ///< |RMS_SA sim − meas| / meas that triggers a K_wear update
  double convergence_tolerance = 0.01;              ///< an update iterates until within this
  int max_wear_iterations = 16;                     ///< twin re-runs per K_wear update
  wear::KWearUpdateRule k_wear_update = wear::KWearUpdateRule::root_find;   ///< root_find | proportional (Eq. 7.13)
  bool pitting_growth_law = false;                  ///< pitting forecast by the fitted dD/dN = a D^b (opt-in; docs/model.md)
  bool pitting_exponent_from_inspections = true;    ///< Eq. 7.8's exponent read from two pitted-area inspections (docs/model.md)
  double min_wear_elasticity = 0.02;                ///< root_find: below this |d ln RMS_SA / d ln K_wear| no update (docs/model.md)
  int commissioning_records = 3;                    ///< first records whose median ln(meas/sim) is the RMS_SA commissioning ratio; 0: none
  double pitting_reference_torque_nm = 20.0;        ///< torque of K_pitting's readable scale (docs/model.md)
  double correlation_threshold = 0.95;              ///< §7.3.3
  double pitting_interval_cycles = 50000.0;         ///< ΔN between the pitting points of §7.3.3
  double simulation_revolutions = 6.0;              ///< input revolutions of the twin's signal per RMS_SA
  double min_torque_nm = 0.5, max_torque_nm = 1000.0;
  double wear_limit_fraction = 0.10;                ///< deepest flank point, of the pitch-circle tooth thickness π m / 2
  double pitting_limit = 0.17;                      ///< mean pitting density (thesis §7.4.1: scrap at ~17 %)
  double forecast_horizon_cycles = 2.0e7;
  double remaining_life_alert_cycles = 500000.0;    ///< remaining_life alert when a limit is closer than this
  int remaining_life_raise_after_records = 2;
  int remaining_life_clear_after_records = 3;
  std::uint32_t queue_capacity = 4;                 ///< records waiting for the model thread (live: coalesced beyond)
  wear::ForceModel force_model = wear::ForceModel::quasi_static;   ///< quasi-static | dynamic (docs/wear.md)
  // The forecast interval (docs/model.md, "Posterior and interval"); the reasons are in wear::ModelSettings.
  double prior_log_k_wear_sd = 4.605170185988091;    ///< prior SD of ln K_wear about initial_k_wear (two decades)
  double log_k_drift_per_million_cycles = 0.6931471805599453;   ///< random-walk SD of ln K per million cycles (x2)
  double rms_sa_relative_sd_floor = 0.01;           ///< floor of RMS_SA's relative record-to-record scatter
  double inspection_area_relative_sd = 0.10;        ///< relative SD of an inspected pitted area
  double inspection_depth_relative_sd = 0.05;       ///< relative SD of an inspected combined mean wear depth
  int disagreement_records = 8;                     ///< records in the chi-square check of RMS_SA residuals
  int ics2_onset_records = 5;                       ///< first ICS2 values of a pair: their median is the onset baseline
};

/// The periodic sim-to-real gap diagnosis in the model thread (docs/gap-report.md). Off by
/// default: it keeps raw records in memory and simulates the twin for each of them.
struct GapConfig {
  bool enabled = false;
  std::uint32_t every_records = 50;            ///< analysed records between diagnoses
  std::uint32_t training_records = 4;          ///< the older of the newest records: the candidates are fitted on these
  std::uint32_t held_out_records = 2;          ///< the newest records: the gaps are scored on these
  int channel = -1;                            ///< measured channel compared with the twin; -1 = the model's
  int bootstrap_resamples = 200;               ///< block bootstrap over revolutions (the intervals)
  std::int64_t seed = 1;                       ///< bootstrap seed: the same records give the same report
  /// Fit misalignment and tip relief by re-running the twin over their grids (about 30 extra
  /// simulations of each training record per diagnosis); false keeps their spectral forms.
  bool rerun_twin = true;
  int drift_raise_after_reports = 1;           ///< twin_drift: reports in a row with the family significant
  int drift_clear_after_reports = 2;           ///< reports in a row without it before clearing
};

struct GearwatchConfig {
  GearboxSpec rig;
  dsp::SignalProcessingSettings processing;
  ProtocolSettings protocol;
  AcquisitionSettings acquisition;
  StorageSettings storage;
  MqttSettings mqtt;
  LoggingSettings logging;
  DaemonSettings daemon;
  AlertSettings alerts;
  ModelConfig model;
  GapConfig gap;
  std::string source_path;                          ///< the file it came from ("" for defaults)
};

/// Reads and validates a config file. Throws ConfigError ("FILE:LINE: key 'a.b': reason").
GearwatchConfig load_config(const std::string& path);
/// Same, from text (for tests and embedded defaults); `name` is used in messages.
GearwatchConfig parse_config(const std::string& text, const std::string& name);

}  // namespace gearwatch::config
