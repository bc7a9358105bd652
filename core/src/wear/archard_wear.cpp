#include "gearwatch/wear/archard_wear.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <numbers>

#include "gearwatch/twin/errors.hpp"
#include "gearwatch/wear/quadrature.hpp"

namespace gearwatch::wear {

namespace {
// The thesis's K is read as MPa⁻¹ in the N–mm–MPa system: h[mm] = K · P[MPa] · s[mm], so
// h[m]·1e3 = K · P[Pa]·1e-6 · s[m]·1e3 and K_SI = K · 1e-6 (docs/wear.md: how this was chosen).
constexpr double kSeedToSi = 1e-6;
}  // namespace

LineContact line_contact(double load_per_width, double reduced_radius, double effective_modulus) {
  if (!std::isfinite(load_per_width) || !std::isfinite(reduced_radius) || !std::isfinite(effective_modulus) ||
      reduced_radius <= 0 || effective_modulus <= 0)
    throw twin::TwinParameterError("Hertz line contact needs a finite load, positive radius and modulus");
  LineContact c;
  if (load_per_width <= 0) return c;
  c.half_width_m = std::sqrt(4.0 * load_per_width * reduced_radius / (std::numbers::pi * effective_modulus));
  c.max_pressure_pa = 2.0 * load_per_width / (std::numbers::pi * c.half_width_m);
  return c;
}

double k_wear_si_from_seed(double k_wear_seed) { return k_wear_seed * kSeedToSi; }
double k_wear_seed_from_si(double k_wear_si) { return k_wear_si / kSeedToSi; }

std::vector<double> archard_wear_depth(const TravellingContact& c, const std::vector<double>& points, double k) {
  if (!(c.last > c.first)) throw twin::TwinParameterError("travelling contact: empty range of centre positions");
  if (!std::isfinite(k) || k < 0) throw twin::TwinParameterError("wear coefficient must be finite and non-negative");
  // The widest strip bounds where a centre can still touch a point.
  constexpr int kScan = 4096;
  double a_max = 0;
  for (int i = 0; i <= kScan; ++i) a_max = std::max(a_max, c.half_width_m(c.first + (c.last - c.first) * i / kScan));
  a_max *= 1.5;
  std::vector<double> depth(points.size(), 0.0);
  if (a_max <= 0 || k == 0) return depth;
  const auto& rule = gauss_legendre(24);
  auto integrand = [&](double x, double q) {
    const double a = c.half_width_m(q);
    if (!(a > 0)) return 0.0;
    const double r = (x - q) / a;
    if (std::abs(r) >= 1.0) return 0.0;
    return c.max_pressure_pa(q) * std::sqrt(1.0 - r * r) * c.sliding_speed_m_s(q) / c.rolling_speed_m_s(q);
  };
  for (std::size_t j = 0; j < points.size(); ++j) {
    const double x = points[j];
    const double lo_bound = std::max(c.first, x - a_max), hi_bound = std::min(c.last, x + a_max);
    if (!(hi_bound > lo_bound)) continue;
    double sum = 0;
    const double a_here = (x >= c.first && x <= c.last) ? c.half_width_m(x) : 0.0;
    if (a_here > 0) {
      // One strip [q_lo, q_hi] around x: edges where |x − q| = a(q).
      auto edge = [&](double inside, double outside) {
        auto covers = [&](double q) { return std::abs(x - q) < c.half_width_m(q); };
        if (covers(outside)) return outside;  // the strip runs past the end of the pass
        for (int it = 0; it < 60; ++it) {
          const double mid = 0.5 * (inside + outside);
          (covers(mid) ? inside : outside) = mid;
        }
        return 0.5 * (inside + outside);
      };
      const double q_lo = edge(x, lo_bound), q_hi = edge(x, hi_bound);
      // q = centre + half·sin θ on each piece: the square-root edges become smooth in θ. The piece
      // boundary at the sliding reversal keeps the |v_s| kink off the interior of a rule.
      auto piece = [&](double lo, double hi) {
        const double centre = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
        double part = 0;
        for (std::size_t i = 0; i < rule.nodes.size(); ++i) {
          const double theta = 0.5 * std::numbers::pi * rule.nodes[i];
          const double q = centre + half * std::sin(theta);
          part += rule.weights[i] * 0.5 * std::numbers::pi * half * std::cos(theta) * integrand(x, q);
        }
        return part;
      };
      const double kink = c.sliding_reversal;
      if (kink > q_lo && kink < q_hi)
        sum = piece(q_lo, kink) + piece(kink, q_hi);
      else
        sum = piece(q_lo, q_hi);
    } else {
      // Nothing carried at x itself (contact loss, or x beyond the pass): strips of neighbours may
      // still reach it, so integrate the whole window in panels.
      constexpr int kPanels = 32;
      const double w = (hi_bound - lo_bound) / kPanels;
      for (int p = 0; p < kPanels; ++p)
        for (std::size_t i = 0; i < rule.nodes.size(); ++i)
          sum += rule.weights[i] * 0.5 * w * integrand(x, lo_bound + w * (p + 0.5 + 0.5 * rule.nodes[i]));
    }
    depth[j] = k * sum;
  }
  return depth;
}

double PassLoad::force_at(double s) const {
  if (position_m.size() < 2 || s < position_m.front() || s > position_m.back()) return 0.0;
  const auto it = std::upper_bound(position_m.begin(), position_m.end(), s);
  const std::size_t i = std::min<std::size_t>(static_cast<std::size_t>(it - position_m.begin()), position_m.size() - 1);
  const std::size_t i0 = i - 1;
  const double span = position_m[i] - position_m[i0];
  const double f = span > 0 ? (s - position_m[i0]) / span : 0.0;
  return force_n[i0] + f * (force_n[i] - force_n[i0]);
}

double pinion_flank_arc(const twin::GearGeometry& g, double s) { return s * s / (2.0 * g.base_radius_pinion); }
double gear_flank_arc(const twin::GearGeometry& g, double s) {
  const double rho = g.line_of_action_length - s;
  return rho * rho / (2.0 * g.base_radius_gear);
}

namespace {
// What a flank's travelling contact needs, shared by its std::function members (copied cheaply).
struct PairContactData {
  twin::GearGeometry geometry;
  PassLoad load;
  std::function<double(double)> width_factor;
  // Hertz at line-of-action position s (the load per width over the remaining face width).
  LineContact at(double s) const {
    const double factor = width_factor ? width_factor(s) : 1.0;
    const double rho1 = s, rho2 = geometry.line_of_action_length - s;
    if (!(factor > 0) || rho1 <= 0 || rho2 <= 0) return LineContact{};
    return line_contact(std::max(0.0, load.force_at(s)) / (geometry.spec.face_width_m * factor),
                        rho1 * rho2 / (rho1 + rho2), geometry.effective_modulus);
  }
  // For ω1 = 1 rad/s: the wear per pass depends on v_s/v_r only, so the speed cancels (it acts
  // through the load).
  double sliding(double s) const {
    const double ratio = static_cast<double>(geometry.spec.pinion_teeth) / geometry.spec.gear_teeth;
    return std::abs(s - ratio * (geometry.line_of_action_length - s));
  }
};

std::shared_ptr<const PairContactData> make_data(const twin::GearGeometry& g, const PassLoad& load,
                                                 const std::function<double(double)>& width_factor) {
  if (load.position_m.size() != load.force_n.size() || load.position_m.size() < 2)
    throw twin::TwinParameterError("pass load: positions and forces must have the same size (at least 2)");
  for (std::size_t i = 0; i < load.force_n.size(); ++i)
    if (!std::isfinite(load.force_n[i]) || !std::isfinite(load.position_m[i]) ||
        (i > 0 && !(load.position_m[i] > load.position_m[i - 1])))
      throw twin::TwinParameterError("pass load: positions must increase and forces be finite");
  return std::make_shared<const PairContactData>(PairContactData{g, load, width_factor});
}

TravellingContact with_s_of(std::shared_ptr<const PairContactData> d, std::function<double(double)> s_of,
                            std::function<double(double)> rolling) {
  TravellingContact c;
  c.max_pressure_pa = [d, s_of](double q) { return d->at(s_of(q)).max_pressure_pa; };
  c.half_width_m = [d, s_of](double q) { return d->at(s_of(q)).half_width_m; };
  c.sliding_speed_m_s = [d, s_of](double q) { return d->sliding(s_of(q)); };
  c.rolling_speed_m_s = std::move(rolling);
  return c;
}
}  // namespace

TravellingContact pinion_contact(const twin::GearGeometry& g, const PassLoad& load,
                                 const std::function<double(double)>& width_factor) {
  auto d = make_data(g, load, width_factor);
  const double rb1 = g.base_radius_pinion;
  auto s_of = [rb1](double q) { return std::sqrt(2.0 * rb1 * q); };
  TravellingContact c = with_s_of(d, s_of, s_of);  // v_r1 = ω1 ρ1 = s for ω1 = 1
  c.first = pinion_flank_arc(g, std::max(load.position_m.front(), g.contact_start));
  c.sliding_reversal = pinion_flank_arc(g, g.pitch_radius_pinion * std::sin(g.pressure_angle_rad));
  c.last = pinion_flank_arc(g, std::min(load.position_m.back(), g.contact_end));
  return c;
}

TravellingContact gear_contact(const twin::GearGeometry& g, const PassLoad& load,
                               const std::function<double(double)>& width_factor) {
  auto d = make_data(g, load, width_factor);
  const double rb2 = g.base_radius_gear, L = g.line_of_action_length;
  const double ratio = static_cast<double>(g.spec.pinion_teeth) / g.spec.gear_teeth;  // ω2 / ω1
  auto s_of = [rb2, L](double q) { return L - std::sqrt(2.0 * rb2 * q); };
  TravellingContact c = with_s_of(d, s_of, [s_of, L, ratio](double q) { return ratio * (L - s_of(q)); });
  // The gear's flank is met from its tip (pinion root side) down to its root.
  c.first = gear_flank_arc(g, std::min(load.position_m.back(), g.contact_end));
  c.sliding_reversal = gear_flank_arc(g, g.pitch_radius_pinion * std::sin(g.pressure_angle_rad));
  c.last = gear_flank_arc(g, std::max(load.position_m.front(), g.contact_start));
  return c;
}

std::vector<double> pinion_profile_points(const twin::GearGeometry& g, int points) {
  std::vector<double> x(static_cast<std::size_t>(points));
  for (int j = 0; j < points; ++j)
    x[static_cast<std::size_t>(j)] = pinion_flank_arc(g, g.contact_start + g.active_length() * j / (points - 1));
  return x;
}

std::vector<double> gear_profile_points(const twin::GearGeometry& g, int points) {
  std::vector<double> x(static_cast<std::size_t>(points));
  for (int j = 0; j < points; ++j)
    x[static_cast<std::size_t>(j)] = gear_flank_arc(g, g.contact_end - g.active_length() * j / (points - 1));
  return x;
}

PassWear pass_wear(const twin::GearGeometry& g, const PassLoad& load, double k_wear_si, int points,
                   const std::function<double(double)>& width_factor) {
  if (points < 2) throw twin::TwinParameterError("wear profile needs at least 2 points");
  PassWear out;
  out.pinion_m = archard_wear_depth(pinion_contact(g, load, width_factor), pinion_profile_points(g, points), k_wear_si);
  out.gear_m = archard_wear_depth(gear_contact(g, load, width_factor), gear_profile_points(g, points), k_wear_si);
  return out;
}

}  // namespace gearwatch::wear
