# shellcheck shell=bash
# Shared by the browser tests of the generated pages (run-browser-test.sh, run-gap-browser-test.sh);
# sourced, not run. The sourcing script sets `test_name` (its failure messages' prefix) and
# `artefacts` first. Sourcing finds headless Chromium and python3, makes the scratch directory
# $work (removed on exit) and the artefact directory.
# shellcheck disable=SC2154 # test_name and artefacts come from the sourcing script

fail() { echo "$test_name: FAILED: $*" >&2; exit 1; }
browser=$(command -v chromium || command -v chromium-browser || true)
[ -n "$browser" ] || fail "chromium is not installed (tools/install-deps.sh --test installs Debian's chromium)"
python=$(command -v python3) || fail "python3 is needed to read the net log"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$artefacts"

# One fresh profile per run; every background service that could reach out is off.
chrome() {
  local profile
  profile=$(mktemp -d "$work/profile.XXXXXX")
  timeout 120 "$browser" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync --disable-default-apps \
    --user-data-dir="$profile" --enable-logging=stderr --v=0 "$@"
}
count() { grep -o -- "$1" "$2" | wc -l; }

# The console capture works: a page that logs on purpose is seen.
check_console_capture() {
  printf '<!DOCTYPE html><html><body><script>console.error("gearwatch-canary-" + (6 * 7))</script></body></html>\n' > "$work/canary.html"
  chrome --dump-dom "file://$work/canary.html" > "$work/canary.dom" 2> "$work/canary.log" || fail "chromium failed on the canary page"
  grep -q 'CONSOLE.*gearwatch-canary-42' "$work/canary.log" || fail "the console capture does not see console.error (see $work/canary.log)"
}

# Requests the page made: the net log's URL_REQUEST_START_JOB entries isolated under file://
# (the browser's own background requests carry another network isolation key), other than
# file: and data: URLs. Prints them, one a line.
page_requests() {
  "$python" - "$1" <<'PY'
import json, sys
text = open(sys.argv[1]).read()
try:
    log = json.loads(text)
except ValueError:  # a log cut short at exit: close its event list
    log = json.loads(text.rstrip().rstrip(",") + "]}")
names = {v: k for k, v in log["constants"]["logEventTypes"].items()}
for e in log.get("events", []):
    p = e.get("params", {})
    if names.get(e["type"]) == "URL_REQUEST_START_JOB" and "file://" in p.get("network_isolation_key", ""):
        if not p.get("url", "").startswith(("file:", "data:")):
            print(p["url"])
PY
}

# Loads PAGE, keeps its console log as ARTEFACT_LOG and leaves the rendered DOM in $work/dom.html;
# every PATTERN must occur in the rendered DOM as often as in the page file, and at least once.
load_and_compare() {
  local page=$1 artefact_log=$2 what=$3
  shift 3
  chrome --log-net-log="$work/net.json" --dump-dom "file://$page" > "$work/dom.html" 2> "$work/console.log" || fail "chromium failed on $what"
  cp "$work/console.log" "$artefact_log"
  local pattern in_file in_dom
  for pattern in "$@"; do
    in_file=$(count "$pattern" "$page")
    in_dom=$(count "$pattern" "$work/dom.html")
    echo "$pattern: page $in_file, rendered DOM $in_dom"
    [ "$in_file" -gt 0 ] || fail "the page has no $pattern"
    [ "$in_dom" -eq "$in_file" ] || fail "rendered DOM has $in_dom × $pattern, the page $in_file"
  done
}

# After load_and_compare: the console stayed silent and the page made no network request.
check_silent_and_offline() {
  if grep -E 'CONSOLE|Uncaught|Refused to' "$work/console.log"; then fail "the page wrote to the console"; fi
  local requests
  requests=$(page_requests "$work/net.json")
  [ -z "$requests" ] || fail "the page made network requests: $requests"
}

# Screenshot of PAGE for a person, WIDTH x HEIGHT; its PNG header must say so.
screenshot() {
  local page=$1 png=$2 width=$3 height=$4 size
  rm -f "$png"
  chrome --hide-scrollbars --window-size="$width,$height" --screenshot="$png" "file://$page" 2>/dev/null >/dev/null \
    || fail "chromium could not take the screenshot"
  size=$(od -An -tu1 -j16 -N8 "$png" | awk '{print ($1*16777216+$2*65536+$3*256+$4) "x" ($5*16777216+$6*65536+$7*256+$8)}')
  [ "$size" = "${width}x${height}" ] || fail "screenshot is $size, expected ${width}x${height}"
}
