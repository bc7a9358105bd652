#include "gearwatch/gap/diagnosis.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <limits>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

#include "gearwatch/gap/attribution.hpp"
#include "gearwatch/gap/candidates.hpp"
#include "gearwatch/gap/evaluation.hpp"
#include "gearwatch/gap/describe.hpp"
#include "gearwatch/gap/features.hpp"
#include "gearwatch/gap/spectra.hpp"
#include "gearwatch/twin/errors.hpp"
#include "gearwatch/twin/gearbox_model.hpp"

namespace gearwatch::gap {
namespace {

constexpr std::size_t kFamilies = kAllFamilyKinds.size();
// Held-out information criterion: a parameter must buy this much of the summed log MSE.
constexpr double kParameterPenalty = 0.003;

struct PairSpectra {
  // Shared: every twin re-run of a record is compared with the same measured spectra.
  std::shared_ptr<const RecordSpectra> measured;
  RecordSpectra twin;
  SpectralSummary measured_all, twin_all;
  double floor = 0;
};

/// A speed ripple whose depth sits at the bottom of its range has no phase part: whatever it fitted
/// (its AM share alone: a pure AM) is not a speed ripple, which turns the shaft ahead and back and
/// so modulates the phase of every line. It stays among the candidates with that bound, and is not
/// chosen.
bool fitted_beyond_its_physics(CandidateEffect effect, const std::vector<double>& values, double sample_rate_hz) {
  if (effect != CandidateEffect::speed_fluctuation) return false;
  const auto bounds = parameters_at_bounds(effect, values, sample_rate_hz, false);
  return std::any_of(bounds.begin(), bounds.end(), [](const ParameterBound& b) { return b.name == "depth" && !b.upper; });
}

std::vector<PairSpectra> reduce(const std::vector<DiagnosisInput>& inputs, const GearPairSpec& gears,
                                const DiagnosisSettings& s, const twin::GearboxMatrices& twin_matrices,
                                const std::shared_ptr<const BearingForcePath>& bearing_path, const char* which) {
  std::vector<PairSpectra> out;
  out.reserve(inputs.size());
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const auto& in = inputs[i];
    const std::string where = std::string(which) + " record " + std::to_string(i) + ": ";
    if (in.measured.sample_rate_hz != in.twin.sample_rate_hz)
      throw std::invalid_argument(where + "measured and twin sample rates differ");
    if (in.twin.channels.empty()) throw std::invalid_argument(where + "the twin record has no channel");
    const int twin_channel = std::min<int>(s.channel, static_cast<int>(in.twin.channels.size()) - 1);
    try {
      PairSpectra p{std::make_shared<const RecordSpectra>(in.measured, s.channel, gears, s.min_revolutions),
                    RecordSpectra(in.twin, twin_channel, gears, s.min_revolutions), {}, {}, 0};
      p.twin.set_run_out_sensitivity(
          run_out_sensitivity(twin_matrices, gears, false, p.twin.speed_hz(), p.twin.torque_nm()),
          run_out_sensitivity(twin_matrices, gears, true, p.twin.speed_hz(), p.twin.torque_nm()));
      p.twin.set_bearing_force_path(bearing_path);
      p.measured_all = p.measured->summary();
      p.twin_all = p.twin.summary();
      const double total = total_input_line_power(p.twin_all);
      if (!(total > 0)) throw std::invalid_argument("the twin record carries no synchronous vibration");
      p.floor = total * std::pow(10.0, s.floor_db / 10.0);
      out.push_back(std::move(p));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(where + e.what());
    }
  }
  return out;
}

/// The same measured record against the twin re-run with an addition; the floor stays the one of the
/// plain twin, so every model is compared above the same level.
PairSpectra with_rerun_twin(const PairSpectra& p, const Record& twin, const GearPairSpec& gears,
                            const DiagnosisSettings& s) {
  if (twin.channels.empty()) throw std::invalid_argument("the rerun twin record has no channel");
  const int twin_channel = std::min<int>(s.channel, static_cast<int>(twin.channels.size()) - 1);
  PairSpectra out{p.measured, RecordSpectra(twin, twin_channel, gears, s.min_revolutions), p.measured_all, {}, p.floor};
  out.twin.set_run_out_sensitivity(p.twin_all.pinion_run_out, p.twin_all.gear_run_out);
  out.twin.set_bearing_force_path(p.twin_all.bearing_force_path);
  out.twin_all = out.twin.summary();
  return out;
}

/// A candidate that changes the twin's dynamics, simulated at each value of its grid for every
/// training and held-out record.
struct RerunSet {
  CandidateEffect effect{};
  std::vector<std::vector<double>> values;  // the grid, then the points a refinement added
  std::deque<std::vector<SummaryPair>> train;   // [point][record]
  // [point][record], re-run only at the points a training fit picks (the held-out records are
  // half the reruns, and one or two points are ever scored). Deques: an element's address stays
  // put while points are added.
  std::deque<std::optional<std::vector<PairSpectra>>> test;
};

std::vector<GapPair> views(const std::vector<PairSpectra>& pairs, const std::vector<SpectralSummary>& models) {
  std::vector<GapPair> v;
  for (std::size_t i = 0; i < pairs.size(); ++i) v.push_back({&pairs[i].measured_all, &models[i], pairs[i].floor});
  return v;
}

std::vector<SpectralSummary> models_of(const std::vector<PairSpectra>& pairs, const std::vector<AppliedEffect>& fx,
                                       const GearPairSpec& gears) {
  std::vector<SpectralSummary> m;
  for (const auto& p : pairs) m.push_back(apply_effects(fx, p.twin_all, gears));
  return m;
}

struct Assessment {
  GapEvaluation point;
  std::array<Interval, kFamilies> interval{};
};

/// The records' summaries over the bootstrap draws, each computed once in a diagnosis. Every model
/// is scored on the same draws (the same seeds), and between the candidates that act on the twin's
/// spectra only the twin's side changes, on a copy; a summary is a pass over all of a record's
/// revolutions, the largest part of scoring a candidate. A draw is fixed by the resample, the pair
/// and the records' sizes (the twin's continues the measured record's generator), so the key is
/// the records' identities, the resample and the pair. Lives for one diagnose() call (one seed and
/// block length).
class BootstrapSummaries {
 public:
  explicit BootstrapSummaries(const DiagnosisSettings& s) : seed_(s.seed), block_(s.bootstrap_block_revolutions) {}
  /// The measured record's and the twin's summary over draw `resample` of pair `pair`.
  std::pair<const SpectralSummary*, const SpectralSummary*> get(const PairSpectra& p, int resample, std::size_t pair) {
    std::mt19937_64 rng(seed_ * 1000003u + static_cast<std::uint64_t>(resample) * 7919u + pair);
    const std::uint64_t measured = p.measured->identity();
    const SpectralSummary* m = &fetch({measured, 0, resample, pair}, *p.measured, rng);
    const SpectralSummary* t = &fetch({measured, p.twin.identity(), resample, pair}, p.twin, rng);
    return {m, t};
  }

