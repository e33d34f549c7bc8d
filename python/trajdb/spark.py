"""trajdb on Apache Spark: the same pipeline, partitioned by site and time window.

    from trajdb import spark as tspark
    res = tspark.pipeline(points, window_s=3600)   # points: a Spark DataFrame with a `site` column
    res.road_users.show(); res.matches; res.transforms; res.calibration; res.windows
    tspark.write(res, "s3://bucket/trajdb")         # site=.../date=... Parquet, GeoParquet road users

`points` has the columns of `trajdb pipeline`'s input (camera, track_id, class, t, x, y and
optionally estimated; t in seconds or a TIMESTAMP) plus `site`. Every camera keeps its own frame
and clock, as on one machine.

How it runs (docs/spark.md has the why):
 1. calibration, once per site: `groupBy(site).applyInArrow` runs the calibration stages
    (windows.CALIBRATION_STAGES) on the site's first `calibrate_s` seconds (a day by default) or
    on `calibrate_on[site] = (t_from, t_to)`; the site tables come back to the driver (a few KB
    per site) and travel to every window of the site;
 2. windows: every track's span on the site's reference clock gives the windows it touches
    with their halo; the complete tracks of each (site, window) go to one
    `groupBy(site, window).applyInArrow` task, which opens DuckDB, loads the extension (sent with
    the job by SparkContext.addFile), runs the same SQL stages and keeps the road users first
    seen in the window (windows.run_window, sql/window.sql);
 3. a window whose halo did not hold a kept road user's whole component says so, and runs
    again with the halo it asked for (at most `max_rounds` rounds), so the result is the
    whole-site result, not an approximation at the seams.
Executors need `duckdb` (>= 1.5) and `pyarrow`; the trajdb package and its SQL are sent with
the job.
"""
import dataclasses
import json
import os
import re
import time
import zipfile

import pyarrow as pa

from . import _HERE
from . import windows as W

_POINT_COLS = ("camera", "track_id", "class", "t", "x", "y")


@dataclasses.dataclass
class Result:
    """The DataFrames of one run. road_users and matches carry site and date (the UTC date of the
    road user's first observation, when t is epoch seconds); transforms and calibration carry
    site; windows has one row per (site, window) task: its halo, rounds, points, road users,
    seconds and the task's peak memory."""
    road_users: object
    matches: object
    transforms: object
    calibration: object
    windows: object


# What the window tasks return: one row per road user, match or status, as nullable structs
# (Arrow types; Spark's schema is derived from them).
_POINT = pa.struct([("t", pa.float64()), ("x", pa.float64()), ("y", pa.float64())])
_ROAD_USER = pa.struct([
    ("road_user", pa.string()), ("first_seen", pa.float64()), ("date", pa.string()), ("class", pa.string()),
    ("n_tracks", pa.int64()), ("sources", pa.list_(pa.struct([("camera", pa.int32()), ("track_id", pa.int64())]))),
    ("t_start", pa.float64()), ("t_end", pa.float64()), ("duration_s", pa.float64()), ("length_m", pa.float64()),
    ("geometry", pa.binary()), ("traj", pa.list_(_POINT)), ("sigma_m", pa.float64()), ("sigma", pa.list_(pa.float64())),
    ("offsets", pa.list_(pa.struct([("camera", pa.int32()), ("track_id", pa.int64()), ("dx", pa.float64()), ("dy", pa.float64())]))),
])
_MATCH = pa.struct([
    ("road_user", pa.string()), ("date", pa.string()), ("camera_a", pa.int32()), ("track_a", pa.int64()),
    ("camera_b", pa.int32()), ("track_b", pa.int64()), ("score", pa.float64()), ("kind", pa.string()), ("class", pa.string()),
])
_STATUS = pa.struct([
    ("round", pa.int64()), ("window_start", pa.float64()), ("window_end", pa.float64()), ("halo_before_s", pa.float64()), ("halo_after_s", pa.float64()),
    ("points", pa.int64()), ("tracks", pa.int64()), ("kept", pa.int64()), ("need_before_s", pa.float64()),
    ("need_after_s", pa.float64()), ("complete", pa.bool_()), ("seconds", pa.float64()), ("peak_rss_mb", pa.float64()),
])
_WINDOW_OUT = pa.schema([("site", pa.string()), ("window", pa.int64()), ("road_user", _ROAD_USER), ("match", _MATCH), ("status", _STATUS)])
_SITE_OUT = "site string, name string, data binary"


