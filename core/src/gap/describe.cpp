#include "gearwatch/gap/describe.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <tuple>

namespace gearwatch::gap {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double ratio_db(double measured, double model, double floor) { return 10.0 * std::log10((measured + floor) / (model + floor)); }

/// The minimum of a unimodal f on [lo, hi] (golden section).
template <class F>
double golden_min(F&& f, double lo, double hi, int iterations = 40) {
  const double phi = (std::sqrt(5.0) - 1) / 2;
  double a = lo, b = hi, c = b - phi * (b - a), d = a + phi * (b - a), fc = f(c), fd = f(d);
  for (int i = 0; i < iterations; ++i) {
    if (fc < fd) b = d, d = c, fd = fc, c = b - phi * (b - a), fc = f(c);
    else a = c, c = d, fc = fd, d = a + phi * (b - a), fd = f(d);
  }
  return fc < fd ? c : d;
}

/// Least squares of y on [1, x]: (intercept, slope).
std::pair<double, double> line_fit(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  if (n < 2) return {n == 1 ? y[0] : 0.0, 0.0};
  const double mx = std::accumulate(x.begin(), x.end(), 0.0) / n, my = std::accumulate(y.begin(), y.end(), 0.0) / n;
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) sxx += (x[i] - mx) * (x[i] - mx), sxy += (x[i] - mx) * (y[i] - my);
  const double slope = sxx > 0 ? sxy / sxx : 0.0;
  return {my - slope * mx, slope};
}

/// The normalised second-order band-pass's power: 1 at r = 1, ½ at its half-power points.
double band_pass(double hz, double fn, double zeta) {
  const double r = hz / fn, a = 1 - r * r, b = 2 * zeta * r;
  return b * b / (a * a + b * b);
}

}  // namespace

FeatureDescriber::FeatureDescriber(const std::vector<DescribedRecord>& records, const GearPairSpec& gears, DescriptionSettings settings)
    : sources_(records), gears_(gears), settings_(settings) {
  const double ratio = static_cast<double>(gears.pinion_teeth) / gears.gear_teeth;  // input orders per output order
  for (const auto& src : sources_) {
    if (!src.measured || !src.twin) throw std::invalid_argument("FeatureDescriber: a record without spectra");
    const auto& m = *src.measured;
    const auto& t = *src.twin;
    RecordCells r{&src, m.speed_hz, src.floor, {}};
    for (std::size_t k = 0; k < std::min(m.input_lines.size(), t.input_lines.size()); ++k)
      r.cells.push_back({CellKind::input_line, k, k + 1.0, (k + 1.0) * m.speed_hz, t.input_lines[k], m.input_lines[k]});
    for (std::size_t k = 0; k < std::min(m.broadband.size(), t.broadband.size()); ++k)
      r.cells.push_back({CellKind::broadband, k, k + 1.5, (k + 1.5) * m.speed_hz, t.broadband[k], m.broadband[k]});
    for (std::size_t j = 0; j < std::min(m.output_lines.size(), t.output_lines.size()); ++j) {
      if (output_line_is_mesh(static_cast<int>(j + 1), gears.gear_teeth)) continue;
      const double o = (j + 1.0) * ratio;
      r.cells.push_back({CellKind::output_line, j, o, o * m.speed_hz, t.output_lines[j], m.output_lines[j]});
    }
    records_.push_back(std::move(r));
  }
  floor_ = floor_change();
  tilt_ = path_tilt();
  modulation_input_ = modulation(FeatureShaft::input);
  modulation_output_ = modulation(FeatureShaft::output);
}

double FeatureDescriber::g_of(std::size_t r, std::size_t c, double measured) const {
  return ratio_db(measured, records_[r].cells[c].twin, records_[r].floor);
}

