#include "gearwatch/record.hpp"

namespace gearwatch {

const char* to_string(RecordEnd end) noexcept {
  switch (end) {
    case RecordEnd::complete: return "complete";
    case RecordEnd::cut_at_gap: return "cut_at_gap";
    case RecordEnd::stream_end: return "stream_end";
  }
  return "unknown";
}

}  // namespace gearwatch
