#include "gearwatch/types/indicator.hpp"

namespace gearwatch::dsp {

const char* to_string(Indicator indicator) noexcept {
  switch (indicator) {
    case Indicator::rms_raw: return "rms_raw";
    case Indicator::kurtosis_raw: return "kurtosis_raw";
    case Indicator::speed_mean_hz: return "speed_mean_hz";
    case Indicator::speed_fluctuation: return "speed_fluctuation";
    case Indicator::gmf1_amplitude: return "gmf1_amplitude";
    case Indicator::rms_sa: return "rms_sa";
    case Indicator::rms_residual: return "rms_residual";
    case Indicator::kurtosis_residual: return "kurtosis_residual";
    case Indicator::ics2_full_band: return "ics2_full_band";
    case Indicator::ics2_low_band: return "ics2_low_band";
    case Indicator::ics2_high_band: return "ics2_high_band";
    case Indicator::ics2_selected_band: return "ics2_selected_band";
    case Indicator::kurtosis_selected_band: return "kurtosis_selected_band";
    case Indicator::sc_gmf_max: return "sc_gmf_max";
    case Indicator::sc_gmf_mean: return "sc_gmf_mean";
    case Indicator::sc_gmf_peak_carrier_hz: return "sc_gmf_peak_carrier_hz";
    case Indicator::input_speed_hz: return "input_speed_hz";
  }
  return "unknown";
}

const char* to_string(BandSelectionCriterion criterion) noexcept {
  switch (criterion) {
    case BandSelectionCriterion::ics2: return "ics2";
    case BandSelectionCriterion::kurtosis: return "kurtosis";
  }
  return "unknown";
}

}  // namespace gearwatch::dsp
