#!/usr/bin/env bash
# Every test of trajdb, from a clean clone: `scripts/test.sh`
#   1. algo unit + property tests without DuckDB (--no-default-features)
#   2. embedded build: unit tests, CLI tests, tests/sql/*.slt through the sqllogictest crate, the
#      fuzz harness (tests/fuzz.rs, quick mode: TRAJDB_FUZZ_CASES per overload, default 24);
#      2b. report.html rendered in headless Chromium (tests/test_report.sh; apt-get installs it);
#      2c. byte-identical results across thread counts and input row orders (tests/test_determinism.sh)
#   3. the function reference docs/functions.md is up to date
#   4. loadable extension: build, footer, the same .slt files, the fuzz cases and the README's
#      examples in stock DuckDB (PyPI duckdb); concurrency, interrupt and work limits
#      (tests/test_robust_python.py); the runner as a careless or hostile user meets it: results
#      folder, injection, sandbox, parameters, metamorphic pipeline runs (tests/test_safety_python.py);
#      NULL / hostile arguments to every table function in a child process, the sandbox, per-database
#      work limits (tests/test_sandbox_python.py); the same road users when frames move far from the
#      origin (UTM), rotate, and clocks shift (tests/test_invariance_python.py, simulated and shared scenes);
#      match and link precision in simulated waiting crowds, scored with the truth (tests/test_crowd_python.py);
#      trajdb.score's HOTA and drifting-clock errors on a hand-made case (tests/test_score_python.py);
#      the Python package (pip install . into a fresh venv) against
#      the binary
#   5. round trip with DuckDB spatial (PyPI duckdb 1.5.5 + duckdb-extension-spatial, own venv), and
#      the .slt suite, fuzz cases, robustness tests and README examples again in that DuckDB 1.5.5
#   6. trajdb.spark in Spark local mode against `trajdb pipeline` on each whole site
#      (tests/test_spark.py; scripts/install_spark.sh installs pyspark and, from apt, Java 17)
# Needs: cargo, python3 (with venv/pip, PyPI reachable). The first run compiles DuckDB (~50 CPU-min).
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/trajdb-target}"
VENV="${TRAJDB_VENV:-$HOME/.cache/trajdb-venv}"
SPATIAL_VENV="${TRAJDB_SPATIAL_VENV:-$HOME/.cache/trajdb-spatial-venv}"

echo "== 1/6 algo tests (no DuckDB)"
cargo test --release --no-default-features --lib

echo "== 2/6 embedded build: unit, CLI, sqllogictest and fuzz tests"
FUZZ_CASES="$CARGO_TARGET_DIR/fuzz-cases.sql"
TRAJDB_FUZZ_OUT="$FUZZ_CASES" cargo test --release

echo "== 2b/6 the report in headless Chromium (installed from Debian when missing)"
if ! command -v chromium > /dev/null && ! command -v chromium-browser > /dev/null; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium > /dev/null
fi
tests/test_report.sh

echo "== 2c/6 determinism across thread counts and input row orders"
tests/test_determinism.sh

echo "== 3/6 function reference is generated from the registered descriptions"
"$CARGO_TARGET_DIR/release/trajdb" functions --markdown > "$CARGO_TARGET_DIR/functions.md"
if ! diff -u docs/functions.md "$CARGO_TARGET_DIR/functions.md"; then
  echo "docs/functions.md is stale: run  $CARGO_TARGET_DIR/release/trajdb functions --markdown > docs/functions.md" >&2
  exit 1
fi

echo "== 4/6 loadable extension in stock DuckDB"
scripts/build_extension.sh
if [ ! -x "$VENV/bin/python" ]; then python3 -m venv "$VENV"; fi
"$VENV/bin/pip" install -q -r requirements-test.txt
python3 tests/test_footer.py && python3 tests/test_footer.py trajdb.duckdb_extension
"$VENV/bin/python" tests/run_slt_python.py trajdb.duckdb_extension
"$VENV/bin/python" tests/run_fuzz_python.py trajdb.duckdb_extension "$FUZZ_CASES"
"$VENV/bin/python" tests/test_robust_python.py trajdb.duckdb_extension
"$VENV/bin/python" tests/test_safety_python.py trajdb.duckdb_extension
"$VENV/bin/python" tests/test_sandbox_python.py trajdb.duckdb_extension
"$VENV/bin/python" tests/test_invariance_python.py trajdb.duckdb_extension
"$VENV/bin/python" tests/test_crowd_python.py trajdb.duckdb_extension
"$VENV/bin/python" tests/test_score_python.py trajdb.duckdb_extension
"$VENV/bin/python" tests/test_readme.py trajdb.duckdb_extension
tests/test_python_package.sh

echo "== 5/6 WKB round trip with DuckDB spatial"
if [ ! -x "$SPATIAL_VENV/bin/python" ]; then python3 -m venv "$SPATIAL_VENV"; fi
"$SPATIAL_VENV/bin/pip" install -q -r requirements-spatial.txt
"$SPATIAL_VENV/bin/python" tests/test_spatial_roundtrip.py trajdb.duckdb_extension
# the same extension file, .slt suite and README examples in DuckDB 1.5 (this venv's duckdb 1.5.5)
"$SPATIAL_VENV/bin/python" tests/run_slt_python.py trajdb.duckdb_extension
"$SPATIAL_VENV/bin/python" tests/run_fuzz_python.py trajdb.duckdb_extension "$FUZZ_CASES"
"$SPATIAL_VENV/bin/python" tests/test_robust_python.py trajdb.duckdb_extension
"$SPATIAL_VENV/bin/python" tests/test_safety_python.py trajdb.duckdb_extension
"$SPATIAL_VENV/bin/python" tests/test_sandbox_python.py trajdb.duckdb_extension
"$SPATIAL_VENV/bin/python" tests/test_crowd_python.py trajdb.duckdb_extension
"$SPATIAL_VENV/bin/python" tests/test_score_python.py trajdb.duckdb_extension
"$SPATIAL_VENV/bin/python" tests/test_readme.py trajdb.duckdb_extension

echo "== 6/6 trajdb.spark in Spark local mode against trajdb pipeline per site"
SPARK_PY="$(scripts/install_spark.sh)"
SPARK_LOG="$CARGO_TARGET_DIR/test_spark.log"
# Spark logs the injected task failures at length: the log is kept, and shown when the test fails
if ! "$SPARK_PY" tests/test_spark.py "$CARGO_TARGET_DIR/release/trajdb" trajdb.duckdb_extension > "$SPARK_LOG" 2>&1; then
  grep -v "^\s*at \|WARN" "$SPARK_LOG" | tail -60 >&2
  echo "tests/test_spark.py failed (whole log: $SPARK_LOG)" >&2
  exit 1
fi
grep -a -o "test_spark: OK.*" "$SPARK_LOG"
echo "scripts/test.sh: all tests passed"
