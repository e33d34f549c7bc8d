"""The archive's cost (issue 40): `trajdb archive` on one machine (worker processes), the one SQL
call `CALL trajdb_archive` (threads of one process) and `trajdb.spark.archive` in Spark local
mode, on 1, 4 and 16 simulated site-days, in one run.

    PY=$(scripts/install_spark.sh)
    $PY benches/archive_scale.py --extension trajdb.duckdb_extension [--minutes 720 --sizes 1,4,16 --out /tmp/trajdb-archive-bench]

A site-day is `trajdb simulate` at Mellingen's size by default (3 cameras, 12 hours, traffic 1.4,
5 Hz: pipeline_scale.sh's Mellingen day), 4 sites of 4 days each (each site its own cameras,
each day its own traffic). The lakes of 1 and 4 site-days are the first partitions of the 16.
All runners do the same work per site-day (the extension's trajdb_archive_task: the site's first
day calibrates it, every other day runs on the kept calibration and is checked; one DuckDB
thread per task) with 2 tasks at a time (--workers 2; workers := 2; Spark local[2]). The SQL
call's tasks share one process: its peak is the process's (two tasks at once), not a task's.

Prints per run: wall, points/s, core-seconds per site-day (the tasks' own seconds, from the
archive's _state/runs.csv, one thread each; and wall x 2 cores, which also counts the idle core
and the driver), the largest task's peak memory (runs.csv), the ratio Spark / one machine; then
the incremental no-op rerun of 16 site-days, and a city's needs (1,000 sites x 365 days) from the
measured core-seconds per site-day.
"""
import argparse
import csv
import os
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python"))


def env(ext):
    return {**os.environ, "PYTHONPATH": os.path.join(ROOT, "python"), "TRAJDB_EXTENSION": ext, "PYSPARK_PYTHON": sys.executable}