FeatureDescriber::Window FeatureDescriber::window_of(const GapFeature& f) const {
  const double ratio = static_cast<double>(gears_.pinion_teeth) / gears_.gear_teeth;
  const double to_input = f.shaft == FeatureShaft::output ? ratio : 1.0;
  Window w;
  for (std::size_t r = 0; r < records_.size(); ++r) {
    const double speed = records_[r].speed_hz;
    double lo = f.order_low * to_input, hi = f.order_high * to_input;
    if (f.movement == FeatureMovement::fixed_in_hz) lo = f.hz_low / speed, hi = f.hz_high / speed;
    const double margin = std::max(2.0, (hi - lo) / 2);
    lo -= margin, hi += margin;
    const auto& cells = records_[r].cells;
    for (std::size_t c = 0; c < cells.size(); ++c)
      if (cells[c].order >= lo && cells[c].order <= hi) w.emplace_back(r, c);
  }
  return w;
}

FeatureDescriber::Fit FeatureDescriber::floor_change() const {
  std::vector<double> x, y;
  for (const auto& r : records_)
    for (const auto& c : r.cells)
      if (c.kind == CellKind::broadband && c.twin >= 10 * r.floor && c.measured > 0 && c.hz > 0)
        x.push_back(std::log10(c.hz / 1000.0)), y.push_back(ratio_db(c.measured, c.twin, r.floor));
  auto [level, slope] = line_fit(x, y);
  // The comparison's floor compresses g where the twin's bins sit near it: the line's least squares
  // over the bins clear of it starts, then the RSS in g itself over every bin above the floor.
  std::vector<std::tuple<double, double, double, double>> bins;  // log10(f/1 kHz), twin, g, floor
  for (const auto& r : records_)
    for (const auto& c : r.cells)
      if (c.kind == CellKind::broadband && c.twin >= r.floor && c.hz > 0)
        bins.emplace_back(std::log10(c.hz / 1000.0), c.twin, ratio_db(c.measured, c.twin, r.floor), r.floor);
  if (x.size() < 2 && !bins.empty()) {  // nothing clear of the floor: start from g itself
    x.clear(), y.clear();
    for (const auto& [lx, t, g, fl] : bins) x.push_back(lx), y.push_back(g);
    std::tie(level, slope) = line_fit(x, y);
  }
  auto rss = [&](double l, double s) {
    double sum = 0;
    for (const auto& [lx, t, g, fl] : bins) {
      const double d = g - ratio_db(t * std::pow(10.0, (l + s * lx) / 10), t, fl);
      sum += d * d;
    }
    return sum;
  };
  for (int round = 0; round < 6 && !bins.empty(); ++round) {
    const double span = 4.0 / (1 << round);
    level = golden_min([&](double l) { return rss(l, slope); }, level - span, level + span, 30);
    slope = golden_min([&](double s) { return rss(level, s); }, slope - span, slope + span, 30);
  }
  Fit fit;
  fit.description.kind = DescriptionKind::floor_change;
  fit.description.parameters = {{"level_db", level}, {"slope_db_per_decade", slope}};
  fit.complexity = 2;
  fit.predict = [this, level, slope](std::size_t r, std::size_t i) {
    const Cell& c = records_[r].cells[i];
    if (c.kind != CellKind::broadband || !(c.hz > 0)) return c.twin;
    return c.twin * std::pow(10.0, (level + slope * std::log10(c.hz / 1000.0)) / 10);
  };
  return fit;
}

FeatureDescriber::Fit FeatureDescriber::path_tilt() const {
  std::vector<double> x, y;
  for (const auto& r : records_)
    for (const auto& c : r.cells)
      if (c.kind == CellKind::input_line && (c.index + 1) % static_cast<std::size_t>(gears_.pinion_teeth) == 0 &&
          c.twin >= 10 * r.floor && c.measured > 0)
        x.push_back(std::log2((c.index + 1.0) / gears_.pinion_teeth)), y.push_back(ratio_db(c.measured, c.twin, r.floor));
  const auto [level, tilt] = line_fit(x, y);
  Fit fit;
  fit.description.kind = DescriptionKind::path_tilt;
  fit.description.parameters = {{"tilt_db_per_octave", tilt}, {"level_db", level}};
  fit.complexity = 2;
  fit.predict = [this, level = level, tilt = tilt](std::size_t r, std::size_t i) {
    const Cell& c = records_[r].cells[i];
    const double mesh_hz = gears_.pinion_teeth * records_[r].speed_hz;
    return c.twin * std::pow(10.0, (level + tilt * std::log2(c.hz / mesh_hz)) / 10);
  };
  return fit;
}

