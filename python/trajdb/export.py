"""Road users for GIS tools, with their time, and optionally on a map (issue 29, part 3).

`merged.parquet` holds each road user's path as WKB LINESTRING M in the EWKB flavour (type
0x40000002), which geopandas' default engine refuses (`GeometryError ... WKB type 1073741826`).
`export` writes the same road users as

  * ``geojson``: one Feature per road user, a LineString (Point for one point) and every column
    of merged.parquet but the geometry as properties; ``times``: the time of every vertex (s,
    reference clock), so nothing of the path's timing is lost;
  * ``gpkg``: a GeoPackage (SQLite, written with the standard library), layer ``road_users``,
    geometry LINESTRING M (ISO WKB; M = t), the columns as attributes; QGIS and GDAL open it;
  * ``parquet``: GeoParquet 1.1 with ISO WKB (LINESTRING M, type 2002), which geopandas reads,
    and the CRS in the metadata when the output is on a map.

Times: ``t_start``, ``t_end`` and ``times`` are seconds on the reference camera's clock, as the
input gave them; when they look like Unix time (after 1990) the files also carry ``t_start_utc``
and ``t_end_utc`` (ISO 8601, UTC), which QGIS's temporal controller takes.

On a map (docs/maps.md): ``control_points=[(x, y, X, Y), ...]`` (at least two; x, y in the
reference camera's frame, X, Y in ``crs``) fit a similarity transform (rotation, uniform scale,
translation; least squares: the extension's rigid_fit, Umeyama 1991) that maps every path into ``crs``:
``"EPSG:4326"`` (X = longitude, Y = latitude, degrees; fitted in a local east/north tangent
plane) or a projected CRS (``"EPSG:25832"``, metres). ``fit_map`` returns the fit and its residuals.

usage: trajdb.export("results/", "road_users.gpkg")          (local frame: no CRS)
       trajdb.export(con, "road_users.geojson", control_points=[...], crs="EPSG:4326")
GeoJSON is always longitude / latitude (RFC 7946): without control points it is refused.
"""
import datetime
import json
import math
import os
import secrets
import sqlite3
import struct
import warnings

FORMATS = {".geojson": "geojson", ".json": "geojson", ".gpkg": "gpkg", ".parquet": "parquet"}
EPOCH_1990 = 631152000.0

# OGC:CRS84 (lon/lat, WGS 84) as PROJJSON: GeoParquet's default CRS, written out explicitly.
CRS84_PROJJSON = {
    "$schema": "https://proj.org/schemas/v0.7/projjson.schema.json", "type": "GeographicCRS",
    "name": "WGS 84 (CRS84)",
    "datum_ensemble": {"name": "World Geodetic System 1984 ensemble",
                       "members": [{"name": "World Geodetic System 1984 (Transit)"}, {"name": "World Geodetic System 1984 (G730)"},
                                   {"name": "World Geodetic System 1984 (G873)"}, {"name": "World Geodetic System 1984 (G1150)"},
                                   {"name": "World Geodetic System 1984 (G1674)"}, {"name": "World Geodetic System 1984 (G1762)"},
                                   {"name": "World Geodetic System 1984 (G2139)"}],
                       "ellipsoid": {"name": "WGS 84", "semi_major_axis": 6378137, "inverse_flattening": 298.257223563},
                       "accuracy": "2.0", "id": {"authority": "EPSG", "code": 6326}},
    "coordinate_system": {"subtype": "ellipsoidal", "axis": [
        {"name": "Geodetic longitude", "abbreviation": "Lon", "direction": "east", "unit": "degree"},
        {"name": "Geodetic latitude", "abbreviation": "Lat", "direction": "north", "unit": "degree"}]},
    "id": {"authority": "OGC", "code": "CRS84"}}


def _epsg(crs):
    if crs is None:
        return None
    s = str(crs).strip().upper()
    if s.startswith("EPSG:"):
        s = s[5:]
    if not s.isdigit():
        raise ValueError(f"trajdb.export: crs={crs!r} is not an EPSG code; give e.g. 'EPSG:4326' (lon/lat) or 'EPSG:25832'")
    return int(s)


