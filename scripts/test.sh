#!/usr/bin/env bash
# Every test of trajdb, from a clean clone: `scripts/test.sh`. One build (the loadable
# extension: Rust only, no C++ compiler anywhere); every SQL test runs through it in stock PyPI
# DuckDB 2.0 and again in DuckDB 1.5.
#   1. Rust: the workspace's unit and property tests (crates/algo: the maths; crates/app: the
#      manifest, parameters, results folder, simulator, report; the extension's own), and the
#      fuzz cases generated for step 4 (tests/fuzz.rs writes them; no DuckDB in any test binary)
#   2. the loadable extension: build, footer; docs/functions.md and the family table of
#      docs/development.md are what trajdb_reference() says
#   3. in DuckDB 2.0 (PyPI): tests/sql/*.slt, the fuzz cases, robustness (concurrency, interrupt,
#      work limits), every function under RLIMIT_AS and every long kernel under an interrupt
#      (tests/test_rlimit_python.py), safety (results folder, injection, sandbox, parameters), table functions in
#      a child process, invariance (frames, clocks, ids, row order), crowds, the scorer, the
#      README's examples, each stage alone (tests/test_stages_python.py) and its contract
#      header (tests/check_stage_contracts.py), the `trajdb` command (tests/test_cli_python.py),
#      byte-identical results across thread counts and row orders, every input kind (DataFrames,
#      Arrow, relations, tables, files, text ids, TIMESTAMP t), the analyst's questions against the
#      simulator's truth (movements, speeds, PET/TTC), fused paths against the true lengths, the
#      data dictionary against the files, the GIS export, the archive (site=S/date=D partitions:
#      camera changes found, incremental, kill -9 and resume byte-identical, faults isolated:
#      tests/test_archive_python.py), report.html in headless Chromium
#      (apt-get installs it), the Python package installed by pip into a fresh venv, and the
#      prebuilt wheel installed without Rust or a compiler (LOAD trajdb by name)
#   4. in DuckDB 1.5.5 with DuckDB spatial: the WKB / GeoParquet round trip, and the .slt suite,
#      fuzz cases, robustness, safety, sandbox, crowd, scorer, README and archive tests again
#   5. trajdb.spark in Spark local mode against trajdb.pipeline on each whole site, and
#      trajdb.spark.archive against trajdb archive on one machine, file for file
#      (scripts/install_spark.sh installs pyspark and, from apt, Java 17)
# Needs: cargo (Rust 1.89+), python3 with venv/pip and PyPI reachable.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/trajdb-target}"
VENV="${TRAJDB_VENV:-$HOME/.cache/trajdb-venv}"
SPATIAL_VENV="${TRAJDB_SPATIAL_VENV:-$HOME/.cache/trajdb-spatial-venv}"
EXT=trajdb.duckdb_extension

echo "== 1/5 Rust: workspace unit and property tests (no DuckDB), fuzz cases generated"
FUZZ_CASES="$CARGO_TARGET_DIR/fuzz-cases.sql"
mkdir -p "$CARGO_TARGET_DIR"
TRAJDB_FUZZ_OUT="$FUZZ_CASES" cargo test --release --workspace

echo "== 2/5 the loadable extension, its footer, the function reference"
scripts/build_extension.sh
if [ ! -x "$VENV/bin/python" ]; then python3 -m venv "$VENV"; fi
"$VENV/bin/pip" install -q --disable-pip-version-check -r requirements-test.txt
python3 tests/test_footer.py && python3 tests/test_footer.py "$EXT"
"$VENV/bin/python" - "$EXT" <<'PY'
import os, sys, duckdb
con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
con.execute(f"LOAD '{os.path.abspath(sys.argv[1])}'")  # a bare file name goes to the system loader
now = con.execute("SELECT trajdb_reference('markdown')").fetchall()[0][0]
if open("docs/functions.md").read() != now:
    got = os.path.join(os.environ["CARGO_TARGET_DIR"], "functions.md")
    open(got, "w").write(now)
    sys.exit(f"docs/functions.md is stale: the extension's reference is in {got}; "
             "run  python -m trajdb functions --markdown > docs/functions.md")
print("ok   docs/functions.md is the extension's trajdb_reference('markdown')")
families = con.execute("SELECT trajdb_reference('families')").fetchall()[0][0]
dev = open("docs/development.md").read()
begin, end = "<!-- generated: trajdb functions --families -->\n", "<!-- end generated -->\n"
if begin not in dev or end not in dev[dev.index(begin):]:
    sys.exit("docs/development.md lacks its generated family table's markers")
