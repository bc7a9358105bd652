#!/usr/bin/env bash
# run-vcan-unit-tests.sh — runs the Catch2 test binary's "[vcan]" tests (SocketCanSource against a
# real vcan0/vcan1, interface down/up and removal) inside the test VM, where the kernel has CAN.
#
# Usage: tests/vcan/run-vcan-unit-tests.sh PATH/TO/gearwatch_tests [CATCH2-FILTER]
#   The filter defaults to "[vcan]". Exit 0 = every selected test passed.
# Environment: see vcan-vm.sh (GEARWATCH_VCAN_CACHE, GEARWATCH_VCAN_SMP, GEARWATCH_VCAN_MEM).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
tests_binary=${1:?usage: run-vcan-unit-tests.sh PATH/TO/gearwatch_tests [FILTER]}
filter=${2:-[vcan]}
[ -x "$tests_binary" ] || { echo "run-vcan-unit-tests: '$tests_binary' is not an executable" >&2; exit 2; }

payload=$(mktemp -d)
trap 'rm -rf "$payload"' EXIT
cp "$tests_binary" "$payload/gearwatch_tests"
printf '%s\n' "$filter" >"$payload/filter"
# Catch2's exit status is the number of failed test cases; --warn NoTests makes a filter that
# selects nothing a failure (exit 2) rather than an empty pass. The [vcan] tests are hidden
# ("[.vcan]"), so they run only here, where they are named.
cat >"$payload/inside.sh" <<'EOF'
/payload/gearwatch_tests --warn NoTests "$(cat /payload/filter)"
EOF
start=$(date +%s)
set +e
"$here/vcan-vm.sh" "$payload" /payload/inside.sh 300
rc=$?
set -e
if [ "$rc" -eq 0 ]; then
  echo "VCAN UNIT TESTS PASSED ($filter, $(( $(date +%s) - start )) s including the VM boot)"
else
  echo "VCAN UNIT TESTS FAILED ($filter): exit status $rc"
fi
exit "$rc"
