"""trajdb.spark in Spark local mode against `trajdb pipeline` on each whole site.

    python tests/test_spark.py trajdb.duckdb_extension

A simulated archive of three sites (3 cameras with clock offsets; 1 camera; 2 cameras at 5 Hz
with a 6-minute hole in the recording) is shuffled and split into 60-second windows. The
Spark results must equal trajdb.pipeline's on each whole site: the same road users (by their
source tracks), the same matches, transforms and merged trajectories within 1e-9. Covered:
road users that cross a window seam, windows without road users, a one-camera site, unsorted
input, every window and write task failing once and retried by Spark (TRAJDB_SPARK_FAIL_ONCE),
a halo too short on purpose (halo_s=0: the windows ask for more and run again), and the
"### Spark example" of docs/spark.md as it stands.
"""
import glob
import json
import os
import re
import subprocess
import sys
import tempfile
import warnings

import duckdb
import pyarrow as pa
import pyarrow.dataset as ds
import pyarrow.parquet as pq

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
EXT = os.path.abspath(sys.argv[1])
os.environ["TRAJDB_EXTENSION"] = EXT  # trajdb.connect() in this process: the reference runs
import trajdb  # noqa: E402
from trajdb import spark as tspark  # noqa: E402
from trajdb import windows as W  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
TOL = 1e-9


def simulate(tmp):
    """The archive: one Parquet file with a site column, rows shuffled."""
    runs = {"a": [dict(cameras=3, minutes=6, clock_offset_max=0.5, seed=11)],
            "b": [dict(cameras=1, minutes=3, seed=12)],
            "c": [dict(cameras=2, minutes=3, rate_hz=5.0, seed=13),
                  dict(cameras=2, minutes=2, rate_hz=5.0, seed=14)]}
    con = duckdb.connect()
    parts = []
    for site, sims in runs.items():
        for i, args in enumerate(sims):
            d = os.path.join(tmp, f"sim-{site}-{i}")
            trajdb.simulate(trajdb.connect(), d, world_rate_hz=0, **args)
            # the second recording of site c: 9 minutes later, other track ids (a hole of 6 min)
            parts.append(f"SELECT '{site}' AS site, camera, track_id + {i * 1000000} AS track_id, class, t + {i * 540.0} AS t, x, y, estimated "
                         f"FROM '{d}/points.parquet'")
    archive = os.path.join(tmp, "archive.parquet")
    con.execute(f"COPY (SELECT * FROM ({' UNION ALL '.join(parts)}) ORDER BY hash(site, camera, track_id, t)) TO '{archive}'")
    for site in runs:
        con.execute(f"COPY (SELECT * EXCLUDE (site) FROM '{archive}' WHERE site = '{site}') TO '{tmp}/site-{site}.parquet'")
    return archive, list(runs)


