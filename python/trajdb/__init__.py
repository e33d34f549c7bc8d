"""trajdb for Python: DuckDB with the trajdb extension loaded.

    import trajdb
    con = trajdb.connect()                       # a DuckDB connection with trajdb loaded
    trajdb.load(con)                             # or load it into your own connection
    trajdb.pipeline(con, "points.parquet", out="results", merge_eta=0.6)
    con.sql("SELECT class, count(*) FROM merged GROUP BY class").show()

Where the extension comes from (docs/install.md): the wheel that scripts/build_wheel.sh makes
ships the ready `trajdb.duckdb_extension` under site-packages/.duckdb_extensions/ (the layout of
DuckDB's own extension wheels); `pip install .` builds it from this repository (setuptools-rust;
no C++ is compiled). `extension_path()` is the file, `extension_dir()` a directory for DuckDB's
`extension_directories` setting in which `LOAD trajdb` finds it by name; `trajdb install-cli`
puts it where the DuckDB command line finds it. `pipeline` runs the same SQL files as
`trajdb pipeline` and writes the same result files (transforms.csv, calibration.csv,
matches.csv, merged.parquet, clusters.csv, links.csv, report.html).
"""
import functools
import glob
import hashlib
import json
import os
import shutil
import sys
import tempfile
import time
import warnings

import duckdb

from .footer import default_platform, footer

__version__ = "0.1.0"
_HERE = os.path.dirname(os.path.abspath(__file__))
# C API v1.2.0 / C_STRUCT: DuckDB 1.5 and 2.0 load it (tested: 1.5.x and 2.0.x in CI)
MIN_DUCKDB = (1, 5)
EXTENSION_FILE = "trajdb.duckdb_extension"
# DuckDB's own default extension directory (kept first in extension_directories, so that
# INSTALL httpfs etc. still go there)
DEFAULT_EXTENSION_DIR = "~/.duckdb/extensions"


def _duckdb_version():
    return tuple(int(p) for p in duckdb.__version__.split(".")[:2] if p.isdigit())


def check_duckdb():
    """Refuses a DuckDB that cannot load the extension, naming the versions that can."""
    if _duckdb_version() < MIN_DUCKDB:
        raise RuntimeError(
            f"trajdb needs DuckDB 1.5 or newer (tested with 1.5.x and 2.0.x); this Python has duckdb {duckdb.__version__}: "
            "pip install -U 'duckdb>=1.5'"
        )


def _cache_dir():
    return os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "trajdb")


def _wheel_extension():
    """The extension file a wheel built by scripts/build_wheel.sh installed (its place is written
    into trajdb/_wheel.py, relative to site-packages), or None."""
    try:
        from . import _wheel
    except ImportError:
        return None
    path = os.path.join(os.path.dirname(_HERE), *_wheel.EXTENSION.split("/"))
    return path if os.path.isfile(path) else None


def extension_path():
    """The loadable extension file (`LOAD '<path>'`): the file that the environment variable
    TRAJDB_EXTENSION names (e.g. one built by scripts/build_extension.sh); else the one the wheel
    installed (site-packages/.duckdb_extensions/v<DuckDB version>/<platform>/trajdb.duckdb_extension);
    else, after `pip install .`, the built library plus DuckDB's footer, cached per build."""
    if os.environ.get("TRAJDB_EXTENSION"):
        return os.path.abspath(os.environ["TRAJDB_EXTENSION"])
    shipped = _wheel_extension()
    if shipped:
        return shipped
    libs = [p for p in glob.glob(os.path.join(_HERE, "_trajdb*")) if not p.endswith(".py")]
    if not libs:
        raise RuntimeError(
            f"trajdb's extension is missing from {_HERE}: reinstall the wheel (pip install trajdb-*.whl), or "
            "`pip install .` from the repository, or set TRAJDB_EXTENSION to a trajdb.duckdb_extension file"
        )
    lib = libs[0]
    with open(lib, "rb") as f:
        data = f.read()
    digest = hashlib.sha256(data).hexdigest()[:16]
    cache = os.path.join(_cache_dir(), digest)
    path = os.path.join(cache, EXTENSION_FILE)
    if not os.path.exists(path):
        os.makedirs(cache, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=cache)
        with os.fdopen(fd, "wb") as f:
            f.write(data + footer("v" + __version__))
        os.replace(tmp, path)  # atomic: a concurrent load never sees half a file
    return path