class MapFit:
    """A fitted map: the reference camera's local (x, y) -> map (X, Y), as the extension's
    map_fit made it (crates/algo/src/align/map.rs: the similarity, through the plane tangent at
    the control points for EPSG:4326). `fit(x, y)` maps one point (map_apply); `residuals` are
    the control points' (map_residual_m, metres)."""

    def __init__(self, fit, epsg, residuals):
        self.fit, self.epsg, self.residuals = fit, epsg, residuals
        self.scale, self.theta_rad, self.rms_m = fit["scale"], fit["theta"], fit["rms_m"]
        self.origin = (fit["lon0"], fit["lat0"]) if fit["lonlat"] else None

    def __call__(self, x, y):
        from . import connect

        p = connect().execute("SELECT map_apply([{'t': 0.0, 'x': ?::DOUBLE, 'y': ?::DOUBLE}], ?::" + MAP_FIT_SQL + ")[1]",
                              [x, y, self.fit]).fetchall()[0][0]
        return (p["x"], p["y"])

    def __repr__(self):
        return (f"MapFit(EPSG:{self.epsg}, scale {self.scale:.6f}, rotation {math.degrees(self.theta_rad):.3f} deg, "
                f"rms residual {self.rms_m:.3f} m over {len(self.residuals)} control points)")


# map_fit's result type (src/bindings/map.rs MAP_FIT), for binding a fit back as a parameter
MAP_FIT_SQL = ("STRUCT(theta DOUBLE, tx DOUBLE, ty DOUBLE, scale DOUBLE, lonlat BOOLEAN, lon0 DOUBLE, lat0 DOUBLE, rms_m DOUBLE, "
               "max_residual_m DOUBLE, points BIGINT)")


def fit_map(control_points, crs):
    """The map of the local frame from >= 2 control points (x, y, X, Y): the extension's map_fit
    (a least-squares similarity, Umeyama 1991, with scale; for EPSG:4326, X = lon and Y = lat,
    fitted in metres east/north of the points' mean, across the antimeridian too). O(n)."""
    epsg = _epsg(crs)
    if epsg is None:
        raise ValueError("trajdb.export: control_points need a crs, e.g. crs='EPSG:4326'")
    try:
        pts = [tuple(float(v) for v in p) for p in control_points]
    except (TypeError, ValueError):
        raise ValueError("trajdb.export: control_points must be at least two finite (x, y, X, Y) tuples") from None
    if any(len(p) != 4 for p in pts):
        raise ValueError("trajdb.export: control_points must be at least two finite (x, y, X, Y) tuples")
    from . import connect

    if epsg in GEOGRAPHIC or (epsg != 4326 and _looks_like_degrees(pts)):
        # a projected CRS's coordinates are metres; a fit of degrees as metres is meaningless
        raise ValueError(
            f"trajdb.export: EPSG:{epsg} {'is a geographic CRS (degrees)' if epsg in GEOGRAPHIC else 'is taken for a projected CRS (metres), but the map points look like longitude/latitude degrees'}; "
            "give longitude/latitude with crs='EPSG:4326' (WGS 84), or the points in a projected CRS (UTM, a national grid)")
    rows = [{"x": p[0], "y": p[1], "map_x": p[2], "map_y": p[3]} for p in pts]
    try:
        f, residuals = connect().execute(
            "SELECT f, [map_residual_m(f, p.x, p.y, p.map_x, p.map_y) FOR p IN pts] FROM "
            "(SELECT map_fit(pts, ?) AS f, pts FROM (SELECT ?::STRUCT(x DOUBLE, y DOUBLE, map_x DOUBLE, map_y DOUBLE)[] AS pts))",
            [epsg == 4326, rows]).fetchall()[0]
    except Exception as e:  # noqa: BLE001 - the extension's message names what is wrong
        raise ValueError(f"trajdb.export: {str(e).split(': ', 1)[-1]}") from None
    if not 0.5 <= f["scale"] <= 2.0:
        warnings.warn(f"trajdb.export: the map fit's scale is {f['scale']:.6g}: the local frame is not in metres, or a control point "
                      "is wrong (is each one (x, y, X, Y) in that order?)", stacklevel=2)
    return MapFit(f, epsg, residuals)


# geographic CRSs (degrees) other than EPSG:4326: refused by name, as fitting their degrees as
# metres is meaningless (ETRS89, NAD83, GDA94, GDA2020, NZGD2000, JGD2000, JGD2011, CGCS2000, SIRGAS 2000)
GEOGRAPHIC = {4258, 4269, 4283, 7844, 4167, 4612, 6668, 4490, 4674}


