#!/usr/bin/env python3
"""The pipeline runner as a careless or hostile user meets it, through the loadable extension in
PyPI DuckDB (issue 25): every case here failed before the fix.

- the results folder: a folder with the user's files, '', '/', 'x/y/..', the input's own folder,
  a failed run (the earlier results stay, no staging folder is left), two runs at once, the
  folder's permissions, a hostile manifest;
- injection: an input string that is SQL (chr(47) tricks, a smuggled COPY), parameter names and
  values (unknown names, NaN, out of range), simulate keyword names;
- parameters do not leak from one run into the next on the same connection;
- the input `points` (a user's table of the pipeline's working table's name), TIMESTAMPTZ under two
  session time zones, exact duplicate rows, times in milliseconds and coordinates in millimetres,
  an all-estimated input;
- metamorphic: rows shuffled, track ids relabelled, the input duplicated give the same road users.

usage: python3 tests/test_safety_python.py path/to/trajdb.duckdb_extension
"""
import os
import stat
import shutil
import subprocess
import sys
import tempfile
import threading
import warnings

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "python"))
os.environ["TRAJDB_EXTENSION"] = os.path.abspath(sys.argv[1])

import duckdb  # noqa: E402
import trajdb  # noqa: E402

FAILED = []


def check(name, cond, detail=""):
    print(("ok   " if cond else "FAIL ") + name + ("" if cond else f": {detail}"))
    if not cond:
        FAILED.append(name)


def raises(fn, *needles):
    try:
        fn()
    except Exception as e:  # noqa: BLE001
        msg = str(e)
        return all(n in msg for n in needles), msg
    return False, "no error"


def tree(d):
    out = {}
    for root, dirs, files in os.walk(d):
        for f in files:
            p = os.path.join(root, f)
            with open(p, "rb") as fh:
                out[os.path.relpath(p, d)] = fh.read()
    return out


def road_users(con, relabel=None):
    """The road users as a set of frozensets of (camera, track_id); `relabel` maps ids back."""
    rows = con.sql("SELECT [(s.camera, s.track_id) FOR s IN sources] FROM merged").fetchall()
    f = relabel or (lambda c, t: (c, t))
    return {frozenset(f(c, t) for c, t in r[0]) for r in rows}