@functools.lru_cache(maxsize=None)
def _engine():
    """(version folder, platform) of this Python's DuckDB, as it names them in its extension
    directories: v2.0.0/linux_amd64 (a development build: its source id)."""
    con = duckdb.connect()
    try:
        version, source_id = con.execute("SELECT library_version, source_id FROM pragma_version()").fetchone()
        platform = con.execute("PRAGMA platform").fetchone()[0]
    finally:
        con.close()
    return (source_id if "-dev" in version else version), platform


def _link(src, dst):
    """dst becomes a symbolic link to src (a copy where links are not allowed); atomically."""
    os.makedirs(os.path.dirname(dst), exist_ok=True)
    if os.path.islink(dst) and os.readlink(dst) == src:
        return
    tmp = f"{dst}.{os.getpid()}.tmp"
    try:
        os.symlink(src, tmp)
    except OSError:
        shutil.copyfile(src, tmp)
    os.replace(tmp, dst)


def extension_dir():
    """A directory for DuckDB's `extension_directories` setting in which `LOAD trajdb` finds
    extension_path() by name, for the DuckDB of this Python: DIR/<version>/<platform>/
    trajdb.duckdb_extension. That is site-packages/.duckdb_extensions when the wheel installed
    the file there for this DuckDB version; otherwise a folder in ~/.cache/trajdb holding a link
    to the file (trajdb writes only there)."""
    version, platform = _engine()
    src = extension_path()
    shipped = _wheel_extension()
    if shipped and src == shipped:
        root = os.path.dirname(os.path.dirname(os.path.dirname(shipped)))
        if os.path.isfile(os.path.join(root, version, platform, EXTENSION_FILE)) and os.path.samefile(
            os.path.join(root, version, platform, EXTENSION_FILE), src
        ):
            return root
    root = os.path.join(_cache_dir(), "extensions", hashlib.sha256(src.encode()).hexdigest()[:16])
    _link(src, os.path.join(root, version, platform, EXTENSION_FILE))
    return root


def progress_bar_wanted():
    """DuckDB's progress bar draws on stdout: only when stdout and stderr are both a terminal
    (never into a log, a pipe or a redirected result)."""
    try:
        return sys.stdout.isatty() and sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


def load(con):
    """Loads trajdb into `con` (opened with allow_unsigned_extensions, as trajdb.connect does)."""
    check_duckdb()
    try:
        con.execute(f"LOAD {_literal(extension_path())}")
    except duckdb.Error as e:
        if "unsigned" in str(e).lower() or "signature" in str(e).lower():
            raise RuntimeError(
                "trajdb is not signed by DuckDB: open the connection with "
                "duckdb.connect(config={'allow_unsigned_extensions': 'true'}), or use trajdb.connect()"
            ) from e
        raise
    return con


def connect(database=":memory:", read_only=False, **config):
    """duckdb.connect with unsigned extensions allowed and trajdb loaded: `database` a file (or
    ':memory:'), `read_only=True` opens it read-only, as duckdb.connect does (trajdb.pipeline then
    runs entirely in TEMP: nothing of trajdb's is written to a database file). The connection also
    finds trajdb by name (`LOAD trajdb`: extension_dir() is added to `extension_directories`,
    after DuckDB's default ~/.duckdb/extensions), and DuckDB's progress bar is off unless stdout
    and stderr are a terminal (`enable_progress_bar=True` keeps it; a setting of this connection,
    not of its cursors). The rest of `config` is kept as given."""
    check_duckdb()
    config.setdefault("allow_unsigned_extensions", "true")
    bar = config.pop("enable_progress_bar", None)  # a session setting: DuckDB refuses it in config
    bar = progress_bar_wanted() if bar is None else str(bar).lower() in ("true", "1")
    try:
        by_name = extension_dir()
    except OSError:
        by_name = None  # no writable cache for the link: LOAD by name is a convenience, load() needs none
    if by_name is not None and "extension_directories" in config:
        config["extension_directories"] = list(config["extension_directories"]) + [by_name]
    elif by_name is not None and "extension_directory" not in config:
        config["extension_directories"] = [DEFAULT_EXTENSION_DIR, by_name]
    con = duckdb.connect(os.fspath(database), read_only=bool(read_only), config=config)
    con.execute(f"SET enable_progress_bar = {'true' if bar else 'false'}")
    return load(con)