def _spark_schema(schema):
    from pyspark.sql.pandas.types import from_arrow_schema

    return from_arrow_schema(schema)


def _geo_metadata(extension=None):
    """GeoParquet metadata of merged.parquet, read from sql/export.sql as the extension embeds
    it (one definition)."""
    con = W.connect(extension or W._default_extension())
    try:
        text = "\n".join(r[0] for r in con.execute("SELECT sql FROM trajdb_script('sql/export.sql') ORDER BY k").fetchall())
    finally:
        con.close()
    m = re.search(r"KV_METADATA \{geo: '([^']*)'\}", text)
    return m.group(1)


def _package_zip():
    """The trajdb Python modules as a zip for SparkContext.addPyFile: executors import them from
    there. The SQL travels inside the tasks (windows.sql_texts(), read on the driver), the
    extension file by SparkContext.addFile."""
    import tempfile

    d = tempfile.mkdtemp(prefix="trajdb-spark-")
    path = os.path.join(d, "trajdb_pkg.zip")
    with zipfile.ZipFile(path, "w") as z:
        for name in sorted(os.listdir(_HERE)):
            if name.endswith(".py"):
                z.write(os.path.join(_HERE, name), f"trajdb/{name}")
    return path


def _fail_once(kind, key):
    """Fault injection for the tests (TRAJDB_SPARK_FAIL_ONCE=dir in the executors' environment):
    the first attempt of every task of `kind` fails after doing the work of one group (noted in
    dir); Spark's retry must neither lose nor duplicate output. A file `always-<kind>-<key>` in
    dir makes that task fail every attempt."""
    d = os.environ.get("TRAJDB_SPARK_FAIL_ONCE")
    if not d:
        return
    if os.path.exists(os.path.join(d, f"always-{kind}-{key}")):  # a task that fails every attempt
        raise RuntimeError(f"trajdb.spark: injected failure of {kind} task {key}, every attempt (TRAJDB_SPARK_FAIL_ONCE)")
    from pyspark import TaskContext

    tc = TaskContext.get()
    if tc is not None and tc.attemptNumber() == 0:
        open(os.path.join(d, f"{kind}-{key}-stage{tc.stageId()}-part{tc.partitionId()}".replace("/", "_")), "w").close()
        raise RuntimeError(f"trajdb.spark: injected failure of {kind} task {key} (TRAJDB_SPARK_FAIL_ONCE)")


def _peak_rss_mb():
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _typed(points):
    """The input columns in the types the pipeline reads, t as seconds."""
    from pyspark.sql import functions as F
    from pyspark.sql import types as T

    cols = set(points.columns)
    missing = [c for c in ("site",) + _POINT_COLS if c not in cols]
    if missing:
        raise ValueError(f"trajdb.spark.pipeline: points has no column {', '.join(missing)} (its columns: {', '.join(points.columns)})")
    t = points.schema["t"].dataType
    if isinstance(t, T.TimestampType):
        tcol = F.unix_micros(F.col("t")).cast("double") / 1e6
    elif isinstance(t, (T.TimestampNTZType, T.DateType)):
        # a timestamp without time zone is UTC, as in the pipeline (epoch(t::TIMESTAMP))
        tz = points.sparkSession.conf.get("spark.sql.session.timeZone")
        tcol = F.unix_micros(F.to_utc_timestamp(F.col("t").cast("timestamp"), tz)).cast("double") / 1e6
    elif isinstance(t, T.NumericType):
        tcol = F.col("t").cast("double")
    else:
        raise ValueError(f"trajdb.spark.pipeline: column t is {t.simpleString()}, not a number (seconds) or a TIMESTAMP")
    for c in ("camera", "track_id"):
        # a text id cast to int would be NULL (or an error, by spark.sql.ansi.enabled): refused
        # here by name, as trajdb.windows refuses it (trajdb.pipeline on a whole site accepts text ids)
        if not isinstance(points.schema[c].dataType, T.IntegralType):
            raise ValueError(f"trajdb.spark.pipeline: {c} must be an integer column (got {points.schema[c].dataType.simpleString()}); "
                             "number your ids first (trajdb.pipeline on a whole site accepts text ids)")
    est = F.col("estimated").cast("int") if "estimated" in cols else F.lit(0)
    return points.select(
        F.col("site").cast("string").alias("site"), F.col("camera").cast("int").alias("camera"),
        F.col("track_id").cast("long").alias("track_id"), F.col("class").cast("string").alias("class"),
        tcol.alias("t"), F.col("x").cast("double").alias("x"), F.col("y").cast("double").alias("y"),
        F.coalesce(est, F.lit(0)).cast("int").alias("estimated"),
    )


