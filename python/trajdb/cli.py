"""`trajdb`: the command over stock DuckDB and the trajdb extension (`python -m trajdb`, or the
console script `trajdb` that `pip install .` makes).

    trajdb [--db FILE] [--csv | --json] sql "QUERY"       (or: sql - , SQL on stdin)
    trajdb pipeline --input FILE --out DIR [--param name=value ...]
    trajdb simulate --out DIR [--cameras N --minutes M --seed S ...]
    trajdb score SCENARIO_DIR --results DIR
    trajdb demo [--out DIR] [simulate options]            (simulate -> pipeline -> score)
    trajdb functions [--markdown | --families]            (the SQL function reference)
    trajdb params [--sql]                                 (the pipeline parameters)
    trajdb report RESULTS_DIR [--open]                    (where report.html is; --open: in a browser)
    trajdb install-cli [--duckdb BIN | --duckdb-version V] [--dir DIR]   (LOAD trajdb by name in the DuckDB CLI)
    trajdb help [COMMAND]                                 (or COMMAND --help)

Argument parsing and printing only. The extension does the work: the parameters are checked by
it (trajdb_params), the pipeline runs in it (trajdb.pipeline), the results folder is claimed and
replaced by it; SQL text is split into statements by DuckDB's own parser. An error is one
`Error: ...` message on stderr and exit status 1; a reader that closes the pipe (`| head`) ends
the command quietly with status 0.
"""
import argparse
import csv
import decimal
import json
import math
import os
import sys
import time
import warnings

import duckdb

import trajdb

PROG = "trajdb"


class UsageError(Exception):
    """A bad command line: printed as `Error: ...` like every other error."""


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage dump, exit status 1 through main), and a help
    epilog that may be computed when the help is shown (`pipeline --help` loads the extension
    for its parameter list; nothing else does)."""

    def __init__(self, *a, epilog_fn=None, **kw):
        kw.setdefault("formatter_class", argparse.RawDescriptionHelpFormatter)
        super().__init__(*a, **kw)
        self.epilog_fn = epilog_fn

    def error(self, message):
        raise UsageError(f"{message} (see: {self.prog} --help)")

    def format_help(self):
        if self.epilog_fn is not None:
            self.epilog = self.epilog_fn()
        return super().format_help()


# --- output --------------------------------------------------------------------------------------


def out(text=""):
    """Writes to stdout (a closed pipe is handled in main)."""
    sys.stdout.write(text + "\n")


def verbatim(text):
    """A text as the extension gives it (docs/functions.md, sql/params.sql: byte for byte)."""
    sys.stdout.write(text if text.endswith("\n") else text + "\n")


def note(text):
    """Progress and findings: stderr, as the pipeline's own progress lines."""
    print(text, file=sys.stderr, flush=True)


def _text_rows(rel):
    """The relation's columns and rows as DuckDB's own VARCHAR casts (lists, structs, dates,
    doubles as DuckDB prints them); NULL stays None."""
    cols = rel.columns
    if not cols:
        return cols, []
    return cols, rel.project("COLUMNS(*)::VARCHAR").fetchall()


def print_table(rel):
    cols, rows = _text_rows(rel)
    cells = [["NULL" if v is None else v for v in r] for r in rows]
    widths = [max([len(c)] + [len(r[k]) for r in cells]) for k, c in enumerate(cols)]
    rule = "+" + "+".join("-" * (w + 2) for w in widths) + "+"
    line = lambda vals: "| " + " | ".join(v.ljust(w) for v, w in zip(vals, widths)) + " |"  # noqa: E731
    out("\n".join([rule, line(cols), rule] + [line(r) for r in cells] + [rule]))