  /// The same draw computed and not kept (for records whose draws are read once: the features'
  /// training records), with the key's generator.
  std::pair<SpectralSummary, SpectralSummary> fresh(const PairSpectra& p, int resample, std::size_t pair) const {
    std::mt19937_64 rng(seed_ * 1000003u + static_cast<std::uint64_t>(resample) * 7919u + pair);
    auto m = p.measured->bootstrap(rng, block_);
    auto t = p.twin.bootstrap(rng, block_);
    return {std::move(m), std::move(t)};
  }

 private:
  using Key = std::tuple<std::uint64_t, std::uint64_t, int, std::size_t>;  // identity 0: none
  const SpectralSummary& fetch(const Key& key, const RecordSpectra& r, std::mt19937_64& rng) {
    if (const auto it = kept_.find(key); it != kept_.end()) {
      r.draw_bootstrap(rng, block_);  // the generator moves on as if drawn, for the next record
      return it->second;
    }
    return kept_.emplace(key, r.bootstrap(rng, block_)).first->second;
  }
  std::uint64_t seed_;
  std::size_t block_;
  std::map<Key, SpectralSummary> kept_;
};

/// The held-out gaps of a model, with a block bootstrap over the revolutions of both records of
/// each pair (the same draws for every model, so models compare on equal terms).
Assessment assess(const std::vector<PairSpectra>& pairs, const std::vector<AppliedEffect>& fx,
                  const GearPairSpec& gears, int resamples, const GapEvaluator& evaluator,
                  BootstrapSummaries& bootstrap) {
  Assessment a;
  const auto models = models_of(pairs, fx, gears);
  a.point = evaluator.evaluate(views(pairs, models), true);
  std::array<std::vector<double>, kFamilies> draws;
  for (int b = 0; b < resamples; ++b) {
    std::vector<const SpectralSummary*> meas;
    std::vector<SpectralSummary> mod;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      const auto [m, t] = bootstrap.get(pairs[i], b, i);
      meas.push_back(m);
      mod.push_back(apply_effects(fx, *t, gears));
    }
    std::vector<GapPair> v;
    for (std::size_t i = 0; i < pairs.size(); ++i) v.push_back({meas[i], &mod[i], pairs[i].floor});
    const auto e = evaluator.evaluate(v, true);
    for (std::size_t f = 0; f < kFamilies; ++f) draws[f].push_back(e.distance_db(f));
  }
  for (std::size_t f = 0; f < kFamilies; ++f) a.interval[f] = bootstrap_interval(std::move(draws[f]), a.point.distance_db(f));
  return a;
}

/// Estimation noise of the distances: each record's bootstrap draws against its own full estimate.
std::array<double, kFamilies> noise_distance(const std::vector<PairSpectra>& pairs, const DiagnosisSettings& s,
                                             const GapEvaluator& evaluator, BootstrapSummaries& bootstrap) {
  std::array<double, kFamilies> sum{};
  const int n = std::max(8, s.bootstrap_resamples / 4);
  for (int b = 0; b < n; ++b) {
    std::vector<GapPair> vm, vt;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      const auto [m, t] = bootstrap.get(pairs[i], b, i);
      vm.push_back({m, &pairs[i].measured_all, pairs[i].floor});
      vt.push_back({t, &pairs[i].twin_all, pairs[i].floor});
    }
    const auto em = evaluator.evaluate(vm, true), et = evaluator.evaluate(vt, true);
    for (std::size_t f = 0; f < kFamilies; ++f)
      sum[f] += em.distance_db(f) * em.distance_db(f) + et.distance_db(f) * et.distance_db(f);
  }
  for (auto& v : sum) v = std::sqrt(v / n);
  return sum;
}

/// The gaps at the resolution of a line or a band (features.hpp) of every record, held out and
/// training, against the twin alone: the held-out records' bootstrap draws are the families' (kept),
/// the training records' are drawn once here (pairs numbered after the held-out ones).
std::vector<GapFeature> find_features(const std::vector<PairSpectra>& train, const std::vector<PairSpectra>& test,
                                      const GearPairSpec& gears, const DiagnosisSettings& s, BootstrapSummaries& bootstrap) {
  std::vector<FeaturePair> pairs;
  for (std::size_t i = 0; i < test.size(); ++i) pairs.push_back({&test[i].measured_all, &test[i].twin_all, test[i].floor, true, i});
  for (std::size_t i = 0; i < train.size(); ++i)
    pairs.push_back({&train[i].measured_all, &train[i].twin_all, train[i].floor, false, i});
  FeatureFinder finder(pairs, gears, s.features);
  for (int b = 0; b < s.bootstrap_resamples; ++b) {
    for (std::size_t i = 0; i < test.size(); ++i) {
      const auto [m, t] = bootstrap.get(test[i], b, i);
      finder.add_draw(i, *m, *t);
    }
    for (std::size_t i = 0; i < train.size(); ++i) {
      const auto [m, t] = bootstrap.fresh(train[i], b, test.size() + i);
      finder.add_draw(test.size() + i, m, t);
    }
  }
  auto features = finder.features();
  // Each feature described in a phenomenological form, on the same records (describe.hpp).
  std::vector<DescribedRecord> described;
  for (const auto* set : {&test, &train})
    for (const auto& p : *set)
      described.push_back({&p.measured_all, &p.twin_all, p.floor, p.measured->input_line_means(), p.measured->output_line_means(),
                           p.twin.input_line_means(), p.twin.output_line_means()});
  DescriptionSettings describing;
  describing.min_feature_db = s.features.min_feature_db;
  describing.floor = s.features.floor;
  describing.local = s.features.local;
  describing.min_speed_ratio = s.features.min_speed_ratio;
  const FeatureDescriber describer(described, gears, describing);
  describer.describe_all(features);
  // The broadband floors' features after the lines' and bins' (their own layer, described as floor changes).
  for (auto& f : finder.floor_features()) {
    f.description = describer.describe_floor(f);
    features.push_back(std::move(f));
  }
  return features;
}