def main():
    w = tempfile.mkdtemp(prefix="trajdb-safety-")
    con = trajdb.connect()
    trajdb.simulate(con, os.path.join(w, "scene"), cameras=2, minutes=1, seed=3)
    scene = os.path.join(w, "scene", "points.parquet")
    con.execute("CREATE TABLE scene AS FROM read_parquet(?)", [scene])

    # ---- 1. the results folder
    user = os.path.join(w, "user")
    os.makedirs(user)
    with open(os.path.join(user, "notes.txt"), "w") as f:
        f.write("mine")
    before = tree(user)
    ok, msg = raises(lambda: trajdb.pipeline(con, os.path.join(w, "typo.parquet"), out=user), "did not write")
    check("out with the user's files is refused before any work (a typo'd input)", ok, msg)
    check("... and the user's files are untouched", tree(user) == before)
    ok, msg = raises(lambda: trajdb.pipeline(con, scene, out=user), "did not write")
    check("out with the user's files is refused (a good input)", ok and tree(user) == before, msg)
    ok, msg = raises(lambda: trajdb.pipeline(con, scene, out=""), "empty")
    check("out='' is refused", ok, msg)
    ok, msg = raises(lambda: trajdb.pipeline(con, scene, out="/"), "root")
    check("out='/' is refused", ok, msg)
    os.makedirs(os.path.join(user, "y"))
    ok, msg = raises(lambda: trajdb.pipeline(con, scene, out=os.path.join(user, "y", "..")), "did not write")
    check("out='x/y/..' is x, refused", ok and os.path.exists(os.path.join(user, "notes.txt")), msg)
    ok, msg = raises(lambda: trajdb.pipeline(con, scene, out=os.path.join(w, "scene")), "")
    check("out = the input's folder is refused, the input stays", not ok or os.path.exists(scene), msg)
    check("... the input's folder", os.path.exists(scene) and ("input" in msg or "did not write" in msg), msg)
    home = os.path.expanduser("~")
    ok, msg = raises(lambda: trajdb.pipeline(con, scene, out=home), "")
    check("out = the home folder is refused", "did not write" in msg or "input" in msg, msg)

    res = os.path.join(w, "results")
    trajdb.pipeline(con, scene, out=res)
    first = tree(res)
    check("a run writes the results and its manifest", "merged.parquet" in first and ".trajdb-results" in first, sorted(first))
    mode = stat.S_IMODE(os.stat(res).st_mode)
    check("the results folder has normal permissions", mode != 0o700 and mode & 0o005, oct(mode))
    with open(os.path.join(res, "my_notes.txt"), "w") as f:
        f.write("mine")
    ok, msg = raises(lambda: trajdb.pipeline(con, os.path.join(w, "typo.parquet"), out=res), "typo")
    after = tree(res)
    check("a failed run keeps the earlier results and the user's file", ok and all(after.get(k) == v for k, v in first.items()) and "my_notes.txt" in after, msg)
    check("... and leaves no staging folder", not any(".trajdb-partial" in k for k in after) and
          not any(n.startswith(".trajdb-partial") for n in os.listdir(res)), sorted(os.listdir(res)))
    trajdb.pipeline(con, scene, out=res)
    check("a rerun replaces its own files and keeps the user's", "my_notes.txt" in os.listdir(res) and "merged.parquet" in os.listdir(res))
    ok, msg = raises(lambda: trajdb.pipeline(con, os.path.join(res, "merged.parquet"), out=res), "input")
    check("out containing the input is refused", ok, msg)
    # two runs at once on one folder: one wins, the other fails clearly; neither corrupts
    errs = []

    def run_one():
        try:
            c = trajdb.connect()
            trajdb.pipeline(c, scene, out=os.path.join(w, "race"))
        except Exception as e:  # noqa: BLE001
            errs.append(str(e))

    ts = [threading.Thread(target=run_one) for _ in range(2)]
    [t.start() for t in ts]
    [t.join() for t in ts]
    race = os.listdir(os.path.join(w, "race"))
    check("two runs on one out: at most one fails, with a clear error", len(errs) <= 1 and all("another trajdb run" in e for e in errs), errs)
    check("... and the folder holds one complete result set", "merged.parquet" in race and not any(n.startswith(".trajdb-partial") for n in race), race)
    # the same race, 40 times on new folders, through the claim alone (4 threads each): exactly
    # one claim wins each time, every other fails with the clear error
    race_errs, race_wins = [], 0
    for k in range(40):
        target = os.path.join(w, "races", str(k))
        got = []

        def claim_one(target=target, got=got):
            c = trajdb.connect()
            try:
                got.append(("ok", c.execute("FROM trajdb_results_begin(?, '')", [target]).fetchall()))
            except duckdb.Error as e:
                got.append(("err", str(e)))
            finally:
                c.close()

        ts = [threading.Thread(target=claim_one) for _ in range(4)]
        [t.start() for t in ts]
        [t.join() for t in ts]
        race_wins += sum(1 for g in got if g[0] == "ok")
        race_errs += [g[1] for g in got if g[0] == "err" and "another trajdb run" not in g[1]]
    check(f"40 races of 4 claims: only clear refusals ({race_wins} claims won)", not race_errs and race_wins >= 40, race_errs[:2])

    # a hostile manifest: names outside the folder are never deleted
    hostile = os.path.join(w, "hostile")
    os.makedirs(hostile)
    with open(os.path.join(hostile, ".trajdb-results"), "w") as f:
        f.write("../victim.txt\n")
    with open(os.path.join(w, "victim.txt"), "w") as f:
        f.write("mine")
    ok, msg = raises(lambda: trajdb.pipeline(con, scene, out=hostile), "not written by trajdb")
    check("a manifest trajdb did not write (naming ../victim.txt) deletes nothing", ok and os.path.exists(os.path.join(w, "victim.txt")), msg)
    with open(os.path.join(hostile, ".trajdb-results"), "w") as f:
        f.write("# trajdb results: the files below were written by trajdb and may be replaced by its next run into this folder\n../victim.txt\n")
    ok, msg = raises(lambda: trajdb.pipeline(con, scene, out=hostile), "earlier trajdb")
    check("a manifest in trajdb's form naming ../victim.txt deletes nothing", ok and os.path.exists(os.path.join(w, "victim.txt")), msg)

    issue37(w, con, scene)

    # ---- 2. injection
    marker = os.path.join(w, "pwned")
    for evil in [
        f"scene; COPY (SELECT 1) TO '{marker}'",
        f"(SELECT 1); COPY (SELECT 1) TO '{marker}' --",
        "read_text('/etc/passwd')",
        f"trajdb_simulate('{w}' || chr(47) || 'evil')",
        "scene' ; CALL trajdb_set_limit('lcss_cells', 1) --",
    ]:
        ok, msg = raises(lambda: trajdb.pipeline(con, evil), "neither a table")
        check(f"input {evil[:40]!r} is a (missing) file name, not SQL", ok and not os.path.exists(marker) and "root:" not in msg
              and not os.path.exists(os.path.join(w, "evil")), msg)
    check("... the work limits were not changed", con.sql("SELECT trajdb_limit('lcss_cells')").fetchall()[0][0] == 10_000_000_000)
    for bad, needle in [({"merge_etta": 0.5}, "unknown parameter"), ({"merge_eta": float("nan")}, "merge_eta"), ({"merge_eta": 2}, "merge_eta must be in"),
                        ({"merge_eta": "0.5; DROP TABLE scene"}, "merge_eta"), ({"x = 1; COPY": 1}, "unknown parameter")]:
        ok, msg = raises(lambda: trajdb.pipeline(con, "scene", **bad), needle)
        check(f"parameter {bad} is refused", ok, msg)
    ok, msg = raises(lambda: trajdb.simulate(con, os.path.join(w, "sim2"), **{"cameras := 2, seed": 1}), "parameter names")
    check("simulate keyword names are identifiers", ok, msg)
    check("the user's table survived", con.sql("SELECT count(*) > 0 FROM scene").fetchall()[0][0])

    # ---- parameters do not leak into the next run
    trajdb.pipeline(con, "scene", merge_eta=0.9)
    eta1 = con.sql("SELECT getvariable('merge_eta')").fetchall()[0][0]
    trajdb.pipeline(con, "scene")
    eta2 = con.sql("SELECT getvariable('merge_eta')").fetchall()[0][0]
    check("a parameter of one run does not leak into the next", eta1 == 0.9 and eta2 == 0.5, (eta1, eta2))
    base = road_users(con)
    check("the scene has road users seen by two cameras", any(len(r) > 1 for r in base) and len(base) > 10, len(base))

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        trajdb.pipeline(con, "scene", cluster_classes="cars, pedestrian")
    check("a class name the input lacks (cluster_classes='cars'): a warning", any("cluster_classes names [cars]" in str(x.message) for x in caught),
          [str(x.message) for x in caught])

    # ---- a name is looked up as DuckDB does: a registered DataFrame / TEMP table first, then the
    # current catalog; the same name in two attached catalogs is an error, not a guess
    con.execute("ATTACH ':memory:' AS archive")
    con.execute("CREATE TABLE archive.main.trips AS FROM scene WHERE camera = (SELECT min(camera) FROM scene)")
    con.execute("CREATE TABLE trips AS FROM scene")
    trajdb.pipeline(con, "trips")
    check("a name in the current catalog wins over an attached one", road_users(con) == base)
    con.execute("CREATE TEMP TABLE trips AS FROM scene")
    trajdb.pipeline(con, "trips")
    check("... and a TEMP table of that name wins, as in DuckDB", road_users(con) == base)
    con.execute("CREATE TABLE archive.main.legs AS FROM scene")
    con.execute("ATTACH ':memory:' AS archive2")
    con.execute("CREATE TABLE archive2.main.legs AS FROM scene")
    ok, msg = raises(lambda: trajdb.pipeline(con, "legs"), "names 2 tables or views")
    check("the same name in two attached catalogs: an error", ok, msg)

    # ---- the input named points, twice
    con.execute("CREATE OR REPLACE TABLE points AS FROM scene")
    trajdb.pipeline(con, "points")
    a = road_users(con)
    trajdb.pipeline(con, "points")
    b = road_users(con)
    check("a user's table named points gives the same road users on the second run", a == b == base, (len(a), len(b), len(base)))
    check("... and is still the user's table", con.sql("SELECT count(*) FROM memory.main.points").fetchall() == con.sql("SELECT count(*) FROM scene").fetchall())
    con.execute("DROP TABLE memory.main.points")

    # ---- an object as input (a DuckDB relation here; pandas / Arrow / Polars go the same way,
    # through con.register under a name of trajdb's own, unregistered afterwards)
    before_views = con.sql("SELECT count(*) FROM duckdb_views() WHERE NOT internal").fetchall()
    trajdb.pipeline(con, con.sql("FROM scene ORDER BY hash(t)"))
    check("a relation object as input: the same road users", road_users(con) == base)
    check("... and its registration is gone", con.sql("SELECT count(*) FROM duckdb_views() WHERE NOT internal").fetchall() == before_views)

    # ---- metamorphic: shuffled rows, relabelled ids, duplicated input, TIMESTAMPTZ in two zones
    con.execute("CREATE TABLE shuffled AS FROM scene ORDER BY hash(camera, track_id, t, 17)")
    trajdb.pipeline(con, "shuffled")
    check("rows shuffled: the same road users", road_users(con) == base)
    con.execute("CREATE TABLE relabelled AS SELECT * REPLACE (track_id * 7919 + 1000003 - camera AS track_id) FROM scene")
    trajdb.pipeline(con, "relabelled")
    back = {(c, t * 7919 + 1000003 - c): (c, t) for c, t in con.sql("SELECT DISTINCT camera, track_id FROM scene").fetchall()}
    check("track ids relabelled: the same road users", road_users(con, lambda c, t: back[(c, t)]) == base)
    con.execute("CREATE TABLE doubled AS FROM scene UNION ALL FROM scene")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        trajdb.pipeline(con, "doubled")
    check("the input twice: the same road users", road_users(con) == base)
    check("... with a warning that counts the repeats", any("repeat the (camera, track_id, t)" in str(x.message) for x in caught), [str(x.message) for x in caught])
    con.execute("CREATE TABLE one_cam_twice AS FROM scene UNION ALL (FROM scene WHERE camera = (SELECT min(camera) FROM scene))")
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        trajdb.pipeline(con, "one_cam_twice")
    check("one camera twice: the same road users", road_users(con) == base)
    # a camera exported again under ANOTHER id (issue 37): not a second camera; left out after the
    # load with a warning naming both (before: aligned at 0 deg, 0 s to its twin, every road user it
    # saw doubled)
    con.execute("CREATE TABLE twin_cam AS FROM scene UNION ALL (SELECT * REPLACE ((SELECT max(camera) FROM scene) + 100 AS camera) "
                "FROM scene WHERE camera = (SELECT min(camera) FROM scene))")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        trajdb.pipeline(con, "twin_cam")
    check("one camera exported again under another id: the same road users", road_users(con) == base)
    check("... with a warning naming both cameras", any("exported again" in str(x.message) for x in caught), [str(x.message) for x in caught])
    con.execute("CREATE TABLE tz AS SELECT * REPLACE (to_timestamp(t + 1790000000) AS t) FROM scene")
    got = []
    for zone in ["UTC", "America/New_York"]:
        con.execute(f"SET TimeZone = '{zone}'")
        trajdb.pipeline(con, "tz")
        got.append((road_users(con), con.sql("SELECT min(t) FROM points").fetchall()[0][0]))
    con.execute("SET TimeZone = 'UTC'")
    check("TIMESTAMPTZ: the same road users and epoch seconds under UTC and New York", got[0] == got[1] and got[0][0] == base, [g[1] for g in got])

    # ---- units, estimated-only, careless column mappings and types: each a clear error from the load
    refused = [
        ("times in milliseconds", "SELECT * REPLACE (t * 1000 AS t) FROM scene", "column t looks like milliseconds"),
        ("coordinates in millimetres", "SELECT * REPLACE (x * 1000 AS x, y * 1000 AS y) FROM scene", "millimetres"),
        ("coordinates in kilometres", "SELECT * REPLACE (x / 1000 AS x, y / 1000 AS y) FROM scene", "too slow for road users"),
        ("an all-estimated input", "SELECT * REPLACE (1 AS estimated) FROM scene", "is estimated"),
        ("a camera id beyond INTEGER", "SELECT * REPLACE (camera::BIGINT + 5000000000 AS camera) FROM scene", "beyond a 32-bit INTEGER"),
        ("epoch seconds in a FLOAT", "SELECT * REPLACE ((t + 1.79e9)::FLOAT AS t) FROM scene", "is FLOAT (32-bit)"),
        ("a DATE t", "SELECT * REPLACE (DATE '2026-01-01' + (t // 86400)::INTEGER AS t) FROM scene", "column t is DATE"),
        ("UTM coordinates in a FLOAT", "SELECT * REPLACE ((x + 4.6e5)::FLOAT AS x, (y + 5.7e6)::FLOAT AS y) FROM scene", "are FLOAT (32-bit)"),
    ]
    for k, (label, q, needle) in enumerate(refused):
        con.execute(f"CREATE TABLE refused_{k} AS {q}")
        ok, msg = raises(lambda: trajdb.pipeline(con, f"refused_{k}"), needle)
        check(f"{label}: a clear error from the load", ok and "meta row" not in msg, msg)
    for cols, needle in [("camera=a, camera=b", "gives a role twice"), ("camera=track_id", "two roles from one column"), ("time=t", "not a role")]:
        ok, msg = raises(lambda: trajdb.pipeline(con, "scene", input_columns=cols), needle)
        check(f"input_columns {cols!r}: a clear error", ok, msg)
    con.execute("CREATE TABLE upper_cols AS SELECT camera AS Camera, track_id AS Track_ID, class AS CLASS, t AS T, x AS X, y AS Y, estimated FROM scene")
    trajdb.pipeline(con, "upper_cols")
    check("column names match case-insensitively", road_users(con) == base)
    con.execute("CREATE TABLE twin AS FROM scene UNION ALL SELECT * REPLACE (camera + 10 AS camera) FROM scene WHERE camera = (SELECT min(camera) FROM scene)")
    ok, msg = raises(lambda: trajdb.pipeline(con, "twin"), "epsilon")
    check("a camera exported twice under another id runs (noise-free pair)", not ok, msg)

    # ---- a sandboxed connection (enable_external_access = false): tables still run, files are
    # neither read nor written, and nothing is created on disk
    sb = trajdb.connect()
    sb.execute("CREATE TABLE scene AS FROM read_parquet(?)", [scene])
    sb.execute("SET enable_external_access = false")
    trajdb.pipeline(sb, "scene")
    check("sandboxed: a table input runs", sb.sql("SELECT count(*) FROM merged").fetchall()[0][0] > 0)
    ok, msg = raises(lambda: trajdb.pipeline(sb, scene), "")
    check("sandboxed: a file input is refused", "disabled" in msg or "external access" in msg.lower(), msg)
    ok, msg = raises(lambda: trajdb.pipeline(sb, "scene", out=os.path.join(w, "sandboxed")), "")
    check("sandboxed: out is refused and nothing is created", ("disabled" in msg or "enable_external_access is false" in msg) and not os.path.exists(os.path.join(w, "sandboxed")), msg)
    ok, msg = raises(lambda: sb.execute("FROM trajdb_results_begin(?, 'scene')", [os.path.join(w, "sandboxed2")]).fetchall(), "")
    check("sandboxed: trajdb_results_begin creates nothing", not os.path.exists(os.path.join(w, "sandboxed2")), msg)

    # ---- fuzz: random `out` strings against a tree of the user's files. Through the SQL functions
    # every runner uses (trajdb_results_begin / _end, crates/app/src/outdir.rs), 300 cases: whatever
    # is refused or written, no file of the user's changes or disappears.
    import random
    rnd = random.Random(25)
    tree_root = os.path.join(w, "fuzz")
    for d in ["a", "a/b", "results", "data"]:
        os.makedirs(os.path.join(tree_root, d), exist_ok=True)
    for f in ["a/x.txt", "a/b/y.txt", "data/points.parquet", "z.txt", "results/notes.txt"]:
        with open(os.path.join(tree_root, f), "w") as fh:
            fh.write(f)
    user_files = tree(tree_root)
    old_cwd, old_home = os.getcwd(), os.environ.get("HOME")
    os.chdir(tree_root)
    os.environ["HOME"] = os.path.join(tree_root, "a")
    parts = ["", ".", "..", "/", "a", "b", "results", "data", "new", "~", " ", "'", '"', ";", "*", "\n", "x.txt", "z.txt", "points.parquet", ".trajdb-results"]
    fc = trajdb.connect()
    fuzz_errors, claimed = [], 0
    for _ in range(300):
        out = "/".join(rnd.choice(parts) for _ in range(rnd.randint(1, 4)))
        inp = rnd.choice(["scene", "data/points.parquet", "data/*.parquet", "*/*.txt", "a"])
        try:
            fc.execute("FROM trajdb_results_begin(?, ?)", [out, inp]).fetchall()
        except duckdb.Error:
            continue
        claimed += 1
        try:
            fc.execute("FROM trajdb_results_end(?, ?)", [out, rnd.random() < 0.7]).fetchall()
        except duckdb.Error as e:
            fuzz_errors.append(f"{out!r}: {e}")
    os.chdir(old_cwd)
    if old_home is not None:
        os.environ["HOME"] = old_home
    now = tree(tree_root)
    lost = [k for k, v in user_files.items() if now.get(k) != v]
    check("fuzz: 300 random out strings change no file of the user's", not lost, lost)
    check(f"fuzz: every claimed run ends cleanly ({claimed} of 300 claimed, the rest refused)", not fuzz_errors and claimed > 20, fuzz_errors[:3])

    # ---- `~` is the same folder for the sandbox check and for the writer: a connection allowed
    # only its working folder cannot write into the home folder through '~/...'
    old_cwd = os.getcwd()
    os.chdir(w)
    tl = trajdb.connect()
    tl.execute("SET allowed_directories = [?]", [w])
    tl.execute("SET enable_external_access = false")
    escape = "~/trajdb-sandbox-escape-" + str(os.getpid())
    ok, msg = raises(lambda: tl.execute("FROM trajdb_results_begin(?, '')", [escape]).fetchall(), "enable_external_access is false")
    check("sandboxed: '~/x' is the home folder for the check too (refused)", ok and not os.path.exists(os.path.expanduser(escape)), msg)
    ok, msg = raises(lambda: tl.execute("FROM trajdb_simulate(?)", [escape]).fetchall(), "enable_external_access is false")
    check("sandboxed: trajdb_simulate('~/x') refused", ok and not os.path.exists(os.path.expanduser(escape)), msg)
    os.chdir(old_cwd)

    # ---- the DuckDB CLI route: `.read sql/pipeline.sql` with a hostile pipeline_input
    cli = trajdb.connect()
    cli.execute("CREATE TABLE scene AS FROM read_parquet(?)", [scene])
    cli.execute("SET VARIABLE pipeline_input = ?", [f"scene; COPY (SELECT 1) TO '{marker}'"])
    ok, msg = raises(lambda: trajdb.read(cli, "sql/pipeline.sql"), "neither a table")
    check("the .read route quotes pipeline_input too", ok and not os.path.exists(marker), msg)
    if not FAILED:
        print("test_safety_python: OK", f"(duckdb {duckdb.__version__})")
    else:
        print(f"test_safety_python: {len(FAILED)} FAILED: {FAILED}")
        sys.exit(1)