FeatureDescriber::Fit FeatureDescriber::modulation(FeatureShaft shaft) const {
  using Complex = std::complex<double>;
  const int zp = gears_.pinion_teeth, z = shaft == FeatureShaft::input ? gears_.pinion_teeth : gears_.gear_teeth;
  // Per record: A (AM, common to the harmonics) and B (PM of the first harmonic), or with powers only
  // the index m_eq; and where each predicted sideband sits.
  struct PerRecord {
    Complex a, b;
    double am = 0, pm = kNaN, weight = 0;
    std::vector<std::pair<std::size_t, double>> sideband_power;  // (cell index in the record, predicted power)
  };
  std::vector<PerRecord> per(records_.size());
  double am_sum = 0, pm_sum = 0, weight_sum = 0;
  bool phases = true;
  for (std::size_t r = 0; r < records_.size(); ++r) {
    const auto& src = *records_[r].source;
    const auto& m = *src.measured;
    const auto& t = *src.twin;
    const bool input = shaft == FeatureShaft::input;
    const auto& lines_m = input ? m.input_lines : m.output_lines;
    const auto& lines_t = input ? t.input_lines : t.output_lines;
    const auto& cm = input ? src.measured_input : src.measured_output;
    const auto& ct = input ? src.twin_input : src.twin_output;
    const bool with_phase = !src.measured_input.empty() && !src.twin_input.empty() && cm.size() >= lines_m.size() &&
                            ct.size() >= lines_t.size();
    phases = phases && with_phase;
    // Harmonics whose carrier (input order n·zp) stands above the floor and whose sidebands exist.
    struct Harmonic {
      int n;
      Complex carrier_m, u_m, l_m, u_t, l_t;
      double carrier_power, excess;
    };
    std::vector<Harmonic> hs;
    for (int n = 1;; ++n) {
      const std::size_t carrier = static_cast<std::size_t>(n * zp) - 1, upper = static_cast<std::size_t>(n * z), lower = upper - 2;
      if (carrier >= m.input_lines.size() || carrier >= t.input_lines.size() || upper >= lines_m.size() || upper >= lines_t.size()) break;
      const double pc = m.input_lines[carrier];
      if (!(pc > 100 * src.floor)) continue;
      Harmonic h{n, {}, {}, {}, {}, {}, pc, lines_m[upper] + lines_m[lower] - lines_t[upper] - lines_t[lower]};
      if (with_phase) {
        const Complex cmc = src.measured_input[carrier], ctc = src.twin_input[carrier];
        if (std::abs(cmc) == 0 || std::abs(ctc) == 0) continue;
        h.carrier_m = cmc, h.u_m = cm[upper] / cmc, h.l_m = cm[lower] / cmc, h.u_t = ct[upper] / ctc, h.l_t = ct[lower] / ctc;
      }
      hs.push_back(h);
    }
    PerRecord& p = per[r];
    double w = 0, excess = 0;
    for (const auto& h : hs) {
      w += h.carrier_power, excess += h.excess;
      if (!with_phase) continue;
      const Complex a = (h.u_m + std::conj(h.l_m)) - (h.u_t + std::conj(h.l_t));
      const Complex b = (h.u_m - std::conj(h.l_m)) - (h.u_t - std::conj(h.l_t));
      p.a += h.carrier_power * a, p.b += h.carrier_power * b / static_cast<double>(h.n);
    }
    if (w <= 0) continue;
    p.weight = w;
    if (with_phase) {
      p.a /= w, p.b /= w;
      p.am = std::abs(p.a), p.pm = std::abs(p.b);
    } else {
      p.am = std::sqrt(std::max(0.0, 2 * excess / w));  // both sidebands m²/4 of the carrier
    }
    // The predicted sideband powers of this record.
    const auto& cells = records_[r].cells;
    const CellKind kind = input ? CellKind::input_line : CellKind::output_line;
    for (const auto& h : hs) {
      const std::size_t upper = static_cast<std::size_t>(h.n * z), lower = upper - 2;
      double pu, pl;
      if (with_phase) {
        pu = std::norm(h.carrier_m * (h.u_t + (p.a + double(h.n) * p.b) / 2.0));
        pl = std::norm(h.carrier_m * (h.l_t + std::conj((p.a - double(h.n) * p.b) / 2.0)));
      } else {
        pu = lines_t[upper] + p.am * p.am / 4 * h.carrier_power;
        pl = lines_t[lower] + p.am * p.am / 4 * h.carrier_power;
      }
      for (std::size_t i = 0; i < cells.size(); ++i)
        if (cells[i].kind == kind && (cells[i].index == upper || cells[i].index == lower))
          p.sideband_power.emplace_back(i, cells[i].index == upper ? pu : pl);
    }
    am_sum += w * p.am, pm_sum += w * (with_phase ? p.pm : 0.0), weight_sum += w;
  }
  Fit fit;
  fit.description.kind = DescriptionKind::modulation;
  fit.description.shaft = shaft;
  const double am = weight_sum > 0 ? am_sum / weight_sum : 0.0;
  const double pm = weight_sum > 0 && phases ? pm_sum / weight_sum : kNaN;
  fit.description.parameters = {{"am_index", am}, {"pm_index_rad", pm}};
  fit.complexity = 2;
  // Each record's cell → predicted power (the twin's elsewhere).
  std::vector<std::vector<double>> predicted(records_.size());
  for (std::size_t r = 0; r < records_.size(); ++r) {
    predicted[r].assign(records_[r].cells.size(), kNaN);
    for (const auto& [i, power] : per[r].sideband_power) predicted[r][i] = power;
  }
  fit.predict = [this, predicted = std::move(predicted)](std::size_t r, std::size_t i) {
    const double p = predicted[r][i];
    return std::isfinite(p) ? p : records_[r].cells[i].twin;
  };
  return fit;
}

