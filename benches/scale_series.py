#!/usr/bin/env python3
"""Is the pipeline's cost linear in the data? (issue 28) The whole pipeline on 1x, 4x and 16x a
simulated day, grown two ways: more hours at the same traffic (`hours`), and more road users per
minute in the same hours (`density`). Per stage: seconds, points/s and peak memory; and each
stage's growth exponent between the smallest and the largest run (time ~ n^e: 1 is linear,
n log n shows as about 1.1 over 16x; above 1.25 is flagged). Timing only: nothing here is a test.

Each run is a child process (a fresh DuckDB: no cache carried over) that runs the manifest's
statements (trajdb_stages) stage by stage on one connection. Peak memory per stage: the process's
peak RSS (VmHWM) is reset before each stage (`/proc/self/clear_refs`, Linux) and read after it,
so each stage's figure is its own peak (DuckDB's buffers and trajdb's allocations together).

usage: python benches/scale_series.py [--base-minutes 720] [--factors 1,4,16] [--ways hours,density]
       [--traffic 1.4] [--work DIR]    (TRAJDB_EXTENSION: default ./trajdb.duckdb_extension)
The day: 3 cameras at 5 Hz, traffic 1.4 (the Mellingen-sized day of benches/pipeline_scale.sh:
3.2 M points in 720 minutes).
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python"))


def peak_kb():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    return 0


def reset_peak():
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def child(points, out):
    """Runs the pipeline stage by stage; prints one JSON line per stage."""
    import trajdb

    con = trajdb.connect()
    n = con.execute("SELECT count(*) FROM read_parquet(?)", [points]).fetchall()[0][0]
    rows = con.execute("SELECT stage, sql, undo FROM trajdb_stages(?, out_dir := ?) ORDER BY k", [points, out]).fetchall()
    stages = []
    for stage, sql, _ in rows:
        if not stages or stages[-1][0] != stage:
            stages.append((stage, []))
        stages[-1][1].append(sql)
    res = []
    for stage, sqls in stages:
        reset_peak()
        t = time.perf_counter()
        for sql in sqls:
            con.execute(sql)
        res.append({"stage": stage, "s": time.perf_counter() - t, "peak_mb": peak_kb() / 1024})
    users = con.execute("SELECT count(*) FROM merged").fetchall()[0][0]
    print(json.dumps({"points": n, "road_users": users, "stages": res}))


def simulate(out, minutes, traffic, seed):
    """A scenario of `trajdb simulate` (3 cameras, 5 Hz), with the simulator's memory limit raised
    for the large ones (its default, 4 GB, refuses 16x the traffic of a day). The simulator makes
    at most a day (1,440 minutes): longer recordings repeat one simulated span of the same site
    (same seed, so the same cameras and clocks) back to back, each repeat's times shifted by the
    span and its track ids by the largest id + 1."""
    if os.path.exists(os.path.join(out, "points.parquet")):
        return
    import trajdb

    con = trajdb.connect()
    con.execute("CALL trajdb_set_limit('memory_bytes', 20000000000)").fetchall()
    if minutes <= 1440:
        trajdb.simulate(con, out, cameras=3, minutes=float(minutes), traffic=float(traffic), rate_hz=5.0, seed=seed, world_rate_hz=0.0)
    else:
        parts = math.ceil(minutes / 1440)
        span = minutes / parts
        one = out + ".part"
        simulate(one, span, traffic, seed)
        os.makedirs(out, exist_ok=True)
        src = os.path.join(one, "points.parquet")
        con.execute("""COPY (SELECT p.* REPLACE (p.t + k * ? AS t, p.track_id + k * (m.top + 1) AS track_id)
                             FROM read_parquet(?) p, range(?) r(k), (SELECT max(track_id) AS top FROM read_parquet(?)) m)
                       TO ? (FORMAT parquet)""", [span * 60.0, src, parts, src, os.path.join(out, "points.parquet")])
    con.close()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--base-minutes", type=float, default=720)
    ap.add_argument("--traffic", type=float, default=1.4)
    ap.add_argument("--factors", default="1,4,16")
    ap.add_argument("--ways", default="hours,density")
    ap.add_argument("--work", default=os.path.join(os.environ.get("TMPDIR", "/tmp"), "trajdb-series"))
    ap.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        return child(*a.child)
    os.environ.setdefault("TRAJDB_EXTENSION", os.path.join(ROOT, "trajdb.duckdb_extension"))
    os.environ["PYTHONPATH"] = os.path.join(ROOT, "python") + os.pathsep + os.environ.get("PYTHONPATH", "")
    py = sys.executable
    factors = [int(f) for f in a.factors.split(",")]
    import duckdb

    print(f"duckdb {duckdb.__version__}, {os.cpu_count()} cores; base: 3 cameras, 5 Hz, {a.base_minutes:g} min, traffic {a.traffic:g}")
    for way in a.ways.split(","):
        runs = {}
        for f in factors:
            minutes, traffic = (a.base_minutes * f, a.traffic) if way == "hours" else (a.base_minutes, a.traffic * f)
            d = os.path.join(a.work, f"{way}-{f}")
            simulate(d, minutes, traffic, 42)
            out = os.path.join(a.work, f"{way}-{f}.results")
            shutil.rmtree(out, ignore_errors=True)
            r = subprocess.run([py, os.path.abspath(__file__), "--child", os.path.join(d, "points.parquet"), out],
                               capture_output=True, text=True, env=os.environ)
            if r.returncode != 0:
                print(f"{way} x{f}: failed: {r.stderr.strip()[-500:]}", flush=True)
                continue
            runs[f] = json.loads(r.stdout.strip().splitlines()[-1])
            tot = sum(s["s"] for s in runs[f]["stages"])
            print(f"{way} x{f}: {runs[f]['points']:,} points, {runs[f]['road_users']:,} road users, {tot:.1f} s, "
                  f"{runs[f]['points'] / tot:,.0f} points/s, peak {max(s['peak_mb'] for s in runs[f]['stages']):,.0f} MB", flush=True)
        if len(runs) < 2:
            continue
        fs = sorted(runs)
        lo, hi = fs[0], fs[-1]
        ratio = runs[hi]["points"] / runs[lo]["points"]
        print(f"\n{way}: seconds (points/s) per stage; e = growth exponent x{lo} -> x{hi} (points x{ratio:.1f}); peak MB")
        print(f"{'stage':10s}" + "".join(f"{'x' + str(f):>22s}" for f in fs) + f"{'e':>7s}" + "".join(f"{'MB x' + str(f):>10s}" for f in fs))
        names = [s["stage"] for s in runs[lo]["stages"]]
        for k, name in enumerate(names):
            cells, secs = "", {}
            for f in fs:
                s = runs[f]["stages"][k]
                secs[f] = s["s"]
                cells += f"{s['s']:9.2f} s ({runs[f]['points'] / max(s['s'], 1e-9):>9,.0f})"
            e = math.log(max(secs[hi], 1e-3) / max(secs[lo], 1e-3)) / math.log(ratio) if secs[lo] > 0.2 else float("nan")
            flag = "  <- faster than n log n" if e == e and e > 1.25 else ""
            mem = "".join(f"{runs[f]['stages'][k]['peak_mb']:10,.0f}" for f in fs)
            print(f"{name:10s}{cells}{e:7.2f}{mem}{flag}")
        print()


if __name__ == "__main__":
    main()