def issue37(w, con, scene):
    """Issue 37, HIGH 4 and 5: trajdb removes or replaces only what it can prove it wrote."""
    # a pipeline into a folder trajdb.simulate wrote: refused, the scenario byte-identical
    sim = os.path.join(w, "i37-sim")
    trajdb.simulate(con, sim, cameras=2, minutes=1, seed=4)
    before = tree(sim)
    ok, msg = raises(lambda: trajdb.pipeline(con, os.path.join(sim, "points.parquet"), out=sim), "")
    check("i37: a pipeline into a scenario folder is refused", "input" in msg or "scenario" in msg, msg)
    ok, msg = raises(lambda: trajdb.pipeline(con, "scene", out=sim), "holds a scenario", "results")
    check("i37: ... also from a table input, with a clear message (out='<dir>/results')", ok, msg)
    check("i37: ... points.parquet, truth.csv, world.csv, cameras.csv byte-identical", tree(sim) == before and
          {"points.parquet", "truth.csv", "world.csv", "cameras.csv"} <= set(before), sorted(before))
    res = os.path.join(sim, "results")
    trajdb.pipeline(con, "scene", out=res)
    check("i37: results beside the scenario, in a folder of their own", os.path.exists(os.path.join(res, "merged.parquet")))
    ok, msg = raises(lambda: trajdb.simulate(con, res, cameras=2, minutes=1, seed=5), "results of a trajdb pipeline run")
    check("i37: a simulate into a results folder is refused", ok and os.path.exists(os.path.join(res, "merged.parquet")), msg)
    check("i37: the scenario is still byte-identical", {k: v for k, v in tree(sim).items() if not k.startswith("results")} == before)

    for part in (_i37_views, _i37_lookalikes, _i37_lock_link, _i37_name_only, _i37_edit, _i37_export, _i37_copy):
        try:
            part(w, con)
        except Exception as ex:  # noqa: BLE001  (the rest still runs: each part is its own reproducer)
            check(f"i37: {part.__name__} ran", False, repr(ex))


