// `gearwatch import FILE --out CAPTURE`: a DAQ recording (WAV, CSV, MATLAB .mat) as a protocol-v1
// capture, the file `simulate` writes and `replay` reads (docs/acquisition.md, "Recordings from
// DAQ files"). The file is read whole, every check runs before anything is written, and the
// capture goes to a temporary file renamed over --out only when complete.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <optional>

#include <unistd.h>

#include "capture_writer.hpp"
#include "cli_common.hpp"
#include "decoder_setup.hpp"
#include "gearwatch/acquisition/daq_file.hpp"
#include "gearwatch/acquisition/daq_import.hpp"

namespace gearwatch::cli {
namespace {

namespace fs = std::filesystem;
namespace acq = gearwatch::acquisition;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Options {
  std::string file, out, config;
  std::vector<std::string> map;
  double scale = 1.0;
  std::string unit = "m/s2";
  double sensitivity_mv_per_g = kNaN;
  double sample_rate_hz = kNaN;
  std::string tacho;
  double speed_hz = kNaN;
  double torque_nm = 0.0;
  std::uint64_t start_revolutions = 0;
  std::uint16_t stream_id = 1;
  bool classic = false;
  acq::DaqReadOptions read;
};

/// How the capture's input shaft turns.
enum class SpeedSource { tacho_channel, constant, none };

/// One capture channel: the recording's channel `source` sent as protocol channel `number`.
struct MappedChannel {
  std::size_t source = 0;
  int number = 0;
  double lsb_m_s2 = 0.01;
  std::string name;  ///< the configured channel's name ("" when that number is not configured)
};

/// The recording as a capture's signal: scaled samples, and the input shaft's edges (from the
/// tacho channel, at a constant speed, or none).
class RecordingSignal final : public daemon::CaptureSignal {
 public:
  /// `measured_edges`: the edges come from a tacho channel, so the condition frames follow them;
  /// otherwise they carry the given constant speed as it is.
  RecordingSignal(std::vector<std::vector<double>> m_s2, double fs, std::vector<double> edges, int edges_per_rev,
                  bool measured_edges)
      : x_(std::move(m_s2)), fs_(fs), edges_(std::move(edges)), epr_(edges_per_rev), measured_(measured_edges) {}
  int channels() const override { return static_cast<int>(x_.size()); }
  double sample_rate_hz() const override { return fs_; }
  double input_revolutions_at(double t) const override {
    // Every edge at or before the sample completes its share of a revolution: the daemon adds
    // the edges after a life-counter frame to its value, so the count must include those before.
    const auto passed = std::upper_bound(edges_.begin(), edges_.end(), t * fs_) - edges_.begin();
    return static_cast<double>(passed) / epr_;
  }
  void generate(std::uint64_t first, std::size_t count, std::vector<std::vector<double>>& out) override {
    out.resize(x_.size());
    for (std::size_t c = 0; c < x_.size(); ++c) out[c].assign(x_[c].begin() + static_cast<std::ptrdiff_t>(first),
                                                              x_[c].begin() + static_cast<std::ptrdiff_t>(first + count));
  }
  std::vector<double> tacho_edges(double from, double to, int) const override {
    return {std::lower_bound(edges_.begin(), edges_.end(), from), std::lower_bound(edges_.begin(), edges_.end(), to)};
  }
  double speed_hz_at(std::uint64_t index) const override {
    // The condition frame's speed: the tacho's mean over the second around it, so a run-up's
    // frames follow it (the assembler checks the edge rate against this).
    if (!measured_) return kNaN;
    const double at = static_cast<double>(index);
    return acq::speed_from_edges(edges_, epr_, fs_, at - fs_ / 2, at + fs_ / 2);
  }

