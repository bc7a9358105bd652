#include "gearwatch/dsp/record_analyzer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <stdexcept>
#include <unordered_set>

namespace gearwatch::dsp {

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("signal processing settings: " + what);
}

void check_band(const FrequencyBand& b, const std::string& name) {
  require(std::isfinite(b.low_hz) && std::isfinite(b.high_hz) && b.low_hz >= 0.0 && b.high_hz > b.low_hz,
          name + " must satisfy 0 <= low_hz < high_hz");
}

// Names of indicators computed from the input-shaft TSA and from the residual.
std::vector<std::string> tsa_names(const SignalProcessingSettings& s) {
  std::vector<std::string> names{to_string(Indicator::gmf1_amplitude)};
  for (int h = 1; h <= s.stored_gmf_harmonics; ++h) names.push_back("gmf_harmonic_" + std::to_string(h));
  names.emplace_back(to_string(Indicator::rms_sa));
  return names;
}

std::vector<std::string> residual_names(const SignalProcessingSettings& s) {
  std::vector<std::string> names;
  for (Indicator i : {Indicator::rms_residual, Indicator::kurtosis_residual, Indicator::ics2_full_band,
                      Indicator::ics2_low_band, Indicator::ics2_high_band, Indicator::ics2_selected_band})
    names.emplace_back(to_string(i));
  if (s.kurtogram_band_selection) names.emplace_back(to_string(Indicator::kurtosis_selected_band));
  for (Indicator i : {Indicator::sc_gmf_max, Indicator::sc_gmf_mean, Indicator::sc_gmf_peak_carrier_hz}) names.emplace_back(to_string(i));
  for (const auto& r : s.mean_carrier_ranges) names.push_back(mean_carrier_indicator_name(r));
  return names;
}

std::vector<std::string> speed_names() { return {to_string(Indicator::speed_mean_hz), to_string(Indicator::speed_fluctuation)}; }

struct Moments {
  double rms = 0.0;
  double std_dev = 0.0;   // about the mean
  double kurtosis = 0.0;  // m4 / m2^2 about the mean (3 for a Gaussian signal)
};

template <class T>
Moments moments(std::span<const T> x) {
  Moments m;
  if (x.empty()) return m;
  const double n = static_cast<double>(x.size());
  double sum = 0.0, sum2 = 0.0;
  for (T v : x) {
    sum += v;
    sum2 += static_cast<double>(v) * v;
  }
  const double mean = sum / n;
  double c2 = 0.0, c4 = 0.0;
  for (T v : x) {
    const double d = static_cast<double>(v) - mean;
    const double d2 = d * d;
    c2 += d2;
    c4 += d2 * d2;
  }
  c2 /= n;
  c4 /= n;
  m.rms = std::sqrt(sum2 / n);
  m.std_dev = std::sqrt(c2);
  m.kurtosis = c2 > 0.0 ? c4 / (c2 * c2) : 0.0;
  return m;
}

}  // namespace

std::string mean_carrier_indicator_name(const FrequencyBand& range) {
  return std::string(kMeanCarrierIndicatorPrefix) + std::to_string(std::llround(range.low_hz)) + "_" +
         std::to_string(std::llround(range.high_hz));
}