def timed(args, e):
    t = time.perf_counter()
    p = subprocess.Popen(args, env=e)
    _, status, ru = os.wait4(p.pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError(f"{args[:4]} failed with status {os.waitstatus_to_exitcode(status)}")
    return time.perf_counter() - t, ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024.0


def runs(out):
    with open(os.path.join(out, "_state", "runs.csv")) as f:
        rows = [r for r in csv.DictReader(f)]
    return rows


SPARK = """
import sys
from pyspark.sql import SparkSession
from trajdb import spark as tspark
spark = (SparkSession.builder.master("local[2]").appName("trajdb-archive-bench").config("spark.ui.enabled", "false")
         .config("spark.ui.showConsoleProgress", "false").getOrCreate())
spark.sparkContext.setLogLevel("ERROR")
r = tspark.archive(spark, sys.argv[1], sys.argv[2], extension=sys.argv[3], progress=False)
assert r["failed"] == 0, r
spark.stop()
"""

SQL = """
import sys, duckdb
con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
con.execute("SET enable_progress_bar = false")
con.execute("LOAD " + repr(sys.argv[3]))
rows = con.execute("FROM trajdb_archive(?, out_dir := ?, workers := 2)", [sys.argv[1], sys.argv[2]]).fetchall()
assert all(r[2] == "ok" for r in rows), rows
"""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--extension", required=True)
    ap.add_argument("--minutes", type=float, default=720.0)
    ap.add_argument("--traffic", type=float, default=1.4)
    ap.add_argument("--rate-hz", type=float, default=5.0)
    ap.add_argument("--sizes", default="1,4,16")
    ap.add_argument("--sites", type=int, default=4)
    ap.add_argument("--out", default="/tmp/trajdb-archive-bench")
    ap.add_argument("--no-spark", action="store_true")
    a = ap.parse_args()
    ext = os.path.abspath(a.extension)
    os.environ["TRAJDB_EXTENSION"] = ext
    import trajdb
    from trajdb import lake_sim

    sizes = [int(s) for s in a.sizes.split(",")]
    total = max(sizes)
    days = (total + a.sites - 1) // a.sites
    shutil.rmtree(a.out, ignore_errors=True)
    os.makedirs(a.out)
    full = os.path.join(a.out, "lake")
    t = time.perf_counter()
    parts = lake_sim.simulate_lake(trajdb.connect(), full, sites=a.sites, days=days, minutes=a.minutes, cameras=3,
                                   traffic=a.traffic, rate_hz=a.rate_hz, world_rate_hz=0, viewpoint_bias_vehicle=1.0,
                                   viewpoint_bias_vru=0.2, ground_plane_scale=0.01)
    # partitions in the order a nightly archive grows: every site's first day, then the second...
    order = sorted(parts, key=lambda p: (p[1], p[0]))[:total]
    print(f"lake: {len(order)} site-days of {a.minutes:g} min, {sum(p[2] for p in order):,} points "
          f"({sum(p[2] for p in order) / len(order):,.0f} per site-day), simulated in {time.perf_counter() - t:.0f} s", flush=True)
    e = env(ext)
    rows = []
    for n in sizes:
        lake = os.path.join(a.out, f"lake-{n}")
        for site, date, _ in order[:n]:
            d = os.path.join(lake, f"site={site}")
            os.makedirs(d, exist_ok=True)
            os.symlink(os.path.join(full, f"site={site}", f"date={date}"), os.path.join(d, f"date={date}"))
        points = sum(p[2] for p in order[:n])
        for runner in ("one machine", "sql call", "spark local[2]"):
            if runner.startswith("spark") and a.no_spark:
                continue
            out = os.path.join(a.out, f"out-{n}-{runner.split()[0]}")
            if runner == "one machine":
                args = [sys.executable, "-m", "trajdb", "archive", "--input", lake, "--out", out, "--workers", "2"]
            elif runner == "sql call":
                args = [sys.executable, "-c", SQL, lake, out, ext]
            else:
                args = [sys.executable, "-c", SPARK, lake, out, ext]
            wall, cpu, maxrss = timed(args, e)
            r = runs(out)
            task_s = sum(float(x["seconds"]) for x in r)
            peak = max(float(x["peak_rss_mb"] or 0) for x in r) if runner != "sql call" else maxrss
            rows.append(dict(n=n, runner=runner, wall=wall, points=points, task_s=task_s, runs=len(r), peak=peak, cpu=cpu))
            print(f"{n:>3} site-days  {runner:<15} wall {wall:7.1f} s  {points / wall:>10,.0f} points/s  "
                  f"task core-s/site-day {task_s / n:6.1f}  wall x 2 cores/site-day {2 * wall / n:6.1f}  "
                  f"largest task {peak:6.0f} MB  ({len(r)} task runs)", flush=True)
    for n in sizes:
        one = [r for r in rows if r["n"] == n and r["runner"] == "one machine"]
        for other in ("sql call", "spark local[2]"):
            sp = [r for r in rows if r["n"] == n and r["runner"] == other]
            if one and sp:
                print(f"{n:>3} site-days  {other} / one machine: task core-s {sp[0]['task_s'] / one[0]['task_s']:.2f}, "
                      f"wall {sp[0]['wall'] / one[0]['wall']:.2f}")
    # the incremental no-op: the 16 again, unchanged
    out = os.path.join(a.out, f"out-{total}-one")
    wall, _, _ = timed([sys.executable, "-m", "trajdb", "archive", "--input", os.path.join(a.out, f"lake-{total}"), "--out", out], e)
    print(f"no-op rerun of {total} site-days: {wall:.2f} s (the command, Python start included)")
    out = os.path.join(a.out, f"out-{total}-sql")
    wall, _, _ = timed([sys.executable, "-c", SQL, os.path.join(a.out, f"lake-{total}"), out, ext], e)
    print(f"no-op rerun of {total} site-days by the SQL call: {wall:.2f} s (Python start and LOAD included)")
    big = [r for r in rows if r["n"] == total and r["runner"] == "one machine"][0]
    per = big["task_s"] / total
    sd = 1000 * 365
    print(f"a city of 1,000 sites x 365 days at {per:.0f} core-s per site-day: {sd * per / 3600:,.0f} core-hours a year; "
          f"one night's 1,000 site-days in 6 hours: {1000 * per / (6 * 3600):.1f} cores; "
          f"a year's backlog on 64 cores: {sd * per / 64 / 86400:.1f} days")


if __name__ == "__main__":
    main()