def print_csv(rel):
    cols, rows = _text_rows(rel)
    w = csv.writer(sys.stdout, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        w.writerow(["" if v is None else v for v in r])


def _json_value(v):
    if isinstance(v, float) and not math.isfinite(v):
        return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, dict):
        return {str(k): _json_value(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_value(x) for x in v]
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    if isinstance(v, (bytes, bytearray, memoryview)):
        return bytes(v).hex()
    if isinstance(v, decimal.Decimal):
        return _json_value(float(v))
    return str(v)  # Decimal, dates, times, UUIDs: their text


def print_json(rel):
    cols = rel.columns
    rows = rel.fetchall() if cols else []
    out(json.dumps([{c: _json_value(v) for c, v in zip(cols, r)} for r in rows], separators=(",", ":")))


PRINTERS = {"table": print_table, "csv": print_csv, "json": print_json}
# statements whose rows are printed (DuckDB's statement types; DESCRIBE, SHOW, SUMMARIZE, VALUES,
# FROM and TABLE are SELECTs to DuckDB)
ROW_TYPES = {"SELECT", "EXPLAIN", "PRAGMA", "CALL"}


_USER_SQL = False  # an error's "LINE n:" context points into the user's own SQL: kept


def run_sql(con, text, fmt):
    """Runs `text` statement by statement (split by DuckDB's parser), printing the rows of every
    statement that returns rows."""
    global _USER_SQL
    _USER_SQL = True
    for stmt in con.extract_statements(text):
        kind = getattr(stmt.type, "name", str(stmt.type)).split(".")[-1]
        if kind in ROW_TYPES:
            rel = con.sql(stmt.query)
            if rel is not None:
                PRINTERS[fmt](rel)
        else:
            con.execute(stmt.query)


# --- simulator options (simulate, demo) ------------------------------------------------------------

# (option, type, trajdb_simulate's named parameter, default as trajdb_simulate has it, help)
SIM_OPTIONS = [
    ("--cameras", int, "cameras", "3", "number of cameras"),
    ("--minutes", float, "minutes", "5", "simulated minutes"),
    ("--seed", int, "seed", "1", "random seed (the same seed gives the same files)"),
    ("--rate-hz", str, "rate_hz", "10", "camera sampling rate (Hz): R, or R1,R2,... one per camera (cycled)"),
    ("--traffic", float, "traffic", "1", "traffic volume multiplier"),
    ("--site-seed", int, "site_seed", "none", "the site's seed: cameras from it, traffic from --seed (days of one site)"),
    ("--pedestrians", float, "pedestrians", "1", "extra pedestrian multiplier (a crowd: 10)"),
    ("--cyclists", float, "cyclists", "1", "extra cyclist multiplier (bike lanes; 2 a minute at 1)"),
    ("--noise-sigma", str, None, "0.05,0.15", "camera position noise sigma (m): S, or LO,HI drawn per camera"),
    ("--noise-tracks-per-min", float, "noise_tracks_per_min", "1", "spurious tracks per camera and minute"),
    ("--clock-offset-max", float, "clock_offset_max", "0", "camera clocks offset by a uniform draw in +-X s"),
    ("--clock-drift-ppm", float, "clock_drift_ppm", "0", "camera clocks run fast/slow by a uniform draw in +-X ppm"),
    ("--time-jitter-s", float, "time_jitter_s", "0", "each time stamp off the capture time by N(0, X) s, clipped to 0.45 frame"),
    ("--clock-epoch", float, "clock_epoch", "0", "seconds added to every camera clock alike (e.g. 1.78e9, Unix time in 2026)"),
    ("--origin", str, "origin", "none",
     "camera frames far from 0: none, utm (each camera x 4.5e5-5e5, y 5.7e6 m) or X,Y added to every local coordinate"),
    ("--world-rate-hz", float, "world_rate_hz", "10", "sampling rate of world.csv (Hz); 0 skips it"),
    ("--waiting-groups", float, "waiting_groups", "0",
     "groups of 2-8 pedestrians and cyclists waiting 10-60 s at a crossing's kerb, 0.6-2 m apart, per minute (docs/simulate.md)"),
    ("--viewpoint-bias", str, None, "0",
     "largest offset (m) along each camera's line of sight between its reported point and a road user's centre: "
     "VEHICLES[,VRU] (VRU: pedestrians and cyclists; default VEHICLES/5), e.g. 1.2,0.2"),
    ("--ground-plane-error", str, None, "0",
     "ground-plane calibration error per camera: SCALE[,PERSPECTIVE] as fractions (scale in +-SCALE; perspective "
     "error PERSPECTIVE at 50 m from the camera; default PERSPECTIVE = SCALE), e.g. 0.015"),
    ("--occlusion", float, "occlusion", "0",
     "tracks cut mid-view in crowds: cuts per second and per road user within 2 m (e.g. 0.05)"),
]


def _number(option, text):
    try:
        return float(text)
    except ValueError:
        raise UsageError(f"argument {option}: must be a number, got {text!r}") from None


def add_sim_options(p, out_default):
    if out_default is None:
        p.add_argument("--out", required=True, metavar="DIR", help="folder for points.parquet / points.csv and the ground truth")
    else:
        p.add_argument("--out", default=out_default, metavar="DIR", help=f"folder for the scenario, results in DIR/results [default: {out_default}]")
    for opt, typ, _, default, hlp in SIM_OPTIONS:
        # no argparse default: an option not given is not passed, trajdb_simulate's default holds
        p.add_argument(opt, type=typ, metavar="X", help=f"{hlp} [default: {default}]")


def sim_params(a):
    """The given simulator options as trajdb_simulate's named parameters (values unchecked here:
    trajdb_simulate checks them and names the parameter in its error)."""
    params = {}
    for opt, _, name, _, _ in SIM_OPTIONS:
        v = getattr(a, opt[2:].replace("-", "_"))
        if v is None:
            continue
        if opt == "--noise-sigma":
            lo, sep, hi = v.partition(",")
            params["noise_sigma_min"] = _number(opt, lo)
            if sep:
                params["noise_sigma_max"] = _number(opt, hi)
        elif opt == "--viewpoint-bias":
            veh, sep, vru = v.partition(",")
            params["viewpoint_bias_vehicle"] = _number(opt, veh)
            params["viewpoint_bias_vru"] = _number(opt, vru) if sep else params["viewpoint_bias_vehicle"] / 5
        elif opt == "--ground-plane-error":
            sc, sep, pe = v.partition(",")
            params["ground_plane_scale"] = _number(opt, sc)
            params["ground_plane_perspective"] = _number(opt, pe) if sep else params["ground_plane_scale"]
        else:
            params[name] = v
    return params


# --- commands --------------------------------------------------------------------------------------


def connect(a):
    return trajdb.connect(a.db) if a.db else trajdb.connect()


def cmd_sql(a):
    text = sys.stdin.read() if a.query == "-" else a.query
    run_sql(connect(a), text, a.format)


def params_table(con):
    """The parameter table (name, type, default, range, stage, description) as the extension
    prints it (trajdb_reference('params'), crates/app/src/params.rs)."""
    return con.execute("SELECT trajdb_reference('params')").fetchall()[0][0].rstrip("\n")


def pipeline_epilog():
    try:
        table = params_table(trajdb.connect())
    except Exception as e:  # noqa: BLE001 - help still prints; the reason is shown
        table = f"(the list needs the extension loaded: {e})"
    return ("Parameters (`auto`: measured by the calibrate stage; --param name=value sets one, "
            "checked by the extension against its type and range):\n" + table)


def cmd_pipeline(a):
    run_pipeline(connect(a), a.input, a.out, _params_of(a))


def run_pipeline(con, input, out_dir, params):
    """trajdb.pipeline with its stage times on stderr, then what was found and its warnings."""
    t = time.perf_counter()
    with warnings.catch_warnings(record=True) as found:
        warnings.simplefilter("always")
        trajdb.pipeline(con, input, out=out_dir, progress=True, **params)
    note(f"[trajdb] total     {time.perf_counter() - t:7.2f} s")
    summary(con, out_dir)
    for w in found:
        note(f"[trajdb] warning: {str(w.message).removeprefix('trajdb.pipeline: ')}")


def summary(con, out_dir):
    """What was found, in a few lines (stderr): sql/summary.sql over the pipeline's tables in `con`."""
    trajdb.read(con, "sql/summary.sql")
    for (line,) in con.execute("SELECT line FROM pipeline_summary ORDER BY k").fetchall():
        note(f"[trajdb] {line}")
    note(f"[trajdb]          results in {out_dir}, open {os.path.join(out_dir, 'report.html')} for the report")


def simulate(con, out_dir, params):
    t = time.perf_counter()
    row = trajdb.simulate(con, out_dir, **params)
    note(f"[trajdb] simulate {time.perf_counter() - t:>7.2f} s  {row[1]} objects, {row[2]} cameras, {row[3]} tracks, "
         f"{row[4]} points -> {out_dir}")
    return row


def cmd_simulate(a):
    simulate(connect(a), a.out, sim_params(a))


# What each file of a results folder is (`trajdb demo` lists them; docs/outputs.md has every column;
# tests/test_cli_python.py checks every file written has a line here)
RESULT_FILES = {
    "report.html": "the report: site map, movements, counts per 15 min with the peak hour, speeds, near misses, QA",
    "merged.parquet": "one row per road user: its fused path, sources, times, length (GeoParquet)",
    "matches.csv": "the accepted cross-camera links between original tracks",
    "links.csv": "each track's chain of pieces within its camera (broken tracks linked)",
    "transforms.csv": "each camera pair's transform and clock relation",
    "calibration.csv": "what the pipeline measured and derived from the data",
    "clusters.csv": "route patterns of one camera's tracks",
    "analysis.sql": "the analysis macros over merged.parquet: .read it in the DuckDB CLI",
}


def cmd_demo(a):
    con = connect(a)
    note(f"[trajdb] demo: simulate intersection traffic -> {a.out}")
    simulate(con, a.out, sim_params(a))
    results = os.path.join(a.out, "results")
    run_pipeline(con, os.path.join(a.out, "points.parquet"), results, {})
    out(f"score of {results} against the simulator's ground truth:")
    print_score(con, a.out, results)
    ok, verdict = con.execute("SELECT passed, line FROM s_demo").fetchall()[0]
    out(verdict)
    out(f"results in {results} (every column: docs/outputs.md):")
    for name in sorted(n for n in os.listdir(results) if not n.startswith(".")):
        size = os.path.getsize(os.path.join(results, name))
        out(f"  {name:<16} {size:>10,} B  {RESULT_FILES.get(name, 'a file of this run')}")
    if not ok:
        raise RuntimeError("demo: the pipeline missed its accuracy targets")


def _params_of(a):
    params = {}
    for p in a.param or []:
        name, sep, value = p.partition("=")
        if not sep:
            raise UsageError(f"--param needs name=value, got {p!r}")
        params[name.strip()] = value.strip()
    return params


# `trajdb archive`'s exit status when partitions failed: FAILED_BASE + their number, at most
# FAILED_BASE + FAILED_MAX (statuses 1 and 2 are an error and a usage error; 130 an interrupt)
FAILED_BASE, FAILED_MAX = 3, 120


def cmd_archive(a):
    if a.workers is not None and a.workers < 1:
        raise UsageError(f"--workers must be >= 1, got {a.workers}")
    con = connect(a)
    r = trajdb.archive(con, a.input, a.out, params=_params_of(a), site=a.site, workers=a.workers, progress=True, task_memory=a.task_memory)
    note(f"[trajdb] archive   {r['partitions']} partitions: {r['done']} run, {r['skipped']} unchanged, {r['failed']} failed "
         f"({r['seconds']:.1f} s) -> {r['out']}")
    for c in r["changes"]:
        note(f"[trajdb] warning: camera change at site {c['site']} on {c['date']}: {c['message']}; registered again from that day")
    for p in r["failed_partitions"]:
        note(f"[trajdb] failed:  {p} (the error is in {os.path.join(r['out'], '_state', 'partitions.parquet')}, column error)")
    for p in r["orphaned"]:
        note(f"[trajdb] note:    {p} is in the archive but no longer in the lake; its results are kept")
    note(f"[trajdb]          open {os.path.join(r['out'], 'reports')} for the reports (index.html per site)")
    if r["failed"]:
        # 3 + the number failed (0 ok, 1 an error, 2 a usage error, so no count collides with them)
        raise SystemExit(FAILED_BASE + min(r["failed"], FAILED_MAX))


def cmd_simulate_lake(a):
    move = None
    if a.move:
        f = a.move.split(",")
        if len(f) not in (6, 7):
            raise UsageError(f"--move needs SITE,DAY,CAMERA,DX,DY,DEG[,DT], got {a.move!r}")
        move = {"site": f[0], "day": int(f[1]), "camera": int(f[2]), "dx": _number("--move", f[3]), "dy": _number("--move", f[4]),
                "deg": _number("--move", f[5]), "dt": _number("--move", f[6]) if len(f) == 7 else 0.0}
    from trajdb import lake_sim

    t = time.perf_counter()
    parts = lake_sim.simulate_lake(connect(a), a.out, sites=a.sites, days=a.days, minutes=a.minutes, cameras=a.cameras, move=move,
                                   traffic=a.traffic)
    note(f"[trajdb] simulate-lake {time.perf_counter() - t:.1f} s: {len(parts)} partitions, {sum(n for _, _, n in parts)} points -> {a.out}")


def cmd_score(a):
    print_score(connect(a), a.scenario, a.results)


def cmd_functions(a):
    fmt = "markdown" if a.markdown else "families" if a.families else "text"
    verbatim(connect(a).execute("SELECT trajdb_reference(?)", [fmt]).fetchone()[0])


def cmd_sql_file(a):
    verbatim(connect(a).execute("SELECT trajdb_pipeline_sql()").fetchone()[0])


def cmd_params(a):
    con = connect(a)
    if a.sql:
        verbatim(con.execute("SELECT trajdb_params_script()").fetchone()[0])
    else:
        out(params_table(con))


def cmd_report(a):
    page = os.path.abspath(os.path.join(a.results, "report.html"))
    if not os.path.isfile(page):
        raise RuntimeError(f"{page} does not exist: report.html is written by `trajdb pipeline --out {a.results}`")
    url = "file://" + page
    out(url)
    if a.open:
        import webbrowser

        if not webbrowser.open(url):
            raise RuntimeError(f"no browser could be started; open {url} yourself")


def _cli_version(binary):
    """The version folder of a DuckDB command line (`duckdb --version`: v1.5.6 (Variegata) 069cc9f9b5;
    a development build: its source id)."""
    import shutil
    import subprocess

    exe = shutil.which(binary)
    if exe is None:
        raise RuntimeError(f"no DuckDB command line {binary!r} found: give its path with --duckdb, "
                           "or the version it reports (duckdb --version) with --duckdb-version v1.5.6")
    try:
        words = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=60, check=True).stdout.split()
    except (OSError, subprocess.SubprocessError) as e:
        raise RuntimeError(f"`{exe} --version` failed ({e}): give the version with --duckdb-version v1.5.6") from None
    if not words or not words[0].startswith("v"):
        raise RuntimeError(f"`{exe} --version` printed {' '.join(words)!r}, not a DuckDB version: give it with --duckdb-version")
    return words[-1] if "-dev" in words[0] and len(words) > 1 else words[0]