std::vector<FamilyGap> family_gaps(const Assessment& a, const std::array<double, kFamilies>& noise,
                                   const DiagnosisSettings& s, const std::string& unresolved_reason) {
  std::vector<FamilyGap> out;
  for (std::size_t f = 0; f < kFamilies; ++f) {
    FamilyGap g;
    g.family = kAllFamilyKinds[f];
    g.resolved = a.point.resolved[f];
    if (!g.resolved) {
      g.unresolved_reason = a.point.count[f] > 0 || g.family != FamilyKind::fixed_frequency
                                ? "no lines of this family in the records' band"
                                : unresolved_reason;
      if (g.family == FamilyKind::fixed_frequency) g.unresolved_reason = unresolved_reason;
      out.push_back(g);
      continue;
    }
    g.distance_db = a.point.distance_db(f);
    g.distance_interval_db = a.interval[f];
    g.energy_share = a.point.energy_share(f);
    // Two records' estimation noise at twice its RMS, and never below the practical minimum.
    const double tau = min_gap_db_of(s, g.family);
    const double threshold = std::sqrt(4.0 * noise[f] * noise[f] + tau * tau);
    g.significant = g.distance_db > threshold;
    out.push_back(g);
  }
  return out;
}

/// Σ over the resolved families of ln(D² + noise² + τ²) (a log likelihood of the family gaps with
/// the estimation noise and the practical minimum τ as the floor, so a family already below them
/// counts for nothing), plus a penalty per fitted parameter.
double information_criterion(const GapEvaluation& e, const std::array<double, kFamilies>& noise, std::size_t k,
                             const DiagnosisSettings& s) {
  double ic = 0;
  for (std::size_t f = 0; f < kFamilies; ++f)
    if (e.resolved[f]) {
      const double tau = min_gap_db_of(s, kAllFamilyKinds[f]);
      ic += std::log(e.distance_db(f) * e.distance_db(f) + noise[f] * noise[f] + tau * tau);
    }
  return ic + kParameterPenalty * static_cast<double>(k);
}

/// Parameters the data set: the band and harmonic gains no training line reaches stay exactly 0.
std::size_t fitted_count(const std::vector<double>& values) {
  return static_cast<std::size_t>(std::count_if(values.begin(), values.end(), [](double v) { return v != 0.0; }));
}

std::vector<double> to_db(const std::vector<double>& p, double floor) {
  std::vector<double> v(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) v[i] = 10 * std::log10(p[i] + floor);
  return v;
}

std::vector<double> per_bin_total(const SpectralSummary& s) {
  std::vector<double> v(s.input_lines.size());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = s.input_lines[i] + s.broadband[i];
  return v;
}

/// The 1 − (own families' distance after / before) of a candidate; 0 when they had no distance.
double shrinkage(const std::vector<FamilyGap>& before, const std::vector<FamilyGap>& after,
                 const std::vector<FamilyKind>& own) {
  const double own_before = families_distance_db(before, own);
  return own_before > 0 ? 1.0 - families_distance_db(after, own) / own_before : 0.0;
}

bool any_significant(const std::vector<FamilyGap>& gaps) {
  return std::any_of(gaps.begin(), gaps.end(), [](const FamilyGap& g) { return g.significant; });
}

/// Settings and sets a diagnosis cannot run with, refused before any work.
void validate(const std::vector<DiagnosisInput>& training, const std::vector<DiagnosisInput>& held_out,
              const DiagnosisSettings& settings) {
  if (training.empty()) throw std::invalid_argument("gap diagnosis needs training records: none given");
  if (held_out.empty()) throw std::invalid_argument("gap diagnosis needs held-out records: none given");
  if (settings.bootstrap_resamples < 10) throw std::invalid_argument("gap diagnosis needs >= 10 bootstrap resamples");
  if (!(settings.twin_min_seconds > 0) || !std::isfinite(settings.twin_min_seconds) ||
      !(settings.twin_min_revolutions >= 0) || !std::isfinite(settings.twin_min_revolutions))
    throw std::invalid_argument(
        "gap diagnosis: twin_min_seconds must be finite and > 0, twin_min_revolutions finite and >= 0");
  if (settings.reference_k_wear) {
    if (!(*settings.reference_k_wear > 0) || !std::isfinite(*settings.reference_k_wear))
      throw std::invalid_argument("gap diagnosis: reference_k_wear must be finite and > 0");
    if (!std::isfinite(settings.rms_sa_wear_elasticity) || settings.rms_sa_wear_elasticity == 0)
      throw std::invalid_argument("gap diagnosis: rms_sa_wear_elasticity must be finite and non-zero");
    if (settings.rms_sa_harmonics < 1) throw std::invalid_argument("gap diagnosis: rms_sa_harmonics must be >= 1");
    if (!settings.rms_sa_wear_elasticities.empty() && settings.rms_sa_wear_elasticities.size() != held_out.size())
      throw std::invalid_argument("gap diagnosis: rms_sa_wear_elasticities needs one value per held-out record (" +
                                  std::to_string(held_out.size()) + "), got " +
                                  std::to_string(settings.rms_sa_wear_elasticities.size()));
    for (double e : settings.rms_sa_wear_elasticities)
      if (!std::isfinite(e)) throw std::invalid_argument("gap diagnosis: every rms_sa_wear_elasticities value must be finite");
  }
}

twin::GearboxMatrices assemble_twin(const DiagnosisSettings& settings) {
  try {
    return twin::assemble(settings.twin_parameters);
  } catch (const twin::TwinParameterError& e) {
    throw std::invalid_argument(std::string("gap diagnosis: the twin's parameters: ") + e.what());
  }
}

/// One diagnosis (diagnosis.hpp), its steps in run()'s order: the records reduced to spectra, the
/// held-out gaps against the twin alone, the dynamic candidates' reruns, each candidate alone, the
/// greedy attribution, the gaps after it, K_wear and the plots. Lives for one diagnose() call.
class Diagnosis {
 public:
  Diagnosis(const std::vector<DiagnosisInput>& training, const std::vector<DiagnosisInput>& held_out,
            const GearPairSpec& gears, const DiagnosisSettings& settings)
      : training_(training), held_out_(held_out), gears_(gears), settings_(settings),
        evaluator_(gears, settings.fixed_bands_per_octave), bootstrap_(settings) {}

