"""The pipeline on one part of a large archive: a site's calibration once, then (site, window)
parts that reuse it. Pure DuckDB + pyarrow (no Spark): `trajdb.spark` calls these inside its
tasks, and any other scheduler can too.

    site = calibrate_site(site_points)                     # dict: table name -> pyarrow.Table
    out = run_window(window_points, site, start, end, loaded_from, loaded_to)
    out["road_users"], out["matches"], out["status"]

How a window stays identical to a run on the whole site is explained in sql/window.sql; the
halo rule is in the README ("Scaling out with Spark").

The stages are the same SQL files as `trajdb pipeline` (sql/stages.sql). What a site computes
once is named here, in SITE_TABLES: a window loads those tables instead of running the
statements that make them. Everything else a stage makes is computed per window.
"""
import io
import re

import duckdb
import pyarrow as pa

from . import _parts, _literal, check_duckdb, set_params, sql_file

# Made once per site (calibrate.sql, align.sql, overlap.sql, and the camera views of
# quality.sql) and shipped to every window of the site: the sampling periods and noise, the
# derived parameters, the cameras' transforms and clock offsets, the view polygons and their
# overlaps. Measuring any of them on one window instead would change the results.
SITE_TABLES = (
    "calib_cameras", "calib_classes", "calib_pairs", "calibration", "calib_fit_window", "quality_views", "quality_start_density",
    "align_frames", "align_origin", "calib_match", "calibration_summary",
    "view_polygons", "view_overlaps", "view_merge_order", "view_overlaps_chain",
)
# Intermediate tables (and macros) of the site's alignment: made by the site run only, never shipped.
SITE_WORK_TABLES = ("align_centroids", "align_scan", "align_hypotheses", "align_vote", "align_widen", "align_hyp_wide", "align_best_wide", "align_tracks", "align_hyp", "align_best", "align_support", "align_refit", "align_pairs", "align_edges", "view_points",
                    "align_keys", "align_activity", "align_coarse", "align_clock", "align_wls",
                    "align_drift_obs", "align_drift_pairs", "align_drift_fit1", "align_drift_kept", "align_drift",
                    "align_retry", "align_speed_votes", "align_speed", "align_sample", "align_scan_pass", "align_speed_scan")
# The stages a site's calibration runs (and nothing after them); windows skip clustering, which
# is an analysis of a whole period, not of a window (run traj_cluster on the road users).
CALIBRATION_STAGES = ("calibrate", "clean", "quality", "align", "overlap")
WINDOW_SKIPS_STAGES = ("cluster",)

_TARGET = re.compile(r"^\s*(?:CREATE\s+OR\s+REPLACE\s+TEMP\s+(?:TABLE|MACRO)|DELETE\s+FROM|UPDATE|INSERT\s+INTO)\s+(\w+)", re.I)


def _strip_comments(q):
    return "\n".join(line for line in q.splitlines() if not line.lstrip().startswith("--"))


def statement_target(query):
    """The table a statement creates or changes (None for a query)."""
    m = _TARGET.match(_strip_comments(query))
    return m.group(1).lower() if m else None


def connect(extension, threads=1):
    """An in-memory DuckDB with the extension file loaded; `threads` per task (a Spark task has one core)."""
    check_duckdb()
    con = duckdb.connect(":memory:", config={"allow_unsigned_extensions": "true", "threads": threads})
    con.execute(f"LOAD {_literal(extension)}")
    return con


def _set_params(con, params):
    set_params(con, params, "trajdb.windows")


def _run(con, text, skip=()):
    for stmt in con.extract_statements(text):
        if skip and statement_target(stmt.query) in skip:
            continue
        con.execute(stmt.query).fetchall()


def _arrow(rel):
    return rel.to_arrow_table()  # DuckDB 1.5 and 2.0


def _load_points(con, points, params):
    """The pipeline's load step (sql/pipeline.sql up to the stages) on an Arrow table."""
    _set_params(con, params)
    con.register("trajdb_window_input", points)
    con.execute("SET VARIABLE pipeline_input = 'trajdb_window_input'")


def sql_texts():
    """The SQL a site or window run executes, read once (trajdb.spark reads it on the driver and
    sends it with the tasks, so executors need no SQL files)."""
    return {"parts": _parts("sql/pipeline.sql", []), "window": sql_file("sql/window.sql")}


def calibrate_site(points, params=None, extension=None, threads=1, sql=None):
    """Runs load and the stages CALIBRATION_STAGES on a site's sample (a pyarrow.Table of
    camera, track_id, class, t, x, y[, estimated]); returns {name: pyarrow.Table} for every
    SITE_TABLES name, plus "result_transforms" (transforms.csv) and "result_calibration" (calibration.csv)."""
    sql = sql or sql_texts()
    con = connect(extension or _default_extension(), threads)
    try:
        _load_points(con, points, params)
        for name, text in sql["parts"]:
            if name == "load" or name in CALIBRATION_STAGES:
                _run(con, text)
        out = {t: _arrow(con.sql(f"FROM {t}")) for t in SITE_TABLES}
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
    sql = sql or sql_texts()
    con = connect(extension or _default_extension(), threads)
    try:
        _load_points(con, points, params)
        for name in SITE_TABLES:
            con.register("trajdb_site_table", site[name])
            con.execute(f"CREATE OR REPLACE TEMP TABLE {name} AS FROM trajdb_site_table")
            con.unregister("trajdb_site_table")
        skip = set(SITE_TABLES) | set(SITE_WORK_TABLES)
        for name, text in sql["parts"]:
            if name not in WINDOW_SKIPS_STAGES:
                _run(con, text, skip if name != "load" else ())
        for k, v in (("window_start", window_start), ("window_end", window_end), ("loaded_from", loaded_from), ("loaded_to", loaded_to)):
            con.execute(f"SET VARIABLE {k} = {float(v)!r}::DOUBLE")
        _run(con, sql["window"])
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
