#!/usr/bin/env bash
# The main job on a fresh machine: build the embedded trajdb (bundled DuckDB) and run the demo.
# Uses the same target directory as scripts/test.sh, so DuckDB is compiled once for both.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/trajdb-target}"
exec cargo run --release -- demo "$@"
