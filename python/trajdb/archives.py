"""trajdb on an archive: site=S/date=D partitions in, partitioned results out, incremental and
resumable (issue 40; docs/archive.md).

    trajdb archive --input LAKE --out OUT          # the command line
    trajdb.archive(con, LAKE, out=OUT)             # Python (trajdb.archives.run(LAKE, OUT) without a connection)
    trajdb.spark.archive(spark, LAKE, OUT)         # the same work as Spark tasks

LAKE holds Parquet or CSV files under site=S/date=D/ folders (hive style), or date=D/ folders of
one site (named by --site, else the folder's name), or date=D/ folders whose files have a `site`
column. OUT receives, per site and day, Hive-partitioned Parquet that DuckDB and Spark read as
one table each (`read_parquet('OUT/road_users/*/*/*.parquet', hive_partitioning = true)`):

    road_users/site=S/date=D/part-0.parquet     merged.parquet of the day (GeoParquet)
    matches/, links/, transforms/, calibration/  the day's matches.csv, links.csv, ... as Parquet
    reports/site=S/date=D/report.html           the day's report; reports/site=S/index.html the site's
    _calibrations/site=S/from=D/                the site's calibration made from day D (kept)
    _state/partitions.parquet                   what was processed from which input (the state)
    _state/runs.csv                             one line per partition run: seconds, peak memory

How a day runs (`run_task`: the extension's trajdb_archive_task, src/archive.rs, the same function
in a worker process, a Spark task and `CALL trajdb_archive`):
 1. the site's calibration in effect (made from an earlier day, or from this one when the site
    has none) is loaded instead of measured: the pipeline's 'day' part (crates/app/src/plan.rs);
 2. the day's matches re-register every camera pair (sql/archive_check.sql); a pair that moved
    by more than archive_change_z standard errors since the calibration day (frame_change), a
    pair whose matches collapsed, or a camera the calibration never saw is a camera change: the
    site is calibrated again from this day, the day runs again on it, and the change is kept in
    the state (which cameras, which day, by how much), the site's report and a warning;
 3. the results go to a scratch folder of the task; the driver moves each file into place
    (os.replace: a reader sees the old file or the new one, never a part) and then records the
    partition in the state. A run killed at any moment leaves partitions that are either
    recorded with their files or not recorded: the next run computes those again, and since a
    day's result depends only on its input and the calibration in effect (one thread per task),
    the result is the same bytes as an uninterrupted run.

Incremental: a partition is done when the state holds it, not failed, with the same input (names, sizes,
modification times; a content fingerprint when those differ), trajdb version, parameters and
calibration in effect. Days are chained per site in date order: a day whose calibration in
effect changed (an earlier day re-registered a camera) runs again. Days run optimistically in
parallel (each with the calibration in effect before the run); the chain is walked again after
them, and the few days a change invalidated run again, until nothing changes (in practice one
round, two when a camera moved).

Files are the user's: OUT must be new, empty, or an archive trajdb made (its `.trajdb-archive`
marker); trajdb replaces only the files it wrote there, and removes only its own scratch folders
(_work/task-*). LAKE is only read.
"""
import datetime
import hashlib
import json
import os
import re
import shutil
import sys
import time

import duckdb
import pyarrow as pa
import pyarrow.parquet as pq

from . import __version__, _literal, check_duckdb, stages
from . import windows as W

MARKER = ".trajdb-archive"
MARKER_HEAD = "# trajdb archive 1: this folder and the files below it were written by trajdb archive; it replaces only its own files\n"
# the per-day result files: (folder, file name in the task's scratch, what it is)
TABLES = (
    ("road_users", "road_users.parquet", "one row per road user: merged.parquet of the day (GeoParquet)"),
    ("matches", "matches.parquet", "the accepted cross-camera links (matches.csv)"),
    ("links", "links.parquet", "each track's chain of pieces within its camera (links.csv)"),
    ("transforms", "transforms.parquet", "each camera pair's transform and clock relation in effect (transforms.csv)"),
    ("calibration", "calibration.parquet", "what the day's run measured and derived (calibration.csv)"),
)
REPORT = ("reports", "report.html")
STATE_COLUMNS = (
    ("site", pa.string()), ("date", pa.string()), ("status", pa.string()), ("inputs", pa.string()), ("fingerprint", pa.string()),
    ("trajdb_version", pa.string()), ("params", pa.string()), ("calibration_in", pa.string()), ("calibration_out", pa.string()),
    ("calibration_made", pa.bool_()), ("changes", pa.string()), ("cameras", pa.int64()), ("points", pa.int64()),
    ("road_users", pa.int64()), ("matches", pa.int64()), ("checks", pa.string()), ("warnings", pa.string()), ("error", pa.string()),
)
STATE_SCHEMA = pa.schema(STATE_COLUMNS)
_KEY = re.compile(r"^(site|date)=(.+)$")
_DATA = (".parquet", ".csv", ".csv.gz")


class ArchiveError(Exception):
    """A refusal before any work (the folders, the lake's layout): names what and how to fix it."""


# --- the lake ---------------------------------------------------------------------------------


