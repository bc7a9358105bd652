#!/usr/bin/env bash
# demo.sh — the whole job on a simulated rig: build gearwatch, run the rig simulator's compressed
# lubricated wear campaign (the thesis's test 1: 10 measured stops over 3.2 M cycles, 3 s records,
# 100 kHz x 2 channels + tacho, CAN FD candump logs, and the truth.json the daemon never reads),
# replay the records in cycle order through `gearwatch replay` with the model on, enter two
# pitted-area inspections as a maintenance engineer would, and print what the engineer wants: the
# wear-mode alert and when it came, the K updates, the wear depth and pitting density against the
# truth, the forecast and remaining life, and where the report is. Starts afresh in demo/ each run.
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
cd "$top"
start=$(date +%s)
# Dependencies, then the gearwatch executable only: the tests and benchmarks are not needed here
# (an existing build/ keeps its configuration).
tools/install-deps.sh
if [ ! -f build/CMakeCache.txt ]; then
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DGEARWATCH_BUILD_TESTS=OFF -DGEARWATCH_BUILD_BENCH=OFF >/dev/null
fi
cmake --build build --target gearwatch --parallel "$(nproc)" >/dev/null
built=$(date +%s)
out=${DEMO_DIR:-demo}
rm -rf "$out/campaign" "$out/report" "$out/gearwatch.db" "$out/gearwatch.db-wal" "$out/gearwatch.db-shm"
mkdir -p "$out"
gw=build/gearwatch
db="$out/gearwatch.db"
truth="$out/campaign/truth.json"
records=${DEMO_RECORDS:-10}

echo "== 1. the rig simulator writes a compressed lubricated campaign ($records records)"
$gw simulate --campaign lubricated --records "$records" --seconds 3.2 --out "$out/campaign" | sed 's/^/   /'