def _i37_views(w, con):
    # the input behind a view, and a file:// URL, into out
    res = os.path.join(w, "i37-views")
    trajdb.pipeline(con, "scene", out=res)
    merged = os.path.join(res, "merged.parquet")
    kept = tree(res)
    con.execute("CREATE OR REPLACE VIEW i37_view AS SELECT * FROM read_parquet(" + "'" + merged.replace("'", "''") + "')")
    con.execute("CREATE OR REPLACE TEMP VIEW i37_outer AS SELECT * FROM i37_view")
    for inp in ["i37_view", "i37_outer"]:
        ok, msg = raises(lambda: trajdb.pipeline(con, inp, out=res), "is or contains the input", "i37_view")
        check(f"i37: a view over out/merged.parquet ({inp}) is refused", ok and tree(res) == kept, msg)
    ok, msg = raises(lambda: trajdb.pipeline(con, "file://" + merged, out=res), "is or contains the input")
    check("i37: a file:// URL into out is refused", ok and tree(res) == kept, msg)
    ok, msg = raises(lambda: con.execute("FROM trajdb_results_begin(?, 'i37_view')", [res]).fetchall(), "cannot tell")
    check("i37: trajdb_results_begin with a view and no views := is refused where out holds results", ok and tree(res) == kept, msg)



