#pragma once
// The indicators with a fixed name (docs/dsp.md): stored by their to_string in indicator_values.name,
// read back by the model thread, the processing thread, the twin and the report by the same value.
// The indicators named by a parameter (gmf_harmonic_<h>, mean_carrier_hz_<low>_<high>) are named
// by dsp/record_analyzer.hpp. Existing names never change spelling.
#include <array>
#include <cstdint>
#include <string_view>

namespace gearwatch::dsp {

enum class Indicator : std::uint8_t {
  rms_raw,                ///< RMS of the raw signal
  kurtosis_raw,           ///< kurtosis of the raw signal
  speed_mean_hz,          ///< mean input-shaft speed over the whole revolutions
  speed_fluctuation,      ///< (fastest − slowest) / mean revolution speed
  gmf1_amplitude,         ///< amplitude of the first mesh harmonic in the TSA
  rms_sa,                 ///< RMS_SA: RMS of the first N mesh harmonics (Eq. 7.1)
  rms_residual,           ///< RMS of the residual
  kurtosis_residual,      ///< kurtosis of the residual
  ics2_full_band,         ///< ICS2 of the whole residual band
  ics2_low_band,          ///< ICS2 in the pitting (low) carrier band
  ics2_high_band,         ///< ICS2 in the abrasion (high) carrier band
  ics2_selected_band,     ///< ICS2 in the band the filter bank selected
  kurtosis_selected_band, ///< kurtosis in the band the kurtogram selected (when enabled)
  sc_gmf_max,             ///< spectral coherence at the mesh order: maximum over the carriers
  sc_gmf_mean,            ///< ... its mean
  sc_gmf_peak_carrier_hz, ///< ... the carrier of its maximum
  input_speed_hz,         ///< the tacho's mean input speed, stored by the daemon beside the analysis's indicators
};
inline constexpr std::array kAllIndicators{
    Indicator::rms_raw,
    Indicator::kurtosis_raw,
    Indicator::speed_mean_hz,
    Indicator::speed_fluctuation,
    Indicator::gmf1_amplitude,
    Indicator::rms_sa,
    Indicator::rms_residual,
    Indicator::kurtosis_residual,
    Indicator::ics2_full_band,
    Indicator::ics2_low_band,
    Indicator::ics2_high_band,
    Indicator::ics2_selected_band,
    Indicator::kurtosis_selected_band,
    Indicator::sc_gmf_max,
    Indicator::sc_gmf_mean,
    Indicator::sc_gmf_peak_carrier_hz,
    Indicator::input_speed_hz,
};
/// The stored name, e.g. "rms_sa".
const char* to_string(Indicator indicator) noexcept;

/// The stored name's prefix of the mean-carrier indicators, "mean_carrier_hz_<low>_<high>"
/// (dsp/record_analyzer.hpp names them; the report and storage find them by it).
inline constexpr std::string_view kMeanCarrierIndicatorPrefix = "mean_carrier_hz_";

/// The criterion a band of the filter-bank tree was selected by (stored as its to_string in
/// band_selections.criterion; the filter bank's criteria carry the same names). Existing names
/// never change spelling.
enum class BandSelectionCriterion : std::uint8_t {
  ics2,       ///< ICS2 of the band's squared envelope (ics2_selected_band)
  kurtosis,   ///< the kurtogram's kurtosis (kurtosis_selected_band, when enabled)
};
inline constexpr std::array kAllBandSelectionCriteria{BandSelectionCriterion::ics2, BandSelectionCriterion::kurtosis};
/// The stored name, e.g. "ics2".
const char* to_string(BandSelectionCriterion criterion) noexcept;

}  // namespace gearwatch::dsp
