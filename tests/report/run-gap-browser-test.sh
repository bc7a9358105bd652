#!/usr/bin/env bash
# The gap page (`gearwatch gap report`) in a real browser (headless Chromium, Debian's `chromium`):
#   run-gap-browser-test.sh GEARWATCH WRITE_GAP_FIXTURE ARTEFACT_DIR
# Writes a database holding a known gap report (tests/gap_report_fixture.hpp) after two older
# ones, writes the page, loads it from file:// and checks that
#   - the rendered DOM holds every SVG, bar, whisker, shaded band and curve of the page file,
#   - the console stays silent (a canary page that logs on purpose proves it is captured),
#   - the page made no network request (none in the browser's net log),
# and keeps ARTEFACT_DIR/gap-report/index.html and ARTEFACT_DIR/gap-report-screenshot.png
# (1280 x 3000) for a person to look at.
set -euo pipefail
gearwatch=${1:?usage: run-gap-browser-test.sh GEARWATCH WRITE_GAP_FIXTURE ARTEFACT_DIR}
fixture=${2:?usage: run-gap-browser-test.sh GEARWATCH WRITE_GAP_FIXTURE ARTEFACT_DIR}
artefacts=${3:?usage: run-gap-browser-test.sh GEARWATCH WRITE_GAP_FIXTURE ARTEFACT_DIR}

test_name="gap page browser test"
# shellcheck source=tests/report/browser-lib.sh
. "$(dirname "$0")/browser-lib.sh"

"$fixture" "$work/plant.db" || fail "could not write the fixture database"
rm -rf "$artefacts/gap-report"
"$gearwatch" gap report --db "$work/plant.db" --out "$artefacts/gap-report" >/dev/null
page="$artefacts/gap-report/index.html"

check_console_capture

load_and_compare "$page" "$artefacts/gap-report-console.log" "the gap page" \
  '<svg class="plot' '<rect class="bar before"' '<rect class="bar after"' '<path class="whisker"' \
  '<rect class="band family' '<polyline' '<circle class="pt"' '<tr class="family-row' '<tr class="candidate-row' '<tr class="history-row"'
# The known report: 1 bar chart + 2 spectra + the trend; 6 resolved families; 3 + 3 bands; 3 curves per
# spectrum; 3 reports (6 trend lines of 3 points).
[ "$(count '<svg class="plot' "$page")" -eq 4 ] || fail "expected 4 plots (bars, orders, Hz, trend)"
[ "$(count '<circle class="pt"' "$page")" -eq 18 ] || fail "expected 18 trend points"
[ "$(count '<rect class="bar before"' "$page")" -eq 6 ] || fail "expected 6 bars before"
[ "$(count '<rect class="band family' "$page")" -eq 6 ] || fail "expected 6 shaded family bands"
[ "$(count '<polyline' "$page")" -eq 12 ] || fail "expected 6 spectrum curves and 6 trend lines"
[ "$(count '<tr class="history-row"' "$page")" -eq 3 ] || fail "expected 3 reports in the history"
grep -q 'unexplained: no candidate explains it' "$work/dom.html" || fail "the unexplained family is not shown"
[ "$(count '<li class="sev-warning drift-alert">' "$work/dom.html")" -eq 1 ] || fail "the raised twin_drift alert is not shown"
check_silent_and_offline

screenshot "$page" "$artefacts/gap-report-screenshot.png" 1280 3000
echo "gap page browser test: passed; screenshot: $artefacts/gap-report-screenshot.png"