def _defaults(params, extension=None):
    """The parameter values a run uses (sql/params.sql's defaults under `params`, checked by the
    extension's declared parameter table)."""
    con = W.connect(extension or W._default_extension())
    W.execute_steps(con, [s for s in W.stages(con, "x", **params) if s[0] == "params"])
    W.read(con, "sql/params.sql")
    return {k: con.execute(f"SELECT getvariable('{k}')").fetchone()[0] for k in ("merge_time_window", "quality_max_gap")}


def pipeline(points, window_s=3600.0, halo_s=None, calibrate_s=86400.0, calibrate_on=None, params=None,
             extension=None, threads_per_task=1, max_rounds=6):
    """Runs the pipeline on `points` (a Spark DataFrame with a site column), per (site,
    window_s-second window), and returns a Result of DataFrames (computed lazily; `write`
    stores them). `halo_s`: the halo on each side of a window (default: measured per site,
    see docs/spark.md); `calibrate_on`: {site: (t_from, t_to)} to calibrate each site on a given
    window of its own clocks instead of its first `calibrate_s` seconds; `params`: pipeline
    parameters as in `trajdb params`."""
    from pyspark.sql import functions as F

    if not (isinstance(window_s, (int, float)) and 1.0 <= window_s <= 1e9):
        raise ValueError(f"trajdb.spark.pipeline: window_s must lie in [1, 1e9] seconds, got {window_s!r}")
    if halo_s is not None and not (isinstance(halo_s, (int, float)) and 0.0 <= halo_s <= 1e9):
        raise ValueError(f"trajdb.spark.pipeline: halo_s must lie in [0, 1e9] seconds, got {halo_s!r}")
    if not (isinstance(max_rounds, int) and max_rounds >= 1):
        raise ValueError(f"trajdb.spark.pipeline: max_rounds must be an integer >= 1, got {max_rounds!r}")
    window_s = float(window_s)
    spark = points.sparkSession
    sc = spark.sparkContext
    params = dict(params or {})
    reach = max(v for v in _defaults(params, extension).values())
    ext = os.path.abspath(extension or W._default_extension())
    sc.addFile(ext)
    sc.addPyFile(_package_zip())
    ext_name = os.path.basename(ext)
    sql = None  # the statements come from the extension inside each task (trajdb_stages)
    pts = _typed(points)
    n_rows, n_null_site = pts.agg(F.count(F.lit(1)), F.count(F.when(F.col("site").isNull(), 1))).first()
    if n_rows == 0:
        raise ValueError("trajdb.spark.pipeline: points has no rows")
    if n_null_site:
        raise ValueError(f"trajdb.spark.pipeline: {n_null_site} of {n_rows} rows have a NULL site; drop or fill them first")

    # 1. calibration once per site
    if calibrate_on:
        cond = None
        for s, (a, b) in calibrate_on.items():
            c = (F.col("site") == str(s)) & (F.col("t") >= float(a)) & (F.col("t") < float(b))
            cond = c if cond is None else cond | c
        sample = pts.where(cond)
    else:
        first = pts.groupBy("site").agg(F.min("t").alias("t_first"))
        sample = pts.join(F.broadcast(first), "site").where(F.col("t") < F.col("t_first") + float(calibrate_s)).drop("t_first")

    def calibrate(table):
        from pyspark import SparkFiles

        site = table.column("site")[0].as_py()
        try:
            tables = W.calibrate_site(table.drop_columns(["site"]), params, SparkFiles.get(ext_name), threads_per_task, sql)
        except Exception as e:
            raise RuntimeError(f"trajdb.spark: site {site}: calibration failed: {e}") from e
        names = sorted(tables)
        return pa.table({"site": [site] * len(names), "name": names, "data": [W.to_ipc(tables[n]) for n in names]})

    site_rows = sample.groupBy("site").applyInArrow(calibrate, _SITE_OUT).collect()
    sites = {}
    for r in site_rows:
        sites.setdefault(r["site"], {})[r["name"]] = bytes(r["data"])
    missing = [r["site"] for r in pts.select("site").distinct().collect() if r["site"] not in sites]
    if missing:
        raise ValueError(f"trajdb.spark.pipeline: sites {sorted(missing)} have no points in their calibration window")
    offsets = []
    for s, t in sites.items():
        for r in W.from_ipc(t["align_frames"]).select(["camera", "clock_offset_s", "clock_drift"]).to_pylist():
            offsets.append((s, int(r["camera"]), float(r["clock_offset_s"] or 0.0), float(r["clock_drift"] or 0.0)))
    off_df = spark.createDataFrame(offsets, "site string, camera int, clock_offset_s double, clock_drift double")

    # 2. every track's span on its site's reference clock, by the extension's clock model
    # (clock_to_reference, crates/algo/src/align/clock.rs: what align.sql does to every point)
    def on_reference_clock(table):
        from pyspark import SparkFiles

        con = W.connect(SparkFiles.get(ext_name), threads_per_task)
        con.register("trajdb_spans", table)
        # the window of the first real observation: clock_window, the k with k*W <= t0_real <
        # (k+1)*W in the same doubles as each task's [k*W, (k+1)*W) (crates/algo/src/traj/grid.rs)
        return W._arrow(con.sql(
            "SELECT site, camera, track_id, t0, t1, t0_real, clock_window(t0_real, ?) AS window FROM ("
            "SELECT site, camera, track_id, clock_to_reference(t0, off, drift) AS t0, clock_to_reference(t1, off, drift) AS t1, "
            "clock_to_reference(t0_real, off, drift) AS t0_real FROM trajdb_spans)", params=[window_s]))

    tracks = (
        pts.groupBy("site", "camera", "track_id")
        .agg(F.min("t").alias("t0"), F.max("t").alias("t1"), F.min(F.when(F.col("estimated") == 0, F.col("t"))).alias("t0_real"))
        .join(F.broadcast(off_df), ["site", "camera"], "left")
        .select("site", "camera", "track_id", "t0", "t1", "t0_real", F.coalesce("clock_offset_s", F.lit(0.0)).alias("off"),
                F.coalesce("clock_drift", F.lit(0.0)).alias("drift"))
        .groupBy("site").applyInArrow(on_reference_clock,
                                       "site string, camera int, track_id long, t0 double, t1 double, t0_real double, window long")
    ).cache()
    if halo_s is None:
        # before: the reach of a candidate link; after: the longest usual track too (p99 per
        # site); a window whose road users reach further asks for more (round 2)
        halos = {
            r["site"]: (reach, float(r["p99"] or 0.0) + reach)
            for r in tracks.groupBy("site").agg(F.percentile_approx(F.col("t1") - F.col("t0"), 0.99).alias("p99")).collect()
        }
    else:
        halos = {s: (max(float(halo_s), reach), max(float(halo_s), reach)) for s in sites}

    # the windows that hold a first real observation (clock_window, above)
    starts = tracks.where(F.col("t0_real").isNotNull()).select("site", "window").distinct()

    def window_task(plan, round_no):
        """plan: {(site, window): (halo_before, halo_after)} -> the task for applyInArrow"""

        def run(table):
            from pyspark import SparkFiles

            t_start = time.perf_counter()
            site = table.column("site")[0].as_py()
            win = table.column("window")[0].as_py()
            hb, ha = plan[(site, win)] if (site, win) in plan else halos[site]
            ws, we = win * window_s, (win + 1) * window_s
            pts_w = table.drop_columns(["site", "window"])
            if pts_w.num_rows == 0:
                return _arrow_schema.empty_table()
            try:
                out = W.run_window(pts_w, {n: W.from_ipc(b) for n, b in site_tables[site].items()},
                                   ws, we, ws - hb, we + ha, params, SparkFiles.get(ext_name), threads_per_task, sql)
            except Exception as e:
                raise RuntimeError(f"trajdb.spark: site {site}, window [{ws}, {we}): {e}") from e
            _fail_once("window", f"{site}-{win}")
            st = out["status"].to_pylist()[0]
            status = {
                "round": round_no, "window_start": ws, "window_end": we, "halo_before_s": hb, "halo_after_s": ha, "points": pts_w.num_rows,
                "tracks": len(set(zip(pts_w.column("camera").to_pylist(), pts_w.column("track_id").to_pylist()))),
                "kept": st["kept"], "need_before_s": st["halo_before_s"], "need_after_s": st["halo_after_s"],
                "complete": st["complete"], "seconds": time.perf_counter() - t_start, "peak_rss_mb": _peak_rss_mb(),
            }
            ru = out["road_users"] if st["complete"] else out["road_users"].slice(0, 0)
            ma = out["matches"] if st["complete"] else out["matches"].slice(0, 0)
            nr, nm = ru.num_rows, ma.num_rows
            n = nr + nm + 1
            return pa.table(
                [pa.array([site] * n, pa.string()), pa.array([win] * n, pa.int64()),
                 pa.concat_arrays([_struct(ru, _arrow_schema.field("road_user").type), pa.nulls(nm + 1, _arrow_schema.field("road_user").type)]),
                 pa.concat_arrays([pa.nulls(nr, _arrow_schema.field("match").type), _struct(ma, _arrow_schema.field("match").type),
                                   pa.nulls(1, _arrow_schema.field("match").type)]),
                 pa.concat_arrays([pa.nulls(nr + nm, _arrow_schema.field("status").type), pa.array([status], _arrow_schema.field("status").type)])],
                schema=_arrow_schema,
            )

        return run

    site_tables = sites
    _arrow_schema = _WINDOW_OUT
    track_cols = ["site", "camera", "track_id", "t0", "t1"]

    def run_round(plan, round_no, only=None):
        """Every (site, window) with a first observation (or only those in `only`), each with its
        halo, as one applyInArrow over the complete tracks that touch it."""
        if only:
            h = spark.createDataFrame([(s, int(w), hb, ha) for (s, w), (hb, ha) in plan.items()], "site string, window bigint, hb double, ha double")
            hmax = h.groupBy("site").agg(F.max("hb").alias("hb"), F.max("ha").alias("ha"))
        else:
            hmax = spark.createDataFrame([(s, hb, ha) for s, (hb, ha) in halos.items()], "site string, hb double, ha double")
        # the windows a track may touch with the widest halo of its site (an equi-join on
        # (site, window) after this, never a range join of tracks against windows) ...
        cand = tracks.select(*track_cols).join(F.broadcast(hmax), "site").withColumn(
            "window", F.explode(F.sequence(F.floor((F.col("t0") - F.col("ha")) / window_s) - 1, F.floor((F.col("t1") + F.col("hb")) / window_s) + 1)))
        if only:
            cand = cand.drop("hb", "ha").join(F.broadcast(h), ["site", "window"])
        else:
            cand = cand.join(starts, ["site", "window"], "left_semi")
        # ... and the exact test: track [t0, t1] meets [k*W - hb, (k+1)*W + ha]
        tw = cand.where((F.col("t1") >= F.col("window") * window_s - F.col("hb"))
                        & (F.col("t0") <= (F.col("window") + 1) * window_s + F.col("ha"))).select("site", "camera", "track_id", "window")
        grouped = pts.join(tw, ["site", "camera", "track_id"]).select("site", "window", *_POINT_COLS, "estimated")
        return grouped.groupBy("site", "window").applyInArrow(window_task(plan, round_no), _spark_schema(_WINDOW_OUT))

    # 3. rounds: windows that asked for a wider halo run again with it
    results = []
    plan = {}
    res = run_round(plan, 1).cache()
    for round_no in range(1, max_rounds + 1):
        results.append(res)
        todo = res.where(F.col("status").isNotNull() & ~F.col("status.complete")).select("site", "window", "status").collect()
        if not todo:
            break
        if round_no == max_rounds:
            bad = ", ".join(f"{r['site']}/{r['window']}" for r in todo[:5])
            raise RuntimeError(
                f"trajdb.spark.pipeline: {len(todo)} windows ({bad}) still lack a complete halo after {max_rounds} rounds; "
                "raise max_rounds or halo_s"
            )
        plan = {
            (r["site"], r["window"]): (max(r["status"]["need_before_s"] * 1.25, r["status"]["halo_before_s"] * 2),
                                       max(r["status"]["need_after_s"] * 1.25, r["status"]["halo_after_s"] * 2))
            for r in todo
        }
        res = run_round(plan, round_no + 1, only=True).cache()
    allres = results[0]
    for r in results[1:]:
        allres = allres.unionByName(r)
    road_users = allres.where(F.col("road_user").isNotNull()).select("site", "road_user.*")
    road_users = road_users.select("site", "date", *[c for c in road_users.columns if c not in ("site", "date")])
    matches = allres.where(F.col("match").isNotNull()).select("site", "match.*")
    matches = matches.select("site", "date", *[c for c in matches.columns if c not in ("site", "date")])
    windows = allres.where(F.col("status").isNotNull()).select("site", "window", "status.*")

    def site_df(name):
        tabs = [W.from_ipc(t[name]) for t in sites.values()]
        rows = []
        for s, tab in zip(sites, tabs):
            rows += [{"site": s, **r} for r in tab.to_pylist()]
        return spark.createDataFrame(rows, _spark_schema(pa.schema([("site", pa.string())] + list(tabs[0].schema))))

    return Result(road_users, matches, site_df("result_transforms"), site_df("result_calibration"), windows)