def cmd_install_cli(a):
    version = a.duckdb_version or _cli_version(a.duckdb)
    path, what = trajdb.install_extension(a.dir, version, a.platform)
    out(f"{what}: {path}")
    out("the DuckDB command line loads it by name (it is not signed by DuckDB, hence -unsigned):")
    out("  duckdb -unsigned -c \"LOAD trajdb; SELECT trajdb_reference('text')\"")


# --- trajdb score: the printout is sql/score.sql's table s_printout -------------------------------------


def print_score(con, scenario, results):
    """`trajdb score`: trajdb.score (sql/score.sql, and sql/score_path.sql when the scenario has
    world.csv), then its printout, written by those files (s_printout; benches/identity_grid.sh
    and tests/test_cli_python.py read it by position). Returns trajdb.score's summary."""
    s = trajdb.score(con, scenario, results)
    for (line,) in con.execute("SELECT line FROM s_printout ORDER BY section, k").fetchall():
        out(line)
    return s


# --- the parser --------------------------------------------------------------------------------------


def build_parser():
    # --db, --csv, --json: before or after the command (a parent parser on both levels; SUPPRESS
    # keeps a subcommand from resetting what was given before it)
    def common(top):
        p = argparse.ArgumentParser(add_help=False)
        d = {} if top else {"default": argparse.SUPPRESS}
        p.add_argument("--db", metavar="FILE", help="a DuckDB database file (default: in memory)", **({"default": None} if top else d))
        g = p.add_mutually_exclusive_group()
        g.add_argument("--csv", dest="format", action="store_const", const="csv", help="print query results as CSV", **d)
        g.add_argument("--json", dest="format", action="store_const", const="json", help="print query results as JSON", **d)
        return p

    top = Parser(
        prog=PROG,
        parents=[common(True)],
        description="Multi-camera traffic-trajectory analysis in stock DuckDB with the trajdb extension: align cameras, "
        "match and merge tracks, cluster routes.",
        epilog="`trajdb help COMMAND` or `trajdb COMMAND --help` describes a command and its options with their defaults.",
    )
    top.set_defaults(format="table")
    top.add_argument("--version", action="version", version=f"trajdb {trajdb.__version__} (duckdb {duckdb.__version__})")
    sub = top.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    cmds = {}

    def add(name, fn, hlp, **kw):
        p = sub.add_parser(name, help=hlp, description=hlp, parents=[common(False)], **kw)
        p.set_defaults(fn=fn)
        cmds[name] = p
        return p

    p = add("sql", cmd_sql, "run SQL (one statement or several, separated by ;) and print the rows of each")
    p.add_argument("query", metavar="QUERY", help="the SQL text; - reads it from stdin")
    p = add("pipeline", cmd_pipeline,
            "the whole pipeline: calibrate, clean, link, align, overlap, match and merge, cluster; writes the results and report.html",
            epilog_fn=pipeline_epilog)
    p.add_argument("--input", required=True, metavar="FILE", help="points as Parquet or CSV: camera, track_id, class, t, x, y[, estimated]")
    p.add_argument("--out", required=True, metavar="DIR", help="results folder (replaced only when the run succeeds)")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help="set a parameter (repeatable); the list follows")
    p = add("archive", cmd_archive,
            "an archive: every site=S/date=D partition of a lake into Hive-partitioned results, incremental and resumable, "
            "each site's calibration kept and checked every day (docs/archive.md); the exit status is 3 + the number of failed partitions (at most 123) when any failed")
    p.add_argument("--input", required=True, metavar="LAKE", help="a folder of site=S/date=D/ (or date=D/) folders of Parquet or CSV points")
    p.add_argument("--out", required=True, metavar="DIR", help="the archive folder: new, empty, or one trajdb archive made")
    p.add_argument("--site", metavar="NAME", help="the site's name when LAKE holds date=D/ folders of one site [default: LAKE's folder name]")
    p.add_argument("--workers", type=int, metavar="N", help="partitions run at once, one core each [default: the machine's cores]")
    p.add_argument("--task-memory", metavar="SIZE", help="DuckDB's memory per partition, beyond which it spills to disk [default: 1.5GB]")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help="set a pipeline parameter (repeatable; trajdb params lists them)")
    p = add("simulate-lake", cmd_simulate_lake,
            "simulate an archive: sites x days of trajdb simulate as LAKE/site=S/date=D/points.parquet (truth in LAKE-truth)")
    p.add_argument("--out", required=True, metavar="LAKE", help="a new folder")
    p.add_argument("--sites", type=int, default=2, metavar="N", help="sites [default: 2]")
    p.add_argument("--days", type=int, default=3, metavar="N", help="days per site [default: 3]")
    p.add_argument("--minutes", type=float, default=10.0, metavar="X", help="minutes per day [default: 10]")
    p.add_argument("--cameras", type=int, default=3, metavar="N", help="cameras per site [default: 3]")
    p.add_argument("--traffic", type=float, default=1.0, metavar="X", help="traffic volume multiplier [default: 1]")
    p.add_argument("--move", metavar="SITE,DAY,CAMERA,DX,DY,DEG[,DT]",
                   help="from day DAY (0 = the first) on, site SITE's camera CAMERA moved by DX, DY m, turned by DEG degrees and its clock "
                        "DT s ahead, e.g. s1,2,1,1,0,0")
    p = add("score", cmd_score, "score a results folder against a scenario's ground truth (cameras.csv, truth.csv, world.csv)")
    p.add_argument("scenario", metavar="SCENARIO_DIR")
    p.add_argument("--results", required=True, metavar="DIR", help="the --out folder of trajdb pipeline")
    add_sim_options(add("simulate", cmd_simulate, "simulate an intersection seen by N cameras, with ground truth (trajdb_simulate)"), None)
    add_sim_options(add("demo", cmd_demo, "simulate, run the pipeline and score it (no outside data needed)"), "trajdb-demo")
    p = add("functions", cmd_functions, "the SQL function reference")
    how = p.add_mutually_exclusive_group()
    how.add_argument("--markdown", action="store_true", help="as docs/functions.md")
    how.add_argument("--families", action="store_true",
                     help="where each section's maths, bindings and functions live (the generated table of docs/development.md)")
    add("sql-file", cmd_sql_file, "the whole pipeline as one SQL file for the DuckDB CLI (as sql/trajdb_pipeline.sql)")
    p = add("params", cmd_params, "the pipeline parameters")
    p.add_argument("--sql", action="store_true", help="as sql/params.sql")
    p = add("report", cmd_report, "the report.html of a results folder: its file:// address (--open: in the default browser)")
    p.add_argument("results", metavar="RESULTS_DIR")
    p.add_argument("--open", action="store_true", help="open it in the default web browser")
    p = add("install-cli", cmd_install_cli,
            "copy the extension where the DuckDB command line finds it by name (LOAD trajdb): "
            "DIR/<its version>/<platform>/trajdb.duckdb_extension; a file there that trajdb did not write is never replaced")
    p.add_argument("--duckdb", default="duckdb", metavar="BIN", help="the DuckDB command line whose version decides the folder [default: duckdb on PATH]")
    p.add_argument("--duckdb-version", metavar="V", help="its version (v1.5.6) instead of running it")
    p.add_argument("--dir", default=trajdb.DEFAULT_EXTENSION_DIR, metavar="DIR",
                   help=f"the extension directory [default: {trajdb.DEFAULT_EXTENSION_DIR}, the CLI's own]")
    p.add_argument("--platform", metavar="P", help="DuckDB platform name [default: this Python's DuckDB's, e.g. linux_amd64]")
    p = add("help", None, "this overview, or a command's help")
    p.add_argument("topic", nargs="?", metavar="COMMAND")
    return top, cmds


