#!/usr/bin/env python3
"""Robustness through the loadable extension in PyPI DuckDB (issue 17):
- concurrency: threads, each with its own cursor on one connection, run trajdb queries
  together; every result equals the serial run;
- interrupt: a long multi-row trajdb query is interrupted from another thread
  (con.interrupt()); it returns within 1 s and the connection keeps working;
- work limits: a single call beyond a documented limit (an LCSS table of 2.25e10 cells) stops at
  once with an error that names the limit and how to raise it, and the connection keeps working;
- memory: under an address-space limit of 3 GB, clustering 30,000 items (a 3.4 GiB distance
  matrix) is an error that says how much was needed; the Python process lives on.

usage: python3 tests/test_robust_python.py path/to/trajdb.duckdb_extension
"""
import os
import subprocess
import sys
import threading
import time

import duckdb

QUERIES = [
    # LCSS over many track pairs (time window, index window), polygons, matching, clustering
    """SELECT sum(lcss_similarity(a, b, 1.0, 0.5)), sum(lcss_index_similarity(a, b, 5, 1.0))
       FROM (SELECT [{'t': i * 0.1, 'x': i * 0.5 + k % 7, 'y': sin(i * 0.1 + k)} FOR i IN range(60)] AS a,
                    [{'t': i * 0.1 + 0.05, 'x': i * 0.5 + k % 5, 'y': sin(i * 0.1 + k) + 0.2} FOR i IN range(60)] AS b
             FROM range(3000) r(k))""",
    """SELECT sum(polygon_area(polygon_overlap(view_polygon([{'x': i * cos(k), 'y': i * sin(k * 1.3)} FOR i IN range(40)], 'convex'),
                                               'POLYGON ((0 0, 30 0, 30 30, 0 30, 0 0))')))
       FROM range(2000) r(k)""",
    """SELECT list(m ORDER BY m.a) FROM (SELECT unnest(hungarian_match(list({'a': k // 40, 'b': k % 40, 'score': ((k * 7919) % 1000) / 1000.0}), true, 0.1)) AS m
                                  FROM range(1600) r(k))""",
    """SELECT agglomerative_cluster(list({'a': i, 'b': j, 'distance': abs(sin(i) - sin(j))}), 'average', 0.3)
       FROM range(60) a(i), range(60) b(j) WHERE i < j""",
]


def run_all(cur):
    return [cur.execute(q).fetchall() for q in QUERIES]


def main():
    ext = os.path.abspath(sys.argv[1])
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{ext}'")

    # concurrency: 6 threads x all queries, each thread its own cursor, against the serial run
    serial = run_all(con)
    results, errors = [None] * 6, []

    def worker(k):
        try:
            results[k] = run_all(con.cursor())
        except Exception as e:  # noqa: BLE001
            errors.append(e)

    threads = [threading.Thread(target=worker, args=(k,)) for k in range(6)]
    [t.start() for t in threads]
    [t.join() for t in threads]
    assert not errors, errors
    assert all(r == serial for r in results), "a concurrent result differs from the serial run"
    print(f"ok   concurrency: 6 threads x {len(QUERIES)} trajdb queries, each on its own cursor, equal to the serial run")

    # interrupt: a long multi-row query stops within 1 s of con.interrupt()
    long_q = """SELECT sum(lcss_similarity(a, b, 1.0, 0.5)) FROM (
                  SELECT [{'t': i * 0.1, 'x': i * 0.5 + k % 7, 'y': 0.0} FOR i IN range(200)] AS a,
                         [{'t': i * 0.1, 'x': i * 0.5 + k % 5, 'y': 0.1} FOR i IN range(200)] AS b FROM range(100000000) r(k))"""
    box = {}

    def long_call():
        t = time.perf_counter()
        try:
            con.execute(long_q).fetchall()
            box["outcome"] = "finished"
        except duckdb.InterruptException:
            box["outcome"] = "interrupted"
        except Exception as e:  # noqa: BLE001
            box["outcome"] = f"{type(e).__name__}: {e}"
        box["end"] = time.perf_counter()

    th = threading.Thread(target=long_call)
    th.start()
    time.sleep(1.0)
    t_int = time.perf_counter()
    con.interrupt()
    th.join(timeout=10)
    assert not th.is_alive(), "the interrupted query did not return within 10 s"
    took = box["end"] - t_int
    assert box["outcome"] == "interrupted", box
    assert took < 1.0, f"returned {took:.2f} s after the interrupt"
    assert con.execute("SELECT 42").fetchall() == [(42,)]
    print(f"ok   interrupt: a long trajdb query returned {took * 1000:.0f} ms after con.interrupt(); the connection works")

    # a single call over its work limit: an error at once, naming the limit
    t = time.perf_counter()
    try:
        con.execute("""SELECT lcss_similarity([{'t': i * 1.0, 'x': i * 1.0, 'y': 0.0} FOR i IN range(150000)],
                                              [{'t': i * 1.0, 'x': i * 1.0, 'y': 0.0} FOR i IN range(150000)], 1.0, 1e9)""").fetchall()
        raise SystemExit("FAIL: a 2.25e10-cell LCSS table was not refused")
    except duckdb.InvalidInputException as e:
        assert "lcss_similarity:" in str(e) and "trajdb_set_limit" in str(e), e
        took = time.perf_counter() - t
        assert took < 20, took  # building the 150k-point lists is most of it; the LCSS would take minutes
        print(f"ok   work limit: a 2.25e10-cell LCSS table refused in {took:.2f} s: {str(e)[:160]}")
    assert con.execute("SELECT 42").fetchall() == [(42,)]

    # memory: a 3.4 GiB matrix under a 3 GB address-space limit, in a child Python
    child = f"""
import resource, duckdb
resource.setrlimit(resource.RLIMIT_AS, (3 * 1024 ** 3, 3 * 1024 ** 3))
con = duckdb.connect(config={{'allow_unsigned_extensions': 'true', 'threads': '2'}})
con.execute("LOAD '{ext}'")
try:
    con.execute("SELECT agglomerative_cluster(list({{'a': k, 'b': k + 1, 'distance': 1.0}}), 'single', 0.5) FROM range(30000) r(k)").fetchall()
    print('NO ERROR')
except duckdb.InvalidInputException as e:
    print('ERROR', e)
print('ALIVE', con.execute('SELECT 42').fetchall())
"""
    out = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and "distance matrix, which could not be allocated" in out.stdout and "ALIVE [(42,)]" in out.stdout, (out.returncode, out.stdout, out.stderr[-2000:])
    print("ok   memory: 30,000 items under a 3 GB limit:", out.stdout.splitlines()[0][:150])


if __name__ == "__main__":
    main()
