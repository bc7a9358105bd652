#include "gearwatch/acquisition/daq_import.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace gearwatch::acquisition {

std::string_view to_string(SampleUnit unit) {
  switch (unit) {
    case SampleUnit::m_s2: return "m/s2";
    case SampleUnit::g: return "g";
    case SampleUnit::volt: return "V";
  }
  return "unknown";
}

std::optional<SampleUnit> parse_sample_unit(std::string_view text) {
  if (text == "m/s2" || text == "m/s^2" || text == "m/s²") return SampleUnit::m_s2;
  if (text == "g") return SampleUnit::g;
  if (text == "V") return SampleUnit::volt;
  return std::nullopt;
}

double m_s2_per_file_unit(const SampleScaling& s) {
  if (!std::isfinite(s.scale) || s.scale == 0.0) throw DaqFileError("--scale must be a finite number other than 0");
  switch (s.unit) {
    case SampleUnit::m_s2: return s.scale;
    case SampleUnit::g: return s.scale * kStandardGravity;
    case SampleUnit::volt:
      if (!(s.sensitivity_mv_per_g > 0) || !std::isfinite(s.sensitivity_mv_per_g))
        throw DaqFileError("--unit V needs the accelerometer's --sensitivity in mV/g (a positive number)");
      // V → g: 1000 / (mV/g); g → m/s².
      return s.scale * 1000.0 / s.sensitivity_mv_per_g * kStandardGravity;
  }
  return s.scale;
}

std::vector<double> detect_tacho_edges(std::span<const double> tacho) {
  std::vector<double> edges;
  if (tacho.size() < 2) return edges;
  const auto [lo_it, hi_it] = std::minmax_element(tacho.begin(), tacho.end());
  const double lo = *lo_it, hi = *hi_it, range = hi - lo;
  if (!(range > 0)) return edges;
  const double mid = lo + 0.5 * range, low = mid - 0.1 * range, high = mid + 0.1 * range;
  bool armed = tacho[0] < low;  // the signal starting high is not an edge: its rise was not seen
  std::size_t last_below_mid = 0;
  for (std::size_t i = 0; i < tacho.size(); ++i) {
    const double x = tacho[i];
    if (x < low) armed = true;
    if (x < mid) last_below_mid = i;
    if (armed && x > high) {
      // The crossing of mid between the last sample below it and the next one.
      const std::size_t k = last_below_mid;
      const double a = tacho[k], b = tacho[k + 1];
      edges.push_back(static_cast<double>(k) + (mid - a) / (b - a));
      armed = false;
    }
  }
  return edges;
}

double speed_from_edges(std::span<const double> edges, int edges_per_rev, double fs, double from, double to) {
  const auto first = std::lower_bound(edges.begin(), edges.end(), from);
  const auto last = std::lower_bound(edges.begin(), edges.end(), to);
  if (last - first < 2) return std::numeric_limits<double>::quiet_NaN();
  const double span = *(last - 1) - *first;
  return static_cast<double>(last - first - 1) / edges_per_rev * fs / span;
}

void check_channel_fits(const DaqRecording& r, std::size_t channel, double m_s2_per_unit, double lsb_m_s2) {
  const auto& x = r.channels.at(channel);
  const std::string& name = r.names.at(channel);
  const double limit = 32767.5 * lsb_m_s2;  // what rounds into the i16 range
  char text[320];
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i])) {
      std::snprintf(text, sizeof text, "channel %s: sample %zu is not a number (%g): a recording with gaps or NaN is not imported",
                    name.c_str(), i, x[i]);
      throw DaqFileError(text);
    }
    if (std::isfinite(r.full_scale) && std::fabs(x[i]) >= r.full_scale) {
      std::snprintf(text, sizeof text, "channel %s: sample %zu sits at the file's full scale: the recording is clipped",
                    name.c_str(), i);
      throw DaqFileError(text);
    }
    const double a = x[i] * m_s2_per_unit;
    if (std::fabs(a) >= limit) {
      std::snprintf(text, sizeof text,
                    "channel %s: sample %zu is %g m/s2, beyond the capture's +-%g m/s2 at %g m/s2 per LSB "
                    "(a coarser [[channels]] scale in --config carries it)",
                    name.c_str(), i, a, 32767 * lsb_m_s2, lsb_m_s2);
      throw DaqFileError(text);
    }
  }
}

double check_rate_and_length(const DaqRecording& r, double given, double min_seconds) {
  const double from_file = r.sample_rate_hz;
  char text[320];
  double fs = from_file;
  if (std::isfinite(given)) {
    // The file's own rate wins unless they agree: a wrong --sample-rate would stretch every
    // frequency silently.
    if (std::isfinite(from_file) && std::fabs(given - from_file) > 1e-6 * from_file) {
      std::snprintf(text, sizeof text, "--sample-rate %.10g Hz disagrees with the %.10g Hz of the %s", given, from_file,
                    std::string(to_string(r.rate_source)).c_str());
      throw DaqFileError(text);
    }
    fs = given;
  }
  if (!std::isfinite(fs))
    throw DaqFileError("the recording carries no sample rate: give it with --sample-rate HZ");
  // The stream header carries whole Hz; a time column's rounding (1e-6 of the rate) is forgiven.
  const double whole = std::round(fs);
  if (std::fabs(fs - whole) > 1e-6 * fs) {
    std::snprintf(text, sizeof text, "sample rate %.10g Hz is not a whole number of Hz (the protocol carries whole Hz)", fs);
    throw DaqFileError(text);
  }
  if (whole < 10000 || whole > 200000) {
    std::snprintf(text, sizeof text, "sample rate %.10g Hz is outside 10-200 kHz, the rates gearwatch analyses", whole);
    throw DaqFileError(text);
  }
  const double seconds = static_cast<double>(r.samples()) / whole;
  if (seconds < min_seconds) {
    std::snprintf(text, sizeof text, "%zu samples at %.10g Hz are %.6g s, shorter than one record (%.6g s, [records] min_length_s)",
                  r.samples(), whole, seconds, min_seconds);
    throw DaqFileError(text);
  }
  return whole;
}

}  // namespace gearwatch::acquisition