def _data_files(folder):
    """The data files of one partition folder (recursively; hidden and _ names skipped), sorted."""
    out = []
    for root, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if not d.startswith((".", "_")))
        for f in sorted(files):
            if not f.startswith((".", "_")) and f.lower().endswith(_DATA):
                out.append(os.path.join(root, f))
    return out


def discover(lake, site=None, con=None):
    """The partitions of `lake`: a list of dicts {site, date, files, format, site_column} sorted
    by site and date. Layouts: site=S/date=D/, or date=D/ (one site: `site`, else the lake
    folder's name; or files with a `site` column, split by its values)."""
    lake = os.path.abspath(lake)
    if not os.path.isdir(lake):
        raise ArchiveError(f"trajdb archive: the input {lake!r} is not a folder; give the lake's root folder (site=S/date=D/ partitions)")
    parts = []
    top = sorted(e for e in os.listdir(lake) if not e.startswith((".", "_")))
    sites = [(m.group(2), os.path.join(lake, e)) for e in top if (m := _KEY.match(e)) and m.group(1) == "site" and os.path.isdir(os.path.join(lake, e))]
    dates_top = [e for e in top if (m := _KEY.match(e)) and m.group(1) == "date"]
    if sites and dates_top:
        raise ArchiveError(f"trajdb archive: {lake!r} mixes site= and date= folders at its top; give one layout (site=S/date=D/ or date=D/)")
    if sites:
        for s, folder in sites:
            for e in sorted(os.listdir(folder)):
                m = _KEY.match(e)
                if m and m.group(1) == "date" and os.path.isdir(os.path.join(folder, e)):
                    parts.append({"site": s, "date": m.group(2), "files": _data_files(os.path.join(folder, e)), "site_column": False})
    elif dates_top:
        for e in dates_top:
            files = _data_files(os.path.join(lake, e))
            parts.append({"site": None, "date": _KEY.match(e).group(2), "files": files, "site_column": False})
        with_site = [_has_site_column([f], con) for p in parts for f in p["files"]]
        has_site = any(with_site)
        if has_site and not all(with_site) and site is None:
            raise ArchiveError(f"trajdb archive: some files of {lake!r} have a site column and some do not; give every file one "
                               "(or none, and name the site with --site)")
        if has_site and site is None:
            split = []
            for p in parts:
                for s in _site_values(p["files"], con):
                    split.append({**p, "site": s, "site_column": True})
                if not p["files"] or not _site_values(p["files"], con):
                    split.append({**p, "site": "(unknown)", "site_column": True})
            parts = split
        else:
            name = site or os.path.basename(lake.rstrip(os.sep)) or "site"
            parts = [{**p, "site": name} for p in parts]
    else:
        raise ArchiveError(f"trajdb archive: {lake!r} has no site=S/ or date=D/ folders; lay the lake out as site=S/date=D/*.parquet "
                           "(hive style; CSV too), or date=D/ for one site")
    for p in parts:
        p["format"] = _format(p["files"])
        for what in ("site", "date"):
            _check_name(what, p[what])
    return sorted(parts, key=lambda p: (p["site"], date_key(p["date"])))


_DATE = re.compile(r"^(\d{4})(?:-(\d{1,2})-(\d{1,2})|(\d{2})(\d{2}))(?!\d)")


def date_key(date):
    """The order of a site's days (their calibrations are chained in it): by the calendar date a
    name starts with (2026-05-04, 2026-5-4, 20260504, 2026-05-04T06), so that 2026-5-10 comes
    after 2026-5-9; names that are no date after every date, by name."""
    m = _DATE.match(date)
    if not m:
        return (1, 0, 0, 0, date)
    y, mo, d = int(m.group(1)), int(m.group(2) or m.group(4)), int(m.group(3) or m.group(5))
    return (0, y, mo, d, date) if 1 <= mo <= 12 and 1 <= d <= 31 else (1, 0, 0, 0, date)


_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.:+@ -]{0,127}$")


def _check_name(what, value):
    """A site or date becomes a folder name under OUT: letters, digits and _ . : + @ - and
    spaces only, never '..', a '/' or a control character (a site column's value
    'x/../../home' would otherwise write outside the archive folder)."""
    if not isinstance(value, str) or not _NAME.match(value) or ".." in value:
        raise ArchiveError(f"trajdb archive: the {what} {value!r} cannot name a folder (letters, digits, _ . : + @ - and spaces, "
                           f"starting with a letter or digit, no '..'); rename it in the lake")


def _format(files):
    kinds = {("parquet" if f.lower().endswith(".parquet") else "csv") for f in files}
    return kinds.pop() if len(kinds) == 1 else ("mixed" if kinds else "none")


def _scan(con, files):
    if _format(files) == "parquet":
        return con.read_parquet(files, hive_partitioning=False, union_by_name=True)
    return con.read_csv(files, union_by_name=True, hive_partitioning=False)


def _has_site_column(files, con):
    own = con is None
    con = con or duckdb.connect()
    try:
        return "site" in [c.lower() for c in _scan(con, files[:1]).columns]
    except duckdb.Error:
        return False
    finally:
        if own:
            con.close()


def _site_values(files, con):
    own = con is None
    con = con or duckdb.connect()
    try:
        rel = _scan(con, files)
        return [str(r[0]) for r in rel.aggregate("site::VARCHAR AS site").distinct().order("site").fetchall() if r[0] is not None]
    except duckdb.Error:
        return []
    finally:
        if own:
            con.close()