  GapReport run() {
    prepare();
    summarise_records();
    compare();
    build_reruns();
    rank_alone();
    rescore_eccentricity();
    for (auto& r : ranked_) report_.candidates.push_back(std::move(r.second));
    attribute();
    assess_after();
    infer_k_wear();
    plot_spectra();
    plot_bands();
    return std::move(report_);
  }

 private:
  /// A candidate on top of the chosen ones, scored held out without a bootstrap.
  struct Addition {
    AppliedEffect effect;
    std::optional<std::size_t> grid;  // a rerun candidate's grid point
    double ic = 0, shrink = 0;
    bool worsens = false;
    std::vector<FamilyGap> gaps;
    // The held-out models it was scored with (the twin it acts on, the chosen effects and it): what
    // accept() keeps for the features' attribution, not computed a second time.
    std::vector<SpectralSummary> models;
  };
  /// A candidate alone, fitted on training, with its held-out assessment.
  struct AloneFit {
    Assessment held_out;
    std::vector<double> values;
  };
  using Ranked = std::pair<double, CandidateScore>;
  static bool by_ic(const Ranked& a, const Ranked& b) { return a.first < b.first; }

  /// Both sets reduced to spectra against the twin, with the casing form's path up to the records'
  /// band (one table for every record and re-run).
  void prepare() {
    const twin::GearboxMatrices twin_matrices = assemble_twin(settings_);
    double top_hz = 0;
    for (const auto* set : {&training_, &held_out_})
      for (const auto& in : *set) top_hz = std::max(top_hz, 0.5 * in.twin.sample_rate_hz);
    const auto bearing_path = bearing_force_path(twin_matrices, std::max(top_hz, 2.0));
    train_ = reduce(training_, gears_, settings_, twin_matrices, bearing_path, "training");
    test_ = reduce(held_out_, gears_, settings_, twin_matrices, bearing_path, "held-out");
    for (const auto& p : train_) train_pairs_.push_back({p.measured_all, p.twin_all, p.floor});
    fs_ = test_.front().measured_all.sample_rate_hz;
  }

  void summarise_records() {
    report_.training_records = train_.size();
    report_.held_out_records = test_.size();
    std::set<double> speeds;
    for (const auto* set : {&training_, &held_out_})
      for (const auto& in : *set)
        if (in.measured.input_revolutions)
          report_.input_revolutions = std::max(report_.input_revolutions, *in.measured.input_revolutions);
    for (const auto* set : {&train_, &test_})
      for (const auto& p : *set) speeds.insert(std::round(p.measured_all.speed_hz * 100) / 100);
    report_.speeds_hz.assign(speeds.begin(), speeds.end());
  }

  /// The held-out gaps against the twin alone, their estimation noise, and the features.
  void compare() {
    fixed_reason_ = evaluator_.fixed_frequency_reason(views(test_, models_of(test_, {}, gears_)));
    noise_ = noise_distance(test_, settings_, evaluator_, bootstrap_);
    before_ = assess(test_, {}, gears_, settings_.bootstrap_resamples, evaluator_, bootstrap_);
    report_.before = family_gaps(before_, noise_, settings_, fixed_reason_);
    ic_before_ = information_criterion(before_.point, noise_, 0, settings_);
    if (settings_.find_features) report_.features = find_features(train_, test_, gears_, settings_, bootstrap_);
    any_significant_ = any_significant(report_.before);
  }

  /// Candidates that change the twin's dynamics: the twin re-run over their grid, when the caller
  /// can re-run it. Only when some family is significant: the reruns cost a twin simulation per
  /// record and grid value, and without a significant family nothing is chosen (the ranking then
  /// scores such a candidate by its spectral form).
  void build_reruns() {
    if (!settings_.attribute || !settings_.rerun_twin || !any_significant_) return;
    for (CandidateEffect c : kAllCandidateEffects) {
      const auto grid = rerun_grid(c);
      if (grid.empty()) continue;
      RerunSet set;
      set.effect = c;
      for (const auto& v : grid) add_rerun_point(set, v);
      reruns_.emplace(c, std::move(set));
    }
  }

  /// The training records with the twin re-run at `v`, added to the set (or the point it has already).
  std::size_t add_rerun_point(RerunSet& set, const std::vector<double>& v) {
    for (std::size_t i = 0; i < set.values.size(); ++i)
      if (set.values[i] == v) return i;
    std::vector<SummaryPair> tr;
    for (std::size_t i = 0; i < train_.size(); ++i) {
      const Record& like = training_[i].twin;
      const auto p = with_rerun_twin(train_[i], settings_.rerun_twin(set.effect, v, like, twin_duration_s(like, settings_)),
                                     gears_, settings_);
      tr.push_back({p.measured_all, p.twin_all, p.floor});
    }
    set.values.push_back(v);
    set.train.push_back(std::move(tr));
    set.test.emplace_back();
    return set.values.size() - 1;
  }

  /// The held-out records with the twin re-run at grid value g.
  const std::vector<PairSpectra>& rerun_test(RerunSet& set, std::size_t g) {
    if (!set.test[g]) {
      std::vector<PairSpectra> te;
      for (std::size_t i = 0; i < test_.size(); ++i) {
        const Record& like = held_out_[i].twin;
        te.push_back(with_rerun_twin(
            test_[i], settings_.rerun_twin(set.effect, set.values[g], like, twin_duration_s(like, settings_)), gears_,
            settings_));
      }
      set.test[g] = std::move(te);
    }
    return *set.test[g];
  }

  /// The grid value whose rerun twin, with the spectral effects `fx` on top, fits the training records best.
  std::size_t best_rerun(const RerunSet& set, const std::vector<AppliedEffect>& fx) const {
    std::size_t best = 0;
    double best_cost = std::numeric_limits<double>::infinity();
    for (std::size_t g = 0; g < set.values.size(); ++g) {
      const double cost = training_cost(set.train[g], fx, gears_);
      if (cost < best_cost) best_cost = cost, best = g;
    }
    return best;
  }

