#!/usr/bin/env python3
"""docs/outputs.md cannot drift (issue 29, part 3): runs the pipeline on a small simulated scene
and checks that the columns of every result file equal, as a set and in order, the columns
documented for it (the rows "| `column` | ..." of the table under the heading "## `file`"), and
that every file the pipeline writes is documented.

usage: python3 tests/test_outputs_doc_python.py path/to/trajdb.duckdb_extension
"""
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
DOC = os.path.join(HERE, "..", "docs", "outputs.md")


def documented():
    """{file name: [column, ...]} from docs/outputs.md."""
    files, cur = {}, None
    for line in open(DOC, encoding="utf-8"):
        m = re.match(r"^## `([^`]+)`", line)
        if m:
            cur = m.group(1)
            files[cur] = []
            continue
        if line.startswith("## "):
            cur = None
        m = re.match(r"^\| `([A-Za-z_0-9]+)` \|", line)
        if cur is not None and m:
            files[cur].append(m.group(1))
    return files


def main():
    ext = os.path.abspath(sys.argv[1])
    os.environ["TRAJDB_EXTENSION"] = ext
    sys.path.insert(0, os.path.join(HERE, "..", "python"))
    import trajdb
    doc = documented()
    failures = 0

    def check(ok, what):
        nonlocal failures
        failures += not ok
        print(("ok   " if ok else "FAIL ") + what)

    with tempfile.TemporaryDirectory() as w:
        env = dict(os.environ, PYTHONPATH=os.path.join(HERE, "..", "python"))
        subprocess.run([sys.executable, "-m", "trajdb", "simulate", "--out", w + "/sim", "--minutes", "2", "--seed", "5"],
                       check=True, env=env, capture_output=True)
        con = trajdb.connect()
        trajdb.pipeline(con, w + "/sim/points.parquet", out=w + "/r")
        written = sorted(f for f in os.listdir(w + "/r") if not f.startswith("."))  # the runner's hidden files: documented, not results
        check(set(written) == set(doc), f"the files written {written} are the files documented {sorted(doc)}")
        for f in written:
            path = os.path.join(w, "r", f)
            if f.endswith(".csv"):
                cols = [r[0] for r in con.execute("DESCRIBE SELECT * FROM read_csv(?, header = true)", [path]).fetchall()]
            elif f.endswith(".parquet"):
                cols = [r[0] for r in con.execute("DESCRIBE SELECT * FROM read_parquet(?)", [path]).fetchall()]
            else:
                continue  # report.html: no columns
            want = doc.get(f, [])
            check(cols == want, f"{f}: columns {cols} == documented {want}")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