def install_extension(directory=DEFAULT_EXTENSION_DIR, version=None, platform=None):
    """Copies extension_path() to DIRECTORY/<version>/<platform>/trajdb.duckdb_extension, where a
    DuckDB of that version (`v1.5.6`) finds it by name: ~/.duckdb/extensions is the default of the
    DuckDB command line (and of the duckdb-cli package). A file already there is replaced only when
    trajdb wrote it (a note beside it, trajdb.duckdb_extension.trajdb, records the hashes) and nobody
    changed it since; anything else is an error naming the file. Returns (path, what happened)."""
    if version is None or platform is None:
        v, p = _engine()
        version, platform = version or v, platform or p
    if not version.startswith("v") and "." in version:
        version = "v" + version
    src = extension_path()
    dst = os.path.join(os.path.expanduser(directory), version, platform, EXTENSION_FILE)
    note = dst + ".trajdb"

    def sha(path):
        h = hashlib.sha256()
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        return h.hexdigest()

    new = sha(src)
    try:
        with open(note) as f:
            written = list(json.load(f).get("sha256", []))
    except (OSError, ValueError, AttributeError, TypeError):
        written = []
    if os.path.lexists(dst):
        old = sha(dst) if os.path.isfile(dst) else None
        if old == new:
            return dst, "already installed"
        if old is None or old not in written:
            raise RuntimeError(
                f"{dst} exists and trajdb did not write it (or it changed since): trajdb does not replace it. "
                "Remove it yourself to install this one, or give another folder (--dir)"
            )
        what = "updated"
    else:
        what = "installed"
    os.makedirs(os.path.dirname(dst), exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(dst), prefix=".trajdb-")
    with os.fdopen(fd, "wb") as out, open(src, "rb") as f:
        shutil.copyfileobj(f, out)
    os.chmod(tmp, 0o644)
    with open(note + ".tmp", "w") as f:
        json.dump({"sha256": (written + [new])[-8:], "source": src, "trajdb": __version__}, f)
    os.replace(note + ".tmp", note)  # the note first: a file trajdb wrote is never left unrecorded
    os.replace(tmp, dst)
    return dst, what


def _literal(v):
    """An SQL string literal (single quotes doubled)."""
    return "'" + str(v).replace("'", "''") + "'"


def _steps(con, query, args):
    """The rows (stage, file, sql, undo, short_name) of a trajdb_stages / trajdb_script query, in
    order (short_name: the short name the statement gives one of trajdb's macros, crates/app/src/plan.rs)."""
    return con.execute(f"SELECT stage, file, sql, undo, short_name FROM {query} ORDER BY k", args).fetchall()


def names_taken(con, names):
    """{name: 'macro main.routes'} for each of `names` that already means something that is not
    trajdb's on `con`: a table, view, macro or function of any database or schema the connection
    sees (the file's, an attached one's, TEMP ones). A TEMP macro is trajdb's own (an earlier
    run's short name, which may be defined again) only when its definition is the one trajdb gave
    it on this connection (temp table trajdb_short_macros): a macro of yours under that name, even
    one that calls trajdb_<name>, stays yours."""
    names = sorted({n.lower() for n in names})
    if not names:
        return {}
    own = _own_short_macros(con)
    rows = con.execute(
        """SELECT lower(name), kind || ' ' || database_name || '.' || schema_name || '.' || name, database_name = 'temp' AND kind = 'macro', body
           FROM (SELECT function_name AS name, CASE WHEN function_type LIKE '%macro%' THEN 'macro' ELSE 'function' END AS kind,
                        database_name, schema_name, coalesce(macro_definition, '') AS body
                 FROM duckdb_functions() WHERE NOT internal
                 UNION ALL SELECT table_name, 'table', database_name, schema_name, '' FROM duckdb_tables()
                 UNION ALL SELECT view_name, 'view', database_name, schema_name, '' FROM duckdb_views() WHERE NOT internal)
           WHERE list_contains(?, lower(name))
           ORDER BY ALL""",
        [names],
    ).fetchall()
    taken = {}
    for name, what, temp_macro, body in rows:
        if not (temp_macro and own.get(name) == body):
            taken.setdefault(name, what)
    return taken


