#!/usr/bin/env bash
# Build trajdb.duckdb_extension: the loadable build (no C++ compile), then the footer.
# usage: scripts/build_extension.sh   -> writes ./trajdb.duckdb_extension
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/trajdb-target}"
# arrow (pulled in by duckdb-rs, never run by the extension) builds unoptimised: .cargo/config.toml
cargo build --release --no-default-features --features extension --lib
python3 scripts/append_footer.py "$CARGO_TARGET_DIR/release/libtrajdb.so" trajdb.duckdb_extension \
  --version "v$(sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -1)"
