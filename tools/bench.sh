#!/usr/bin/env bash
# bench.sh — builds (Release) and runs every benchmark in bench/ (each bench/bench_<what>.cpp is
# an executable build/bench/bench_<what>) and prints one table: benchmark, figure, target, ratio
# (figure / target), MET or MISSED. A benchmark reports itself with final lines of the form
#   BENCH name=<name> figure=<number> unit=<unit> target=<number> cmp=<ge|le> met=<0|1>
# (cmp=ge: the figure must reach the target; le: stay below it). A benchmark without such a line
# gets a row with its last output line. Each benchmark's full output is kept in build/bench/<name>.out.
# Exit status 0 if every target was met.
# bench_replay (the whole job: a 20-record rig campaign replayed with the model on, then with the gap
# diagnosis) makes its campaign once and keeps it in build/bench/replay-campaign-20x10s.
#   tools/bench.sh                 all benchmarks
#   tools/bench.sh bench_twin ...  only these
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
cd "$top"
tools/install-deps.sh
build=build
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
elif [ "$(sed -n 's/^CMAKE_BUILD_TYPE:[A-Z]*=//p' "$build/CMakeCache.txt")" != Release ]; then
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
fi
if [ $# -gt 0 ]; then
  benches=("$@")
else
  benches=()
  for src in bench/bench_*.cpp; do benches+=("$(basename "${src%.cpp}")"); done
fi
cmake --build "$build" --target "${benches[@]}" --parallel "$(nproc)" >/dev/null

rows=()
missed=0
for b in "${benches[@]}"; do
  exe=$build/bench/$b
  out=$build/bench/$b.out
  echo "bench: running $b" >&2
  set +e
  "$exe" >"$out" 2>&1
  rc=$?
  set -e
  if grep -q '^BENCH ' "$out"; then
    while read -r line; do
      get() { echo "$line" | tr ' ' '\n' | sed -n "s/^$1=//p"; }
      name=$(get name) figure=$(get figure) unit=$(get unit) target=$(get target) cmp=$(get cmp) met=$(get met)
      ratio=$(awk -v f="$figure" -v t="$target" 'BEGIN { if (t != 0) printf "%.2f", f / t; else print "-" }')
      sign='>='; [ "$cmp" = le ] && sign='<='
      verdict=MET; [ "$met" = 1 ] || { verdict=MISSED; missed=$((missed + 1)); }
      rows+=("$b|$name|$figure $unit|$sign $target|$ratio|$verdict")
    done < <(grep '^BENCH ' "$out")
  else
    verdict="no BENCH line (exit $rc)"
    [ "$rc" -eq 0 ] || missed=$((missed + 1))
    rows+=("$b|-|$(tail -n 1 "$out" | cut -c1-70)|-|-|$verdict")
  fi
done

{
  echo "program|benchmark|figure|target|ratio|verdict"
  printf '%s\n' "${rows[@]}"
} | awk -F'|' '{ for (i = 1; i <= NF; i++) { cell[NR, i] = $i; if (length($i) > w[i]) w[i] = length($i) } n = NF }
            END { for (r = 1; r <= NR; r++) { line = ""; for (i = 1; i <= n; i++) line = line sprintf("%-" w[i] + 2 "s", cell[r, i]); print line } }'
echo "bench: ${#rows[@]} figures, $missed missed (outputs in $build/bench/*.out)"
[ "$missed" -eq 0 ]