def _stat(files, root):
    return [[os.path.relpath(f, root), os.path.getsize(f), os.stat(f).st_mtime_ns] for f in files]


def _content_fingerprint(files):
    h = hashlib.blake2b(digest_size=16)
    for f in files:
        h.update(os.path.basename(f).encode() + b"\0")
        with open(f, "rb") as fh:
            while chunk := fh.read(1 << 22):
                h.update(chunk)
        h.update(b"\1")
    return h.hexdigest()


# --- the archive folder -------------------------------------------------------------------------


def _inside(a, b):
    a, b = os.path.realpath(a), os.path.realpath(b)
    return a == b or a.startswith(b.rstrip(os.sep) + os.sep)


def claim(out, lake):
    """Checks OUT (new, empty, or an archive trajdb made) and returns its absolute path, the
    marker written. Refuses a folder with anything else in it, the lake itself, a folder inside
    the lake or holding it, a trajdb results folder."""
    out = os.path.abspath(out)
    if not out or out == os.sep:
        raise ArchiveError(f"trajdb archive: --out {out!r} is not a folder trajdb can own; name a new folder")
    if _inside(out, lake) or _inside(lake, out):
        raise ArchiveError(f"trajdb archive: --out {out!r} and the input {lake!r} hold one another; put the results outside the lake")
    if os.path.exists(out):
        if not os.path.isdir(out):
            raise ArchiveError(f"trajdb archive: --out {out!r} is a file; name a new folder")
        entries = os.listdir(out)
        if entries and MARKER not in entries:
            raise ArchiveError(f"trajdb archive: --out {out!r} holds files trajdb did not write ({', '.join(sorted(entries)[:3])}); "
                               "name a new or empty folder (trajdb never writes among your files)")
    os.makedirs(out, exist_ok=True)
    marker = os.path.join(out, MARKER)
    if not os.path.exists(marker):
        _write_atomic(marker, (MARKER_HEAD + f"input\t{os.path.abspath(lake)}\n").encode())
    else:
        # one archive, one lake: a run from another lake would mix two lakes' days in one state
        made = [ln.split("\t", 1)[1] for ln in open(marker, encoding="utf-8", errors="replace").read().splitlines() if ln.startswith("input\t")]
        if made and os.path.realpath(made[0]) != os.path.realpath(lake):
            raise ArchiveError(f"trajdb archive: {out!r} is the archive of the lake {made[0]!r}, not of {os.path.abspath(lake)!r}; "
                               "name another --out for this lake (or give that lake's path)")
    for d in ("_state", "_work"):
        os.makedirs(os.path.join(out, d), exist_ok=True)
    return out


def _write_atomic(path, data, work=None):
    """`data` into `path` whole or not at all: written beside it under a name of trajdb's
    scratch (OUT/_work/task-*, removed by the next run when a kill leaves it), then renamed."""
    tmp = os.path.join(work, f"task-tmp-{os.getpid()}-{time.time_ns()}") if work else f"{path}.tmp-{os.getpid()}"
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _lock(out):
    """One archive run per OUT at a time (an advisory lock held until the process exits)."""
    import fcntl

    fh = open(os.path.join(out, "_state", "lock"), "a+")
    try:
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        fh.close()
        raise ArchiveError(f"trajdb archive: another trajdb archive is writing into {out!r}; wait for it to finish") from None
    return fh


def _clean_work(out):
    """Removes the scratch folders of earlier, interrupted runs: only trajdb's own (task-*)."""
    work = os.path.join(out, "_work")
    for e in os.listdir(work):
        if e.startswith("task-"):
            p = os.path.join(work, e)
            if os.path.isdir(p) and not os.path.islink(p):
                shutil.rmtree(p, ignore_errors=True)
            else:
                os.remove(p)


def _read_parquet(path):
    """One Parquet file as it is: no partition columns guessed from its path (pyarrow's
    read_table adds site and from for a file under site=S/from=D/, depending on its version)."""
    return pq.ParquetFile(path).read()


def load_state(out):
    path = os.path.join(out, "_state", "partitions.parquet")
    if not os.path.exists(path):
        return {}
    t = _read_parquet(path)
    return {(r["site"], r["date"]): r for r in t.to_pylist()}


def save_state(out, state):
    rows = [state[k] for k in sorted(state)]
    t = pa.Table.from_pylist([{c: r.get(c) for c, _ in STATE_COLUMNS} for r in rows], schema=STATE_SCHEMA)
    sink = pa.BufferOutputStream()
    pq.write_table(t, sink)
    _write_atomic(os.path.join(out, "_state", "partitions.parquet"), sink.getvalue().to_pybytes(), work=os.path.join(out, "_work"))


def _append_run(out, row):
    path = os.path.join(out, "_state", "runs.csv")
    new = not os.path.exists(path)
    with open(path, "a") as f:
        if new:
            f.write("finished_utc,site,date,status,seconds,peak_rss_mb,points\n")
        f.write(",".join(str(row.get(k, "")) for k in ("finished_utc", "site", "date", "status", "seconds", "peak_rss_mb", "points")) + "\n")


