#!/usr/bin/env python3
"""Metamorphic tests of the pipeline (issue 26, part 1): the road users (their sets of source
tracks) must be identical when
- every camera's frame is moved far from the origin (+1e6 m; UTM-sized x ~ 4.6e5, y ~ 5.7e6),
- one camera's frame is rotated by 57 degrees and moved by hundreds of km,
- every clock is shifted by a Unix epoch (2026), or one camera's clock by 0.7 s or -3.6 s
  (beyond the first +-1 s search: align.sql widens the search for such pairs),
on a simulated scene and on the shared scenes from real trajectories (when ../shared/data is
beside the clone). Before align.sql voted about each camera's centroid, frames in UTM aligned no
camera at all.

usage: python3 tests/test_invariance_python.py path/to/trajdb.duckdb_extension
"""
import os
import sys
import tempfile
import warnings

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "python"))
os.environ["TRAJDB_EXTENSION"] = os.path.abspath(sys.argv[1])

import trajdb  # noqa: E402

CHANGES = [
    ("every frame +1e6 m", "SELECT * REPLACE (x + 1e6 AS x, y + 1e6 AS y) FROM base"),
    ("UTM-sized frames", "SELECT * REPLACE (x + 4.6e5 + camera * 2000 AS x, y + 5.71e6 - camera * 500 AS y) FROM base"),
    ("one frame rotated 57 deg and moved 360 km",
     "SELECT * REPLACE (CASE WHEN camera = (SELECT max(camera) FROM base) THEN x * cos(1.0) - y * sin(1.0) + 3e5 ELSE x END AS x, "
     "CASE WHEN camera = (SELECT max(camera) FROM base) THEN x * sin(1.0) + y * cos(1.0) - 2e5 ELSE y END AS y) FROM base"),
    ("every clock + a 2026 epoch", "SELECT * REPLACE (t + 1.79e9 AS t) FROM base"),
    ("one clock +0.7 s", "SELECT * REPLACE (CASE WHEN camera = (SELECT max(camera) FROM base) THEN t + 0.7 ELSE t END AS t) FROM base"),
    ("one clock -3.6 s (beyond the first search range)", "SELECT * REPLACE (CASE WHEN camera = (SELECT max(camera) FROM base) THEN t - 3.6 ELSE t END AS t) FROM base"),
]


def users(con):
    return {frozenset((s["camera"], s["track_id"]) for s in r[0]) for r in con.sql("SELECT sources FROM merged").fetchall()}


def main():
    warnings.simplefilter("ignore")
    failed = []
    w = tempfile.mkdtemp(prefix="trajdb-invariance-")
    scenes = []
    con = trajdb.connect()
    trajdb.simulate(con, os.path.join(w, "sim"), cameras=3, minutes=2, seed=5)
    scenes.append(("simulated", os.path.join(w, "sim", "points.parquet")))
    shared = os.path.join(HERE, "..", "..", "shared", "data")
    for sc in ("dut_intersection_3cam", "dut_roundabout_2cam"):
        if os.path.exists(os.path.join(shared, sc, "points.parquet")):
            scenes.append((sc, os.path.join(shared, sc, "points.parquet")))
    for name, path in scenes:
        con = trajdb.connect()
        con.execute("CREATE TABLE base AS FROM read_parquet(?)", [path])
        trajdb.pipeline(con, "base")
        base, cams = users(con), con.sql("SELECT count(*) FROM align_frames").fetchall()[0][0]
        for change, q in CHANGES:
            con.execute(f"CREATE OR REPLACE TABLE v AS {q}")
            trajdb.pipeline(con, "v")
            got = users(con)
            ok = got == base and con.sql("SELECT count(*) FROM align_frames").fetchall()[0][0] == cams
            print(("ok   " if ok else "FAIL ") + f"{name}: {change}: {len(got)} road users" + ("" if ok else f", {len(got ^ base)} differ from the {len(base)} of the original"))
            if not ok:
                failed.append(f"{name}: {change}")
    if failed:
        print(f"test_invariance_python: {len(failed)} FAILED: {failed}")
        sys.exit(1)
    print("test_invariance_python: OK")


if __name__ == "__main__":
    main()