FeatureDescriber::Fit FeatureDescriber::resonance(const GapFeature& f, const Window& w) const {
  // RSS of g over the window for (f_n, ζ, G dB).
  auto rss = [&](double fn, double zeta, double gain_db) {
    const double gm1 = std::pow(10.0, gain_db / 10) - 1;
    double s = 0;
    for (const auto& [r, i] : w) {
      const Cell& c = records_[r].cells[i];
      const double d = g_of(r, i, c.measured) - g_of(r, i, c.twin * (1 + gm1 * band_pass(c.hz, fn, zeta)));
      s += d * d;
    }
    return s;
  };
  auto best_gain = [&](double fn, double zeta) { return golden_min([&](double g) { return rss(fn, zeta, g); }, -30, 40, 20); };
  double lo = f.hz_low, hi = f.hz_high;
  if (!(hi > lo) || !(lo > 0)) lo = std::max(1.0, f.hz * 0.9), hi = f.hz * 1.1;
  // A grid over f_n in the feature's band and ζ from 0.002 to 0.3 (log), the gain by golden section;
  // then a pattern search around the best.
  double bf = f.hz, bz = 0.02, bg = 0, best = std::numeric_limits<double>::infinity();
  constexpr int kF = 24, kZeta = 12;
  for (int i = 0; i <= kF; ++i)
    for (int j = 0; j <= kZeta; ++j) {
      const double fn = lo + (hi - lo) * i / kF, zeta = 0.002 * std::pow(150.0, static_cast<double>(j) / kZeta), g = best_gain(fn, zeta),
                   v = rss(fn, zeta, g);
      if (v < best) best = v, bf = fn, bz = zeta, bg = g;
    }
  double step_f = (hi - lo) / kF, step_lz = std::log(150.0) / kZeta;
  for (int it = 0; it < 30; ++it) {
    bool moved = false;
    for (const auto& [df, dlz] : {std::pair{1.0, 0.0}, {-1.0, 0.0}, {0.0, 1.0}, {0.0, -1.0}}) {
      const double fn = bf + df * step_f, zeta = bz * std::exp(dlz * step_lz);
      if (!(fn > 0) || zeta < 1e-4 || zeta > 1) continue;
      const double g = best_gain(fn, zeta), v = rss(fn, zeta, g);
      if (v < best) best = v, bf = fn, bz = zeta, bg = g, moved = true;
    }
    if (!moved) step_f /= 2, step_lz /= 2;
  }
  Fit fit;
  fit.description.kind = DescriptionKind::resonance;
  fit.description.parameters = {{"frequency_hz", bf}, {"damping_ratio", bz}, {"gain_db", bg}};
  fit.complexity = 3;
  const double gm1 = std::pow(10.0, bg / 10) - 1;
  fit.predict = [this, bf, bz, gm1](std::size_t r, std::size_t i) {
    const Cell& c = records_[r].cells[i];
    return c.twin * (1 + gm1 * band_pass(c.hz, bf, bz));
  };
  return fit;
}

