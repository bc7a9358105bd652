#pragma once
// Shared by storage's JSON columns (not a public header): doubles to JSON and back. JSON has no NaN
// or infinity, so a non-finite value is written as null and null is read back as NaN.
#include <cmath>
#include <limits>
#include <vector>

#include <nlohmann/json.hpp>

namespace gearwatch::storage::detail {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

inline nlohmann::json json_number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }
inline double number_from_json(const nlohmann::json& j) { return j.is_null() ? kNaN : j.get<double>(); }

inline nlohmann::json json_numbers(const std::vector<double>& values) {
  nlohmann::json a = nlohmann::json::array();
  for (double v : values) a.push_back(json_number(v));
  return a;
}
inline std::vector<double> numbers_from_json(const nlohmann::json& j) {
  std::vector<double> out;
  out.reserve(j.size());
  for (const auto& v : j) out.push_back(number_from_json(v));
  return out;
}

}  // namespace gearwatch::storage::detail