echo "== 2. replay the records in cycle order into $db (model on); two inspections on the way"
# The engineer opens the gearbox at the 5th and 6th stops and measures the pitted area; the demo
# takes the values from the truth (that is what an inspection would find).
inspect_at=(4 5)
i=0
for f in "$out"/campaign/rec_*.log; do
  $gw replay "$f" --db "$db" --config config/demo.toml >"$out/replay.log" 2>&1 || { cat "$out/replay.log"; exit 1; }
  if [ "$i" = "${inspect_at[1]}" ]; then
    for k in "${inspect_at[@]}"; do
      read -r cycles pitted < <(sqlite3 -separator ' ' :memory: \
        "SELECT json_extract(value, '$.cycles'), json_extract(value, '$.pitting_density')
         FROM json_each(readfile('$truth'), '$.records') WHERE key = $k")
      echo "   inspection at $cycles cycles: pitted area $pitted"
      $gw inspect --db "$db" --cycles "$cycles" --pitted-area "$pitted" >/dev/null
    done
  fi
  i=$((i + 1))
done
echo "   $i records replayed"

echo "== 3. the wear-mode alert, and when it came"
onset=$(sqlite3 :memory: "SELECT min(key) FROM json_each(readfile('$truth'), '$.records') WHERE json_extract(value, '$.pitting_density') > 0")
onset_cycles=$(sqlite3 :memory: "SELECT json_extract(value, '$.cycles') FROM json_each(readfile('$truth'), '$.records') WHERE key = $onset")
echo "   truth: first pitted record #$onset ($onset_cycles cycles)"
sqlite3 -header -column "$db" "
  SELECT a.channel, a.value AS verdict, (SELECT count(*) FROM records r2 WHERE r2.id < r.id) AS record,
         r.input_revolutions AS cycles, (SELECT count(*) FROM records r2 WHERE r2.id < r.id) - $onset AS records_after_onset
  FROM alerts a JOIN records r ON r.id = a.record_id
  WHERE a.kind = 'wear_mechanism' AND a.transition = 'raised' ORDER BY a.id" | sed 's/^/   /'

echo "== 4. K updates (the purple loop: K_wear from RMS_SA, K_pitting from the inspections and ICS2)"
sqlite3 -header -column "$db" "
  SELECT cycles, kind, outcome, printf('%.3g', old_value) AS old, printf('%.3g', new_value) AS new,
         printf('%.4g', measured) AS measured, printf('%.4g', simulated_after) AS simulated
  FROM k_updates ORDER BY id" | sed 's/^/   /'
echo "   truth's K_wear: $(sqlite3 :memory: "SELECT group_concat(printf('%.3g from %g', json_extract(value, '$.k_wear'), json_extract(value, '$.cycles')), ', ')
  FROM (SELECT value, json_extract(value, '$.k_wear') AS k, lag(json_extract(value, '$.k_wear')) OVER (ORDER BY key) AS prev
        FROM json_each(readfile('$truth'), '$.records')) WHERE prev IS NULL OR k <> prev") (m^2/N; the truth's phases change between records)"

echo "== 5. wear depth and pitting density: the model against the truth"
sqlite3 -header -column "$db" "
  WITH t AS (SELECT json_extract(value, '$.cycles') AS cycles,
                    json_extract(value, '$.combined_mean_wear_depth_um') AS depth_um,
                    json_extract(value, '$.pitting_density') AS pitting
             FROM json_each(readfile('$truth'), '$.records'))
  SELECT p.cycles, printf('%.3f', p.wear_mean_m * 1e6) AS model_depth_um, printf('%.3f', t.depth_um) AS truth_depth_um,
         printf('%+.1f %%', 100.0 * (p.wear_mean_m * 1e6 - t.depth_um) / t.depth_um) AS depth_error,
         printf('%.2f %%', 100.0 * p.pitting_mean) AS model_pitting, printf('%.2f %%', 100.0 * t.pitting) AS truth_pitting
  FROM predictions p JOIN t ON t.cycles = p.cycles ORDER BY p.cycles" | sed 's/^/   /'

echo "== 6. forecast and remaining life (at the newest record's speed and torque)"
$gw twin state --db "$db" | sed -n '/^prediction/,$p' | sed 's/^/   /'
# The truth's own cycles left at the newest record (truth.json's limits: the truth continued past
# the campaign to the model's limits), to hold the forecast and its interval against.
sqlite3 :memory: "
  WITH l AS (SELECT json_extract(readfile('$truth'), '$.limits') AS v),
       last AS (SELECT max(json_extract(value, '$.cycles')) AS c FROM json_each(readfile('$truth'), '$.records'))
  SELECT '   truth: ' ||
         CASE WHEN json_type(v, '$.pitting_limit_cycles') IN ('integer', 'real')
              THEN printf('pitting limit %g %% reached %.4g M cycles after the newest record', 100 * json_extract(v, '$.pitting_limit'),
                          max(0, json_extract(v, '$.pitting_limit_cycles') - c) / 1e6)
              ELSE 'pitting limit not reached within the search' END || '; ' ||
         CASE WHEN json_type(v, '$.wear_limit_cycles') IN ('integer', 'real')
              THEN printf('wear limit %.3f mm reached %.4g M cycles after it', 1e3 * json_extract(v, '$.wear_limit_m'),
                          max(0, json_extract(v, '$.wear_limit_cycles') - c) / 1e6)
              ELSE printf('wear limit %.3f mm not reached within %.4g M cycles', 1e3 * json_extract(v, '$.wear_limit_m'),
                          json_extract(v, '$.searched_to_cycles') / 1e6) END
  FROM l, last"

echo "== 7. the maintenance page"
$gw report --db "$db" --out "$out/report" >/dev/null
echo "   open $out/report/index.html   (or: gearwatch query alerts|updates|predictions --db $db)"
echo "== demo took $(( $(date +%s) - start )) s ($(( built - start )) s of it building)"