void SignalProcessingSettings::validate(const GearboxSpec& rig) const {
  require(samples_per_revolution == 0 ||
              (is_smooth_size(static_cast<std::size_t>(std::max(samples_per_revolution, 1))) &&
               samples_per_revolution >= 64 && samples_per_revolution <= (1 << 20)),
          "samples_per_revolution must be 0 (auto) or a 2^a 3^b 5^c number in [64, 1048576]");
  require(stored_gmf_harmonics >= 1 && stored_gmf_harmonics <= 100, "stored_gmf_harmonics must be in [1, 100]");
  require(rms_sa_harmonics >= 1 && rms_sa_harmonics <= stored_gmf_harmonics,
          "rms_sa_harmonics must be in [1, stored_gmf_harmonics]");
  require(ics2_harmonics >= 1 && ics2_harmonics <= 50, "ics2_harmonics must be in [1, 50]");
  require(ics2_tolerance_bins >= 0 && ics2_tolerance_bins <= 50, "ics2_tolerance_bins must be in [0, 50]");
  check_band(pitting_band, "pitting_band");
  check_band(abrasion_band, "abrasion_band");
  require(filter_bank_levels >= 1 && filter_bank_levels <= 10, "filter_bank_levels must be in [1, 10]");
  std::unordered_set<std::string> names;
  for (const auto& r : mean_carrier_ranges) {
    check_band(r, "mean_carrier_ranges");
    require(names.insert(mean_carrier_indicator_name(r)).second, "mean_carrier_ranges has a duplicate range");
  }
  require(std::isfinite(min_revolutions_for_tsa) && min_revolutions_for_tsa >= 2.0,
          "min_revolutions_for_tsa must be >= 2");
  require(max_clipped_fraction >= 0.0 && max_clipped_fraction <= 1.0, "max_clipped_fraction must be in [0, 1]");
  require(flat_line_max_std_lsb >= 0.0 && flat_line_max_std_lsb <= 1000.0, "flat_line_max_std_lsb must be in [0, 1000]");
  require(residual_rms_floor >= 0.0 && residual_rms_floor < 1.0, "residual_rms_floor must be in [0, 1)");
  require(band_energy_floor_db >= -300.0 && band_energy_floor_db <= 0.0, "band_energy_floor_db must be in [-300, 0]");
  require(trend_significance > 0.0 && trend_significance <= 0.5, "trend_significance must be in (0, 0.5]");
  require(wear_min_band_share >= 0.0 && wear_min_band_share <= 1.0, "wear_min_band_share must be in [0, 1]");
  require(wear_baseline_records == 0 || (wear_baseline_records >= 10 && wear_baseline_records <= 200),
          "wear_baseline_records must be 0 or in [10, 200]");
  require(trend_window_records >= 3, "trend_window_records must be at least 3");
  require(band_jump_persistence_records >= 1, "band_jump_persistence_records must be at least 1");
  require(std::isfinite(band_jump_sigma) && band_jump_sigma >= 0.0, "band_jump_sigma must be >= 0");
  require(rig.gears.pinion_teeth >= 1 && rig.gears.gear_teeth >= 1, "rig tooth counts must be positive");
  require(rig.sample_rate_hz > 0.0, "rig sample rate must be positive");
  require(rig.min_speed_hz > 0.0 && rig.max_speed_hz > rig.min_speed_hz, "rig speed range must satisfy 0 < min < max");
}

std::optional<double> ChannelAnalysis::value(const std::string& name) const {
  for (const auto& i : indicators)
    if (i.name == name) return i.value;
  return std::nullopt;
}

const SkippedIndicator* ChannelAnalysis::skip_reason(const std::string& name) const {
  for (const auto& s : skipped)
    if (s.name == name) return &s;
  return nullptr;
}

RecordAnalyzer::RecordAnalyzer(const GearboxSpec& rig, const SignalProcessingSettings& settings)
    : rig_(rig), settings_(settings), envelope_(plans_), coherence_(plans_) {
  settings_.validate(rig_);
}

std::vector<std::string> RecordAnalyzer::indicator_names() const {
  std::vector<std::string> names{to_string(Indicator::rms_raw), to_string(Indicator::kurtosis_raw)};
  for (auto& n : speed_names()) names.push_back(n);
  for (auto& n : tsa_names(settings_)) names.push_back(n);
  for (auto& n : residual_names(settings_)) names.push_back(n);
  return names;
}

const TachoSpec* input_tacho(const GearboxSpec& rig, const Record& record) {
  const TachoSpec* tacho = nullptr;
  for (const auto& t : rig.tachos) {
    if (t.shaft < 0 || t.shaft >= kMaxShafts || record.tacho_edges[static_cast<std::size_t>(t.shaft)].empty()) continue;
    if (tacho == nullptr || (t.ratio_to_input == 1.0 && tacho->ratio_to_input != 1.0)) tacho = &t;
  }
  return tacho;
}

