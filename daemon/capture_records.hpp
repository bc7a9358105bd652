#pragma once
// A capture file cut into records as `replay` cuts them ([records]): the analysable ones, in order.
#include <string>
#include <vector>

#include "gearwatch/config/config.hpp"
#include "gearwatch/types/record.hpp"

namespace gearwatch::daemon {

/// Throws std::runtime_error with a one-line reason: a missing file or a device, a read error, or
/// no record of at least records.min_length_s.
std::vector<Record> read_capture_records(const std::string& capture, const config::GearwatchConfig& cfg);

}  // namespace gearwatch::daemon
