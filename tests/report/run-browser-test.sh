#!/usr/bin/env bash
# The report page in a real browser (headless Chromium, Debian's `chromium`):
#   run-browser-test.sh GEARWATCH ARTEFACT_DIR
# Builds a small database by replaying simulated captures, writes the report, loads it from
# file:// and checks that
#   - the rendered DOM holds every SVG, polyline and point of the page file,
#   - the console stays silent (the page has no script, so any console line — a refused request
#     under the page's Content-Security-Policy, an error — is a failure); a canary page that
#     logs on purpose proves the console is really captured,
#   - the page made no network request (none in the browser's net log; a probe page that does
#     make one proves the check sees it),
# and keeps ARTEFACT_DIR/report/index.html and ARTEFACT_DIR/report-screenshot.png (1280 x 2000)
# for a person to look at.
set -euo pipefail
gearwatch=${1:?usage: run-browser-test.sh GEARWATCH ARTEFACT_DIR}
artefacts=${2:?usage: run-browser-test.sh GEARWATCH ARTEFACT_DIR}

fail() { echo "report browser test: FAILED: $*" >&2; exit 1; }
browser=$(command -v chromium || command -v chromium-browser || true)
[ -n "$browser" ] || fail "chromium is not installed (tools/install-deps.sh --test installs Debian's chromium)"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$artefacts"

# Short records and a 3-record baseline, so a few seconds of capture give analysed records,
# unanalysed 0.3 s tails (gaps) and raised and cleared threshold alerts.
cat > "$work/c.toml" <<'EOF'
[records]
length_s = 1.0
interval_s = 1.0
min_length_s = 0.5
[alerts]
baseline_records = 3
watched_indicators = ["rms_raw", "rms_sa"]
EOF
i=0
for args in "--duration 3.3 --torque 20 --start-revs 0" "--duration 3.3 --torque 30 --start-revs 70" \
            "--duration 3 --torque 20 --start-revs 140" "--duration 2 --torque 30 --start-revs 200"; do
  i=$((i + 1))
  # shellcheck disable=SC2086 # the arguments are meant to split
  "$gearwatch" simulate --out "$work/cap$i.log" --speed 20 $args >/dev/null
  "$gearwatch" replay "$work/cap$i.log" --db "$work/plant.db" --config "$work/c.toml" >/dev/null
done
"$gearwatch" inspect --db "$work/plant.db" --cycles 100 --pitted-area 0.02 --note "tooth 3" >/dev/null
rm -rf "$artefacts/report"
"$gearwatch" report --db "$work/plant.db" --out "$artefacts/report" >/dev/null
page="$artefacts/report/index.html"

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
printf '<!DOCTYPE html><html><body><script>console.error("gearwatch-canary-" + (6 * 7))</script></body></html>\n' > "$work/canary.html"
chrome --dump-dom "file://$work/canary.html" > "$work/canary.dom" 2> "$work/canary.log" || fail "chromium failed on the canary page"
grep -q 'CONSOLE.*gearwatch-canary-42' "$work/canary.log" || fail "the console capture does not see console.error (see $work/canary.log)"

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
python=$(command -v python3) || fail "python3 is needed to read the net log"

# The net-log check works: a page without the report's policy that asks for an image (on the
# loopback discard port, where nothing answers) is caught.
printf '<!DOCTYPE html><html><body><img src="http://127.0.0.1:9/probe.png"></body></html>\n' > "$work/probe.html"
chrome --log-net-log="$work/probe-net.json" --dump-dom "file://$work/probe.html" > /dev/null 2>&1 || fail "chromium failed on the probe page"
page_requests "$work/probe-net.json" | grep -q '^http://127.0.0.1:9/probe.png$' || fail "the net-log check does not see a page's request"

# The report: rendered DOM, console and requests.
chrome --log-net-log="$work/net.json" --dump-dom "file://$page" > "$work/dom.html" 2> "$work/console.log" || fail "chromium failed on the report"
cp "$work/console.log" "$artefacts/report-console.log"
for pattern in '<svg class="plot"' '<polyline' '<circle class="pt"' '<tr class="alert-row' '<tr class="health-row"'; do
  in_file=$(count "$pattern" "$page")
  in_dom=$(count "$pattern" "$work/dom.html")
  echo "$pattern: page $in_file, rendered DOM $in_dom"
  [ "$in_file" -gt 0 ] || fail "the page has no $pattern"
  [ "$in_dom" -eq "$in_file" ] || fail "rendered DOM has $in_dom × $pattern, the page $in_file"
done
[ "$(count '<svg class="plot"' "$page")" -eq 10 ] || fail "expected 10 plots (5 families × 2 channels)"
if grep -E 'CONSOLE|Uncaught|Refused to' "$work/console.log"; then fail "the page wrote to the console"; fi
requests=$(page_requests "$work/net.json")
[ -z "$requests" ] || fail "the page made network requests: $requests"

# Screenshot for a person; its PNG header must say 1280 x 2000.
rm -f "$artefacts/report-screenshot.png"
chrome --hide-scrollbars --window-size=1280,2000 --screenshot="$artefacts/report-screenshot.png" "file://$page" 2>/dev/null >/dev/null \
  || fail "chromium could not take the screenshot"
size=$(od -An -tu1 -j16 -N8 "$artefacts/report-screenshot.png" | awk '{print ($1*16777216+$2*65536+$3*256+$4) "x" ($5*16777216+$6*65536+$7*256+$8)}')
[ "$size" = "1280x2000" ] || fail "screenshot is $size, expected 1280x2000"
echo "report browser test: passed; screenshot: $artefacts/report-screenshot.png"