 private:
  std::vector<std::vector<double>> x_;
  double fs_;
  std::vector<double> edges_;
  int epr_;
  bool measured_;
};

/// The configured channel a --map target names: its name or its protocol number.
const ChannelSpec* configured_channel(const config::GearwatchConfig& cfg, const std::string& target) {
  for (const auto& c : cfg.rig.channels)
    if (c.name == target || std::to_string(c.number) == target) return &c;
  return nullptr;
}

double lsb_of(const config::GearwatchConfig& cfg, int number) {
  for (const auto& c : cfg.rig.channels)
    if (c.number == number) return c.scale_m_s2_per_lsb;
  return cfg.rig.channels.empty() ? 0.01 : cfg.rig.channels.front().scale_m_s2_per_lsb;
}

/// The capture's channels: --map SOURCE=TARGET entries, or every channel of the recording but the
/// tacho, in order, as channels 0, 1, ... They must be channels 0 … k−1, each once.
std::vector<MappedChannel> map_channels(const Options& opt, const config::GearwatchConfig& cfg, const acq::DaqRecording& r,
                                        std::optional<std::size_t> tacho) {
  std::vector<MappedChannel> mapped;
  if (opt.map.empty()) {
    for (std::size_t s = 0; s < r.channels.size(); ++s)
      if (s != tacho) mapped.push_back({s, static_cast<int>(mapped.size()), 0, ""});
  }
  for (const auto& entry : opt.map) {
    const auto eq = entry.rfind('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == entry.size())
      throw CommandError("--map " + entry + ": expected SOURCE=CHANNEL (a column/channel of the file = a configured channel name or number)", 64);
    const std::size_t source = acq::find_channel(r, entry.substr(0, eq));
    const std::string target = entry.substr(eq + 1);
    const ChannelSpec* c = configured_channel(cfg, target);
    if (c == nullptr) {
      std::string names;
      for (const auto& k : cfg.rig.channels) names += (names.empty() ? "" : ", ") + k.name + " (" + std::to_string(k.number) + ")";
      throw CommandError("--map " + entry + ": no configured channel " + target + " (configured: " + names + ")");
    }
    if (tacho && source == *tacho) throw CommandError("--map " + entry + ": that is the tacho channel");
    mapped.push_back({source, c->number, 0, ""});
  }
  if (mapped.empty()) throw CommandError("no vibration channel left to import (the recording's only channel is the tacho)");
  if (mapped.size() > 8) throw CommandError("the recording has " + std::to_string(mapped.size()) + " vibration channels, the protocol carries 8: choose with --map");
  std::sort(mapped.begin(), mapped.end(), [](const auto& a, const auto& b) { return a.number < b.number; });
  for (std::size_t i = 0; i < mapped.size(); ++i)
    if (mapped[i].number != static_cast<int>(i))
      throw CommandError("the capture's channels must be 0 … " + std::to_string(mapped.size() - 1) + ", each once (a stream carries channels 0 … count-1): channel " +
                         std::to_string(mapped[i].number) + " is mapped " + (i > 0 && mapped[i - 1].number == mapped[i].number ? "twice" : "without the ones below it"));
  for (auto& m : mapped) {
    m.lsb_m_s2 = lsb_of(cfg, m.number);
    if (const ChannelSpec* c = configured_channel(cfg, std::to_string(m.number))) m.name = c->name;
  }
  return mapped;
}

/// The input shaft's edges on the sample clock: detected on the tacho channel, or one every
/// 1/(speed·edges_per_rev) s for a constant speed (the first one interval after sample 0).
std::vector<double> input_edges(const Options& opt, const acq::DaqRecording& r, std::optional<std::size_t> tacho, double fs,
                                int epr) {
  if (tacho) {
    auto edges = acq::detect_tacho_edges(r.channels[*tacho]);
    if (edges.size() < 2)
      throw CommandError("tacho channel " + r.names[*tacho] + " has " + std::to_string(edges.size()) + " pulses: no speed can be read from it");
    return edges;
  }
  std::vector<double> edges;
  if (std::isfinite(opt.speed_hz)) {
    const auto n = static_cast<double>(r.samples());
    const double per_second = opt.speed_hz * epr;
    for (double k = 1; k * fs / per_second < n; ++k) edges.push_back(k * fs / per_second);
  }
  return edges;
}

SpeedSource speed_source(const Options& opt) {
  if (!opt.tacho.empty()) return SpeedSource::tacho_channel;
  return std::isfinite(opt.speed_hz) ? SpeedSource::constant : SpeedSource::none;
}

std::string_view to_string(SpeedSource s) {
  switch (s) {
    case SpeedSource::tacho_channel: return "tacho channel";
    case SpeedSource::constant: return "constant";
    case SpeedSource::none: return "none (the daemon estimates it from the signal)";
  }
  return "unknown";
}

/// A temporary file beside --out, removed unless committed by rename.
class PendingFile {
 public:
  explicit PendingFile(const fs::path& out) : out_(out), tmp_(out) { tmp_ += ".import-tmp-" + std::to_string(::getpid()); }
  ~PendingFile() {
    std::error_code ignored;
    if (!committed_) fs::remove(tmp_, ignored);
  }
  const fs::path& path() const { return tmp_; }
  void commit() {
    std::error_code ec;
    fs::rename(tmp_, out_, ec);
    if (ec) throw CommandError("cannot write " + out_.string() + ": " + ec.message());
    committed_ = true;
  }

 private:
  fs::path out_, tmp_;
  bool committed_ = false;
};

struct Imported {
  acq::DaqRecording recording;
  std::vector<MappedChannel> channels;
  daemon::CaptureSettings cs;
  std::vector<double> edges;
  SpeedSource speed = SpeedSource::none;
  double m_s2_per_unit = 1.0;
};

/// Every check, in the order an operator fixes them: the file, its rate and length, the channels,
/// the samples, the speed. Nothing is written here.
Imported prepare(const Options& opt) {
  Imported im;
  const auto cfg = load_config_or_defaults(opt.config);
  im.recording = acq::read_daq_file(opt.file, opt.read);
  const auto& r = im.recording;
  const double fs = acq::check_rate_and_length(r, opt.sample_rate_hz, cfg.rig.schedule.min_length_s);
  std::optional<std::size_t> tacho;
  if (!opt.tacho.empty()) tacho = acq::find_channel(r, opt.tacho);
  im.channels = map_channels(opt, cfg, r, tacho);
  const auto unit = acq::parse_sample_unit(opt.unit);
  if (!unit) throw CommandError("--unit " + opt.unit + ": expected m/s2, g or V", 64);
  im.m_s2_per_unit = acq::m_s2_per_file_unit({opt.scale, *unit, opt.sensitivity_mv_per_g});
  for (const auto& m : im.channels) acq::check_channel_fits(r, m.source, im.m_s2_per_unit, m.lsb_m_s2);
  if (tacho)
    for (double v : r.channels[*tacho])
      if (!std::isfinite(v)) throw CommandError("tacho channel " + r.names[*tacho] + " holds a sample that is not a number");

  const TachoSpec input_tacho = cfg.rig.tachos.empty() ? TachoSpec{} : cfg.rig.tachos.front();
  im.speed = speed_source(opt);
  im.edges = input_edges(opt, r, tacho, fs, input_tacho.edges_per_rev);
  auto& cs = im.cs;
  cs.signal.sample_rate_hz = fs;
  cs.signal.channels = static_cast<int>(im.channels.size());
  cs.signal.torque_nm = opt.torque_nm;
  // The speed frame: the given one, the tacho's mean where a second has too few edges, or 0 =
  // unknown (the daemon then searches its whole speed range for the signal's estimate).
  cs.signal.speed_hz = im.speed == SpeedSource::constant ? opt.speed_hz
                       : tacho ? acq::speed_from_edges(im.edges, input_tacho.edges_per_rev, fs, 0, static_cast<double>(r.samples()))
                               : 0.0;
  cs.duration_s = static_cast<double>(r.samples()) / fs;
  cs.fd = !opt.classic;
  cs.stream_id = opt.stream_id;
  cs.start_revolutions = opt.start_revolutions;
  cs.edges_per_rev = input_tacho.edges_per_rev;
  cs.tacho_shaft = input_tacho.shaft;
  cs.ids = daemon::protocol_ids(cfg);
  for (const auto& m : im.channels) cs.channel_scales_m_s2_per_lsb.push_back(m.lsb_m_s2);
  return im;
}

void run_import(const Options& opt) {
  if (fs::is_directory(opt.out)) throw CommandError("--out " + opt.out + " is a directory");
  Imported im = prepare(opt);
  std::vector<std::vector<double>> m_s2;
  for (const auto& m : im.channels) {
    m_s2.push_back(std::move(im.recording.channels[m.source]));
    for (double& v : m_s2.back()) v *= im.m_s2_per_unit;
  }
  RecordingSignal signal(std::move(m_s2), im.cs.signal.sample_rate_hz, im.edges, im.cs.edges_per_rev,
                         im.speed == SpeedSource::tacho_channel);
  PendingFile pending(opt.out);
  const auto s = daemon::write_capture(im.cs, signal, pending.path().string());
  pending.commit();
  std::cout << "wrote " << opt.out << ": " << s.frames << " frames, " << s.samples_per_channel << " samples x "
            << im.channels.size() << " channels at " << im.cs.signal.sample_rate_hz << " Hz ("
            << (im.recording.rate_source == acq::RateSource::none ? std::string_view("--sample-rate")
                                                                  : acq::to_string(im.recording.rate_source))
            << "), speed " << to_string(im.speed) << ", " << s.tacho_edges << " tacho edges";
  if (im.speed != SpeedSource::none) std::cout << ", mean " << im.cs.signal.speed_hz << " Hz";
  std::cout << "\n";
  for (const auto& m : im.channels)
    std::cout << "  " << im.recording.names[m.source] << " -> channel " << m.number << (m.name.empty() ? "" : " " + m.name) << " ("
              << m.lsb_m_s2 << " m/s2 per LSB)\n";
}

}  // namespace

void register_import(CLI::App& app) {
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("import", "Turn a DAQ recording (WAV, CSV, MATLAB .mat) into a capture (protocol v1, candump -L log)");
  cmd->add_option("FILE", opt->file, "The recording: .wav, .csv (.txt) or .mat")->required();
  cmd->add_option("--out", opt->out, "The capture to write (replaced only when complete)")->required();
  cmd->add_option("--config", opt->config, "Channel names and scales, tacho edges per revolution, protocol ids and [records] min_length_s");
  cmd->add_option("--map", opt->map,
                  "SOURCE=CHANNEL: a column/channel of the file (0-based index or its name) carried as a configured channel "
                  "(its name or number); repeatable. Default: every channel but the tacho, in order, as channels 0, 1, ...");
  cmd->add_option("--scale", opt->scale, "Multiplies every sample first (WAV samples are fractions of full scale)")->capture_default_str();
  cmd->add_option("--unit", opt->unit, "Unit of the scaled samples: m/s2, g or V")->check(CLI::IsMember({"m/s2", "m/s^2", "g", "V"}))->capture_default_str();
  cmd->add_option("--sensitivity", opt->sensitivity_mv_per_g, "Accelerometer sensitivity, mV/g (with --unit V)")->check(CLI::PositiveNumber);
  cmd->add_option("--sample-rate", opt->sample_rate_hz, "Samples per second, when the file carries none (must agree when it does)")->check(CLI::PositiveNumber);
  auto* tacho = cmd->add_option("--tacho", opt->tacho, "The file's tacho channel (index or name): its pulses become tacho frames");
  auto* speed = cmd->add_option("--speed", opt->speed_hz, "A constant input-shaft speed, Hz: tacho frames at that speed")->check(CLI::Range(0.1, 1000.0));
  tacho->excludes(speed);
  cmd->add_option("--torque", opt->torque_nm, "Input torque, N·m (the operating-condition frames; the model needs it)")->required()->check(CLI::Range(0.0, 10000.0));
  cmd->add_option("--start-revs", opt->start_revolutions, "Life counter (input revolutions) at the first sample")->capture_default_str();
  cmd->add_option("--stream-id", opt->stream_id, "Stream id in the header")->capture_default_str();
  cmd->add_flag("--classic", opt->classic, "Classic CAN frames, 2 samples each (default CAN FD, 30)");
  cmd->add_option("--time-column", opt->read.csv_time_column, "CSV: the time column (name or index; default a column named time, t or time_s)");
  cmd->add_option("--mat-variable", opt->read.mat_variable, ".mat: the samples variable (default the only numeric matrix)");
  cmd->add_option("--mat-rate-variable", opt->read.mat_rate_variable, ".mat: the scalar rate variable, Hz (default fs, Fs, sample_rate, sampling_rate or SampleRate)");
  cmd->callback([opt] {
    try {
      run_import(*opt);
    } catch (const CommandError& e) {
      throw CommandError(std::string(e.what()) + "; nothing written", e.exit_status);
    } catch (const std::exception& e) {
      throw CommandError(std::string(e.what()) + "; nothing written");
    }
  });
}

}  // namespace gearwatch::cli
