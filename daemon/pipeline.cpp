#include "pipeline.hpp"

#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <chrono>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>
#include <utility>

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <spdlog/spdlog.h>
#include <systemd/sd-daemon.h>

#include "gearwatch/acquisition/candump_log.hpp"
#include "gearwatch/acquisition/candump_source.hpp"
#include "gearwatch/acquisition/protocol_decoder.hpp"
#include "gearwatch/acquisition/record_assembler.hpp"
#include "gearwatch/acquisition/socketcan.hpp"
#include "gearwatch/acquisition/spsc_ring.hpp"
#include "gearwatch/storage/database_lock.hpp"
#include "gearwatch/storage/writer.hpp"
#include "config_reload.hpp"
#include "decoder_setup.hpp"
#include "logging.hpp"
#include "model_thread.hpp"
#include "mqtt_sender.hpp"
#include "record_processing.hpp"
#include "replay_resume.hpp"
#include "thread_cpu.hpp"
#include "vocabulary.hpp"

namespace gearwatch::daemon {
namespace {

namespace acq = gearwatch::acquisition;
using Clock = std::chrono::steady_clock;

// Bad frames and lines from the acquisition thread, on their way to the rejected_frames table.
// Bounded: past the per-run cap only the counters grow (a flooding bus must not fill the disk).
class RejectedFrameBox {
 public:
  static constexpr std::size_t kStoreCap = 10000;
  void put(storage::RejectedFrame f) {
    std::lock_guard lock(mutex_);
    if (stored_ >= kStoreCap) return;
    ++stored_;
    box_.push_back(std::move(f));
  }
  std::deque<storage::RejectedFrame> take() {
    std::lock_guard lock(mutex_);
    std::deque<storage::RejectedFrame> out;
    out.swap(box_);
    return out;
  }

 private:
  std::mutex mutex_;
  std::deque<storage::RejectedFrame> box_;
  std::size_t stored_ = 0;
};

// One log line per kind of bad input per interval, with the count held back.
class BadInputLog {
 public:
  explicit BadInputLog(double interval_s)
      : interval_(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(interval_s))) {}
  void warn(const std::string& kind, const std::string& message) {
    // Called from the acquisition thread (bad frames) and the processing thread (dropouts, sensors).
    std::lock_guard lock(mutex_);
    auto it = limiters_.find(kind);
    if (it == limiters_.end()) it = limiters_.emplace(kind, acq::LogRateLimiter(interval_)).first;
    std::uint64_t suppressed = 0;
    if (it->second.allow(Clock::now(), suppressed)) {
      if (suppressed) spdlog::warn("{}: {} ({} more like it since the last report)", kind, message, suppressed);
      else spdlog::warn("{}: {}", kind, message);
    }
  }

 private:
  std::mutex mutex_;
  Clock::duration interval_;
  std::map<std::string, acq::LogRateLimiter> limiters_;
};

bool read_text(const std::string& path, std::string& text) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream s;
  s << in.rdbuf();
  text = s.str();
  return !in.bad();
}

// A database gearwatch may not write is a setup error: say which file or directory and why,
// before anything starts, instead of SQLite's "attempt to write a readonly database" at the
// first write. (Checked with the real uid, which is the one SQLite writes with.)
void require_writable_database(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path file(path);
  fs::path dir = file.parent_path();
  if (dir.empty()) dir = ".";
  auto describe = [](const fs::path& p) {
    struct stat st {};
    if (::stat(p.c_str(), &st) != 0) return std::string();
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    return std::string(" (mode ") + mode + ", owner uid " + std::to_string(st.st_uid) + "; gearwatch runs as uid " +
           std::to_string(::getuid()) + ")";
  };
  if (fs::exists(file, ec)) {
    if (::access(path.c_str(), R_OK | W_OK) != 0)
      throw std::runtime_error("database " + path + " is not writable" + describe(file) +
                               ": gearwatch stores every record there; make it writable or set storage.database to a writable place");
  }
  // SQLite creates the database (when new) and its -wal and -shm files next to it.
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    throw std::runtime_error("directory " + dir.string() + " of database " + path + " is not writable" + describe(dir) +
                             ": SQLite needs to create the database's -wal and -shm files there");
}

