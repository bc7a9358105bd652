#include "replay_resume.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <system_error>
#include <vector>

#include "gearwatch/storage/resume.hpp"
#include "gearwatch/storage/sqlite.hpp"

namespace gearwatch::daemon {
namespace {

// Enough of a capture to tell two recordings apart (their first frames carry their timestamps
// and samples), little enough to read at every start.
constexpr std::size_t kIdentityBytes = 1 << 20;

std::string resolved(const std::string& path) {
  std::error_code ec;
  auto p = std::filesystem::weakly_canonical(std::filesystem::absolute(path, ec), ec);
  return ec ? path : p.string();
}

// FNV-1a, 64 bits: not a defence against a forged capture, only against mistaking one recording
// for another.
std::uint64_t fnv1a64(const char* data, std::size_t n, std::uint64_t h = 0xcbf29ce484222325ULL) {
  for (std::size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 0x100000001b3ULL;
  }
  return h;
}

// The same capture gives the same numbers; the tolerance absorbs a REAL's round trip and the
// order of a sum, nothing a different signal could fall within.
bool same(std::optional<double> stored, double now) {
  if (!std::isfinite(now)) return !stored.has_value();  // NaN/unknown is stored as NULL
  return stored && std::abs(*stored - now) <= 1e-9 * std::max(1.0, std::abs(now));
}

}  // namespace

CaptureIdentity identify_capture(const std::string& path) {
  CaptureIdentity id{resolved(path), ""};
  // Only a regular file can be read twice: reading the head of a FIFO (a capture streamed in)
  // would take its first frames away from the source. A stream has no identity to resume by.
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return id;
  std::ifstream in(path, std::ios::binary);
  if (!in) return id;
  std::vector<char> head(kIdentityBytes);
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  const auto n = static_cast<std::size_t>(in.gcount());
  if (in.bad()) return id;
  char text[64];
  std::snprintf(text, sizeof text, "fnv1a64:%016llx:%zu", static_cast<unsigned long long>(fnv1a64(head.data(), n)), n);
  id.content_id = text;
  return id;
}

ReplayResume ReplayResume::load(const std::string& database, const CaptureIdentity& capture) {
  ReplayResume resume;
  std::error_code ec;
  if (!std::filesystem::exists(database, ec)) return resume;
  storage::Database db(database, storage::Database::Mode::read_only);
  if (db.user_version() == 0) return resume;  // created but never migrated: nothing stored
  for (const auto& run : storage::load_runs(db)) {
    // A run that knows its capture's identity is matched by it alone; an older one by its path.
    const bool same_capture = run.capture_id ? !capture.content_id.empty() && *run.capture_id == capture.content_id
                                             : run.source == capture.path || resolved(run.source) == capture.path;
    if (!same_capture) continue;
    for (const auto& r : storage::load_run_records(db, run.id)) {
      auto& stored = resume.records_[{r.stream_sequence, r.stream_id, r.start_index}];
      if (r.sample_count >= stored.sample_count)
        stored = Stored{r.sample_count, r.input_revolutions, r.speed_hz, r.torque_nm, r.rms_channel.value_or(-1), r.rms_raw};
      auto& until = resume.stored_until_[{r.stream_sequence, r.stream_id}];
      until = std::max(until, r.start_index + r.sample_count);
    }
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
