// The whole job's throughput (issue 38, item 3): a wear campaign made by the rig simulator
// (`gearwatch simulate --campaign lubricated`, 20 records of 10 s, 100 kHz × 2 channels + tacho)
// replayed through the daemon's real pipeline (run_pipeline, one capture per run as
// tools/demo.sh does), once with the model on and once with the gap diagnosis on too. Reported:
// records per second of wall time, and per record each thread's CPU time (the pipeline's own
// counters) as a ratio to the record's duration (its real-time factor) and to one r2c FFT of the
// record's length timed in the same run.
//
// Target: back-to-back records (interval = length) kept up with live with the model on, on one
// core for processing (channel_workers = 1) and one for the model: per record, the processing
// thread's CPU and the model thread's each at most the record's duration. The gap pass diagnoses
// every 10 records (the default is 50: 20 records would give none); its cost per record is given
// at the default schedule, amortised.
//
//   build/bench/bench_replay [records] [seconds]     (defaults 20 and 10)
// The campaign is kept in build/bench/replay-campaign-<records>x<seconds>s and reused.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "cli_common.hpp"
#include "commands.hpp"
#include "gearwatch/dsp/fft.hpp"
#include "pipeline.hpp"

namespace fs = std::filesystem;
using namespace gearwatch;
using Clock = std::chrono::steady_clock;