std::vector<double> FeatureDescriber::tone_response(std::size_t r, double order, const Window& w) const {
  const SpectralSummary& t = *records_[r].source->twin;
  SpectralSummary unit;
  unit.speed_hz = t.speed_hz, unit.input_revolutions = t.input_revolutions, unit.output_revolutions = t.output_revolutions;
  unit.input_lines.assign(t.input_lines.size(), 0.0);
  unit.output_lines.assign(t.output_lines.size(), 0.0);
  unit.broadband.assign(t.broadband.size(), 0.0);
  add_non_synchronous_tone(unit, order, 1.0, gears_);
  std::vector<double> out;
  for (const auto& [wr, i] : w) {
    if (wr != r) continue;
    const Cell& c = records_[r].cells[i];
    const auto& v = c.kind == CellKind::input_line ? unit.input_lines : c.kind == CellKind::output_line ? unit.output_lines : unit.broadband;
    out.push_back(c.index < v.size() ? v[c.index] : 0.0);
  }
  return out;
}

FeatureDescriber::Fit FeatureDescriber::tone(const GapFeature& f, const Window& w, bool fixed_in_hz) const {
  const double ratio = static_cast<double>(gears_.pinion_teeth) / gears_.gear_teeth;
  const double to_input = f.shaft == FeatureShaft::output ? ratio : 1.0;
  double total = 0;
  for (const auto& r : records_) total = std::max(total, total_input_line_power(*r.source->twin));
  // Candidate places: in input orders (ghost) or Hz (tone), across the feature's extent, 0.05 orders apart, then refined by halving.
  double lo = f.order_low * to_input, hi = f.order_high * to_input;
  double top_speed = 0;
  for (const auto& r : records_) top_speed = std::max(top_speed, r.speed_hz);
  if (fixed_in_hz) lo = f.hz_low, hi = f.hz_high;
  const double step = fixed_in_hz ? 0.05 * top_speed : 0.05;
  // Per place: every record's unit responses on the window (in the window's order), then the power.
  struct Result {
    double place = 0, power = 0, rss = std::numeric_limits<double>::infinity();
    std::vector<std::vector<double>> unit;
  };
  auto evaluate = [&](double place) {
    Result res;
    res.place = place;
    for (std::size_t r = 0; r < records_.size(); ++r)
      res.unit.push_back(tone_response(r, fixed_in_hz ? place / records_[r].speed_hz : place, w));
    auto rss = [&](double log_power) {
      const double p = std::pow(10.0, log_power);
      std::vector<std::size_t> at(records_.size(), 0);
      double s = 0;
      for (const auto& [r, i] : w) {
        const Cell& c = records_[r].cells[i];
        const double d = g_of(r, i, c.measured) - g_of(r, i, c.twin + p * res.unit[r][at[r]++]);
        s += d * d;
      }
      return s;
    };
    const double top = std::log10(std::max(total, 1e-300));
    const double lp = golden_min(rss, top - 14, top + 2, 36);
    res.power = std::pow(10.0, lp), res.rss = rss(lp);
    return res;
  };
  Result best;
  // A ghost sits off the shafts' integer orders: a tone on one is a line the synchronous averages keep.
  auto on_a_line = [&](double place) {
    if (fixed_in_hz) return false;
    const double out = place / ratio;
    return std::abs(place - std::round(place)) < 0.05 || std::abs(out - std::round(out)) < 0.05;
  };
  for (double place = lo; place <= hi + 1e-9; place += step) {
    if (on_a_line(place)) continue;
    auto res = evaluate(place);
    if (res.rss < best.rss) best = std::move(res);
  }
  for (double s = step / 2; s > step / 128; s /= 2)
    for (double place : {best.place - s, best.place + s}) {
      if (on_a_line(place) || best.unit.empty()) continue;
      auto res = evaluate(place);
      if (res.rss < best.rss) best = std::move(res);
    }
  Fit fit;
  fit.complexity = 2;
  const double amplitude = std::sqrt(best.power);
  if (fixed_in_hz) {
    fit.description.kind = DescriptionKind::fixed_tone;
    fit.description.parameters = {{"frequency_hz", best.place}, {"amplitude_m_s2", amplitude}, {"fundamental_hz", best.place},
                                  {"harmonic", 1.0}, {"supply_hz", 0.0}};
  } else {
    fit.description.kind = DescriptionKind::ghost_line;
    fit.description.shaft = f.shaft;
    fit.description.parameters = {{"order", best.place / to_input}, {"amplitude_m_s2", amplitude}};
  }
  // The prediction on the window's cells (the twin's elsewhere).
  std::vector<std::vector<double>> predicted(records_.size());
  std::vector<std::size_t> at(records_.size(), 0);
  for (std::size_t r = 0; r < records_.size(); ++r) predicted[r].assign(records_[r].cells.size(), kNaN);
  if (!best.unit.empty())
    for (const auto& [r, i] : w) predicted[r][i] = records_[r].cells[i].twin + best.power * best.unit[r][at[r]++];
  fit.predict = [this, predicted = std::move(predicted)](std::size_t r, std::size_t i) {
    const double p = predicted[r][i];
    return std::isfinite(p) ? p : records_[r].cells[i].twin;
  };
  return fit;
}