def _join_values(argv):
    """`--origin -100,250` and `--clock-epoch -1e9` as `--origin=-100,250`: argparse would take a
    value that starts with '-' for an option (clap allowed it)."""
    takes = {o[0] for o in SIM_OPTIONS} | {"--param", "--out", "--input", "--results", "--db", "--move"}
    argv, k = list(argv), 0
    while k < len(argv) - 1:
        if argv[k] in takes and argv[k + 1].startswith("-") and len(argv[k + 1]) > 1:
            argv[k : k + 2] = [f"{argv[k]}={argv[k + 1]}"]
        k += 1
    return argv


def real_main(argv):
    top, cmds = build_parser()
    a = top.parse_args(_join_values(argv))
    if a.command is None:
        # no command: SQL piped on stdin runs (`trajdb --db x.duckdb < script.sql`, as before); a
        # terminal or an empty stdin gets the overview
        text = "" if sys.stdin is None or sys.stdin.isatty() else sys.stdin.read()
        if text.strip():
            run_sql(connect(a), text, a.format)
        else:
            out(top.format_help().rstrip("\n"))
        return
    if a.command == "help":
        if a.topic is None:
            out(top.format_help().rstrip("\n"))
        elif a.topic in cmds:
            out(cmds[a.topic].format_help().rstrip("\n"))
        else:
            raise UsageError(f"no command {a.topic!r}; the commands: {', '.join(cmds)}")
        return
    a.fn(a)


