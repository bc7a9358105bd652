#pragma once
// What the two gap benches print (`gap bench`, `gap bench --generator independent`;
// docs/gap-bench.md): one JSON document, or for people a heading, a table of one row per group and
// the summary lines, with a progress line per seed on stderr. Each bench builds its own rows; the
// format, the number style and the settings both report are here once.
#include <cstdint>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace gearwatch::cli {

/// part / whole; NaN when whole is 0 (no such draw: not a rate of 0).
double fraction(int part, int whole);
/// A finite number, or null (JSON has no NaN).
nlohmann::json number_or_null(double v);

/// The settings both benches run with, as the document's keys seeds, sample_rate_hz,
/// record_seconds, torques_nm and wall_seconds.
struct BenchRunSettings {
  int seeds = 0;
  double sample_rate_hz = 0;
  double record_seconds = 0;
  std::vector<double> torques_nm;
  double wall_seconds = 0;
};
nlohmann::json bench_document(const BenchRunSettings& run);

/// The table form: numbers fixed with two decimals (cells are written into `row()` and `line()`
/// streams by the bench).
struct BenchTable {
  std::string heading;               ///< first line, without its newline
  std::string columns;               ///< the column names' line, without its newline
  std::vector<std::string> rows;     ///< one per group, without newlines
  std::vector<std::string> summary;  ///< lines after the table, without newlines
};

class BenchPrinter {
 public:
  explicit BenchPrinter(std::string format) : format_(std::move(format)) {}
  bool json() const noexcept { return format_ == "json"; }
  /// "seed 3 <what> done in 12.3 s" on stderr, in either format (the JSON document is alone on
  /// stdout): a long run shows where it is, and what it has scored so far.
  void progress(std::uint64_t seed, const std::string& what, double seconds) const;
  /// The document (format json) or the table, on stdout.
  void print(const nlohmann::json& document, const BenchTable& table) const;

 private:
  std::string format_;
};

/// A stream set up for the table's numbers (fixed, two decimals).
std::ostringstream table_stream();

}  // namespace gearwatch::cli
