#include "gearwatch/types/dropout_cause.hpp"

namespace gearwatch::acquisition {

const char* to_string(DropoutCause cause) noexcept {
  switch (cause) {
    case DropoutCause::protocol: return "protocol";
    case DropoutCause::ring_overflow: return "ring_overflow";
  }
  return "protocol";
}

}  // namespace gearwatch::acquisition