def reference(tmp, site):
    out = os.path.join(tmp, f"ref-{site}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # site b has one camera: a warning, and results
        trajdb.pipeline(trajdb.connect(), f"{tmp}/site-{site}.parquet", out=out)
    con = duckdb.connect()
    ru = {frozenset((s["camera"], s["track_id"]) for s in r[0]): r[1:] for r in
          con.sql(f"SELECT sources, class, t_start, t_end, length_m, traj FROM '{out}/merged.parquet'").fetchall()}
    ma = {r[:5]: r[5] for r in con.sql(f"SELECT camera_a, track_a, camera_b, track_b, kind, score FROM read_csv('{out}/matches.csv')").fetchall()}
    tf = {r[:2]: r[2:] for r in con.sql(f"SELECT cam_from, cam_to, theta_rad, tx, ty, clock_offset_s FROM read_csv('{out}/transforms.csv')").fetchall()}
    geo = pq.read_schema(f"{out}/merged.parquet").metadata[b"geo"]
    return ru, ma, tf, geo


def close(a, b):
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(close(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(close(a[k], b[k]) for k in a)
    if isinstance(a, float) or isinstance(b, float):
        return a is not None and b is not None and abs(a - b) <= TOL * max(1.0, abs(a), abs(b))
    return a == b


def compare(res, refs, label):
    ru_rows = res.road_users.collect()
    keys = [(r["site"], r["road_user"]) for r in ru_rows]
    assert len(keys) == len(set(keys)), f"{label}: a road user appears twice"
    for site, (ru, ma, tf, _) in refs.items():
        got = {frozenset((s["camera"], s["track_id"]) for s in r["sources"]): r for r in ru_rows if r["site"] == site}
        assert len(got) == sum(1 for r in ru_rows if r["site"] == site), f"{label}: site {site}: two road users share a track"
        assert got.keys() == ru.keys(), (
            f"{label}: site {site}: road users differ: {len(got.keys() - ru.keys())} only in Spark, {len(ru.keys() - got.keys())} only in trajdb.pipeline"
        )
        for k, (cls, t0, t1, length, traj) in ru.items():
            r = got[k]
            assert r["class"] == cls and close([r["t_start"], r["t_end"], r["length_m"]], [t0, t1, length]), f"{label}: site {site}: road user {sorted(k)}"
            assert close([(p["t"], p["x"], p["y"]) for p in r["traj"]], [(p["t"], p["x"], p["y"]) for p in traj]), f"{label}: {site} traj {sorted(k)}"
        gm = {(r["camera_a"], r["track_a"], r["camera_b"], r["track_b"], r["kind"]): r["score"]
              for r in res.matches.where(f"site = '{site}'").collect()}
        assert gm.keys() == ma.keys(), f"{label}: site {site}: matches differ: {sorted(gm.keys() ^ ma.keys())[:5]}"
        assert all(close(gm[k], ma[k]) for k in ma), f"{label}: site {site}: match scores differ"
        gt = {(r["cam_from"], r["cam_to"]): (r["theta_rad"], r["tx"], r["ty"], r["clock_offset_s"])
              for r in res.transforms.where(f"site = '{site}'").collect()}
        assert gt.keys() == tf.keys() and all(close(list(gt[k]), list(tf[k])) for k in tf), f"{label}: site {site}: transforms differ"
    return ru_rows


def check_site_tables():
    """The site tables the extension's manifest names (trajdb_stages' `shared`; every one of them
    is made by a site statement: crates/app/src/plan.rs tests) are what a window receives."""
    con = W.connect(W._default_extension())
    names = W.site_table_names(con)
    assert "align_frames" in names and "view_overlaps" in names, names
    made = {r[0] for r in con.execute("SELECT makes FROM trajdb_stages('x', part := 'window') WHERE makes IS NOT NULL").fetchall()}
    assert not (set(names) & made), f"a window remakes site tables: {sorted(set(names) & made)}"


def main():
    check_site_tables()
    tmp = tempfile.mkdtemp(prefix="trajdb-spark-test-")
    archive, sites = simulate(tmp)
    refs = {s: reference(tmp, s) for s in sites}
    assert len(refs["b"][0]) > 0, "the one-camera site has road users in trajdb.pipeline"
    os.environ.setdefault("PYSPARK_PYTHON", sys.executable)
    from pyspark.sql import SparkSession

    # every window and write task fails once; Spark retries it (set before Spark starts: the
    # Python workers inherit the JVM's environment)
    fail_dir = os.path.join(tmp, "fail-once")
    os.makedirs(fail_dir)
    os.environ["TRAJDB_SPARK_FAIL_ONCE"] = fail_dir
    spark = (SparkSession.builder.master("local[2,3]").appName("trajdb-test")  # 3 attempts per task
             .config("spark.ui.enabled", "false").config("spark.ui.showConsoleProgress", "false")
             .config("spark.sql.shuffle.partitions", "8").getOrCreate())
    spark.sparkContext.setLogLevel("ERROR")
    points = spark.read.parquet(archive).repartition(5)  # unsorted, and spread over partitions

    # 1. 60 s windows
    res = tspark.pipeline(points, window_s=60, extension=EXT)
    ru_rows = compare(res, refs, "60 s windows")
    wins = res.windows.collect()
    last = {}
    for w in wins:  # every window's last round held all its road users' components
        if w["round"] > last.get((w["site"], w["window"]), (0, None))[0]:
            last[(w["site"], w["window"])] = (w["round"], w["complete"])
    assert all(c for _, c in last.values()), sorted(k for k, v in last.items() if not v[1])
    reran60 = sum(1 for w in wins if w["round"] > 1)
    out = os.path.join(tmp, "out")
    tspark.write(res, out)
    injected = os.listdir(fail_dir)
    assert any(f.startswith("window-") for f in injected) and any(f.startswith("write-") for f in injected), injected

    # a road user across a seam came out once, from the window of its first observation
    seam = [r for r in ru_rows if r["site"] == "a" and int(r["t_start"] // 60) != int(r["t_end"] // 60)]
    assert seam, "no road user crosses a window seam"
    # site c's hole: windows 3..8 hold no first observation, so no task ran for them
    ran = {w["window"] for w in wins if w["site"] == "c"}
    assert not ran & set(range(4, 8)), sorted(ran)

    # the written files: one per partition, no duplicates after the retries, GeoParquet road users
    for name in ("road_users", "matches", "transforms", "calibration"):
        files = [f for f in glob.glob(f"{out}/{name}/**/*", recursive=True) if os.path.isfile(f)]
        assert files and all(os.path.basename(f) == "part-0.parquet" for f in files), files
    assert os.path.exists(f"{out}/_SUCCESS")
    back = ds.dataset(f"{out}/road_users", format="parquet", partitioning="hive").to_table()
    assert back.num_rows == len(ru_rows), (back.num_rows, len(ru_rows))
    keys = list(zip(back.column("site").to_pylist(), back.column("road_user").to_pylist()))
    assert len(keys) == len(set(keys))
    for f in glob.glob(f"{out}/road_users/site=*/date=*/part-0.parquet"):
        assert json.loads(pq.read_schema(f).metadata[b"geo"]) == json.loads(refs["a"][3]), f
    back_m = ds.dataset(f"{out}/matches", format="parquet", partitioning="hive").to_table()
    assert back_m.num_rows == res.matches.count()

    # 2. a halo too short on purpose: windows ask for the halo they need and run again
    res0 = tspark.pipeline(points, window_s=30, halo_s=0, extension=EXT)
    compare(res0, refs, "30 s windows, halo 0")
    rounds = res0.windows.where("NOT complete").count()
    assert rounds > 0, "halo 0 should have needed a second round"

    # 3. a window without road users, run directly: nothing kept, complete
    site_pts = pa.Table.from_batches(duckdb.sql(f"SELECT camera, track_id, class, t, x, y, estimated FROM '{tmp}/site-a.parquet'").to_arrow_reader())
    cal = W.calibrate_site(site_pts, extension=EXT)
    o = W.run_window(site_pts, cal, 5000.0, 5060.0, 4990.0, 5070.0, extension=EXT)
    assert o["road_users"].num_rows == 0 and o["matches"].num_rows == 0 and o["status"].to_pylist()[0]["complete"]

    # 4. trajdb.spark.archive equals trajdb archive on one machine, file for file (issue 40): two
    #    sites, two days each, a camera moved on the second day of one (the chain of
    #    calibrations, a day run again), every archive task failing once and retried by Spark
    from trajdb import lake_sim

    lake = os.path.join(tmp, "lake")
    lake_sim.simulate_lake(trajdb.connect(), lake, sites=2, days=2, minutes=3, viewpoint_bias_vehicle=1.0, ground_plane_scale=0.01,
                           move={"site": "s2", "day": 1, "camera": 0, "dx": 0.0, "dy": 0.0, "deg": 3.0})
    on_spark, local = os.path.join(tmp, "archive-spark"), os.path.join(tmp, "archive-local")
    rs = tspark.archive(spark, lake, on_spark, extension=EXT, progress=False)
    rl = trajdb.archive(trajdb.connect(), lake, local)
    assert rs["failed"] == rl["failed"] == 0 and rs["done"] == rl["done"] == 4, (rs, rl)
    assert [c["date"] for c in rs["changes"]] == [c["date"] for c in rl["changes"]] == [lake_sim.day_name(1)], (rs["changes"], rl["changes"])
    assert any(f.startswith("archive-") for f in os.listdir(fail_dir))

    def tree(d):
        skip = {"_state/runs.csv", "_state/lock", ".trajdb-archive"}
        return {os.path.relpath(p, d): open(p, "rb").read() for p in glob.glob(f"{d}/**", recursive=True)
                if os.path.isfile(p) and os.path.relpath(p, d) not in skip}
    ts, tl = tree(on_spark), tree(local)
    assert ts.keys() == tl.keys(), sorted(set(ts) ^ set(tl))
    assert [f for f in ts if ts[f] != tl[f]] == [], [f for f in ts if ts[f] != tl[f]]
    n_archive = len(ts)
    # a site-day whose task fails every attempt fails alone: the round's other site-days are done
    bad = f"s1-{lake_sim.day_name(1)}"
    open(os.path.join(fail_dir, f"always-archive-{bad}"), "w").close()
    rb = tspark.archive(spark, lake, os.path.join(tmp, "archive-spark-bad"), extension=EXT, progress=False)
    os.remove(os.path.join(fail_dir, f"always-archive-{bad}"))
    assert rb["failed"] == 1 and rb["failed_partitions"] == [f"site=s1/date={lake_sim.day_name(1)}"] and rb["done"] == 4, rb
    tb = tree(os.path.join(tmp, "archive-spark-bad"))
    assert not any(f"site=s1/date={lake_sim.day_name(1)}" in f for f in tb), sorted(tb)
    assert all(tb[f] == ts[f] for f in tb if f.startswith(("road_users/", "matches/"))), "the other site-days differ"

    spark.stop()

    # 5. docs/spark.md's "### Spark example", as it stands, in its own process and folder
    with open(os.path.join(ROOT, "docs", "spark.md")) as f:
        text = f.read()
    m = re.compile(r"```python\n(.*?)```", re.S).search(text, text.index("### Spark example\n"))
    demo = os.path.join(tmp, "readme")
    os.makedirs(demo)
    env = {k: v for k, v in os.environ.items() if k != "TRAJDB_SPARK_FAIL_ONCE"}
    env.update(PYTHONPATH=os.path.join(ROOT, "python"), TRAJDB_EXTENSION=EXT, PYSPARK_PYTHON=sys.executable)
    r = subprocess.run([sys.executable, "-c", m.group(1)], cwd=demo, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-4000:]
    assert os.path.exists(f"{demo}/spark-demo/results/_SUCCESS") and glob.glob(f"{demo}/spark-demo/results/road_users/site=north/date=1970-01-01/part-0.parquet")
    assert "pedestrian" in r.stdout, r.stdout[-2000:]

    n = {s: len(refs[s][0]) for s in sites}
    print(f"test_spark: OK: road users per site {n}, {len(seam)} across a seam, {len(wins)} window tasks, "
          f"{len(injected)} injected task failures retried, {reran60} windows rerun at 60 s, {rounds} windows rerun with a wider halo (halo_s=0); "
          f"archive on Spark = on one machine, {n_archive} files byte for byte, a site-day failing every attempt failed alone")


if __name__ == "__main__":
    main()
