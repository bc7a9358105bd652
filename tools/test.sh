#!/usr/bin/env bash
# test.sh — builds gearwatch and runs every test with CTest: the Catch2 suite (one CTest test
# per TEST_CASE) and the real-vcan tests in a qemu VM. Prints CTest's summary
# ("100% tests passed, 0 tests failed out of N"); exit 0 only if all passed.
# On a fresh machine the dependencies only the tests use (qemu, chromium, clang, mosquitto …) are
# downloaded and installed while gearwatch compiles, and so are the test VMs' kernel and the systemd
# VM's Debian root (network-bound, cached for later runs); the tests start once both are done.
set -euo pipefail
# Each phase's duration goes to stderr, so a slow run shows where its time went.
started=$SECONDS
phase() { echo "test.sh: $1 took $((SECONDS - started)) s" >&2; started=$SECONDS; }
top=$(cd "$(dirname "$0")/.." && pwd)
cd "$top"
tools/install-deps.sh --test-build
phase "installing the build dependencies"
mkdir -p build
deps_log=build/install-test-deps.log
# The VM root needs root (debootstrap); if fetching it fails here, systemd_service_from_deb tries
# again and reports why.
prepare_vms() {
  [ "$(id -u)" -eq 0 ] || return 0
  tests/systemd/systemd-vm.sh --prepare ||
    echo "test.sh: preparing the systemd VM's root failed; the systemd test will try again" >&2
}
# At the build's own priority: the installer is mostly network- and disk-bound and needs little CPU,
# but at the lowest priority each of its short CPU steps (apt's, dpkg's, debootstrap's) waits for a
# compiler to yield, and it then finished after the build instead of well before it (docs/ci.md).
# The next phase's line says how long the tests waited for it.
{
  tools/install-deps.sh --test && prepare_vms
} >"$deps_log" 2>&1 &
deps_pid=$!
# A failed build must not leave the package manager running unattended behind it.
trap 'wait "$deps_pid" 2>/dev/null || true' EXIT
tools/build.sh --test-build
phase "building"
if ! wait "$deps_pid"; then
  cat "$deps_log" >&2
  echo "test.sh: installing the test dependencies failed (tools/install-deps.sh --test)" >&2
  exit 1
fi
trap - EXIT
phase "waiting for the test dependencies after the build"
cat "$deps_log" >&2
cd build
status=0
ctest --output-on-failure --timeout 900 -j "$(nproc)" "$@" || status=$?
phase "running the tests"
exit "$status"
