#include "gearwatch/types/speed_source.hpp"

namespace gearwatch::dsp {

const char* to_string(SpeedSource source) noexcept {
  switch (source) {
    case SpeedSource::tacho: return "tacho";
    case SpeedSource::signal_estimate: return "signal_estimate";
  }
  return "unknown";
}

}  // namespace gearwatch::dsp
