#include "gearwatch/storage/schema.hpp"

#include <algorithm>
#include <array>
#include <string>

#include "gearwatch/types/alerts.hpp"
#include "gearwatch/types/gap_report.hpp"
#include "gearwatch/types/model_run.hpp"
#include "gearwatch/types/record.hpp"
#include "gearwatch/types/skip_reason.hpp"
#include "gearwatch/types/speed_source.hpp"
#include "gearwatch/types/wear_mechanism.hpp"
#include "model_run_columns.hpp"

namespace gearwatch::storage {
namespace {

// Each entry moves the schema from version i to i+1. Never edit a released step: add one.
constexpr std::array<const char*, 18> kMigrations{
    // 0 -> 1: acquisition, records, indicators, staff views.
    R"SQL(
CREATE TABLE runs (
  id INTEGER PRIMARY KEY,
  kind TEXT NOT NULL CHECK (kind IN ('run', 'replay')),
  source TEXT NOT NULL,
  config_path TEXT,
  started_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  ended_at TEXT,
  end_reason TEXT
);
CREATE TABLE streams (
  id INTEGER PRIMARY KEY,
  run_id INTEGER NOT NULL REFERENCES runs(id),
  sequence INTEGER NOT NULL,
  stream_id INTEGER NOT NULL,
  sample_rate_hz INTEGER NOT NULL,
  channel_count INTEGER NOT NULL,
  started_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  UNIQUE (run_id, sequence)
);
CREATE TABLE records (
  id INTEGER PRIMARY KEY,
  stream_key INTEGER NOT NULL REFERENCES streams(id),
  start_index INTEGER NOT NULL,
  sample_count INTEGER NOT NULL,
  duration_s REAL NOT NULL,
  end_reason TEXT NOT NULL CHECK (end_reason IN ('complete', 'cut_at_gap', 'stream_end')),
  analysed INTEGER NOT NULL,
  reject_reason TEXT,
  torque_nm REAL,
  speed_hz REAL,
  input_revolutions REAL,
  created_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);
CREATE INDEX records_by_stream ON records(stream_key, start_index);
CREATE TABLE indicator_values (
  record_id INTEGER NOT NULL REFERENCES records(id),
  channel INTEGER NOT NULL,
  name TEXT NOT NULL,
  value REAL,
  PRIMARY KEY (record_id, channel, name)
) WITHOUT ROWID;
CREATE INDEX indicator_values_by_name ON indicator_values(name, record_id);
CREATE TABLE indicator_skips (
  record_id INTEGER NOT NULL REFERENCES records(id),
  channel INTEGER NOT NULL,
  name TEXT NOT NULL,
  reason TEXT NOT NULL,
  PRIMARY KEY (record_id, channel, name)
) WITHOUT ROWID;
CREATE TABLE band_selections (
  record_id INTEGER NOT NULL REFERENCES records(id),
  channel INTEGER NOT NULL,
  criterion TEXT NOT NULL,
  level REAL NOT NULL,
  centre_hz REAL NOT NULL,
  bandwidth_hz REAL NOT NULL,
  value REAL,
  PRIMARY KEY (record_id, channel, criterion)
) WITHOUT ROWID;
CREATE TABLE gap_events (
  id INTEGER PRIMARY KEY,
  stream_key INTEGER NOT NULL REFERENCES streams(id),
  channel INTEGER NOT NULL,
  first_missing_index INTEGER NOT NULL,
  missing_samples INTEGER NOT NULL,
  cause TEXT NOT NULL,
  detected_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);
CREATE TABLE life_counter_events (
  id INTEGER PRIMARY KEY,
  stream_key INTEGER NOT NULL REFERENCES streams(id),
  sample_index INTEGER NOT NULL,
  previous_revolutions INTEGER NOT NULL,
  revolutions INTEGER NOT NULL,
  detected_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);
CREATE TABLE rejected_frames (
  id INTEGER PRIMARY KEY,
  run_id INTEGER NOT NULL REFERENCES runs(id),
  kind TEXT NOT NULL,
  reason TEXT NOT NULL,
  frame TEXT NOT NULL,
  received_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);
CREATE TABLE health_snapshots (
  id INTEGER PRIMARY KEY,
  run_id INTEGER NOT NULL REFERENCES runs(id),
  taken_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  final INTEGER NOT NULL DEFAULT 0,
  frames INTEGER NOT NULL DEFAULT 0, samples INTEGER NOT NULL DEFAULT 0,
  kernel_drops INTEGER NOT NULL DEFAULT 0, ring_overflows INTEGER NOT NULL DEFAULT 0, ring_high_water INTEGER NOT NULL DEFAULT 0,
  malformed_frames INTEGER NOT NULL DEFAULT 0, malformed_lines INTEGER NOT NULL DEFAULT 0, unknown_ids INTEGER NOT NULL DEFAULT 0,
  unconfigured_channel_frames INTEGER NOT NULL DEFAULT 0, frames_before_header INTEGER NOT NULL DEFAULT 0,
  gaps INTEGER NOT NULL DEFAULT 0, gap_samples INTEGER NOT NULL DEFAULT 0, ring_gaps INTEGER NOT NULL DEFAULT 0,
  duplicates INTEGER NOT NULL DEFAULT 0, tacho_edges INTEGER NOT NULL DEFAULT 0, tacho_out_of_order INTEGER NOT NULL DEFAULT 0,
  stream_changes INTEGER NOT NULL DEFAULT 0, life_counter_resets INTEGER NOT NULL DEFAULT 0, unsupported_version INTEGER NOT NULL DEFAULT 0,
  read_errors INTEGER NOT NULL DEFAULT 0, reopens INTEGER NOT NULL DEFAULT 0,
  records_complete INTEGER NOT NULL DEFAULT 0, records_cut INTEGER NOT NULL DEFAULT 0, records_rejected INTEGER NOT NULL DEFAULT 0,
  storage_retries INTEGER NOT NULL DEFAULT 0, storage_queue_waits INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE alert_events (
  id INTEGER PRIMARY KEY,
  created_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  record_id INTEGER REFERENCES records(id),
  severity TEXT NOT NULL CHECK (severity IN ('info', 'warning', 'alarm')),
  kind TEXT NOT NULL,
  message TEXT NOT NULL
);
CREATE TABLE inspections (
  id INTEGER PRIMARY KEY,
  entered_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  cycles REAL NOT NULL,
  pitted_area_fraction REAL,
  wear_depth_m REAL,
  note TEXT
);

-- Staff views: stable column names (docs/storage.md).
CREATE VIEW indicators AS
  SELECT r.id AS record_id, s.run_id, s.stream_id, r.start_index, r.created_at,
         r.input_revolutions AS cycles, r.speed_hz, r.torque_nm,
         v.channel, v.name, v.value
  FROM indicator_values v JOIN records r ON r.id = v.record_id JOIN streams s ON s.id = r.stream_key;
CREATE VIEW alerts AS
  SELECT id, created_at, severity, kind, record_id, message FROM alert_events;
CREATE VIEW acquisition_health AS
  SELECT h.*, r.kind AS run_kind, r.source, r.started_at AS run_started_at, r.ended_at AS run_ended_at
  FROM health_snapshots h JOIN runs r ON r.id = h.run_id
  WHERE h.id = (SELECT max(id) FROM health_snapshots x WHERE x.run_id = h.run_id);
CREATE VIEW record_status AS
  SELECT r.id AS record_id, s.run_id, s.stream_id, r.start_index, r.sample_count, r.duration_s,
         r.end_reason, r.analysed, r.reject_reason, r.created_at,
         (SELECT group_concat(k.name || ': ' || k.reason, '; ') FROM indicator_skips k WHERE k.record_id = r.id) AS skipped
  FROM records r JOIN streams s ON s.id = r.stream_key;
)SQL",
    // 1 -> 2: wear-mechanism identification over the record history (thesis §4.4).
    R"SQL(
CREATE TABLE wear_mechanism_assessments (
  record_id INTEGER NOT NULL REFERENCES records(id),
  channel INTEGER NOT NULL,
  mechanism TEXT NOT NULL CHECK (mechanism IN ('none', 'fatigue_pitting', 'abrasive_wear', 'both', 'undetermined')),
  points INTEGER NOT NULL,
  low_band_p REAL, high_band_p REAL, low_band_rho REAL, high_band_rho REAL,
  band_jumps INTEGER NOT NULL,
  evidence TEXT NOT NULL,
  PRIMARY KEY (record_id, channel)
) WITHOUT ROWID;
CREATE VIEW wear_mechanism AS
  SELECT a.record_id, r.created_at, r.input_revolutions AS cycles, a.channel, a.mechanism, a.points,
         a.low_band_p, a.high_band_p, a.low_band_rho, a.high_band_rho, a.band_jumps, a.evidence
  FROM wear_mechanism_assessments a JOIN records r ON r.id = a.record_id;
)SQL",
    // 2 -> 3: one vocabulary for every enumerated value (filled from the enums at each writable
    // open, checked by triggers), alert transitions and their persistent state, skip details.
    R"SQL(
CREATE TABLE vocabulary (
  domain TEXT NOT NULL,
  token TEXT NOT NULL,
  PRIMARY KEY (domain, token)
) WITHOUT ROWID;
ALTER TABLE alert_events ADD COLUMN channel INTEGER;
ALTER TABLE alert_events ADD COLUMN transition TEXT NOT NULL DEFAULT 'event';
ALTER TABLE alert_events ADD COLUMN value TEXT;
ALTER TABLE alert_events ADD COLUMN subject TEXT;
ALTER TABLE indicator_skips ADD COLUMN detail TEXT;
ALTER TABLE health_snapshots ADD COLUMN storage_rows_rejected INTEGER NOT NULL DEFAULT 0;
ALTER TABLE health_snapshots ADD COLUMN records_restarted_after_gap INTEGER NOT NULL DEFAULT 0;
ALTER TABLE health_snapshots ADD COLUMN channels_stopped INTEGER NOT NULL DEFAULT 0;
CREATE TABLE alert_state (
  kind TEXT NOT NULL,
  channel INTEGER NOT NULL,
  active INTEGER NOT NULL,
  value TEXT,
  consecutive_present INTEGER NOT NULL,
  consecutive_absent INTEGER NOT NULL,
  marker REAL NOT NULL DEFAULT 0,
  subject TEXT NOT NULL DEFAULT '',
  updated_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  PRIMARY KEY (kind, channel, subject)
) WITHOUT ROWID;
CREATE TRIGGER alert_events_kind_in_vocabulary BEFORE INSERT ON alert_events
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'alert_kind')
   AND NEW.kind NOT IN (SELECT token FROM vocabulary WHERE domain = 'alert_kind')
BEGIN SELECT RAISE(ABORT, 'alert_events.kind: value not in vocabulary domain alert_kind'); END;
CREATE TRIGGER alert_events_severity_in_vocabulary BEFORE INSERT ON alert_events
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'alert_severity')
   AND NEW.severity NOT IN (SELECT token FROM vocabulary WHERE domain = 'alert_severity')
