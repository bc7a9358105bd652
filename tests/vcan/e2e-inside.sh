# e2e-inside.sh — the end-to-end test's steps, run INSIDE the test VM by busybox sh
# (run-vcan-test.sh builds the payload: gearwatch, canplayer, sqlite3, vcan.toml, iface-map, and per
# capture NAME.log the reference NAME.db it made on the host with `gearwatch replay` of it; the
# captures: cap.log, a simulated rig capture, and campaign.log, one record of the rig simulator's
# lubricated wear campaign). For each capture, a daemon of its own:
#  1. `gearwatch run` listens on vcan0 and writes /tmp/run.db;
#  2. canplayer replays the capture onto vcan0 in real time (its timestamps pace it);
#  3. SIGTERM: the daemon stops acquisition, drains its ring, commits, exits 0;
#  4. the reference: /payload/NAME.db, or, without it, `gearwatch replay` of the capture here
#     (same binary, same capture, same config: the result is the same, only ~30x slower under
#     emulation, which is why the host makes it);
#  5. both databases must hold the same records (start, sample count, end reason), the live run
#     must have lost nothing (kernel drops, ring overflows, gaps, malformed frames), and every
#     indicator of every record must be the same as the replay's (relative 1e-9: the VM's CPU may
#     take other SIMD paths in FFTW than the host's).
# Prints "VCAN E2E: PASS ..." or "VCAN E2E: FAIL: <reason>" and exits 0 / 1.
P=/payload
DRAIN_LIMIT_S=${DRAIN_LIMIT_S:-200}
[ -f $P/limits ] && . $P/limits
map=$(cat $P/iface-map)
now() { date +%s; }
t_start=$(now)
fail() {
  echo "VCAN E2E: FAIL: $*"
  for f in /tmp/run.log /tmp/replay.log; do
    [ -s $f ] && { echo "---- last lines of $f"; tail -n 40 $f; }
  done
  exit 1
}
step() { echo "vcan-e2e [+$(( $(now) - t_start )) s] $*"; }