def _looks_like_degrees(pts):
    """Map points within a tenth of a degree of each other in longitude/latitude ranges, for local
    points metres apart: degrees given for a projected CRS."""
    mx, my, lx, ly = ([p[k] for p in pts] for k in (2, 3, 0, 1))
    in_range = all(-180 <= v <= 180 for v in mx) and all(-90 <= v <= 90 for v in my)
    return in_range and max(max(mx) - min(mx), max(my) - min(my)) < 0.1 and max(max(lx) - min(lx), max(ly) - min(ly)) > 10


def _road_users(source, fit=None):
    """Rows of merged.parquet as dicts, from a results folder, a merged.parquet path or a
    DuckDB connection after the pipeline (its `merged` road users via result_road_users());
    with a MapFit, each traj on the map (map_apply; t unchanged)."""
    if isinstance(source, (str, os.PathLike)):
        path = os.fspath(source)
        if os.path.isdir(path):
            path = os.path.join(path, "merged.parquet")
        if not os.path.isfile(path):
            raise FileNotFoundError(f"trajdb.export: {path} not found: give a results folder, its merged.parquet or a connection")
        from . import connect

        con, src, args = connect(), "read_parquet(?)", [path]  # with the extension: map_apply
    else:
        con, src, args = source, "result_road_users()", []
    # t_start / t_end are TIMESTAMPTZ when the input's t was a timestamp (merged.parquet keeps the
    # input's kind); the files carry seconds, as traj's t, and the ISO times beside them. They are
    # turned into seconds in SQL: fetching a TIMESTAMPTZ into Python needs pytz (issue 39: a
    # datetime here was a TypeError in _utc)
    types = dict((r[0], r[1]) for r in con.execute(f"SELECT column_name, column_type FROM (DESCRIBE SELECT * FROM {src})", args).fetchall())
    ts = [k for k in ("t_start", "t_end") if types.get(k, "").startswith("TIMESTAMP")]
    repl = [f"epoch({k}) AS {k}" for k in ts] + (["map_apply(traj, $fit::" + MAP_FIT_SQL + ") AS traj"] if fit else [])
    replace = f" REPLACE ({', '.join(repl)})" if repl else ""
    named = {f"a{k}": v for k, v in enumerate(args)}
    src = src.replace("?", "$a0")
    # each path's ISO WKB (LINESTRING M, M = t; POINT M for one point) by the extension's one
    # WKB writer (traj_to_wkb, crates/algo/src/traj.rs), in the same query: "wkb_m", not a property
    try:
        cur = con.execute(f"SELECT *, traj_to_wkb(traj, true) AS wkb_m FROM (SELECT * EXCLUDE (geometry){replace} FROM {src}) ORDER BY road_user",
                          {**named, **({"fit": fit.fit} if fit else {})})
    except Exception as e:  # noqa: BLE001 - a path the fit puts off the map (map_apply): the extension says which
        if fit is None or "map_apply" not in str(e):
            raise
        raise ValueError(f"trajdb.export: {str(e).split(': ', 1)[-1]}") from None
    names = [d[0] for d in cur.description]
    return [dict(zip(names, r)) for r in cur.fetchall()]


def _utc(t):
    if t is None or not (EPOCH_1990 <= t <= 4.1e9):
        return None
    return datetime.datetime.fromtimestamp(t, datetime.timezone.utc).isoformat().replace("+00:00", "Z")


def _properties(r):
    p = {k: v for k, v in r.items() if k not in ("traj", "sigma", "sources", "wkb_m")}
    p["sources"] = ",".join(f"{s['camera']}:{s['track_id']}" for s in r["sources"] or [])
    p["times"] = [q["t"] for q in r["traj"]]
    p["sigma"] = list(r["sigma"]) if r.get("sigma") is not None else None
    if _utc(r["t_start"]):
        p["t_start_utc"], p["t_end_utc"] = _utc(r["t_start"]), _utc(r["t_end"])
    return p