# --- one site-day (runs in a worker process or a Spark task) --------------------------------------


# DuckDB's memory per task: a Mellingen-sized day (3 M points, 12 h) peaked at 2.3 GB without
# a limit and at 1.5 GB (the process) with 1.2 GB, in the same time (DuckDB spills to the task's
# scratch folder). A day that cannot fit fails with DuckDB's out-of-memory error, alone: raise
# it with --task-memory.
TASK_MEMORY = "1.5GB"
# the driver rewrites _state/partitions.parquet at most this often (and at each round's end)
STATE_EVERY_S = 2.0


def _reset_peak_rss():
    """Starts a task's peak memory afresh (a worker runs many tasks): Linux resets the process's
    high-water mark VmHWM on `5` written to /proc/self/clear_refs; elsewhere the peak stays the
    process's own since it started."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def _peak_rss_mb():
    """The task's peak resident memory in MB (VmHWM since _reset_peak_rss; else the process's)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return round(int(line.split()[1]) / 1024.0, 1)
    except (OSError, ValueError, IndexError):
        pass
    try:
        import resource

        return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1)
    except Exception:  # noqa: BLE001 - not on every platform
        return None


def run_task(task):
    """One site-day: returns {row (the state row), run (timings), scratch, calibration (the
    folder of a calibration made today, or None)}. Never raises: a failure is the row's error.
    The day itself is the extension's (`trajdb_archive_task`, src/archive.rs: the same function
    `CALL trajdb_archive` runs), in a private database of one thread; this process measures it."""
    t0 = time.perf_counter()
    _reset_peak_rss()
    try:
        check_duckdb()
        con = W.connect(task["extension"], threads=1)
        try:
            spec = {k: task.get(k) for k in ("site", "date", "files", "site_column", "inputs", "fingerprint", "cal_id", "cal_dir", "scratch",
                                             "params", "params_json", "build", "memory_limit")}
            res = json.loads(con.execute("FROM trajdb_archive_task(?)", [json.dumps(spec)]).fetchone()[0])
        finally:
            con.close()
    except Exception as e:  # noqa: BLE001 - a partition's failure is reported, the others go on
        res = {"row": _failed_row(task, f"{type(e).__name__}: {e}".strip()[:2000]), "scratch": None, "calibration": None}
    row = res["row"]
    run = {"finished_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"), "site": task["site"],
           "date": task["date"], "status": row["status"], "seconds": round(time.perf_counter() - t0, 2), "peak_rss_mb": _peak_rss_mb(),
           "points": row.get("points")}
    return {"row": row, "run": run, "scratch": res["scratch"], "calibration": res["calibration"]}


def _failed_row(task, error):
    """A partition's state row before (or without) its run: failed with `error`."""
    return {"site": task["site"], "date": task["date"], "inputs": task["inputs"], "fingerprint": task["fingerprint"],
            "trajdb_version": task["build"], "params": task["params_json"], "calibration_in": task["cal_id"],
            "calibration_out": task["cal_id"], "calibration_made": False, "changes": "[]", "warnings": "[]", "error": error,
            "status": "failed", "checks": "[]", "cameras": None, "points": None, "road_users": None, "matches": None}


def _who(camera, changes):
    """The camera a change is put on: the one every changed pair shares, else the pair's two."""
    if camera is not None:
        return f"camera {camera}"
    pairs = {(c["camera_fixed"], c["camera_moving"]) for c in changes if c["kind"] in ("moved", "lost")}
    return f"camera {min(pairs)[0]} or {min(pairs)[1]}" if len(pairs) == 1 else "a camera"


def _describe(c):
    if c["kind"] == "new camera":
        return f"camera {c['camera_moving']} is new"
    if c["kind"] == "lost":
        return f"cameras {c['camera_fixed']}-{c['camera_moving']}: {c['pairs']} matches where {c['expected_pairs']} were expected"
    return (f"cameras {c['camera_fixed']}-{c['camera_moving']}: moved {c['moved_m']} m, turned {c['turned_deg']} deg, "
            f"clock {c['clock_s']} s ({c['z']} standard errors)")


# --- the driver --------------------------------------------------------------------------------


def _cal_dir(out, site, cal_id):
    return os.path.join(out, "_calibrations", f"site={site}", f"from={cal_id}") if cal_id else None


def _commit(out, res):
    """Moves a finished task's files into place, then records it (the partition's commit point)."""
    row = res["row"]
    site, date = row["site"], row["date"]
    if row["status"] == "ok":
        if res["calibration"]:
            dest = _cal_dir(out, site, row["calibration_out"])
            os.makedirs(os.path.dirname(dest), exist_ok=True)
            if os.path.exists(dest):  # an interrupted run's copy of the same calibration
                old = os.path.join(os.path.dirname(res["scratch"]), f"task-old-{os.getpid()}-{time.time_ns()}")
                os.replace(dest, old)
                shutil.rmtree(old, ignore_errors=True)
            os.replace(res["calibration"], dest)
        for folder, name, _ in TABLES:
            _place(os.path.join(res["scratch"], name), os.path.join(out, folder, f"site={site}", f"date={date}", "part-0.parquet"))
        _place(os.path.join(res["scratch"], REPORT[1]), os.path.join(out, REPORT[0], f"site={site}", f"date={date}", REPORT[1]))
    else:
        # the files of an earlier run of this partition no longer describe its input (or this
        # version, or these parameters): removed, so that no reader takes them for this run's
        # (only trajdb's own files: the partition's part-0.parquet and report.html)
        for folder, _, _ in TABLES:
            _unlink_own(os.path.join(out, folder, f"site={site}", f"date={date}"), "part-0.parquet")
        _unlink_own(os.path.join(out, REPORT[0], f"site={site}", f"date={date}"), REPORT[1])
    if res["scratch"]:
        shutil.rmtree(res["scratch"], ignore_errors=True)


