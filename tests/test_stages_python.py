#!/usr/bin/env python3
"""Each pipeline stage (sql/stages/*.sql) tested on its own, on a tiny deterministic scene.

The scene (tests/sql/stages/scene.sql, pure SQL, no simulator) is two cameras, 12 road users on
4 routes, 10 Hz, +-0.05 m noise, camera 1 rotated by 0.5 rad, moved by (15, 5) m and 0.4 s
ahead, plus a broken track, a one-point track and a 1000 m/s track. A stage's test loads the
scene as `points` (the load step's table), runs the stages before it (sql/stages.sql order) and
then the stage's own file, and checks what the stage's header says it makes. So a stage can be
changed and tested alone: `python3 tests/test_stages_python.py EXT align` runs calibrate, clean,
quality, align and checks align only. The stage files are read directly (no package, no runner).
It also checks the contract headers (tests/check_stage_contracts.py) and that every `auto`
parameter of sql/params.sql gets its value in one table, `calibration`.

usage: python3 tests/test_stages_python.py path/to/trajdb.duckdb_extension [stage ...]
"""
import math
import os
import re
import subprocess
import sys
import traceback

import duckdb

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(ROOT, "tests/sql/stages/scene.sql")


def stages(con):
    """The stage list of the extension's manifest (trajdb_stages: sql/stages.sql)."""
    rows = con.execute("SELECT stage FROM trajdb_stages('x') WHERE file LIKE 'sql/stages/%' GROUP BY stage ORDER BY min(k)").fetchall()
    return [r[0] for r in rows]


def run_file(con, rel):
    """A pipeline SQL file as the extension embeds it (trajdb_script); the scene, a test fixture
    outside sql/, through DuckDB's own parser."""
    if rel.startswith("sql/"):
        for (sql,) in con.execute("SELECT sql FROM trajdb_script(?) ORDER BY k", [rel]).fetchall():
            con.execute(sql).fetchall()
        return
    text = open(os.path.join(ROOT, rel), encoding="utf-8").read()
    for st in con.extract_statements(text):
        con.execute(st.query).fetchall()


