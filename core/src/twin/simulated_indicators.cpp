// The simulated signal's indicators through the measurement pipeline (no second implementation).
#include <string>

#include "gearwatch/dsp/record_analyzer.hpp"
#include "gearwatch/twin/simulation.hpp"

namespace gearwatch::twin {

dsp::ChannelAnalysis simulated_analysis(const GearboxParameters& p, const ToothProfileDeviation& deviation, const OperatingPoint& op,
                                        double duration_s, const GearboxSpec& rig, const dsp::SignalProcessingSettings& settings) {
  const CasingSignal signal = simulate_casing_signal(p, deviation, op, duration_s, rig.sample_rate_hz);
  Record record;
  record.sample_rate_hz = signal.sample_rate_hz;
  record.channels.push_back(signal.acceleration);
  record.channel_numbers.push_back(rig.channels.empty() ? 0 : rig.channels.front().number);
  const int shaft = rig.tachos.empty() ? 0 : rig.tachos.front().shaft;
  if (shaft < 0 || shaft >= kMaxShafts) throw TwinParameterError("rig tacho shaft index out of range");
  record.tacho_edges[static_cast<std::size_t>(shaft)] = signal.tacho_edges;
  record.torque_nm = op.input_torque_nm;
  record.speed_hz = op.input_speed_hz;
  dsp::RecordAnalyzer analyzer(rig, settings);
  return analyzer.analyze(record, 0);
}

double simulated_rms_sa(const GearboxParameters& p, const ToothProfileDeviation& deviation, const OperatingPoint& op,
                        double duration_s, const GearboxSpec& rig, const dsp::SignalProcessingSettings& settings) {
  const dsp::ChannelAnalysis analysis = simulated_analysis(p, deviation, op, duration_s, rig, settings);
  if (const auto v = analysis.value(dsp::Indicator::rms_sa)) return *v;
  const dsp::SkippedIndicator* why = analysis.skip_reason(dsp::Indicator::rms_sa);
  throw TwinParameterError(std::string("simulated RMS_SA not available: ") + (why ? dsp::to_string(why->reason) : "not computed"));
}

}  // namespace gearwatch::twin