ChannelAnalysis RecordAnalyzer::analyze(const Record& record, std::size_t channel_index, std::span<const double> input_edges) {
  if (channel_index >= record.channels.size())
    throw std::out_of_range("RecordAnalyzer::analyze: record has no channel " + std::to_string(channel_index));
  ChannelAnalysis out;
  const auto all = indicator_names();
  auto skip_all = [&](SkipReason reason) {
    for (const auto& n : all) out.skipped.push_back({n, reason, {}});
  };
  const std::span<const float> x(record.channels[channel_index]);
  if (x.empty()) {
    skip_all(SkipReason::empty_record);
    return out;
  }
  if (!(record.sample_rate_hz > 0.0) || !std::isfinite(record.sample_rate_hz)) {
    skip_all(SkipReason::bad_sample_rate);
    return out;
  }
  if (!std::all_of(x.begin(), x.end(), [](float v) { return std::isfinite(v); })) {
    skip_all(SkipReason::non_finite_samples);
    return out;
  }
  // Clipping: samples at the converter's full scale (32767 steps of the channel's scaling).
  const ChannelSpec* spec = nullptr;
  if (channel_index < record.channel_numbers.size())
    for (const auto& c : rig_.channels)
      if (c.number == record.channel_numbers[channel_index]) spec = &c;
  if (spec == nullptr && channel_index < rig_.channels.size()) spec = &rig_.channels[channel_index];
  if (spec != nullptr && spec->scale_m_s2_per_lsb > 0.0) {
    // Half a step below full scale: a float sample of a clipped i16 lands on it exactly.
    const double full_scale = (32767.0 - 0.5) * spec->scale_m_s2_per_lsb;
    const auto clipped = static_cast<double>(
        std::count_if(x.begin(), x.end(), [&](float v) { return std::abs(static_cast<double>(v)) >= full_scale; }));
    if (clipped > settings_.max_clipped_fraction * static_cast<double>(x.size())) {
      skip_all(SkipReason::clipped_samples);
      return out;
    }
  }
  const Moments raw = moments(x);
  // Flat line: at most flat_line_max_std_lsb LSB of spread (exactly constant without a scale).
  const double lsb = spec != nullptr && spec->scale_m_s2_per_lsb > 0.0 ? spec->scale_m_s2_per_lsb : 0.0;
  if (raw.std_dev <= settings_.flat_line_max_std_lsb * lsb) {
    skip_all(SkipReason::flat_line);
    return out;
  }
  out.indicators.push_back({to_string(Indicator::rms_raw), raw.rms});
  out.indicators.push_back({to_string(Indicator::kurtosis_raw), raw.kurtosis});

  std::string failure;
  try {
    analyze_order_domain(record, x, raw.std_dev, input_edges, out);
  } catch (const std::exception& e) {
    failure = e.what();
  }
  // Every indicator ends up either computed or skipped with a reason.
  std::unordered_set<std::string> seen;
  for (const auto& i : out.indicators) seen.insert(i.name);
  for (const auto& s : out.skipped) seen.insert(s.name);
  for (const auto& n : all)
    if (!seen.count(n))
      out.skipped.push_back({n, failure.empty() ? SkipReason::not_computed : SkipReason::analysis_error, failure});
  return out;
}

/// One record's order-domain analysis (the speed, order tracking and synchronous separation, the
/// residual's envelope, band selection and coherence), its steps in analyze_order_domain's order.
/// A step that returns false ends the analysis; what it skipped and why is in `out`. Nested in
/// RecordAnalyzer, so its steps use the analyzer's plans and buffers.
struct RecordAnalyzer::Context {
  Context(RecordAnalyzer& analyzer, const Record& r, std::span<const float> samples, double raw_std, ChannelAnalysis& o)
      : a(analyzer), record(r), x(samples), raw_std_dev(raw_std), out(o) {}

