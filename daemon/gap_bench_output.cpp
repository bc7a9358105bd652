#include "gap_bench_output.hpp"

#include <cmath>
#include <iomanip>
#include <iostream>
#include <limits>
#include <sstream>

#include "cli_common.hpp"

namespace gearwatch::cli {

double fraction(int part, int whole) {
  return whole ? static_cast<double>(part) / whole : std::numeric_limits<double>::quiet_NaN();
}

nlohmann::json number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

nlohmann::json bench_document(const BenchRunSettings& run) {
  nlohmann::json j;
  j["seeds"] = run.seeds;
  j["sample_rate_hz"] = run.sample_rate_hz;
  j["record_seconds"] = run.record_seconds;
  j["torques_nm"] = run.torques_nm;
  j["wall_seconds"] = run.wall_seconds;
  return j;
}

std::ostringstream table_stream() {
  std::ostringstream s;
  s << std::fixed << std::setprecision(2);
  return s;
}

void BenchPrinter::progress(std::uint64_t seed, const std::string& what, double seconds) const {
  std::cerr << "seed " << seed << " " << what << " done in " << std::fixed << std::setprecision(1) << seconds << " s\n";
}

void BenchPrinter::print(const nlohmann::json& document, const BenchTable& table) const {
  if (json()) {
    std::cout << dump_json(document, 2) << "\n";
    return;
  }
  std::cout << table.heading << "\n" << table.columns << "\n";
  for (const auto& r : table.rows) std::cout << r << "\n";
  for (const auto& s : table.summary) std::cout << s << "\n";
}

}  // namespace gearwatch::cli