std::string sample_rate_message(const acq::StreamInfo& s, double configured_hz) {
  const std::string rate = std::to_string(s.sample_rate_hz) + " Hz";
  char configured[32];
  std::snprintf(configured, sizeof configured, "%.10g Hz", configured_hz);
  if (static_cast<double>(s.sample_rate_hz) == configured_hz)
    return "stream " + std::to_string(s.stream_id) + ": sample rate " + rate + " as configured";
  return "stream " + std::to_string(s.stream_id) + ": the header's sample rate " + rate + " differs from rig.sample_rate_hz = " +
         configured + "; its samples are analysed at " + rate;
}

// The spdlog level a command runs at: replay's summary is on stdout.
config::LogLevel effective_level(config::LogLevel level, PipelineMode mode) {
  return mode == PipelineMode::replay ? logging::summary_command_level(level) : level;
}

// What runs.end_reason says: the source's error, else the signal that stopped the run, else (a
// replay read to its end) "end of capture".
std::string run_end_text(const std::string& error, int stop_signal, PipelineMode mode) {
  if (!error.empty()) return error;
  if (stop_signal != 0) return std::string("stopped by SIG") + ::sigabbrev_np(stop_signal);
  return mode == PipelineMode::replay ? "end of capture" : "stopped";
}

// A channel status change in words, for the log and the sensor alert.
std::string channel_status_message(const acq::ChannelStatusChange& c) {
  std::string message = "channel " + std::to_string(c.channel) + ": ";
  switch (c.status) {
    case acq::ChannelStatus::missing_from_stream:
      message += "configured but not in the stream (the header announces fewer channels) — left out of the records";
      break;
    case acq::ChannelStatus::stopped:
      message += "frames stopped at sample " + std::to_string(c.index) + " — cut out of the records until they come back";
      break;
    case acq::ChannelStatus::resumed:
      message += "frames back at sample " + std::to_string(c.index) + " — in the records again from the next one";
      break;
    case acq::ChannelStatus::silent:
      message += "announced by the stream but no frame of it since sample " + std::to_string(c.index) +
                 " while the tacho went on — no records until it delivers";
      break;
  }
  return message;
}

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

std::uint64_t load(const std::atomic<std::uint64_t>& x) { return x.load(std::memory_order_relaxed); }

// The ring holds at least this many events, however small ring_capacity_samples is set.
constexpr std::size_t kMinRingEvents = 1024;
// A file source waiting for room in the ring looks again this often.
constexpr auto kRingFullRetry = std::chrono::microseconds(200);
// A rejected log line is stored cut to this length (the reason says what was wrong with it).
constexpr std::size_t kRejectedLineChars = 300;
// Events the processing thread takes from the ring before it looks at health and rejects.
constexpr int kEventsPerTurn = 4096;
// The processing thread's pause when the ring was empty.
constexpr auto kIdlePause = std::chrono::milliseconds(2);

// One run of the daemon (`gearwatch run`) or a replay: the steps of run() in order of start, the
// threads' bodies, the record assembler's callbacks and the health snapshot. Members are declared
// in order of start, so they are destroyed in reverse; those whose making has effects outside
// (files, signal handlers, threads, database reads) are made by their step.
class Pipeline {
 public:
  Pipeline(const config::GearwatchConfig& config, PipelineMode mode, GapHooks gap);
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  PipelineResult run();

 private:
  // Steps of run(), in order.
  void open_storage();
  void start_mqtt();
  void record_run_start();
  void open_source();
  void handle_signals();
  void remember_config_text();
  void start_model();
  void start_processor();
  void start_threads();
  std::string stop_in_reverse();
  PipelineResult result(const std::string& run_end_reason) const;

  // Acquisition side.
  void push_event(const acq::AcquisitionEvent& e);
  void reject_line(std::size_t line_no, const std::string& line, const std::string& reason);
  void on_frame(const acq::CanFrame& frame);
  void on_source_end(const acq::SourceEnd& end);
  void stop_all(const std::string& why);
  void wait_for_signal();
  void arm_watchdog();
  void reload();
  void apply_reloaded(ReloadableKey key, const config::GearwatchConfig& next);
  void acquisition_thread();

  // Processing side: the assembler's callbacks and the thread's loop.
  void on_record(Record&& r, bool analysable);
  void on_stream(const acq::StreamInfo& s);
  void on_dropout(const acq::DropoutInfo& g);
  void on_life_counter(const acq::LifeCounterReset& l);
  void on_channel_status(const acq::ChannelStatusChange& c);
  void on_tacho_status(const acq::TachoStatusChange& t);
  void submit_if_any(storage::AlertUpdate update);
  bool process_turn(Clock::time_point& next_health);
  void snapshot_assembler();
  void processing_thread();

