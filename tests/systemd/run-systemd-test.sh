#!/usr/bin/env bash
# run-systemd-test.sh — gearwatch as a plant runs it: its Debian package, built from this build
# with CPack, installed with apt-get into a Debian root that boots with systemd as PID 1 and real
# vcan interfaces (systemd-vm.sh, under qemu). inside.sh starts the service on vcan1, plays a
# `gearwatch simulate` capture onto it with canplayer, stops it, kills it, and checks the
# readiness time, the hardening, the watchdog, the records against `gearwatch replay` of the same
# capture (made here, natively), the restart and the database's integrity, and the exposure.
#
# Usage: tests/systemd/run-systemd-test.sh BUILD_DIR
#   BUILD_DIR  a configured and built build directory (its gearwatch and CPackConfig.cmake)
# Exit 0 = pass; the last line is a one-line summary ("SYSTEMD TEST: PASS ..." / "... FAIL ...").
# Environment: GEARWATCH_SYSTEMD_DURATION (seconds of capture, default 22), GEARWATCH_SYSTEMD_LIMIT
# (seconds the VM may run, default 600), and those of systemd-vm.sh.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=$(cd "${1:?usage: run-systemd-test.sh BUILD_DIR}" && pwd)
gearwatch=$build/gearwatch
duration=${GEARWATCH_SYSTEMD_DURATION:-22}
start=$(date +%s)
[ -x "$gearwatch" ] || { echo "SYSTEMD TEST: FAIL: $gearwatch is not built"; exit 2; }
for tool in cpack dpkg-shlibdeps file sqlite3; do
  command -v "$tool" >/dev/null || { echo "SYSTEMD TEST: FAIL: $tool is missing (tools/install-deps.sh --test)"; exit 2; }
done

payload=$(mktemp -d)
trap 'rm -rf "$payload"' EXIT
mkdir -p "$payload/debs"

# The package, as tools/package.sh makes it, from this build's gearwatch.
(cd "$payload" && cpack -G DEB --config "$build/CPackConfig.cmake" -B "$payload/cpack" >"$payload/cpack.log" 2>&1) ||
  { cat "$payload/cpack.log"; echo "SYSTEMD TEST: FAIL: cpack could not build the package"; exit 1; }
mv "$payload"/cpack/gearwatch_*.deb "$payload/debs/"
rm -rf "$payload/cpack" "$payload/cpack.log"
echo "systemd-test: package $(cd "$payload/debs" && ls -- *.deb), Depends: $(dpkg-deb -f "$payload"/debs/*.deb Depends)"

# The capture, and the reference: `gearwatch replay` of it with the same config, natively.
"$gearwatch" simulate --out "$payload/cap.log" --duration "$duration" >"$payload/simulate.out" 2>&1 ||
  { cat "$payload/simulate.out"; echo "SYSTEMD TEST: FAIL: gearwatch simulate failed"; exit 1; }
iface=$(awk 'NF >= 3 && $1 ~ /^\(/ { print $2; exit }' "$payload/cap.log")
echo "vcan1=$iface" >"$payload/iface"
"$gearwatch" replay "$payload/cap.log" --db "$payload/replay.db" --config "$here/gearwatch-vcan1.toml" \
  >"$payload/replay.out" 2>&1 ||
  { tail -n 20 "$payload/replay.out"; echo "SYSTEMD TEST: FAIL: gearwatch replay failed"; exit 1; }
sqlite3 -batch "$payload/replay.db" \
  "SELECT start_index, sample_count, end_reason, analysed FROM records ORDER BY start_index" >"$payload/replay.rows"
echo "systemd-test: capture of $duration s: $(wc -l <"$payload/cap.log") frames; replay: $(wc -l <"$payload/replay.rows") records"
rm -f "$payload"/replay.db* "$payload/replay.out" "$payload/simulate.out"
cp "$here/inside.sh" "$here/gearwatch-vcan1.toml" "$payload/"

set +e
"$here/systemd-vm.sh" "$payload" "${GEARWATCH_SYSTEMD_LIMIT:-600}"
rc=$?
set -e
if [ "$rc" -eq 0 ]; then
  echo "SYSTEMD TEST: PASS ($(( $(date +%s) - start )) s in all: package, capture, root, boot, test)"
else
  echo "SYSTEMD TEST: FAIL: exit status $rc ($(( $(date +%s) - start )) s in all; see the lines above)"
fi
exit "$rc"
