#include "replay_resume.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <system_error>
#include <vector>

#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::daemon {
namespace {

std::string resolved(const std::string& path) {
  std::error_code ec;
  auto p = std::filesystem::weakly_canonical(path, ec);
  return ec ? path : p.string();
}

// The same capture gives the same numbers; the tolerance absorbs a REAL's round trip and the
// order of a sum, nothing a different signal could fall within.
bool same(std::optional<double> stored, double now) {
  if (!std::isfinite(now)) return !stored.has_value();  // NaN/unknown is stored as NULL
  return stored && std::abs(*stored - now) <= 1e-9 * std::max(1.0, std::abs(now));
}

}  // namespace

ReplayResume ReplayResume::load(const std::string& database, const std::string& capture) {
  ReplayResume resume;
  std::error_code ec;
  if (!std::filesystem::exists(database, ec)) return resume;
  storage::Database db(database, storage::Database::Mode::read_only);
  if (db.user_version() == 0) return resume;  // created but never migrated: nothing stored
  // Earlier runs name the capture as they were given it (relative or absolute).
  const std::string wanted = resolved(capture);
  std::vector<std::int64_t> runs;
  {
    storage::Statement st(db, "SELECT id, source FROM runs");
    while (st.step())
      if (st.get_text(1) == capture || resolved(st.get_text(1)) == wanted) runs.push_back(st.get_int(0));
  }
  storage::Statement st(db, R"SQL(
    SELECT s.sequence, s.stream_id, r.start_index, r.sample_count, r.input_revolutions, r.speed_hz, r.torque_nm,
           (SELECT v.channel FROM indicator_values v WHERE v.record_id = r.id AND v.name = 'rms_raw' ORDER BY v.channel LIMIT 1),
           (SELECT v.value FROM indicator_values v WHERE v.record_id = r.id AND v.name = 'rms_raw' ORDER BY v.channel LIMIT 1)
    FROM records r JOIN streams s ON s.id = r.stream_key WHERE s.run_id = ?)SQL");
  for (const auto run : runs) {
    st.bind(1, run);
    while (st.step()) {
      auto optional = [&](int col) { return st.is_null(col) ? std::nullopt : std::optional<double>(st.get_double(col)); };
      const auto sequence = static_cast<std::uint64_t>(st.get_int(0));
      const auto stream_id = static_cast<std::uint16_t>(st.get_int(1));
      const auto start = static_cast<std::uint64_t>(st.get_int(2));
      const auto count = static_cast<std::uint64_t>(st.get_int(3));
      auto& stored = resume.records_[{sequence, stream_id, start}];
      if (count >= stored.sample_count) {
        stored = Stored{count, optional(4), optional(5), optional(6), st.is_null(7) ? -1 : static_cast<int>(st.get_int(7)),
                        st.is_null(8) ? 0.0 : st.get_double(8)};
      }
      auto& until = resume.stored_until_[{sequence, stream_id}];
      until = std::max(until, start + count);
    }
    st.reset();
  }
  return resume;
}

bool ReplayResume::stored(std::uint64_t sequence, const Record& record) const {
  const auto it = records_.find({sequence, record.stream_id, record.start_index});
  if (it == records_.end()) return false;
  const Stored& s = it->second;
  if (s.sample_count < record.sample_count()) return false;
  if (!same(s.input_revolutions, record.input_revolutions.value_or(std::nan("")))) return false;
  if (!same(s.speed_hz, record.speed_hz) || !same(s.torque_nm, record.torque_nm)) return false;
  if (s.rms_channel < 0) return true;
  // The samples themselves: the RMS of the channel whose rms_raw was stored.
  for (std::size_t c = 0; c < record.channel_numbers.size(); ++c) {
    if (record.channel_numbers[c] != s.rms_channel) continue;
    double sum2 = 0.0;
    for (const float v : record.channels[c]) sum2 += static_cast<double>(v) * v;
    const double rms = std::sqrt(sum2 / static_cast<double>(record.channels[c].size()));
    return std::abs(rms - s.rms_raw) <= 1e-6 * std::max(1e-12, std::abs(s.rms_raw));
  }
  return false;  // that channel is not in this record: not the same record
}

bool ReplayResume::before_resume_point(std::uint64_t sequence, std::uint16_t stream_id, std::uint64_t index) const {
  const auto it = stored_until_.find({sequence, stream_id});
  return it != stored_until_.end() && index < it->second;
}

}  // namespace gearwatch::daemon
