#!/usr/bin/env bash
# Documented check of `rom gap --report DIR`'s gap.html in a real headless browser:
# Debian's Chromium (`apt-get install chromium`) loads the page, its DOM after rendering must
# hold the ranking and where tables and one inline SVG per label, and a screenshot is written
# to DIR/gap.png for a person to look at. CI machines have no browser, hence a script, not a
# test.
#
#   bash studies/gap-html-check/run.sh REPORT_DIR
set -euo pipefail
dir=${1:?usage: studies/gap-html-check/run.sh REPORT_DIR (written by rom gap --report)}
page=$(realpath "$dir/gap.html")
browser=$(command -v chromium || command -v chromium-browser || true)
[ -n "$browser" ] || { echo "no chromium on this machine (apt-get install chromium)" >&2; exit 2; }
flags=(--headless --no-sandbox --disable-gpu --hide-scrollbars)
dom=$("$browser" "${flags[@]}" --dump-dom "file://$page" 2>/dev/null)
labels=$(python3 -c "import json,sys; print(len(json.load(open(sys.argv[1]))['calibration']['center_distances_m']))" "$dir/gap.json")
tables=$(grep -o "<table" <<<"$dom" | wc -l)
svgs=$(grep -o "<svg" <<<"$dom" | wc -l)
echo "rendered: $tables tables, $svgs SVG plots, $labels labels in gap.json"
[ "$tables" -ge 2 ] || { echo "FAIL: expected the ranking and the where table" >&2; exit 1; }
[ "$svgs" -eq "$labels" ] || { echo "FAIL: expected one SVG per label" >&2; exit 1; }
"$browser" "${flags[@]}" --window-size=1100,1800 --screenshot="$(realpath "$dir")/gap.png" \
  "file://$page" 2>/dev/null
echo "screenshot: $dir/gap.png"
