#!/usr/bin/env bash
# demo.sh — the main job on the embedded default: build gearwatch, generate a rig capture
# (simulated UNSW spur rig, 100 kHz x 2 channels + tacho, CAN FD, 60 s), replay it through the
# whole pipeline (decode, records, indicators, SQLite) into demo/gearwatch.db and print what
# was found. Re-running it adds another run to the same database.
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
cd "$top"
tools/build.sh >/dev/null
out=${DEMO_DIR:-demo}
mkdir -p "$out"
gw=build/gearwatch
echo "== 1. simulate a rig capture (protocol v1, candump -L log)"
$gw simulate --out "$out/rig.log" --duration 60 --speed 10 --torque 20 --fd --start-revs 250000
echo "== 2. replay it through the pipeline into $out/gearwatch.db"
$gw replay "$out/rig.log" --db "$out/gearwatch.db" --config config/demo.toml
echo "== 3. records"
$gw query records --db "$out/gearwatch.db" --limit 6
echo "== 4. indicators of the newest record (channel 0)"
rid=$(sqlite3 "$out/gearwatch.db" "SELECT max(id) FROM records WHERE analysed = 1")
sqlite3 -header -column "$out/gearwatch.db" \
  "SELECT name, round(value, 6) AS value FROM indicators WHERE record_id = $rid AND channel = 0 ORDER BY name"
echo "== 5. acquisition health"
$gw query health --db "$out/gearwatch.db" --format csv | cut -d, -f1-16
echo "== 6. the twin's natural frequencies against the seed's Table 5.5"
$gw twin modes