def _struct(table, struct_type):
    """The rows of `table` as one StructArray of `struct_type` (fields by name, cast)."""
    cols = [table.column(f.name).combine_chunks().cast(f.type) if table.num_rows else pa.array([], f.type) for f in struct_type]
    return pa.StructArray.from_arrays(cols, fields=list(struct_type))


# What write() puts into its folder: the only entries it may delete there.
_OUTPUT_ENTRIES = ("road_users", "matches", "transforms", "calibration", "_SUCCESS")


def write(result, path, mode="overwrite"):
    """Writes a Result as partitioned Parquet under `path` (a local path or any URI pyarrow.fs
    reaches: s3://, gs://, hdfs://):
        road_users/site=S/date=D/part-0.parquet   GeoParquet 1.1, as merged.parquet
        matches/site=S/date=D/part-0.parquet
        transforms/site=S/part-0.parquet, calibration/site=S/part-0.parquet
        _SUCCESS                                   written last
    One file per partition, named by the partition: a task that Spark retries writes the same
    file again (into a temporary name, then moved into place), so output is never duplicated.
    mode 'overwrite' replaces an earlier result set in `path` (only the entries above are deleted);
    a folder holding anything else is refused."""
    from pyarrow import fs as pafs

    if mode not in ("overwrite", "error"):
        raise ValueError(f"trajdb.spark.write: mode is 'overwrite' or 'error', got {mode!r}")
    filesystem, root = pafs.FileSystem.from_uri(path if "://" in path else os.path.abspath(path))
    info = filesystem.get_file_info(root)
    if info.type == pafs.FileType.File:
        raise FileExistsError(f"trajdb.spark.write: {path} is a file; name a folder for the results")
    if info.type == pafs.FileType.Directory:
        # only an earlier trajdb result set is replaced, and only its own entries are deleted:
        # a folder holding anything else (the user's files) is refused, whatever the mode
        entries = filesystem.get_file_info(pafs.FileSelector(root, recursive=False))
        names = {e.base_name for e in entries}
        foreign = sorted(names - set(_OUTPUT_ENTRIES))
        if foreign:
            raise FileExistsError(
                f"trajdb.spark.write: {path} holds files that trajdb did not write (e.g. {foreign[0]!r}); "
                "write into a new folder, an empty one, or one with earlier trajdb results"
            )
        if names and mode == "error":
            raise FileExistsError(f"trajdb.spark.write: {path} holds earlier results (mode='overwrite' replaces them)")
        if "_SUCCESS" in names:
            filesystem.delete_file(f"{root}/_SUCCESS")  # first: a half-replaced set is never marked complete
        for e in entries:
            if e.base_name in _OUTPUT_ENTRIES and e.type == pafs.FileType.Directory:
                filesystem.delete_dir(e.path)
    filesystem.create_dir(root)
    geo = _geo_metadata()
    for name, df, parts, order in (
        ("road_users", result.road_users, ["site", "date"], ["first_seen", "road_user"]),
        ("matches", result.matches, ["site", "date"], ["camera_a", "track_a", "camera_b", "track_b"]),
        ("transforms", result.transforms, ["site"], ["cam_from", "cam_to"]),
        ("calibration", result.calibration, ["site"], ["scope", "quantity"]),
    ):
        _write_table(df, path, root, name, parts, order, geo if name == "road_users" else None)
    with filesystem.open_output_stream(f"{root}/_SUCCESS") as f:
        f.write(b"")