def _own_short_macros(con):
    """{name: definition} of the short-name macros trajdb defined on `con` (temp table
    trajdb_short_macros, written by execute_steps; absent: none)."""
    if not con.execute("SELECT count(*) FROM duckdb_tables() WHERE database_name = 'temp' AND table_name = 'trajdb_short_macros'").fetchall()[0][0]:
        return {}
    return dict(con.execute("SELECT name, definition FROM temp.main.trajdb_short_macros").fetchall())


def _remember_short_macro(con, name):
    """Records the definition trajdb just gave its short-name macro `name` (names_taken)."""
    con.execute("CREATE TEMP TABLE IF NOT EXISTS trajdb_short_macros (name VARCHAR, definition VARCHAR)")
    con.execute("DELETE FROM temp.main.trajdb_short_macros WHERE name = ?", [name])
    con.execute("""INSERT INTO temp.main.trajdb_short_macros
                   SELECT ?, coalesce(any_value(macro_definition), '') FROM duckdb_functions()
                   WHERE database_name = 'temp' AND lower(function_name) = ?""", [name, name])


def execute_steps(con, steps, progress=False):
    """Runs the statements of trajdb_stages() / trajdb_script() on `con`: each row in order;
    after a row succeeds its `undo` is remembered; when one fails, the remembered undos run
    last-first and the error is raised with the stage and file it came from. This loop is the
    whole runner on the Python side: the statements, the parameters and the results folder's
    rules come from the extension (crates/app/src/plan.rs). With `progress`, each stage's time
    goes to stderr as a plain line. Returns [(stage, seconds)].

    Your names stay yours: a statement that would give one of trajdb's analysis macros its short
    name (`routes`, `approaches`, ...: sql/analysis.sql) is left out when that name is already a
    table, view, macro or function of yours (checked once, before the first statement), with a
    warning naming it; trajdb's macro is still there as trajdb_<name>. Every other statement
    creates TEMP objects only (crates/app/src/plan.rs refuses a manifest that would not)."""
    import sys

    steps = list(steps)
    steps = [tuple(s) + (None,) * (5 - len(s)) for s in steps]  # (stage, file, sql, undo[, short_name])
    taken = names_taken(con, [s[4] for s in steps if s[4]])
    for name, what in taken.items():
        warnings.warn(
            f"trajdb: {what} is yours and keeps its name; trajdb's macro is trajdb_{name}() "
            f"(call it by that name, or rename yours to get trajdb's as {name}())",
            stacklevel=3,
        )
    undo, timings = [], []
    for stage, file, sql, undo_sql, short in steps:
        if short in taken:
            continue
        t = time.perf_counter()
        try:
            con.execute(sql).fetchall()
        except BaseException as e:
            # the undos run on a cursor of their own: inside a failed explicit transaction `con`
            # refuses every statement, and the results folder's claim is process-wide
            try:
                undo_con = con.cursor() if undo else None
            except duckdb.Error:
                undo_con = con
            for u in reversed(undo):
                try:
                    undo_con.execute(u).fetchall()
                except duckdb.Error:
                    pass
            if hasattr(e, "add_note"):
                # the statement's first words name it when DuckDB's own message does not (an INTERNAL error)
                head = " ".join(line for line in sql.split("\n") if not line.lstrip().startswith("--"))[:160]
                e.add_note(f"trajdb: in stage '{stage}' ({file}), in the statement: {' '.join(head.split())} ...")
            raise
        if short:
            _remember_short_macro(con, short)
        if undo_sql:
            undo.append(undo_sql)
        dt = time.perf_counter() - t
        if timings and timings[-1][0] == stage:
            timings[-1] = (stage, timings[-1][1] + dt)
        else:
            if progress and timings:
                print(f"[trajdb] {timings[-1][0]:<9} {timings[-1][1]:7.2f} s", file=sys.stderr, flush=True)
            timings.append((stage, dt))
    if progress and timings:
        print(f"[trajdb] {timings[-1][0]:<9} {timings[-1][1]:7.2f} s", file=sys.stderr, flush=True)
    return timings


def read(con, path):
    """Runs one of trajdb's SQL files as the extension embeds it (`sql/score.sql`, ...), like
    the DuckDB CLI's `.read sql/...` (the statements come from trajdb_script)."""
    execute_steps(con, _steps(con, "trajdb_script(?)", [path]))