def scene(ext, upto, **params):
    """A connection with the scene loaded as `points`, the parameters set (name=value, SQL
    literals) before sql/params.sql, and the stages up to and including `upto` run."""
    con = duckdb.connect(":memory:", config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{ext}'")
    for k, v in params.items():
        con.execute(f"SET VARIABLE {k} = {v}")
    run_file(con, "sql/params.sql")
    run_file(con, "tests/sql/stages/scene.sql")
    names = stages(con)
    for s in names[: names.index(upto) + 1]:
        run_file(con, f"sql/stages/{s}.sql")
    return con


def rows(con, q):
    return con.execute(q).fetchall()


def one(con, q):
    return con.execute(q).fetchall()[0][0]


def auto_parameters():
    """The parameters whose default is `auto` (NULL in the generated sql/params.sql)."""
    text = open(os.path.join(ROOT, "sql/params.sql"), encoding="utf-8").read()
    return sorted(re.findall(r"SET VARIABLE (\w+) = coalesce\(getvariable\('\w+'\), NULL::", text))


# ---------------------------------------------------------------------------------------------


def test_calibrate(ext):
    con = scene(ext, "calibrate")
    cams = rows(con, "SELECT camera, period_s, sigma_m FROM calib_cameras ORDER BY camera")
    assert [c for c, _, _ in cams] == [0, 1], cams
    for c, period, sigma in cams:
        assert abs(period - 0.1) < 1e-9, (c, period)
        # uniform +-0.05 m noise: sigma 0.029 m per axis (turns add a little)
        assert 0.015 < sigma < 0.06, (c, sigma)
    assert sorted(r[0] for r in rows(con, "SELECT class FROM calib_classes")) == ["car", "pedestrian"]
    # the run-wide values
    got = dict(rows(con, "SELECT parameter, value FROM calibration WHERE scope = 'pipeline'"))
    assert got["clean_min_points"] == 2 and abs(got["clean_min_duration_s"] - 0.15) < 1e-9, got
    assert got["merge_min_points"] == 3 and got["cluster_camera"] == 0, got
    for p in got:
        assert one(con, f"SELECT calibrated('{p}')") == got[p], p
    # per camera pair, from the measured noise
    sp = one(con, "SELECT sigma_pair_m FROM calib_pairs WHERE cam_a = 0 AND cam_b = 1")
    pair = dict(rows(con, "SELECT parameter, value FROM calibration WHERE scope = 'camera pair'"))
    assert pair == {"align_max_rms_m": 0.1 + 3 * sp, "align_refine_rms_m": 0.05 + 2 * sp}, pair
    assert rows(con, "SELECT cam_a, cam_b, value FROM calibrated_values('align_max_rms_m')") == [(0, 1, 0.1 + 3 * sp)]
    # per class, and the default for a class without a measurement
    acc = dict(rows(con, "SELECT class, accel_p95 FROM calib_classes"))
    assert dict(rows(con, "SELECT class, value FROM calibrated_values('quality_max_accel')")) == acc
    assert one(con, "SELECT calibrated('quality_max_accel')") == 0.0
    # one row per parameter and scope key
    assert one(con, "SELECT count(*) - count(DISTINCT (parameter, scope, cam_a, cam_b, class)) FROM calibration") == 0
    # every auto parameter but merge_epsilon (measured after alignment) has its value here
    have = {r[0] for r in rows(con, "SELECT DISTINCT parameter FROM calibration")}
    assert set(auto_parameters()) - have == {"merge_epsilon"}, (auto_parameters(), have)

    # a given value wins; the measurement stays beside it
    con = scene(ext, "calibrate", align_max_rms_m="0.7", quality_max_accel="2.5", merge_min_points="5", clean_min_points="4")
    r = rows(con, "SELECT parameter, measured, given, value FROM calibration WHERE parameter = 'align_max_rms_m'")
    assert r == [("align_max_rms_m", 0.1 + 3 * sp, 0.7, 0.7)], r
    assert {v for _, v in rows(con, "SELECT class, value FROM calibrated_values('quality_max_accel')")} == {2.5}
    assert one(con, "SELECT calibrated('quality_max_accel')") == 2.5
    assert one(con, "SELECT calibrated('merge_min_points')") == 5 and one(con, "SELECT calibrated('clean_min_points')") == 4


def test_clean(ext):
    con = scene(ext, "clean")
    assert rows(con, "SELECT camera, track_id, reason FROM clean_dropped ORDER BY track_id") == [
        (0, 901, "too short"), (0, 902, "implausible speed")]
    assert one(con, "SELECT count(*) FROM points WHERE track_id IN (901, 902)") == 0
    assert rows(con, "SELECT camera, count(DISTINCT track_id) FROM points GROUP BY camera ORDER BY camera") == [(0, 13), (1, 12)]
    # the measured thresholds decide: a one-point track passes when clean_min_points = 1
    con = scene(ext, "clean", clean_min_points="1")
    assert rows(con, "SELECT track_id, reason FROM clean_dropped") == [(902, "implausible speed")]


def test_quality(ext):
    con = scene(ext, "quality")
    assert rows(con, "SELECT camera, from_id, to_id, kind FROM quality_breaks") == [(0, 104, 150, "broken")]
    assert rows(con, "SELECT track_id, linked_id FROM quality_links WHERE camera = 0 AND track_id <> linked_id") == [(150, 104)]
    assert one(con, "SELECT count(*) FROM points WHERE track_id = 150") == 0
    assert rows(con, "SELECT camera, count(DISTINCT track_id) FROM points GROUP BY camera ORDER BY camera") == [(0, 12), (1, 12)]
    assert one(con, "SELECT count(*) FROM quality_reach_links") == 0
    assert sorted(r[0] for r in rows(con, "SELECT DISTINCT camera FROM quality_views")) == [0, 1]


def test_align(ext):
    con = scene(ext, "align")
    f = {c: (ref, tf, off, drift) for c, ref, tf, off, drift in
         rows(con, "SELECT camera, reference, to_reference, clock_offset_s, clock_drift FROM align_frames")}
    assert set(f) == {0, 1} and f[0][0] == 0 and f[1][0] == 0, f
    _, tf, off, drift = f[1]
    assert abs(tf["theta"] - 0.5) < 0.002 and abs(tf["tx"] - 15) < 0.05 and abs(tf["ty"] - 5) < 0.05, tf
    assert abs(off - 0.4) < 0.01 and drift == 0, (off, drift)
    assert f[0][2] == 0.0 and f[0][1]["theta"] == 0.0
    # the clock: camera 1's points are on camera 0's clock now (its first sample: 7.05 s)
    assert abs(one(con, "SELECT min(t) FROM points WHERE camera = 1") - 7.05) < 0.02
    # merge_epsilon: measured here from the matched residuals, into calibration (one table)
    sd, src = rows(con, "SELECT sigma_d_m, source FROM calib_match WHERE cam_a = 0 AND cam_b = 1")[0]
    assert src == "matched residuals" and 0.01 < sd < 0.1, (sd, src)
    eps = max(math.sqrt(2 * math.log(100)) * sd, 1e-3)
    (ca, cb, v), = rows(con, "SELECT cam_a, cam_b, value FROM calibrated_values('merge_epsilon')")
    assert (ca, cb) == (0, 1) and abs(v - eps) < 1e-12 * eps, (ca, cb, v, eps)
    assert abs(one(con, "SELECT calibrated('merge_epsilon')") - eps) < 1e-12 * eps
    have = {r[0] for r in rows(con, "SELECT DISTINCT parameter FROM calibration")}
    assert set(auto_parameters()) <= have, (auto_parameters(), have)
    # calibration.csv's rows: the camera pair's values and how they were chosen
    summ = {q: (v, how) for q, v, how in rows(con, "SELECT quantity, value, how FROM result_calibration() WHERE scope = 'cameras 0-1'")}
    assert abs(summ["merge_epsilon"][0] - eps) < 1e-12 * eps and summ["merge_epsilon"][1] == "3.03 x residual sigma", summ
    assert summ["align_max_rms_m"][1] == "0.1 + 3 sigma_pair (noise_align_vote_rms)", summ
    assert one(con, "SELECT value FROM result_calibration() WHERE quantity = 'reference camera'") == 0
    # given: the value wins everywhere, and is reported as given
    con = scene(ext, "align", merge_epsilon="0.3")
    assert rows(con, "SELECT scope, value FROM calibration WHERE parameter = 'merge_epsilon' ORDER BY scope") == [
        ("camera pair", 0.3), ("default", 0.3)]
    assert one(con, "SELECT how FROM result_calibration() WHERE scope = 'cameras 0-1' AND quantity = 'merge_epsilon'") == "given"


def test_overlap(ext):
    con = scene(ext, "overlap")
    assert rows(con, "SELECT camera, class FROM view_polygons ORDER BY camera, class") == [
        (0, "*"), (0, "car"), (0, "pedestrian"), (1, "*"), (1, "car"), (1, "pedestrian")]
    area = one(con, "SELECT area_m2 FROM view_overlaps WHERE class = '*' AND cam_a = 0 AND cam_b = 1")
    # the views' common rectangle is 35 m x 45 m; the roads' hulls cover part of it
    assert 500 < area < 35 * 45, area
    assert rows(con, "SELECT position, camera FROM view_merge_order ORDER BY position") == [(1, 0), (2, 1)]
    assert one(con, "SELECT count(*) FROM view_overlaps_chain WHERE camera = 1 AND merged = [0]") == 3
    # a class is seen at least where a smaller class is (class_length_m): the car view holds the
    # pedestrian view, so a car on a route no earlier car took is still inside its views
    assert one(con, """SELECT bool_and(polygon_area(polygon_overlap(c.polygon, p.polygon)) >= polygon_area(p.polygon) - 1e-6)
                       FROM view_polygons c JOIN view_polygons p USING (camera)
                       WHERE c.class = 'car' AND p.class = 'pedestrian'""")
    assert one(con, "SELECT bool_and(c.area_m2 >= p.area_m2) FROM view_polygons c JOIN view_polygons p USING (camera) WHERE c.class = 'car' AND p.class = 'pedestrian'")


def test_merge(ext):
    con = scene(ext, "merge")
    m = rows(con, "SELECT camera_a, track_a, camera_b, track_b, kind FROM result_matches()")
    assert len(m) >= 11, m
    for ca, ta, cb, tb, kind in m:
        # road user k is track 100 + k in camera 0 (its second piece: 150) and 200 + k in camera 1
        assert (ca, cb, kind) == (0, 1, "hungarian") and (tb - 200 == ta - 100 or (ta, tb) == (150, 204)), (ta, tb)
    # every one of the 12 road users matched across the cameras (each match checked above against
    # the ids' pattern). Before issue 38 one of them stayed two road users (13, 11 matched): its
    # msd held its offset; pair_evidence judges the residual about the offset and the offset apart.
    assert one(con, "SELECT count(*) FROM merge_users") == 12
    assert one(con, "SELECT count(*) FROM merge_users WHERE n_tracks = 2") == 12
    # the merged road user of road user 4 lists both of camera 0's pieces
    src = one(con, "SELECT sources FROM merge_road_users() WHERE list_contains(sources, {'camera': 0, 'track_id': 150})")
    assert {(s["camera"], s["track_id"]) for s in src} == {(0, 104), (0, 150), (1, 204)}, src
    # one epsilon per camera pair, from calibration
    assert one(con, "SELECT count(*) FROM merge_scores s WHERE s.candidate") >= 11
    assert rows(con, "SELECT road_user FROM merge_groups GROUP BY road_user HAVING count(*) > 3") == []


def test_fuse(ext):
    con = scene(ext, "fuse")
    assert one(con, "SELECT count(*) FROM fuse_paths") == 12
    assert one(con, "SELECT count(*) FROM merged WHERE sigma_m IS NULL OR len(sigma) <> len(traj)") == 0
    o = one(con, "SELECT clock_origin FROM align_origin")
    # the fused path is on the common clock (t = clock_origin + k 0.1 s), strictly increasing
    bad = one(con, f"""SELECT count(*) FROM (SELECT unnest(traj) AS p FROM merged)
                       WHERE abs((p.t - {o}) / 0.1 - round((p.t - {o}) / 0.1)) > 1e-6""")
    assert bad == 0, bad
    assert one(con, "SELECT count(*) FROM merged WHERE NOT list_sort([p.t FOR p IN traj]) = [p.t FOR p IN traj]") == 0
    # road user 0 drives along y = -2 in the reference (camera 0's) frame; fused: within 0.1 m
    dev = one(con, """SELECT max(abs(p.y + 2)) FROM (SELECT unnest(traj) AS p FROM merged
                      WHERE list_contains(sources, {'camera': 0, 'track_id': 100}))""")
    assert dev < 0.1, dev
    assert one(con, "SELECT count(*) FROM result_road_users() WHERE sigma_m IS NULL") == 0


def test_cluster(ext):
    con = scene(ext, "cluster")
    a = rows(con, "SELECT class, track_id, cluster FROM cluster_assign")
    assert len(a) == 12 and {c for c, _, _ in a} == {"car", "pedestrian"}, a
    cl = {t: (c, k) for c, t, k in a}
    for t in cl:
        for u in cl:
            same_route = (t - 100) % 4 == (u - 100) % 4
            assert (cl[t] == cl[u]) == same_route, (t, u, cl[t], cl[u])
    assert {r[0] for r in rows(con, "SELECT camera FROM result_clusters()")} == {0}
    # a given cluster_camera: camera 1's tracks
    con = scene(ext, "cluster", cluster_camera="1")
    assert {r[0] for r in rows(con, "SELECT track_id // 100 FROM cluster_assign")} == {2}


def bare(ext, points_sql, upto, **params):
    """A connection with `points` made by `points_sql`, the parameters set, and the stages up to
    `upto` run (the ports of the old in-process pipeline unit tests)."""
    con = duckdb.connect(":memory:", config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{ext}'")
    for k, v in params.items():
        con.execute(f"SET VARIABLE {k} = {v}")
    run_file(con, "sql/params.sql")
    con.execute(points_sql)
    names = stages(con)
    for s in names[: names.index(upto) + 1]:
        run_file(con, f"sql/stages/{s}.sql")
    return con


def test_clean_short_tracks(ext):
    """The clean stage with its auto thresholds measured by calibrate (period 0.1 s): keeps a 2 Hz
    track of 3 points (1 s of a real road user) and a 10 Hz track of 4 points (0.3 s), drops a
    single point and an estimated-only track; given values win over the measured ones."""
    pts = """CREATE TEMP TABLE points AS
             SELECT 1 AS camera, track_id, 'pedestrian' AS class, k * dt AS t, k::DOUBLE AS x, 0.0 AS y, est AS estimated
             FROM (VALUES (1, 0.5, 3, 0), (2, 0.1, 4, 0), (3, 0.1, 1, 0), (4, 0.1, 8, 1), (5, 0.1, 5, 0)) v(track_id, dt, n, est),
                  range(10) r(k) WHERE k < n"""
    con = bare(ext, pts, "clean")
    assert [r[0] for r in rows(con, "SELECT DISTINCT track_id FROM points ORDER BY 1")] == [1, 2, 5]
    assert [r[0] for r in rows(con, "SELECT reason FROM clean_dropped ORDER BY track_id")] == ["too short", "estimated only"]
    con = bare(ext, pts, "clean", clean_min_points="5", clean_min_duration_s="0.35")
    assert [r[0] for r in rows(con, "SELECT DISTINCT track_id FROM points ORDER BY 1")] == [1, 5]


def test_quality_braking(ext):
    """The quality stage's second pass: a car braking at 3 m/s^2 through a 1.5 s gap resumes 3.4 m
    short of its constant-velocity prediction, out of pass 1's 2 m but inside 2 + 3 * 1.5^2 / 2 m;
    a pair pass 1 linked stays linked and is not offered again. With quality_max_accel = 0 the
    second pass adds nothing."""
    pts = """CREATE OR REPLACE TEMP TABLE points AS
             SELECT 1 AS camera, track_id, 'car' AS class, t, x, y, 0 AS estimated FROM (
               SELECT 9 AS track_id, k * 0.1 AS t,
                      CASE WHEN k < 200 THEN -50 + k ELSE 150 END AS x,
                      CASE WHEN k < 200 THEN -50 ELSE -50 + (k - 200) END AS y FROM range(300) r(k)
               UNION ALL SELECT 1, k * 0.1, 10 * k * 0.1, 0 FROM range(51) r(k)
               UNION ALL SELECT 2, 6.5 + k * 0.1, 61.625 + 5.5 * k * 0.1, 0 FROM range(31) r(k)
               UNION ALL SELECT 3, k * 0.1, 10 * k * 0.1, 20 FROM range(51) r(k)
               UNION ALL SELECT 4, 6.0 + k * 0.1, 60 + 10 * k * 0.1, 20 FROM range(31) r(k))"""
    for accel, reach in (("3.0", [(1, 2)]), ("0.0", [])):
        con = bare(ext, pts, "quality", quality_max_accel=accel)
        assert rows(con, "SELECT track_id, linked_id FROM quality_links WHERE track_id <> linked_id ORDER BY 1") == [(4, 3)], accel
        assert rows(con, "SELECT from_id, to_id FROM quality_reach_links ORDER BY 1") == reach, accel


def test_contracts(ext):
    r = subprocess.run([sys.executable, os.path.join(ROOT, "tests/check_stage_contracts.py"), ext], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


TESTS = {"contracts": test_contracts, "calibrate": test_calibrate, "clean": test_clean, "quality": test_quality, "align": test_align,
         "overlap": test_overlap, "merge": test_merge, "fuse": test_fuse, "cluster": test_cluster,
         "clean_short_tracks": test_clean_short_tracks, "quality_braking": test_quality_braking}


def main():
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    ext = os.path.abspath(sys.argv[1])
    want = sys.argv[2:] or list(TESTS)
    con = duckdb.connect(":memory:", config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{ext}'")
    names = stages(con)
    assert len(names) >= 8 and set(names) <= set(TESTS), f"a stage without a test: {sorted(set(names) - set(TESTS))}"
    failed = 0
    for name in want:
        try:
            TESTS[name](ext)
            print(f"ok   {name}")
        except Exception as e:  # noqa: BLE001 - report every stage, then fail
            failed += 1
            where = traceback.extract_tb(e.__traceback__)[-1]
            print(f"FAIL {name}: {type(e).__name__}: {e}\n     at line {where.lineno}: {where.line}")
    if failed:
        raise SystemExit(f"{failed} stage test(s) failed")
    print(f"all {len(want)} stage tests passed")


if __name__ == "__main__":
    main()
