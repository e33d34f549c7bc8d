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

    sql = block(readme, "### DuckDB CLI", "sql")
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    n_select = 0
    own_sql = "".join(l for l in sql.splitlines(keepends=True) if not l.startswith(".read "))
    top = con.extract_statements(own_sql)  # the block's own statements
    text = expand(sql)
    for stmt in con.extract_statements(text):
        q = stmt.query.strip()
        rel = con.execute(q)
        own = any(q == t.query.strip() for t in top)
        if own and re.match(r"(?is)^\s*(--[^\n]*\n\s*)*(SELECT|WITH|FROM)\b", q):
            rows = rel.fetchall()
            n_select += 1
            assert rows, f"README example returned no rows:\n{q}"
    assert n_select >= 8, n_select
    print(f"ok   README DuckDB CLI block: {n_select} queries, each with rows")

    py = block(readme, "### Python", "python")
    # the block uses the trajdb package (python/) over this extension file
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "python"), TRAJDB_EXTENSION=ext)
    r = subprocess.run([sys.executable, "-c", py], cwd=ROOT, capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    print("ok   README Python block")


if __name__ == "__main__":
    main()