def _unlink_own(folder, name):
    """Removes trajdb's file `name` in `folder`, and the folder when that leaves it empty."""
    path = os.path.join(folder, name)
    if os.path.isfile(path) and not os.path.islink(path):
        os.remove(path)
    try:
        os.rmdir(folder)  # only when empty
    except OSError:
        pass


def _place(src, dest):
    os.makedirs(os.path.dirname(dest), exist_ok=True)
    os.replace(src, dest)


def _params_json(params):
    return json.dumps({k: str(v) for k, v in sorted((params or {}).items())}, sort_keys=True)


def _check_params(params, extension, task_memory=None):
    """Unknown names and bad values fail before any work (the extension checks them; DuckDB
    checks the task memory)."""
    con = W.connect(extension, threads=1)
    try:
        stages(con, "archive_input", part="site", **params)
        try:
            con.execute("SET memory_limit = ?", [task_memory or TASK_MEMORY])
        except duckdb.Error as e:
            raise ArchiveError(f"trajdb archive: task memory {task_memory!r} is not a memory size DuckDB takes (give e.g. '2GB'): {e}") from None
    finally:
        con.close()


class Progress:
    """partitions done / total, points/s, time left: one line rewritten on a terminal, plain
    lines in a log."""

    def __init__(self, total, stream=None, enabled=True):
        self.total, self.done, self.points, self.failed, self.t0 = total, 0, 0, 0, time.perf_counter()
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.tty = enabled and hasattr(self.stream, "isatty") and self.stream.isatty()

    def update(self, res):
        self.done += 1
        row = res["row"]
        self.points += row.get("points") or 0
        self.failed += row["status"] != "ok"
        if not self.enabled:
            return
        el = time.perf_counter() - self.t0
        rate = self.points / el if el > 0 else 0.0
        left = el / self.done * (self.total - self.done)
        what = f"site {row['site']} {row['date']} {row['status']}"
        if row["status"] != "ok":
            what += f": {row['error'][:160]}"
        self.total = max(self.total, self.done)
        line = (f"[trajdb] archive {self.done}/{self.total} partitions, {rate:,.0f} points/s, "
                f"{_eta(left)} left ({what})")
        if self.tty:
            self.stream.write("\r\033[K" + line)
            if self.done >= self.total:
                self.stream.write("\n")
        else:
            self.stream.write(line + "\n")
        self.stream.flush()


def _eta(s):
    s = int(round(s))
    return f"{s // 3600} h {s % 3600 // 60:02d} min" if s >= 3600 else (f"{s // 60} min {s % 60:02d} s" if s >= 60 else f"{s} s")


