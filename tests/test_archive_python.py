#!/usr/bin/env python3
"""The archive (issue 40; python/trajdb/archives.py, docs/archive.md), on simulated lakes of a few
sites and days (trajdb.lake_sim: each site its own cameras, each day its own traffic, viewpoint
bias and 1 % ground-plane errors as roadside cameras have):

1. camera changes: a camera moved by 1 m on day 3 of 5 at one site, turned by 1 degree at
   another, its clock 0.1 s or 0.5 s ahead at a third: found on that day and on no other, the camera named, the site registered again from
   it, and the days' road users as right as the days before (IDF1 against the truth);
2. incremental: a rerun runs nothing and rewrites nothing; a changed partition is the only one
   run again (the others' files keep their bytes and their modification times);
3. kill -9 at several moments of a run, then a rerun: every file the same bytes as an
   uninterrupted run's (the state too); no scratch folder left; a driver killed alone takes
   its workers with it;
4. faults: a corrupt file, an empty partition, a day with one camera, a day without one of
   the cameras: reported per partition, the others done, the exit status 3 + the number failed;
5. the folders: a folder of the user's is refused as --out, and so is the lake itself; the
   command line; a site column instead of site= folders; text camera ids; the sandbox;
6. repairs (the hostile review's findings): a deleted calibration folder is made again, a run
   from another lake refused, a failed partition's old files removed, export_day's columns,
   workers that exit between tasks never hang the driver;
7. metamorphic: one camera's frame in UTM and turned, its clock an hour off, the ids
   relabelled, the rows shuffled, on every day: the same road users, no camera change;
8. one SQL call: `CALL trajdb_archive` writes the same bytes as `trajdb archive` (a camera
   change included) and the same state; killed with -9 and called again, the same bytes;
9. the hostile probe's findings: `~` in out_dir is the home folder the sandbox checked; a
   symbolic link in the archive folder is refused and nothing is written through it; a file of
   the lake outside the sandbox is never read (its content never in an error); a commit whose
   result files are incomplete leaves no half partition.

usage: python3 tests/test_archive_python.py path/to/trajdb.duckdb_extension
"""
import glob
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXT = os.path.abspath(sys.argv[1])
os.environ["TRAJDB_EXTENSION"] = EXT
sys.path.insert(0, os.path.join(ROOT, "python"))
import duckdb  # noqa: E402
import trajdb  # noqa: E402
from trajdb import archives as A  # noqa: E402
from trajdb import lake_sim  # noqa: E402

REAL = dict(viewpoint_bias_vehicle=1.0, viewpoint_bias_vru=0.2, ground_plane_scale=0.01)
ENV = {**os.environ, "PYTHONPATH": os.path.join(ROOT, "python"), "TRAJDB_EXTENSION": EXT}


def cli(*args, check=True):
    p = subprocess.run([sys.executable, "-m", "trajdb", *args], env=ENV, capture_output=True, text=True)
    if check and p.returncode != 0:
        raise AssertionError(f"trajdb {' '.join(args)}: status {p.returncode}\n{p.stderr}")
    return p


def state(out):
    return {(r["site"], r["date"]): r for r in duckdb.sql(f"FROM read_parquet('{out}/_state/partitions.parquet')").to_arrow_table().to_pylist()}


def files(out, skip=("_state/runs.csv", "_state/lock")):
    """Every file of an archive: {relative path: bytes}."""
    got = {}
    for p in sorted(glob.glob(os.path.join(out, "**"), recursive=True) + glob.glob(os.path.join(out, ".*"))):
        rel = os.path.relpath(p, out)
        if os.path.isfile(p) and rel not in skip:
            with open(p, "rb") as f:
                got[rel] = f.read()
    return got


def idf1(out, truth, site, date, w):
    dest = tempfile.mkdtemp(prefix=f"score-{site}-{date}-", dir=w)
    A.export_day(out, site, date, dest)
    return trajdb.score(trajdb.connect(), os.path.join(truth, f"site={site}", f"date={date}"), dest)["idf1"]


