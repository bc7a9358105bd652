#!/bin/sh
# Every SQL statement lives in storage/ behind its typed readers and writers (docs/storage.md):
# no other room's source may hold SQL text in a string literal, build a Statement, call SQLite
# or exec() on a connection. Known exceptions: none.
# Usage: no_sql_outside_storage.sh SOURCE_DIR [ROOM...]   (rooms default to every room but storage/)
set -eu
src=$1
shift
[ $# -gt 0 ] || set -- daemon report acquisition config core rig bench fuzz
cd "$src"
# A statement's fragments count too (a query built from pieces: " WHERE kind IN (?,?)").
pattern='"[^"]*\b(SELECT|INSERT INTO|UPDATE [a-z_]+ SET|DELETE FROM|CREATE (TABLE|VIEW|INDEX|TRIGGER)|DROP (TABLE|VIEW)|ALTER TABLE|PRAGMA|BEGIN|COMMIT|ROLLBACK|SAVEPOINT|WHERE|ORDER BY|GROUP BY|LEFT JOIN|INNER JOIN)\b|\bStatement\b|sqlite3_|sqlite3\.h|\.exec\('
if found=$(grep -rnE "$pattern" --include='*.cpp' --include='*.hpp' --include='*.h' --include='*.cc' "$@"); then
  echo "SQL outside storage/ (move it into a typed reader or writer in storage/):"
  echo "$found"
  exit 1
fi
echo "no SQL outside storage/ in: $*"