def export(source, path, format=None, control_points=None, crs=None, overwrite=False):
    """Write the road users of `source` (a results folder, its merged.parquet, or a DuckDB
    connection after trajdb.pipeline) to `path` as GeoJSON, GeoPackage or GeoParquet (format
    from the extension unless given), keeping every vertex's time. With control_points and crs,
    the paths are put on the map first (fit_map). Returns the number of road users written.
    An existing file is an error unless overwrite=True."""
    path = os.fspath(path)
    fmt = format or FORMATS.get(os.path.splitext(path)[1].lower())
    if fmt not in ("geojson", "gpkg", "parquet"):
        raise ValueError(f"trajdb.export: format {format or os.path.splitext(path)[1]!r} unknown; give 'geojson', 'gpkg' or 'parquet' "
                         "(or a path ending .geojson, .gpkg, .parquet)")
    if os.path.exists(path) and not overwrite:
        raise FileExistsError(f"trajdb.export: {path} exists; give another path or overwrite=True")
    fit = fit_map(control_points, crs) if control_points is not None else None
    if fit is None and crs is not None:
        raise ValueError("trajdb.export: crs needs control_points (the local frame has no CRS of its own)")
    if fmt == "geojson" and fit is None:
        # RFC 7946: GeoJSON coordinates are WGS84 longitude / latitude, and geopandas, QGIS and
        # web maps read them so: metres of a camera's frame would land off the coast of Africa
        # (issue 39). Nothing is written.
        raise ValueError(
            "trajdb.export: GeoJSON is always longitude / latitude (RFC 7946), and the paths are in the reference camera's local frame "
            "in metres; give control_points=[(x, y, lon, lat), ...] and crs='EPSG:4326' to put them on the map (docs/maps.md), "
            "or write .gpkg or .parquet, which say they have no CRS"
        )
    epsg = fit.epsg if fit else None
    rows = _road_users(source, fit)
    feats = [(r, [(q["x"], q["y"], q["t"]) for q in r["traj"]]) for r in rows]
    # a temporary name of this call's own (pid + random), created with O_EXCL: never a file of
    # the user's (a `<path>.partial` of theirs stays as it is), and removed only by this call
    while True:
        tmp = f"{path}.{os.getpid()}-{secrets.token_hex(6)}.partial"
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            break
        except FileExistsError:
            continue
    try:
        if fmt == "geojson":
            _geojson(tmp, feats, epsg)
        elif fmt == "gpkg":
            _gpkg(tmp, feats, epsg)
        else:
            _geoparquet(tmp, feats, epsg)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.remove(tmp)
        except OSError:
            pass
        raise
    return len(feats)


def _geojson(path, feats, epsg):
    out = {"type": "FeatureCollection", "name": "road_users", "features": []}
    if epsg not in (None, 4326):  # RFC 7946 is lon/lat; GDAL and QGIS read this member
        out["crs"] = {"type": "name", "properties": {"name": f"urn:ogc:def:crs:EPSG::{epsg}"}}
    for r, xym in feats:
        coords = [[p[0], p[1]] for p in xym]
        geom = {"type": "Point", "coordinates": coords[0]} if len(coords) == 1 else {"type": "LineString", "coordinates": coords}
        out["features"].append({"type": "Feature", "id": r["road_user"], "geometry": geom, "properties": _properties(r)})
    with open(path, "w", encoding="utf-8") as f:
        json.dump(out, f, allow_nan=False)