def camera_changes(w):
    con = trajdb.connect()
    lake = os.path.join(w, "moves")
    # site s1: camera 1 moved by 1 m on day 2 (0-based); s2: camera 2 turned by 1 degree on day 2
    lake_sim.simulate_lake(con, lake, sites=1, days=5, minutes=8, move={"site": "s1", "day": 2, "camera": 1, "dx": 1.0, "dy": 0.0, "deg": 0.0}, **REAL)
    lake2 = os.path.join(w, "turns")
    lake_sim.simulate_lake(con, lake2, sites=1, days=5, minutes=8, move={"site": "s1", "day": 2, "camera": 2, "dx": 0.0, "dy": 0.0, "deg": 1.0}, **REAL)
    for lk, cam, what in ((lake, "1", "moved_m"), (lake2, "2", "turned_deg")):
        out = lk + "-out"
        r = trajdb.archive(con, lk, out)
        assert r["failed"] == 0 and r["done"] == 5, r
        st = state(out)
        days = sorted(st)
        changed = [d for (s, d) in days if st[(s, d)]["changes"] != "[]"]
        assert changed == [lake_sim.day_name(2)], (lk, changed, [st[k]["checks"] for k in days])
        ch = json.loads(st[("s1", lake_sim.day_name(2))]["changes"])
        assert ch["camera"] == cam, ch
        size = max(abs(p[what]) for p in ch["pairs"])
        assert 0.8 < size < 1.2, (what, ch)
        # registered again from that day; the days after use the new calibration, unchanged
        made = [d for (s, d) in days if st[(s, d)]["calibration_made"]]
        assert made == [lake_sim.day_name(0), lake_sim.day_name(2)], made
        assert st[("s1", lake_sim.day_name(4))]["calibration_in"].startswith(lake_sim.day_name(2))
        # the days' road users stay right (as on the days before the change)
        scores = [idf1(out, lk + "-truth", "s1", d, w) for (_, d) in days]
        assert min(scores) >= 0.98, scores
        assert any("camera change" in x for x in json.loads(st[("s1", lake_sim.day_name(2))]["warnings"]))
        # the day's own report says so too (its warnings), and no other day's
        reports = {d: open(os.path.join(out, "reports", "site=s1", f"date={d}", "report.html")).read() for (_, d) in days}
        assert [d for d in reports if "camera change on" in reports[d]] == [lake_sim.day_name(2)]
        index = open(os.path.join(out, "reports", "site=s1", "index.html")).read()
        assert f"camera {cam}" in index and "(made)" in index
        print(f"  camera changes: {what} found on day 2 only, camera {cam} named ({size:.3f}); IDF1 per day {[round(s, 4) for s in scores]}")
    # a camera's clock that jumps: by 0.1 s (within the check's clock search: measured) and by
    # 0.5 s (beyond it: its matches collapse, `lost`): found on that day only, the camera named,
    # the days' road users right
    for dt, kind in ((0.1, "moved"), (0.5, "lost")):
        lk = os.path.join(w, f"clock-{dt}")
        lake_sim.simulate_lake(con, lk, sites=1, days=4, minutes=8, move={"site": "s1", "day": 2, "camera": 1, "dx": 0.0, "dy": 0.0, "deg": 0.0, "dt": dt}, **REAL)
        out = lk + "-out"
        r = trajdb.archive(con, lk, out)
        assert r["failed"] == 0 and r["done"] == 4, r
        st = state(out)
        changed = [d for (s, d) in sorted(st) if st[(s, d)]["changes"] != "[]"]
        assert changed == [lake_sim.day_name(2)], (dt, changed)
        ch = json.loads(st[("s1", lake_sim.day_name(2))]["changes"])
        assert ch["camera"] == "1" and {p["kind"] for p in ch["pairs"]} == {kind}, ch
        if kind == "moved":
            assert all(abs(abs(p["clock_s"]) - dt) < 0.02 for p in ch["pairs"]), ch  # (the sign: which of the pair is camera 1)
        scores = [idf1(out, lk + "-truth", "s1", d, w) for (_, d) in sorted(st)]
        assert min(scores) >= 0.98, scores
        print(f"  camera changes: a clock {dt} s ahead found on day 2 only ({kind}), camera 1 named; IDF1 per day {[round(x, 4) for x in scores]}")
    # with the check off (a threshold no change reaches): what the kept calibration alone gives
    # on the moved days (printed: at 1 m the identities hold, the paths are a metre off)
    off = lake + "-off"
    trajdb.archive(con, lake, off, params={"archive_change_z": 1000})
    assert all(r["changes"] == "[]" for r in state(off).values())
    moved = [idf1(off, lake + "-truth", "s1", lake_sim.day_name(d), w) for d in (2, 3, 4)]
    print(f"  without the check: IDF1 on the moved days {[round(s, 4) for s in moved]}")


