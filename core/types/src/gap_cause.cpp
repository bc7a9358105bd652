#include "gearwatch/types/gap_cause.hpp"

namespace gearwatch::acquisition {

const char* to_string(GapCause cause) noexcept {
  switch (cause) {
    case GapCause::protocol: return "protocol";
    case GapCause::ring_overflow: return "ring_overflow";
  }
  return "protocol";
}

}  // namespace gearwatch::acquisition