def _write_table(df, uri, root, name, parts, order, geo):
    schema = f"{', '.join(p + ' string' for p in parts)}, file string, rows bigint"
    location = uri if "://" in uri else os.path.abspath(uri)

    def write_group(table):
        import uuid
        from urllib.parse import quote

        import pyarrow.parquet as pq
        from pyarrow import fs as pafs

        filesystem, base = pafs.FileSystem.from_uri(location)
        keys = [table.column(p)[0].as_py() for p in parts]
        # hive partition folders, the value URI-escaped as Spark and pyarrow read it back
        d = "/".join([f"{base}/{name}"] + [f"{p}={quote(str(k), safe='')}" for p, k in zip(parts, keys)])
        data = table.drop_columns(parts).sort_by([(c, "ascending") for c in order])
        if geo is not None:
            data = data.replace_schema_metadata({**(data.schema.metadata or {}), b"geo": geo.encode()})
        filesystem.create_dir(d)
        final, tmp = f"{d}/part-0.parquet", f"{d}/.part-0.parquet.{uuid.uuid4().hex}.tmp"
        with filesystem.open_output_stream(tmp) as f:
            pq.write_table(data, f)
        filesystem.move(tmp, final)  # a retried task replaces the file: never two copies
        _fail_once("write", f"{name}-{'-'.join(map(str, keys))}")
        return pa.table({**{p: [k] for p, k in zip(parts, keys)}, "file": [final], "rows": [data.num_rows]})

    df.groupBy(*parts).applyInArrow(write_group, schema).collect()


