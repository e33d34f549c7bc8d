#!/usr/bin/env bash
# README command 1, the main job on a fresh machine, in stock DuckDB: build the loadable
# extension and the Python package (`pip install .`: Rust only, no C++), then `trajdb demo`:
# simulate 5 minutes of a 3-camera intersection (trajdb_simulate), run the whole pipeline, score
# it against the simulator's truth. Output in ./trajdb-demo (or $1), with results/report.html.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/trajdb-target}"
VENV="${TRAJDB_DEMO_VENV:-$HOME/.cache/trajdb-demo-venv}"
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
"$VENV/bin/pip" install -q --disable-pip-version-check .
exec "$VENV/bin/python" -m trajdb demo --out "${1:-trajdb-demo}"