FeatureDescription FeatureDescriber::describe(const GapFeature& f) const {
  const Window w = window_of(f);
  FeatureDescription none;
  if (w.empty()) return none;
  std::vector<Fit> fits{floor_, tilt_, modulation_input_, modulation_output_};
  // The local forms where they can be the one cause: a resonance within an octave (the forms' ζ
  // ≤ 0.3 keeps its 3 dB band there for gains up to 10 dB), a tone within four input orders (its
  // leakage reaches three lines each side).
  double top_speed = 0;
  for (const auto& r : records_) top_speed = std::max(top_speed, r.speed_hz);
  const double to_input = f.shaft == FeatureShaft::output ? static_cast<double>(gears_.pinion_teeth) / gears_.gear_teeth : 1.0;
  if (f.hz_high <= 2 * f.hz_low) fits.push_back(resonance(f, w));
  if (f.movement != FeatureMovement::fixed_in_hz && (f.order_high - f.order_low) * to_input <= 4) fits.push_back(tone(f, w, false));
  if (f.movement != FeatureMovement::fixed_in_orders && f.hz_high - f.hz_low <= 4 * top_speed) fits.push_back(tone(f, w, true));
  double gap_sq = 0;
  std::size_t core = 0;
  for (const auto& [r, i] : w) {
    const double g = g_of(r, i, records_[r].cells[i].measured);
    gap_sq += g * g;
    core += std::abs(g) >= settings_.min_feature_db ? 1 : 0;
  }
  const double n = static_cast<double>(w.size());
  none.gap_db = std::sqrt(gap_sq / n);
  if (core == 0) return none;
  FeatureDescription best = none;
  double best_bic = std::numeric_limits<double>::infinity();
  for (const auto& fit : fits) {
    double rss = 0, core_sq = 0;
    for (const auto& [r, i] : w) {
      const double g = g_of(r, i, records_[r].cells[i].measured), d = g - g_of(r, i, fit.predict(r, i));
      rss += d * d;
      if (std::abs(g) >= settings_.min_feature_db) core_sq += d * d;
    }
    if (!(std::sqrt(core_sq / static_cast<double>(core)) < settings_.min_feature_db)) continue;  // its gap stays
    const double res2 = settings_.resolution_db * settings_.resolution_db;
    const double bic = n * std::log(std::max(rss / n, res2)) + fit.complexity * std::log(n);
    if (bic < best_bic) {
      best_bic = bic;
      best = fit.description;
      best.gap_db = none.gap_db;
      best.residual_db = std::sqrt(rss / n);
    }
  }
  return best;
}

