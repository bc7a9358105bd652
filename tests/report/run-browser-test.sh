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
#   - at a 1280 x 800 window the page does not scroll sideways (documentElement.scrollWidth <= 1280)
#     and the acquisition-health table fits its box; the configured channel names, the skip
#     reasons and the verdict's unseen band are in the rendered, visible text,
# and keeps ARTEFACT_DIR/report/index.html and ARTEFACT_DIR/report-screenshot.png (1280 x 2000)
# for a person to look at.
set -euo pipefail
gearwatch=${1:?usage: run-browser-test.sh GEARWATCH ARTEFACT_DIR}
artefacts=${2:?usage: run-browser-test.sh GEARWATCH ARTEFACT_DIR}

test_name="report browser test"
# shellcheck source=tests/report/browser-lib.sh
. "$(dirname "$0")/browser-lib.sh"

# Short records and a 3-record baseline, so a few seconds of capture give analysed records,
# unanalysed 0.3 s tails (gaps) and raised and cleared threshold alerts; named channels; the last
# capture at 25.6 kHz, where the abrasion band lies above 0.45 fs (skipped, and unseen by the verdict).
cat > "$work/c.toml" <<'EOF'
[records]
length_s = 1.0
interval_s = 1.0
min_length_s = 0.5
[alerts]
baseline_records = 3
watched_indicators = ["rms_raw", "rms_sa"]
[[channels]]
number = 0
name = "pinion_end_y"
scale = 0.01
[[channels]]
number = 1
name = "motor_side_x"
scale = 0.01
EOF
i=0
for args in "--duration 3.3 --torque 20 --start-revs 0" "--duration 3.3 --torque 30 --start-revs 70" \
            "--duration 3 --torque 20 --start-revs 140" "--duration 2 --torque 30 --start-revs 200" \
            "--duration 2 --torque 20 --start-revs 260 --sample-rate 25600"; do
  i=$((i + 1))
  # shellcheck disable=SC2086 # the arguments are meant to split
  "$gearwatch" simulate --out "$work/cap$i.log" --speed 20 --config "$work/c.toml" $args >/dev/null
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
  '<svg class="plot"' '<polyline' '<circle class="pt"' '<tr class="alert-row' '<tr class="health-row"' \
  '<tr class="skip-row" data-reason="band_above_nyquist"' '<tr class="caveat-row" data-reason="band_trimmed"' \
  '<p class="cannot-see"' 'pinion_end_y (channel 0)' 'motor_side_x (channel 1)'
[ "$(count '<svg class="plot"' "$page")" -eq 10 ] || fail "expected 10 plots (5 families × 2 channels)"
[ "$(count '<tr class="skip-row" data-reason="band_above_nyquist"' "$page")" -eq 2 ] || fail "expected a band_above_nyquist row per channel"
check_silent_and_offline

# Layout at 1280 px, measured in the browser: the report in a 1280 x 800 frame of a measuring page
# (the report itself runs no script); file:// pages may read each other only with
# --allow-file-access-from-files. The frame's own text (innerText: rendered and visible) must
# hold the channel names, the skip reasons and the unseen band.
cat > "$work/measure.html" <<MEASURE
<!DOCTYPE html><html><head><meta charset="utf-8"><style>body{margin:0}iframe{display:block;border:0;width:1280px;height:800px}</style></head>
<body><iframe id="report" src="file://$page"></iframe><pre id="result">not measured</pre><script>
document.getElementById("report").addEventListener("load", function () {
  var d = this.contentDocument, root = d.documentElement, health = d.querySelector("table.health").parentNode, text = d.body.innerText;
  var wanted = ["pinion_end_y (channel 0)", "motor_side_x (channel 1)", "band_above_nyquist", "band_trimmed",
                "cannot see the abrasion band", "ics2_high_band, mean_carrier_hz_0_30000, mean_carrier_hz_0_50000"];
  var missing = wanted.filter(function (w) { return text.indexOf(w) < 0; });
  document.getElementById("result").textContent = "viewport=" + root.clientWidth + " scrollWidth=" + root.scrollWidth +
    " health=" + health.scrollWidth + "/" + health.clientWidth + " missing=[" + missing.join("|") + "]";
});
</script></body></html>
MEASURE
chrome --allow-file-access-from-files --window-size=1280,800 --dump-dom "file://$work/measure.html" > "$work/measure.dom" 2>/dev/null \
  || fail "chromium failed on the measuring page"
measured=$(sed -n 's/.*<pre id="result">\([^<]*\)<\/pre>.*/\1/p' "$work/measure.dom")
echo "at 1280 x 800: $measured"
# The viewport is 1280 px less the vertical scroll bar's width, if the browser draws one.
[[ $measured =~ ^viewport=([0-9]+)\ scrollWidth=([0-9]+)\ health=([0-9]+)/([0-9]+)\ missing=\[(.*)\]$ ]] || fail "the page was not measured: '$measured'"
[ "${BASH_REMATCH[1]}" -le 1280 ] && [ "${BASH_REMATCH[1]}" -ge 1240 ] || fail "the frame's viewport is not about 1280 px: ${BASH_REMATCH[1]}"
[ "${BASH_REMATCH[2]}" -le "${BASH_REMATCH[1]}" ] || fail "the page scrolls sideways at 1280 px: scrollWidth ${BASH_REMATCH[2]} > ${BASH_REMATCH[1]}"
[ "${BASH_REMATCH[3]}" -le "${BASH_REMATCH[4]}" ] || fail "the health table is wider than its box: ${BASH_REMATCH[3]} > ${BASH_REMATCH[4]} px"
[ -z "${BASH_REMATCH[5]}" ] || fail "not in the rendered text: ${BASH_REMATCH[5]}"

# Screenshot for a person.
screenshot "$page" "$artefacts/report-screenshot.png" 1280 2000
echo "report browser test: passed; screenshot: $artefacts/report-screenshot.png"