BEGIN SELECT RAISE(ABORT, 'alert_events.severity: value not in vocabulary domain alert_severity'); END;
CREATE TRIGGER alert_events_transition_in_vocabulary BEFORE INSERT ON alert_events
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'alert_transition')
   AND NEW.transition NOT IN (SELECT token FROM vocabulary WHERE domain = 'alert_transition')
BEGIN SELECT RAISE(ABORT, 'alert_events.transition: value not in vocabulary domain alert_transition'); END;
CREATE TRIGGER alert_state_kind_in_vocabulary BEFORE INSERT ON alert_state
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'alert_kind')
   AND NEW.kind NOT IN (SELECT token FROM vocabulary WHERE domain = 'alert_kind')
BEGIN SELECT RAISE(ABORT, 'alert_state.kind: value not in vocabulary domain alert_kind'); END;
CREATE TRIGGER indicator_skips_reason_in_vocabulary BEFORE INSERT ON indicator_skips
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'skip_reason')
   AND NEW.reason NOT IN (SELECT token FROM vocabulary WHERE domain = 'skip_reason')
BEGIN SELECT RAISE(ABORT, 'indicator_skips.reason: value not in vocabulary domain skip_reason'); END;
CREATE TRIGGER rejected_frames_kind_in_vocabulary BEFORE INSERT ON rejected_frames
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'rejected_frame_kind')
   AND NEW.kind NOT IN (SELECT token FROM vocabulary WHERE domain = 'rejected_frame_kind')
BEGIN SELECT RAISE(ABORT, 'rejected_frames.kind: value not in vocabulary domain rejected_frame_kind'); END;
CREATE TRIGGER gap_events_cause_in_vocabulary BEFORE INSERT ON gap_events
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'gap_cause')
   AND NEW.cause NOT IN (SELECT token FROM vocabulary WHERE domain = 'gap_cause')
