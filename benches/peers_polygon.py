#!/usr/bin/env python3
"""trajdb's polygon family against its peers, in one process on the same data:
DuckDB spatial (ST_* via GEOS, duckdb-extension-spatial) and shapely (GEOS, vectorised numpy).

DuckDB spatial is on PyPI only for DuckDB 1.5.x, so this runs in DuckDB 1.5.5, which loads the
same trajdb.duckdb_extension (stable C API v1.2.0). Data: the real points of
../shared/data/dut_intersection_3cam (camera 1, local frame), repeated to N points.

Tasks
  hull       view polygon of all points of one camera (convex; concave with each tool's knob)
  pip        point-in-polygon of every point against a ~50-vertex polygon (camera 1's concave
             view polygon, simplified)
  overlap    intersection of camera 1's concave view polygon with a shifted copy, 200 times
             (the per-class overlaps)

usage: python benches/peers_polygon.py --ext trajdb.duckdb_extension [--n 2000000]
       (venv: pip install -r requirements-spatial.txt shapely numpy)
"""
import argparse
import glob
import os
import time

import duckdb
import duckdb_extension_spatial
import numpy as np
import shapely

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "shared", "data", "dut_intersection_3cam", "points.parquet")


def timed(f, reps=3):
    best, out = float("inf"), None
    for _ in range(reps):
        t0 = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ext", required=True)
    ap.add_argument("--n", type=int, default=2_000_000)
    ap.add_argument("--threads", type=int, default=0, help="DuckDB threads (0 = all cores)")
    a = ap.parse_args()
    spatial = glob.glob(os.path.join(os.path.dirname(duckdb_extension_spatial.__file__), "extensions", "*", "spatial.duckdb_extension"))[0]
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    if a.threads:
        con.execute(f"SET threads = {a.threads}")
    con.execute(f"LOAD '{spatial}'")
    con.execute(f"LOAD '{os.path.abspath(a.ext)}'")
    threads = con.execute("SELECT current_setting('threads')").fetchone()[0]
    print(f"duckdb {duckdb.__version__} ({threads} threads), shapely {shapely.__version__} (GEOS {shapely.geos_version_string}), numpy {np.__version__}")
    con.execute(f"CREATE TABLE src AS SELECT camera, x, y FROM read_parquet('{os.path.abspath(DATA)}') WHERE estimated = 0")
    # Repeat camera 1's points (jittered deterministically) up to N.
    n1 = con.execute("SELECT count(*) FROM src WHERE camera = 1").fetchone()[0]
    reps = max(1, a.n // n1)
    con.execute(f"""CREATE TABLE pts AS
        SELECT x + 0.01 * (r % 7) AS x, y - 0.01 * (r % 5) AS y
        FROM src, range({reps}) t(r) WHERE camera = 1""")
    con.execute("CREATE TABLE pts_geom AS SELECT ST_Point(x, y) AS g, x, y FROM pts")
    xy = con.execute("SELECT x, y FROM pts").fetchnumpy()
    x, y = xy["x"], xy["y"]
    n = len(x)
    print(f"{n} points")
    rows = []

    # ---- hull
    t_tr, _ = timed(lambda: con.execute("SELECT polygon_area(view_polygon(list({'x': x, 'y': y}), 'convex')) FROM pts").fetchone())
    t_sp, _ = timed(lambda: con.execute("SELECT ST_Area(ST_ConvexHull(ST_Collect(list(g)))) FROM pts_geom").fetchone())
    t_sh, _ = timed(lambda: shapely.convex_hull(shapely.multipoints(np.column_stack([x, y]))).area)
    rows.append(("convex hull", n, t_tr, t_sp, t_sh))
    m = min(n, 200_000)
    con.execute(f"CREATE TABLE small AS SELECT * FROM pts_geom LIMIT {m}")
    t_tr, _ = timed(lambda: con.execute("SELECT polygon_area(view_polygon(list({'x': x, 'y': y}), 'concave', 2.0)) FROM small").fetchone(), 1)
    t_sp, _ = timed(lambda: con.execute("SELECT ST_Area(ST_ConcaveHull(ST_Collect(list(g)), 0.1, false)) FROM small").fetchone(), 1)
    sx, sy = x[:m], y[:m]
    t_sh, _ = timed(lambda: shapely.concave_hull(shapely.multipoints(np.column_stack([sx, sy])), ratio=0.1).area, 1)
    rows.append(("concave hull", m, t_tr, t_sp, t_sh))

    # ---- point in polygon against a 50-vertex polygon
    wkt = con.execute("""
        WITH v AS (SELECT view_polygon(list({'x': x, 'y': y}), 'concave', 2.0) AS p FROM src WHERE camera = 1)
        SELECT ST_AsText(ST_SimplifyPreserveTopology(ST_GeomFromWKB(p), 0.4)) FROM v""").fetchone()[0]
    poly = shapely.from_wkt(wkt)
    nv = len(poly.exterior.coords) if poly.geom_type == "Polygon" else sum(len(g.exterior.coords) for g in poly.geoms)
    con.execute(f"CREATE TABLE poly AS SELECT '{wkt}' AS w, ST_GeomFromText('{wkt}') AS g")
    t_tr, c_tr = timed(lambda: con.execute("SELECT count(*) FILTER (WHERE polygon_contains(poly.w, x, y)) FROM pts, poly").fetchone()[0])
    t_sp, c_sp = timed(lambda: con.execute("SELECT count(*) FILTER (WHERE ST_Intersects(poly.g, pts_geom.g)) FROM pts_geom, poly").fetchone()[0])

    def sh_pip():
        shapely.prepare(poly)
        return int(shapely.intersects_xy(poly, x, y).sum())

    t_sh, c_sh = timed(sh_pip)
    assert c_tr == c_sp == c_sh, (c_tr, c_sp, c_sh)
    rows.append((f"point in polygon ({nv} vertices), {c_tr} inside", n, t_tr, t_sp, t_sh))

    # ---- overlaps
    # 200 different shifted copies, so that no engine can evaluate one constant row once.
    k = 200
    con.execute(f"""CREATE TABLE hulls AS
                   WITH h AS (SELECT view_polygon(list({{'x': x, 'y': y}}), 'concave', 2.0) AS p FROM src WHERE camera = 1)
                   SELECT i, p AS a, ST_AsWKB(ST_Translate(ST_GeomFromWKB(p), 4 + i * 0.01, 2)) AS b FROM h, range({k}) t(i)""")
    con.execute("CREATE TABLE hulls_g AS SELECT i, a, b, ST_GeomFromWKB(a) AS ga, ST_GeomFromWKB(b) AS gb FROM hulls")
    ov = con.execute("SELECT polygon_area(polygon_overlap(a, b)), polygon_area(a) FROM hulls WHERE i = 0").fetchone()
    assert ov[0] > 0.2 * ov[1], ov
    t_tr, s_tr = timed(lambda: con.execute("SELECT sum(polygon_area(polygon_overlap(a, b))) FROM hulls_g").fetchone()[0])
    t_sp, s_sp = timed(lambda: con.execute("SELECT sum(ST_Area(ST_Intersection(ga, gb))) FROM hulls_g").fetchone()[0])
    pairs = [(shapely.from_wkb(bytes(r[0])), shapely.from_wkb(bytes(r[1]))) for r in con.execute("SELECT a, b FROM hulls ORDER BY i").fetchall()]
    t_sh, s_sh = timed(lambda: sum(shapely.intersection(p, q).area for p, q in pairs))
    assert abs(s_tr - s_sp) < 1e-6 * s_sp and abs(s_tr - s_sh) < 1e-6 * s_sh, (s_tr, s_sp, s_sh)
    va = len(pairs[0][0].exterior.coords)
    rows.append((f"overlap of two concave views (~{va} vertices) x{k}", k, t_tr, t_sp, t_sh))

    print(f"\n{'task':52s} {'n':>9s} {'trajdb s':>9s} {'spatial s':>10s} {'shapely s':>10s} {'spatial/trajdb':>15s} {'shapely/trajdb':>15s}")
    for name, cnt, tt, ts, th in rows:
        print(f"{name:52s} {cnt:9d} {tt:9.4f} {ts:10.4f} {th:10.4f} {ts / tt:14.1f}x {th / tt:14.1f}x")


if __name__ == "__main__":
    main()
