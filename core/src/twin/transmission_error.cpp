#include "gearwatch/twin/transmission_error.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "gearwatch/twin/errors.hpp"

namespace gearwatch::twin {
namespace {
void check_profile(const std::vector<double>& table, const std::string& what) {
  if (table.empty()) return;
  if (table.size() < 2) throw TwinParameterError(what + ": a profile deviation needs at least 2 points");
  for (double v : table)
    if (!std::isfinite(v) || std::abs(v) > 1e-3)
      throw TwinParameterError(what + ": deviation values must be finite and below 1 mm in magnitude");
}
bool all_zero(const std::vector<double>& t) {
  return std::all_of(t.begin(), t.end(), [](double v) { return v == 0.0; });
}
}  // namespace

GeometricTransmissionError::GeometricTransmissionError(const GearGeometry& geometry, ToothProfileDeviation deviation)
    : geometry_(geometry), deviation_(std::move(deviation)) {
  check_profile(deviation_.pinion, "pinion");
  check_profile(deviation_.gear, "gear");
  if (!deviation_.pinion_per_tooth.empty() &&
      deviation_.pinion_per_tooth.size() != static_cast<std::size_t>(geometry_.spec.pinion_teeth))
    throw TwinParameterError("per-tooth pinion deviations: expected one profile per tooth (" +
                             std::to_string(geometry_.spec.pinion_teeth) + ")");
  if (!deviation_.gear_per_tooth.empty() &&
      deviation_.gear_per_tooth.size() != static_cast<std::size_t>(geometry_.spec.gear_teeth))
    throw TwinParameterError("per-tooth gear deviations: expected one profile per tooth (" +
                             std::to_string(geometry_.spec.gear_teeth) + ")");
  for (const auto& t : deviation_.pinion_per_tooth) check_profile(t, "pinion tooth");
  for (const auto& t : deviation_.gear_per_tooth) check_profile(t, "gear tooth");
  zero_ = all_zero(deviation_.pinion) && all_zero(deviation_.gear);
  for (const auto& t : deviation_.pinion_per_tooth) zero_ = zero_ && all_zero(t);
  for (const auto& t : deviation_.gear_per_tooth) zero_ = zero_ && all_zero(t);
}

double GeometricTransmissionError::sample(const std::vector<double>& table, double u) {
  if (table.empty()) return 0.0;
  u = std::clamp(u, 0.0, 1.0) * static_cast<double>(table.size() - 1);
  const std::size_t i = std::min(static_cast<std::size_t>(u), table.size() - 2);
  const double f = u - static_cast<double>(i);
  return table[i] + f * (table[i + 1] - table[i]);
}

double GeometricTransmissionError::slope(const std::vector<double>& table, double u) {
  if (table.empty() || u < 0.0 || u > 1.0) return 0.0;
  const double pos = u * static_cast<double>(table.size() - 1);
  const std::size_t i = std::min(static_cast<std::size_t>(pos), table.size() - 2);
  return (table[i + 1] - table[i]) * static_cast<double>(table.size() - 1);  // per unit fraction
}

const std::vector<double>& GeometricTransmissionError::pinion_table(int tooth) const {
  if (deviation_.pinion_per_tooth.empty()) return deviation_.pinion;
  const int n = static_cast<int>(deviation_.pinion_per_tooth.size());
  return deviation_.pinion_per_tooth[static_cast<std::size_t>(((tooth % n) + n) % n)];
}

const std::vector<double>& GeometricTransmissionError::gear_table(int tooth) const {
  if (deviation_.gear_per_tooth.empty()) return deviation_.gear;
  const int n = static_cast<int>(deviation_.gear_per_tooth.size());
  return deviation_.gear_per_tooth[static_cast<std::size_t>(((tooth % n) + n) % n)];
}

double GeometricTransmissionError::pair_error(double s, int pinion_tooth, int gear_tooth) const {
  if (zero_) return 0.0;
  return -(sample(pinion_table(pinion_tooth), geometry_.profile_fraction_pinion(s)) +
           sample(gear_table(gear_tooth), geometry_.profile_fraction_gear(s)));
}

double GeometricTransmissionError::pair_error_slope(double s, int pinion_tooth, int gear_tooth) const {
  if (zero_) return 0.0;
  const double length = geometry_.active_length();
  // u_p = (s − s0)/L rises with s, u_g = (s_end − s)/L falls with s.
  return -(slope(pinion_table(pinion_tooth), geometry_.profile_fraction_pinion(s)) / length -
           slope(gear_table(gear_tooth), geometry_.profile_fraction_gear(s)) / length);
}

double GeometricTransmissionError::kinematic_error(const double* positions, int pair_count) const {
  if (pair_count <= 0) return 0.0;
  double e = pair_error(positions[0], 0, 0);
  for (int i = 1; i < pair_count; ++i) e = std::max(e, pair_error(positions[i], 0, 0));
  return e;
}

namespace {
// A profile table (root → tip, uniformly spaced) read at u ∈ [0, 1] by linear interpolation.
double profile_at(const std::vector<double>& table, double u) {
  if (table.empty()) return 0.0;
  if (table.size() == 1) return table.front();
  const double x = std::clamp(u, 0.0, 1.0) * static_cast<double>(table.size() - 1);
  const auto i = std::min(static_cast<std::size_t>(x), table.size() - 2);
  const double t = x - static_cast<double>(i);
  return (1 - t) * table[i] + t * table[i + 1];
}

std::vector<double> relieved(const std::vector<double>& table, double amount, double length, std::size_t points) {
  const std::size_t n = std::max(points, table.size());
  std::vector<double> out(n);
  for (std::size_t j = 0; j < n; ++j) {
    const double u = static_cast<double>(j) / static_cast<double>(n - 1);
    out[j] = profile_at(table, u) + amount * std::max(0.0, (u - (1.0 - length)) / length);
  }
  return out;
}
}  // namespace

ToothProfileDeviation with_linear_tip_relief(const ToothProfileDeviation& base, double amount_m, double length_fraction,
                                             std::size_t points) {
  if (!std::isfinite(amount_m) || amount_m < 0) throw TwinParameterError("tip relief amount must be finite and >= 0");
  if (!(length_fraction > 0 && length_fraction <= 1)) throw TwinParameterError("tip relief length must lie in (0, 1]");
  points = std::max<std::size_t>(points, 2);
  ToothProfileDeviation out;
  out.pinion = relieved(base.pinion, amount_m, length_fraction, points);
  out.gear = relieved(base.gear, amount_m, length_fraction, points);
  for (const auto& t : base.pinion_per_tooth) out.pinion_per_tooth.push_back(relieved(t, amount_m, length_fraction, points));
  for (const auto& t : base.gear_per_tooth) out.gear_per_tooth.push_back(relieved(t, amount_m, length_fraction, points));
  return out;
}

}  // namespace gearwatch::twin