def geo_json():
    """The GeoParquet metadata (a dict) that road_users files carry."""
    return json.loads(_geo_metadata())


def _archive_task(task, ext_name):
    """One site-day of trajdb.archives in a Spark task: the extension from SparkFiles."""
    from pyspark import SparkFiles

    from trajdb import archives

    res = archives.run_task({**task, "extension": SparkFiles.get(ext_name)})
    _fail_once("archive", f"{task['site']}-{task['date']}")
    return res


def _task_failure(e):
    """Whether a Spark job failed because one of its tasks failed every attempt (Spark's "Job
    aborted due to stage failure"), rather than the driver or the cluster (a stopped context, a
    cancelled job: those stop the run, and no partition is marked failed for them)."""
    return "Job aborted due to stage failure" in str(e)


def archive(spark, lake, out, params=None, site=None, extension=None, progress=True, task_memory=None):
    """`trajdb archive` with Spark running the site-days (python/trajdb/archives.py; docs/archive.md):
    the same lake layout in, the same archive folder out (OUT must be a path the driver and the
    executors share), the same per-site-day work (archives.run_task: the kept calibration, the
    daily camera-change check, one DuckDB thread per task) and the same state, so that a run
    here and `trajdb archive` give the same files (tests/test_spark.py checks it). The driver
    plans, Spark runs each round's site-days as tasks, the driver commits them."""
    from . import archives

    sc = spark.sparkContext
    ext = os.path.abspath(extension or W._default_extension())
    sc.addFile(ext)
    sc.addPyFile(_package_zip())
    ext_name = os.path.basename(ext)

    def executor(tasks, on_done):
        if not tasks:
            return
        rdd = sc.parallelize(tasks, len(tasks))
        try:
            results = rdd.map(lambda t: _archive_task(t, ext_name)).collect()
        except Exception as e:  # noqa: BLE001 - a task failed every attempt (its worker killed, say): Spark fails the whole job
            if not _task_failure(e):
                raise  # not a task's failure (a stopped context, a cancelled job): the run stops, no partition is marked
            results = None
        if results is not None:
            for res in results:
                on_done(res)
            return
        # each site-day again as a job of its own, so that the one that fails every attempt fails
        # alone (the others' results are the same bytes: one thread per task)
        for t in tasks:
            try:
                [res] = sc.parallelize([t], 1).map(lambda t: _archive_task(t, ext_name)).collect()
            except Exception as e:  # noqa: BLE001 - this partition failed, the others go on
                if not _task_failure(e):
                    raise
                first = next((ln.strip() for ln in str(e).splitlines() if ln.strip()), type(e).__name__)
                res = archives.failed_result(t, f"its Spark task failed every attempt: {first[:500]}")
            on_done(res)

    return archives.run(lake, out, params=params, site=site, extension=ext, progress=progress, executor=executor, task_memory=task_memory)