i = dev.index(begin) + len(begin)
if dev[i:dev.index(end, i)] != families:
    sys.exit("docs/development.md's family table is stale: replace the lines between its markers with "
             "python -m trajdb functions --families")
print("ok   docs/development.md's family table is the extension's trajdb_reference('families')")
PY

echo "== 3/5 DuckDB 2.0 (PyPI): SQL, fuzz, robustness, safety, invariance, stages, command, package"
PY="$VENV/bin/python"
"$PY" tests/run_slt_python.py "$EXT"
"$PY" tests/run_fuzz_python.py "$EXT" "$FUZZ_CASES"
"$PY" tests/test_robust_python.py "$EXT"
"$PY" tests/test_rlimit_python.py "$EXT"
"$PY" tests/test_safety_python.py "$EXT"
"$PY" tests/test_sandbox_python.py "$EXT"
"$PY" tests/test_invariance_python.py "$EXT"
"$PY" tests/test_crowd_python.py "$EXT"
"$PY" tests/test_score_python.py "$EXT"
"$PY" tests/test_readme.py "$EXT"
"$PY" tests/check_stage_contracts.py "$EXT"
"$PY" tests/check_rust_imports.py
"$PY" tests/test_stages_python.py "$EXT"
"$PY" tests/test_cli_python.py "$EXT"
"$PY" tests/test_determinism_python.py "$EXT"
"$PY" tests/test_inputs_python.py "$EXT"
"$PY" tests/test_runner_python.py "$EXT"
"$PY" tests/test_analysis_python.py "$EXT"
"$PY" tests/test_userdb_python.py "$EXT"
"$PY" tests/test_paths_python.py "$EXT"
"$PY" tests/test_outputs_doc_python.py "$EXT"
"$PY" tests/test_export_python.py "$EXT"
"$PY" tests/test_archive_python.py "$EXT"
if ! command -v chromium > /dev/null && ! command -v chromium-browser > /dev/null; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium > /dev/null
fi
tests/test_report.sh "$EXT" "$PY"
tests/test_python_package.sh "$EXT"
tests/test_wheel.sh "$EXT"

echo "== 4/5 DuckDB 1.5.5 with DuckDB spatial: WKB round trip, and the SQL tests again"
if [ ! -x "$SPATIAL_VENV/bin/python" ]; then python3 -m venv "$SPATIAL_VENV"; fi
"$SPATIAL_VENV/bin/pip" install -q --disable-pip-version-check -r requirements-spatial.txt
PY15="$SPATIAL_VENV/bin/python"
"$PY15" tests/test_spatial_roundtrip.py "$EXT"
"$PY15" tests/run_slt_python.py "$EXT"
"$PY15" tests/run_fuzz_python.py "$EXT" "$FUZZ_CASES"
"$PY15" tests/test_robust_python.py "$EXT"
"$PY15" tests/test_rlimit_python.py "$EXT" rlimit   # the interrupt part runs in 2.0 (DuckDB 1.5 ran a 2048-row chunk of its moderate calls past the bound)
"$PY15" tests/test_safety_python.py "$EXT"
"$PY15" tests/test_sandbox_python.py "$EXT"
"$PY15" tests/test_crowd_python.py "$EXT"
"$PY15" tests/test_score_python.py "$EXT"
"$PY15" tests/test_readme.py "$EXT"
"$PY15" tests/test_stages_python.py "$EXT"
"$PY15" tests/test_inputs_python.py "$EXT"
"$PY15" tests/test_runner_python.py "$EXT"
"$PY15" tests/test_analysis_python.py "$EXT"
"$PY15" tests/test_userdb_python.py "$EXT"
"$PY15" tests/test_outputs_doc_python.py "$EXT"
"$PY15" tests/test_export_python.py "$EXT"
"$PY15" tests/test_archive_python.py "$EXT"

echo "== 5/5 trajdb.spark in Spark local mode against trajdb.pipeline per site"
SPARK_PY="$(scripts/install_spark.sh)"
SPARK_LOG="$CARGO_TARGET_DIR/test_spark.log"
# Spark logs the injected task failures at length: the log is kept, and shown when the test fails
if ! "$SPARK_PY" tests/test_spark.py "$EXT" > "$SPARK_LOG" 2>&1; then
  grep -v "^\s*at \|WARN" "$SPARK_LOG" | tail -60 >&2
  echo "tests/test_spark.py failed (whole log: $SPARK_LOG)" >&2
  exit 1
fi
grep -a -o "test_spark: OK.*" "$SPARK_LOG"
echo "scripts/test.sh: all tests passed"