def incremental(w):
    con = trajdb.connect()
    lake, out = os.path.join(w, "inc"), os.path.join(w, "inc-out")
    lake_sim.simulate_lake(con, lake, sites=2, days=3, minutes=4, **REAL)
    r = trajdb.archive(con, lake, out)
    assert r["done"] == 6 and r["failed"] == 0, r
    before = files(out)
    mtimes = {p: os.stat(os.path.join(out, p)).st_mtime_ns for p in before}
    t = time.perf_counter()
    r = trajdb.archive(con, lake, out)
    noop = time.perf_counter() - t
    assert r["done"] == 0 and r["skipped"] == 6, r
    assert files(out) == before and all(os.stat(os.path.join(out, p)).st_mtime_ns == m for p, m in mtimes.items() if not p.endswith("index.html"))
    # a touched file with the same bytes: read once (its fingerprint), not run
    part = os.path.join(lake, "site=s2", f"date={lake_sim.day_name(2)}", "points.parquet")
    os.utime(part, ns=(time.time_ns(), time.time_ns()))
    r = trajdb.archive(con, lake, out)
    assert r["done"] == 0, r
    # a changed partition (its last day: no later day depends on it): only it runs again
    con.execute(f"COPY (FROM read_parquet('{part}', hive_partitioning = false) WHERE track_id % 7 <> 3) TO '{part}.new' (FORMAT parquet)")
    os.replace(part + ".new", part)
    r = trajdb.archive(con, lake, out)
    assert r["done"] == 1, r
    after = files(out)
    changed = sorted(p for p in after if after[p] != before.get(p))
    assert all(f"site=s2/date={lake_sim.day_name(2)}" in p or p in ("_state/partitions.parquet", "reports/site=s2/index.html") for p in changed), changed
    assert any(p.startswith("road_users/site=s2") for p in changed)
    rerun = f"site=s2/date={lake_sim.day_name(2)}"
    for p, m in mtimes.items():
        if rerun not in p and p not in changed and not p.endswith("index.html") and p in after:
            assert os.stat(os.path.join(out, p)).st_mtime_ns == m, p
    print(f"  incremental: no-op rerun of 6 partitions {noop:.2f} s; one changed partition: {len(changed)} files rewritten, all its own")
    return lake