def main(argv=None):
    """The `trajdb` command; returns the exit status (0, or 1 after an error)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        real_main(argv)
        sys.stdout.flush()
        return 0
    except BrokenPipeError:
        return _closed_pipe()
    except KeyboardInterrupt:
        print("Error: interrupted", file=sys.stderr)
        return 130
    except SystemExit as e:  # --help / --version from argparse
        try:
            sys.stdout.flush()
        except BrokenPipeError:
            return _closed_pipe()
        return e.code if isinstance(e.code, int) else 0
    except Exception as e:  # noqa: BLE001 - every error is one message, never a traceback
        try:
            sys.stdout.flush()
        except BrokenPipeError:
            return _closed_pipe()
        msg = str(e).strip() or type(e).__name__
        if isinstance(e, duckdb.Error) and not _USER_SQL:
            # DuckDB's "LINE 1: ..." context shows the command's own internal query, not the user's
            msg = msg.split("\n\nLINE ")[0].rstrip()
        # where it happened (trajdb.execute_steps adds the stage and its file as a note)
        msg = "\n".join([msg] + [f"  {n}" for n in getattr(e, "__notes__", [])])
        print(f"Error: {msg}", file=sys.stderr)
        return 1


def _closed_pipe():
    """The reader is gone (`trajdb ... | head`): not an error. stdout goes to /dev/null so that
    Python's own flush at exit does not complain."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except OSError:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