BEGIN SELECT RAISE(ABORT, 'gap_events.cause: value not in vocabulary domain gap_cause'); END;
DROP VIEW alerts;
CREATE VIEW alerts AS
  SELECT id, created_at, severity, kind, channel, subject, transition, value, record_id, message FROM alert_events;
CREATE VIEW active_alerts AS
  SELECT s.kind, CASE WHEN s.channel < 0 THEN NULL ELSE s.channel END AS channel,
         nullif(s.subject, '') AS subject, s.value,
         (SELECT max(e.created_at) FROM alert_events e
           WHERE e.kind = s.kind AND coalesce(e.channel, -1) = s.channel AND coalesce(e.subject, '') = s.subject
             AND e.transition = 'raised') AS raised_at,
         s.updated_at
  FROM alert_state s WHERE s.active = 1;
DROP VIEW record_status;
CREATE VIEW record_status AS
  SELECT r.id AS record_id, s.run_id, s.stream_id, r.start_index, r.sample_count, r.duration_s,
         r.end_reason, r.analysed, r.reject_reason, r.created_at,
         (SELECT group_concat(k.channel || ' ' || k.name || ': ' || k.reason || coalesce(' (' || k.detail || ')', ''), '; ')
            FROM indicator_skips k WHERE k.record_id = r.id) AS skipped
  FROM records r JOIN streams s ON s.id = r.stream_key;
)SQL",
    // 3 -> 4: the digital twin's state, every K update, and the model's runs with predictions.
    R"SQL(
CREATE TABLE model_state (
  gear_pair INTEGER PRIMARY KEY,
  updated_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  record_id INTEGER REFERENCES records(id),
  cycles REAL NOT NULL,
  k_wear REAL NOT NULL,
  k_pitting REAL NOT NULL,
  state TEXT NOT NULL
);
CREATE TABLE model_runs (
  id INTEGER PRIMARY KEY,
  created_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  record_id INTEGER REFERENCES records(id),
  gear_pair INTEGER NOT NULL,
  cycles REAL, speed_hz REAL, torque_nm REAL,
  advanced INTEGER NOT NULL,
  detail TEXT,
  skipped_records INTEGER NOT NULL DEFAULT 0,
  skipped_record_ids TEXT,
  rms_sa_measured REAL, rms_sa_simulated REAL, ics2_low REAL, ics2_density_estimate REAL,
  k_wear REAL, k_pitting REAL,
  wear_mean_m REAL, wear_max_m REAL, pinion_wear_mean_m REAL, gear_wear_mean_m REAL,
  pitting_mean REAL, pitting_max REAL, pitting_max_fraction REAL,
  forecast_speed_hz REAL, forecast_torque_nm REAL,
  wear_limit_m REAL, wear_cycles_left REAL, wear_cycles_left_low REAL, wear_cycles_left_high REAL,
  pitting_limit REAL, pitting_cycles_left REAL, pitting_cycles_left_low REAL, pitting_cycles_left_high REAL,
  forecast_failure TEXT,
  profile TEXT,
  forecast_curve TEXT
);
CREATE INDEX model_runs_by_pair ON model_runs(gear_pair, id);
CREATE TABLE model_run_issues (
  run_id INTEGER NOT NULL REFERENCES model_runs(id),
  issue TEXT NOT NULL,
  PRIMARY KEY (run_id, issue)
) WITHOUT ROWID;
CREATE TABLE k_update_log (
  id INTEGER PRIMARY KEY,
  created_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  run_id INTEGER NOT NULL REFERENCES model_runs(id),
  gear_pair INTEGER NOT NULL,
  cycles REAL NOT NULL,
  kind TEXT NOT NULL,
  triggered_by TEXT NOT NULL,
  outcome TEXT NOT NULL,
  old_value REAL NOT NULL,
  new_value REAL NOT NULL,
  applies_from_cycles REAL NOT NULL,
  iterations INTEGER NOT NULL,
  measured REAL, simulated_before REAL, simulated_after REAL,
  correlation_before REAL, correlation_after REAL,
  evidence TEXT NOT NULL
);
ALTER TABLE inspections ADD COLUMN gear_pair INTEGER;
CREATE TRIGGER model_run_issues_issue_in_vocabulary BEFORE INSERT ON model_run_issues
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'model_issue')
   AND NEW.issue NOT IN (SELECT token FROM vocabulary WHERE domain = 'model_issue')
BEGIN SELECT RAISE(ABORT, 'model_run_issues.issue: value not in vocabulary domain model_issue'); END;
CREATE TRIGGER k_update_log_kind_in_vocabulary BEFORE INSERT ON k_update_log
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'model_update_kind')
   AND NEW.kind NOT IN (SELECT token FROM vocabulary WHERE domain = 'model_update_kind')
BEGIN SELECT RAISE(ABORT, 'k_update_log.kind: value not in vocabulary domain model_update_kind'); END;
CREATE TRIGGER k_update_log_triggered_by_in_vocabulary BEFORE INSERT ON k_update_log
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'model_update_trigger')
   AND NEW.triggered_by NOT IN (SELECT token FROM vocabulary WHERE domain = 'model_update_trigger')
BEGIN SELECT RAISE(ABORT, 'k_update_log.triggered_by: value not in vocabulary domain model_update_trigger'); END;
CREATE TRIGGER k_update_log_outcome_in_vocabulary BEFORE INSERT ON k_update_log
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'model_update_outcome')
   AND NEW.outcome NOT IN (SELECT token FROM vocabulary WHERE domain = 'model_update_outcome')
BEGIN SELECT RAISE(ABORT, 'k_update_log.outcome: value not in vocabulary domain model_update_outcome'); END;
CREATE VIEW k_updates AS
  SELECT u.id, u.created_at, u.gear_pair, u.cycles, u.kind, u.triggered_by, u.outcome, u.old_value, u.new_value,
         u.applies_from_cycles, u.iterations, u.measured, u.simulated_before, u.simulated_after,
         u.correlation_before, u.correlation_after, r.record_id, u.evidence
  FROM k_update_log u JOIN model_runs r ON r.id = u.run_id;
