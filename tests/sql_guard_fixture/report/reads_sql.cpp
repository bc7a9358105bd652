// Fixture for tests/no_sql_outside_storage.sh: a room that reads SQL itself, which the guard must refuse.
const char* const kQuery = "SELECT count(*) FROM records";
