#include "gearwatch/gap/attribution.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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
    for (std::size_t i = 0; i < rec.measured->input_lines.size(); ++i) add(Spectrum::input_lines, i, i + 1.0);
    for (std::size_t i = 0; i < rec.measured->broadband.size(); ++i) add(Spectrum::broadband, i, i + 1.5);
    for (std::size_t i = 0; i < rec.measured->output_lines.size(); ++i)
      if (!output_line_is_mesh(static_cast<int>(i + 1), gears.gear_teeth)) add(Spectrum::output_lines, i, (i + 1.0) * per_output);
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
