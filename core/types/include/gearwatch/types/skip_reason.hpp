#pragma once
// Why an indicator was not computed for a record. The tokens cross into the database (and the
// daemon turns some into sensor alerts), so this enum is their single source of truth: storage
// can build its CHECK list from kAllSkipReasons. Existing tokens never change spelling.
#include <array>
#include <optional>
#include <string_view>

namespace gearwatch::dsp {

enum class SkipReason {
  empty_record,           ///< the channel has no samples
  bad_sample_rate,        ///< sample rate not finite and positive
  non_finite_samples,     ///< a NaN or Inf sample
  clipped_samples,        ///< more than max_clipped_fraction of samples at full scale
  flat_line,              ///< samples (near-)constant: standard deviation below flat_line_max_std_lsb
  no_tacho,               ///< no tacho edges on any configured shaft
  too_few_edges,          ///< fewer edges than one revolution
  tacho_irregular,        ///< non-finite / non-increasing edges, or a missed or extra edge
  speed_out_of_range,     ///< a revolution outside the rig's speed range
  too_few_revolutions,    ///< a shaft has fewer than min_revolutions_for_tsa whole revolutions
  above_nyquist,          ///< a mesh harmonic above the TSA's Nyquist order
  band_above_nyquist,     ///< a fixed band or mean-carrier range above the record's Nyquist
  band_empty,             ///< a fixed band holds no spectrum bin
  band_below_floor,       ///< a fixed band's energy below band_energy_floor_db
  residual_below_floor,   ///< residual RMS below residual_rms_floor x raw RMS
  all_bands_below_floor,  ///< no band of the tree (within Nyquist) above band_energy_floor_db
  non_finite_result,      ///< the computation gave NaN or Inf
  filter_bank_error,      ///< the filter bank refused the signal (detail: its message)
  analysis_error,         ///< an unexpected failure (detail: its message)
  not_computed,           ///< not reached (should not happen; kept so every name has a reason)
  no_life_counter,        ///< wear_mechanism: the record has no place in the pair's life (no life counter yet)
  cycle_count_fault,      ///< wear_mechanism: the record's revolutions failed their check (detail: which, with the numbers)
};

inline constexpr std::array kAllSkipReasons{
    SkipReason::empty_record,       SkipReason::bad_sample_rate,       SkipReason::non_finite_samples,
    SkipReason::clipped_samples,    SkipReason::flat_line,             SkipReason::no_tacho,
    SkipReason::too_few_edges,      SkipReason::tacho_irregular,       SkipReason::speed_out_of_range,
    SkipReason::too_few_revolutions, SkipReason::above_nyquist,        SkipReason::band_above_nyquist,
    SkipReason::band_empty,         SkipReason::band_below_floor,      SkipReason::residual_below_floor,
    SkipReason::all_bands_below_floor, SkipReason::non_finite_result,  SkipReason::filter_bank_error,
    SkipReason::analysis_error,     SkipReason::not_computed,          SkipReason::no_life_counter,
    SkipReason::cycle_count_fault,
};

/// The stored snake_case token, e.g. "no_tacho".
const char* to_string(SkipReason reason) noexcept;

/// Something true of an indicator that WAS computed, and that its value depends on (stored beside
/// the skip reasons, vocabulary domain indicator_note). Existing tokens never change spelling.
enum class IndicatorNote {
  band_trimmed,   ///< a fixed carrier band reaching past 0.45·fs, analysed up to there (detail: the band used)
};
inline constexpr std::array kAllIndicatorNotes{IndicatorNote::band_trimmed};
const char* to_string(IndicatorNote note) noexcept;

/// The reason whose token is `token`, or nullopt (e.g. for reading stored tokens back).
std::optional<SkipReason> parse_skip_reason(std::string_view token) noexcept;

}  // namespace gearwatch::dsp
