#!/usr/bin/env bash
# test.sh — builds gearwatch and runs every test with CTest: the Catch2 suite (one CTest test
# per TEST_CASE) and the real-vcan tests in a qemu VM. Prints CTest's summary
# ("100% tests passed, 0 tests failed out of N"); exit 0 only if all passed.
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
cd "$top"
tools/build.sh --test
cd build
ctest --output-on-failure --timeout 900 -j "$(nproc)" "$@"
