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

test_name="report browser test"
# shellcheck source=tests/report/browser-lib.sh
. "$(dirname "$0")/browser-lib.sh"

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

check_console_capture

# The net-log check works: a page without the report's policy that asks for an image (on the
# loopback discard port, where nothing answers) is caught.
printf '<!DOCTYPE html><html><body><img src="http://127.0.0.1:9/probe.png"></body></html>\n' > "$work/probe.html"
chrome --log-net-log="$work/probe-net.json" --dump-dom "file://$work/probe.html" > /dev/null 2>&1 || fail "chromium failed on the probe page"
page_requests "$work/probe-net.json" | grep -q '^http://127.0.0.1:9/probe.png$' || fail "the net-log check does not see a page's request"

# The report: rendered DOM, console and requests.
load_and_compare "$page" "$artefacts/report-console.log" "the report" \
  '<svg class="plot"' '<polyline' '<circle class="pt"' '<tr class="alert-row' '<tr class="health-row"'
[ "$(count '<svg class="plot"' "$page")" -eq 10 ] || fail "expected 10 plots (5 families × 2 channels)"
check_silent_and_offline

# Screenshot for a person.
screenshot "$page" "$artefacts/report-screenshot.png" 1280 2000
echo "report browser test: passed; screenshot: $artefacts/report-screenshot.png"