def _local_executor(workers):
    """Tasks in `workers` worker processes, one thread each: `python -m trajdb.archives --worker`,
    one task per line of JSON in; per task the worker answers `took` (it has the task) and then
    its result, one line each. Subprocesses, not multiprocessing: a caller's script without
    `if __name__ == "__main__":` is not run again in each worker, and DuckDB is never forked.
    A worker that ended before it took a task (killed between tasks) is replaced and the task
    sent again; one that ended while running it fails that partition alone. When the driver
    stops (an interrupt, an error), no worker takes another task and the running ones are
    killed: nothing goes on behind a stopped run."""
    import queue
    import subprocess
    import threading

    def run(tasks, on_done):
        if not tasks:
            return
        todo = queue.Queue()
        for t in tasks:
            todo.put(t)
        results = queue.Queue()
        stop = threading.Event()
        procs, procs_lock = set(), threading.Lock()
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([os.path.dirname(os.path.dirname(os.path.abspath(__file__)))]
                                                          + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])}

        def spawn():
            p = subprocess.Popen([sys.executable, "-m", "trajdb.archives", "--worker"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                 env=env, text=True, bufsize=1)
            with procs_lock:
                procs.add(p)
            return p

        def end(p):
            with procs_lock:
                procs.discard(p)
            try:
                p.stdin.close()
                p.wait(timeout=30)
            except Exception:  # noqa: BLE001 - a worker that will not stop is killed
                p.kill()

        def send(p, t):
            """(worker, its result line): "" when it died while running the task. A worker that
            ended before it took the task (no `took`) is replaced and the task sent again, once."""
            for attempt in range(2):
                try:
                    p.stdin.write(json.dumps(t) + "\n")
                    p.stdin.flush()
                    took = p.stdout.readline()
                except OSError:  # BrokenPipeError: it had ended
                    took = ""
                if took.strip() == "took":
                    return p, p.stdout.readline()
                if took:  # not the protocol: a result-shaped line or garbage, as the result
                    return p, took
                end(p)
                if attempt or stop.is_set():
                    return None, ""
                p = spawn()
            return None, ""

        def worker():
            p, t = None, None
            try:
                p = spawn()
                while not stop.is_set():
                    try:
                        t = todo.get_nowait()
                    except queue.Empty:
                        return
                    q, line = send(p, t)
                    if not line:  # the worker died (killed, out of memory): the task failed, a new worker goes on
                        status = (q or p).poll()
                        results.put(_died(t, status))
                        t = None
                        if q is not None:
                            end(q)
                        p = None
                        if stop.is_set():
                            return
                        p = spawn()
                        continue
                    p = q
                    try:
                        results.put(json.loads(line))
                    except ValueError:
                        results.put(_died(t, f"(it wrote {line[:200]!r})"))
                    t = None
            except BaseException as e:  # noqa: BLE001 - never leave the driver waiting for a result
                if t is not None:
                    results.put(failed_result(t, f"the archive's worker thread failed on this partition: {type(e).__name__}: {e}"))
            finally:
                if p is not None:
                    end(p)

        threads = [threading.Thread(target=worker, daemon=True) for _ in range(max(1, min(workers, len(tasks))))]
        for th in threads:
            th.start()
        got = 0
        try:
            while got < len(tasks):
                try:
                    res = results.get(timeout=1.0)
                except queue.Empty:
                    if any(th.is_alive() for th in threads):
                        continue
                    # every worker thread ended: what is still queued never ran
                    while True:
                        try:
                            t = todo.get_nowait()
                        except queue.Empty:
                            break
                        results.put(failed_result(t, "no archive worker was left to run this partition"))
                    if results.empty():
                        raise ArchiveError(f"trajdb archive: {len(tasks) - got} partitions were lost by the worker threads (a bug: please report it)")
                    continue
                got += 1
                on_done(res)
        except BaseException:
            # the driver stops (Ctrl-C in a notebook, an error committing): no new task, and the
            # running workers killed (their scratch is removed by the next run)
            stop.set()
            with procs_lock:
                running = list(procs)
            for p in running:
                try:
                    p.kill()
                except OSError:
                    pass
            raise
        for th in threads:
            th.join()

    return run


def failed_result(task, error):
    """The result of a task that could not report one itself (its process died, its Spark task
    failed every attempt): the partition failed with `error`, nothing to commit."""
    run = {"finished_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"), "site": task["site"],
           "date": task["date"], "status": "failed", "seconds": "", "peak_rss_mb": "", "points": ""}
    return {"row": _failed_row(task, error[:2000]), "run": run, "scratch": None, "calibration": None}


def _died(task, status):
    return failed_result(task, f"the worker process ended with status {status} while running this partition (killed, or out of memory?)")


def _die_with_driver():
    """A worker ends when its driver does (kill -9 included): Linux sends it SIGKILL when the
    thread that started it ends (PR_SET_PDEATHSIG); elsewhere it ends at its next task (stdin
    closed). Without this a killed run's workers went on computing days no one would commit."""
    try:
        import ctypes
        import signal

        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG = 1
    except Exception:  # noqa: BLE001 - not Linux
        pass


def _worker_main():
    _die_with_driver()  # (a driver that died before this line: stdin's end ends the worker)
    # the protocol owns the original stdout; anything else printed (by Python or C code) goes to stderr
    proto = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    # (tests: TRAJDB_ARCHIVE_WORKER_TASKS=n makes a worker end after n tasks, as one killed
    # between tasks would: tests/test_archive_python.py)
    quit_after = int(os.environ.get("TRAJDB_ARCHIVE_WORKER_TASKS") or 0)
    n = 0
    for line in sys.stdin:
        if line.strip():
            task = json.loads(line)
            proto.write("took\n")  # the task is this worker's now (a worker that dies before this is replaced)
            proto.flush()
            proto.write(json.dumps(run_task(task)) + "\n")
            proto.flush()
            n += 1
            if quit_after and n >= quit_after:
                os._exit(0)