def _i37_lookalikes(w, con):
    # (a) a user's folder holding only .trajdb-partial-old/
    a = os.path.join(w, "i37-a")
    os.makedirs(os.path.join(a, ".trajdb-partial-old"))
    with open(os.path.join(a, ".trajdb-partial-old", "points.csv"), "w") as f:
        f.write("mine")
    ok, msg = raises(lambda: trajdb.pipeline(con, "scene", out=a), "did not write")
    check("i37 (a): a folder holding only .trajdb-partial-old/ is refused, its files stay", ok and tree(a) == {".trajdb-partial-old/points.csv": b"mine"}, msg)

    # (b) a user's .trajdb-lock, and a hard link under that name to a user's file
    b = os.path.join(w, "i37-b")
    os.makedirs(b)
    with open(os.path.join(b, ".trajdb-lock"), "w") as f:
        f.write("my lock notes")
    raises(lambda: trajdb.pipeline(con, "scene", out=b))
    check("i37 (b): a user's .trajdb-lock is not truncated", open(os.path.join(b, ".trajdb-lock")).read() == "my lock notes")


def _i37_lock_link(w, con):
    # (b) a hard link under the lock's name to a user's file: in an otherwise empty folder, and
    # beside earlier results
    thesis = os.path.join(w, "i37-thesis.txt")
    with open(thesis, "w") as f:
        f.write("my thesis")
    b1 = os.path.join(w, "i37-b1")
    os.makedirs(b1)
    os.link(thesis, os.path.join(b1, ".trajdb-lock"))
    raises(lambda: trajdb.pipeline(con, "scene", out=b1))
    check("i37 (b): a hard link named .trajdb-lock (in an empty folder) is not truncated", open(thesis).read() == "my thesis")
    b2 = os.path.join(w, "i37-b2")
    trajdb.pipeline(con, "scene", out=b2)
    if os.path.exists(os.path.join(b2, ".trajdb-lock")):
        os.remove(os.path.join(b2, ".trajdb-lock"))  # an earlier trajdb's
    os.link(thesis, os.path.join(b2, ".trajdb-lock"))
    trajdb.pipeline(con, "scene", out=b2)
    check("i37 (b): a hard link named .trajdb-lock beside results is not written", open(thesis).read() == "my thesis")



