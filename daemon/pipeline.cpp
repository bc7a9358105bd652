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
#include <set>
#include <sstream>
#include <thread>

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
    // Called from the acquisition thread (bad frames) and the processing thread (gaps, sensors).
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

// The spdlog level a command runs at: replay is quiet at "info" (its summary is on stdout).
std::string effective_level(const std::string& level, PipelineMode mode) {
  return mode == PipelineMode::replay && level == "info" ? "warn" : level;
}

// What runs.end_reason says: the source's error, else the signal that stopped the run, else (a
// replay read to its end) "end of capture".
std::string run_end_text(const std::string& error, int stop_signal, PipelineMode mode) {
  if (!error.empty()) return error;
  if (stop_signal != 0) return std::string("stopped by SIG") + ::sigabbrev_np(stop_signal);
  return mode == PipelineMode::replay ? "end of capture" : "stopped";
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
  const bool from_file = mode == PipelineMode::replay || config.acquisition.source == config::SourceKind::candump;
  const std::string source_name = from_file ? config.acquisition.capture : config.acquisition.interface;

  // --- storage first: an unusable database stops us before anything is acquired
  std::atomic<bool> fatal_storage{false};
  storage::WriterOptions wopt;
  wopt.database = config.storage.database;
  wopt.busy_timeout_ms = static_cast<int>(config.storage.busy_timeout_ms);
  wopt.queue_capacity = config.storage.queue_capacity;
  wopt.retry_initial_ms = static_cast<int>(config.storage.retry_initial_ms);
  wopt.retry_max_ms = static_cast<int>(config.storage.retry_max_ms);
  wopt.vocabulary = acquisition_vocabulary();
  if (config.mqtt.enabled) wopt.outbox = storage::OutboxIdentity{config.mqtt.site, config.mqtt.gearbox, config.mqtt.outbox_limit};
  require_writable_database(config.storage.database);
  // One writer per database, held until we return: a second run or replay on it is refused here.
  const storage::DatabaseLock writer_lock = storage::DatabaseLock::acquire(config.storage.database);
  storage::StorageWriter writer(wopt, [&](const std::string&) { fatal_storage = true; });
  try {
    writer.start();
  } catch (const std::exception& e) {
    throw std::runtime_error("database " + config.storage.database + " cannot be opened for writing: " + e.what());
  }
  // The MQTT sender delivers what the outbox holds, older rows of earlier runs first.
  std::unique_ptr<MqttSender> mqtt;
  if (config.mqtt.enabled) {
    mqtt = std::make_unique<MqttSender>(config.mqtt, config.storage.database, writer);
    try {
      mqtt->start();
    } catch (const std::exception& e) {
      throw std::runtime_error(std::string("mqtt: ") + e.what());
    }
  }
  // A capture replayed again (after a crash, or given twice, by any path) continues after what it stored.
  const CaptureIdentity capture = from_file ? identify_capture(source_name) : CaptureIdentity{source_name, ""};
  const ReplayResume resume = from_file ? ReplayResume::load(config.storage.database, capture) : ReplayResume{};
  if (resume.records_stored() > 0)
    spdlog::warn("{}: {} records of this capture are already in {}; continuing after them", source_name,
                 resume.records_stored(), config.storage.database);
  std::vector<storage::ChannelName> channel_names;
  for (const auto& c : config.rig.channels) channel_names.push_back({c.number, c.name});
  writer.submit(storage::RunStarted{mode == PipelineMode::replay ? "replay" : "run", capture.path, config.source_path,
                                    capture.content_id, std::move(channel_names)});

  // --- acquisition objects (used on the acquisition thread only, counters readable anywhere)
  const std::size_t ring_events =
      std::max<std::size_t>(1024, config.acquisition.ring_capacity_samples / acq::kMaxSamplesPerEvent);
  acq::SpscRing<acq::AcquisitionEvent> ring(ring_events);
  std::atomic<bool> acquisition_done{false};
  std::atomic<bool> stopping{false};
  RejectedFrameBox rejected;
  BadInputLog bad_input_log(config.logging.rate_limit_s);
  const bool wait_when_full = from_file;

  // The ring counts every refused push; a file source retries them, so those are waits, not
  // overflows, and are taken out of ring_overflows (which counts events lost).
  std::atomic<std::uint64_t> refused_then_retried{0};
  acq::ProtocolDecoder decoder = make_decoder(config, [&](const acq::AcquisitionEvent& e) {
    if (ring.try_push(e)) return;
    if (!wait_when_full) return;  // live: dropped and counted by the ring
    // A file can wait: hand the event over as soon as processing makes room.
    refused_then_retried.fetch_add(1, std::memory_order_relaxed);
    while (!stopping.load(std::memory_order_relaxed)) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      if (ring.try_push(e)) return;
      refused_then_retried.fetch_add(1, std::memory_order_relaxed);
    }
    refused_then_retried.fetch_sub(1, std::memory_order_relaxed);  // stopped: this one is lost
  });

  boost::asio::io_context io;
  std::unique_ptr<acq::FrameSource> source;
  std::string frame_text;
  if (from_file) {
    source = std::make_unique<acq::CandumpFileSource>(
        io, source_name, [&](std::size_t line_no, const std::string& line, const std::string& reason) {
          const char* kind = acq::to_string(acq::RejectKind::malformed_line);
          bad_input_log.warn(kind, source_name + ":" + std::to_string(line_no) + ": " + reason);
          rejected.put({kind, reason, line.substr(0, 300)});
        });
  } else {
    acq::SocketCanOptions sopt;
    sopt.receive_buffer_bytes = config.acquisition.receive_buffer_bytes;
    sopt.reopen_initial = std::chrono::milliseconds(config.acquisition.reopen_initial_ms);
    sopt.reopen_maximum = std::chrono::milliseconds(config.acquisition.reopen_max_ms);
    source = std::make_unique<acq::SocketCanSource>(io, source_name, sopt);
  }
  std::string end_reason;
  int stop_signal = 0;  // the signal that stopped the run, if one did
  auto on_frame = [&](const acq::CanFrame& frame) {
    if (auto rejection = decoder.decode(frame)) {
      const char* kind = acq::to_string(rejection->kind);
      bad_input_log.warn(kind, rejection->reason);
      acq::format_candump_line(frame, from_file ? "log" : source_name, frame_text);
      rejected.put({kind, std::move(rejection->reason), frame_text});
    }
  };

  boost::asio::signal_set signals(io, SIGTERM, SIGINT, SIGHUP);
  boost::asio::steady_timer watchdog(io);
  std::atomic<std::int64_t> processing_heartbeat{Clock::now().time_since_epoch().count()};
  std::uint64_t watchdog_usec = 0;
  const bool use_watchdog = mode == PipelineMode::live && sd_watchdog_enabled(0, &watchdog_usec) > 0;

  auto stop_all = [&](const std::string& why) {
    if (stopping.exchange(true)) return;
    if (!why.empty()) end_reason = why;
    sd_notify(0, "STOPPING=1");
    source->stop();
    signals.cancel();
    watchdog.cancel();
  };
  // SIGHUP (`systemctl reload`): read the file again; apply what can change while running, name
  // what needs a restart, and keep running on the current settings either way.
  std::string started_text;
  if (!config.source_path.empty() && !read_text(config.source_path, started_text))
    spdlog::warn("cannot read {} again to remember it; a reload will report every key as changed", config.source_path);
  config::GearwatchConfig running_config = config;
  auto reload = [&] {
    if (config.source_path.empty()) {
      spdlog::warn("SIGHUP: started without a configuration file; nothing to reload");
      return;
    }
    std::string text;
    if (!read_text(config.source_path, text)) {
      spdlog::error("SIGHUP: cannot read {}; still running on the settings it started with", config.source_path);
      return;
    }
    ReloadPlan plan;
    try {
      plan = plan_reload(started_text, running_config, text, config.source_path);
    } catch (const config::ConfigError& e) {
      spdlog::error("SIGHUP: {} — configuration not reloaded, still running on the current settings", e.what());
      if (mode == PipelineMode::live) sd_notify(0, "STATUS=configuration file invalid; not reloaded (see the journal)");
      return;
    }
    std::string applied;
    for (const auto& key : plan.apply) {
      if (key == "logging.level")
        applied += (applied.empty() ? "" : ", ") + key + " (" + running_config.logging.level + " -> " + plan.next.logging.level + ")";
    }
    // Said before the new level is in force, so a quieter level does not hide it.
    spdlog::info("SIGHUP: configuration {} reloaded; applied: {}", config.source_path, applied.empty() ? "none" : applied);
    for (const auto& key : plan.apply) {
      if (key == "logging.level") {
        running_config.logging.level = plan.next.logging.level;
        spdlog::set_level(spdlog::level::from_str(effective_level(plan.next.logging.level, mode)));
      }
    }
    if (!plan.restart_required.empty()) {
      spdlog::warn("SIGHUP: restart required to apply: {} (still running on the values it started with)",
                   join_keys(plan.restart_required));
      if (mode == PipelineMode::live)
        sd_notify(0, ("STATUS=restart required to apply: " + join_keys(plan.restart_required)).c_str());
    } else if (mode == PipelineMode::live) {
      sd_notify(0, "STATUS=running; configuration reloaded");
    }
  };
  std::function<void()> wait_for_signal = [&] {
    signals.async_wait([&](const boost::system::error_code& ec, int signo) {
      if (ec) return;
      if (signo == SIGHUP) {
        reload();
        wait_for_signal();
        return;
      }
      spdlog::info("signal {}: stopping acquisition, draining, committing", signo);
      stop_signal = signo;
      stop_all("");
    });
  };
  wait_for_signal();
  std::function<void()> arm_watchdog = [&] {
    watchdog.expires_after(std::chrono::microseconds(static_cast<long>(watchdog_usec * config.daemon.watchdog_margin)));
    watchdog.async_wait([&](const boost::system::error_code& ec) {
      if (ec) return;
      // Ping only while processing is alive too: a stuck processing thread must trip systemd.
      const auto beat = Clock::time_point(Clock::duration(processing_heartbeat.load()));
      if (Clock::now() - beat < std::chrono::microseconds(watchdog_usec)) sd_notify(0, "WATCHDOG=1");
      else spdlog::error("processing thread has not made progress for a watchdog period; not pinging");
      arm_watchdog();
    });
  };
  if (use_watchdog) arm_watchdog();

  // --- model thread (digital twin updating); a replay is lossless, live it coalesces when behind
  std::unique_ptr<ModelThread> model;
  if (config.model.enabled) {
    model = std::make_unique<ModelThread>(config, writer, mode == PipelineMode::replay, std::move(gap));
    model->start();
  }

  // --- processing thread; the wear history of the installed gear pair continues from the database
  RecordProcessor processor(config, load_processor_memory(config.storage.database, config.alerts));
  std::uint64_t current_sequence = 0;
  std::uint16_t current_stream_id = 0;
  std::atomic<std::uint64_t> records_total{0}, records_analysed{0}, records_already_stored{0};
  RecordsWithoutIndicators records_without_indicators;  // the processing thread's; read after it joined
  acq::AssemblerCounters assembler_snapshot;
  std::mutex assembler_snapshot_mutex;
  acq::RecordAssembler assembler(
      config.rig,
      acq::RecordAssembler::Callbacks{
          [&](Record&& r, bool analysable) {
            if (resume.stored(current_sequence, r)) {
              ++records_already_stored;
              return;
            }
            storage::RecordResult result = processor.process(r, analysable, current_sequence);
            std::optional<ModelInput> model_in;
            if (model && analysable) {
              model_in = model_input(result, config);
              model_in->sample_rate_hz = r.sample_rate_hz;  // the twin's counterpart at the stream's rate
              if (config.gap.enabled) model_in->samples = std::make_shared<const Record>(std::move(r));
            }
            if (analysable) records_without_indicators.count(result);
            writer.submit(std::move(result));  // first: the model's row refers to the stored record
            if (model_in) model->submit(std::move(*model_in));
            ++records_total;
            if (analysable) ++records_analysed;
          },
          [&](const acq::StreamInfo& s) {
            current_sequence = s.sequence;
            current_stream_id = s.stream_id;
            spdlog::info("stream {} started: {} Hz, {} channels announced", s.stream_id, s.sample_rate_hz, s.channel_count);
            writer.submit(storage::StreamStarted{s.sequence, s.stream_id, s.sample_rate_hz, s.channel_count});
            // The header is the truth for its samples: they are analysed at its rate. A configuration
            // that says otherwise is reported once per stream.
            const std::string rate_message = sample_rate_message(s, config.rig.sample_rate_hz);
            if (static_cast<double>(s.sample_rate_hz) != config.rig.sample_rate_hz) spdlog::warn("{}", rate_message);
            auto rate_update = processor.stream_sample_rate(s.sample_rate_hz, rate_message);
            if (!rate_update.alerts.empty() || !rate_update.alert_states.empty()) writer.submit(std::move(rate_update));
          },
          [&](const acq::GapInfo& g) {
            if (resume.before_resume_point(current_sequence, current_stream_id, g.first_missing)) return;
            bad_input_log.warn("gap", "channel " + std::to_string(g.channel) + ": " + std::to_string(g.missing) +
                                          " samples missing from index " + std::to_string(g.first_missing) + " (" +
                                          acq::to_string(g.cause) + ")");
            writer.submit(storage::GapEvent{current_sequence, g.channel, g.first_missing, g.missing, acq::to_string(g.cause)});
          },
          [&](const acq::LifeCounterReset& l) {
            if (resume.before_resume_point(current_sequence, current_stream_id, l.index)) return;
            writer.submit(storage::LifeCounterEvent{current_sequence, l.index, l.previous_revolutions, l.revolutions});
            writer.submit(processor.life_counter_reset(l.previous_revolutions, l.revolutions));
          },
          [&](const acq::ChannelStatusChange& c) {
            const bool present = c.status == acq::ChannelStatus::resumed;
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
            bad_input_log.warn("sensor", message);
            auto update = processor.sensor_presence(c.channel, present, acq::to_string(c.status), message);
            if (!update.alerts.empty() || !update.alert_states.empty()) writer.submit(std::move(update));
          },
          [&](const acq::TachoStatusChange& t) {
            const bool present = t.status == acq::TachoStatus::resumed;
            const std::string message =
                "tacho of shaft " + std::to_string(t.shaft) +
                (present ? ": edges back at sample " + std::to_string(t.index)
                         : ": no edge since sample " + std::to_string(t.index) +
                               " while the samples go on — order-domain indicators and cycle counts need it");
            bad_input_log.warn("tacho", message);
            auto update = processor.tacho_presence(t.shaft, present, acq::to_string(t.status), message);
            if (!update.alerts.empty() || !update.alert_states.empty()) writer.submit(std::move(update));
          }});

  auto overflows_lost = [&] {
    const std::uint64_t retried = refused_then_retried.load(std::memory_order_acquire);
    const std::uint64_t refused = ring.overflows();
    return refused - std::min(retried, refused);
  };
  auto health = [&](bool final) {
    const auto& d = decoder.counters();
    const auto& h = source->health();
    acq::AssemblerCounters a;
    {
      std::lock_guard lock(assembler_snapshot_mutex);
      a = assembler_snapshot;
    }
    const auto& w = writer.counters();
    auto v = [](const std::atomic<std::uint64_t>& x) { return x.load(std::memory_order_relaxed); };
    storage::HealthSnapshot s;
    s.final = final;
    using C = storage::HealthCounter;
    s[C::frames] = v(d.frames);
    s[C::samples] = v(d.samples);
    s[C::kernel_drops] = v(h.kernel_drops);
    s[C::ring_overflows] = overflows_lost();
    s[C::ring_high_water] = ring.high_water();
    s[C::malformed_frames] = v(d.malformed_frames);
    s[C::malformed_lines] = v(h.malformed_lines);
    s[C::unknown_ids] = v(d.unknown_ids);
    s[C::unconfigured_channel_frames] = v(d.unconfigured_channel_frames);
    s[C::frames_before_header] = v(d.frames_before_header);
    s[C::gaps] = v(d.gaps);
    s[C::gap_samples] = v(d.gap_samples);
    s[C::ring_gaps] = a.ring_gaps;
    s[C::duplicates] = v(d.duplicates);
    s[C::tacho_edges] = v(d.tacho_edges);
    s[C::tacho_out_of_order] = v(d.tacho_out_of_order);
    s[C::stream_changes] = v(d.stream_changes);
    s[C::life_counter_resets] = v(d.life_counter_resets);
    s[C::unsupported_version] = v(d.unsupported_version);
    s[C::read_errors] = v(h.read_errors);
    s[C::reopens] = v(h.reopens);
    s[C::records_complete] = a.records_complete;
    s[C::records_cut] = a.records_cut;
    s[C::records_rejected] = a.records_rejected;
    s[C::records_restarted_after_gap] = a.records_restarted_after_gap;
    s[C::channels_stopped] = a.channels_stopped;
    s[C::storage_retries] = v(w.retries);
    s[C::storage_rows_rejected] = v(w.rows_rejected);
    s[C::storage_queue_waits] = v(w.queue_waits);
    if (mqtt) {
      const auto& m = mqtt->counters();
      s[C::mqtt_published] = v(m.published);
      s[C::mqtt_delivered] = v(m.delivered);
      s[C::mqtt_connects] = v(m.connects);
      s[C::mqtt_connect_failures] = v(m.connect_failures);
      s[C::mqtt_refused] = v(m.refused);
      s[C::mqtt_outbox_dropped] = v(m.outbox_dropped);
    }
    return s;
  };

  std::atomic<std::uint64_t> processing_cpu_ns{0}, acquisition_cpu_ns{0};
  std::thread processing([&] {
    // Acquisition must never wait for the CPU behind indicator computation: processing runs at a
    // lower priority (a thread's nice value on Linux); the ring absorbs the difference.
    if (config.daemon.processing_nice > 0 &&
        ::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), config.daemon.processing_nice) != 0)
      spdlog::warn("could not lower the processing thread's priority: {}", std::strerror(errno));
    acq::AcquisitionEvent e;
    auto next_health = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                          std::chrono::duration<double>(config.daemon.health_interval_s));
    for (;;) {
      bool got = false;
      for (int i = 0; i < 4096 && ring.try_pop(e); ++i) {
        assembler.consume(e);
        got = true;
      }
      processing_heartbeat.store(Clock::now().time_since_epoch().count());
      {
        std::lock_guard lock(assembler_snapshot_mutex);
        assembler_snapshot = assembler.counters();
      }
      for (auto& f : rejected.take()) writer.submit(std::move(f));
      if (Clock::now() >= next_health) {
        writer.submit(health(false));
        next_health += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config.daemon.health_interval_s));
      }
      if (!got) {
        if (acquisition_done.load(std::memory_order_acquire) && ring.size() == 0) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
    }
    assembler.finish();
    {
      std::lock_guard lock(assembler_snapshot_mutex);
      assembler_snapshot = assembler.counters();
    }
    for (auto& f : rejected.take()) writer.submit(std::move(f));
    processing_cpu_ns = thread_cpu_ns();
  });

  // --- acquisition thread
  std::thread acquisition([&] {
    source->start(on_frame, [&](const acq::SourceEnd& end) {
      if (end.kind == acq::SourceEndKind::failed) {
        spdlog::error("source ended: {}", end.error);
        end_reason = end.error;
      }
      stop_all(end.kind == acq::SourceEndKind::failed ? end.error : "");
    });
    sd_notify(0, "READY=1");
    io.run();
    acquisition_cpu_ns = thread_cpu_ns();
    acquisition_done.store(true, std::memory_order_release);
  });

  // Reverse order of start: acquisition, processing, then the writer (which drains).
  acquisition.join();
  processing.join();
  if (model) model->stop();  // drains what it holds
  if (mqtt) mqtt->close_alerts();  // its alerts need the writer, which stops next
  writer.submit(health(true));
  const std::string run_end_reason = run_end_text(end_reason, stop_signal, mode);
  writer.submit(storage::RunEnded{run_end_reason});
  writer.stop();
  if (mqtt) mqtt->stop();  // after the writer: the outbox holds every message of the run

  PipelineResult result;
  result.end_reason = end_reason;
  result.run_end_reason = run_end_reason;
  result.records = records_total;
  result.records_analysed = records_analysed;
  result.records_without_indicators = records_without_indicators;
  result.records_already_stored = records_already_stored;
  result.frames = decoder.counters().frames;
  result.samples = decoder.counters().samples;
  result.lost_samples = decoder.counters().gap_samples + assembler_snapshot.ring_gap_samples;
  result.kernel_dropped_frames = source->health().kernel_drops;
  result.run_id = writer.counters().run_id;
  result.cpu.acquisition_s = 1e-9 * static_cast<double>(acquisition_cpu_ns.load());
  result.cpu.processing_s = 1e-9 * static_cast<double>(processing_cpu_ns.load());
  result.cpu.channel_helpers_s = 1e-9 * static_cast<double>(processor.channel_helper_cpu_ns());
  if (model) {
    result.cpu.gap_s = 1e-9 * static_cast<double>(model->counters().gap_cpu_ns.load());
    result.cpu.model_s = 1e-9 * static_cast<double>(model->counters().cpu_ns.load()) - result.cpu.gap_s;
  }
  if (fatal_storage || writer.counters().lost_at_exit > 0) result.exit_status = 3;
  else if (!end_reason.empty()) result.exit_status = 2;
  return result;
}

}  // namespace gearwatch::daemon