  RecordAnalyzer& a;
  const Record& record;
  std::span<const float> x;
  double raw_std_dev;
  ChannelAnalysis& out;
  double fs = record.sample_rate_hz;
  std::vector<std::string> order_names, residual_group;
  int z1 = a.rig_.gears.pinion_teeth, z2 = a.rig_.gears.gear_teeth;
  // The shaft's angle and speed.
  double total_revs = 0, mean_speed = 0, slowest = 0, fastest = 0;
  std::size_t spr = 0, input_revs = 0, output_revs = 0, length = 0;
  // The residual's spectral stretch: the first R' revolutions, R' 7-smooth.
  std::size_t spectral_revs = 0, spectral_length = 0, last_bin = 0;
  std::span<const double> residual;
  Ics2Parameters ics2;
  double nyquist_hz = 0, usable_hz = 0, bins_per_hz = 0, total_energy = 0, min_band_fraction = 0, full_band = 0;

  void skip(const std::vector<std::string>& names, SkipReason reason, const std::string& detail = {}) {
    for (const auto& n : names) out.skipped.push_back({n, reason, detail});
  }
  void add(const std::string& name, double value) {
    if (std::isfinite(value))
      out.indicators.push_back({name, value});
    else
      out.skipped.push_back({name, SkipReason::non_finite_result, {}});
  }

  void name_groups() {
    order_names = speed_names();
    for (auto& n : tsa_names(a.settings_)) order_names.push_back(n);
    residual_group = residual_names(a.settings_);
    for (auto& n : residual_group) order_names.push_back(n);
  }

  /// Tacho: the given input-shaft edges (a speed estimate), else the input shaft's own tacho if it
  /// has edges, else any other shaft's scaled by its ratio.
  bool assign_angle(std::span<const double> input_edges) {
    const TachoSpec* tacho = input_tacho(a.rig_, record);
    if (tacho == nullptr && input_edges.empty()) {
      skip(order_names, SkipReason::no_tacho);
      return false;
    }
    const TachoCheck check =
        input_edges.empty() ? a.angle_.assign(record.tacho_edges[static_cast<std::size_t>(tacho->shaft)],
                                              tacho->edges_per_rev, 1.0 / tacho->ratio_to_input)
                            : a.angle_.assign(input_edges, 1, 1.0);
    if (!check.ok()) {
      skip(order_names, *check.failure);
      return false;
    }
    return true;
  }

  /// The speed profile and its indicators, refused outside the rig's speed range.
  bool speed_indicators() {
    a.angle_.speed_per_revolution(fs, out.speed_profile_hz);
    total_revs = a.angle_.total_revolutions();
    const double duration = a.angle_.time_at(total_revs) - a.angle_.time_at(0.0);
    mean_speed = total_revs * fs / duration;
    slowest = mean_speed, fastest = mean_speed;
    for (double v : out.speed_profile_hz) {
      slowest = std::min(slowest, v);
      fastest = std::max(fastest, v);
    }
    if (slowest < a.rig_.min_speed_hz || fastest > a.rig_.max_speed_hz) {
      skip(order_names, SkipReason::speed_out_of_range);
      return false;
    }
    out.mean_speed_hz = mean_speed;
    add(to_string(Indicator::speed_mean_hz), mean_speed);
    add(to_string(Indicator::speed_fluctuation), (fastest - slowest) / mean_speed);
    return true;
  }

  /// The order-tracking resolution and the whole revolutions of both shafts; enough for a TSA?
  bool count_revolutions() {
    spr = static_cast<std::size_t>(a.settings_.samples_per_revolution);
    if (spr == 0) spr = std::clamp<std::size_t>(next_smooth_size(static_cast<std::size_t>(std::ceil(fs / slowest))), 64, 1u << 20);
    out.samples_per_revolution = spr;
    input_revs = static_cast<std::size_t>(std::floor(total_revs + 1e-9));
    output_revs = static_cast<std::size_t>(std::floor(total_revs * z1 / z2 + 1e-9));
    if (static_cast<double>(input_revs) < a.settings_.min_revolutions_for_tsa) {
      skip(tsa_names(a.settings_), SkipReason::too_few_revolutions);
      skip(residual_group, SkipReason::too_few_revolutions);
      return false;
    }
    return true;
  }

