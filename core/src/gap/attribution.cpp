#include "gearwatch/gap/attribution.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <tuple>
#include <utility>

#include "gearwatch/gap/binned.hpp"
#include "gearwatch/gap/candidates.hpp"

namespace gearwatch::gap {
namespace {

double ratio_db(double measured, double model, double floor) { return 10.0 * std::log10((measured + floor) / (model + floor)); }

enum class Spectrum { input_lines, output_lines, broadband };
struct FeatureCell {
  std::size_t record;
  Spectrum spectrum;
  std::size_t index;
};

const std::vector<double>& spectrum_of(const SpectralSummary& s, Spectrum which) {
  return which == Spectrum::input_lines ? s.input_lines : which == Spectrum::output_lines ? s.output_lines : s.broadband;
}

/// A cell's place in input orders, as the finder placed it: line k at k, broadband bin [k, k+1) at
/// k + ½, output line j at j·z1/z2.
double cell_order(Spectrum which, std::size_t index, const GearPairSpec& gears) {
  const double k = static_cast<double>(index);
  return which == Spectrum::input_lines ? k + 1.0
         : which == Spectrum::broadband ? k + 1.5
                                        : (k + 1.0) * (static_cast<double>(gears.pinion_teeth) / gears.gear_teeth);
}

/// Calls visit(spectrum, index, order) for every cell of a record's summary, the output shaft's mesh
/// orders left to the input side.
template <class Visit>
void for_each_cell(const SpectralSummary& s, const GearPairSpec& gears, Visit&& visit) {
  for (std::size_t i = 0; i < s.input_lines.size(); ++i) visit(Spectrum::input_lines, i, cell_order(Spectrum::input_lines, i, gears));
  for (std::size_t i = 0; i < s.broadband.size(); ++i) visit(Spectrum::broadband, i, cell_order(Spectrum::broadband, i, gears));
  for (std::size_t i = 0; i < s.output_lines.size(); ++i)
    if (!output_line_is_mesh(static_cast<int>(i + 1), gears.gear_teeth))
      visit(Spectrum::output_lines, i, cell_order(Spectrum::output_lines, i, gears));
}

bool seen_in(const GapFeature& f, bool held_out, std::size_t record) {
  return std::any_of(f.seen_in.begin(), f.seen_in.end(),
                     [&](const FeatureSighting& s) { return s.held_out == held_out && s.record == record; });
}

/// The feature's cells of the records of one set it was seen in (its extent, in Hz when fixed in Hz),
/// whose gap against the twin alone is at least the practical minimum. Cells are placed at their
/// centres as the finder placed them: line k at k, broadband bin [k, k+1) at k + ½, output line j at
/// j·z1/z2 (input orders), the mesh orders counted on the input side.
std::vector<FeatureCell> cells_of(const GapFeature& f, const std::vector<RecordModels>& records, bool held_out,
                                  const GearPairSpec& gears, double min_feature_db) {
  const double per_output = static_cast<double>(gears.pinion_teeth) / gears.gear_teeth;
  const double scale = f.shaft == FeatureShaft::output ? per_output : 1.0;
  const double low = f.order_low * scale, high = f.order_high * scale;
  const bool in_hz = f.movement == FeatureMovement::fixed_in_hz;
  std::vector<FeatureCell> cells;
  for (std::size_t r = 0; r < records.size(); ++r) {
    if (!seen_in(f, held_out, r)) continue;
    const auto& rec = records[r];
    const double speed = rec.measured->speed_hz;
    auto inside = [&](double order) {
      return in_hz ? order * speed >= f.hz_low && order * speed <= f.hz_high : order >= low && order <= high;
    };
    auto add = [&](Spectrum which, std::size_t i, double order) {
      const auto& m = spectrum_of(*rec.measured, which);
      const auto& t = spectrum_of(*rec.twin, which);
      if (i < m.size() && i < t.size() && inside(order) && std::abs(ratio_db(m[i], t[i], rec.floor)) >= min_feature_db)
        cells.push_back({r, which, i});
    };
    for_each_cell(*rec.measured, gears, add);
  }
  return cells;
}

double rms_gap_db(const std::vector<FeatureCell>& cells, const std::vector<RecordModels>& records, int step) {
  if (cells.empty()) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0;
  for (const auto& c : cells) {
    const auto& rec = records[c.record];
    const SpectralSummary& model = step < 0 ? *rec.twin : *rec.with_chosen.at(static_cast<std::size_t>(step));
    const auto& m = spectrum_of(*rec.measured, c.spectrum);
    const auto& t = spectrum_of(model, c.spectrum);
    const double g = c.index < t.size() ? ratio_db(m[c.index], t[c.index], rec.floor) : 0.0;
    sum += g * g;
  }
  return std::sqrt(sum / static_cast<double>(cells.size()));
}

}  // namespace

double feature_gap_db(const GapFeature& feature, const std::vector<RecordModels>& records, bool held_out, int step,
                      const GearPairSpec& gears, double min_feature_db) {
  return rms_gap_db(cells_of(feature, records, held_out, gears, min_feature_db), records, step);
}

std::optional<CandidateEffect> explaining_candidate(const GapFeature& f, const std::vector<RecordModels>& held_out,
                                                    const std::vector<RecordModels>& training,
                                                    const std::vector<CandidateEffect>& chosen, const GearPairSpec& gears,
                                                    double min_feature_db) {
  // A floor change that added white noise explains on its own bands (white_floor_psd) is the noise
  // floor's, chosen or not: its family's RMS over the whole band rarely reaches significance.
  if (f.description.kind == DescriptionKind::floor_change && std::isfinite(f.description.parameter("white_psd_m2_s4_per_hz")))
    return CandidateEffect::noise_floor;
  auto cells = cells_of(f, held_out, true, gears, min_feature_db);
  const bool shown_held_out = !cells.empty();
  if (!shown_held_out) cells = cells_of(f, training, false, gears, min_feature_db);
  const auto& records = shown_held_out ? held_out : training;
  for (std::size_t k = 0; k < chosen.size() && !cells.empty(); ++k)
    if (rms_gap_db(cells, records, static_cast<int>(k)) < min_feature_db) return chosen[k];
  return std::nullopt;
}

namespace {

/// One line or bin near a resonance feature: its frequency, the measured and twin powers, the floor
/// F and the bearing-force path (what casing_mode's gain needs). A broadband bin also gives where
/// its first half-order Hann bin sits and their spacing: it reads the gain averaged over them.
struct WindowCell {
  double hz, measured, twin, floor;
  std::complex<double> path;           ///< at hz
  const BearingForcePath* path_table;  ///< at any Hz, for a bin's average
  double first_half_bin_hz = 0, half_bin_hz = 0;  ///< a bin's half-order bins; 0: a line
};

/// A cell of `rec` as a WindowCell (a broadband bin [k, k+1) orders: its half-order bins at k and k + ½).
WindowCell window_cell(const RecordModels& rec, Spectrum which, std::size_t i, double hz, const BearingForcePath& path) {
  WindowCell c{hz, spectrum_of(*rec.measured, which)[i], spectrum_of(*rec.twin, which)[i], rec.floor, path.at(hz), &path};
  if (which == Spectrum::broadband) {
    const double speed = rec.measured->speed_hz;
    c.first_half_bin_hz = (static_cast<double>(i) + 1.0) * speed, c.half_bin_hz = 0.5 * speed;
  }
  return c;
}

/// Every line and bin of `records` between lo_hz and hi_hz (output mesh lines counted on the input side).
std::vector<WindowCell> window_cells(const std::vector<RecordModels>& records, double lo_hz, double hi_hz, const GearPairSpec& gears) {
  std::vector<WindowCell> cells;
  for (const auto& rec : records) {
    const BearingForcePath* path = rec.twin->bearing_force_path.get();
    if (path == nullptr) continue;
    const double speed = rec.measured->speed_hz;
    auto add = [&](Spectrum which, std::size_t i, double order) {
      const double hz = order * speed;
      const auto& m = spectrum_of(*rec.measured, which);
      const auto& t = spectrum_of(*rec.twin, which);
      if (hz >= lo_hz && hz <= hi_hz && i < m.size() && i < t.size()) cells.push_back(window_cell(rec, which, i, hz, *path));
    };
    for_each_cell(*rec.measured, gears, add);
  }
  return cells;
}

/// One casing mode (f_n, ζ, modal mass m, the phase of its residue at the sensor): casing_mode's
/// form with both its modes at f_n, which is one mode of half their mass.
struct OneMode {
  double hz, zeta, mass, phase;
};

/// A mode's power gain, its constants computed once per mode.
class OneModeGain {
 public:
  explicit OneModeGain(const OneMode& m) : mode_(m), term_(m.hz, m.zeta, m.mass, m.phase) {}
  double at(std::complex<double> path, double f_hz) const { return std::norm(1.0 + term_(path, f_hz)); }
  /// A line's gain at its frequency; a bin's averaged over its half-order bins (binned.hpp).
  double operator()(const WindowCell& c) const {
    if (c.half_bin_hz == 0) return at(c.path, c.hz);
    return binned_average(c.first_half_bin_hz, c.half_bin_hz, mode_.hz, mode_.zeta,
                          [&](double f) { return at(c.path_table->at(f), f); });
  }