CREATE VIEW predictions AS
  SELECT m.id AS run_id, m.created_at, m.record_id, m.gear_pair, m.cycles, m.speed_hz, m.torque_nm,
         m.k_wear, m.k_pitting, m.rms_sa_measured, m.rms_sa_simulated, m.ics2_low, m.ics2_density_estimate,
         m.wear_mean_m, m.wear_max_m, m.pitting_mean, m.pitting_max,
         m.wear_limit_m, m.wear_cycles_left, m.wear_cycles_left_low, m.wear_cycles_left_high,
         m.pitting_limit, m.pitting_cycles_left, m.pitting_cycles_left_low, m.pitting_cycles_left_high,
         m.forecast_speed_hz, m.forecast_torque_nm, m.forecast_failure,
         (SELECT group_concat(i.issue, ',') FROM model_run_issues i WHERE i.run_id = m.id) AS issues, m.detail
  FROM model_runs m WHERE m.advanced = 1;
CREATE VIEW model_skips AS
  SELECT m.id AS run_id, m.created_at, m.record_id, m.gear_pair, m.cycles, m.skipped_records, m.skipped_record_ids,
         (SELECT group_concat(i.issue, ',') FROM model_run_issues i WHERE i.run_id = m.id) AS issues, m.detail
  FROM model_runs m WHERE m.advanced = 0 OR m.skipped_records > 0;
)SQL",
    // 4 -> 5: the sim-to-real gap reports (docs/gap-report.md): one row per diagnosis, its families
    // before/after, its ranked candidates with their held-out gaps, the greedy choice, and the
    // staff views gap_reports and gap_candidates.
    R"SQL(
CREATE TABLE gap_report_runs (
  id INTEGER PRIMARY KEY,
  created_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  record_id INTEGER REFERENCES records(id),
  gear_pair INTEGER NOT NULL DEFAULT 0,
  input_revolutions REAL,
  speeds_hz TEXT NOT NULL,
  training_records INTEGER NOT NULL,
  held_out_records INTEGER NOT NULL,
  k_wear_before REAL,
  k_wear_after REAL,
  plot TEXT
);
CREATE TABLE gap_report_families (
  report_id INTEGER NOT NULL REFERENCES gap_report_runs(id),
  family TEXT NOT NULL,
  before_position INTEGER, before_resolved INTEGER, before_unresolved_reason TEXT,
  before_distance_db REAL, before_interval_low_db REAL, before_interval_high_db REAL,
  before_energy_share REAL, before_significant INTEGER,
  after_position INTEGER, after_resolved INTEGER, after_unresolved_reason TEXT,
  after_distance_db REAL, after_interval_low_db REAL, after_interval_high_db REAL,
  after_energy_share REAL, after_significant INTEGER,
  unexplained_position INTEGER,
  PRIMARY KEY (report_id, family)
) WITHOUT ROWID;
CREATE TABLE gap_report_candidates (
  report_id INTEGER NOT NULL REFERENCES gap_report_runs(id),
  rank INTEGER NOT NULL,
  effect TEXT NOT NULL,
  shrinkage REAL,
  information_criterion REAL,
  worsens_other_family INTEGER NOT NULL,
  parameters TEXT NOT NULL,
  PRIMARY KEY (report_id, rank)
) WITHOUT ROWID;
CREATE TABLE gap_candidate_families (
  report_id INTEGER NOT NULL REFERENCES gap_report_runs(id),
  rank INTEGER NOT NULL,
  family TEXT NOT NULL,
  explains_position INTEGER,
  held_out_position INTEGER, resolved INTEGER, unresolved_reason TEXT,
  distance_db REAL, interval_low_db REAL, interval_high_db REAL, energy_share REAL, significant INTEGER,
  PRIMARY KEY (report_id, rank, family)
) WITHOUT ROWID;
CREATE TABLE gap_report_chosen (
  report_id INTEGER NOT NULL REFERENCES gap_report_runs(id),
  step INTEGER NOT NULL,
  effect TEXT NOT NULL,
  PRIMARY KEY (report_id, step)
) WITHOUT ROWID;
CREATE TRIGGER gap_report_families_family_in_vocabulary BEFORE INSERT ON gap_report_families
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'gap_family')
   AND NEW.family NOT IN (SELECT token FROM vocabulary WHERE domain = 'gap_family')
BEGIN SELECT RAISE(ABORT, 'gap_report_families.family: value not in vocabulary domain gap_family'); END;
CREATE TRIGGER gap_candidate_families_family_in_vocabulary BEFORE INSERT ON gap_candidate_families
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'gap_family')
   AND NEW.family NOT IN (SELECT token FROM vocabulary WHERE domain = 'gap_family')
BEGIN SELECT RAISE(ABORT, 'gap_candidate_families.family: value not in vocabulary domain gap_family'); END;
CREATE TRIGGER gap_report_candidates_effect_in_vocabulary BEFORE INSERT ON gap_report_candidates
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'gap_effect')
   AND NEW.effect NOT IN (SELECT token FROM vocabulary WHERE domain = 'gap_effect')
BEGIN SELECT RAISE(ABORT, 'gap_report_candidates.effect: value not in vocabulary domain gap_effect'); END;
CREATE TRIGGER gap_report_chosen_effect_in_vocabulary BEFORE INSERT ON gap_report_chosen
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'gap_effect')
   AND NEW.effect NOT IN (SELECT token FROM vocabulary WHERE domain = 'gap_effect')
BEGIN SELECT RAISE(ABORT, 'gap_report_chosen.effect: value not in vocabulary domain gap_effect'); END;
CREATE VIEW gap_reports AS
  SELECT g.id AS report_id, g.created_at, g.record_id, g.gear_pair, g.input_revolutions AS cycles, g.speeds_hz,
         g.training_records, g.held_out_records, f.family,
         f.before_resolved AS resolved, f.before_unresolved_reason AS unresolved_reason,
         f.before_distance_db AS distance_before_db, f.before_interval_low_db AS interval_before_low_db,
         f.before_interval_high_db AS interval_before_high_db, f.before_energy_share AS energy_share_before,
         f.before_significant AS significant_before,
         f.after_distance_db AS distance_after_db, f.after_interval_low_db AS interval_after_low_db,
         f.after_interval_high_db AS interval_after_high_db, f.after_energy_share AS energy_share_after,
         f.after_significant AS significant_after,
         CASE WHEN f.before_distance_db IS NOT NULL AND f.after_distance_db IS NOT NULL AND abs(f.before_distance_db) > 0
              THEN 1.0 - abs(f.after_distance_db) / abs(f.before_distance_db) END AS shrinkage,
         (SELECT group_concat(c.effect, ',') FROM (SELECT effect FROM gap_report_chosen WHERE report_id = g.id ORDER BY step) c
           WHERE EXISTS (
             SELECT 1 FROM gap_report_candidates k JOIN gap_candidate_families e ON e.report_id = k.report_id AND e.rank = k.rank
             WHERE k.report_id = g.id AND k.effect = c.effect AND e.family = f.family AND e.explains_position IS NOT NULL)) AS attributed_to,
         CASE WHEN f.unexplained_position IS NULL THEN 0 ELSE 1 END AS unexplained,
         (SELECT group_concat(c.effect, ',') FROM (SELECT effect FROM gap_report_chosen WHERE report_id = g.id ORDER BY step) c) AS chosen,
         g.k_wear_before, g.k_wear_after
  FROM gap_report_runs g JOIN gap_report_families f ON f.report_id = g.id;