def _params_json(params, who):
    """The parameters as the JSON object trajdb_stages checks (names, types and ranges are the
    extension's: `trajdb params`)."""
    values = {}
    for k, v in (params or {}).items():
        if hasattr(v, "item") and not isinstance(v, (str, bytes)):
            v = v.item()  # a numpy scalar
        if not isinstance(v, (bool, int, float, str)):
            raise TypeError(f"{who}: parameter {k} must be a number, a boolean or text, got {type(v).__name__}")
        values[str(k)] = v
    for k, v in values.items():
        if isinstance(v, float) and (v != v or v in (float("inf"), float("-inf"))):
            raise ValueError(f"{who}: parameter {k} must be a finite number, got {v!r}")
    return json.dumps(values, allow_nan=False)


def stages(con, input, out=None, part="all", **params):
    """The statements of one run (rows stage, file, sql, undo, short_name of trajdb_stages): the same
    manifest `CALL trajdb_pipeline` runs; `execute_steps` runs them."""
    named = ", out_dir := ?" if out is not None else ""
    args = [input] + ([os.fspath(out)] if out is not None else []) + [part, _params_json(params, "trajdb.stages")]
    try:
        return _steps(con, f"trajdb_stages(?{named}, part := ?, params := ?)", args)
    except duckdb.Error as e:
        raise ValueError(f"trajdb: {e}") from None


def _connection_ready(con, who):
    """Refuses plainly, before any work, a connection that still holds an unfinished result
    (`con.execute(...)` whose rows were not all fetched): DuckDB 2.0 runs nothing else on it until
    then, and the first statement of the run failed with a message that blamed the input (issue 39).
    DuckDB 1.5 closes such a result when the next statement runs; it is then not an error."""
    try:
        con.execute("SELECT 1").fetchall()
    except duckdb.Error as e:
        if "unfinished result" in str(e):
            raise RuntimeError(
                f"{who}: the connection still holds an unfinished result (a con.execute(...) whose rows were not all fetched); "
                "fetch the rest (.fetchall()) or close it (.close() on the result, or con.execute('SELECT 1') in DuckDB 1.5) "
                "and run again; DuckDB runs nothing else on this connection until then (your input is not at fault)"
            ) from None
        raise


def _input_name(con, input):
    """The input as the pipeline's load reads it, and the name registered for it (or None).

    A str or os.PathLike is a path, a glob or a table / view name, as given: sql/pipeline.sql
    resolves it as a table or view of `con`, or else as a file, and quotes it; it is never run as
    SQL ("(SELECT 1)" is a file that does not exist). A pandas or polars DataFrame, a pyarrow
    Table (or anything else DuckDB scans from Python) and a DuckDB relation (`con.sql("SELECT
    ...")`: how a query is passed) are registered on `con` under a name of their own, for the run
    only. A relation of another connection is read into an Arrow table first (its database is
    not `con`'s)."""
    if isinstance(input, str):
        return input, None
    if isinstance(input, os.PathLike):
        return os.fspath(input), None
    if isinstance(input, (bytes, bytearray)):
        raise TypeError("trajdb.pipeline: the input is bytes; give a path as str (or os.PathLike), a table name, a DataFrame, an Arrow table or a DuckDB relation")
    name = "trajdb_input_" + hashlib.sha256(os.urandom(16)).hexdigest()[:12]
    try:
        con.register(name, input)
    except duckdb.Error as e:
        if isinstance(input, duckdb.DuckDBPyRelation):
            # a relation made by another connection (or on another database)
            con.register(name, input.to_arrow_table())
        else:
            raise TypeError(
                f"trajdb.pipeline: cannot read an input of type {type(input).__name__}; give a path, glob or table name (str), "
                f"a pandas or polars DataFrame, a pyarrow Table or a DuckDB relation (con.sql('SELECT ...')) ({e})"
            ) from None
    return name, name


