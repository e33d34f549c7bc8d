#!/usr/bin/env bash
# The Python package (issue 16): `pip install .` into a FRESH venv (setuptools-rust builds the
# loadable extension: no C++), then the `trajdb` console script it installs runs the demo in
# stock PyPI DuckDB (trajdb_simulate, the pipeline, report.html, the score); its files are
# compared one by one with the same demo run through the repository's package and the given
# extension build (TRAJDB_EXTENSION); and an old DuckDB is refused with a message naming the
# versions that work.
# usage: tests/test_python_package.sh path/to/trajdb.duckdb_extension
set -euo pipefail
[ -f "${1:-}" ] || { echo "usage: $0 path/to/trajdb.duckdb_extension" >&2; exit 2; }
EXT="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"
cd "$(dirname "$0")/.."
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/trajdb-target}"
REPO="$PWD"
W="$(mktemp -d)"
trap 'rm -rf "$W"' EXIT
python3 -m venv "$W/venv"
"$W/venv/bin/pip" install -q . 2>&1 | grep -v "^\s*$" | grep -vi "warning" || true
"$W/venv/bin/python" -c "import trajdb" || { echo "FAIL: pip install . did not install trajdb" >&2; exit 1; }
[ -x "$W/venv/bin/trajdb" ] || { echo "FAIL: pip install . did not install the trajdb command" >&2; exit 1; }
"$W/venv/bin/trajdb" --help | grep -q "pipeline" || { echo "FAIL: trajdb --help" >&2; exit 1; }
# the demo both ways: the installed command with the extension pip built, and the repository's
# package with the given extension (python -m trajdb)
(cd "$W" && env -u TRAJDB_EXTENSION "$W/venv/bin/trajdb" demo --out pydemo > "$W/pydemo.txt" 2>&1) || true
grep -q "demo PASSED" "$W/pydemo.txt" || { cat "$W/pydemo.txt" >&2; echo "FAIL: trajdb demo did not pass" >&2; exit 1; }
(cd "$W" && TRAJDB_EXTENSION="$EXT" PYTHONPATH="$REPO/python" "$W/venv/bin/python" -m trajdb demo --out extdemo > "$W/extdemo.txt" 2>&1) \
  || { cat "$W/extdemo.txt" >&2; echo "FAIL: the demo through $EXT" >&2; exit 1; }
# the rest with the installed package and the extension pip built
env -u TRAJDB_EXTENSION "$W/venv/bin/python" - "$W" <<'PY'
import sys, duckdb, trajdb
w = sys.argv[1]
con = trajdb.connect()
v = con.sql("SELECT extension_version FROM duckdb_extensions() WHERE extension_name = 'trajdb'").fetchall()
assert v == [("v" + trajdb.__version__,)], v
# identical to the demo through the repository's extension build, file by file
q = duckdb.connect()
checks = {
    "merged.parquet": "SELECT road_user, class, n_tracks, sources, t_start, t_end, length_m, traj FROM '{}/merged.parquet'",
    "matches.csv": "FROM '{}/matches.csv'",
    "transforms.csv": "FROM '{}/transforms.csv'",
    "links.csv": "FROM '{}/links.csv'",
    "clusters.csv": "FROM '{}/clusters.csv'",
}
for name, sql in checks.items():
    a, b = sql.format(f"{w}/extdemo/results"), sql.format(f"{w}/pydemo/results")
    n = q.sql(f"SELECT count(*) FROM '{w}/extdemo/results/{name}'").fetchall()[0][0]
    diff = q.sql(f"SELECT (SELECT count(*) FROM ({a} EXCEPT ALL {b})) + (SELECT count(*) FROM ({b} EXCEPT ALL {a}))").fetchall()[0][0]
    assert n > 0 and diff == 0, f"{name}: {diff} rows differ of {n}"
    print(f"ok   {name}: {n} rows, identical to the demo through the repository's extension")
# report.html: the same page but for the stage times and the input path
import re
def page(d):
    h = open(f"{w}/{d}/results/report.html").read()
    return re.sub(r"<h2>Stages</h2><table>.*?</table>", "", re.sub(r"Input: <code>.*?</code>", "", h))
a, b = page("extdemo"), page("pydemo")
assert len(a) > 100_000 and a == b, f"report.html differs ({len(a)} / {len(b)} characters)"
print(f"ok   report.html: {len(a)} characters, identical to the repository extension's but for the stage times")
# faulty input through the package: a clear error, and the earlier results stay as they were
import os, warnings
scen = f"{w}/pydemo/points.parquet"
out = f"{w}/pyfaulty"
trajdb.pipeline(con, scen, out=out)
assert os.path.exists(f"{out}/report.html")
q.execute(f"COPY (SELECT * FROM '{scen}' WHERE false) TO '{w}/empty.parquet'")
try:
    trajdb.pipeline(con, f"{w}/empty.parquet", out=out)
    raise SystemExit("FAIL: an empty input gave no error")
except duckdb.InvalidInputException as e:
    assert "has no rows" in str(e), e
assert os.path.exists(f"{out}/report.html") and not any(n.startswith(".trajdb-partial") for n in os.listdir(out)), os.listdir(out)
print("ok   empty input: an error; the earlier results stay, and no staging folder is left")
q.execute(f"COPY (SELECT * FROM '{scen}' WHERE camera = 1) TO '{w}/one.parquet'")
with warnings.catch_warnings(record=True) as got:
    warnings.simplefilter("always")
    trajdb.pipeline(con, f"{w}/one.parquet", out=out)
assert any("one camera" in str(g.message) for g in got), [str(g.message) for g in got]
print("ok   one camera: results, and a warning that says so")
# an old DuckDB is refused, naming the versions that work
duckdb.__version__ = "1.4.3"
try:
    trajdb.connect()
    raise SystemExit("FAIL: duckdb 1.4.3 was not refused")
except RuntimeError as e:
    assert "1.5 or newer" in str(e) and "1.4.3" in str(e), e
    print("ok   duckdb 1.4.3 refused:", e)
PY
