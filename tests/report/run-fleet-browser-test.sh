#!/usr/bin/env bash
# The fleet page (`gearwatch fleet report`) in a real browser (headless Chromium, Debian's `chromium`):
#   run-fleet-browser-test.sh GEARWATCH WRITE_FLEET_PAGE ARTEFACT_DIR
# WRITE_FLEET_PAGE starts PostgreSQL, writes the known fleet (tests/fleet/fleet_page_fixture.hpp)
# and the page; this script loads it from file:// and checks that
#   - the rendered DOM holds every row, trend plot, point and alert of the page file, worst first,
#   - the console stays silent (a canary page that logs on purpose proves it is captured),
#   - the page made no network request (none in the browser's net log),
# and keeps ARTEFACT_DIR/fleet/index.html and ARTEFACT_DIR/fleet-screenshot.png (1280 x 1000).
set -euo pipefail
gearwatch=${1:?usage: run-fleet-browser-test.sh GEARWATCH WRITE_FLEET_PAGE ARTEFACT_DIR}
writer=${2:?usage: run-fleet-browser-test.sh GEARWATCH WRITE_FLEET_PAGE ARTEFACT_DIR}
artefacts=${3:?usage: run-fleet-browser-test.sh GEARWATCH WRITE_FLEET_PAGE ARTEFACT_DIR}

test_name="fleet page browser test"
# shellcheck source=tests/report/browser-lib.sh
. "$(dirname "$0")/browser-lib.sh"

rm -rf "$artefacts/fleet"
"$writer" "$gearwatch" "$artefacts/fleet" >/dev/null || fail "could not write the fleet page (exit $?)"
page="$artefacts/fleet/index.html"

check_console_capture

load_and_compare "$page" "$artefacts/fleet-console.log" "the fleet page" \
  '<tr class="gearbox-row' '<svg class="plot' '<circle class="pt"' '<polyline' '<li class="sev-alarm"' '<li class="sev-warning"' \
  'class="mech-wear"' 'class="state-offline"'
# The known fleet: 5 gearboxes; 4 with a trend (gbQuiet 4 points, the others 1); 2 active alerts.
[ "$(count '<tr class="gearbox-row' "$page")" -eq 5 ] || fail "expected 5 gearbox rows"
[ "$(count '<svg class="plot' "$page")" -eq 4 ] || fail "expected 4 trend plots"
[ "$(count '<circle class="pt"' "$page")" -eq 7 ] || fail "expected 7 trend points"
order=$(grep -o 'data-gearbox="[^"]*"' "$work/dom.html" | tr '\n' ' ')
[ "$order" = 'data-gearbox="plant2/gbPit" data-gearbox="plant2/gbWarn&lt;&amp;&gt;" data-gearbox="plant1/gbLife" data-gearbox="plant1/gbQuiet" data-gearbox="plant1/gbOff" ' ] \
  || fail "rendered order is $order"
check_silent_and_offline

screenshot "$page" "$artefacts/fleet-screenshot.png" 1280 1000
echo "fleet page browser test: passed; screenshot: $artefacts/fleet-screenshot.png"
