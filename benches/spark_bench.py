"""trajdb.spark benchmark: N simulated sites x 1 day, in Spark local mode with 1 and 2 executor
cores, against N sequential `trajdb pipeline` runs (the command, python -m trajdb over stock
DuckDB and the same extension, all cores), in one run.

    PY=$(scripts/install_spark.sh)
    $PY benches/spark_bench.py --extension trajdb.duckdb_extension [--sites 8 --minutes 1440 --window-s 3600 --out /tmp/trajdb-spark-bench]

Prints, per run: wall time, points per second, speed-up over the sequential runs, and peak
memory: of the Python workers that run the tasks (getrusage's ru_maxrss at the end of each
task: a worker is reused across tasks, so the largest value bounds every task's peak), of the
JVM (driver and executor in local mode), and of each sequential run. Spark calibrates each
site on its first --calibrate-s seconds (default one hour: a year's archive calibrates on one
day, so calibration is a small share there; here it would double the work if it used the whole
day). The road users found are compared with the sequential runs' counts.
"""
import argparse
import datetime
import json
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DAY0 = datetime.datetime(2026, 11, 2, tzinfo=datetime.timezone.utc).timestamp()  # t is epoch seconds


def run_child(args, **kw):
    """Runs a command; returns (seconds, peak RSS in MB) of that child (os.wait4)."""
    t = time.perf_counter()
    p = subprocess.Popen(args, **kw)
    _, status, ru = os.wait4(p.pid, 0)
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode != 0:
        raise RuntimeError(f"{args[:2]} failed with status {p.returncode}")
    return time.perf_counter() - t, ru.ru_maxrss / 1024.0


def trajdb_cmd(a, *args):
    """`python -m trajdb ARGS` with this repository's package and a.extension: (argv, env)."""
    env = dict(os.environ, TRAJDB_EXTENSION=a.extension, PYTHONPATH=os.path.join(ROOT, "python"))
    return [sys.executable, "-m", "trajdb", *args], env


def make_archive(a):
    import duckdb

    os.makedirs(a.out, exist_ok=True)
    archive = os.path.join(a.out, "archive.parquet")
    sites = [f"site{i + 1:02d}" for i in range(a.sites)]
    if not os.path.exists(archive):
        parts = []
        for i, s in enumerate(sites):
            d = os.path.join(a.out, "sim", s)
            if not os.path.exists(os.path.join(d, "points.parquet")):
                # Skövde-sized traffic (the simulator's default volume), 3 cameras with clock offsets
                cmd, env = trajdb_cmd(a, "simulate", "--out", d, "--cameras", "3", "--minutes", str(a.minutes), "--seed", str(i + 1),
                                      "--clock-offset-max", "0.5", "--world-rate-hz", "0")
                run_child(cmd, env=env, stdout=subprocess.DEVNULL)
            parts.append(f"SELECT '{s}' AS site, camera, track_id, class, t + {DAY0} AS t, x, y, estimated FROM '{d}/points.parquet'")
        con = duckdb.connect()
        con.execute(f"COPY ({' UNION ALL '.join(parts)}) TO '{archive}' (FORMAT parquet, ROW_GROUP_SIZE 1000000)")
        for s in sites:
            con.execute(f"COPY (SELECT * EXCLUDE (site) FROM '{archive}' WHERE site = '{s}') TO '{a.out}/{s}.parquet'")
    import duckdb

    n = duckdb.sql(f"SELECT count(*) FROM '{archive}'").fetchall()[0][0]
    return archive, sites, n


