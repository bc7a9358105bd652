#!/usr/bin/env bash
# run-fuzzers.sh — builds the libFuzzer targets with clang-14 (ASan + UBSan) in build-fuzz/ and
# runs each for a bounded time from its seed corpus (fuzz/corpus/<target>/, read only: what the
# run finds goes to a scratch corpus). Prints, per target, the executions and the crashes; a crash
# input is kept as build-fuzz/artifacts/<target>-crash-<sha1>. Exit 0 only if nothing crashed.
#
# Usage: fuzz/run-fuzzers.sh [--build-only] [--time SECONDS] [TARGET...]
#   targets: fuzz_protocol_decoder fuzz_candump_log fuzz_config (default: all); SECONDS: 50 each
# Environment: GEARWATCH_FUZZ_BUILD_DIR (default build-fuzz), CXX_FUZZ (default clang++-14).
# Needs Debian's clang-14 and libfuzzer-14-dev (tools/install-deps.sh --test). docs/fuzzing.md.
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
build=${GEARWATCH_FUZZ_BUILD_DIR:-$top/build-fuzz}
seconds=50 build_only=0 targets=()
while [ $# -gt 0 ]; do
  case $1 in
    --build-only) build_only=1 ;;
    --time) seconds=${2:?--time SECONDS}; shift ;;
    *) targets+=("$1") ;;
  esac
  shift
done
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_protocol_decoder fuzz_candump_log fuzz_config)
cxx=${CXX_FUZZ:-clang++-14}
command -v "$cxx" >/dev/null || { echo "FUZZ: FAIL: $cxx is missing (tools/install-deps.sh --test)"; exit 2; }

# Configure once; a build dir of its own (Clang, sanitizers), no tests or benchmarks in it.
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$top" -B "$build" -G Ninja -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=None -DCMAKE_CXX_FLAGS=-O1 \
    -DGEARWATCH_BUILD_FUZZERS=ON -DGEARWATCH_BUILD_TESTS=OFF -DGEARWATCH_BUILD_BENCH=OFF >"$build.configure.log" 2>&1 ||
    { cat "$build.configure.log"; echo "FUZZ: FAIL: configuring $build"; exit 2; }
  rm -f "$build.configure.log"
fi
# Several callers (one CTest test per target) may build at once: one build at a time.
exec 9>"$build/.build-lock"
flock 9
cmake --build "$build" --target "${targets[@]}" >"$build/build.log" 2>&1 ||
  { tail -n 30 "$build/build.log"; echo "FUZZ: FAIL: building ${targets[*]}"; exit 2; }
flock -u 9
[ "$build_only" = 1 ] && { echo "FUZZ: built ${targets[*]} in $build"; exit 0; }

status=0
mkdir -p "$build/artifacts"
for t in "${targets[@]}"; do
  scratch=$(mktemp -d)
  log=$build/$t.log
  set +e
  "$build/fuzz/$t" -max_total_time="$seconds" -print_final_stats=1 -timeout=10 -rss_limit_mb=2048 \
    -artifact_prefix="$build/artifacts/$t-" "$scratch" "$top/fuzz/corpus/$t" >"$log" 2>&1
  rc=$?
  set -e
  rm -rf "$scratch"
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  if [ "$rc" -eq 0 ]; then
    echo "FUZZ $t: ${runs:-?} executions in $seconds s (${rate:-?}/s), coverage ${cov:-?} edges, 0 crashes"
  else
    status=1
    artifact=$(sed -n "s/.*Test unit written to \(.*\)/\1/p" "$log" | tail -1)
    grep -m5 -E 'ERROR: |runtime error|invariant violated|deadly signal' "$log" || tail -n 20 "$log"
    echo "FUZZ $t: ${runs:-?} executions, 1 crash (exit status $rc); input: ${artifact:-none written}; log: $log"
  fi
done
exit $status
