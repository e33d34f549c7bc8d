"""The pipeline on one part of a large archive: a site's calibration once, then (site, window)
parts that reuse it. Pure DuckDB + pyarrow (no Spark): `trajdb.spark` calls these inside its
tasks, and any other scheduler can too.

    site = calibrate_site(site_points)                     # dict: table name -> pyarrow.Table
    out = run_window(window_points, site, start, end, loaded_from, loaded_to)
    out["road_users"], out["matches"], out["status"]

How a window stays identical to a run on the whole site is explained in sql/window.sql; the
halo rule is in docs/spark.md.

The stages are the same SQL files as `trajdb pipeline` (sql/stages.sql). What a site computes
once is named here, in SITE_TABLES: a window loads those tables instead of running the
statements that make them. Everything else a stage makes is computed per window.
"""
import io

import duckdb
import pyarrow as pa

from . import _literal, check_duckdb, execute_steps, read, stages

def connect(extension, threads=1):
    """An in-memory DuckDB with the extension file loaded; `threads` per task (a Spark task has one core)."""
    check_duckdb()
    con = duckdb.connect(":memory:", config={"allow_unsigned_extensions": "true", "threads": threads})
    con.execute(f"LOAD {_literal(extension)}")
    return con


def _plan(con, part, params):
    """The statements of a site or window run, from the extension's manifest (trajdb_stages:
    which stages, which statements a window skips, which tables a site ships)."""
    return stages(con, "trajdb_window_input", part=part, **(params or {}))


def site_table_names(con, params=None):
    """The tables a site's calibration makes once and ships to its windows (trajdb_stages'
    `shared`: crates/app/src/plan.rs SITE_TABLES)."""
    return [r[0] for r in con.execute(
        "SELECT makes FROM trajdb_stages('trajdb_window_input', part := 'site') WHERE shared GROUP BY makes ORDER BY min(k)").fetchall()]


def _arrow(rel):
    return rel.to_arrow_table()  # DuckDB 1.5 and 2.0


def _integer_ids(points, who):
    """Windows number ids per run: text ids would be numbered apart in the site and in each
    window, so cameras could silently mismatch. Refused until the site's id table travels along."""
    for col in ("camera", "track_id"):
        if col in points.column_names and not pa.types.is_integer(points.schema.field(col).type):
            raise ValueError(f"{who}: {col} must be an integer column for site/window runs (got {points.schema.field(col).type}); "
                             "number your ids first (trajdb.pipeline on a whole site accepts text ids)")


def calibrate_site(points, params=None, extension=None, threads=1, sql=None):
    """Runs the load and the calibration stages on a site's sample (a pyarrow.Table of camera,
    track_id, class, t, x, y[, estimated]); returns {name: pyarrow.Table} for every site table
    (site_table_names), plus "result_transforms" (transforms.csv) and "result_calibration"
    (calibration.csv). `sql` is accepted for compatibility and ignored: the statements come from
    the extension."""
    _integer_ids(points, "trajdb.windows.calibrate_site")
    con = connect(extension or _default_extension(), threads)
    try:
        con.register("trajdb_window_input", points)
        execute_steps(con, _plan(con, "site", params))
        out = {t: _arrow(con.sql(f"FROM {t}")) for t in site_table_names(con)}
        out["result_transforms"] = _arrow(con.sql("FROM result_transforms() ORDER BY cam_from, cam_to"))
        out["result_calibration"] = _arrow(con.sql("FROM result_calibration() ORDER BY scope, quantity"))
        return out
    finally:
        con.close()


def run_window(points, site, window_start, window_end, loaded_from, loaded_to, params=None, extension=None, threads=1, sql=None):
    """The pipeline on one window of a site: `points` are the complete tracks that touch
    [loaded_from, loaded_to] on the reference clock, `site` is calibrate_site()'s result.
    Returns {'road_users', 'matches', 'status'} (pyarrow.Tables): the road users whose first
    real observation lies in [window_start, window_end), their matches, and window_status
    (sql/window.sql: whether the halo held every kept road user's component)."""
    _integer_ids(points, "trajdb.windows.run_window")
    con = connect(extension or _default_extension(), threads)
    try:
        con.register("trajdb_window_input", points)
        for name in site_table_names(con):
            con.register("trajdb_site_table", site[name])
            con.execute(f"CREATE OR REPLACE TEMP TABLE {name} AS FROM trajdb_site_table")
            con.unregister("trajdb_site_table")
        for k, v in (("window_start", window_start), ("window_end", window_end), ("loaded_from", loaded_from), ("loaded_to", loaded_to)):
            con.execute(f"SET VARIABLE {k} = ?::DOUBLE", [float(v)])
        execute_steps(con, _plan(con, "window", params))
        road_users = _arrow(con.sql(
            """SELECT w.key AS road_user, w.first_seen,
                      coalesce(try(strftime(to_timestamp(w.first_seen), '%Y-%m-%d')), 'undated') AS date,
                      r.* EXCLUDE (road_user)
               FROM result_road_users() r JOIN window_road_users w USING (road_user)
               WHERE w.keep ORDER BY w.first_seen, w.key"""))
        matches = _arrow(con.sql(
            """SELECT w.key AS road_user,
                      coalesce(try(strftime(to_timestamp(w.first_seen), '%Y-%m-%d')), 'undated') AS date,
                      m.* EXCLUDE (road_user)
               FROM result_matches() m JOIN window_road_users w USING (road_user)
               WHERE w.keep ORDER BY camera_a, track_a, camera_b, track_b"""))
        status = _arrow(con.sql("FROM window_status"))
        return {"road_users": road_users, "matches": matches, "status": status}
    finally:
        con.close()


def _default_extension():
    from . import extension_path

    return extension_path()


def to_ipc(table):
    """A pyarrow.Table as Arrow IPC stream bytes (how a site's tables travel to the windows)."""
    sink = io.BytesIO()
    with pa.ipc.new_stream(sink, table.schema) as w:
        w.write_table(table)
    return sink.getvalue()


def from_ipc(data):
    return pa.ipc.open_stream(io.BytesIO(data)).read_all()
