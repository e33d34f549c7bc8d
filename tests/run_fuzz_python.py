#!/usr/bin/env python3
"""The fuzz cases of tests/fuzz.rs (TRAJDB_FUZZ_OUT) against the loadable extension in PyPI
DuckDB (issue 17): every case gives a value, NULL, or an error; trajdb's errors are an
ordinary InvalidInputException that names the function, never INTERNAL or a panic, and the
connection keeps working after each one.

usage: python3 tests/run_fuzz_python.py path/to/trajdb.duckdb_extension cases.sql
"""
import os
import re
import sys
import time

import duckdb


def main():
    ext, cases = os.path.abspath(sys.argv[1]), sys.argv[2]
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{ext}'")
    stmts = [l.rstrip().rstrip(";") for l in open(cases) if l.strip()]
    n = errors = 0
    failures = []
    slowest = (0.0, "")
    for sql in stmts:
        name = re.match(r"SELECT \((\w+)\(", sql).group(1)
        t = time.perf_counter()
        try:
            con.execute(sql).fetchall()
        except duckdb.Error as e:
            errors += 1
            msg = str(e)
            if "INTERNAL" in msg or "panic" in msg.lower() or isinstance(e, duckdb.FatalException):
                failures.append(f"{sql[:160]}: {type(e).__name__}: {msg[:300]}")
            elif f"{name}:" in msg and not isinstance(e, duckdb.InvalidInputException):
                failures.append(f"{sql[:160]}: trajdb's error arrived as {type(e).__name__}, not InvalidInputException: {msg[:200]}")
        took = time.perf_counter() - t
        if took > slowest[0]:
            slowest = (took, sql[:160])
        n += 1
        try:
            assert con.execute("SELECT 42").fetchall() == [(42,)]
        except Exception as e:  # noqa: BLE001 - any failure here is the finding
            failures.append(f"{sql[:160]}: the connection stopped working: {e}")
            break
    print(f"duckdb {duckdb.__version__}: {n} fuzz cases, {errors} errors, {len(failures)} failures; slowest {slowest[0]:.2f} s: {slowest[1]}")
    for f in failures[:30]:
        print("FAIL", f)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
