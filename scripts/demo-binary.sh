#!/usr/bin/env bash
# The demo with the trajdb binary (bundled DuckDB, compiled from source once: ~30 min on 2 cores):
# the same results and report.html as scripts/demo.sh. Uses the same target directory as scripts/test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/trajdb-target}"
exec cargo run --release -- demo "$@"