def build_id(extension):
    """The trajdb build a result depends on: the package version and the extension's bytes (a
    rebuilt extension may compute other numbers under the same version)."""
    h = hashlib.blake2b(digest_size=6)
    with open(extension, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return f"{__version__}+{h.hexdigest()}"


def calibration_id(date, fingerprint, build, params_json):
    """The name of the calibration a day makes: its date, its input and the build and parameters
    that made it (a calibration made under other parameters is another one, never reused)."""
    made_by = hashlib.blake2b((build + "\n" + params_json).encode(), digest_size=4).hexdigest()
    return f"{date}-{fingerprint[:12]}-{made_by}"


def plan(parts, state, out, params_json, lake, wait=True, attempted=(), build=None):
    """One round's tasks: walks each site's days in date order with the calibration in effect
    (the state's, for days already done), and returns the days that need work, each with the
    calibration it starts from. A day that makes (or made last time) its site's calibration
    runs first: the site's later days wait for the next round, when its folder is there
    (`wait`; without it, all days: the progress bar's count)."""
    build = build or __version__
    tasks = []
    by_site = {}
    for p in parts:
        by_site.setdefault(p["site"], []).append(p)
    for site, days in by_site.items():
        cal = None
        for p in days:
            st = state.get((site, p["date"]))
            same = st and st["fingerprint"] == p["fingerprint"] and st["trajdb_version"] == build and st["params"] == params_json \
                and st["calibration_in"] == cal and (cal is None or os.path.isdir(_cal_dir(out, site, cal))) \
                and (not st["calibration_made"] or os.path.isdir(_cal_dir(out, site, st["calibration_out"])))
            # (a day that made a calibration is done only while its folder is there: a deleted
            # _calibrations folder is made again by its day, not waited for by the days after it)
            # done: the same input, version, parameters and calibration in effect, and not failed
            # (a failed partition is tried again once per run: a worker killed for memory may pass
            # next time; a corrupt file fails again in a second)
            if same and (st["status"] == "ok" or (site, p["date"], cal) in attempted):
                cal = st["calibration_out"]
                continue
            if wait and cal is not None and not os.path.isdir(_cal_dir(out, site, cal)):
                break  # a calibration this round makes: the site's later days wait for the next round
            tasks.append({**p, "cal_id": cal})
            makes = cal is None or bool(st and st["calibration_made"])
            if cal is None:
                cal = calibration_id(p["date"], p["fingerprint"], build, params_json)  # this day will calibrate the site (if it runs)
            if wait and makes:
                break  # it makes the site's calibration again (or may: a camera change): the later days wait for it
    return tasks


def _fingerprint_parts(parts, state, lake):
    """Each partition's inputs (name, size, mtime) and content fingerprint; the content is read
    only when the names, sizes or times differ from the state's (a no-op run reads no data)."""
    for p in parts:
        p["inputs"] = json.dumps(_stat(p["files"], lake))
        st = state.get((p["site"], p["date"]))
        if st and st["inputs"] == p["inputs"]:
            p["fingerprint"] = st["fingerprint"]
        else:
            p["fingerprint"] = _content_fingerprint(p["files"]) + ("" if not p["site_column"] else "-" + hashlib.sha1(p["site"].encode()).hexdigest()[:8])


def run(lake, out, params=None, site=None, workers=None, extension=None, progress=True, executor=None, stream=None, max_rounds=None,
        task_memory=None):
    """The archive run (module docstring). Returns a summary dict: partitions, done (partitions
    run this run), runs (day runs: a day run again after an earlier day's camera change counts
    twice), skipped, failed (in the state after the run), changes (camera changes found this
    run), seconds. `executor(tasks, on_done)` runs the tasks (default: local processes; trajdb.spark
    gives Spark's)."""
    check_duckdb()
    t0 = time.perf_counter()
    lake = os.path.abspath(os.fspath(lake))
    params = {k: v for k, v in (params or {}).items()}
    from . import extension_path

    extension = extension or extension_path()
    parts = discover(lake, site=site)
    _check_params(params, extension, task_memory)
    out = claim(os.fspath(out), lake)
    lock = _lock(out)
    try:
        _clean_work(out)
        state = load_state(out)
        _fingerprint_parts(parts, state, lake)
        params_json = _params_json(params)
        workers = workers or os.cpu_count() or 1
        executor = executor or _local_executor(workers)
        done, rounds, ran, saved = 0, 0, set(), time.monotonic()
        build = build_id(extension)
        prog = Progress(len(plan(parts, state, out, params_json, lake, wait=False, build=build)), stream=stream, enabled=progress)
        attempted = set()
        while True:
            tasks = plan(parts, state, out, params_json, lake, attempted=attempted, build=build)
            if not tasks:
                break
            rounds += 1
            if max_rounds is not None and rounds > max_rounds:
                break
            prog.total = max(prog.total, prog.done + len(tasks))
            attempted |= {(t["site"], t["date"], t["cal_id"]) for t in tasks}
            for k, t in enumerate(tasks):
                t.update(scratch=os.path.join(out, "_work", f"task-{os.getpid()}-{rounds}-{k}"), cal_dir=_cal_dir(out, t["site"], t["cal_id"]),
                         params=params, params_json=params_json, extension=extension, memory_limit=task_memory or TASK_MEMORY, build=build)

            def on_done(res):
                nonlocal done, saved
                _commit(out, res)
                row = res["row"]
                state[(row["site"], row["date"])] = row
                # the state is rewritten whole (one Parquet file): at most every STATE_EVERY_S
                # seconds and at each round's end, not after every partition (O(N^2) over a
                # city's year). A kill in between leaves partitions placed but not recorded: the
                # next run runs them again, to the same bytes (one thread per task).
                if time.monotonic() - saved >= STATE_EVERY_S:
                    save_state(out, state)
                    saved = time.monotonic()
                _append_run(out, res["run"])
                prog.update(res)
                done += 1
                ran.add((row["site"], row["date"]))

            try:
                executor(tasks, on_done)
            finally:
                # what was committed is recorded, also when the run stops here (an interrupt)
                save_state(out, state)
                saved = time.monotonic()
            _clean_work(out)  # the scratch of attempts that never reached the driver (a Spark retry's first attempt)
        _site_indexes(out, state)
        failed = sorted(k for k, r in state.items() if r["status"] != "ok")
        # the camera changes of this run's partitions, as the state holds them at the end (a day
        # run on a calibration that an earlier day's change then replaced ran again)
        changes = [{"site": s, "date": d, **json.loads(state[(s, d)]["changes"])} for s, d in sorted(ran) if state[(s, d)]["changes"] not in ("[]", None)]
        present = {(p["site"], p["date"]) for p in parts}
        return {"partitions": len(parts), "done": len(ran & present), "runs": done, "skipped": len(parts) - len(ran & present),
                "failed": len([k for k in failed if k in present]), "failed_partitions": [f"site={s}/date={d}" for s, d in failed if (s, d) in present],
                "changes": changes, "rounds": rounds, "seconds": round(time.perf_counter() - t0, 2), "out": out,
                "orphaned": sorted(f"site={s}/date={d}" for s, d in state if (s, d) not in present)}
    finally:
        lock.close()


def _site_indexes(out, state):
    """reports/site=S/index.html: the site's days, their counts, failures and camera changes."""
    import html

    by_site = {}
    for (s, d), r in sorted(state.items(), key=lambda kv: (kv[0][0], date_key(kv[0][1]))):
        by_site.setdefault(s, []).append(r)
    for s, rows in by_site.items():
        lines = [f"<!doctype html><meta charset=utf-8><title>trajdb archive: site {html.escape(s)}</title>",
                 "<style>body{font-family:sans-serif;margin:2em}td,th{padding:2px 8px;text-align:right}td.l,th.l{text-align:left}</style>",
                 f"<h1>Site {html.escape(s)}</h1><p>{len(rows)} days; {sum(r['status'] != 'ok' for r in rows)} failed; "
                 f"{sum(bool(r['calibration_made']) for r in rows)} calibrations.</p>",
                 "<table><tr><th class=l>date</th><th class=l>status</th><th>cameras</th><th>points</th><th>road users</th><th>matches</th>"
                 "<th class=l>calibration</th><th class=l>camera changes and errors</th></tr>"]
        for r in rows:
            ch = json.loads(r["changes"] or "[]")
            note = ""
            if ch:
                note = f"{_who(ch.get('camera'), ch['pairs'])}: " + "; ".join(_describe(c) for c in ch["pairs"])
            if r["error"]:
                note = r["error"]
            link = (f"<a href='date={html.escape(r['date'])}/report.html'>{html.escape(r['date'])}</a>" if r["status"] == "ok" else html.escape(r["date"]))
            lines.append(f"<tr><td class=l>{link}</td><td class=l>{html.escape(r['status'])}</td><td>{r['cameras'] or ''}</td><td>{r['points'] or ''}</td>"
                         f"<td>{r['road_users'] or ''}</td><td>{r['matches'] or ''}</td><td class=l>{html.escape(r['calibration_out'] or '')}"
                         f"{' (made)' if r['calibration_made'] else ''}</td><td class=l>{html.escape(note)}</td></tr>")
        lines.append("</table>")
        dest = os.path.join(out, REPORT[0], f"site={s}", "index.html")
        os.makedirs(os.path.dirname(dest), exist_ok=True)
        _write_atomic(dest, "\n".join(lines).encode(), work=os.path.join(out, "_work"))


def export_day(out, site, date, dest, con=None):
    """One partition of an archive as a `trajdb pipeline` results folder `dest` (a new folder):
    merged.parquet, matches.csv, links.csv, transforms.csv, calibration.csv and report.html, for
    the tools that read one (trajdb score, analysis.sql)."""
    dest = os.path.abspath(dest)
    if os.path.lexists(dest) and not (os.path.isdir(dest) and not os.path.islink(dest) and not os.listdir(dest)):
        raise ArchiveError(f"trajdb archive: {dest!r} exists and is not an empty folder; name a new folder")
    part = lambda folder, name: os.path.join(out, folder, f"site={site}", f"date={date}", name)  # noqa: E731
    if not os.path.exists(part("road_users", "part-0.parquet")):
        raise ArchiveError(f"trajdb archive: {out!r} has no partition site={site}/date={date}")
    # written whole beside dest, then renamed onto it: a failure leaves no half-written folder
    stage = f"{dest}.trajdb-tmp-{os.getpid()}-{time.time_ns()}"
    os.makedirs(stage)
    own = con is None
    con = con or duckdb.connect()
    try:
        shutil.copyfile(part("road_users", "part-0.parquet"), os.path.join(stage, "merged.parquet"))
        shutil.copyfile(part(REPORT[0], REPORT[1]), os.path.join(stage, REPORT[1]))
        for folder, _, _ in TABLES[1:]:
            name = {"matches": "matches.csv", "links": "links.csv", "transforms": "transforms.csv", "calibration": "calibration.csv"}[folder]
            # the file's own columns only (no site and date guessed from its path)
            con.execute(f"COPY (FROM read_parquet(?, hive_partitioning = false)) TO {_literal(os.path.join(stage, name))} (HEADER, DELIMITER ',')",
                        [part(folder, "part-0.parquet")])
        if os.path.isdir(dest):
            os.rmdir(dest)  # empty (checked above); fails, keeping the stage for no one, if a file appeared since
        os.replace(stage, dest)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    finally:
        if own:
            con.close()
    return dest


if __name__ == "__main__" and sys.argv[1:] == ["--worker"]:
    _worker_main()
