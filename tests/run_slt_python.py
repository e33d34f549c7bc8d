#!/usr/bin/env python3
"""Run tests/sql/*.slt against the built loadable extension in stock DuckDB (PyPI `duckdb`).

This is a small reader of the sqllogictest subset our files use (`statement ok`,
`statement error <regex>`, `query <types>` with `----` results, `#` comments). Values are
formatted exactly as sqllogictest-rs formats them: each result column is cast to VARCHAR by DuckDB,
NULL prints as `NULL`, the empty string as `(empty)`, and cells of a row are joined by one
space with whitespace normalised (sqllogictest-rs's default validator).

usage: python3 tests/run_slt_python.py path/to/trajdb.duckdb_extension [filter]
"""
import glob
import os
import re
import sys

import duckdb

ROWS = ("SELECT", "WITH", "FROM", "VALUES")


def returns_rows(sql):
    first = re.split(r"[\s(]", sql.lstrip(), maxsplit=1)[0].upper()
    return first in ROWS


def norm(s):
    return " ".join(s.split())


def parse(path):
    """Yield records: (kind, arg, sql, expected_lines, line_no)."""
    lines = open(path, encoding="utf-8").read().split("\n")
    i = 0
    while i < len(lines):
        line = lines[i]
        if not line.strip() or line.lstrip().startswith("#"):
            i += 1
            continue
        start = i + 1
        head = line.strip()
        i += 1
        sql = []
        while i < len(lines) and lines[i].strip() and lines[i].strip() != "----":
            sql.append(lines[i])
            i += 1
        expected = []
        if i < len(lines) and lines[i].strip() == "----":
            i += 1
            while i < len(lines) and lines[i].strip():
                expected.append(lines[i])
                i += 1
        if head.startswith("statement ok"):
            yield ("ok", None, "\n".join(sql), expected, start)
        elif head.startswith("statement error"):
            yield ("error", head[len("statement error"):].strip(), "\n".join(sql), expected, start)
        elif head.startswith("query"):
            yield ("query", head, "\n".join(sql), expected, start)
        else:
            raise SystemExit(f"{path}:{start}: unsupported record {head!r}")


def connect(ext):
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{ext}'")
    return con


def run_sql(con, sql):
    if not returns_rows(sql):
        con.execute(sql)
        return None
    wrapped = f"SELECT COLUMNS(*)::VARCHAR FROM ({sql.strip().rstrip(';')}) AS slt_q"
    rows = con.execute(wrapped).fetchall()
    out = []
    for r in rows:
        out.append(["NULL" if v is None else ("(empty)" if v == "" else v) for v in r])
    return out


def run_file(ext, path):
    con = connect(ext)
    for kind, arg, sql, expected, line in parse(path):
        where = f"{os.path.basename(path)}:{line}"
        if kind == "ok":
            try:
                run_sql(con, sql)
            except Exception as e:  # noqa: BLE001
                return f"{where}: statement failed: {e}\n{sql}"
        elif kind == "error":
            try:
                run_sql(con, sql)
            except Exception as e:  # noqa: BLE001
                if arg and not re.search(arg, str(e)):
                    return f"{where}: error {str(e)!r} does not match /{arg}/\n{sql}"
                continue
            return f"{where}: statement succeeded but an error was expected\n{sql}"
        else:
            try:
                rows = run_sql(con, sql) or []
            except Exception as e:  # noqa: BLE001
                return f"{where}: query failed: {e}\n{sql}"
            got = [norm(" ".join(r)) for r in rows]
            want = [norm(x) for x in expected]
            if got != want:
                return f"{where}: result mismatch\n{sql}\nexpected:\n" + "\n".join(want) + "\nactual:\n" + "\n".join(got)
    return None


def main():
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    ext = os.path.abspath(sys.argv[1])
    flt = sys.argv[2] if len(sys.argv) > 2 else ""
    here = os.path.dirname(os.path.abspath(__file__))
    files = sorted(f for f in glob.glob(os.path.join(here, "sql", "*.slt")) if flt in f)
    passed = failed = 0
    # the .slt files' own scratch folders in /tmp, from an earlier run (perhaps of an earlier
    # trajdb, whose manifests the results-folder rules refuse): this runner's, removed first
    import shutil
    for d in glob.glob("/tmp/trajdb-slt-*") + ["/tmp/trajdb-example-results", "/tmp/trajdb-sim-example"]:
        shutil.rmtree(d, ignore_errors=True) if os.path.isdir(d) and not os.path.islink(d) else None
    print(f"duckdb {duckdb.__version__}, extension {ext}")
    for f in files:
        err = run_file(ext, f)
        if err is None:
            passed += 1
            print(f"ok   {os.path.basename(f)}")
        else:
            failed += 1
            print(f"FAIL {os.path.basename(f)}\n{err}")
    print(f"loadable-extension: {passed} passed, {failed} failed")
    sys.exit(1 if failed or not passed else 0)


if __name__ == "__main__":
    main()
