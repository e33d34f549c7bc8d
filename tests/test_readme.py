#!/usr/bin/env python3
"""The README's examples, executed (issue 15): the ```sql block of "### DuckDB CLI" and the
```python block of "### Python" run as they stand against the loadable extension in PyPI
DuckDB, from the repository root, on ../shared/data (as in CI). Every SELECT of the SQL block
must return at least one row: an example that returns nothing teaches nothing.

usage: python3 tests/test_readme.py path/to/trajdb.duckdb_extension
"""
import os
import re
import subprocess
import sys

import duckdb

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def block(text, heading, lang):
    """The first ```lang block after the line `heading`."""
    start = text.index(heading + "\n")
    m = re.compile(r"```" + lang + r"\n(.*?)```", re.S).search(text, start)
    assert m, f"no ```{lang} block after {heading}"
    return m.group(1)


def expand(sql):
    """The DuckDB CLI's `.read FILE`, recursively."""
    out = []
    for line in sql.splitlines(keepends=True):
        if line.startswith(".read "):
            with open(line.split(maxsplit=1)[1].strip()) as f:
                out.append(expand(f.read()))
        else:
            out.append(line)
    return "".join(out)


def main():
    ext = os.path.abspath(sys.argv[1])
    os.chdir(ROOT)
    if not os.path.exists("../shared/data/dut_intersection_3cam/points.parquet"):
        print("SKIP: ../shared/data is not there")
        return
    # the examples load './trajdb.duckdb_extension': run them where that path is the built file
    if not os.path.exists("trajdb.duckdb_extension") or not os.path.samefile(ext, "trajdb.duckdb_extension"):
        raise SystemExit(f"run from a checkout whose ./trajdb.duckdb_extension is {ext}")
    readme = open("README.md").read()
    # the examples' own scratch folder in /tmp, from an earlier run (perhaps of an earlier trajdb,
    # whose manifests the results-folder rules refuse): removed first
    import shutil
    if os.path.isdir("/tmp/trajdb-readme-results") and not os.path.islink("/tmp/trajdb-readme-results"):
        shutil.rmtree("/tmp/trajdb-readme-results")

    sql = block(readme, "### DuckDB CLI", "sql")
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    n_select = 0
    # in order, as the CLI does: a `.read` reads its file when it comes (a results folder's
    # analysis.sql exists only after the CALL above it)
    def run_own(text):
        nonlocal n_select
        for stmt in con.extract_statements(text):
            q = stmt.query.strip()
            rel = con.execute(q)
            if re.match(r"(?is)^\s*(--[^\n]*\n\s*)*(SELECT|WITH|FROM)\b", q):
                rows = rel.fetchall()
                n_select += 1
                assert rows, f"README example returned no rows:\n{q}"

    buf = []
    for line in sql.splitlines(keepends=True):
        if line.startswith(".read "):
            run_own("".join(buf))
            buf = []
            for stmt in con.extract_statements(expand(line)):
                con.execute(stmt.query)
        else:
            buf.append(line)
    run_own("".join(buf))
    assert n_select >= 8, n_select
    print(f"ok   README DuckDB CLI block: {n_select} queries, each with rows")

    py = block(readme, "### Python", "python")
    # the block uses the trajdb package (python/) over this extension file
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "python"), TRAJDB_EXTENSION=ext)
    r = subprocess.run([sys.executable, "-c", py], cwd=ROOT, capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    print("ok   README Python block")

    # the loop "without the package", as written: a run, then a failing run releases the results
    # folder (its undo ends the claim) and keeps the earlier results (issue 37)
    loop = block(readme, "Without the package, the extension alone does the same: `trajdb_stages()` lists the statements of", "python")
    sys.path.insert(0, os.path.join(ROOT, "python"))
    os.environ["TRAJDB_EXTENSION"] = ext
    import tempfile
    import trajdb
    w = tempfile.mkdtemp(prefix="trajdb-readme-loop-")
    con = trajdb.connect()
    trajdb.simulate(con, os.path.join(w, "sim"), cameras=2, minutes=1, seed=3)
    out = os.path.join(w, "results")
    exec(loop, {"con": con, "path": os.path.join(w, "sim", "points.parquet"), "out": out})
    first = {n: open(os.path.join(out, n), "rb").read() for n in os.listdir(out)}
    assert "merged.parquet" in first, sorted(first)
    con.execute("CREATE TABLE no_columns AS SELECT 1 AS a")
    try:
        exec(loop, {"con": con, "path": "no_columns", "out": out})
        raise AssertionError("the README loop did not fail on a table without the columns")
    except duckdb.Error:
        pass
    now = {n: open(os.path.join(out, n), "rb").read() for n in os.listdir(out)}
    assert now == first, (sorted(first), sorted(now))
    # the claim was released: the folder can be claimed again at once
    con.execute("FROM trajdb_results_begin(?, '')", [out]).fetchall()
    con.execute("FROM trajdb_results_end(?, false)", [out]).fetchall()
    print("ok   README trajdb_stages loop: runs, and a failing run releases the folder and keeps the results")


if __name__ == "__main__":
    main()