  /// Order tracking onto both shafts and the synchronous separation.
  void separate() {
    length = input_revs * spr;
    a.input_angle_.resize(length);
    a.resampler_.resample(x, a.angle_, spr, input_revs, a.input_angle_);
    a.output_angle_.resize(output_revs * spr);
    if (output_revs > 0)
      a.output_resampler_.resample(x, a.angle_, spr, output_revs, a.output_angle_, static_cast<double>(z2) / z1);
    a.residual_.resize(length);
    const auto separation = a.separation_.separate(a.input_angle_, a.output_angle_, spr, z1, z2, a.plans_, a.residual_);
    out.tsa_averages_input = static_cast<double>(separation.input_averages);
    out.tsa_averages_output = static_cast<double>(separation.output_averages);
  }

  /// The input-shaft TSA's mesh harmonics and RMS_SA.
  void tsa_indicators() {
    auto& gmf = a.gmf_amplitudes_;
    synchronous_harmonic_amplitudes(a.separation_.input_tsa(), z1, static_cast<std::size_t>(a.settings_.stored_gmf_harmonics),
                                    a.plans_, gmf);
    if (std::isfinite(gmf[0])) add(to_string(Indicator::gmf1_amplitude), gmf[0]);
    else out.skipped.push_back({to_string(Indicator::gmf1_amplitude), SkipReason::above_nyquist, {}});
    for (std::size_t h = 0; h < gmf.size(); ++h) {
      const std::string name = "gmf_harmonic_" + std::to_string(h + 1);
      if (std::isfinite(gmf[h])) add(name, gmf[h]);
      else out.skipped.push_back({name, SkipReason::above_nyquist, {}});
    }
    try {
      add(to_string(Indicator::rms_sa), rms_sa(gmf, static_cast<std::size_t>(a.settings_.rms_sa_harmonics)));
    } catch (const std::invalid_argument&) {
      out.skipped.push_back({to_string(Indicator::rms_sa), SkipReason::above_nyquist, {}});
    }
  }

  /// The residual's RMS and kurtosis; its structure only when it stands above the floor.
  bool residual_moments() {
    if (static_cast<double>(output_revs) < a.settings_.min_revolutions_for_tsa) {
      skip(residual_group, SkipReason::too_few_revolutions);
      return false;
    }
    const Moments res = moments(std::span<const double>(a.residual_.data(), length));
    add(to_string(Indicator::rms_residual), res.rms);
    add(to_string(Indicator::kurtosis_residual), res.kurtosis);
    // A residual at the level of quantisation and order-tracking error has no structure worth a
    // number: ICS2 of such residue reads anything from 0.3 to 1.3 on a noise-free gear signal.
    if (res.rms < a.settings_.residual_rms_floor * raw_std_dev) {
      std::vector<std::string> structure;
      for (const auto& n : residual_group)
        if (n != to_string(Indicator::rms_residual) && n != to_string(Indicator::kurtosis_residual)) structure.push_back(n);
      skip(structure, SkipReason::residual_below_floor);
      return false;
    }
    return true;
  }

