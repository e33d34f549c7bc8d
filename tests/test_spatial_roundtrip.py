#!/usr/bin/env python3
"""Round trip between trajdb's polygon functions and DuckDB spatial, in one stock DuckDB.

DuckDB spatial ships on PyPI as `duckdb-extension-spatial`, only for DuckDB 1.5.x; trajdb's
extension uses the stable C API (v1.2.0), so it loads there too. Checks:
  * ST_GeomFromWKB reads every WKB trajdb writes (POLYGON, MULTIPOLYGON, POLYGON EMPTY) and
    ST_IsValid holds;
  * areas, intersections and unions agree with ST_Area / ST_Intersection / ST_Union_Agg;
  * polygon_to_wkt text is the same geometry (ST_Equals);
  * trajdb reads spatial's ST_AsWKB and ST_AsText output;
  * polygon_contains agrees with ST_Intersects (closed polygon) on a grid, boundary included.

usage: python tests/test_spatial_roundtrip.py trajdb.duckdb_extension
"""
import glob
import os
import sys

import duckdb
import duckdb_extension_spatial


def main():
    ext = os.path.abspath(sys.argv[1])
    spatial = glob.glob(os.path.join(os.path.dirname(duckdb_extension_spatial.__file__), "extensions", "*", "spatial.duckdb_extension"))
    assert spatial, "spatial.duckdb_extension not found in the duckdb-extension-spatial package"
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{spatial[0]}'")
    con.execute(f"LOAD '{ext}'")
    failures = 0
    checks = 0

    def check(name, sql, expect=True):
        nonlocal failures, checks
        checks += 1
        got = con.execute(sql).fetchone()[0]
        ok = got == expect
        failures += not ok
        print(("ok   " if ok else "FAIL ") + name + ("" if ok else f": got {got!r}, expected {expect!r}"))

    # A scene: three overlapping camera views built from point clouds (convex and concave),
    # as WKB from trajdb.
    con.execute("""
        CREATE TABLE pts AS
        SELECT c AS cam, 10 * c + 20 * cos(i * 0.37) * (0.5 + (i * 7919 % 101) / 202.0) AS x,
               15 * sin(i * 0.37) * (0.5 + (i * 104729 % 97) / 194.0) + 3 * c AS y
        FROM range(3) a(c), range(2000) b(i)""")
    con.execute("""
        CREATE TABLE views AS
        SELECT cam, view_polygon(list({'x': x, 'y': y}), 'convex') AS convex,
               view_polygon(list({'x': x, 'y': y}), 'concave', 1.0) AS concave
        FROM pts GROUP BY cam""")
    check("view_polygon convex: ST_GeomFromWKB valid, same area",
          "SELECT bool_and(ST_IsValid(ST_GeomFromWKB(convex)) AND abs(ST_Area(ST_GeomFromWKB(convex)) - polygon_area(convex)) < 1e-9) FROM views")
    check("view_polygon concave: ST_GeomFromWKB valid, same area",
          "SELECT bool_and(ST_IsValid(ST_GeomFromWKB(concave)) AND abs(ST_Area(ST_GeomFromWKB(concave)) - polygon_area(concave)) < 1e-9) FROM views")
    # i_overlay (geo's boolean engine) snaps to a fine integer grid: results agree with GEOS to
    # ~1e-9 relative in area, so the checks are relative, not exact.
    check("polygon_overlap = ST_Intersection (area, symmetric difference ~ 0)", """
        SELECT bool_and(ST_IsValid(ST_GeomFromWKB(polygon_overlap(a.concave, b.convex)))
                        AND abs(ST_Area(ST_Intersection(ST_GeomFromWKB(a.concave), ST_GeomFromWKB(b.convex)))
                                - polygon_area(polygon_overlap(a.concave, b.convex))) < 1e-8 * polygon_area(a.concave)
                        AND ST_Area(ST_SymDifference(ST_GeomFromWKB(polygon_overlap(a.concave, b.convex)),
                                    ST_Intersection(ST_GeomFromWKB(a.concave), ST_GeomFromWKB(b.convex)))) < 1e-7 * polygon_area(a.concave))
        FROM views a, views b WHERE a.cam <> b.cam""")
    check("polygon_union = ST_Union_Agg", """
        SELECT abs(polygon_area(polygon_union(list(concave))) - ST_Area(ST_Union_Agg(ST_GeomFromWKB(concave)))) < 1e-6
               AND ST_IsValid(ST_GeomFromWKB(polygon_union(list(concave))))
        FROM views""")
    check("multi-camera overlap (A ∪ B) ∩ C", """
        SELECT abs(polygon_area(polygon_overlap(polygon_union([a.convex, b.convex]), c.convex))
                   - ST_Area(ST_Intersection(ST_Union(ST_GeomFromWKB(a.convex), ST_GeomFromWKB(b.convex)), ST_GeomFromWKB(c.convex)))) < 1e-6
        FROM views a, views b, views c WHERE a.cam = 0 AND b.cam = 1 AND c.cam = 2""")
    check("MULTIPOLYGON output is read as one", """
        SELECT ST_GeometryType(ST_GeomFromWKB(polygon_overlap('POLYGON ((0 0, 10 0, 10 1, 0 1, 0 0))',
               'MULTIPOLYGON (((1 -1, 2 -1, 2 2, 1 2, 1 -1)), ((5 -1, 6 -1, 6 2, 5 2, 5 -1)))')))::VARCHAR""", "MULTIPOLYGON")
    check("POLYGON EMPTY output is an empty polygon", """
        SELECT ST_IsEmpty(g) AND ST_GeometryType(g)::VARCHAR = 'POLYGON'
        FROM (SELECT ST_GeomFromWKB(polygon_overlap('POLYGON ((0 0, 1 0, 1 1, 0 0))', 'POLYGON ((5 5, 6 5, 6 6, 5 5))')) AS g)""")
    check("degenerate hull (collinear) is POLYGON EMPTY to spatial too",
          "SELECT ST_IsEmpty(ST_GeomFromWKB(view_polygon([{'x': 0, 'y': 0}, {'x': 1, 'y': 1}, {'x': 2, 'y': 2}], 'convex')))")
    check("polygon_to_wkt is the same geometry",
          "SELECT bool_and(ST_Equals(ST_GeomFromText(polygon_to_wkt(concave)), ST_GeomFromWKB(concave))) FROM views")
    check("polygon_buffer(-d) ~ ST_Buffer(-d)", """
        SELECT bool_and(abs(polygon_area(polygon_buffer(convex, -0.5)) - ST_Area(ST_Buffer(ST_GeomFromWKB(convex), -0.5)))
                        < 1e-3 * polygon_area(convex)) FROM views""")
    check("trajdb reads spatial's WKB and WKT", """
        SELECT abs(polygon_area(ST_AsWKB(ST_Buffer(ST_Point(0, 0), 1.0))) - ST_Area(ST_Buffer(ST_Point(0, 0), 1.0))) < 1e-12
           AND polygon_area(ST_AsText(ST_GeomFromText('POLYGON ((0 0, 3 0, 3 3, 0 0))'))) = 4.5""")
    check("polygon_contains = ST_Intersects on a grid (boundary included)", """
        WITH g AS (SELECT (i % 41 - 20) * 0.5 AS x, (i // 41 - 20) * 0.5 AS y FROM range(1681) t(i)),
             p AS (SELECT 'POLYGON ((-8 -8, 8 -8, 8 8, 0 3, -8 8, -8 -8), (-2 -2, 2 -2, 2 0, -2 0, -2 -2))' AS w)
        SELECT count(*) FILTER (WHERE polygon_contains(p.w, x, y) <> ST_Intersects(ST_GeomFromText(p.w), ST_Point(x, y))) = 0
        FROM g, p""")
    check("traj_points_inside = count of ST_Intersects", """
        WITH v AS (SELECT convex FROM views WHERE cam = 1),
             t AS (SELECT list({'t': i, 'x': 30 * cos(i * 0.01), 'y': 20 * sin(i * 0.013)} ORDER BY i) AS tr FROM range(3000) r(i))
        SELECT traj_points_inside(t.tr, v.convex) = (SELECT count(*) FROM range(3000) r(i), v
                   WHERE ST_Intersects(ST_GeomFromWKB(v.convex), ST_Point(30 * cos(i * 0.01), 20 * sin(i * 0.013))))
        FROM t, v""")
    check("traj_to_wkb = ST_GeomFromText(traj_to_wkt)", """
        WITH t AS (SELECT [{'t': i, 'x': 3.5 * i, 'y': sin(i)} FOR i IN range(50)] AS tr
                   UNION ALL SELECT [{'t': 0, 'x': 1.5, 'y': -2}] UNION ALL SELECT [])
        SELECT bool_and(ST_Equals(ST_GeomFromWKB(traj_to_wkb(tr)), ST_GeomFromText(traj_to_wkt(tr)))
                        OR (len(tr) = 0 AND ST_IsEmpty(ST_GeomFromWKB(traj_to_wkb(tr))))) FROM t""")
    # merged.parquet of `trajdb pipeline`: WKB + GeoParquet 'geo' metadata (pipeline::GEOPARQUET_META)
    geo = ('{"version":"1.1.0","primary_column":"geometry","columns":{"geometry":{"encoding":"WKB",'
           '"geometry_types":["LineString M","Point M"],"crs":null,"edges":"planar"}}}')
    path = os.path.join(os.environ.get("TMPDIR", "/tmp"), f"trajdb-geoparquet-{os.getpid()}.parquet")
    con.execute(f"""COPY (SELECT 1 AS road_user, traj_to_wkb([{{'t': 0, 'x': 0, 'y': 0}}, {{'t': 1.5, 'x': 3, 'y': 4}}], true) AS geometry)
                    TO '{path}' (FORMAT parquet, KV_METADATA {{geo: '{geo}'}})""")
    check("GeoParquet merged.parquet (LINESTRING M, M = t) is read by spatial as GEOMETRY with M",
          f"SELECT typeof(geometry) = 'GEOMETRY' AND ST_Length(geometry) = 5 AND ST_HasM(geometry) AND ST_MMax(geometry) = 1.5 FROM read_parquet('{path}')")
    os.remove(path)
    print(f"duckdb {duckdb.__version__} + spatial: {checks - failures} passed, {failures} failed")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
