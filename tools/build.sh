#!/usr/bin/env bash
# build.sh — configures and builds gearwatch (Release) into build/; the executable is build/gearwatch.
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
cd "$top"
tools/install-deps.sh "$@"
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
# --test-build (tools/test.sh): only what the tests run; otherwise everything, benchmarks included.
targets=()
[ "${1:-}" = "--test-build" ] && targets=(--target test_programs)
cmake --build build --parallel "$(nproc)" "${targets[@]}"