run_one() {
  name=$1
  # 1. the daemon, live on vcan0
  rm -f /tmp/run.db /tmp/run.db-wal /tmp/run.db-shm /tmp/replay.db /tmp/run.log /tmp/replay.log
  step "$name: starting gearwatch run on vcan0"
  $P/gearwatch run --config $P/vcan.toml 2>/tmp/run.log &
  daemon=$!
  waited=0
  until grep -q "listening on vcan0" /tmp/run.log 2>/dev/null; do
    kill -0 $daemon 2>/dev/null || { wait $daemon; fail "gearwatch run exited (status $?) before listening on vcan0"; }
    waited=$((waited + 1))
    [ $waited -le 300 ] || fail "gearwatch run did not report 'listening on vcan0' within 30 s"
    sleep 0.1
  done
  step "daemon listening"

  # 2. the capture, replayed onto vcan0 at its recorded pace
  frames=$(wc -l <$P/$name.log)
  step "canplayer: $frames frames, $map"
  t0=$(now)
  $P/canplayer -I $P/$name.log $map || fail "canplayer failed (status $?)"
  play_s=$(( $(now) - t0 ))
  step "canplayer done in ${play_s} s"
  kill -0 $daemon 2>/dev/null || { wait $daemon; fail "gearwatch run died during the replay (status $?)"; }

  # 3. orderly stop: drain and commit
  t0=$(now)
  kill -TERM $daemon
  ( sleep $DRAIN_LIMIT_S; kill -KILL $daemon 2>/dev/null ) &
  guard=$!
  wait $daemon
  run_status=$?
  kill $guard 2>/dev/null
  drain_s=$(( $(now) - t0 ))
  step "gearwatch run exited with status $run_status after SIGTERM (${drain_s} s to drain and commit)"
  [ $run_status -eq 0 ] || fail "gearwatch run exited with status $run_status after SIGTERM (137 = killed after ${DRAIN_LIMIT_S} s)"

  # 4. the reference: the same capture from the file
  if [ -f $P/$name.db ]; then
    reference=$P/$name.db
    step "reference: gearwatch replay of the same capture, made on the host"
  else
    reference=/tmp/replay.db
    t0=$(now)
    $P/gearwatch replay $P/$name.log --db $reference --config $P/vcan.toml 2>/tmp/replay.log >/tmp/replay.out ||
      fail "gearwatch replay failed (status $?)"
    step "gearwatch replay done in the VM in $(( $(now) - t0 )) s"
  fi

  # 5. compare
  q="SELECT start_index, sample_count, end_reason FROM records ORDER BY start_index"
  $P/sqlite3 -separator ' | ' /tmp/run.db "$q" >/tmp/run.rows 2>/tmp/run.sqlerr || fail "sqlite3 on run.db: $(cat /tmp/run.sqlerr)"
  $P/sqlite3 -separator ' | ' $reference "$q" >/tmp/replay.rows 2>/tmp/replay.sqlerr || fail "sqlite3 on $reference: $(cat /tmp/replay.sqlerr)"
  health_q="SELECT COALESCE(SUM(kernel_drops + ring_overflows + gaps + malformed_frames), -1) FROM acquisition_health"
  losses=$($P/sqlite3 /tmp/run.db "$health_q" 2>/tmp/health.sqlerr) || fail "sqlite3 acquisition_health: $(cat /tmp/health.sqlerr)"
  echo "---- live run (gearwatch run on vcan0): start_index | sample_count | end_reason"
  cat /tmp/run.rows
  echo "---- file replay (gearwatch replay): start_index | sample_count | end_reason"
  cat /tmp/replay.rows
  echo "---- live run acquisition_health (every snapshot)"
  $P/sqlite3 -header -separator ' | ' /tmp/run.db "SELECT * FROM acquisition_health" 2>&1 | tail -n 12
  n_run=$(wc -l </tmp/run.rows)
  n_replay=$(wc -l </tmp/replay.rows)
  samples_run=$(awk -F' [|] ' '{s += $2} END {print s + 0}' /tmp/run.rows)
  samples_replay=$(awk -F' [|] ' '{s += $2} END {print s + 0}' /tmp/replay.rows)
  echo "records: live $n_run, replay $n_replay; samples in records: live $samples_run, replay $samples_replay; live losses: $losses"

  [ "$n_replay" -gt 0 ] || fail "the replay produced no records: nothing to compare"
  cmp -s /tmp/run.rows /tmp/replay.rows || {
    echo "---- difference (replay -> live)"
    diff /tmp/replay.rows /tmp/run.rows
    fail "the live run's records differ from the replay's ($n_run vs $n_replay records)"
  }
  [ "$losses" = "0" ] || fail "the live run lost data: kernel_drops + ring_overflows + gaps + malformed_frames = $losses"
  # 6. the same analysis: every indicator of every record, live against replay
  iq="SELECT r.start_index, i.channel, i.name, CASE WHEN i.value IS NULL THEN 'null' ELSE printf('%.17g', i.value) END FROM indicator_values i JOIN records r ON r.id = i.record_id ORDER BY 1, 2, 3"
  $P/sqlite3 -separator ' ' /tmp/run.db "$iq" >/tmp/run.ind 2>/tmp/run.sqlerr || fail "sqlite3 indicators of run.db: $(cat /tmp/run.sqlerr)"
  $P/sqlite3 -separator ' ' $reference "$iq" >/tmp/replay.ind 2>/tmp/replay.sqlerr || fail "sqlite3 indicators of $reference: $(cat /tmp/replay.sqlerr)"
  n_ind=$(wc -l </tmp/replay.ind)
  [ "$n_ind" -gt 0 ] || fail "$name: the replay stored no indicators"
  [ "$(wc -l </tmp/run.ind)" = "$n_ind" ] || fail "$name: live stored $(wc -l </tmp/run.ind) indicator values, replay $n_ind"
  worst=$(paste -d ' ' /tmp/replay.ind /tmp/run.ind | awk '
    $1 != $5 || $2 != $6 || $3 != $7 { print "mismatch: " $0; exit }
    { d = $4 - $8; if (d < 0) d = -d; m = $4 < 0 ? -$4 : $4; r = m > 0 ? d / m : d; if (r > w) { w = r; at = $3 " ch " $2 " record " $1 } }
    END { printf "%.3g %s\n", w, at }')
  case "$worst" in mismatch*) fail "$name: indicator rows differ: $worst" ;; esac
  rel=${worst%% *}
  awk -v r="$rel" 'BEGIN { exit !(r <= 1e-9) }' || fail "$name: an indicator differs by $worst (relative) between live and replay"
  echo "$name: $n_ind indicator values equal to the replay's (largest relative difference $worst)"
  grep "ics2_low_band\|rms_sa " /tmp/run.ind | sed "s/^/  $name live: /"
  summary="$summary; $name: $n_run records identical, $samples_run samples, $n_ind indicators equal, zero losses, canplayer ${play_s} s, drain ${drain_s} s"

}

summary=""
for capture in cap campaign; do
  [ -f $P/$capture.log ] || { [ $capture = cap ] && fail "the payload has no cap.log"; continue; }
  run_one $capture
done
echo "VCAN E2E: PASS:${summary#;}; total $(( $(now) - t_start )) s in the VM"
exit 0
