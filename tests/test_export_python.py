#!/usr/bin/env python3
"""trajdb.export (python/trajdb/export.py; issue 29, part 3): the road users of a run written as
GeoJSON, GeoPackage and GeoParquet, read back: the same road users, classes and lengths, every
vertex with its time, and on a map through synthetic control points (docs/maps.md).

  * GeoJSON: json; LineString coordinates = traj's x, y; properties.times = traj's t.
  * GeoPackage: sqlite3; the GeoPackage header (GP, srs_id, envelope) and ISO WKB LINESTRING M
    (type 2002) whose M values are traj's t; gpkg_geometry_columns says m = 1.
  * GeoParquet: DuckDB; ISO WKB (2002, not the EWKB 0x40000002 geopandas refuses), geo metadata.
  * On a map: control points made from a known similarity (rotation 30 deg, scale 1, a shift to
    UTM-sized numbers; and a lon/lat one near 57.7 N, 11.97 E): fit_map recovers it (residual
    < 1 mm; lon/lat < 1e-8 deg over a few hundred metres), the exported vertices equal the
    known map of traj's points, GeoParquet carries the CRS (OGC:CRS84 PROJJSON for lon/lat).
  * Errors: one control point, coincident points, an unknown format, an existing file.

usage: python3 tests/test_export_python.py path/to/trajdb.duckdb_extension
"""
import json
import math
import os
import sqlite3
import struct
import subprocess
import sys
import warnings
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    ext = os.path.abspath(sys.argv[1])
    os.environ["TRAJDB_EXTENSION"] = ext
    sys.path.insert(0, os.path.join(HERE, "..", "python"))
    import duckdb
    import trajdb
    from trajdb.export import export, fit_map
    failures = 0

    def check(ok, what):
        nonlocal failures
        failures += not ok
        print(("ok   " if ok else "FAIL ") + what)

    with tempfile.TemporaryDirectory() as w:
        env = dict(os.environ, PYTHONPATH=os.path.join(HERE, "..", "python"))
        subprocess.run([sys.executable, "-m", "trajdb", "simulate", "--out", w + "/sim", "--minutes", "2", "--seed", "3",
                        "--clock-epoch", "1780000000"], check=True, env=env, capture_output=True)
        con = trajdb.connect()
        trajdb.pipeline(con, w + "/sim/points.parquet", out=w + "/r")
        truth = {r[0]: r[1:] for r in duckdb.connect().execute(
            "SELECT road_user, class, length_m, [p.t FOR p IN traj], [p.x FOR p IN traj], [p.y FOR p IN traj] FROM read_parquet(?)",
            [w + "/r/merged.parquet"]).fetchall()}
        check(len(truth) > 10, f"{len(truth)} road users to export")

        # GeoJSON from the results folder: GeoJSON is longitude / latitude or a declared CRS, never
        # the local frame (issue 39: geopandas read local metres as WGS84); here the identity map
        # into a projected CRS (control points equal in both frames), so coordinates stay traj's
        ident = [(0.0, 0.0, 0.0, 0.0), (100.0, 0.0, 100.0, 0.0), (0.0, 100.0, 0.0, 100.0)]
        n = export(w + "/r", w + "/ru.geojson", control_points=ident, crs="EPSG:32632")
        gj = json.load(open(w + "/ru.geojson"))
        got = {f["properties"]["road_user"]: f for f in gj["features"]}
        check(n == len(truth) and set(got) == set(truth), "GeoJSON: the same road users")
        check(all(got[k]["properties"]["class"] == v[0] and got[k]["properties"]["times"] == v[2] for k, v in truth.items()),
              "GeoJSON: classes and every vertex's time (properties.times) kept")
        check(all([c[0] for c in (got[k]["geometry"]["coordinates"] if got[k]["geometry"]["type"] == "LineString"
                                  else [got[k]["geometry"]["coordinates"]])] == v[3] for k, v in truth.items()),
              "GeoJSON: coordinates are traj's x")
        f0 = next(iter(got.values()))["properties"]
        check(f0.get("t_start_utc", "").startswith("2026-"), f"GeoJSON: Unix times also as UTC: t_start_utc = {f0.get('t_start_utc')}")

        # GeoPackage from the connection
        n = export(con, w + "/ru.gpkg")
        db = sqlite3.connect(w + "/ru.gpkg")
        check(db.execute("PRAGMA application_id").fetchone()[0] == 0x47504B47, "GPKG: application_id 'GPKG'")
        check(db.execute("SELECT geometry_type_name, m, srs_id FROM gpkg_geometry_columns").fetchall() == [("LINESTRING", 1, -1)],
              "GPKG: LINESTRING with M, undefined Cartesian SRS (-1)")
        ok = n == len(truth)
        for ru, cls, blob in db.execute("SELECT road_user, class, geom FROM road_users"):
            magic, _, flags, srs = struct.unpack_from("<2sBBi", blob)
            wkb = blob[8 + 32:]
            order, gtype = struct.unpack_from("<BI", wkb)
            if gtype == 2002:
                npts = struct.unpack_from("<I", wkb, 5)[0]
                xym = [struct.unpack_from("<3d", wkb, 9 + 24 * i) for i in range(npts)]
            else:
                xym = [struct.unpack_from("<3d", wkb, 5)]
            ok &= magic == b"GP" and flags == 3 and srs == -1 and gtype in (2001, 2002)
            ok &= cls == truth[ru][0] and [p[2] for p in xym] == truth[ru][2] and [p[0] for p in xym] == truth[ru][3]
        check(ok, "GPKG: every road user, ISO WKB LINESTRING M whose M values are traj's t")

        # an input whose t is a TIMESTAMPTZ: merged.parquet's t_start / t_end are TIMESTAMPTZ, and
        # the files carry them as seconds and ISO UTC (issue 39: a TypeError in _utc before)
        con.execute("CREATE TABLE ts_points AS SELECT * REPLACE (to_timestamp(t) AS t) FROM read_parquet(?)", [w + "/sim/points.parquet"])
        trajdb.pipeline(con, "ts_points", out=w + "/rts")
        for src, fmt in ((w + "/rts", "geojson"), (con, "gpkg"), (w + "/rts/merged.parquet", "parquet")):
            try:
                n = export(src, w + "/ts." + fmt, **({"control_points": ident, "crs": "EPSG:32632"} if fmt == "geojson" else {}))
                ok = n == len(truth)
            except Exception as e:  # noqa: BLE001
                ok, n = False, repr(e)
            check(ok, f"TIMESTAMPTZ input: {fmt} export of every road user ({n})")
        fts = json.load(open(w + "/ts.geojson"))["features"][0]["properties"]
        check(isinstance(fts["t_start"], float) and fts.get("t_start_utc", "").startswith("2026-"),
              f"TIMESTAMPTZ input: t_start as seconds and t_start_utc as ISO ({fts['t_start']}, {fts.get('t_start_utc')})")

        # GeoParquet: ISO WKB, read back by DuckDB
        export(w + "/r/merged.parquet", w + "/ru.parquet")
        d = duckdb.connect()
        d.execute("SET enable_geoparquet_conversion = false")  # the WKB bytes as written
        rows = d.execute("SELECT road_user, times, NULL, geometry FROM read_parquet(?)", [w + "/ru.parquet"]).fetchall()
        check({r[0] for r in rows} == set(truth) and all(r[1] == truth[r[0]][2] for r in rows), "GeoParquet: the same road users, times kept")
        check(all(struct.unpack_from("<I", r[3], 1)[0] in (2001, 2002) for r in rows), "GeoParquet: ISO WKB types 2001/2002 (not EWKB)")
        meta = d.execute("SELECT value FROM parquet_kv_metadata(?) WHERE key = 'geo'", [w + "/ru.parquet"]).fetchall()
        check(meta and json.loads(meta[0][0])["columns"]["geometry"]["crs"] is None, "GeoParquet: geo metadata, crs null (local frame)")

        # on a map: a known similarity, control points from it
        th, s, bx, by = math.radians(30), 1.0, 500000.0, 5730000.0
        known = lambda x, y: (s * (math.cos(th) * x - math.sin(th) * y) + bx, s * (math.sin(th) * x + math.cos(th) * y) + by)
        cps = [(x, y, *known(x, y)) for x, y in [(0, 0), (50, 10), (-20, 40)]]
        fit = fit_map(cps, "EPSG:32632")
        check(abs(fit.theta_rad - th) < 1e-9 and abs(fit.scale - 1) < 1e-9 and fit.rms_m < 1e-3, f"fit_map recovers the similarity: {fit}")
        export(w + "/r", w + "/utm.geojson", control_points=cps, crs="EPSG:32632")
        gj = json.load(open(w + "/utm.geojson"))
        k, v = next(iter(truth.items()))
        f = next(f for f in gj["features"] if f["properties"]["road_user"] == k)
        c = f["geometry"]["coordinates"] if f["geometry"]["type"] == "LineString" else [f["geometry"]["coordinates"]]
        check(max(math.dist(c[i], known(v[3][i], v[4][i])) for i in range(len(c))) < 1e-6 and gj["crs"]["properties"]["name"].endswith("32632"),
              "GeoJSON in EPSG:32632: vertices = the known map of traj, crs named")
        # two points suffice; lon/lat through a tangent plane at 57.7 N
        lat0, lon0 = 57.7, 11.97
        ll = lambda x, y: (lon0 + math.degrees(x / (6378137.0 * math.cos(math.radians(lat0)))), lat0 + math.degrees(y / 6378137.0))
        cps2 = [(0, 0, *ll(0, 0)), (100, 0, *ll(100, 0))]
        fit2 = fit_map(cps2, "EPSG:4326")
        check(fit2.rms_m < 1e-3 and abs(fit2.theta_rad) < 1e-6, f"fit_map, 2 points, lon/lat: {fit2}")
        lon, lat = fit2(200, 300)
        check(abs(lon - ll(200, 300)[0]) < 1e-7 and abs(lat - ll(200, 300)[1]) < 1e-7, f"lon/lat 300 m away: {lon:.8f}, {lat:.8f}")
        export(w + "/r", w + "/ll.parquet", control_points=cps2, crs="EPSG:4326")
        meta = json.loads(d.execute("SELECT value FROM parquet_kv_metadata(?) WHERE key = 'geo'", [w + "/ll.parquet"]).fetchall()[0][0])
        check(meta["columns"]["geometry"]["crs"]["id"] == {"authority": "OGC", "code": "CRS84"}, "GeoParquet on the map: crs OGC:CRS84")
        export(w + "/r", w + "/ll.gpkg", control_points=cps2, crs="EPSG:4326")
        check(sqlite3.connect(w + "/ll.gpkg").execute("SELECT srs_id FROM gpkg_geometry_columns").fetchall() == [(4326,)], "GPKG on the map: srs 4326")

        # GDAL reads them (DuckDB spatial's ST_Read, where duckdb-extension-spatial is installed:
        # requirements-spatial.txt, DuckDB 1.5)
        try:
            import glob
            import duckdb_extension_spatial
            sp = glob.glob(os.path.join(os.path.dirname(duckdb_extension_spatial.__file__), "extensions", "*", "spatial.duckdb_extension"))[0]
        except (ImportError, IndexError):
            print("skip GDAL read-back: duckdb-extension-spatial not installed")
        else:
            g = duckdb.connect(config={"allow_unsigned_extensions": "true"})
            g.execute("LOAD '" + sp.replace("'", "''") + "'")
            for f, has_m in [("ru.geojson", False), ("ru.gpkg", True), ("ll.gpkg", True)]:
                r = g.execute("SELECT count(*), bool_and(ST_HasM(geom)) FROM ST_Read(?)", [w + "/" + f]).fetchall()[0]
                check(r[0] == len(truth) and (r[1] or not has_m), f"GDAL (ST_Read) opens {f}: {r[0]} road users" + (", M kept" if has_m else ""))

        # errors
        def raises(fn, exc, what):
            try:
                fn()
            except exc as e:
                check("trajdb.export" in str(e), f"{what}: {e}")
            else:
                check(False, f"{what}: no error")
        raises(lambda: fit_map(cps[:1], "EPSG:32632"), ValueError, "one control point")
        raises(lambda: fit_map([(1, 1, 0, 0), (1, 1, 5, 5)], "EPSG:32632"), ValueError, "coincident control points")
        raises(lambda: fit_map(cps, "utm"), ValueError, "a CRS that is not an EPSG code")
        raises(lambda: fit_map(cps2, "EPSG:4258"), ValueError, "a geographic CRS other than EPSG:4326 (its degrees are no metres)")
        raises(lambda: fit_map(cps2, "EPSG:32632"), ValueError, "longitude/latitude given for a projected CRS")
        # the tuples in the wrong order (lon, lat, x, y): a scale far from 1 is said, and paths the
        # fit puts past a pole are an error, never a file of impossible coordinates
        swapped = [(p[2], p[3], p[0], p[1]) for p in cps2]
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            fit_map(swapped, "EPSG:4326")
        check(any("scale" in str(x.message) for x in said), f"a scale far from 1 is said: {[str(x.message) for x in said]}")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            raises(lambda: export(w + "/r", w + "/swapped.geojson", control_points=swapped, crs="EPSG:4326"), ValueError,
                   "control points in the wrong order")
        check(not os.path.exists(w + "/swapped.geojson"), "nothing written for them")
        raises(lambda: export(w + "/r", w + "/x.shp"), ValueError, "an unknown format")
        raises(lambda: export(w + "/r", w + "/ru.geojson"), FileExistsError, "an existing file")
        raises(lambda: export(w + "/r", w + "/local.geojson"), ValueError, "GeoJSON in the local frame (no control points)")
        check(not os.path.exists(w + "/local.geojson"), "a refused GeoJSON writes nothing")
        raises(lambda: export(w + "/nothing", w + "/y.gpkg"), FileNotFoundError, "no results")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
