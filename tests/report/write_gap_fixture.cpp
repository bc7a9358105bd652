// Writes a database holding the known gap report (tests/gap_report_fixture.hpp) after two older
// reports, for the gap page's browser test:  write_gap_fixture DATABASE
#include <cstdio>
#include <exception>

#include "../gap_report_fixture.hpp"
#include "gearwatch/storage/gap_reports.hpp"
#include "gearwatch/storage/schema.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: write_gap_fixture DATABASE\n");
    return 2;
  }
  try {
    using namespace gearwatch;
    storage::Database db(argv[1]);
    storage::open_and_migrate(db);
    storage::Transaction tx(db);
    // A casing mode drifting into view: no significant family at first, then the fixed frequency.
    gap::GapReport older = testing::known_gap_report();
    older.input_revolutions = 61728.0;
    older.chosen.clear();
    older.k_wear_after.reset();
    for (auto& g : older.before) {
      g.significant = false;
      g.distance_db *= 0.3;
      g.distance_interval_db = {g.distance_interval_db.low * 0.3, g.distance_interval_db.high * 0.3};
    }
    storage::insert_gap_report(db, older, {std::nullopt, 0});
    older.input_revolutions = 92592.5;
    older.before[5] = testing::family_gap(gap::FamilyKind::fixed_frequency, 8.0, 6.25, 9.75, 0.55, true);
    storage::insert_gap_report(db, older, {std::nullopt, 0});
    storage::insert_gap_report(db, testing::known_gap_report(), {std::nullopt, 0});
    tx.commit();
    // The drift the newest report raised, as the daemon stores it.
    db.exec("INSERT INTO alert_events(severity, kind, transition, value, message, subject) VALUES ('warning', 'twin_drift',"
            " 'raised', '12.6 dB', 'the twin and the gearbox differ in fixed_frequency by 12.6 dB', 'fixed_frequency')");
    db.exec("INSERT INTO alert_state(kind, channel, subject, active, value, consecutive_present, consecutive_absent)"
            " VALUES ('twin_drift', -1, 'fixed_frequency', 1, '12.6 dB', 1, 0)");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "write_gap_fixture: %s\n", e.what());
    return 1;
  }
  return 0;
}