CREATE VIEW gap_candidates AS
  SELECT g.id AS report_id, g.created_at, g.input_revolutions AS cycles, k.rank, k.effect, k.shrinkage,
         k.information_criterion, k.worsens_other_family,
         (SELECT c.step FROM gap_report_chosen c WHERE c.report_id = g.id AND c.effect = k.effect) AS chosen_step,
         (SELECT group_concat(e.family, ',') FROM (SELECT family FROM gap_candidate_families
            WHERE report_id = g.id AND rank = k.rank AND explains_position IS NOT NULL ORDER BY explains_position) e) AS explains,
         k.parameters
  FROM gap_report_candidates k JOIN gap_report_runs g ON g.id = k.report_id;
)SQL",
    // 5 -> 6: a run from a capture file keeps the capture's content identity, so a capture given
    // again by another path (relative, through a symlink) is recognised (docs/storage.md, "Resuming").
    R"SQL(
ALTER TABLE runs ADD COLUMN capture_id TEXT;
CREATE INDEX runs_capture_id ON runs(capture_id);
)SQL",
    // 6 -> 7: where a record's shaft angle came from (the tacho or the vibration signal's estimate,
    // docs/dsp.md "Speed from the signal") with the estimate's mean speed; caveats of computed
    // indicators (a carrier band trimmed to 0.45 fs); the carrier band a wear verdict could not see.
    R"SQL(
ALTER TABLE records ADD COLUMN speed_source TEXT;
ALTER TABLE records ADD COLUMN estimated_speed_hz REAL;
ALTER TABLE wear_mechanism_assessments ADD COLUMN unseen_band TEXT;
CREATE TABLE indicator_notes (
  record_id INTEGER NOT NULL REFERENCES records(id),
  channel INTEGER NOT NULL,
  name TEXT NOT NULL,
  note TEXT NOT NULL,
  detail TEXT,
  PRIMARY KEY (record_id, channel, name, note)
) WITHOUT ROWID;
CREATE TRIGGER records_speed_source_in_vocabulary BEFORE INSERT ON records
  WHEN NEW.speed_source IS NOT NULL AND EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'speed_source')
   AND NEW.speed_source NOT IN (SELECT token FROM vocabulary WHERE domain = 'speed_source')
BEGIN SELECT RAISE(ABORT, 'records.speed_source: value not in vocabulary domain speed_source'); END;
CREATE TRIGGER indicator_notes_note_in_vocabulary BEFORE INSERT ON indicator_notes
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'indicator_note')
   AND NEW.note NOT IN (SELECT token FROM vocabulary WHERE domain = 'indicator_note')
BEGIN SELECT RAISE(ABORT, 'indicator_notes.note: value not in vocabulary domain indicator_note'); END;
CREATE TRIGGER wear_mechanism_assessments_unseen_band_in_vocabulary BEFORE INSERT ON wear_mechanism_assessments
  WHEN NEW.unseen_band IS NOT NULL AND EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'carrier_band')
   AND NEW.unseen_band NOT IN (SELECT token FROM vocabulary WHERE domain = 'carrier_band')
BEGIN SELECT RAISE(ABORT, 'wear_mechanism_assessments.unseen_band: value not in vocabulary domain carrier_band'); END;
DROP VIEW record_status;
CREATE VIEW record_status AS
  SELECT r.id AS record_id, s.run_id, s.stream_id, r.start_index, r.sample_count, r.duration_s,
         r.end_reason, r.analysed, r.reject_reason, r.created_at,
         (SELECT group_concat(k.channel || ' ' || k.name || ': ' || k.reason || coalesce(' (' || k.detail || ')', ''), '; ')
            FROM indicator_skips k WHERE k.record_id = r.id) AS skipped,
         r.speed_source, r.estimated_speed_hz,
         (SELECT group_concat(n.channel || ' ' || n.name || ': ' || n.note || coalesce(' (' || n.detail || ')', ''), '; ')
            FROM indicator_notes n WHERE n.record_id = r.id) AS notes
  FROM records r JOIN streams s ON s.id = r.stream_key;
DROP VIEW wear_mechanism;
CREATE VIEW wear_mechanism AS
  SELECT a.record_id, r.created_at, r.input_revolutions AS cycles, a.channel, a.mechanism, a.points,
         a.low_band_p, a.high_band_p, a.low_band_rho, a.high_band_rho, a.band_jumps, a.evidence, a.unseen_band
  FROM wear_mechanism_assessments a JOIN records r ON r.id = a.record_id;
  )SQL",
    // 7 -> 8: the forecast interval's nominal coverage, why it was widened or brought nearer
    // (forecast_flag tokens) and the numbers behind it (docs/model.md, "Posterior and interval").
    R"SQL(
ALTER TABLE model_runs ADD COLUMN interval_coverage REAL;
ALTER TABLE model_runs ADD COLUMN forecast_evidence TEXT;
CREATE TABLE model_run_forecast_flags (
  run_id INTEGER NOT NULL REFERENCES model_runs(id),
  flag TEXT NOT NULL,
  PRIMARY KEY (run_id, flag)
) WITHOUT ROWID;
CREATE TRIGGER model_run_forecast_flags_flag_in_vocabulary BEFORE INSERT ON model_run_forecast_flags
  WHEN EXISTS (SELECT 1 FROM vocabulary WHERE domain = 'forecast_flag')
   AND NEW.flag NOT IN (SELECT token FROM vocabulary WHERE domain = 'forecast_flag')