  std::uint64_t overflows_lost() const;
  storage::HealthSnapshot health(bool final);
  void add_acquisition_health(storage::HealthSnapshot& s);
  void add_mqtt_health(storage::HealthSnapshot& s) const;

  const config::GearwatchConfig& config_;
  const PipelineMode mode_;
  GapHooks gap_;
  const bool from_file_;
  const std::string source_name_;

  std::atomic<bool> fatal_storage_{false};
  std::optional<storage::DatabaseLock> writer_lock_;  // one writer per database, held until we return
  std::optional<storage::StorageWriter> writer_;
  std::unique_ptr<MqttSender> mqtt_;
  CaptureIdentity capture_;
  ReplayResume resume_;

  // Acquisition objects (used on the acquisition thread only, counters readable anywhere).
  acq::SpscRing<acq::AcquisitionEvent> ring_;
  std::atomic<bool> acquisition_done_{false};
  std::atomic<bool> stopping_{false};
  RejectedFrameBox rejected_;
  BadInputLog bad_input_log_;
  // The ring counts every refused push; a file source retries them, so those are waits, not
  // overflows, and are taken out of ring_overflows (which counts events lost).
  std::atomic<std::uint64_t> refused_then_retried_{0};
  acq::ProtocolDecoder decoder_;
  boost::asio::io_context io_;
  std::unique_ptr<acq::FrameSource> source_;
  std::string frame_text_;
  std::string end_reason_;
  int stop_signal_ = 0;  // the signal that stopped the run, if one did
  std::optional<boost::asio::signal_set> signals_;
  boost::asio::steady_timer watchdog_;
  std::atomic<std::int64_t> processing_heartbeat_{Clock::now().time_since_epoch().count()};
  std::uint64_t watchdog_usec_ = 0;
  std::string started_text_;
  config::GearwatchConfig running_config_;

  std::unique_ptr<ModelThread> model_;

  // Processing objects (the processing thread's; counters read after it joined).
  std::optional<RecordProcessor> processor_;
  std::uint64_t current_sequence_ = 0;
  std::uint16_t current_stream_id_ = 0;
  bool model_reset_pending_ = false;  ///< a life-counter reset was recorded since the model's last record
  std::atomic<std::uint64_t> records_total_{0}, records_analysed_{0}, records_already_stored_{0};
  RecordsWithoutIndicators records_without_indicators_;
  acq::AssemblerCounters assembler_snapshot_;
  std::mutex assembler_snapshot_mutex_;
  acq::RecordAssembler assembler_;
  std::atomic<std::uint64_t> processing_cpu_ns_{0}, acquisition_cpu_ns_{0};
  std::thread processing_;
  std::thread acquisition_;
};

Pipeline::Pipeline(const config::GearwatchConfig& config, PipelineMode mode, GapHooks gap)
    : config_(config),
      mode_(mode),
      gap_(std::move(gap)),
      from_file_(mode == PipelineMode::replay || config.acquisition.source == config::SourceKind::candump),
      source_name_(from_file_ ? config.acquisition.capture : config.acquisition.interface),
      ring_(std::max<std::size_t>(kMinRingEvents, config.acquisition.ring_capacity_samples / acq::kMaxSamplesPerEvent)),
      bad_input_log_(config.logging.rate_limit_s),
      decoder_(make_decoder(config, [this](const acq::AcquisitionEvent& e) { push_event(e); })),
      watchdog_(io_),
      running_config_(config),
      assembler_(config.rig,
                 acq::RecordAssembler::Callbacks{
                     [this](Record&& r, bool analysable) { on_record(std::move(r), analysable); },
                     [this](const acq::StreamInfo& s) { on_stream(s); },
                     [this](const acq::DropoutInfo& g) { on_dropout(g); },
                     [this](const acq::LifeCounterReset& l) { on_life_counter(l); },
                     [this](const acq::ChannelStatusChange& c) { on_channel_status(c); },
                     [this](const acq::TachoStatusChange& t) { on_tacho_status(t); }}) {}

PipelineResult Pipeline::run() {
  open_storage();
  start_mqtt();
  record_run_start();
  open_source();
  handle_signals();
  start_model();
  start_processor();
  start_threads();
  return result(stop_in_reverse());
}