void FeatureDescriber::describe_all(std::vector<GapFeature>& features) const {
  for (auto& f : features) f.description = describe(f);
  // Tones: supply pick-up when near a harmonic of 50 or 60 Hz (the base more of them sit on), else
  // harmonics of the lowest tone they are integer multiples of.
  double top_speed = 0;
  for (const auto& r : records_) top_speed = std::max(top_speed, r.speed_hz);
  const double tol = settings_.supply_tolerance_orders * top_speed;
  std::vector<FeatureDescription*> tones;
  for (auto& f : features)
    if (f.description.kind == DescriptionKind::fixed_tone) tones.push_back(&f.description);
  auto harmonic_of = [&](double hz, double base) {
    const double k = std::round(hz / base);
    return k >= 1 && k <= settings_.max_supply_harmonic && std::abs(hz - k * base) <= tol ? k : 0.0;
  };
  int on50 = 0, on60 = 0;
  for (auto* t : tones) on50 += harmonic_of(t->parameter("frequency_hz"), 50) > 0, on60 += harmonic_of(t->parameter("frequency_hz"), 60) > 0;
  const double supply = on50 == 0 && on60 == 0 ? 0.0 : on60 > on50 ? 60.0 : 50.0;
  double lowest = std::numeric_limits<double>::infinity();
  for (auto* t : tones)
    if (supply == 0 || harmonic_of(t->parameter("frequency_hz"), supply) == 0) lowest = std::min(lowest, t->parameter("frequency_hz"));
  auto set = [](FeatureDescription& d, const char* name, double v) {
    for (auto& [n, value] : d.parameters)
      if (n == name) value = v;
  };
  for (auto* t : tones) {
    const double hz = t->parameter("frequency_hz");
    if (const double k = supply > 0 ? harmonic_of(hz, supply) : 0.0; k > 0) {
      set(*t, "fundamental_hz", supply), set(*t, "harmonic", k), set(*t, "supply_hz", supply);
    } else if (std::isfinite(lowest)) {
      const double k = std::round(hz / lowest);
      if (k >= 1 && std::abs(hz - k * lowest) <= tol) set(*t, "fundamental_hz", lowest), set(*t, "harmonic", k);
    }
  }
}

std::optional<CandidateEffect> explaining_candidate(const GapReport& report, const GapFeature& f, const GearPairSpec& gears) {
  FamilyKind family = FamilyKind::broadband;
  const double nearest = std::round(f.order);
  if (f.movement == FeatureMovement::fixed_in_hz) family = FamilyKind::fixed_frequency;
  else if (f.shaft == FeatureShaft::output && nearest >= 1) family = output_line_family(static_cast<int>(nearest), gears.gear_teeth);
  else if (std::abs(f.order - nearest) <= 0.25 && nearest >= 1) family = input_line_family(static_cast<int>(nearest), gears.pinion_teeth);
  if (std::find(report.unexplained.begin(), report.unexplained.end(), family) != report.unexplained.end()) return std::nullopt;
  for (const CandidateEffect effect : report.chosen)
    for (const auto& c : report.candidates)
      if (c.effect == effect && std::find(c.explains.begin(), c.explains.end(), family) != c.explains.end()) return effect;
  return std::nullopt;
}

}  // namespace gearwatch::gap