def pipeline(con, input, out=None, progress=False, **params):
    """The whole pipeline on `input` (a Parquet / CSV / JSON file or glob, a table or view name, a
    pandas or polars DataFrame, a pyarrow Table, or a DuckDB relation such as `con.sql("SELECT
    ...")`; a str is never run as SQL: docs/inputs.md), as `CALL trajdb_pipeline`: parameters by keyword
    (`merge_eta=0.6`; `trajdb params` lists them; an unknown name or a bad value is an error),
    then the stages; with `out`, the result files and report.html are written there. The tables
    (merged, matches, ...) stay in `con`. The statements come from the extension
    (trajdb_stages) and run on `con`, so a registered DataFrame or a TEMP table is an input too.

    `out` is a new folder, an empty one, or one holding an earlier trajdb result set; anything
    else (a folder with your files in it, the input's folder, '') is refused before any work. A
    failed run leaves the earlier results as they were; trajdb deletes only files it wrote itself
    (docs/robustness.md)."""
    _connection_ready(con, "trajdb.pipeline")
    name, registered = _input_name(con, input)
    try:
        steps = stages(con, name, out=out, **params)
        execute_steps(con, steps, progress=progress)
        for w in warnings_of(con):
            warnings.warn(f"trajdb.pipeline: {w}", stacklevel=2)
    finally:
        if registered:
            con.unregister(registered)
    return con


def warnings_of(con):
    """What a finished pipeline run should tell its user (sql/warnings.sql: one camera, cameras
    left out of the common frame, class flicker, repeated rows)."""
    return [r[0] for r in con.sql("SELECT message FROM pipeline_warnings ORDER BY k").fetchall()]


def simulate(con, out, **params):
    """`trajdb simulate` in stock DuckDB: the scenario files in `out` (trajdb_simulate(); named
    parameters as there, e.g. cameras=3, minutes=5, seed=1), plus points.parquet typed as the
    shared scenarios. Returns the one summary row (dir, objects, cameras, tracks, points)."""
    for k in params:
        if not str(k).isidentifier():
            raise ValueError(f"trajdb.simulate: parameter names are those of trajdb_simulate (cameras, minutes, seed, ...), got {k!r}")
    # names are identifiers (DuckDB refuses unknown ones); values and paths are bound parameters.
    # The scenario and points.parquet go into one claim of `out` (crates/app/src/outdir.rs), so that
    # points.parquet is in the manifest: a later scenario into `out` replaces it with the rest.
    args = "".join(f", {k} := ?" for k in params)
    out = os.path.abspath(os.fspath(out))
    # kind 'scenario': a scenario folder is never a pipeline's results folder, nor the reverse
    staging = con.execute("FROM trajdb_results_begin(?, '', kind := 'scenario')", [out]).fetchone()[0]
    try:
        row = con.execute(f"FROM trajdb_simulate(?{args})", [staging, *params.values()]).fetchall()[0]
        con.execute("SET VARIABLE trajdb_sim_csv = ?", [os.path.join(staging, "points.csv")])
        con.execute("SET VARIABLE trajdb_sim_parquet = ?", [os.path.join(staging, "points.parquet")])
        read(con, "sql/simulate.sql")  # points.csv -> points.parquet, typed as the shared scenarios
        con.execute("RESET VARIABLE trajdb_sim_csv")
        con.execute("RESET VARIABLE trajdb_sim_parquet")
        con.execute("FROM trajdb_results_end(?, true)", [out]).fetchall()
    except BaseException:
        con.execute("FROM trajdb_results_end(?, false)", [out]).fetchall()
        raise
    row = (out,) + tuple(row[1:])
    return row


def score(con, scenario, results):
    """`trajdb score`: the results folder against the scenario's ground truth (sql/score.sql,
    and sql/score_path.sql when the scenario has world.csv; docs/scoring.md). Returns
    {'rot_deg', 'trans_m', 'clock_s', 'drift_ppm', 'match_f1', 'idf1', 'hota', 'deta', 'assa',
    'exact'} (worst camera pair: clock_s the worst clock error over the recording, drift_ppm the
    worst pairwise drift error; overall match F1, road-user identity and HOTA); the tables
    s_pair_err, s_identity, s_hota, s_class_scores (s_path_summary, s_fuse_vs_best,
    s_path_quality with world.csv) and s_printout (what `trajdb score` prints) stay in `con`: the
    scorer's TEMP tables and macros are all named s_* (a TEMP object of yours of such a name is
    replaced; score on a connection of its own, as `trajdb score` does, to keep yours)."""
    scenario, results = os.path.abspath(scenario), os.path.abspath(results)
    con.execute("SET VARIABLE score_scenario = ?", [scenario])
    con.execute("SET VARIABLE score_results = ?", [results])
    read(con, "sql/score.sql")
    if os.path.exists(os.path.join(scenario, "world.csv")):
        read(con, "sql/score_path.sql")
    # one row, computed in sql/score.sql (s_summary: the F1 and the worst pair are written there)
    cur = con.execute("FROM s_summary")
    return dict(zip([d[0] for d in cur.description], cur.fetchall()[0]))