def _gpkg(path, feats, epsg):
    srs_id = -1 if epsg is None else epsg
    con = sqlite3.connect(path)
    c = con.cursor()
    c.execute("PRAGMA application_id = 1196444487")  # 'GPKG'
    c.execute("PRAGMA user_version = 10300")
    c.execute("""CREATE TABLE gpkg_spatial_ref_sys (srs_name TEXT NOT NULL, srs_id INTEGER PRIMARY KEY, organization TEXT NOT NULL,
                 organization_coordsys_id INTEGER NOT NULL, definition TEXT NOT NULL, description TEXT)""")
    srs = [("Undefined Cartesian SRS", -1, "NONE", -1, "undefined", "the reference camera's local metric frame"),
           ("Undefined geographic SRS", 0, "NONE", 0, "undefined", None),
           ("WGS 84 geodetic", 4326, "EPSG", 4326, 'GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],'
            'PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433],AUTHORITY["EPSG","4326"]]', None)]
    if epsg not in (None, 4326):
        srs.append((f"EPSG:{epsg}", epsg, "EPSG", epsg, "undefined", None))
    c.executemany("INSERT INTO gpkg_spatial_ref_sys VALUES (?, ?, ?, ?, ?, ?)", srs)
    c.execute("""CREATE TABLE gpkg_contents (table_name TEXT NOT NULL PRIMARY KEY, data_type TEXT NOT NULL, identifier TEXT UNIQUE,
                 description TEXT DEFAULT '', last_change DATETIME NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')),
                 min_x DOUBLE, min_y DOUBLE, max_x DOUBLE, max_y DOUBLE, srs_id INTEGER)""")
    c.execute("""CREATE TABLE gpkg_geometry_columns (table_name TEXT NOT NULL, column_name TEXT NOT NULL, geometry_type_name TEXT NOT NULL,
                 srs_id INTEGER NOT NULL, z TINYINT NOT NULL, m TINYINT NOT NULL, PRIMARY KEY (table_name, column_name))""")
    c.execute("""CREATE TABLE road_users (fid INTEGER PRIMARY KEY AUTOINCREMENT, geom BLOB, road_user INTEGER, class TEXT, n_tracks INTEGER,
                 sources TEXT, t_start REAL, t_end REAL, t_start_utc DATETIME, t_end_utc DATETIME, duration_s REAL, length_m REAL,
                 sigma_m REAL, times TEXT)""")
    xs, ys = [], []
    for r, xym in feats:
        wkb = bytes(r["wkb_m"])
        bx, by = [p[0] for p in xym], [p[1] for p in xym]
        xs += [min(bx), max(bx)]
        ys += [min(by), max(by)]
        head = b"GP" + struct.pack("<BBi4d", 0, 0x03, srs_id, min(bx), max(bx), min(by), max(by))  # little endian, xy envelope
        p = _properties(r)
        c.execute("INSERT INTO road_users (geom, road_user, class, n_tracks, sources, t_start, t_end, t_start_utc, t_end_utc, duration_s, "
                  "length_m, sigma_m, times) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                  (head + wkb, r["road_user"], r["class"], r["n_tracks"], p["sources"], r["t_start"], r["t_end"],
                   p.get("t_start_utc"), p.get("t_end_utc"), r["duration_s"], r["length_m"], r.get("sigma_m"), json.dumps(p["times"])))
    c.execute("INSERT INTO gpkg_contents (table_name, data_type, identifier, description, min_x, min_y, max_x, max_y, srs_id) "
              "VALUES ('road_users', 'features', 'road_users', 'trajdb road users (M = t, s)', ?, ?, ?, ?, ?)",
              (min(xs, default=None), min(ys, default=None), max(xs, default=None), max(ys, default=None), srs_id))
    c.execute("INSERT INTO gpkg_geometry_columns VALUES ('road_users', 'geom', 'LINESTRING', ?, 0, 1)", (srs_id,))
    con.commit()
    con.close()


def _geoparquet(path, feats, epsg):
    import duckdb
    con = duckdb.connect()
    con.execute("CREATE TABLE ru (road_user BIGINT, class VARCHAR, n_tracks BIGINT, sources VARCHAR, t_start DOUBLE, t_end DOUBLE, "
                "duration_s DOUBLE, length_m DOUBLE, sigma_m DOUBLE, times DOUBLE[], geometry BLOB)")
    con.executemany("INSERT INTO ru VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                    [(r["road_user"], r["class"], r["n_tracks"], _properties(r)["sources"], r["t_start"], r["t_end"], r["duration_s"],
                      r["length_m"], r.get("sigma_m"), [p[2] for p in xym], bytes(r["wkb_m"])) for r, xym in feats])
    if epsg is None:
        crs = None
    elif epsg == 4326:
        crs = CRS84_PROJJSON
    else:  # a PROJJSON naming the code; GDAL and pyproj resolve it by its id
        crs = {"$schema": "https://proj.org/schemas/v0.7/projjson.schema.json", "type": "ProjectedCRS", "name": f"EPSG:{epsg}",
               "id": {"authority": "EPSG", "code": epsg}}
    geo = {"version": "1.1.0", "primary_column": "geometry",
           "columns": {"geometry": {"encoding": "WKB", "geometry_types": ["LineString M", "Point M"], "crs": crs, "edges": "planar"}}}
    con.execute("SET VARIABLE trajdb_export_geo = ?", [json.dumps(geo)])
    con.execute("SET VARIABLE trajdb_export_path = ?", [path])
    # the path and the metadata go in as variables, never spliced into the SQL
    con.execute("COPY (FROM ru ORDER BY road_user) TO (getvariable('trajdb_export_path')) "
                "(FORMAT parquet, KV_METADATA {geo: getvariable('trajdb_export_geo')})")
    con.close()
