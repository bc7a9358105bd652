#include "gap_diagnoser.hpp"

#include <future>
#include <map>
#include <mutex>
#include <set>
#include <tuple>

#include "gearwatch/gap/candidates.hpp"
#include "gearwatch/gap/diagnosis.hpp"
#include "gearwatch/twin/simulation.hpp"
#include "gearwatch/wear/wear_loop.hpp"

namespace gearwatch::daemon {

int gap_channel(const config::GearwatchConfig& config) {
  if (config.gap.channel >= 0) return config.gap.channel;
  if (config.model.channel >= 0) return config.model.channel;
  return config.rig.channels.empty() ? 0 : config.rig.channels.front().number;
}

gap::DiagnosisSettings gap_diagnosis_settings(const config::GearwatchConfig& config) {
  gap::DiagnosisSettings settings;
  // The index in the records the daemon hands over: they carry the compared channel (gap_channel) alone
  // (kept_gap_record), so the protocol number never stands in for a position in a record.
  settings.channel = 0;
  settings.bootstrap_resamples = config.gap.bootstrap_resamples;
  settings.seed = static_cast<std::uint64_t>(config.gap.seed);
  settings.rms_sa_harmonics = config.processing.rms_sa_harmonics;
  return settings;
}

GapDiagnoser make_gap_diagnoser(const config::GearwatchConfig& config, const twin::GearboxParameters& params) {
  auto base = gap_diagnosis_settings(config);
  base.twin_parameters = params;
  return [gears = config.rig.gears, base = std::move(base)](const std::vector<gap::DiagnosisInput>& training,
                                                                           const std::vector<gap::DiagnosisInput>& held_out,
                                                                           const GapCallContext& context) {
    auto settings = base;
    settings.rerun_twin = context.rerun_twin;
    settings.reference_k_wear = context.reference_k_wear;
    settings.rms_sa_wear_elasticities = context.rms_sa_wear_elasticities;
    return gap::diagnose(training, held_out, gears, settings);
  };
}

namespace {

/// The fields of a twin record that come from the measured record it stands for, not from the
/// simulation (the stream's identity and place, the operating point, the life position).
void stamp(Record& twin, const Record& measured) {
  twin.stream_key = measured.stream_key;
  twin.stream_id = measured.stream_id;
  twin.start_index = measured.start_index;
  twin.end = measured.end;
  twin.torque_nm = measured.torque_nm;
  twin.speed_hz = measured.speed_hz;
  twin.input_revolutions = measured.input_revolutions;
}

/// What a twin run of a record depends on besides the addition: the operating point, the rate,
/// the record's length (the counterpart's length follows it) and the wear state's profile.
using TwinBasis = std::tuple<double, double, double, double, std::vector<double>, std::vector<double>,
                             std::vector<std::vector<double>>, std::vector<std::vector<double>>>;

TwinBasis twin_basis(const Record& measured, const wear::WearState& state) {
  twin::ToothProfileDeviation d = wear::to_profile_deviation(state);
  return {measured.speed_hz, measured.torque_nm, measured.sample_rate_hz, measured.duration_s(), std::move(d.pinion),
          std::move(d.gear), std::move(d.pinion_per_tooth), std::move(d.gear_per_tooth)};
}

}  // namespace

class SharedTwinRuns {
 public:
  struct AcrossDiagnoses {};
  explicit SharedTwinRuns(AcrossDiagnoses) : across_(true) {}
  explicit SharedTwinRuns(const std::vector<GapSample>& samples) {
    std::map<TwinBasis, int> count;
    for (const auto& s : samples)
      if (s.measured) ++count[twin_basis(*s.measured, s.state)];
    for (auto& [basis, n] : count)
      if (n >= 2) shared_.insert(basis);
  }
  /// `run()` for `measured`, or the run made for another record with the same basis, stamped as
  /// `measured`'s. `effect` is -1 for the counterpart itself.
  template <class Run>
  Record get(const Record& measured, const wear::WearState& state, int effect, const std::vector<double>& values,
             double duration_s, Run&& run) {
    if (across_) return effect < 0 ? kept_counterpart(measured, state, duration_s, run) : run();
    if (shared_.empty()) return run();  // no two records alike: no key worth building
    TwinBasis basis = twin_basis(measured, state);
    if (!shared_.count(basis)) return run();
    const Key key{std::move(basis), effect, values, duration_s};
    auto it = runs_.find(key);
    if (it == runs_.end()) it = runs_.emplace(key, run()).first;
    Record out = it->second;
    stamp(out, measured);
    return out;
  }