  /// A chosen rerun candidate's grid value refined on the training records: a compass search in half
  /// and then quarter grid steps (in the log), inside the grid's range. A whole step (×1.8 in angle,
  /// ×2 in relief) moves the first mesh harmonics by a few dB, and K_wear's inference from them
  /// magnifies that; the refinement costs a few reruns of the training records, for one candidate.
  std::size_t refine_rerun(RerunSet& set, std::size_t start, const std::vector<AppliedEffect>& fx) {
    const auto grid = rerun_grid(set.effect);
    const auto ratios = rerun_grid_ratios(set.effect);
    std::vector<double> low = grid.front(), high = grid.front();  // the grid's range along each parameter
    for (const auto& g : grid)
      for (std::size_t j = 0; j < g.size(); ++j) low[j] = std::min(low[j], g[j]), high[j] = std::max(high[j], g[j]);
    std::size_t best = start;
    double best_cost = training_cost(set.train[start], fx, gears_);
    for (double fraction : {0.5, 0.25})
      for (std::size_t j = 0; j < ratios.size(); ++j)
        for (double direction : {-1.0, 1.0}) {
          auto v = set.values[best];
          v[j] = std::clamp(v[j] * std::pow(ratios[j], direction * fraction), low[j], high[j]);
          const std::size_t point = add_rerun_point(set, v);
          const double cost = training_cost(set.train[point], fx, gears_);
          if (cost < best_cost) best_cost = cost, best = point;
        }
    return best;
  }

  /// Held out, a family outside the candidate's own above its interval before any effect, and by more
  /// than 0.5 dB: a candidate that does this while it shrinks its own families is flagged, and it is
  /// not chosen (an effect that makes the twin worse elsewhere is not the cause; its families stay
  /// unexplained).
  bool worsens_other_family(const std::vector<FamilyGap>& after, const std::vector<FamilyKind>& own) const {
    for (std::size_t f = 0; f < kFamilies && f < after.size(); ++f) {
      const auto& b = report_.before[f];
      if (std::find(own.begin(), own.end(), b.family) != own.end() || !b.resolved) continue;
      if (after[f].distance_db > b.distance_interval_db.high && after[f].distance_db > b.distance_db + 0.5) return true;
    }
    return false;
  }

  /// Each candidate alone on the twin: fitted on training, scored held out.
  void rank_alone() {
    if (settings_.attribute)
      for (CandidateEffect c : kAllCandidateEffects) ranked_.push_back(score_alone(c));
    std::stable_sort(ranked_.begin(), ranked_.end(), by_ic);
  }

  Ranked score_alone(CandidateEffect c) {
    const auto form = candidate_form(c, fs_);
    CandidateScore score;
    score.effect = c;
    const auto r = reruns_.find(c);
    const AloneFit fit = r != reruns_.end() ? fit_rerun_alone(r->second, score) : fit_spectral_alone(c, form, score);
    score.explains = form.explains;
    score.held_out_after = family_gaps(fit.held_out, noise_, settings_, fixed_reason_);
    score.shrinkage = shrinkage(report_.before, score.held_out_after, form.explains);
    score.information_criterion = information_criterion(fit.held_out.point, noise_, fitted_count(fit.values), settings_);
    score.worsens_other_family = score.shrinkage > 0 && worsens_other_family(score.held_out_after, form.explains);
    return std::make_pair(score.information_criterion, std::move(score));
  }

  /// A rerun candidate alone: the grid point that fits the training records best.
  AloneFit fit_rerun_alone(RerunSet& set, CandidateScore& score) {
    const CandidateEffect c = set.effect;
    AloneFit fit;
    const std::size_t g = best_rerun(set, {});
    alone_grid_[c] = g;
    fit.values = set.values[g];
    fit.held_out = assess(rerun_test(set, g), {}, gears_, settings_.candidate_bootstrap_resamples, evaluator_, bootstrap_);
    const auto names = rerun_parameter_names(c);
    for (std::size_t i = 0; i < fit.values.size(); ++i) score.parameters.emplace_back(names.at(i), fit.values[i]);
    score.at_bounds = parameters_at_bounds(c, fit.values, fs_, true);
    return fit;
  }

  /// A spectral candidate alone: its form fitted to the training records.
  AloneFit fit_spectral_alone(CandidateEffect c, const CandidateForm& form, CandidateScore& score) {
    AloneFit fit;
    fit.values = fit_candidate(c, {}, train_pairs_, gears_);
    alone_[c] = fit.values;
    fit.held_out = assess(test_, {{c, fit.values}}, gears_, settings_.candidate_bootstrap_resamples, evaluator_, bootstrap_);
    const auto names = parameter_names(form, fit.values);
    for (std::size_t i = 0; i < fit.values.size(); ++i) score.parameters.emplace_back(names[i], fit.values[i]);
    score.at_bounds = parameters_at_bounds(c, fit.values, fs_, false);
    return fit;
  }

  /// The run-out through the twin. The power form gives a pair of first sidebands their mean; the
  /// twin with a run-out gives each line its own (AM and PM out of phase through the time-varying
  /// mesh, several dB apart on the rig's). When the power form ranks eccentricity among the two best
  /// and the twin can be re-run, each record's twin is re-run 4 times (run_out_response_reruns; a 5th
  /// without a run-out when the counterpart is longer than a rerun) for its lines' response, and the
  /// form is fitted again with it.
  void rescore_eccentricity() {
    const auto rank = std::find_if(ranked_.begin(), ranked_.end(), [](const Ranked& r) {
      return r.second.effect == CandidateEffect::eccentricity;
    });
    if (!settings_.rerun_twin || !any_significant_ || rank == ranked_.end() || rank - ranked_.begin() >= 2) return;
    const auto runs = run_out_response_reruns();
    attach_run_out_response(train_, training_, runs);
    attach_run_out_response(test_, held_out_, runs);
    for (std::size_t i = 0; i < train_.size(); ++i) train_pairs_[i].twin = train_[i].twin_all;
    ranked_.erase(rank);
    ranked_.push_back(score_alone(CandidateEffect::eccentricity));
    std::stable_sort(ranked_.begin(), ranked_.end(), by_ic);
  }