  /// The spectral indicators use the first R' revolutions, R' the largest 7-smooth count <= R, so
  /// every transform size factors into small primes (a prime R such as 97 would make FFTW's
  /// transforms several times slower); at most a few percent of the record is left out. The
  /// stretch is transformed tapered (kEnvelopeTaperFraction: it does not join end to start, and
  /// the step would be a broadband click) for the envelopes' band-passes.
  void prepare_spectrum() {
    spectral_revs = previous_smooth_size(input_revs);
    spectral_length = spectral_revs * spr;
    residual = std::span<const double>(a.residual_.data(), spectral_length);
    remove_discrete_lines();
    ics2 = Ics2Parameters{static_cast<double>(z1), a.settings_.ics2_harmonics, a.settings_.ics2_tolerance_bins};
    const RealFft& fft = a.plans_.real(spectral_length);
    a.tapered_residual_.assign(residual.begin(), residual.end());
    apply_tukey_taper(a.tapered_residual_, kEnvelopeTaperFraction);
    a.residual_spectrum_.resize(fft.spectrum_size());
    fft.forward(a.tapered_residual_, a.residual_spectrum_);
    nyquist_hz = std::min(fs / 2.0, static_cast<double>(spr) / 2.0 * slowest);
    bins_per_hz = static_cast<double>(spectral_revs) / mean_speed;
    last_bin = spectral_length / 2 - 1;
    total_energy = 0.0;  // one-sided, DC and Nyquist bins excluded like the envelopes
    for (std::size_t k = 1; k <= last_bin; ++k) total_energy += std::norm(a.residual_spectrum_[k]);
    min_band_fraction = std::pow(10.0, a.settings_.band_energy_floor_db / 10.0);
    // Carrier bands reach up to 0.45·fs (kUsableBandFraction).
    usable_hz = std::min(nyquist_hz, kUsableBandFraction * fs);
  }

  /// The residual's random part (SignalProcessingSettings::remove_residual_lines); a stretch too
  /// short for the remover's blocks is left whole. In place: the stretch is read only through
  /// `residual` from here on (its moments are taken).
  void remove_discrete_lines() {
    if (!a.settings_.remove_residual_lines || spectral_length < a.line_remover_.min_length()) return;
    a.line_remover_.remove(std::span<double>(a.residual_.data(), spectral_length), a.plans_);
  }

  /// Squared-envelope ICS2 with cyclic orders of the input shaft: full band and fixed carrier bands.
  void envelope_indicators() {
    full_band = a.envelope_.full_band_ics2(a.tapered_residual_, a.residual_spectrum_, spectral_revs, ics2).value;
    add(to_string(Indicator::ics2_full_band), full_band);
    band_ics2(a.settings_.pitting_band, to_string(Indicator::ics2_low_band));
    band_ics2(a.settings_.abrasion_band, to_string(Indicator::ics2_high_band));
  }