BEGIN SELECT RAISE(ABORT, 'model_run_forecast_flags.flag: value not in vocabulary domain forecast_flag'); END;
DROP VIEW predictions;
CREATE VIEW predictions AS
  SELECT m.id AS run_id, m.created_at, m.record_id, m.gear_pair, m.cycles, m.speed_hz, m.torque_nm,
         m.k_wear, m.k_pitting, m.rms_sa_measured, m.rms_sa_simulated, m.ics2_low, m.ics2_density_estimate,
         m.wear_mean_m, m.wear_max_m, m.pitting_mean, m.pitting_max,
         m.wear_limit_m, m.wear_cycles_left, m.wear_cycles_left_low, m.wear_cycles_left_high,
         m.pitting_limit, m.pitting_cycles_left, m.pitting_cycles_left_low, m.pitting_cycles_left_high,
         m.forecast_speed_hz, m.forecast_torque_nm, m.forecast_failure,
         (SELECT group_concat(i.issue, ',') FROM model_run_issues i WHERE i.run_id = m.id) AS issues, m.detail,
         m.interval_coverage,
         (SELECT group_concat(f.flag, ',') FROM model_run_forecast_flags f WHERE f.run_id = m.id) AS forecast_flags,
         m.forecast_evidence
  FROM model_runs m WHERE m.advanced = 1;
  )SQL",
    // 8 -> 9: what the periodic gap diagnosis keeps between records (docs/gap.md, "Persistence"):
    // its schedule's counters per gear pair and the records the next diagnosis can use (the compared
    // channel's samples, the tacho edges and the wear state at each), written with each record's model
    // run, so replays one capture per process diagnose like one long replay.
    R"SQL(
CREATE TABLE gap_schedule (
  gear_pair INTEGER PRIMARY KEY,
  records_added INTEGER NOT NULL,
  since_diagnosis INTEGER NOT NULL
);
CREATE TABLE gap_kept_records (
  id INTEGER PRIMARY KEY,
  gear_pair INTEGER NOT NULL,
  position INTEGER NOT NULL,
  record_id INTEGER REFERENCES records(id),
  model_run_id INTEGER REFERENCES model_runs(id),
  stream_sequence INTEGER NOT NULL,
  stream_id INTEGER NOT NULL,
  start_index INTEGER NOT NULL,
  sample_rate_hz REAL NOT NULL,
  speed_hz REAL,
  torque_nm REAL,
  input_revolutions REAL,
  channel INTEGER NOT NULL,
  sample_count INTEGER NOT NULL,
  samples BLOB NOT NULL,
  tacho_edges TEXT NOT NULL,
  wear_state TEXT NOT NULL,
  UNIQUE (gear_pair, position)
);
)SQL",
    // 9 -> 10: the names the run's config gave its accelerometer channels, so the pages and queries
    // say "casing_y" where the rows say channel 0 (docs/storage.md; the config may be gone or changed
    // since the run, so the names are kept as they were then).
    R"SQL(
CREATE TABLE run_channels (
  run_id INTEGER NOT NULL REFERENCES runs(id),
  channel INTEGER NOT NULL,
  name TEXT NOT NULL,
  PRIMARY KEY (run_id, channel)
) WITHOUT ROWID;
)SQL",
    // 10 -> 11: the MQTT outbox (docs/mqtt.md): each message to publish, written in the transaction
    // of the data it reports, delivered in id order and marked on the broker's acknowledgement.
    R"SQL(
CREATE TABLE outbox (
  id INTEGER PRIMARY KEY,
  topic TEXT NOT NULL CHECK (topic IN ('alert', 'record', 'wear', 'model', 'health', 'gap')),
  record_id INTEGER REFERENCES records(id),
  payload TEXT NOT NULL,
  created_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  delivered_at TEXT
);
CREATE INDEX outbox_undelivered ON outbox(id) WHERE delivered_at IS NULL;
CREATE TABLE outbox_counters (
  name TEXT PRIMARY KEY,
  value INTEGER NOT NULL
) WITHOUT ROWID;
INSERT INTO outbox_counters(name, value) VALUES ('dropped', 0);
ALTER TABLE health_snapshots ADD COLUMN mqtt_published INTEGER NOT NULL DEFAULT 0;
ALTER TABLE health_snapshots ADD COLUMN mqtt_delivered INTEGER NOT NULL DEFAULT 0;
ALTER TABLE health_snapshots ADD COLUMN mqtt_connects INTEGER NOT NULL DEFAULT 0;
ALTER TABLE health_snapshots ADD COLUMN mqtt_connect_failures INTEGER NOT NULL DEFAULT 0;
ALTER TABLE health_snapshots ADD COLUMN mqtt_refused INTEGER NOT NULL DEFAULT 0;
ALTER TABLE health_snapshots ADD COLUMN mqtt_outbox_dropped INTEGER NOT NULL DEFAULT 0;
)SQL",
    // 11 -> 12: a message the broker refuses (MQTT 5 PUBACK reason >= 0x80, e.g. outside the ACL)
    // is marked refused with the broker's reason, kept like a delivered one, never sent again
    // automatically, and counted for the database's life (docs/mqtt.md).
    R"SQL(
ALTER TABLE outbox ADD COLUMN refused_at TEXT;
ALTER TABLE outbox ADD COLUMN refused_reason TEXT;
DROP INDEX outbox_undelivered;
CREATE INDEX outbox_undelivered ON outbox(id) WHERE delivered_at IS NULL AND refused_at IS NULL;
INSERT INTO outbox_counters(name, value) VALUES ('refused', 0);
ALTER TABLE health_snapshots ADD COLUMN mqtt_publish_refused INTEGER NOT NULL DEFAULT 0;
)SQL",
    // 12 -> 13: the daemon's side of the fleet's resend requests in its health snapshots
    // (docs/fleet.md, "Lost messages"), beside the other mqtt_* counters.
    R"SQL(
ALTER TABLE health_snapshots ADD COLUMN mqtt_resend_requests INTEGER NOT NULL DEFAULT 0;
ALTER TABLE health_snapshots ADD COLUMN mqtt_resent INTEGER NOT NULL DEFAULT 0;
ALTER TABLE health_snapshots ADD COLUMN mqtt_resend_gone INTEGER NOT NULL DEFAULT 0;
ALTER TABLE health_snapshots ADD COLUMN mqtt_resend_ignored INTEGER NOT NULL DEFAULT 0;
)SQL",
    // 13 -> 14: the combined mean depth's interval (docs/model.md, "Profile-shape term"): RMS_SA
    // fixes a depth only for a given profile shape, so the depth is given over the shapes' range.
    R"SQL(