// Storage first: an unusable database stops us before anything is acquired.
void Pipeline::open_storage() {
  storage::WriterOptions wopt;
  wopt.database = config_.storage.database;
  wopt.busy_timeout_ms = static_cast<int>(config_.storage.busy_timeout_ms);
  wopt.queue_capacity = config_.storage.queue_capacity;
  wopt.retry_initial_ms = static_cast<int>(config_.storage.retry_initial_ms);
  wopt.retry_max_ms = static_cast<int>(config_.storage.retry_max_ms);
  wopt.vocabulary = acquisition_vocabulary();
  if (config_.mqtt.enabled)
    wopt.outbox = storage::OutboxIdentity{config_.mqtt.site, config_.mqtt.gearbox, config_.mqtt.outbox_limit};
  require_writable_database(config_.storage.database);
  // A second run or replay on the same database is refused here.
  writer_lock_.emplace(storage::DatabaseLock::acquire(config_.storage.database));
  writer_.emplace(wopt, [this](const std::string&) { fatal_storage_ = true; });
  try {
    writer_->start();
  } catch (const std::exception& e) {
    throw std::runtime_error("database " + config_.storage.database + " cannot be opened for writing: " + e.what());
  }
}

// The MQTT sender delivers what the outbox holds, older rows of earlier runs first.
// With [mqtt] sender = "publisher", `gearwatch publish` delivers it from a unit of its own.
void Pipeline::start_mqtt() {
  if (!config_.mqtt.enabled || config_.mqtt.sender != config::MqttSender::daemon) return;
  mqtt_ = std::make_unique<MqttSender>(config_.mqtt, config_.storage.database, *writer_);
  try {
    mqtt_->start();
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("mqtt: ") + e.what());
  }
}

// A capture replayed again (after a crash, or given twice, by any path) continues after what it stored.
void Pipeline::record_run_start() {
  capture_ = from_file_ ? identify_capture(source_name_) : CaptureIdentity{source_name_, ""};
  resume_ = from_file_ ? ReplayResume::load(config_.storage.database, capture_) : ReplayResume{};
  if (resume_.records_stored() > 0)
    spdlog::warn("{}: {} records of this capture are already in {}; continuing after them", source_name_,
                 resume_.records_stored(), config_.storage.database);
  std::vector<storage::ChannelName> channel_names;
  for (const auto& c : config_.rig.channels) channel_names.push_back({c.number, c.name});
  writer_->submit(storage::RunStarted{mode_ == PipelineMode::replay ? "replay" : "run", capture_.path, config_.source_path,
                                      capture_.content_id, std::move(channel_names)});
}

void Pipeline::open_source() {
  if (from_file_) {
    source_ = std::make_unique<acq::CandumpFileSource>(
        io_, source_name_,
        [this](std::size_t line_no, const std::string& line, const std::string& reason) { reject_line(line_no, line, reason); });
    return;
  }
  acq::SocketCanOptions sopt;
  sopt.receive_buffer_bytes = config_.acquisition.receive_buffer_bytes;
  sopt.reopen_initial = std::chrono::milliseconds(config_.acquisition.reopen_initial_ms);
  sopt.reopen_maximum = std::chrono::milliseconds(config_.acquisition.reopen_max_ms);
  source_ = std::make_unique<acq::SocketCanSource>(io_, source_name_, sopt);
}

// Signals (SIGHUP reloads, SIGTERM and SIGINT stop) and, live under systemd, the watchdog.
void Pipeline::handle_signals() {
  signals_.emplace(io_, SIGTERM, SIGINT, SIGHUP);
  const bool use_watchdog = mode_ == PipelineMode::live && sd_watchdog_enabled(0, &watchdog_usec_) > 0;
  remember_config_text();
  wait_for_signal();
  if (use_watchdog) arm_watchdog();
}

// The file's text as started, so a reload can tell which keys changed.
void Pipeline::remember_config_text() {
  if (!config_.source_path.empty() && !read_text(config_.source_path, started_text_))
    spdlog::warn("cannot read {} again to remember it; a reload will report every key as changed", config_.source_path);
}

// Digital twin updating; a replay is lossless, live it coalesces when behind.
void Pipeline::start_model() {
  if (!config_.model.enabled) return;
  model_ = std::make_unique<ModelThread>(config_, *writer_, mode_ == PipelineMode::replay, std::move(gap_));
  model_->start();
}

