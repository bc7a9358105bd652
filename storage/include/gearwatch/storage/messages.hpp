#pragma once
// What the processing thread asks the writer to store. Plain values.
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "gearwatch/storage/gap_kept_records.hpp"
#include "gearwatch/types/alerts.hpp"
#include "gearwatch/types/dropout_cause.hpp"
#include "gearwatch/types/gap_report.hpp"
#include "gearwatch/types/model_run.hpp"
#include "gearwatch/types/record.hpp"
#include "gearwatch/types/speed_source.hpp"
#include "gearwatch/types/wear_mechanism.hpp"

namespace gearwatch::storage {

/// An accelerometer channel as the run's config names it ([[channels]] number and name).
struct ChannelName {
  int channel = 0;
  std::string name;
};

struct RunStarted {
  std::string kind;         ///< "run" or "replay"
  std::string source;       ///< interface name or the capture's canonical absolute path
  std::string config_path;
  std::string capture_id;   ///< the capture's content identity ("" for an interface: stored as NULL)
  std::vector<ChannelName> channels;  ///< the configured channels' names (table run_channels)
};

struct RunEnded {
  std::string reason;       ///< "" for a normal end
};

struct StreamStarted {
  std::uint64_t sequence = 0;
  std::uint16_t stream_id = 0;
  std::uint32_t sample_rate_hz = 0;
  std::uint8_t channel_count = 0;
};

struct BandSelectionRow {
  std::string criterion;
  double level = 0, centre_hz = 0, bandwidth_hz = 0, value = 0;
};

struct SkippedRow {
  std::string name;     ///< indicator
  std::string reason;   ///< a skip_reason token
  std::string detail;   ///< free text ("" = none)
};

struct NoteRow {
  std::string name;     ///< indicator
  std::string note;     ///< an indicator_note token
  std::string detail;   ///< free text ("" = none)
};

struct ChannelResult {
  int channel = 0;
  std::vector<std::pair<std::string, double>> values;
  std::vector<SkippedRow> skipped;
  std::vector<NoteRow> notes;
  std::vector<BandSelectionRow> bands;
};

struct WearAssessment {
  int channel = 0;
  dsp::WearMechanism mechanism = dsp::WearMechanism::undetermined;
  std::uint64_t points = 0;
  double low_band_p = 1, high_band_p = 1, low_band_rho = 0, high_band_rho = 0;
  std::uint64_t band_jumps = 0;
  std::string evidence;
  std::optional<dsp::CarrierBand> unseen_band;   ///< the band the verdict could not see
};

struct RecordResult {
  std::uint64_t stream_sequence = 0;
  std::uint64_t start_index = 0;
  std::uint64_t sample_count = 0;
  double duration_s = 0;
  RecordEnd end_reason = RecordEnd::complete;
  bool analysed = false;
  std::string reject_reason;              ///< why not analysed ("" when analysed)
  double torque_nm = 0, speed_hz = 0;     ///< NaN when unknown (stored as NULL)
  std::optional<double> input_revolutions;
  /// Where the analysed shaft angle came from (nullopt: neither, nothing order-domain computed),
  /// and the signal estimate's mean input speed when there was one (NaN = none; both stored NULL).
  std::optional<dsp::SpeedSource> speed_source;
  double estimated_speed_hz = std::numeric_limits<double>::quiet_NaN();
  std::vector<ChannelResult> channels;
  std::vector<WearAssessment> assessments;
  /// Alert transitions caused by this record (stored with its id) and the alert states they
  /// leave behind (stored in the same transaction, so a restart resumes exactly here).
  std::vector<AlertEvent> alerts;
  std::vector<std::pair<AlertKey, AlertState>> alert_states;
};

/// Alert transitions not tied to a record (a sensor missing from the stream, a counter reset).
struct AlertUpdate {
  std::vector<AlertEvent> alerts;
  std::vector<std::pair<AlertKey, AlertState>> alert_states;
};

/// Samples missing from a stream (acquisition's dropout), stored in the table `gap_events`
/// (a released name kept: docs/storage.md, "Stored names").
struct DropoutEvent {
  std::uint64_t stream_sequence = 0;
  int channel = 0;
  std::uint64_t first_missing_index = 0, missing_samples = 0;
  acquisition::DropoutCause cause = acquisition::DropoutCause::protocol;
};

struct LifeCounterEvent {
  std::uint64_t stream_sequence = 0;
  std::uint64_t sample_index = 0, previous_revolutions = 0, revolutions = 0;
};

struct RejectedFrame {
  std::string kind;       ///< e.g. malformed_frame, duplicate, malformed_line
  std::string reason;
  std::string frame;      ///< the frame as a candump line, or the raw log line
};

/// The acquisition's health counters: one column of health_snapshots each, named by to_string.
enum class HealthCounter : std::uint8_t {
  frames,
  samples,
  kernel_drops,
  ring_overflows,
  ring_high_water,
  malformed_frames,
  malformed_lines,
  unknown_ids,
  unconfigured_channel_frames,
  frames_before_header,
  dropouts,
  dropout_samples,
  ring_dropouts,
  duplicates,
  tacho_edges,
  tacho_out_of_order,
  stream_changes,
  life_counter_resets,
  unsupported_version,
  read_errors,
  reopens,
  records_complete,
  records_cut,
  records_rejected,
  records_restarted_after_dropout,
  channels_stopped,
  storage_retries,
  storage_rows_rejected,
  storage_queue_waits,
  mqtt_published,  ///< MQTT sender (0 with [mqtt] off)
  mqtt_delivered,
  mqtt_connects,
  mqtt_connect_failures,
  mqtt_refused,
  mqtt_outbox_dropped,
  mqtt_publish_refused,  ///< messages the broker refused (MQTT 5 PUBACK reason >= 0x80), this run
  mqtt_resend_requests,  ///< resend requests taken from the fleet consumer (docs/fleet.md), this run
  mqtt_resent,           ///< outbox rows published again for them
  mqtt_resend_gone,      ///< ids asked for that the outbox cannot serve (named on resend_gone)
  mqtt_resend_ignored,   ///< requests or ranges ignored: malformed, another gearbox's, never sent
};
inline constexpr std::array kAllHealthCounters{
    HealthCounter::frames,
    HealthCounter::samples,
    HealthCounter::kernel_drops,
    HealthCounter::ring_overflows,
    HealthCounter::ring_high_water,
    HealthCounter::malformed_frames,
    HealthCounter::malformed_lines,
    HealthCounter::unknown_ids,
    HealthCounter::unconfigured_channel_frames,
    HealthCounter::frames_before_header,
    HealthCounter::dropouts,
    HealthCounter::dropout_samples,
    HealthCounter::ring_dropouts,
    HealthCounter::duplicates,
    HealthCounter::tacho_edges,
    HealthCounter::tacho_out_of_order,
    HealthCounter::stream_changes,
    HealthCounter::life_counter_resets,
    HealthCounter::unsupported_version,
    HealthCounter::read_errors,
    HealthCounter::reopens,
    HealthCounter::records_complete,
    HealthCounter::records_cut,
    HealthCounter::records_rejected,
    HealthCounter::records_restarted_after_dropout,
    HealthCounter::channels_stopped,
    HealthCounter::storage_retries,
    HealthCounter::storage_rows_rejected,
    HealthCounter::storage_queue_waits,
    HealthCounter::mqtt_published,
    HealthCounter::mqtt_delivered,
    HealthCounter::mqtt_connects,
    HealthCounter::mqtt_connect_failures,
    HealthCounter::mqtt_refused,
    HealthCounter::mqtt_outbox_dropped,
    HealthCounter::mqtt_publish_refused,
    HealthCounter::mqtt_resend_requests,
    HealthCounter::mqtt_resent,
    HealthCounter::mqtt_resend_gone,
    HealthCounter::mqtt_resend_ignored,
};
/// The counter's column in health_snapshots. The four dropout counters keep their released
/// column names (gaps, gap_samples, ring_gaps, records_restarted_after_gap): docs/storage.md,
/// "Stored names".
const char* to_string(HealthCounter counter) noexcept;

/// Counter values at one moment, every counter (0 unless set).
struct HealthSnapshot {
  bool final = false;
  std::array<std::uint64_t, kAllHealthCounters.size()> counters{};  ///< by HealthCounter
  std::uint64_t& operator[](HealthCounter c) { return counters[static_cast<std::size_t>(c)]; }
  std::uint64_t operator[](HealthCounter c) const { return counters[static_cast<std::size_t>(c)]; }
};

/// The MQTT sender's counters: in health_snapshots when the daemon sends ([mqtt] sender =
/// "daemon"), in publisher_health when `gearwatch publish` does.
inline constexpr std::array kMqttHealthCounters{
    HealthCounter::mqtt_published,       HealthCounter::mqtt_delivered,       HealthCounter::mqtt_connects,
    HealthCounter::mqtt_connect_failures, HealthCounter::mqtt_refused,        HealthCounter::mqtt_outbox_dropped,
    HealthCounter::mqtt_publish_refused, HealthCounter::mqtt_resend_requests, HealthCounter::mqtt_resent,
    HealthCounter::mqtt_resend_gone,     HealthCounter::mqtt_resend_ignored,
};

/// `gearwatch publish`'s counters at one moment (table publisher_health; no run: the publisher
/// acquires nothing). Only the kMqttHealthCounters of `counters` are stored.
struct PublisherHealth {
  bool final = false;
  std::int64_t pid = 0;
  HealthSnapshot counters;
};

/// What the model thread made of one record (or of a record it had to skip), with the state it
/// leaves behind: all written in one transaction, so a restart continues exactly here.
struct ModelRunResult {
  std::uint64_t stream_sequence = 0;      ///< identify the record (its id is looked up)
  std::uint64_t start_index = 0;
  bool has_record = true;
  /// The record's id when it was stored by an earlier process (the model catching up at start):
  /// its stream is not one of this run's, so it cannot be looked up by stream and start index.
  std::optional<std::int64_t> stored_record_id;
  std::int64_t gear_pair = 0;
  wear::ModelRunReport report;
  std::uint64_t skipped_records = 0;      ///< records coalesced away before this one
  std::string skipped_record_ids;         ///< "stream:start_index" of each, comma-separated
  std::string profile_json;               ///< root -> tip profiles of the state after this run
  std::string forecast_json;              ///< the forecast curve
  bool store_state = false;               ///< write model_state (the state changed)
  std::string state_json;
  std::vector<AlertEvent> alerts;
  std::vector<std::pair<AlertKey, AlertState>> alert_states;
  /// The periodic gap step's counters after this record and the record itself when a coming
  /// diagnosis can use it (only when the step is enabled and the model advanced to the record).
  std::optional<GapScheduleUpdate> gap;
};

/// One sim-to-real gap diagnosis (docs/gap-report.md) with the twin_drift transitions it caused
/// and the alert states they leave: written in one transaction.
struct GapReportResult {
  std::uint64_t stream_sequence = 0;      ///< the record that triggered it (its id is looked up)
  std::uint64_t start_index = 0;
  bool has_record = true;
  std::int64_t gear_pair = 0;
  gap::GapReport report;
  std::vector<AlertEvent> alerts;
  std::vector<std::pair<AlertKey, AlertState>> alert_states;
};

using Message = std::variant<RunStarted, RunEnded, StreamStarted, RecordResult, AlertUpdate, DropoutEvent,
                             LifeCounterEvent, RejectedFrame, HealthSnapshot, PublisherHealth, ModelRunResult, GapReportResult>;

}  // namespace gearwatch::storage