def kill_and_resume(w, lake):
    ref = os.path.join(w, "ref-out")
    assert cli("archive", "--input", lake, "--out", ref).returncode == 0
    want = files(ref)
    for k, delay in enumerate((1.5, 4.0, 7.0)):
        out = os.path.join(w, f"killed-{k}")
        p = subprocess.Popen([sys.executable, "-m", "trajdb", "archive", "--input", lake, "--out", out], env=ENV,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        time.sleep(delay)
        if k == 1:
            # the driver alone: its workers must end with it (not go on computing days no one
            # will commit)
            os.kill(p.pid, signal.SIGKILL)
            p.wait()
            for _ in range(100):
                try:
                    os.killpg(p.pid, 0)
                except ProcessLookupError:
                    break
                time.sleep(0.1)
            else:
                os.killpg(p.pid, signal.SIGKILL)
                raise AssertionError("the workers outlived their driver by 10 s")
        else:
            os.killpg(p.pid, signal.SIGKILL)  # the driver and its workers, at once
            p.wait()
        n = len(state(out)) if os.path.exists(os.path.join(out, "_state", "partitions.parquet")) else 0
        assert cli("archive", "--input", lake, "--out", out).returncode == 0
        got = files(out)
        assert got.keys() == want.keys(), sorted(set(got) ^ set(want))
        bad = [f for f in want if got[f] != want[f] and f != ".trajdb-archive"]
        assert not bad, bad
        assert not [e for e in os.listdir(os.path.join(out, "_work"))], os.listdir(os.path.join(out, "_work"))
        print(f"  kill -9 after {delay} s ({n} of 6 partitions recorded), rerun: {len(got)} files the same bytes as an uninterrupted run")
    return ref


def repairs(w, lake, ref):
    """What the hostile review found: each repaired, each checked."""
    want = files(ref)
    # a deleted calibration folder is made again by its day (the site's later days wait for it,
    # and do not stall): the archive ends as it was, byte for byte
    out = os.path.join(w, "repair-cal")
    shutil.copytree(ref, out)
    first = sorted(glob.glob(os.path.join(out, "_calibrations", "site=s1", "from=*")))[0]
    shutil.rmtree(first)
    r = trajdb.archive(trajdb.connect(), lake, out)
    assert r["failed"] == 0 and os.path.isdir(first) and r["done"] >= 1, r
    got = files(out)
    assert [f for f in want if got.get(f) != want[f] and f != ".trajdb-archive"] == [], "not the same archive again"
    # the archive of one lake refuses a run from another (two lakes' days would mix in one state)
    other = os.path.join(w, "other-lake")
    shutil.copytree(lake, other)
    p = cli("archive", "--input", other, "--out", out, check=False)
    assert p.returncode == 1 and "is the archive of the lake" in p.stderr, p.stderr
    # a partition that was right and then fails (its input now corrupt): its old files go, so
    # that no reader takes them for this input's
    part = os.path.join(lake + "-copy")
    shutil.copytree(lake, part)
    out2 = os.path.join(w, "repair-fail")
    trajdb.archive(trajdb.connect(), part, out2)
    day = lake_sim.day_name(2)
    with open(os.path.join(part, "site=s2", f"date={day}", "points.parquet"), "wb") as f:
        f.write(b"PAR1 broken")
    r = trajdb.archive(trajdb.connect(), part, out2)
    assert r["failed_partitions"] == [f"site=s2/date={day}"], r
    left = [f for f in files(out2) if f"site=s2/date={day}" in f]
    assert left == [], left
    # export_day: the file's own columns (no site and date guessed from the archive's folders),
    # into a new folder only
    dest = os.path.join(w, "exported")
    A.export_day(ref, "s1", lake_sim.day_name(0), dest)
    head = open(os.path.join(dest, "matches.csv")).readline().strip().split(",")
    assert "site" not in head and "date" not in head, head
    try:
        A.export_day(ref, "s1", lake_sim.day_name(0), dest)
        raise AssertionError("export_day wrote into a folder that is not empty")
    except A.ArchiveError as e:
        assert "not an empty folder" in str(e)
    # a worker that dies between tasks (here: after each one) never leaves the driver waiting:
    # the run ends, each partition done or failed with the reason, and a rerun completes it
    out3 = os.path.join(w, "repair-worker")
    env = {**ENV, "TRAJDB_ARCHIVE_WORKER_TASKS": "1"}
    p = subprocess.run([sys.executable, "-m", "trajdb", "archive", "--input", lake, "--out", out3, "--workers", "2"], env=env,
                       capture_output=True, text=True, timeout=600)
    st = state(out3)
    # (each worker says `took` before it runs a task: one that ended between tasks is replaced
    # and the task sent again, so every partition is done in this run)
    assert p.returncode == 0 and len(st) == 6 and all(r["status"] == "ok" for r in st.values()), (p.stderr, st)
    assert files(out3).keys() == want.keys()
    # new parameters: every site's calibration is made again under them before its later days
    # run (a calibration is named by its input, build and parameters): the same bytes as a
    # fresh archive with those parameters (the hostile review found the later days run on the
    # old calibration and recorded as done)
    changed, fresh = os.path.join(w, "repair-params"), os.path.join(w, "repair-params-fresh")
    shutil.copytree(ref, changed)
    trajdb.archive(trajdb.connect(), lake, changed, params={"align_trim": 0.2})
    trajdb.archive(trajdb.connect(), lake, fresh, params={"align_trim": 0.2})
    a, b = files(changed), files(fresh)
    assert [f for f in b if a.get(f) != b[f] and f != ".trajdb-archive"] == [], [f for f in b if a.get(f) != b[f]]
    assert all(f.startswith("_calibrations/") for f in a if f not in b), [f for f in a if f not in b]  # the old ones, kept
    # DuckDB spills into the task's own scratch when a day needs more than --task-memory
    spill = os.path.join(w, "repair-spill")
    assert cli("archive", "--input", lake, "--out", spill, "--task-memory", "300MB").returncode == 0
    assert [f for f in want if files(spill).get(f) != want[f] and f != ".trajdb-archive"] == []
    print("  repairs: a deleted calibration made again (same bytes), another lake refused, a failed partition's old files "
          f"removed, export_day without guessed columns, workers that exit after each task: replaced, every partition done; new parameters: "
          "calibrations made again, the same bytes as a fresh archive; 300 MB per task: the same bytes")


def faults(w):
    con = trajdb.connect()
    lake, out = os.path.join(w, "faults"), os.path.join(w, "faults-out")
    lake_sim.simulate_lake(con, lake, sites=1, days=2, minutes=4, **REAL)
    s1 = os.path.join(lake, "site=s1")
    src = os.path.join(s1, f"date={lake_sim.day_name(1)}", "points.parquet")
    for name, sql in (("one-camera", "WHERE camera = 0"), ("camera-missing", "WHERE camera <> 2")):
        os.makedirs(os.path.join(s1, f"date=2026-06-{name}"))
        con.execute(f"COPY (FROM read_parquet('{src}', hive_partitioning = false) {sql}) TO '{s1}/date=2026-06-{name}/points.parquet' (FORMAT parquet)")
    os.makedirs(os.path.join(s1, "date=2026-07-corrupt"))
    with open(os.path.join(s1, "date=2026-07-corrupt", "points.parquet"), "wb") as f:
        f.write(b"PAR1 not a parquet file at all")
    os.makedirs(os.path.join(s1, "date=2026-07-empty"))
    p = cli("archive", "--input", lake, "--out", out, check=False)
    assert p.returncode == 3 + 2, (p.returncode, p.stderr)  # 3 + the number failed (1 and 2 are an error and a usage error)
    st = state(out)
    ok = sorted(d for (_, d), r in st.items() if r["status"] == "ok")
    failed = {d: r["error"] for (_, d), r in st.items() if r["status"] != "ok"}
    assert set(failed) == {"2026-07-corrupt", "2026-07-empty"}, failed
    assert "no data files" in failed["2026-07-empty"] and "parquet" in failed["2026-07-corrupt"].lower(), failed
    assert "2026-06-one-camera" in ok and "2026-06-camera-missing" in ok, ok
    assert "failed:  site=s1/date=2026-07-corrupt" in p.stderr, p.stderr
    # a rerun tries the failed ones again (a worker killed for memory may pass), and only them
    p = cli("archive", "--input", lake, "--out", out, check=False)
    assert p.returncode == 3 + 2 and "2 run" in p.stderr, p.stderr
    print(f"  faults: {sorted(failed)} failed with their errors, {len(ok)} others done, exit status 3 + 2")


def folders(w):
    con = trajdb.connect()
    lake = os.path.join(w, "folders")
    lake_sim.simulate_lake(con, lake, sites=1, days=1, minutes=3, **REAL)
    mine = os.path.join(w, "mine")
    os.makedirs(mine)
    with open(os.path.join(mine, "thesis.docx"), "w") as f:
        f.write("mine")
    for out, why in ((mine, "did not write"), (lake, "hold one another"), (os.path.join(lake, "out"), "hold one another")):
        p = cli("archive", "--input", lake, "--out", out, check=False)
        assert p.returncode == 1 and why in p.stderr, (out, p.stderr)
    assert open(os.path.join(mine, "thesis.docx")).read() == "mine" and os.listdir(mine) == ["thesis.docx"]
    p = cli("archive", "--input", lake, "--out", os.path.join(w, "bad-memory"), "--task-memory", "lots", check=False)
    assert p.returncode == 1 and 'task_memory "lots"' in p.stderr, p.stderr
    # the sandbox of the caller's connection
    locked = trajdb.connect()
    locked.execute(f"SET allowed_directories = ['{os.path.join(w, 'allowed')}']")
    locked.execute("SET enable_external_access = false")
    try:
        trajdb.archive(locked, lake, os.path.join(w, "sandboxed"))
        raise AssertionError("the sandbox was not obeyed")
    except PermissionError as e:
        assert "allowed_directories" in str(e)
    assert not os.path.exists(os.path.join(w, "sandboxed"))
    nolocal = trajdb.connect()
    nolocal.execute("SET disabled_filesystems = 'LocalFileSystem'")
    try:
        trajdb.archive(nolocal, lake, os.path.join(w, "sandboxed"))
        raise AssertionError("disabled_filesystems was not obeyed")
    except PermissionError as e:
        assert "disabled" in str(e), e
    assert not os.path.exists(os.path.join(w, "sandboxed"))
    # date=D/ folders with a site column, and text camera ids: numbered as the site's first day
    # numbered them, whichever cameras a later day has
    flat = os.path.join(w, "flat")
    src = os.path.join(lake, "site=s1", f"date={lake_sim.day_name(0)}", "points.parquet")
    for d, where in (("2026-05-01", ""), ("2026-05-02", "WHERE camera <> 2")):
        os.makedirs(os.path.join(flat, f"date={d}"))
        con.execute(f"""COPY (SELECT 'cam-' || chr(99 - camera::INTEGER) AS camera, * EXCLUDE (camera), s AS site
                              FROM read_parquet('{src}', hive_partitioning = false), (VALUES ('north'), ('south')) v(s) {where})
                        TO '{flat}/date={d}/points.parquet' (FORMAT parquet)""")
    out = os.path.join(w, "flat-out")
    r = trajdb.archive(con, flat, out)
    assert r["failed"] == 0 and r["done"] == 4, r
    st = state(out)
    assert sorted(st) == [("north", "2026-05-01"), ("north", "2026-05-02"), ("south", "2026-05-01"), ("south", "2026-05-02")]
    cams = duckdb.sql(f"SELECT DISTINCT cam_from FROM read_parquet('{out}/transforms/site=north/date=2026-05-02/*.parquet') ORDER BY 1").fetchall()
    assert [c[0] for c in cams] == ["cam-b", "cam-c"], cams
    assert all(r["changes"] == "[]" for r in st.values()), [r["changes"] for r in st.values()]
    n = duckdb.sql(f"SELECT count(*) FROM read_parquet('{out}/road_users/*/*/*.parquet', hive_partitioning = true) WHERE site = 'south'").fetchall()[0][0]
    assert n > 0
    # a site name that would leave the archive folder ('..', '/') is refused before any work
    evil = os.path.join(w, "evil")
    os.makedirs(os.path.join(evil, "date=2026-05-01"))
    con.execute(f"""COPY (SELECT *, 'x/../../escaped' AS site FROM read_parquet('{src}', hive_partitioning = false))
                    TO '{evil}/date=2026-05-01/points.parquet' (FORMAT parquet)""")
    p = cli("archive", "--input", evil, "--out", os.path.join(w, "evil-out"), check=False)
    assert p.returncode == 1 and "cannot name a folder" in p.stderr, p.stderr
    assert not os.path.exists(os.path.join(w, "evil-out")) and not os.path.exists(os.path.join(os.path.dirname(w), "escaped"))
    print("  folders: the user's folder and the lake refused as --out, the sandbox obeyed; a site column and text camera ids work; "
          "a site named to escape the folder refused")


def users(out, site, date, relabel=None):
    """The day's road users as sets of their source tracks, (camera, track id) with the ids
    mapped back through `relabel` {(camera, id): original id}."""
    rows = duckdb.sql(f"""SELECT [(s.camera, s.track_id) FOR s IN sources] FROM
                          read_parquet('{out}/road_users/site={site}/date={date}/part-0.parquet', hive_partitioning = false)""").fetchall()
    back = (lambda c, k: relabel[(c, k)]) if relabel else (lambda c, k: k)
    return {frozenset((c, back(c, k)) for c, k in r[0]) for r in rows}


def metamorphic(w):
    """The same lake with one camera's frame moved into UTM and turned, its clock an hour
    off, every track relabelled and the rows shuffled, on every day: the same road users on
    every day, and no camera change (a camera's frame that is the same every day is no change,
    wherever it is)."""
    con = trajdb.connect()
    lake, moved = os.path.join(w, "meta"), os.path.join(w, "meta-moved")
    lake_sim.simulate_lake(con, lake, sites=1, days=3, minutes=4, **REAL)
    for d in range(3):
        src = os.path.join(lake, "site=s1", f"date={lake_sim.day_name(d)}", "points.parquet")
        dest = os.path.join(moved, "site=s1", f"date={lake_sim.day_name(d)}")
        os.makedirs(dest)
        con.execute(f"""COPY (SELECT * REPLACE (track_id * 7919 + 13 AS track_id,
                                     CASE WHEN camera = 1 THEN t + 3600 ELSE t END AS t,
                                     CASE WHEN camera = 1 THEN 465000 + x * cos(0.7) - y * sin(0.7) ELSE x END AS x,
                                     CASE WHEN camera = 1 THEN 5710000 + x * sin(0.7) + y * cos(0.7) ELSE y END AS y)
                              FROM read_parquet('{src}', hive_partitioning = false) ORDER BY hash(camera, track_id, t))
                        TO '{dest}/points.parquet' (FORMAT parquet)""")
    a, b = trajdb.archive(con, lake, lake + "-out"), trajdb.archive(con, moved, moved + "-out")
    assert a["failed"] == b["failed"] == 0 and a["changes"] == b["changes"] == [], (a, b)
    same = []
    for d in range(3):
        day = lake_sim.day_name(d)
        relabel = {(c, k * 7919 + 13): k for c, k in duckdb.sql(
            f"SELECT DISTINCT camera, track_id FROM read_parquet('{lake}/site=s1/date={day}/points.parquet', hive_partitioning = false)").fetchall()}
        ua, ub = users(lake + "-out", "s1", day), users(moved + "-out", "s1", day, relabel)
        same.append(len(ua & ub) / max(len(ua), 1))
        assert ua == ub, (day, len(ua), len(ub), len(ua & ub))
    print(f"  metamorphic: one camera in UTM, turned 40 deg, its clock +1 h, every id relabelled, rows shuffled: "
          f"the same road users on each of 3 days ({[round(x, 3) for x in same]}), no camera change")


def sql_call(archive, lake, out):
    """CALL trajdb_archive(lake, out_dir := out) in a process of its own (as a user's)."""
    code = ("import duckdb, sys; con = duckdb.connect(config={'allow_unsigned_extensions': 'true'}); "
            "con.execute('LOAD ' + repr(sys.argv[1])); "
            "rows = con.execute('FROM trajdb_archive(?, out_dir := ?, workers := 2)', [sys.argv[2], sys.argv[3]]).fetchall(); "
            "print(sum(r[3] for r in rows), sum(r[2] != 'ok' for r in rows))")
    return subprocess.Popen([sys.executable, "-c", code, EXT, lake, out], env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)


def same_archive(a, b):
    """Two archives of one lake hold the same bytes (the state: the same rows; its file is written
    by each host's own Parquet writer)."""
    fa, fb = files(a), files(b)
    assert fa.keys() == fb.keys(), sorted(set(fa) ^ set(fb))
    bad = [f for f in fa if fa[f] != fb[f] and f not in (".trajdb-archive", "_state/partitions.parquet")]
    assert not bad, bad
    sa, sb = state(a), state(b)
    assert sa == sb, [(k, {c: (sa[k][c], sb[k][c]) for c in sa[k] if sa[k][c] != sb[k].get(c)}) for k in sa if sa[k] != sb.get(k)][:3]
    return len(fa)


def sql(w, lake, ref):
    # the camera-change lake of section 1 (made by trajdb.archive): CALL writes the same
    moves = os.path.join(w, "moves")
    out = os.path.join(w, "moves-sql")
    p = sql_call(None, moves, out)
    so, se = p.communicate()
    assert p.returncode == 0, se
    n = same_archive(moves + "-out", out)
    print(f"  CALL trajdb_archive on the camera-change lake: {n} files the same bytes as trajdb.archive's, the same state ({so.split()})")
    # kill -9 during the call, then call again: the same bytes as the command's uninterrupted run
    for k, delay in enumerate((2.0, 5.0)):
        out = os.path.join(w, f"sql-killed-{k}")
        p = sql_call(None, lake, out)
        time.sleep(delay)
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()
        n0 = len(state(out)) if os.path.exists(os.path.join(out, "_state", "partitions.parquet")) else 0
        p = sql_call(None, lake, out)
        so, se = p.communicate()
        assert p.returncode == 0, se
        n = same_archive(ref, out)
        assert not os.listdir(os.path.join(out, "_work")), os.listdir(os.path.join(out, "_work"))
        print(f"  CALL killed -9 after {delay} s ({n0} partitions recorded), called again: {n} files the same bytes as trajdb archive's")


def probe(w):
    con = trajdb.connect()
    lake = os.path.join(w, "probe", "sb", "lake")
    lake_sim.simulate_lake(con, lake, sites=1, days=2, minutes=2, **REAL)
    sb = os.path.dirname(lake)
    # H1: '~' is the home folder the sandbox allowed, never a folder named '~' in the working folder
    home, cwd = os.path.join(w, "probe", "home"), os.path.join(w, "probe", "cwd")
    os.makedirs(home)
    os.makedirs(cwd)
    code = ("import duckdb, sys; con = duckdb.connect(config={'allow_unsigned_extensions': 'true'}); con.execute('LOAD ' + repr(sys.argv[1])); "
            "con.execute('SET allowed_directories = ' + repr([sys.argv[2] + '/', sys.argv[3] + '/'])); con.execute('SET enable_external_access = false'); "
            "print(len(con.execute(\"FROM trajdb_archive(?, out_dir := '~/arch', workers := 1)\", [sys.argv[3]]).fetchall()))")
    p = subprocess.run([sys.executable, "-c", code, EXT, home, lake], env={**ENV, "HOME": home}, cwd=cwd, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert os.path.exists(os.path.join(home, "arch", ".trajdb-archive")) and not os.listdir(cwd), (os.listdir(home), os.listdir(cwd))
    out = os.path.join(home, "arch")
    # H2: a link in the archive folder (to a folder of the user's) is refused; nothing written through it
    outside = os.path.join(w, "probe", "outside")
    os.makedirs(outside)
    os.rename(os.path.join(out, "reports"), os.path.join(w, "probe", "reports-aside"))
    os.symlink(outside, os.path.join(out, "reports"))
    shutil.rmtree(os.path.join(out, "_calibrations"))
    try:
        trajdb.archive(con, lake, out)
        raise AssertionError("a symbolic link in the archive folder was followed")
    except A.ArchiveError as e:
        assert "symbolic link" in str(e), e
    assert os.listdir(outside) == [], os.listdir(outside)
    # H3: a lake file that is a link to a file outside the sandbox: refused, never read
    secret = os.path.join(w, "probe", "secret.csv")
    with open(secret, "w") as f:
        f.write("site,camera\nhunter2 is the password,1\n")
    dl = os.path.join(sb, "lake-d")
    for d in ("2026-05-04", "2026-05-05"):
        os.makedirs(os.path.join(dl, f"date={d}"))
    con.execute("COPY (SELECT 's1' AS site, * FROM read_parquet(?)) TO '" + os.path.join(dl, "date=2026-05-04", "p.parquet") + "'",
                [os.path.join(lake, "site=s1", "date=" + lake_sim.day_name(0), "points.parquet")])
    os.symlink(secret, os.path.join(dl, "date=2026-05-05", "evil.csv"))
    locked = trajdb.connect()
    locked.execute(f"SET allowed_directories = ['{sb}/']")
    locked.execute("SET enable_external_access = false")
    try:
        locked.execute("FROM trajdb_archive(?, out_dir := ?)", [dl, os.path.join(sb, "out-d")]).fetchall()
        raise AssertionError("a file outside the sandbox was read")
    except duckdb.Error as e:
        assert "hunter2" not in str(e) and "evil.csv" in str(e), e
    assert not os.path.exists(os.path.join(sb, "out-d", "road_users"))
    # M7: a result whose files are incomplete: the partition failed, none of its files in place
    ext = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    ext.execute(f"LOAD '{EXT}'")
    out2 = os.path.join(w, "probe", "half")
    h = ext.execute("SELECT handle FROM trajdb_archive_open(?, out_dir := ?)", [lake, out2]).fetchone()[0]
    task = ext.execute("FROM trajdb_archive_next(?)", [h]).fetchone()[0]
    res = json.loads(ext.execute("FROM trajdb_archive_task(?)", [task]).fetchone()[0])
    os.remove(os.path.join(res["scratch"], "links.parquet"))
    row = json.loads(ext.execute("FROM trajdb_archive_commit(?, ?)", [h, json.dumps(res)]).fetchone()[0])
    assert row["status"] == "failed" and "links.parquet" in row["error"], row
    ext.execute("FROM trajdb_archive_close(?)", [h]).fetchall()
    assert not glob.glob(os.path.join(out2, "*", "site=*", "date=*", "*")), glob.glob(os.path.join(out2, "*", "site=*", "date=*", "*"))
    print("  probe: '~' is the sandbox's home folder; a link in the archive refused, nothing written through it; a lake file "
          "outside the sandbox never read; an incomplete result leaves no half partition")


def readme(w):
    """The README's archive commands, as written, in a folder of their own."""
    text = open(os.path.join(ROOT, "README.md")).read()
    i = text.index("## An archive")
    block = text[text.index("```sh\n", i) + 6:text.index("```", text.index("```sh\n", i) + 6)]
    d = os.path.join(w, "readme")
    os.makedirs(d)
    for line in block.strip().splitlines():
        cmd = line.split("#")[0].split()
        assert cmd[0] == "trajdb", line
        p = subprocess.run([sys.executable, "-m", "trajdb", *cmd[1:]], cwd=d, env=ENV, capture_output=True, text=True)
        assert p.returncode == 0, (line, p.stderr)
    st = state(os.path.join(d, "archive"))
    assert len(st) == 6 and all(r["status"] == "ok" for r in st.values()), st
    print(f"  README: its archive commands run as written ({len(st)} partitions)")


def main():
    w = tempfile.mkdtemp(prefix="trajdb-archive-")
    try:
        camera_changes(w)
        lake = incremental(w)
        ref = kill_and_resume(w, lake)
        repairs(w, lake, ref)
        faults(w)
        folders(w)
        metamorphic(w)
        sql(w, lake, ref)
        probe(w)
        readme(w)
    finally:
        shutil.rmtree(w, ignore_errors=True)
    print("test_archive: OK")


if __name__ == "__main__":
    main()