// The wear history of the installed gear pair continues from the database.
void Pipeline::start_processor() {
  processor_.emplace(config_, load_processor_memory(config_.storage.database, config_.alerts));
}

void Pipeline::start_threads() {
  processing_ = std::thread([this] { processing_thread(); });
  acquisition_ = std::thread([this] { acquisition_thread(); });
}

// Reverse order of start: acquisition, processing, the model, then the writer (which drains).
// Returns the run's end as stored in runs.end_reason.
std::string Pipeline::stop_in_reverse() {
  acquisition_.join();
  processing_.join();
  if (model_) model_->stop();  // drains what it holds
  if (mqtt_) mqtt_->settle();        // refusals met now are still raised through the writer
  if (mqtt_) mqtt_->close_alerts();  // its alerts need the writer, which stops next
  writer_->submit(health(true));
  std::string run_end_reason = run_end_text(end_reason_, stop_signal_, mode_);
  writer_->submit(storage::RunEnded{run_end_reason});
  writer_->stop();
  if (mqtt_) mqtt_->stop();  // after the writer: the outbox holds every message of the run
  return run_end_reason;
}

PipelineResult Pipeline::result(const std::string& run_end_reason) const {
  PipelineResult result;
  result.end_reason = end_reason_;
  result.run_end_reason = run_end_reason;
  result.records = records_total_;
  result.records_analysed = records_analysed_;
  result.records_without_indicators = records_without_indicators_;
  result.records_already_stored = records_already_stored_;
  result.frames = decoder_.counters().frames;
  result.samples = decoder_.counters().samples;
  result.lost_samples = decoder_.counters().dropout_samples + assembler_snapshot_.ring_dropout_samples;
  result.kernel_dropped_frames = source_->health().kernel_drops;
  result.run_id = writer_->counters().run_id;
  result.cpu.acquisition_s = 1e-9 * static_cast<double>(acquisition_cpu_ns_.load());
  result.cpu.processing_s = 1e-9 * static_cast<double>(processing_cpu_ns_.load());
  result.cpu.channel_helpers_s = 1e-9 * static_cast<double>(processor_->channel_helper_cpu_ns());
  if (model_) {
    result.cpu.gap_s = 1e-9 * static_cast<double>(model_->counters().gap_cpu_ns.load());
    result.cpu.model_s = 1e-9 * static_cast<double>(model_->counters().cpu_ns.load()) - result.cpu.gap_s;
  }
  if (fatal_storage_ || writer_->counters().lost_at_exit > 0) result.exit_status = 3;
  else if (!end_reason_.empty()) result.exit_status = 2;
  return result;
}

// ---- acquisition side

// The decoder's sink. Live, a full ring drops the event (counted by the ring); a file can wait:
// the event is handed over as soon as processing makes room.
void Pipeline::push_event(const acq::AcquisitionEvent& e) {
  if (ring_.try_push(e)) return;
  if (!from_file_) return;
  refused_then_retried_.fetch_add(1, std::memory_order_relaxed);
  while (!stopping_.load(std::memory_order_relaxed)) {
    std::this_thread::sleep_for(kRingFullRetry);
    if (ring_.try_push(e)) return;
    refused_then_retried_.fetch_add(1, std::memory_order_relaxed);
  }
  refused_then_retried_.fetch_sub(1, std::memory_order_relaxed);  // stopped: this one is lost
}

void Pipeline::reject_line(std::size_t line_no, const std::string& line, const std::string& reason) {
  const char* kind = acq::to_string(acq::RejectKind::malformed_line);
  bad_input_log_.warn(kind, source_name_ + ":" + std::to_string(line_no) + ": " + reason);
  rejected_.put({kind, reason, line.substr(0, kRejectedLineChars)});
}

void Pipeline::on_frame(const acq::CanFrame& frame) {
  if (auto rejection = decoder_.decode(frame)) {
    const char* kind = acq::to_string(rejection->kind);
    bad_input_log_.warn(kind, rejection->reason);
    acq::format_candump_line(frame, from_file_ ? "log" : source_name_, frame_text_);
    rejected_.put({kind, std::move(rejection->reason), frame_text_});
  }
}

void Pipeline::on_source_end(const acq::SourceEnd& end) {
  if (end.kind == acq::SourceEndKind::failed) {
    spdlog::error("source ended: {}", end.error);
    end_reason_ = end.error;
  }
  stop_all(end.kind == acq::SourceEndKind::failed ? end.error : "");
}

