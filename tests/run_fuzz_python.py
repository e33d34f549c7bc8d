#!/usr/bin/env python3
"""The fuzz cases that tests/fuzz.rs generates (TRAJDB_FUZZ_OUT) against the loadable extension
in PyPI DuckDB (issue 17). Every case must give a value, NULL, or an error; and:
  * no panic text and no INTERNAL / fatal error (a panic that crossed the boundary and killed
    the process fails this script by its exit status; --trace names the case that did it);
  * trajdb's own errors are an ordinary InvalidInputException that names the function
    (`lcss_similarity: ...`), and an Invalid Input error always names it (DuckDB's
    Conversion errors aside);
  * no call takes longer than 30 s (a watchdog interrupts it and the case fails: the work
    limits keep every call far below);
  * the connection keeps working after each case (SELECT 42).
Slow cases (> 2 s) are printed, and the slowest one at the end.

usage: python3 tests/run_fuzz_python.py path/to/trajdb.duckdb_extension cases.sql [--trace]
"""
import os
import re
import sys
import threading
import time

import duckdb

HANG_S = float(os.environ.get("TRAJDB_FUZZ_HANG_S", "30"))  # a call slower than this counts as a hang
SLOW_S = 2.0


def bad_error(name, e):
    """Why an error is a finding, or None."""
    msg = str(e)
    if "INTERNAL" in msg or "panic" in msg.lower() or isinstance(e, duckdb.FatalException):
        return f"panic / internal error: {type(e).__name__}: {msg[:300]}"
    if f"{name}:" in msg and not isinstance(e, duckdb.InvalidInputException):
        return f"trajdb's error arrived as {type(e).__name__}, not InvalidInputException: {msg[:200]}"
    invalid_input = isinstance(e, duckdb.InvalidInputException) or "Invalid Input Error" in msg
    if invalid_input and f"{name}:" not in msg and "Conversion" not in msg:
        return f"an error that does not name {name}: {msg[:300]}"
    return None


def main():
    ext, cases = os.path.abspath(sys.argv[1]), sys.argv[2]
    trace = "--trace" in sys.argv[3:]
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{ext}'")
    stmts = [l.rstrip().rstrip(";") for l in open(cases) if l.strip()]
    n = errors = nulls = 0
    failures = []
    slowest = (0.0, "")
    for sql in stmts:
        name = re.match(r"SELECT \((\w+)\(", sql).group(1)
        if trace:
            print(f"case {n + 1}: {sql[:300]}", file=sys.stderr, flush=True)
        hung = threading.Event()

        def interrupt():
            hung.set()
            print(f"HANG (> {HANG_S:.0f} s, interrupting): {sql[:400]}", file=sys.stderr, flush=True)
            con.interrupt()

        dog = threading.Timer(HANG_S, interrupt)
        t = time.perf_counter()
        dog.start()
        try:
            if con.execute(sql).fetchall()[0][0] is None:
                nulls += 1
        except duckdb.Error as e:
            errors += 1
            if not hung.is_set():
                why = bad_error(name, e)
                if why:
                    failures.append(f"{sql[:160]}: {why}")
        finally:
            dog.cancel()
        took = time.perf_counter() - t
        if hung.is_set():
            failures.append(f"{sql[:160]}: did not come back within {HANG_S:.0f} s")
        if took > SLOW_S:
            print(f"slow case ({took:.1f} s): {sql[:300]}", file=sys.stderr, flush=True)
        if took > slowest[0]:
            slowest = (took, sql[:160])
        n += 1
        if n % 5000 == 0:
            print(f"fuzz: {n} cases so far, {len(failures)} failures", file=sys.stderr, flush=True)
        try:
            assert con.execute("SELECT 42").fetchall() == [(42,)]
        except Exception as e:  # noqa: BLE001 - any failure here is the finding
            failures.append(f"{sql[:160]}: the connection stopped working: {e}")
            break
    assert n > 0, f"no cases in {cases}"
    print(f"duckdb {duckdb.__version__}: {n} fuzz cases, {errors} errors, {nulls} NULLs, {len(failures)} failures; "
          f"slowest {slowest[0]:.2f} s: {slowest[1]}")
    for f in failures[:40]:
        print("FAIL", f)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