  void attach_run_out_response(std::vector<PairSpectra>& pairs, const std::vector<DiagnosisInput>& inputs,
                               const std::array<std::vector<double>, 5>& runs) const {
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      const Record& like = inputs[i].twin;
      const int channel = std::min<int>(settings_.channel, static_cast<int>(like.channels.size()) - 1);
      const double duration = twin_duration_s(like, settings_);
      std::vector<RecordSpectra> spectra;
      // The twin without a run-out is the counterpart itself when that is as long as a rerun.
      const bool counterpart_is_base = like.duration_s() <= duration;
      for (std::size_t r = counterpart_is_base ? 1 : 0; r < runs.size(); ++r)
        spectra.emplace_back(settings_.rerun_twin(CandidateEffect::eccentricity, runs[r], like, duration), channel, gears_,
                             settings_.min_revolutions);
      const std::size_t u = counterpart_is_base ? 0 : 1;
      const RecordSpectra& base = counterpart_is_base ? pairs[i].twin : spectra[0];
      const auto response =
          run_out_response(base, {&spectra[u], &spectra[u + 1], &spectra[u + 2], &spectra[u + 3]}, kRunOutResponseUnitM);
      // Bootstrap draws take it from the spectra; the full summary gets it as it is.
      pairs[i].twin.set_run_out_response(response);
      pairs[i].twin_all.run_out_response = response;
    }
  }

  /// The family gaps of one held-out evaluation without a bootstrap (its interval is the point).
  std::vector<FamilyGap> point_gaps(const GapEvaluation& e) const {
    Assessment a;
    a.point = e;
    for (std::size_t f = 0; f < kFamilies; ++f) a.interval[f] = {e.distance_db(f), e.distance_db(f)};
    return family_gaps(a, noise_, settings_, fixed_reason_);
  }

  /// Greedy addition: the best candidate on top of the ones chosen so far, while it pays. A chosen
  /// rerun candidate replaces the twin the later ones act on (one rerun at a time).
  void attribute() {
    ic_current_ = ic_before_;
    current_gaps_ = report_.before;
    if (!any_significant_ || !settings_.attribute) return;
    for (int round = 0; round < settings_.max_effects; ++round) {
      auto best = best_addition(round);
      if (!best || best->ic > ic_current_ - settings_.accept_ic_drop || best->shrink < settings_.min_shrinkage ||
          best->worsens)
        break;
      accept(std::move(*best));
      if (!any_significant(current_gaps_)) break;
    }
  }

  /// The lowest held-out IC among the candidates that act on a significant family is the
  /// attribution; it is added only if it pays (IC drop) and shrinks its own families. When it
  /// does not, no lesser candidate is tried in its place: the families stay unexplained.
  std::optional<Addition> best_addition(int round) {
    std::optional<Addition> best;
    for (CandidateEffect c : kAllCandidateEffects) {
      if (std::find(report_.chosen.begin(), report_.chosen.end(), c) != report_.chosen.end()) continue;
      const auto form = candidate_form(c, fs_);
      if (reruns_.count(c) && rerun_chosen_) continue;
      Addition a = try_addition(c, form, round);
      const double best_ic = best ? best->ic : std::numeric_limits<double>::infinity();
      if (explains_significant(form.explains) && a.ic < best_ic && !fitted_beyond_its_physics(c, a.effect.values, fs_)) {
        a.worsens = worsens_other_family(a.gaps, form.explains);
        best = std::move(a);
      }
    }
    return best;
  }

  /// Candidate `c` on top of the chosen ones: fitted on training, scored held out.
  Addition try_addition(CandidateEffect c, const CandidateForm& form, int round) {
    Addition a{{c, {}}, std::nullopt, 0, 0, false, {}, {}};
    auto& models = a.models;
    if (const auto r = reruns_.find(c); r != reruns_.end()) {
      a.grid = chosen_.empty() ? alone_grid_[c] : best_rerun(r->second, chosen_);
      a.effect.values = r->second.values[*a.grid];
      models = models_of(rerun_test(r->second, *a.grid), chosen_, gears_);
    } else {
      a.effect.values = round == 0 ? alone_[c] : fit_candidate(c, chosen_, *train_base_, gears_);
      auto fx = chosen_;
      fx.push_back(a.effect);
      models = models_of(*test_base_, fx, gears_);
    }
    const auto e = evaluator_.evaluate(views(*test_base_, models), true);
    a.ic = information_criterion(e, noise_, fitted_count(a.effect.values), settings_);
    a.gaps = point_gaps(e);
    a.shrink = shrinkage(current_gaps_, a.gaps, form.explains);
    return a;
  }

  bool explains_significant(const std::vector<FamilyKind>& explains) const {
    return std::any_of(current_gaps_.begin(), current_gaps_.end(), [&](const FamilyGap& g) {
      return g.significant && std::find(explains.begin(), explains.end(), g.family) != explains.end();
    });
  }

  void accept(Addition best) {
    report_.chosen.push_back(best.effect.effect);
    if (best.grid)
      accept_rerun(best);
    else
      chosen_.push_back(best.effect);
    ic_current_ = best.ic;
    current_gaps_ = std::move(best.gaps);
    // The held-out models with the effects chosen so far, for the features' attribution: the ones
    // the addition was scored with (on the twin it now acts on, with the same effects).
    step_models_.push_back(std::move(best.models));
    std::vector<SpectralSummary> train_models;
    for (const auto& p : *train_base_) train_models.push_back(apply_effects(chosen_, p.twin, gears_));
    step_train_models_.push_back(std::move(train_models));
  }

  /// A chosen rerun candidate, refined; the later candidates act on its twin.
  void accept_rerun(Addition& best) {
    auto& set = reruns_.at(best.effect.effect);
    const std::size_t refined = refine_rerun(set, *best.grid, chosen_);
    if (refined != *best.grid) {
      best.grid = refined;
      const auto& refined_test = rerun_test(set, refined);
      best.models = models_of(refined_test, chosen_, gears_);
      const auto e = evaluator_.evaluate(views(refined_test, best.models), true);
      best.ic = information_criterion(e, noise_, fitted_count(set.values[refined]), settings_);
      best.gaps = point_gaps(e);
      update_parameters(best.effect.effect, set.values[refined]);
    }
    test_base_ = &rerun_test(set, *best.grid);
    train_base_ = &set.train[*best.grid];
    rerun_chosen_ = true;
  }

  /// The candidate's reported parameters after a refinement.
  void update_parameters(CandidateEffect effect, const std::vector<double>& values) {
    for (auto& candidate : report_.candidates)
      if (candidate.effect == effect) {
        for (std::size_t i = 0; i < candidate.parameters.size() && i < values.size(); ++i)
          candidate.parameters[i].second = values[i];
        candidate.at_bounds = parameters_at_bounds(effect, values, fs_, true);
      }
  }

  /// The held-out gaps with the chosen effects, what stays unexplained, and the features' candidates.
  void assess_after() {
    const auto after = assess(*test_base_, chosen_, gears_, settings_.bootstrap_resamples, evaluator_, bootstrap_);
    report_.after = family_gaps(after, noise_, settings_, fixed_reason_);
    for (const auto& g : report_.after)
      if (g.significant) report_.unexplained.push_back(g.family);
    attribute_features();
  }

  /// Each feature's candidate (attribution.hpp): the chosen one whose addition removes its held-out gap.
  void attribute_features() {
    std::vector<RecordModels> held_out, training;
    for (std::size_t i = 0; i < test_.size(); ++i) {
      RecordModels h{&test_[i].measured_all, &test_[i].twin_all, {}, test_[i].floor};
      for (const auto& step : step_models_) h.with_chosen.push_back(&step[i]);
      held_out.push_back(std::move(h));
    }
    for (std::size_t i = 0; i < train_.size(); ++i) {
      RecordModels t{&train_[i].measured_all, &train_[i].twin_all, {}, train_[i].floor};
      for (const auto& step : step_train_models_) t.with_chosen.push_back(&step[i]);
      training.push_back(std::move(t));
    }
    for (auto& f : report_.features) {
      f.explained_by = explaining_candidate(f, held_out, training, report_.chosen, gears_, settings_.features.min_feature_db);
      if (!f.explained_by) f.explained_by = family_explaining_candidate(report_, f, gears_);
      if (!f.explained_by && settings_.attribute) explain_by_casing_mode(f, held_out, training);
    }
  }

  /// A resonance fixed in Hz (or seen at one speed) that no chosen candidate explains: one casing
  /// mode fitted on its own training cells, judged on its held-out ones (attribution.hpp). Its
  /// parameters join the description, so the report says which mode.
  void explain_by_casing_mode(GapFeature& f, const std::vector<RecordModels>& held_out, const std::vector<RecordModels>& training) {
    if (f.description.kind != DescriptionKind::resonance ||
        (f.movement != FeatureMovement::fixed_in_hz && f.movement != FeatureMovement::undetermined))
      return;
    const auto fit = casing_mode_for_resonance(f, held_out, training, gears_, settings_.features);
    if (!fit || !fit->explains) return;
    f.explained_by = CandidateEffect::casing_mode;
    f.description.parameters.emplace_back("casing_mode_hz", fit->mode_hz);
    f.description.parameters.emplace_back("casing_damping_ratio", fit->damping_ratio);
    f.description.parameters.emplace_back("casing_modal_mass_kg", fit->modal_mass_kg);
    f.description.parameters.emplace_back("casing_residue_phase_deg", fit->residue_phase_rad * 180.0 / std::numbers::pi);
  }

  /// K_wear is what makes the twin's RMS_SA equal the measured one, so whatever the twin lacks on the
  /// mesh harmonics is absorbed into it; with the chosen effects added the twin's RMS_SA changes and
  /// so does the K inferred. Records at different speeds differ in level, so their ratios are pooled
  /// in the log (geometric mean), not their energies. Least squares in the log:
  /// ln r_i = e_i ln(K/K_ref) (one elasticity for all: the mean log ratio / e).
  void infer_k_wear() {
    if (!settings_.reference_k_wear) return;
    auto rms_sa = [&](const SpectralSummary& s) { return rms_sa_of_lines(s, gears_.pinion_teeth, settings_.rms_sa_harmonics); };
    double num_before = 0, num_after = 0, den = 0;
    for (std::size_t i = 0; i < test_.size(); ++i) {
      const auto& p = test_[i];
      const auto meas = rms_sa(p.measured_all), twin = rms_sa(p.twin_all),
                 with_fx = rms_sa(apply_effects(chosen_, (*test_base_)[i].twin_all, gears_));
      if (!meas || !twin || !with_fx) continue;
      const double e = settings_.rms_sa_wear_elasticities.empty() ? settings_.rms_sa_wear_elasticity
                                                                  : settings_.rms_sa_wear_elasticities[i];
      if (std::abs(e) < settings_.min_rms_sa_wear_elasticity) continue;
      num_before += e * std::log(*meas / *twin);
      num_after += e * std::log(*meas / *with_fx);
      den += e * e;
    }
    if (den > 0) {
      const double k_ref = *settings_.reference_k_wear;
      report_.k_wear_before = inferred_k_wear(std::exp(num_before / den), 1.0, k_ref, 1.0);
      report_.k_wear_after = inferred_k_wear(std::exp(num_after / den), 1.0, k_ref, 1.0);
    }
  }

  /// Plots: the first held-out record's spectra, measured, twin and twin with the chosen effects.
  void plot_spectra() {
    const auto& p = test_.front();
    const auto twin_after = apply_effects(chosen_, test_base_->front().twin_all, gears_);
    const std::size_t k = std::min(p.measured_all.input_lines.size(), p.twin_all.input_lines.size());
    for (std::size_t i = 0; i < k; ++i) {
      report_.order_axis.push_back(static_cast<double>(i + 1));
      report_.hz_axis.push_back(static_cast<double>(i + 1) * p.measured_all.speed_hz);
    }
    auto cut = [&](std::vector<double> v) {
      v.resize(k);
      return v;
    };
    report_.measured_order_db = cut(to_db(p.measured_all.input_lines, p.floor));
    report_.twin_order_db = cut(to_db(p.twin_all.input_lines, p.floor));
    report_.twin_after_order_db = cut(to_db(twin_after.input_lines, p.floor));
    report_.measured_hz_db = cut(to_db(per_bin_total(p.measured_all), p.floor));
    report_.twin_hz_db = cut(to_db(per_bin_total(p.twin_all), p.floor));
    report_.twin_after_hz_db = cut(to_db(per_bin_total(twin_after), p.floor));
  }

  /// The plots' family bands: shaft orders, sidebands and mesh harmonics along the order axis, the
  /// fixed-frequency bands with a gap along the Hz axis.
  void plot_bands() {
    const int k = static_cast<int>(report_.order_axis.size());
    const int z1 = gears_.pinion_teeth;
    const int m = kSidebandOrders;
    double shaft_from = 0.5;
    for (int n = 1; n * z1 <= k && n <= 10; ++n) {
      report_.order_bands.push_back({FamilyKind::input_shaft_orders, {shaft_from, n * z1 - m - 0.5}});
      report_.order_bands.push_back({FamilyKind::input_sidebands, {n * z1 - m - 0.5, n * z1 - 0.5}});
      report_.order_bands.push_back({FamilyKind::mesh_harmonics, {n * z1 - 0.5, n * z1 + 0.5}});
      report_.order_bands.push_back({FamilyKind::input_sidebands, {n * z1 + 0.5, n * z1 + m + 0.5}});
      shaft_from = n * z1 + m + 0.5;
    }
    for (const auto& band : before_.point.fixed_bands)
      if (std::abs(band.gain_db) >= min_gap_db_of(settings_, FamilyKind::fixed_frequency))
        report_.hz_bands.push_back({FamilyKind::fixed_frequency, {band.low_hz, band.high_hz}});
  }

  const std::vector<DiagnosisInput>& training_;
  const std::vector<DiagnosisInput>& held_out_;
  const GearPairSpec& gears_;
  const DiagnosisSettings& settings_;
  const GapEvaluator evaluator_;
  BootstrapSummaries bootstrap_;
  GapReport report_;
  std::vector<PairSpectra> train_, test_;  // the records reduced; a run-out response attached later
  std::vector<SummaryPair> train_pairs_;   // the training records' full summaries, for the fits
  double fs_ = 0;                          // the held-out records' sample rate
  std::string fixed_reason_;
  std::array<double, kFamilies> noise_{};
  Assessment before_;
  double ic_before_ = 0;
  bool any_significant_ = false;
  std::map<CandidateEffect, RerunSet> reruns_;
  std::vector<Ranked> ranked_;
  std::map<CandidateEffect, std::vector<double>> alone_;  // the spectral candidates' values alone
  std::map<CandidateEffect, std::size_t> alone_grid_;     // the rerun candidates' grid point alone
  // The greedy attribution's state: the spectral effects chosen (applied to the base twin), the
  // twin they act on (a chosen rerun's), its IC and gaps so far.
  std::vector<AppliedEffect> chosen_;
  const std::vector<PairSpectra>* test_base_ = &test_;
  const std::vector<SummaryPair>* train_base_ = &train_pairs_;
  bool rerun_chosen_ = false;
  double ic_current_ = 0;
  std::vector<FamilyGap> current_gaps_;
  std::vector<std::vector<SpectralSummary>> step_models_;  // [step][held-out record]: twin + the first step + 1 chosen
  std::vector<std::vector<SpectralSummary>> step_train_models_;  // the same for the training records
};

}  // namespace