 private:
  OneMode mode_;
  CasingModeTerm term_;
};

/// How a mode is read on a bin: at the bin's centre (the grid's coarse look) or averaged over its
/// half-order bins (what the bin holds).
enum class BinReading { at_centre, averaged };

/// The sum of squared g over `cells`, the twin times the mode's gain (none: the twin alone).
double squared_gaps(const std::vector<WindowCell>& cells, const OneModeGain* mode, BinReading reading) {
  double sum = 0;
  for (const auto& c : cells) {
    const double gain = mode == nullptr ? 1.0 : reading == BinReading::averaged ? (*mode)(c) : mode->at(c.path, c.hz);
    const double g = ratio_db(c.measured, c.twin * gain, c.floor);
    sum += g * g;
  }
  return sum;
}

/// The sum of squared g over `cells` with the mode.
double misfit(const std::vector<WindowCell>& cells, const OneMode& mode, BinReading reading) {
  const OneModeGain gain(mode);
  return squared_gaps(cells, &gain, reading);
}

/// The one mode's damping ratios: casing_mode's range, down to a steel casing's material damping.
/// A mode whose peak is narrower than its lines' spacing is as narrow as the structure makes it.
CandidateParameter one_mode_damping(const CandidateForm& form) {
  constexpr double kLowestDampingRatio = 0.0005;
  CandidateParameter zeta = form.parameters[2];
  zeta.low = std::min(kLowestDampingRatio, zeta.low);
  return zeta;
}

/// The box a mode is searched in.
struct ModeBounds {
  double lo_hz, hi_hz, zeta_low, zeta_high, mass_low, mass_high;
};

/// Phases of the residue a grid tries: a mode's residue at the sensor is complex where the casing's
/// damping is not proportional to its mass and stiffness (bolted joints, covers), so its peak need not
/// stand where the bearing-force path's own phase puts it.
constexpr int kResiduePhases = 8;
double residue_phase(int i) { return 2.0 * std::numbers::pi * i / kResiduePhases; }

/// `m` with f_n, ζ and the mass in the box.
OneMode clamped(OneMode m, const ModeBounds& box) {
  m.hz = std::clamp(m.hz, box.lo_hz, box.hi_hz);
  m.zeta = std::clamp(m.zeta, box.zeta_low, box.zeta_high);
  m.mass = std::clamp(m.mass, box.mass_low, box.mass_high);
  return m;
}

/// `mode` moved along coordinate k (the logs of f_n, ζ and m; the residue's phase) by `delta`, in its box.
OneMode moved(OneMode m, std::size_t k, double delta, const ModeBounds& box) {
  if (k == 3) return m.phase += delta, m;
  double& v = k == 0 ? m.hz : k == 1 ? m.zeta : m.mass;
  v *= std::exp(delta);
  return clamped(m, box);
}

/// A compass search in the logs of f_n, ζ and m and in the residue's phase from `start`, halving its
/// steps, on cost(mode).
template <class Cost>
OneMode compass(Cost&& cost, OneMode best, std::array<double, 4> step, const ModeBounds& box) {
  double best_cost = cost(best);
  for (int halving = 0; halving < 24; ++halving) {
    bool moved_once = true;
    while (moved_once) {
      moved_once = false;
      for (std::size_t k = 0; k < step.size(); ++k)
        for (double sign : {-1.0, 1.0}) {
          const OneMode m = moved(best, k, sign * step[k], box);
          const double c = cost(m);
          if (c < best_cost - 1e-12 * (1 + best_cost)) best_cost = c, best = m, moved_once = true;
        }
    }
    for (double& x : step) x /= 2;
  }
  return best;
}

/// Points of the modal-mass grid (log-spaced over casing_mode's range).
constexpr int kModalMasses = 41;

/// The best (cost, mode) over the modal-mass grid and the residue's phases at `at`'s f_n and ζ.
template <class Cost>
std::pair<double, OneMode> best_mass_and_phase(Cost&& cost, OneMode at, const CandidateParameter& mass_range) {
  std::pair<double, OneMode> best{std::numeric_limits<double>::infinity(), at};
  for (int j = 0; j < kModalMasses; ++j)
    for (int q = 0; q < kResiduePhases; ++q) {
      at.mass = mass_range.low * std::pow(mass_range.high / mass_range.low, j / (kModalMasses - 1.0)), at.phase = residue_phase(q);
      const double c = cost(at);
      if (c < best.first) best = {c, at};
    }
  return best;
}

/// The least-squares mode on `cells`: a grid (ζ log-spaced over its range, f_n over [lo, hi] every
/// quarter of the half-power band of the grid's ζ, 2ζf_n at f_n = `centre_hz`, so that no mode of
/// that ζ falls between two grid points; at each, the modal masses and the residue's phases), then a
/// compass search from the grid's best point at every ζ and from the feature's description (its f_n
/// and ζ): a narrow mode's basin is narrower than a grid cell in m and f_n, so the grid's best point
/// overall is often a broad mode that fits everything a little.
OneMode fit_one_mode(const std::vector<WindowCell>& cells, double lo_hz, double hi_hz, double centre_hz, const CandidateForm& form,
                     std::optional<OneMode> described) {
  const CandidateParameter zeta_range = one_mode_damping(form);
  const auto& mass_range = form.parameters[3];
  const ModeBounds box{lo_hz, hi_hz, zeta_range.low, zeta_range.high, mass_range.low, mass_range.high};
  constexpr int kZeta = 15;
  auto on_centres = [&](const OneMode& m) { return misfit(cells, m, BinReading::at_centre); };
  auto zeta_point = [&](int i) { return zeta_range.low * std::pow(zeta_range.high / zeta_range.low, i / (kZeta - 1.0)); };
  auto hz_step = [&](double zeta) { return 0.5 * zeta * centre_hz; };
  std::vector<OneMode> starts;
  for (int i = 0; i < kZeta; ++i) {
    std::pair<double, OneMode> best{std::numeric_limits<double>::infinity(), {lo_hz, zeta_point(i), mass_range.high, 0}};
    for (double hz = lo_hz; hz <= hi_hz; hz += hz_step(zeta_point(i)))
      best = std::min(best, best_mass_and_phase(on_centres, {hz, zeta_point(i), 0, 0}, mass_range),
                      [](const auto& a, const auto& b) { return a.first < b.first; });
    starts.push_back(best.second);
  }
  if (described) {
    starts.push_back(best_mass_and_phase(on_centres, clamped(*described, box), mass_range).second);
  }
  auto step_from = [&](const OneMode& start) {
    return std::array<double, 4>{std::log1p(hz_step(start.zeta) / start.hz), std::log(zeta_range.high / zeta_range.low) / (kZeta - 1),
                                 std::log(mass_range.high / mass_range.low) / (kModalMasses - 1), residue_phase(1) / 2};
  };
  // Each start refined on the bins' centres (cheap), the best of them as the bins hold it; then that
  // one refined as the bins hold it.
  OneMode best = starts.front();
  double best_cost = std::numeric_limits<double>::infinity();
  for (const auto& start : starts) {
    const OneMode m = compass(on_centres, start, step_from(start), box);
    const double c = misfit(cells, m, BinReading::averaged);
    if (c < best_cost) best_cost = c, best = m;
  }
  return compass([&](const OneMode& x) { return misfit(cells, x, BinReading::averaged); }, best, step_from(best), box);
}

double rms_with(const std::vector<FeatureCell>& cells, const std::vector<RecordModels>& records, const OneModeGain* mode,
                const GearPairSpec& gears) {
  double sum = 0;
  for (const auto& c : cells) {
    const auto& rec = records[c.record];
    const double hz = cell_order(c.spectrum, c.index, gears) * rec.measured->speed_hz;
    double model = spectrum_of(*rec.twin, c.spectrum)[c.index];
    if (mode != nullptr && rec.twin->bearing_force_path)
      model *= (*mode)(window_cell(rec, c.spectrum, c.index, hz, *rec.twin->bearing_force_path));
    const double g = ratio_db(spectrum_of(*rec.measured, c.spectrum)[c.index], model, rec.floor);
    sum += g * g;
  }
  return cells.empty() ? std::numeric_limits<double>::quiet_NaN() : std::sqrt(sum / static_cast<double>(cells.size()));
}

/// A local cell (features.hpp: local_peak_cells): one broadband bin's band of bins, their measured
/// powers and their local expectation E (the twin plus the acquisition's floor, scaled by the
/// neighbourhood's median ratio), each bin as a WindowCell for a mode's gain.
struct LocalBand {
  double hz;  ///< the centre bin's place
  std::vector<double> measured, expected;
  std::vector<WindowCell> bins;
};

/// A record's local cells centred in [lo_hz, hi_hz].
std::vector<LocalBand> local_bands(const RecordModels& rec, double lo_hz, double hi_hz, const FeatureSettings& settings) {
  if (!rec.twin->bearing_force_path) return {};
  const BearingForcePath& path = *rec.twin->bearing_force_path;
  const double acquisition = compare_floors(*rec.measured, *rec.twin, settings.floor).acquisition;
  const auto expected = local_expectation(*rec.measured, *rec.twin, acquisition, settings.local);
  const auto& measured = rec.measured->broadband;
  const std::size_t h = settings.local.band_bins / 2;
  const double speed = rec.measured->speed_hz;
  auto place = [&](std::size_t i) { return cell_order(Spectrum::broadband, i, GearPairSpec{}) * speed; };
  std::vector<LocalBand> out;
  for (std::size_t k = h; k + h < expected.size() && k + h < measured.size(); ++k) {
    if (place(k) < lo_hz || place(k) > hi_hz) continue;
    LocalBand band{place(k), {}, {}, {}};
    for (std::size_t j = k - h; j <= k + h && std::isfinite(expected[j]); ++j) {
      band.measured.push_back(measured[j]), band.expected.push_back(expected[j]);
      band.bins.push_back(window_cell(rec, Spectrum::broadband, j, place(j), path));
    }
    if (band.bins.size() == 2 * h + 1) out.push_back(std::move(band));
  }
  return out;
}

/// A local cell's gain, dB, as the finder reads it (ΣM / ΣE); with a mode, each bin's E times the
/// mode's gain there: a mode of the structure lifts whatever the neighbourhood shows the floor to be.
double band_gain_db(const LocalBand& band, const OneModeGain* mode) {
  double m = 0, e = 0;
  for (std::size_t i = 0; i < band.bins.size(); ++i)
    m += band.measured[i], e += band.expected[i] * (mode != nullptr ? (*mode)(band.bins[i]) : 1.0);
  return m > 0 && e > 0 ? 10.0 * std::log10(m / e) : std::numeric_limits<double>::quiet_NaN();
}

/// The feature's description as a mode (its f_n and ζ; none when it is not a resonance's).
std::optional<OneMode> described_mode(const GapFeature& f) {
  const double fn = f.description.parameter("frequency_hz"), zeta = f.description.parameter("damping_ratio");
  if (!std::isfinite(fn) || !std::isfinite(zeta)) return std::nullopt;
  return OneMode{fn, zeta, 0, 0};
}

/// A peak narrower than a bin, which only the local cells find: the mode fitted on the training
/// records' local cells about it (sum of squared gains), from the feature's own description (a
/// resonance's f_n and ζ, fitted by its describer on bins read the same way; the modal mass from a
/// log grid there). ζ may go below casing_mode's range, to a steel casing's material damping: a
/// mode lifting less than a bin is as narrow as the structure makes it.
std::optional<OneMode> local_mode(const std::vector<LocalBand>& bands, const GapFeature& f, double lo_hz, double hi_hz,
                                  const CandidateForm& form) {
  const auto described = described_mode(f);
  if (bands.empty() || !described) return std::nullopt;
  const CandidateParameter zeta_range = one_mode_damping(form);
  const auto& mass_range = form.parameters[3];
  const ModeBounds box{lo_hz, hi_hz, zeta_range.low, zeta_range.high, mass_range.low, mass_range.high};
  auto cost = [&](const OneMode& m) {
    const OneModeGain gain(m);
    double sum = 0;
    for (const auto& b : bands) {
      const double g = band_gain_db(b, &gain);
      if (std::isfinite(g)) sum += g * g;
    }
    return sum;
  };
  const OneMode start = best_mass_and_phase(cost, clamped(*described, box), mass_range).second;
  const std::array<double, 4> step = {std::log1p(0.25 * start.zeta), 0.25,
                                      std::log(mass_range.high / mass_range.low) / (kModalMasses - 1), residue_phase(1) / 2};
  return compass(cost, start, step, box);
}

/// RMS gaps (without, with the mode) over the feature's local cells in the records of one set that
/// show it, centred inside its extent, at the practical minimum or more without. NaN: none.
std::pair<double, double> local_gap_db(const GapFeature& f, const std::vector<RecordModels>& records, bool held_out,
                                       const OneMode& mode, const FeatureSettings& settings) {
  const OneModeGain gain(mode);
  double before = 0, after = 0;
  std::size_t n = 0;
  for (std::size_t r = 0; r < records.size(); ++r) {
    if (!seen_in(f, held_out, r)) continue;
    for (const auto& band : local_bands(records[r], f.hz_low, f.hz_high, settings)) {
      const double b = band_gain_db(band, nullptr), a = band_gain_db(band, &gain);
      if (!(b >= settings.min_feature_db) || !std::isfinite(a)) continue;
      before += b * b, after += a * a, ++n;
    }
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  return n == 0 ? std::pair{nan, nan} : std::pair{std::sqrt(before / n), std::sqrt(after / n)};
}

double rms_window(const std::vector<WindowCell>& cells, const OneModeGain* mode) {
  if (cells.empty()) return 0.0;
  return std::sqrt(squared_gaps(cells, mode, BinReading::averaged) / static_cast<double>(cells.size()));
}

/// The window a mode is fitted in: the feature's extent (every cell the mode lifted by the practical
/// minimum or more) and two bins of the fastest record each side, cells that did not move, which pin
/// the mode's flanks. Not wider: a mode driven through the bearing forces' phase has an antiresonance
/// beside its peak that a resonance in the path lacks, and far cells would weigh that difference.
struct ModeWindow {
  double lo_hz, hi_hz, centre_hz;
};

ModeWindow mode_window(const GapFeature& f, const std::vector<RecordModels>& held_out, const std::vector<RecordModels>& training) {
  double top_speed = 0;
  for (const auto* set : {&held_out, &training})
    for (const auto& r : *set) top_speed = std::max(top_speed, r.measured->speed_hz);
  const double margin = 2 * top_speed;
  return {std::max(1.0, f.hz_low - margin), f.hz_high + margin, 0.5 * (f.hz_low + f.hz_high)};
}

/// A mode and how it was judged.
struct JudgedMode {
  OneMode mode;
  CasingModeFit fit;
};

/// The mode fitted on the training records' lines and bins in the window, judged on the feature's
/// held-out lines and bins (its training ones when no held-out record shows it).
std::optional<JudgedMode> mode_from_lines_and_bins(const GapFeature& f, const std::vector<RecordModels>& held_out,
                                                   const std::vector<RecordModels>& training, const GearPairSpec& gears,
                                                   const ModeWindow& w, const CandidateForm& form, double min_feature_db) {
  const auto fit_cells = window_cells(training, w.lo_hz, w.hi_hz, gears);
  if (fit_cells.empty()) return std::nullopt;
  auto judged = cells_of(f, held_out, true, gears, min_feature_db);
  const auto* records = &held_out;
  bool held = true;
  if (judged.empty()) judged = cells_of(f, training, false, gears, min_feature_db), records = &training, held = false;
  const OneMode mode = fit_one_mode(fit_cells, w.lo_hz, w.hi_hz, w.centre_hz, form, described_mode(f));
  const OneModeGain gain(mode);
  return JudgedMode{mode, {mode.hz, mode.zeta, mode.mass, mode.phase, rms_with(judged, *records, nullptr, gears),
                           rms_with(judged, *records, &gain, gears), held, false}};
}

/// The mode fitted on the training records' local cells in the window, judged on the feature's
/// held-out local cells (its training ones when no held-out record shows it; NaN gaps: neither does).
std::optional<JudgedMode> mode_from_local_cells(const GapFeature& f, const std::vector<RecordModels>& held_out,
                                                const std::vector<RecordModels>& training, const ModeWindow& w,
                                                const CandidateForm& form, const FeatureSettings& settings) {
  std::vector<LocalBand> bands;
  for (const auto& rec : training) {
    auto b = local_bands(rec, w.lo_hz, w.hi_hz, settings);
    bands.insert(bands.end(), std::make_move_iterator(b.begin()), std::make_move_iterator(b.end()));
  }
  const auto fitted = local_mode(bands, f, w.lo_hz, w.hi_hz, form);
  if (!fitted) return std::nullopt;
  JudgedMode out{*fitted, {fitted->hz, fitted->zeta, fitted->mass, fitted->phase, 0, 0, true, false}};
  std::tie(out.fit.gap_before_db, out.fit.gap_after_db) = local_gap_db(f, held_out, true, out.mode, settings);
  if (!std::isfinite(out.fit.gap_before_db)) {
    out.fit.held_out = false;
    std::tie(out.fit.gap_before_db, out.fit.gap_after_db) = local_gap_db(f, training, false, out.mode, settings);
  }
  return out;
}

}  // namespace

std::optional<CasingModeFit> casing_mode_for_resonance(const GapFeature& f, const std::vector<RecordModels>& held_out,
                                                       const std::vector<RecordModels>& training, const GearPairSpec& gears,
                                                       const FeatureSettings& settings) {
  if (training.empty()) return std::nullopt;
  const CandidateForm form = candidate_form(CandidateEffect::casing_mode, training.front().measured->sample_rate_hz);
  const ModeWindow w = mode_window(f, held_out, training);
  // The mode is fitted on what the training records show of it: their lines and bins when any of
  // them rises by the minimum, else their local cells (a peak narrower than a bin, or one between
  // the lines each training speed puts near it, shows only there).
  const auto judged = !cells_of(f, training, false, gears, settings.min_feature_db).empty()
                          ? mode_from_lines_and_bins(f, held_out, training, gears, w, form, settings.min_feature_db)
                          : mode_from_local_cells(f, held_out, training, w, form, settings);
  if (!judged) return std::nullopt;
  CasingModeFit out = judged->fit;
  out.residue_phase_rad = std::remainder(judged->mode.phase, 2.0 * std::numbers::pi);
  if (!std::isfinite(out.gap_before_db)) return out;
  // Held out, the mode must not make the window worse, whether or not those records show the feature.
  const auto window = window_cells(held_out.empty() ? training : held_out, w.lo_hz, w.hi_hz, gears);
  const OneModeGain gain(judged->mode);
  out.explains = out.gap_after_db < settings.min_feature_db && rms_window(window, &gain) <= rms_window(window, nullptr);
  return out;
}

std::optional<CandidateEffect> family_explaining_candidate(const GapReport& report, const GapFeature& f, const GearPairSpec& gears) {
  FamilyKind family = FamilyKind::broadband;
  const double nearest = std::round(f.order);
  if (f.description.kind == DescriptionKind::floor_change) family = FamilyKind::broadband;
  // A modulation's gap is in its shaft's first sidebands n·z ± 1; a feature holding a pair of them
  // has its centre on the carrier between them, a mesh order, whose family is not the sidebands'.
  else if (f.description.kind == DescriptionKind::modulation)
    family = f.description.shaft == FeatureShaft::output ? FamilyKind::output_sidebands : FamilyKind::input_sidebands;
  else if (f.movement == FeatureMovement::fixed_in_hz) family = FamilyKind::fixed_frequency;
  else if (f.shaft == FeatureShaft::output && nearest >= 1) family = output_line_family(static_cast<int>(nearest), gears.gear_teeth);
  else if (std::abs(f.order - nearest) <= 0.25 && nearest >= 1) family = input_line_family(static_cast<int>(nearest), gears.pinion_teeth);
  if (std::find(report.unexplained.begin(), report.unexplained.end(), family) != report.unexplained.end()) return std::nullopt;
  for (const CandidateEffect effect : report.chosen)
    for (const auto& c : report.candidates)
      if (c.effect == effect && std::find(c.explains.begin(), c.explains.end(), family) != c.explains.end()) return effect;
  return std::nullopt;
}

}  // namespace gearwatch::gap