ALTER TABLE model_runs ADD COLUMN wear_mean_low_m REAL;
ALTER TABLE model_runs ADD COLUMN wear_mean_high_m REAL;
DROP VIEW predictions;
CREATE VIEW predictions AS
  SELECT m.id AS run_id, m.created_at, m.record_id, m.gear_pair, m.cycles, m.speed_hz, m.torque_nm,
         m.k_wear, m.k_pitting, m.rms_sa_measured, m.rms_sa_simulated, m.ics2_low, m.ics2_density_estimate,
         m.wear_mean_m, m.wear_max_m, m.pitting_mean, m.pitting_max,
         m.wear_limit_m, m.wear_cycles_left, m.wear_cycles_left_low, m.wear_cycles_left_high,
         m.pitting_limit, m.pitting_cycles_left, m.pitting_cycles_left_low, m.pitting_cycles_left_high,
         m.forecast_speed_hz, m.forecast_torque_nm, m.forecast_failure,
         (SELECT group_concat(i.issue, ',') FROM model_run_issues i WHERE i.run_id = m.id) AS issues, m.detail,
         m.interval_coverage,
         (SELECT group_concat(f.flag, ',') FROM model_run_forecast_flags f WHERE f.run_id = m.id) AS forecast_flags,
         m.forecast_evidence, m.wear_mean_low_m, m.wear_mean_high_m
  FROM model_runs m WHERE m.advanced = 1;
)SQL",
    // 14 -> 15: `gearwatch publish`, the sender in a unit of its own ([mqtt] sender = "publisher"),
    // stores its counters here: it acquires nothing, so it has no run (docs/mqtt.md).
    R"SQL(
CREATE TABLE publisher_health (
  id INTEGER PRIMARY KEY,
  at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  pid INTEGER NOT NULL,
  final INTEGER NOT NULL CHECK (final IN (0, 1)),
  mqtt_published INTEGER NOT NULL DEFAULT 0,
  mqtt_delivered INTEGER NOT NULL DEFAULT 0,
  mqtt_connects INTEGER NOT NULL DEFAULT 0,
  mqtt_connect_failures INTEGER NOT NULL DEFAULT 0,
  mqtt_refused INTEGER NOT NULL DEFAULT 0,
  mqtt_outbox_dropped INTEGER NOT NULL DEFAULT 0,
  mqtt_publish_refused INTEGER NOT NULL DEFAULT 0,
  mqtt_resend_requests INTEGER NOT NULL DEFAULT 0,
  mqtt_resent INTEGER NOT NULL DEFAULT 0,
  mqtt_resend_gone INTEGER NOT NULL DEFAULT 0,
  mqtt_resend_ignored INTEGER NOT NULL DEFAULT 0
);
CREATE VIEW mqtt_publisher AS
  SELECT * FROM publisher_health WHERE id = (SELECT max(id) FROM publisher_health);
)SQL",
    // 15 -> 16: the depth calibrated by inspected wear depths (docs/model.md, "Depth calibration"):
    // the depth estimate (the model's mean times ρ), ρ's posterior median and ln SD, and how many
    // inspected depths it rests on; NULL without depth inspections.
    R"SQL(
ALTER TABLE model_runs ADD COLUMN wear_mean_estimate_m REAL;
ALTER TABLE model_runs ADD COLUMN wear_depth_ratio REAL;
ALTER TABLE model_runs ADD COLUMN wear_depth_ratio_log_sd REAL;
ALTER TABLE model_runs ADD COLUMN wear_depth_inspections INTEGER;
DROP VIEW predictions;
CREATE VIEW predictions AS
  SELECT m.id AS run_id, m.created_at, m.record_id, m.gear_pair, m.cycles, m.speed_hz, m.torque_nm,
         m.k_wear, m.k_pitting, m.rms_sa_measured, m.rms_sa_simulated, m.ics2_low, m.ics2_density_estimate,
         m.wear_mean_m, m.wear_max_m, m.pitting_mean, m.pitting_max,
         m.wear_limit_m, m.wear_cycles_left, m.wear_cycles_left_low, m.wear_cycles_left_high,
         m.pitting_limit, m.pitting_cycles_left, m.pitting_cycles_left_low, m.pitting_cycles_left_high,
         m.forecast_speed_hz, m.forecast_torque_nm, m.forecast_failure,
         (SELECT group_concat(i.issue, ',') FROM model_run_issues i WHERE i.run_id = m.id) AS issues, m.detail,
         m.interval_coverage,
         (SELECT group_concat(f.flag, ',') FROM model_run_forecast_flags f WHERE f.run_id = m.id) AS forecast_flags,
         m.forecast_evidence, m.wear_mean_low_m, m.wear_mean_high_m,
         m.wear_mean_estimate_m, m.wear_depth_ratio, m.wear_depth_ratio_log_sd, m.wear_depth_inspections
  FROM model_runs m WHERE m.advanced = 1;
)SQL",
    // 16 -> 17: an inspection's deepest wear point (the mould's profile) and its depths' own relative
    // SD (docs/model.md, "Deepest point"); NULL: not measured, or the configured SD.
    R"SQL(
ALTER TABLE inspections ADD COLUMN wear_depth_max_m REAL;
ALTER TABLE inspections ADD COLUMN wear_depth_relative_sd REAL;
)SQL",
    // 17 -> 18: the deepest-point posterior beside ρ's (docs/model.md, "Deepest point"): the mean and
    // SD of ln P, deepest / mean, and the inspections it rests on; NULL without inspected deepest points.
    "ALTER TABLE model_runs ADD COLUMN " GW_COL_PEAK_LOG_MEAN " REAL;\n"
    "ALTER TABLE model_runs ADD COLUMN " GW_COL_PEAK_LOG_SD " REAL;\n"
    "ALTER TABLE model_runs ADD COLUMN " GW_COL_PEAK_RATIO " REAL;\n"
    "ALTER TABLE model_runs ADD COLUMN " GW_COL_PEAK_INSPECTIONS " INTEGER;\n"
    R"SQL(
