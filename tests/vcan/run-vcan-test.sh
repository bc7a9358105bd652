#!/usr/bin/env bash
# run-vcan-test.sh — end-to-end test over a real vcan interface: a simulated rig capture
# (100 kHz x 2 vibration channels + tacho, CAN FD), then one record of the rig simulator's
# lubricated wear campaign (the pitted end of the test), are each played onto vcan0 by can-utils'
# canplayer while `gearwatch run` listens; each database must hold the same records and the same
# indicators as `gearwatch replay` of the same capture, with zero losses. Runs in the qemu test VM
# (vcan-vm.sh), so it works on hosts whose kernel has no CAN.
#
# Usage: tests/vcan/run-vcan-test.sh PATH/TO/gearwatch
# Exit 0 = pass; the last line is a one-line summary ("VCAN E2E: PASS ..." / "... FAIL ...").
# Environment:
#   GEARWATCH_VCAN_DURATION  seconds of signal to simulate (default 22)
#   GEARWATCH_VCAN_CAMPAIGN_S  seconds of the campaign record (default 5.5: one 5 s record)
#   GEARWATCH_VCAN_DRAIN_S   how long the daemon may take to drain after SIGTERM (default 200;
#                            processing is ~30x slower under emulation and works through the
#                            ring's backlog after the capture ends)
#   GEARWATCH_VCAN_REPLAY_IN_VM=1  make the reference replay inside the VM too (slower: ~90 s
#                            more) instead of on the host
#   and those of vcan-vm.sh (GEARWATCH_VCAN_CACHE, GEARWATCH_VCAN_SMP, GEARWATCH_VCAN_MEM).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
gearwatch=${1:?usage: run-vcan-test.sh PATH/TO/gearwatch}
duration=${GEARWATCH_VCAN_DURATION:-22}
campaign_s=${GEARWATCH_VCAN_CAMPAIGN_S:-5.5}
[ -x "$gearwatch" ] || { echo "VCAN E2E: FAIL: '$gearwatch' is not an executable"; exit 2; }
"$here/install-deps.sh"

start=$(date +%s)
payload=$(mktemp -d)
trap 'rm -rf "$payload"' EXIT

# The capture is made on the host (native speed); the VM only plays it.
if ! "$gearwatch" simulate --out "$payload/cap.log" --duration "$duration" --speed 10 --torque 20 --fd \
     >"$payload/simulate.out" 2>&1; then
  cat "$payload/simulate.out"
  echo "VCAN E2E: FAIL: gearwatch simulate could not make the capture"
  exit 1
fi
# The campaign record: the last of a two-stop lubricated campaign (3.2 M cycles, ~17 % pitted).
if ! "$gearwatch" simulate --campaign lubricated --records 2 --seconds "$campaign_s" --out "$payload/campaign" \
     >"$payload/campaign.out" 2>&1; then
  cat "$payload/campaign.out"
  echo "VCAN E2E: FAIL: gearwatch simulate could not make the campaign record"
  exit 1
fi
record=$(ls "$payload"/campaign/rec_*.log | tail -n 1)
echo "vcan-e2e: campaign record $(basename "$record"): $(grep "^$(basename "$record")" "$payload/campaign.out" | cut -d: -f2-)"
mv "$record" "$payload/campaign.log"
rm -rf "$payload/campaign" "$payload/campaign.out"
# canplayer maps interfaces by name: send the capture's interface (first field after the time) as vcan0.
iface=$(awk 'NF >= 3 && $1 ~ /^\(/ { print $2; exit }' "$payload/cap.log")
[ -n "$iface" ] || { echo "VCAN E2E: FAIL: the capture has no candump -L lines"; exit 1; }
[ "$(awk 'NF >= 3 && $1 ~ /^\(/ { print $2; exit }' "$payload/campaign.log")" = "$iface" ] ||
  { echo "VCAN E2E: FAIL: the campaign record uses another interface name than the capture"; exit 1; }
echo "vcan0=$iface" >"$payload/iface-map"
echo "DRAIN_LIMIT_S=${GEARWATCH_VCAN_DRAIN_S:-200}" >"$payload/limits"
echo "vcan-e2e: capture of ${duration} s: $(wc -l <"$payload/cap.log") frames, $(du -h "$payload/cap.log" | cut -f1), interface $iface"

# The reference databases: `gearwatch replay` of the same captures, at native speed.
if [ "${GEARWATCH_VCAN_REPLAY_IN_VM:-0}" != 1 ]; then
  for name in cap campaign; do
    if ! "$gearwatch" replay "$payload/$name.log" --db "$payload/$name.db" --config "$here/vcan.toml" \
         >"$payload/replay.out" 2>&1; then
      tail -n 20 "$payload/replay.out"
      echo "VCAN E2E: FAIL: gearwatch replay of $name.log failed on the host"
      exit 1
    fi
    echo "vcan-e2e: reference $name: $(tail -n 1 "$payload/replay.out")"
  done
  rm -f "$payload/replay.out"
fi
cp "$gearwatch" "$payload/gearwatch"
cp "$(command -v canplayer)" "$payload/canplayer"
cp "$(command -v sqlite3)" "$payload/sqlite3"
cp "$here/vcan.toml" "$here/e2e-inside.sh" "$payload/"

set +e
"$here/vcan-vm.sh" "$payload" /payload/e2e-inside.sh $(( duration + ${campaign_s%.*} + 500 ))
rc=$?
set -e
if [ "$rc" -eq 0 ]; then
  echo "VCAN E2E: PASS ($(( $(date +%s) - start )) s in all, VM boot included)"
else
  echo "VCAN E2E: FAIL: exit status $rc ($(( $(date +%s) - start )) s in all; see the lines above)"
fi
exit "$rc"
