#include "gearwatch/types/skip_reason.hpp"

#include "gearwatch/types/token.hpp"

namespace gearwatch::dsp {

const char* to_string(SkipReason reason) noexcept {
  switch (reason) {
    case SkipReason::empty_record: return "empty_record";
    case SkipReason::bad_sample_rate: return "bad_sample_rate";
    case SkipReason::non_finite_samples: return "non_finite_samples";
    case SkipReason::clipped_samples: return "clipped_samples";
    case SkipReason::flat_line: return "flat_line";
    case SkipReason::no_tacho: return "no_tacho";
    case SkipReason::too_few_edges: return "too_few_edges";
    case SkipReason::tacho_irregular: return "tacho_irregular";
    case SkipReason::speed_out_of_range: return "speed_out_of_range";
    case SkipReason::too_few_revolutions: return "too_few_revolutions";
    case SkipReason::above_nyquist: return "above_nyquist";
    case SkipReason::band_above_nyquist: return "band_above_nyquist";
    case SkipReason::band_empty: return "band_empty";
    case SkipReason::band_below_floor: return "band_below_floor";
    case SkipReason::residual_below_floor: return "residual_below_floor";
    case SkipReason::all_bands_below_floor: return "all_bands_below_floor";
    case SkipReason::non_finite_result: return "non_finite_result";
    case SkipReason::filter_bank_error: return "filter_bank_error";
    case SkipReason::analysis_error: return "analysis_error";
    case SkipReason::not_computed: return "not_computed";
    case SkipReason::no_life_counter: return "no_life_counter";
    case SkipReason::cycle_count_fault: return "cycle_count_fault";
  }
  return "unknown";
}

const char* to_string(IndicatorNote note) noexcept {
  switch (note) {
    case IndicatorNote::band_trimmed: return "band_trimmed";
  }
  return "unknown";
}

std::optional<SkipReason> parse_skip_reason(std::string_view token) noexcept {
  return from_token(kAllSkipReasons, token);
}

}  // namespace gearwatch::dsp