GapReport diagnose(const std::vector<DiagnosisInput>& training, const std::vector<DiagnosisInput>& held_out,
                   const GearPairSpec& gears, const DiagnosisSettings& settings) {
  validate(training, held_out, settings);
  return Diagnosis(training, held_out, gears, settings).run();
}

double families_distance_db(const std::vector<FamilyGap>& gaps, const std::vector<FamilyKind>& families) {
  double sum = 0;
  int n = 0;
  for (const auto& g : gaps)
    if (g.resolved && std::find(families.begin(), families.end(), g.family) != families.end())
      sum += g.distance_db * g.distance_db, ++n;
  return n ? std::sqrt(sum / n) : 0.0;
}

double min_gap_db_of(const DiagnosisSettings& settings, FamilyKind family) noexcept {
  return family == FamilyKind::broadband || family == FamilyKind::fixed_frequency ? settings.min_residual_gap_db
                                                                                   : settings.min_gap_db;
}

std::optional<double> rms_sa_of_lines(const SpectralSummary& s, int pinion_teeth, int harmonics) {
  if (pinion_teeth < 1 || harmonics < 1) return std::nullopt;
  const auto z1 = static_cast<std::size_t>(pinion_teeth), n = static_cast<std::size_t>(harmonics);
  if (s.input_lines.size() < n * z1) return std::nullopt;
  double e = 0;
  for (std::size_t h = 1; h <= n; ++h) e += s.input_lines[h * z1 - 1];
  return e > 0 && std::isfinite(e) ? std::optional<double>(std::sqrt(e)) : std::nullopt;
}

