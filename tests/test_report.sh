#!/usr/bin/env bash
# The report in a real browser (issue 15, issue 39 §8): headless Chromium renders report.html of a
# simulated 65 minutes (no outside data needed; an hour, so that it has a peak hour); the page's
# own script counts its sections, every element wider than its box or the window (body
# data-sections / data-overflow), the study's figures drawn at a readable size inside the window
# (data-study: the site map, the movement diagram, the counts with the peak hour, the conflict map)
# and their labels cut off by their figure (data-clipped). Asserts 20 sections, no overflow, all
# four figures, no label cut off, and the peak hour's PHF in the text; keeps a full-page
# screenshot in $CARGO_TARGET_DIR/report-screenshot.png.
# The scene and the report come from the `trajdb` command (python -m trajdb) over stock DuckDB
# and the extension.
# usage: tests/test_report.sh path/to/trajdb.duckdb_extension [PYTHON]   (needs chromium; PYTHON
#        with duckdb installed, default python3)
set -euo pipefail
[ -f "${1:-}" ] || { echo "usage: $0 path/to/trajdb.duckdb_extension" >&2; exit 2; }
EXT="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"
cd "$(dirname "$0")/.."
PY="${2:-python3}"
export TRAJDB_EXTENSION="$EXT" PYTHONPATH="$PWD/python${PYTHONPATH:+:$PYTHONPATH}"
SHOT_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/trajdb-target}"
W="$(mktemp -d)"
trap 'rm -rf "$W"' EXIT
"$PY" -m trajdb simulate --cameras 3 --minutes 65 --seed 7 --out "$W/sim" 2> /dev/null
"$PY" -m trajdb pipeline --input "$W/sim/points.parquet" --out "$W/r" 2> /dev/null
B="$(command -v chromium || command -v chromium-browser || command -v google-chrome)"
FLAGS=(--headless --no-sandbox --disable-gpu --disable-background-networking --disable-component-update --disable-sync --no-first-run)
timeout 120 "$B" "${FLAGS[@]}" --window-size=1400,1000 --dump-dom "file://$W/r/report.html" 2> /dev/null > "$W/dom.html"
body=$(grep -o '<body[^>]*>' "$W/dom.html")
echo "rendered: $body"
[[ "$body" == *'data-overflow="0"'* ]] || { echo "FAIL: elements overflow their box or the window: $body" >&2; exit 1; }
[[ "$body" == *'data-sections="20"'* ]] || { echo "FAIL: expected 20 sections: $body" >&2; exit 1; }
[[ "$body" == *'data-study="site-map movement-diagram peak-hour conflict-map"'* ]] || { echo "FAIL: a study figure is missing or too small: $body" >&2; exit 1; }
[[ "$body" == *'data-clipped="0"'* ]] || { echo "FAIL: labels cut off by their figure: $body" >&2; exit 1; }
grep -q 'Peak hour +0:00 – +1:00:00</b>: V = [0-9]* vehicles, busiest quarter V15 = [0-9]*, <b>PHF = [0-9]* / (4 × [0-9]*) = 0\.[0-9][0-9]</b>' "$W/dom.html" \
  || { echo "FAIL: no peak hour with its PHF" >&2; grep -o '<div id="peak-hour">.\{0,300\}' "$W/dom.html" >&2; exit 1; }
grep -q 'class="conf"><b>Confidence</b> (vehicles with a known movement' "$W/dom.html" || { echo "FAIL: no confidence line under the movements" >&2; exit 1; }
# SSAM's kinds only between vehicles: no pedestrian pair is a lane change
if grep -o '<tr><th>[0-9]*</th><td>pedestrian</td><td>[0-9]*</td><td>pedestrian</td><td>[^<]*</td><td>[^<]*</td>' "$W/dom.html" | grep -v 'pedestrian-pedestrian</td>$' | grep -q .; then
  echo "FAIL: a pedestrian pair has a vehicle kind" >&2; exit 1
fi
mkdir -p "$SHOT_DIR"
timeout 120 "$B" "${FLAGS[@]}" --hide-scrollbars --window-size=1400,9000 \
  --screenshot="$SHOT_DIR/report-screenshot.png" "file://$W/r/report.html" > /dev/null 2>&1
echo "ok   report renders in $("$B" --version 2>/dev/null): 20 sections, no overflow, the site map, movement diagram, peak hour with PHF and conflict map, no label cut off"