def archive(con, lake, out, params=None, site=None, workers=None, progress=False, executor=None, task_memory=None):
    """`trajdb archive`: every site=S/date=D partition of the folder `lake` (Parquet or CSV) into
    the archive folder `out` (Hive-partitioned Parquet, a state table, a report per site),
    incremental and resumable (python/trajdb/archives.py; docs/archive.md). Parameters as for
    pipeline (a dict: {"merge_eta": 0.6}). The work runs in connections of its own (one per
    task, one thread each, `workers` processes: the machine's cores by default; DuckDB's memory
    per task `task_memory`, default '1.5GB', spilling beyond it); `con` is the
    caller's, whose sandbox settings hold: with enable_external_access off, lake and out must lie
    in its allowed_directories. Returns a summary: partitions, done, skipped, failed,
    failed_partitions, changes (camera changes found), seconds."""
    from . import archives

    _sandbox(con, [os.fspath(lake), os.fspath(out)], "trajdb.archive")
    return archives.run(lake, out, params=params, site=site, workers=workers, progress=progress, executor=executor, task_memory=task_memory)


def _sandbox(con, paths, who):
    """DuckDB's sandbox of `con` for work done outside it (the archive's own connections):
    nothing in a folder the connection may not list (disabled_filesystems, allowed_directories,
    ...), nor with enable_external_access off unless every path lies in allowed_directories
    (allowed_paths names single files: a folder's work is never covered by it)."""
    # the connection's own file system first, as DuckDB decides for its own SQL (every sandbox
    # setting: disabled_filesystems, which current_setting reads back empty in DuckDB 1.5 and
    # 2.0, included): each folder's listing must be allowed
    for p in paths:
        try:
            con.execute("SELECT count(*) FROM glob(?)", [os.path.join(os.path.abspath(p), "*")]).fetchall()
        except duckdb.PermissionException as e:
            raise PermissionError(f"{who}: this connection may not use {p!r} ({str(e).splitlines()[0]}); allow the folder "
                                  "(allowed_directories, disabled_filesystems) or use another connection") from None
    external, allowed = con.execute(
        "SELECT current_setting('enable_external_access'), current_setting('allowed_directories')").fetchone()
    if external in (True, "true", "True", 1):
        return
    roots = [os.path.realpath(d) for d in (allowed or [])]
    for p in paths:
        real = os.path.realpath(p)
        if not any(real == r or real.startswith(r.rstrip(os.sep) + os.sep) for r in roots):
            raise PermissionError(
                f"{who}: {p!r} is outside this connection's allowed_directories ({', '.join(allowed or []) or 'none'}) and "
                "enable_external_access is off; add the folder to allowed_directories before turning external access off "
                "(allowed_paths names files, not the folders an archive works in)")


def demo(out="trajdb-demo", **params):
    """`trajdb demo` in stock DuckDB: simulate (3 cameras, 5 minutes, seed 1 unless given), run
    the pipeline into out/results, score it against the simulator's truth; raises unless match
    F1 >= 0.95 and every camera pair is within 0.5 deg / 0.3 m (sql/score.sql's s_demo)."""
    con = connect()
    row = simulate(con, out, **params)
    results = os.path.join(out, "results")
    pipeline(con, os.path.join(out, "points.parquet"), out=results)
    s = score(con, out, results)
    ok, verdict = con.execute("SELECT passed, line FROM s_demo").fetchall()[0]
    print(f"simulated {row[1]} objects, {row[2]} cameras, {row[3]} tracks, {row[4]} points -> {out}")
    print(f"{verdict}; results in {results}")
    if not ok:
        raise RuntimeError("demo: the pipeline missed its accuracy targets")
    return s


from .export import export, fit_map  # noqa: E402  (trajdb.export: GeoJSON / GeoPackage / GeoParquet, results on a map)
