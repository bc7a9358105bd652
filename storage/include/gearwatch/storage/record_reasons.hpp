#pragma once
// Typed readers of what the records say about themselves (docs/storage.md, docs/report.md): the
// records with how they ended and where their shaft angle came from, the names the runs' configs
// gave the channels, why indicators were skipped or computed with a caveat, and the newest wear
// verdict per channel with the band it could not see. Every stored token comes back as its enum;
// a token this build does not know is refused (std::runtime_error naming the row), since the
// vocabulary triggers let no other token in. Older schemas read as far as they go: a table or
// column they lack reads as empty.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gearwatch/storage/sqlite.hpp"
#include "gearwatch/types/record.hpp"
#include "gearwatch/types/skip_reason.hpp"
#include "gearwatch/types/speed_source.hpp"
#include "gearwatch/types/wear_mechanism.hpp"

namespace gearwatch::storage {

struct RecordSummary {
  std::int64_t id = 0;
  std::optional<double> input_revolutions;     ///< NULL without a life counter
  std::string created_at;
  bool analysed = false;
  RecordEnd end_reason = RecordEnd::complete;  ///< why the record ended where it did
  std::optional<dsp::SpeedSource> speed_source;  ///< nullopt: nothing order-domain was computed
};

/// Every record, by id.
std::vector<RecordSummary> load_record_summaries(Database& db);

/// A channel's configured name: the newest run that named it, and the other names earlier runs
/// gave it (newest first), so a renamed channel is not mistaken for a new one.
struct ChannelNaming {
  std::int64_t channel = 0;
  std::string name;
  std::vector<std::string> earlier_names;
};

/// Every channel any run named (table run_channels, schema version 10), by channel number.
std::vector<ChannelNaming> load_channel_names(Database& db);

/// One indicator of one record and channel that was not computed (table indicator_skips).
struct IndicatorSkip {
  std::int64_t record_id = 0;
  std::int64_t channel = 0;
  std::string indicator;
  dsp::SkipReason reason = dsp::SkipReason::not_computed;
  std::string detail;  ///< "" when none was stored
};

/// The skips of the records with id >= first_record, by record, channel and indicator.
std::vector<IndicatorSkip> load_indicator_skips(Database& db, std::int64_t first_record);

/// One indicator that was computed with a caveat its value depends on (table indicator_notes).
struct IndicatorCaveat {
  std::int64_t record_id = 0;
  std::int64_t channel = 0;
  std::string indicator;
  dsp::IndicatorNote note = dsp::IndicatorNote::band_trimmed;
  std::string detail;
};

/// The caveats of the records with id >= first_record, by record, channel and indicator.
std::vector<IndicatorCaveat> load_indicator_caveats(Database& db, std::int64_t first_record);

/// A wear-mechanism verdict (view wear_mechanism).
struct StoredWearVerdict {
  std::int64_t channel = 0;
  std::int64_t record_id = 0;
  dsp::WearMechanism mechanism = dsp::WearMechanism::undetermined;
  std::int64_t points = 0;
  std::string created_at;
  std::optional<double> cycles;
  std::string evidence;
  std::optional<dsp::CarrierBand> unseen_band;  ///< the band above the records' 0.45·fs
};

/// The newest verdict of each channel, by channel.
std::vector<StoredWearVerdict> load_newest_wear_verdicts(Database& db);

}  // namespace gearwatch::storage
