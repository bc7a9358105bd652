// Fixture for tests/no_sql_outside_storage.sh: a query built from fragments; the guard must find the
// fragment with the WHERE clause (line 4), not only literals that start a statement.
const char* const kHead = "kind, value ";
const char* const kTail = " WHERE kind IN (?,?)";