  /// A band reaching past the usable band keeps the part below when that is at least half of it
  /// (the band still stands for its mechanism), noted.
  void band_ics2(FrequencyBand band, const std::string& name) {
    if (band.high_hz > usable_hz + 1e-9) {
      const double kept = std::max(0.0, usable_hz - band.low_hz) / (band.high_hz - band.low_hz);
      char text[200];
      if (kept < 0.5) {
        std::snprintf(text, sizeof text, "%.0f-%.0f Hz: %.0f %% of it below %.0f Hz", band.low_hz, band.high_hz, 100.0 * kept,
                      usable_hz);
        out.skipped.push_back({name, SkipReason::band_above_nyquist, text});
        return;
      }
      std::snprintf(text, sizeof text, "%.0f-%.0f Hz analysed of %.0f-%.0f Hz", band.low_hz, usable_hz, band.low_hz, band.high_hz);
      out.notes.push_back({name, IndicatorNote::band_trimmed, text});
      band.high_hz = usable_hz;
    }
    const auto first = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(band.low_hz * bins_per_hz)));
    const auto last = std::min(last_bin, static_cast<std::size_t>(std::floor(band.high_hz * bins_per_hz)));
    if (first > last) {
      out.skipped.push_back({name, SkipReason::band_empty, {}});
      return;
    }
    double band_energy = 0.0;
    for (std::size_t k = first; k <= last; ++k) band_energy += std::norm(a.residual_spectrum_[k]);
    if (!(band_energy > 0.0) || band_energy < min_band_fraction * total_energy) {
      out.skipped.push_back({name, SkipReason::band_below_floor, {}});
      return;
    }
    add(name, a.envelope_.band_ics2(a.residual_spectrum_, spectral_length, spectral_revs, first, last, ics2).value);
  }

  /// Band selection over the 1/3-binary tree (ICS2, and kurtosis for comparison), among the bands
  /// above the energy floor. The tree's filters are linear, so it runs on the untapered stretch.
  void band_selection() {
    Ics2Criterion ics2_criterion(a.envelope_, a.plans_, spr, ics2);
    ics2_criterion.set_whole_signal_value(full_band);
    std::vector<BandCriterion*> criteria{&a.power_criterion_, &ics2_criterion};
    if (a.settings_.kurtogram_band_selection) criteria.push_back(&a.kurtosis_criterion_);
    auto& maps = a.band_maps_;
    maps.resize(criteria.size());
    const double equivalent_rate = static_cast<double>(spr) * mean_speed;  // angle-domain samples per second
    std::vector<std::string> selection_names{to_string(Indicator::ics2_selected_band)};
    std::vector<BandSelectionCriterion> selected_by{BandSelectionCriterion::ics2};
    if (a.settings_.kurtogram_band_selection) {
      selection_names.emplace_back(to_string(Indicator::kurtosis_selected_band));
      selected_by.push_back(BandSelectionCriterion::kurtosis);
    }
    try {
      // ICS2 and kurtosis only on the bands the selection may pick (the power map is criteria[0]).
      a.filter_bank_.analyse(residual, a.settings_.filter_bank_levels, criteria, maps,
                             BandGate{0, usable_hz / equivalent_rate, min_band_fraction});
      for (std::size_t i = 1; i < criteria.size(); ++i) {
        const auto best = maps[i].optimum(usable_hz / equivalent_rate, &maps[0], min_band_fraction);
        if (!best.found) {
          skip({selection_names[i - 1]}, SkipReason::all_bands_below_floor);
          continue;
        }
        out.band_selections.push_back({selected_by[i - 1], best.level, best.centre_fraction * equivalent_rate,
                                       best.bandwidth_fraction * equivalent_rate, best.value});
        add(selection_names[i - 1], best.value);
      }
    } catch (const std::invalid_argument& e) {
      skip(selection_names, SkipReason::filter_bank_error, e.what());
    }
  }

  /// Spectral coherence at the gear-mesh order and mean carrier frequencies (Fig. 4.13).
  void coherence_indicators() {
    a.coherence_.estimate(residual, spr, z1);
    const auto gamma = a.coherence_.coherence();
    const auto nyquist_bin = std::min(gamma.size() - 1, static_cast<std::size_t>(std::floor(nyquist_hz / mean_speed)));
    double peak = 0.0, sum = 0.0;
    std::size_t peak_bin = static_cast<std::size_t>(z1), count = 0;
    for (std::size_t k = static_cast<std::size_t>(z1); k <= nyquist_bin; ++k) {
      sum += gamma[k];
      ++count;
      if (gamma[k] > peak) {
        peak = gamma[k];
        peak_bin = k;
      }
    }
    add(to_string(Indicator::sc_gmf_max), peak);
    add(to_string(Indicator::sc_gmf_mean), count > 0 ? sum / static_cast<double>(count) : std::nan(""));
    add(to_string(Indicator::sc_gmf_peak_carrier_hz), static_cast<double>(peak_bin) * mean_speed);
    for (const auto& range : a.settings_.mean_carrier_ranges) {
      const std::string name = mean_carrier_indicator_name(range);
      if (range.high_hz > nyquist_hz + 1e-9) {
        out.skipped.push_back({name, SkipReason::band_above_nyquist, {}});
        continue;
      }
      add(name, a.coherence_.mean_carrier_order(range.low_hz / mean_speed, range.high_hz / mean_speed) * mean_speed);
    }
  }
};

void RecordAnalyzer::analyze_order_domain(const Record& record, std::span<const float> x, double raw_std_dev,
                                          std::span<const double> input_edges, ChannelAnalysis& out) {
  Context c(*this, record, x, raw_std_dev, out);
  c.name_groups();
  if (!c.assign_angle(input_edges) || !c.speed_indicators() || !c.count_revolutions()) return;
  c.separate();
  c.tsa_indicators();
  if (!c.residual_moments()) return;
  c.prepare_spectrum();
  c.envelope_indicators();
  c.band_selection();
  c.coherence_indicators();
}

}  // namespace gearwatch::dsp