std::optional<double> rms_sa_of_record(const Record& record, int channel, const GearPairSpec& gears, int harmonics) {
  return rms_sa_of_lines(RecordSpectra(record, channel, gears).summary(), gears.pinion_teeth, harmonics);
}

double rms_sa_wear_elasticity(double rms_sa_at_low_depth, double rms_sa_at_high_depth) {
  if (!(rms_sa_at_low_depth > 0) || !(rms_sa_at_high_depth > 0) || !std::isfinite(rms_sa_at_low_depth) ||
      !std::isfinite(rms_sa_at_high_depth))
    throw std::invalid_argument("rms_sa_wear_elasticity: RMS_SA values must be finite and > 0");
  return std::log(rms_sa_at_high_depth / rms_sa_at_low_depth) / std::log(kElasticityDepthHigh / kElasticityDepthLow);
}

double twin_duration_s(const Record& record, const DiagnosisSettings& settings) {
  double cap = settings.twin_min_seconds;
  if (record.speed_hz > 0) cap = std::max(cap, settings.twin_min_revolutions / record.speed_hz);
  return std::min(record.duration_s(), cap);
}

double inferred_k_wear(double rms_sa_measured, double rms_sa_model, double reference_k_wear, double elasticity) {
  if (!(rms_sa_measured > 0) || !(rms_sa_model > 0) || !std::isfinite(rms_sa_measured) || !std::isfinite(rms_sa_model))
    throw std::invalid_argument("inferred_k_wear: RMS_SA values must be finite and > 0");
  if (!(reference_k_wear > 0) || !std::isfinite(reference_k_wear))
    throw std::invalid_argument("inferred_k_wear: reference K_wear must be finite and > 0");
  if (!std::isfinite(elasticity) || elasticity == 0)
    throw std::invalid_argument("inferred_k_wear: elasticity must be finite and non-zero");
  return reference_k_wear * std::pow(rms_sa_measured / rms_sa_model, 1.0 / elasticity);
}

}  // namespace gearwatch::gap