void Pipeline::stop_all(const std::string& why) {
  if (stopping_.exchange(true)) return;
  if (!why.empty()) end_reason_ = why;
  sd_notify(0, "STOPPING=1");
  source_->stop();
  signals_->cancel();
  watchdog_.cancel();
}

void Pipeline::wait_for_signal() {
  signals_->async_wait([this](const boost::system::error_code& ec, int signo) {
    if (ec) return;
    if (signo == SIGHUP) {
      reload();
      wait_for_signal();
      return;
    }
    spdlog::info("signal {}: stopping acquisition, draining, committing", signo);
    stop_signal_ = signo;
    stop_all("");
  });
}

void Pipeline::arm_watchdog() {
  watchdog_.expires_after(std::chrono::microseconds(static_cast<long>(watchdog_usec_ * config_.daemon.watchdog_margin)));
  watchdog_.async_wait([this](const boost::system::error_code& ec) {
    if (ec) return;
    // Ping only while processing is alive too: a stuck processing thread must trip systemd.
    const auto beat = Clock::time_point(Clock::duration(processing_heartbeat_.load()));
    if (Clock::now() - beat < std::chrono::microseconds(watchdog_usec_)) sd_notify(0, "WATCHDOG=1");
    else spdlog::error("processing thread has not made progress for a watchdog period; not pinging");
    arm_watchdog();
  });
}

// SIGHUP (`systemctl reload`): read the file again; apply what can change while running, name
// what needs a restart, and keep running on the current settings either way.
void Pipeline::reload() {
  if (config_.source_path.empty()) {
    spdlog::warn("SIGHUP: started without a configuration file; nothing to reload");
    return;
  }
  std::string text;
  if (!read_text(config_.source_path, text)) {
    spdlog::error("SIGHUP: cannot read {}; still running on the settings it started with", config_.source_path);
    return;
  }
  ReloadPlan plan;
  try {
    plan = plan_reload(started_text_, running_config_, text, config_.source_path);
  } catch (const config::ConfigError& e) {
    spdlog::error("SIGHUP: {} — configuration not reloaded, still running on the current settings", e.what());
    if (mode_ == PipelineMode::live) sd_notify(0, "STATUS=configuration file invalid; not reloaded (see the journal)");
    return;
  }
  std::string applied;
  for (const ReloadableKey key : plan.apply)
    applied += (applied.empty() ? "" : ", ") + std::string(to_string(key)) + " (" + reloadable_value(key, running_config_) +
               " -> " + reloadable_value(key, plan.next) + ")";
  // Said before the new level is in force, so a quieter level does not hide it.
  spdlog::info("SIGHUP: configuration {} reloaded; applied: {}", config_.source_path, applied.empty() ? "none" : applied);
  for (const ReloadableKey key : plan.apply) apply_reloaded(key, plan.next);
  if (!plan.restart_required.empty()) {
    spdlog::warn("SIGHUP: restart required to apply: {} (still running on the values it started with)",
                 join_keys(plan.restart_required));
    if (mode_ == PipelineMode::live)
      sd_notify(0, ("STATUS=restart required to apply: " + join_keys(plan.restart_required)).c_str());
  } else if (mode_ == PipelineMode::live) {
    sd_notify(0, "STATUS=running; configuration reloaded");
  }
}

void Pipeline::apply_reloaded(ReloadableKey key, const config::GearwatchConfig& next) {
  switch (key) {
    case ReloadableKey::logging_level:
      running_config_.logging.level = next.logging.level;
      spdlog::set_level(spdlog::level::from_str(config::to_string(effective_level(next.logging.level, mode_))));
      return;
  }
}

void Pipeline::acquisition_thread() {
  source_->start([this](const acq::CanFrame& frame) { on_frame(frame); },
                 [this](const acq::SourceEnd& end) { on_source_end(end); });
  sd_notify(0, "READY=1");
  io_.run();
  acquisition_cpu_ns_ = thread_cpu_ns();
  acquisition_done_.store(true, std::memory_order_release);
}

// ---- processing side