  std::size_t kept() const {
    std::lock_guard lock(mutex_);
    return runs_.size() + counterparts_.size();
  }

 private:
  using Key = std::tuple<TwinBasis, int, std::vector<double>, double>;

  /// The counterpart at `measured`'s basis, simulated by the first diagnosis to ask; the others
  /// wait for it rather than simulate it again.
  template <class Run>
  Record kept_counterpart(const Record& measured, const wear::WearState& state, double duration_s, Run& run) {
    const Key key{twin_basis(measured, state), -1, {}, duration_s};
    std::promise<Record> made;
    std::shared_future<Record> ready;
    bool mine = false;
    {
      std::lock_guard lock(mutex_);
      auto it = counterparts_.find(key);
      mine = it == counterparts_.end();
      ready = mine ? counterparts_.emplace(key, made.get_future().share()).first->second : it->second;
    }
    if (mine) {
      try {
        made.set_value(run());
      } catch (...) {
        made.set_exception(std::current_exception());
        std::lock_guard lock(mutex_);
        counterparts_.erase(key);  // a failure is not kept: the next diagnosis tries again
      }
    }
    Record out = ready.get();
    stamp(out, measured);
    return out;
  }

  bool across_ = false;
  std::set<TwinBasis> shared_;
  std::map<Key, Record> runs_;
  mutable std::mutex mutex_;
  std::map<Key, std::shared_future<Record>> counterparts_;
};

std::shared_ptr<SharedTwinRuns> share_twin_runs(const std::vector<GapSample>& samples) {
  return std::make_shared<SharedTwinRuns>(samples);
}

std::shared_ptr<SharedTwinRuns> share_twin_counterparts_across_diagnoses() {
  return std::make_shared<SharedTwinRuns>(SharedTwinRuns::AcrossDiagnoses{});
}

std::size_t kept_twin_runs(const SharedTwinRuns& shared) { return shared.kept(); }

namespace {

/// The twin at `measured`'s operating point and rate, `duration_s` long (the record's length for
/// the counterpart itself, shorter for a rerun).
Record counterpart_record(const Record& measured, int channel, const twin::GearboxParameters& params,
                          const twin::ToothProfileDeviation& profile, twin::SimulationOptions options, double duration_s) {
  const twin::OperatingPoint op{measured.speed_hz, measured.torque_nm};
  options.sample_rate_hz = measured.sample_rate_hz;
  const twin::CasingSignal signal = twin::simulate_casing_signal(params, profile, op, duration_s, options);
  Record twin;
  twin.sample_rate_hz = signal.sample_rate_hz;
  twin.channels = {signal.acceleration};
  twin.channel_numbers = {channel};
  twin.tacho_edges[0] = signal.tacho_edges;
  stamp(twin, measured);
  return twin;
}

}  // namespace

TwinCounterpart make_twin_counterpart(const twin::GearboxParameters& params, const config::GearwatchConfig& config,
                                      std::shared_ptr<SharedTwinRuns> shared) {
  const int channel = gap_channel(config);
  // The twin repeats itself every revolution: a counterpart as long as the diagnosis's reruns
  // (gap::twin_duration_s) reads the same spectra as one as long as the record, at a fraction of
  // the cost on the model thread.
  return [params, channel, settings = gap_diagnosis_settings(config), shared](const Record& measured,
                                                                               const wear::WearState& state) {
    const double duration_s = gap::twin_duration_s(measured, settings);
    auto run = [&] { return counterpart_record(measured, channel, params, wear::to_profile_deviation(state), {}, duration_s); };
    return shared ? shared->get(measured, state, -1, {}, duration_s, run) : run();
  };
}

TwinRerunCounterpart make_twin_rerun(const twin::GearboxParameters& params, const config::GearwatchConfig& config,
                                     std::shared_ptr<SharedTwinRuns> shared) {
  if (!config.gap.rerun_twin) return {};
  const int channel = gap_channel(config);
  return [params, channel, shared](const Record& measured, const wear::WearState& state, gap::CandidateEffect effect,
                                   const std::vector<double>& values, double duration_s) {
    auto run = [&] {
      twin::ToothProfileDeviation profile = wear::to_profile_deviation(state);
      twin::SimulationOptions options;
      gap::add_rerun_effect(effect, values, profile, options);
      return counterpart_record(measured, channel, params, profile, options, duration_s);
    };
    return shared ? shared->get(measured, state, static_cast<int>(effect), values, duration_s, run) : run();
  };
}

}  // namespace gearwatch::daemon