DROP VIEW predictions;
CREATE VIEW predictions AS
  SELECT m.id AS run_id, m.created_at, m.record_id, m.gear_pair, m.cycles, m.speed_hz, m.torque_nm,
         m.k_wear, m.k_pitting, m.rms_sa_measured, m.rms_sa_simulated, m.ics2_low, m.ics2_density_estimate,
         m.wear_mean_m, m.wear_max_m, m.pitting_mean, m.pitting_max,
         m.wear_limit_m, m.wear_cycles_left, m.wear_cycles_left_low, m.wear_cycles_left_high,
         m.pitting_limit, m.pitting_cycles_left, m.pitting_cycles_left_low, m.pitting_cycles_left_high,
         m.forecast_speed_hz, m.forecast_torque_nm, m.forecast_failure,
         (SELECT group_concat(i.issue, ',') FROM model_run_issues i WHERE i.run_id = m.id) AS issues, m.detail,
         m.interval_coverage,
         (SELECT group_concat(f.flag, ',') FROM model_run_forecast_flags f WHERE f.run_id = m.id) AS forecast_flags,
         m.forecast_evidence, m.wear_mean_low_m, m.wear_mean_high_m,
         )SQL" GW_DEPTH_RATIO_COLUMNS ", " GW_PEAK_RATIO_COLUMNS R"SQL(
  FROM model_runs m WHERE m.advanced = 1;
)SQL",
};

}  // namespace

int current_schema_version() noexcept { return static_cast<int>(kMigrations.size()); }

Vocabulary core_vocabulary() {
  Vocabulary v;
  auto add = [&](const char* domain, const auto& all) {
    auto& tokens = v[domain];
    for (auto value : all) tokens.emplace_back(to_string(value));
  };
  add("record_end_reason", kAllRecordEnds);
  add("wear_mechanism", dsp::kAllWearMechanisms);
  add("alert_kind", kAllAlertKinds);
  add("alert_severity", kAllAlertSeverities);
  add("alert_transition", kAllAlertTransitions);
  add("skip_reason", dsp::kAllSkipReasons);
  add("indicator_note", dsp::kAllIndicatorNotes);
  add("speed_source", dsp::kAllSpeedSources);
  add("carrier_band", dsp::kAllCarrierBands);
  add("model_update_kind", wear::kAllUpdateKinds);
  add("model_update_trigger", wear::kAllUpdateTriggers);
  add("model_update_outcome", wear::kAllUpdateOutcomes);
  add("model_issue", wear::kAllModelIssues);
  add("forecast_flag", wear::kAllForecastFlags);
  add("gap_family", gap::kAllFamilyKinds);
  add("gap_effect", gap::kAllCandidateEffects);
  return v;
}

const char* to_string(DatabaseKind kind) noexcept {
  switch (kind) {
    case DatabaseKind::empty: return "empty";
    case DatabaseKind::gearwatch: return "gearwatch";
    case DatabaseKind::gearwatch_before_application_id: return "gearwatch_before_application_id";
    case DatabaseKind::foreign: return "foreign";
  }
  return "?";
}

namespace {

std::int64_t single_integer(Database& db, const char* sql) {
  Statement st(db, sql);
  return st.step() ? st.get_int(0) : 0;
}

// The tables of schema version 1, which every gearwatch database has had since its first release.
bool has_first_version_tables(Database& db) {
  return single_integer(db,
                        "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name IN"
                        " ('runs', 'streams', 'records', 'indicator_values', 'indicator_skips', 'health_snapshots', 'inspections')") == 7;
}

}  // namespace

DatabaseIdentity identify_database(Database& db) {
  DatabaseIdentity id;
  id.application_id = single_integer(db, "PRAGMA application_id");
  id.user_version = db.user_version();
  id.schema_objects = single_integer(db, "SELECT count(*) FROM sqlite_master");
  if (id.application_id == kApplicationId) id.kind = DatabaseKind::gearwatch;
  else if (id.application_id != 0) id.kind = DatabaseKind::foreign;
  else if (id.schema_objects == 0 && id.user_version == 0) id.kind = DatabaseKind::empty;
  // Before application_id, a gearwatch database was known by its schema version and its tables.
  else if (id.user_version >= 1 && id.user_version <= current_schema_version() && has_first_version_tables(db))
    id.kind = DatabaseKind::gearwatch_before_application_id;
  else id.kind = DatabaseKind::foreign;
  return id;
}

void refuse_foreign_database(const std::string& path, const DatabaseIdentity& identity) {
  if (identity.kind != DatabaseKind::foreign) return;
  throw ForeignDatabase(path + " is not a gearwatch database (application_id " + std::to_string(identity.application_id) +
                        ", user_version " + std::to_string(identity.user_version) + ", " +
                        std::to_string(identity.schema_objects) + " tables, views, indexes and triggers); left untouched");
}

void enable_foreign_keys(Database& db) { db.exec("PRAGMA foreign_keys = ON"); }

void migrate_to_version(Database& db, int version) {
  for (int v = db.user_version(); v < std::min(version, current_schema_version()); ++v) {
    Transaction tx(db);
    db.exec(kMigrations[static_cast<std::size_t>(v)]);
    db.set_user_version(v + 1);
    tx.commit();
  }
}

void open_and_migrate(Database& db, const Vocabulary& extra) {
  // Identified before anything is written: not even the journal mode of another application's
  // file may change.
  refuse_foreign_database(db.path(), identify_database(db));
  db.exec("PRAGMA journal_mode = WAL");
  db.exec("PRAGMA synchronous = FULL");
  enable_foreign_keys(db);
  const int have = db.user_version();
  if (have > current_schema_version()) {
    throw SqliteError(0, db.path() + ": schema version " + std::to_string(have) +
                             " is newer than this gearwatch understands (" + std::to_string(current_schema_version()) + ")");
  }
  migrate_to_version(db, current_schema_version());
  // The vocabulary is this build's: rewritten at every writable open, so the database accepts
  // exactly the values this binary can produce.
  Vocabulary vocabulary = core_vocabulary();
  for (const auto& [domain, tokens] : extra) vocabulary[domain] = tokens;
  Transaction tx(db);
  db.exec("PRAGMA application_id = " + std::to_string(kApplicationId));
  db.exec("DELETE FROM vocabulary");
  Statement insert(db, "INSERT OR IGNORE INTO vocabulary(domain, token) VALUES (?, ?)");
  for (const auto& [domain, tokens] : vocabulary)
    for (const auto& token : tokens) insert.bind(1, domain).bind(2, token).run();
  tx.commit();
}

}  // namespace gearwatch::storage