void Pipeline::on_record(Record&& r, bool analysable) {
  if (resume_.stored(current_sequence_, r)) {
    ++records_already_stored_;
    return;
  }
  storage::RecordResult result = processor_->process(r, analysable, current_sequence_);
  std::optional<ModelInput> model_in;
  if (model_ && analysable) {
    model_in = model_input(result, config_);
    model_in->sample_rate_hz = r.sample_rate_hz;  // the twin's counterpart at the stream's rate
    model_in->life_counter_reset_before = std::exchange(model_reset_pending_, false);
    if (config_.gap.enabled) model_in->samples = std::make_shared<const Record>(std::move(r));
  }
  if (analysable) records_without_indicators_.count(result);
  writer_->submit(std::move(result));  // first: the model's row refers to the stored record
  if (model_in) model_->submit(std::move(*model_in));
  ++records_total_;
  if (analysable) ++records_analysed_;
}

void Pipeline::on_stream(const acq::StreamInfo& s) {
  current_sequence_ = s.sequence;
  current_stream_id_ = s.stream_id;
  spdlog::info("stream {} started: {} Hz, {} channels announced", s.stream_id, s.sample_rate_hz, s.channel_count);
  writer_->submit(storage::StreamStarted{s.sequence, s.stream_id, s.sample_rate_hz, s.channel_count});
  // The header is the truth for its samples: they are analysed at its rate. A configuration
  // that says otherwise is reported once per stream.
  const std::string rate_message = sample_rate_message(s, config_.rig.sample_rate_hz);
  if (static_cast<double>(s.sample_rate_hz) != config_.rig.sample_rate_hz) spdlog::warn("{}", rate_message);
  submit_if_any(processor_->stream_sample_rate(s.sample_rate_hz, rate_message));
}

void Pipeline::on_dropout(const acq::DropoutInfo& g) {
  if (resume_.before_resume_point(current_sequence_, current_stream_id_, g.first_missing)) return;
  bad_input_log_.warn("dropout", "channel " + std::to_string(g.channel) + ": " + std::to_string(g.missing) +
                                 " samples missing from index " + std::to_string(g.first_missing) + " (" +
                                 acq::to_string(g.cause) + ")");
  writer_->submit(storage::DropoutEvent{current_sequence_, g.channel, g.first_missing, g.missing, g.cause});
}

void Pipeline::on_life_counter(const acq::LifeCounterReset& l) {
  if (resume_.before_resume_point(current_sequence_, current_stream_id_, l.index)) return;
  writer_->submit(storage::LifeCounterEvent{current_sequence_, l.index, l.previous_revolutions, l.revolutions});
  model_reset_pending_ = true;  // the next record the model gets begins a new gear pair
  writer_->submit(processor_->life_counter_reset(l.previous_revolutions, l.revolutions));
}

void Pipeline::on_channel_status(const acq::ChannelStatusChange& c) {
  const bool present = c.status == acq::ChannelStatus::resumed;
  const std::string message = channel_status_message(c);
  bad_input_log_.warn("sensor", message);
  submit_if_any(processor_->sensor_presence(c.channel, present, acq::to_string(c.status), message));
}

void Pipeline::on_tacho_status(const acq::TachoStatusChange& t) {
  const bool present = t.status == acq::TachoStatus::resumed;
  const std::string message =
      "tacho of shaft " + std::to_string(t.shaft) +
      (present ? ": edges back at sample " + std::to_string(t.index)
               : ": no edge since sample " + std::to_string(t.index) +
                     " while the samples go on — order-domain indicators and cycle counts need it");
  bad_input_log_.warn("tacho", message);
  submit_if_any(processor_->tacho_presence(t.shaft, present, acq::to_string(t.status), message));
}

void Pipeline::submit_if_any(storage::AlertUpdate update) {
  if (!update.alerts.empty() || !update.alert_states.empty()) writer_->submit(std::move(update));
}

void Pipeline::snapshot_assembler() {
  std::lock_guard lock(assembler_snapshot_mutex_);
  assembler_snapshot_ = assembler_.counters();
}

// One turn of the processing loop: assemble what the ring holds, pass on rejects and, when due,
// a health snapshot. Returns false when the ring was empty.
bool Pipeline::process_turn(Clock::time_point& next_health) {
  acq::AcquisitionEvent e;
  bool got = false;
  for (int i = 0; i < kEventsPerTurn && ring_.try_pop(e); ++i) {
    assembler_.consume(e);
    got = true;
  }
  processing_heartbeat_.store(Clock::now().time_since_epoch().count());
  snapshot_assembler();
  for (auto& f : rejected_.take()) writer_->submit(std::move(f));
  if (Clock::now() >= next_health) {
    writer_->submit(health(false));
    next_health += seconds(config_.daemon.health_interval_s);
  }
  return got;
}