namespace {

double process_cpu_s() {
  rusage u{};
  ::getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// `gearwatch simulate --campaign lubricated ...`, in this process.
void make_campaign(const fs::path& dir, int records, double seconds) {
  if (fs::exists(dir / "truth.json")) return;
  fs::remove_all(dir);
  std::vector<std::string> args{"gearwatch",  "simulate", "--campaign", "lubricated", "--records", std::to_string(records),
                                "--seconds", std::to_string(seconds), "--out", dir.string()};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  CLI::App app;
  cli::register_simulate(app);
  const auto t = Clock::now();
  app.parse(static_cast<int>(argv.size()), argv.data());
  std::printf("campaign made in %.0f s\n", std::chrono::duration<double>(Clock::now() - t).count());
}

// One r2c FFT of n points: the median of 15 timed executions after one that warms up.
double fft_seconds(std::size_t n) {
  dsp::RealFft fft(n);
  dsp::RealBuffer x(n);
  dsp::ComplexBuffer y(n / 2 + 1);
  for (std::size_t i = 0; i < n; ++i) x[i] = std::sin(0.001 * static_cast<double>(i * i % 7919));
  fft.forward(x, y);
  std::vector<double> t;
  for (int k = 0; k < 15; ++k) {
    const auto t0 = Clock::now();
    fft.forward(x, y);
    t.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
  }
  std::nth_element(t.begin(), t.begin() + 7, t.end());
  return t[7];
}

struct Pass {
  std::uint64_t records = 0, analysed = 0, gap_reports = 0;
  double wall_s = 0, process_s = 0;
  daemon::PipelineResult::ThreadCpu cpu;
};

Pass replay(const std::vector<fs::path>& captures, const fs::path& db, bool gap) {
  for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(db.string() + suffix);
  config::GearwatchConfig cfg = cli::load_config_or_defaults("");
  cfg.storage.database = db.string();
  cfg.acquisition.source = config::SourceKind::candump;
  cfg.daemon.channel_workers = 1;  // the target's one core for processing
  cfg.model.enabled = true;
  cfg.gap.enabled = gap;
  cfg.gap.every_records = 10;
  Pass p;
  const auto t0 = Clock::now();
  const double c0 = process_cpu_s();
  for (const auto& capture : captures) {
    cfg.acquisition.capture = capture.string();
    const daemon::PipelineResult r = daemon::run_pipeline(cfg, daemon::PipelineMode::replay);
    if (r.exit_status != 0) throw std::runtime_error(capture.string() + ": replay exit status " + std::to_string(r.exit_status));
    p.records += r.records;
    p.analysed += r.records_analysed;
    p.cpu.acquisition_s += r.cpu.acquisition_s;
    p.cpu.processing_s += r.cpu.processing_s;
    p.cpu.channel_helpers_s += r.cpu.channel_helpers_s;
    p.cpu.model_s += r.cpu.model_s;
    p.cpu.gap_s += r.cpu.gap_s;
    p.gap_reports += r.cpu.gap_s > 0 ? 1 : 0;
  }
  p.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  p.process_s = process_cpu_s() - c0;
  return p;
}

void print_pass(const char* name, const Pass& p, double record_s, double fft_s) {
  const double n = static_cast<double>(std::max<std::uint64_t>(p.analysed, 1));
  const double writer = p.process_s - p.cpu.acquisition_s - p.cpu.processing_s - p.cpu.channel_helpers_s - p.cpu.model_s - p.cpu.gap_s;
  std::printf("== %s: %llu records (%llu analysed) in %.1f s wall = %.3f records/s; process CPU %.1f s\n", name,
              static_cast<unsigned long long>(p.records), static_cast<unsigned long long>(p.analysed), p.wall_s,
              static_cast<double>(p.records) / p.wall_s, p.process_s);
  std::printf("   per record (%.1f s of signal): thread, CPU s, x record duration, x one r2c FFT of the record, share\n", record_s);
  auto row = [&](const char* thread, double total) {
    std::printf("   %-34s %8.3f %8.4f %9.1f %6.1f %%\n", thread, total / n, total / n / record_s, total / n / fft_s,
                100 * total / p.process_s);
  };
  row("acquisition (candump text decode)", p.cpu.acquisition_s);
  row("processing (assembly, indicators)", p.cpu.processing_s + p.cpu.channel_helpers_s);
  row("model (blue/purple loops, forecast)", p.cpu.model_s);
  row("gap diagnoses", p.cpu.gap_s);
  row("storage writer and the rest", writer);
}

}  // namespace

int main(int argc, char** argv) {
  const int records = argc > 1 ? std::stoi(argv[1]) : 20;
  const double seconds = argc > 2 ? std::stod(argv[2]) : 10.0;
  spdlog::set_level(spdlog::level::err);
  const fs::path bench_dir = fs::path(GEARWATCH_SOURCE_DIR) / "build" / "bench";
  char name[64];
  std::snprintf(name, sizeof name, "replay-campaign-%dx%gs", records, seconds);
  const fs::path campaign = bench_dir / name;
  make_campaign(campaign, records, seconds);
  std::vector<fs::path> captures;
  for (const auto& e : fs::directory_iterator(campaign))
    if (e.path().extension() == ".log") captures.push_back(e.path());
  std::sort(captures.begin(), captures.end());

  const double fs_hz = 100000.0;
  const double fft_s = fft_seconds(static_cast<std::size_t>(seconds * fs_hz));
  std::printf("one r2c FFT of %.0f points (the record's length): %.2f ms\n", seconds * fs_hz, 1e3 * fft_s);

  const Pass model = replay(captures, bench_dir / "replay-model.db", false);
  print_pass("model on", model, seconds, fft_s);
  const Pass gap = replay(captures, bench_dir / "replay-gap.db", true);
  print_pass("model and gap on (a diagnosis every 10 records)", gap, seconds, fft_s);

  const double n = static_cast<double>(std::max<std::uint64_t>(model.analysed, 1));
  const double processing_rtf = (model.cpu.processing_s + model.cpu.channel_helpers_s) / n / seconds;
  const double model_rtf = model.cpu.model_s / n / seconds;
  const double keeps_up = std::max(processing_rtf, model_rtf);
  // The gap at its default schedule (every 50 records), amortised over the records between diagnoses.
  const double per_diagnosis = gap.gap_reports > 0 ? gap.cpu.gap_s / static_cast<double>(gap.gap_reports) : 0.0;
  const double gap_model_rtf = (gap.cpu.model_s / n + per_diagnosis / 50.0) / seconds;
  std::printf("gap diagnoses: %llu, %.1f s CPU each (%.2f x the record's duration); at the default every 50 records %.3f per record\n",
              static_cast<unsigned long long>(gap.gap_reports), per_diagnosis, per_diagnosis / seconds, per_diagnosis / 50.0 / seconds);
  std::printf("shortest record interval kept up with: one core each for processing and model %.3f x the record length; "
              "both on one core %.3f x\n",
              keeps_up, processing_rtf + model_rtf);
  std::printf("BENCH name=replay_records_per_s_model figure=%.3f unit=records_per_s target=%.3f cmp=ge met=%d\n",
              static_cast<double>(model.records) / model.wall_s, 1.0 / seconds,
              static_cast<double>(model.records) / model.wall_s >= 1.0 / seconds ? 1 : 0);
  std::printf("BENCH name=replay_records_per_s_gap figure=%.3f unit=records_per_s target=%.3f cmp=ge met=%d\n",
              static_cast<double>(gap.records) / gap.wall_s, 1.0 / seconds,
              static_cast<double>(gap.records) / gap.wall_s >= 1.0 / seconds ? 1 : 0);
  std::printf("BENCH name=replay_keeps_up_model figure=%.3f unit=x_record_duration target=1 cmp=le met=%d\n", keeps_up,
              keeps_up <= 1 ? 1 : 0);
  std::printf("BENCH name=replay_keeps_up_model_gap50 figure=%.3f unit=x_record_duration target=1 cmp=le met=%d\n",
              std::max(processing_rtf, gap_model_rtf), std::max(processing_rtf, gap_model_rtf) <= 1 ? 1 : 0);
  return 0;
}