def sequential(a, sites):
    out, total, peak = {}, 0.0, 0.0
    for s in sites:
        cmd, env = trajdb_cmd(a, "pipeline", "--input", f"{a.out}/{s}.parquet", "--out", f"{a.out}/seq/{s}")
        sec, rss = run_child(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        import duckdb

        out[s] = duckdb.sql(f"SELECT count(*) FROM '{a.out}/seq/{s}/merged.parquet'").fetchall()[0][0]
        total += sec
        peak = max(peak, rss)
        print(f"  sequential {s}: {sec:.1f} s, peak RSS {rss:.0f} MB, {out[s]} road users", flush=True)
    return total, peak, out


def spark_run(a, cores):
    """In a child process (one JVM per core count): prints a JSON line of figures."""
    os.environ.setdefault("PYSPARK_PYTHON", sys.executable)
    sys.path.insert(0, os.path.join(ROOT, "python"))
    from pyspark.sql import SparkSession

    from trajdb import spark as tspark

    spark = (SparkSession.builder.master(f"local[{cores}]").appName(f"trajdb-bench-{cores}")
             .config("spark.ui.enabled", "false").config("spark.driver.memory", "6g")
             .config("spark.sql.shuffle.partitions", str(max(8, 4 * cores))).getOrCreate())
    spark.sparkContext.setLogLevel("ERROR")
    points = spark.read.parquet(os.path.join(a.out, "archive.parquet"))
    t = time.perf_counter()
    res = tspark.pipeline(points, window_s=a.window_s, calibrate_s=a.calibrate_s, extension=a.extension)
    wins = res.windows.collect()  # the rounds ran inside pipeline(); this reads the cache
    t_pipe = time.perf_counter() - t
    tspark.write(res, os.path.join(a.out, f"spark{cores}"))
    wall = time.perf_counter() - t
    per_site = {r["site"]: r["count"] for r in res.road_users.groupBy("site").count().collect()}
    jvm_peak = 0.0  # the JVM this process started (local mode: driver and executor in one)
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/stat") as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
            if ppid == os.getpid():
                with open(f"/proc/{pid}/status") as f:
                    for line in f:
                        if line.startswith("VmHWM:"):
                            jvm_peak = max(jvm_peak, int(line.split()[1]) / 1024.0)
        except (OSError, ValueError, IndexError):
            pass
    last = [w for w in wins if w["complete"]]
    print("RESULT " + json.dumps({
        "cores": cores, "wall_s": wall, "pipeline_s": t_pipe, "write_s": wall - t_pipe,
        "windows": len(last), "reruns": sum(1 for w in wins if w["round"] > 1),
        "task_peak_rss_mb_max": max(w["peak_rss_mb"] for w in wins), "task_peak_rss_mb_median": sorted(w["peak_rss_mb"] for w in wins)[len(wins) // 2],
        "task_seconds_median": sorted(w["seconds"] for w in wins)[len(wins) // 2], "task_seconds_max": max(w["seconds"] for w in wins),
        "jvm_peak_rss_mb": jvm_peak, "road_users": per_site,
    }), flush=True)
    spark.stop()


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--extension", required=True)
    p.add_argument("--sites", type=int, default=8)
    p.add_argument("--minutes", type=int, default=1440)
    p.add_argument("--window-s", type=float, default=3600.0)
    p.add_argument("--calibrate-s", type=float, default=3600.0)
    p.add_argument("--cores", default="1,2")
    p.add_argument("--out", default="/tmp/trajdb-spark-bench")
    p.add_argument("--spark-child", type=int, default=0)
    a = p.parse_args()
    a.extension, a.out = os.path.abspath(a.extension), os.path.abspath(a.out)
    if a.spark_child:
        return spark_run(a, a.spark_child)
    t = time.perf_counter()
    archive, sites, n = make_archive(a)
    print(f"archive: {len(sites)} sites x {a.minutes} min, {n:,} points ({time.perf_counter() - t:.0f} s to simulate)", flush=True)
    seq_s, seq_peak, seq_ru = sequential(a, sites)
    print(f"sequential trajdb pipeline x {len(sites)}: {seq_s:.1f} s, {n / seq_s:,.0f} points/s, peak RSS {seq_peak:.0f} MB", flush=True)
    for cores in [int(c) for c in a.cores.split(",")]:
        out = subprocess.run([sys.executable, __file__, "--spark-child", str(cores)] + sys.argv[1:], capture_output=True, text=True)
        line = [x for x in out.stdout.splitlines() if x.startswith("RESULT ")]
        if out.returncode != 0 or not line:
            print(out.stderr[-3000:], file=sys.stderr)
            raise SystemExit(f"spark run with {cores} cores failed")
        r = json.loads(line[0][len("RESULT "):])
        diff = {s: r["road_users"].get(s, 0) - seq_ru[s] for s in sites}
        print(f"spark local[{cores}]: {r['wall_s']:.1f} s ({r['pipeline_s']:.1f} s pipeline + {r['write_s']:.1f} s write), "
              f"{n / r['wall_s']:,.0f} points/s, {seq_s / r['wall_s']:.2f}x the sequential runs; {r['windows']} windows, "
              f"{r['reruns']} reruns; task: median {r['task_seconds_median']:.1f} s, max {r['task_seconds_max']:.1f} s, "
              f"peak RSS median {r['task_peak_rss_mb_median']:.0f} MB, max {r['task_peak_rss_mb_max']:.0f} MB; JVM peak RSS {r['jvm_peak_rss_mb']:.0f} MB; "
              f"road users minus sequential per site: {diff}", flush=True)


if __name__ == "__main__":
    main()