void Pipeline::processing_thread() {
  // Acquisition must never wait for the CPU behind indicator computation: processing runs at a
  // lower priority (a thread's nice value on Linux); the ring absorbs the difference.
  if (config_.daemon.processing_nice > 0 &&
      ::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), config_.daemon.processing_nice) != 0)
    spdlog::warn("could not lower the processing thread's priority: {}", std::strerror(errno));
  auto next_health = Clock::now() + seconds(config_.daemon.health_interval_s);
  for (;;) {
    if (process_turn(next_health)) continue;
    if (acquisition_done_.load(std::memory_order_acquire) && ring_.size() == 0) break;
    std::this_thread::sleep_for(kIdlePause);
  }
  assembler_.finish();
  snapshot_assembler();
  for (auto& f : rejected_.take()) writer_->submit(std::move(f));
  processing_cpu_ns_ = thread_cpu_ns();
}

// ---- health

std::uint64_t Pipeline::overflows_lost() const {
  const std::uint64_t retried = refused_then_retried_.load(std::memory_order_acquire);
  const std::uint64_t refused = ring_.overflows();
  return refused - std::min(retried, refused);
}

storage::HealthSnapshot Pipeline::health(bool final) {
  storage::HealthSnapshot s;
  s.final = final;
  add_acquisition_health(s);
  using C = storage::HealthCounter;
  const auto& w = writer_->counters();
  s[C::storage_retries] = load(w.retries);
  s[C::storage_rows_rejected] = load(w.rows_rejected);
  s[C::storage_queue_waits] = load(w.queue_waits);
  add_mqtt_health(s);
  return s;
}

// The source's, the decoder's, the ring's and the assembler's counters.
void Pipeline::add_acquisition_health(storage::HealthSnapshot& s) {
  const auto& d = decoder_.counters();
  const auto& h = source_->health();
  acq::AssemblerCounters a;
  {
    std::lock_guard lock(assembler_snapshot_mutex_);
    a = assembler_snapshot_;
  }
  using C = storage::HealthCounter;
  s[C::frames] = load(d.frames);
  s[C::samples] = load(d.samples);
  s[C::kernel_drops] = load(h.kernel_drops);
  s[C::ring_overflows] = overflows_lost();
  s[C::ring_high_water] = ring_.high_water();
  s[C::malformed_frames] = load(d.malformed_frames);
  s[C::malformed_lines] = load(h.malformed_lines);
  s[C::unknown_ids] = load(d.unknown_ids);
  s[C::unconfigured_channel_frames] = load(d.unconfigured_channel_frames);
  s[C::frames_before_header] = load(d.frames_before_header);
  s[C::dropouts] = load(d.dropouts);
  s[C::dropout_samples] = load(d.dropout_samples);
  s[C::ring_dropouts] = a.ring_dropouts;
  s[C::duplicates] = load(d.duplicates);
  s[C::tacho_edges] = load(d.tacho_edges);
  s[C::tacho_out_of_order] = load(d.tacho_out_of_order);
  s[C::stream_changes] = load(d.stream_changes);
  s[C::life_counter_resets] = load(d.life_counter_resets);
  s[C::unsupported_version] = load(d.unsupported_version);
  s[C::read_errors] = load(h.read_errors);
  s[C::reopens] = load(h.reopens);
  s[C::records_complete] = a.records_complete;
  s[C::records_cut] = a.records_cut;
  s[C::records_rejected] = a.records_rejected;
  s[C::records_restarted_after_dropout] = a.records_restarted_after_dropout;
  s[C::channels_stopped] = a.channels_stopped;
}

void Pipeline::add_mqtt_health(storage::HealthSnapshot& s) const {
  if (mqtt_) add_mqtt_counters(mqtt_->counters(), s);
}

}  // namespace

void RecordsWithoutIndicators::count(const storage::RecordResult& record) {
  std::set<dsp::SkipReason> why;
  for (const auto& channel : record.channels) {
    if (!channel.values.empty()) return;
    for (const auto& skipped : channel.skipped)
      if (const auto reason = dsp::parse_skip_reason(skipped.reason)) why.insert(*reason);
  }
  ++records;
  for (const auto reason : why) ++reasons[reason];
}

PipelineResult run_pipeline(const config::GearwatchConfig& config, PipelineMode mode, GapHooks gap) {
  Pipeline pipeline(config, mode, std::move(gap));
  return pipeline.run();
}

}  // namespace gearwatch::daemon