def _i37_name_only(w, con):
    # (c) a hand-written manifest naming points.csv without an identity deletes nothing
    for k, head in enumerate(["# trajdb results: the files below were written by trajdb and may be replaced by its next run into this folder\n",
                              "# trajdb manifest 2: the files below were written by trajdb (name, size:fingerprint) and may be replaced by "
                              "its next run of the same kind into this folder\nkind\tresults\n"]):
        c = os.path.join(w, f"i37-c{k}")
        os.makedirs(c)
        with open(os.path.join(c, "points.csv"), "w") as f:
            f.write("my points")
        with open(os.path.join(c, ".trajdb-results"), "w") as f:
            f.write(head + "points.csv\n")
        ok, msg = raises(lambda: trajdb.pipeline(con, "scene", out=c), "will not")
        check(f"i37 (c): a name-only manifest line for points.csv deletes nothing ({['old', 'new'][k]} form)",
              ok and open(os.path.join(c, "points.csv")).read() == "my points", msg)



def _i37_edit(w, con):
    # (d) an edited merged.parquet with its size and mtime restored is not overwritten
    d = os.path.join(w, "i37-d")
    trajdb.pipeline(con, "scene", out=d)
    m = os.path.join(d, "merged.parquet")
    st = os.stat(m)
    with open(m, "r+b") as f:
        f.seek(st.st_size // 2)
        byte = f.read(1)
        f.seek(st.st_size // 2)
        f.write(bytes([byte[0] ^ 0xFF]))
    os.utime(m, ns=(st.st_atime_ns, st.st_mtime_ns))
    edited = open(m, "rb").read()
    ok, msg = raises(lambda: trajdb.pipeline(con, "scene", out=d), "merged.parquet changed since trajdb wrote it")
    check("i37 (d): an edit with size and mtime restored: the run is refused, the file stays", ok and open(m, "rb").read() == edited, msg)



def _i37_export(w, con):
    # (e) trajdb.export leaves a user's <path>.partial alone
    e = os.path.join(w, "i37-e.gpkg")
    with open(e + ".partial", "w") as f:
        f.write("my partial notes")
    trajdb.export(con, e)
    check("i37 (e): export leaves the user's <path>.partial untouched", open(e + ".partial").read() == "my partial notes" and os.path.exists(e))
    check("i37 (e): ... and leaves no temporary file of its own",
          sorted(n for n in os.listdir(w) if n.startswith("i37-e")) == ["i37-e.gpkg", "i37-e.gpkg.partial"], os.listdir(w))



def _i37_copy(w, con):
    # a copied results folder can be reused
    res = os.path.join(w, "i37-orig")
    trajdb.pipeline(con, "scene", out=res)
    cp = os.path.join(w, "i37-copy")
    shutil.copytree(res, cp)
    try:
        trajdb.pipeline(con, "scene", out=cp)
        ok, msg = True, ""
    except Exception as ex:  # noqa: BLE001
        ok, msg = False, str(ex)
    check("i37: a copied results folder can be reused", ok and os.path.exists(os.path.join(cp, "merged.parquet")), msg)


if __name__ == "__main__":
    main()
