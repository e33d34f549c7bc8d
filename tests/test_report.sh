#!/usr/bin/env bash
# The report in a real browser (issue 15): headless Chromium renders report.html of a simulated
# day (no outside data needed); the page's own script counts its sections and every element
# wider than its box or the window (body data-sections / data-overflow). Asserts 17 sections and
# no overflow, and keeps a full-page screenshot in $CARGO_TARGET_DIR/report-screenshot.png.
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
"$PY" -m trajdb simulate --cameras 3 --minutes 2 --seed 7 --out "$W/sim" 2> /dev/null
"$PY" -m trajdb pipeline --input "$W/sim/points.parquet" --out "$W/r" 2> /dev/null
B="$(command -v chromium || command -v chromium-browser || command -v google-chrome)"
body=$(timeout 120 "$B" --headless --no-sandbox --disable-gpu --window-size=1400,1000 --dump-dom "file://$W/r/report.html" 2> /dev/null | grep -o '<body[^>]*>')
echo "rendered: $body"
[[ "$body" == *'data-overflow="0"'* ]] || { echo "FAIL: elements overflow their box or the window: $body" >&2; exit 1; }
[[ "$body" == *'data-sections="17"'* ]] || { echo "FAIL: expected 17 sections: $body" >&2; exit 1; }
mkdir -p "$SHOT_DIR"
timeout 120 "$B" --headless --no-sandbox --disable-gpu --hide-scrollbars --window-size=1400,9000 \
  --screenshot="$SHOT_DIR/report-screenshot.png" "file://$W/r/report.html" > /dev/null 2>&1
echo "ok   report renders in $("$B" --version 2>/dev/null): 17 sections, no overflow"
