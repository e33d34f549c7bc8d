#!/usr/bin/env python3
"""sql/analysis.sql (issue 29 §4; docs/analysis.md) against the simulator's truth.

1. Movements, EXACT: clean simulated scenes (`trajdb simulate --noise-tracks-per-min 0
   --noise-sigma 0.05`: no spurious tracks, 5 cm noise; 5 minutes, seeds 1 and 2) run through the
   pipeline in this session (trajdb_stages, so `merged` and `align_frames` stay), then:
   - approaches from the data: every vehicle and cyclist (objects.csv source sim:<class>:<from>-><to>)
     whose true path starts and ends outside every camera's view gets a movement, no other does; the
     data approaches map one to one onto the arms; every movement label equals the truth's turn
     (driving on the right, arms E N W S: E->N is a right turn); movements() counts per approach pair
     and class equal the truth's per route and class;
   - user-drawn gates (the arms' cross-sections 15 m from the centre, in the world frame, mapped into
     the reference camera's frame with cameras.csv): the same counts, named by the arms themselves;
   - the mirrored frame (y -> -y) with left_handed := true gives the same labels.
   Road users map to objects through merged.sources and truth.csv (majority of points).
2. Speeds: per class, the median and 85th percentile of road users' mean speeds within 5% of the
   truth's (world.csv over the same times).
3. Conflicts on handmade pairs with exact kinematics (10 Hz): PET within 0.1 s (a right-angle
   crossing, a 45 degree crossing, a car turning on a circle against two straight ones), the conflict point within
   0.1 m; a pair far apart in time is not a candidate; TTC of a head-on pair that brakes to a stop
   (2.9 s at t = 2).

usage: python3 tests/test_analysis_python.py path/to/trajdb.duckdb_extension
"""
import math
import os
import re
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "python"))
os.environ["TRAJDB_EXTENSION"] = os.path.abspath(sys.argv[1])

import duckdb  # noqa: E402
import trajdb  # noqa: E402

ANALYSIS = open(os.path.join(ROOT, "sql", "analysis.sql"), encoding="utf-8").read()
ARM_BEARING = {"E": 0.0, "N": 90.0, "W": 180.0, "S": 270.0}


def truth_turn(fr, to):
    """The turn of route fr->to: entering from arm fr (heading away from it), leaving by arm to."""
    d = (ARM_BEARING[to] - (ARM_BEARING[fr] + 180.0)) % 360.0
    d = d - 360.0 if d > 180.0 else d
    return "through" if abs(d) < 45 else "u-turn" if abs(d) >= 135 else "left" if d > 0 else "right"


def run_scene(tmp, seed):
    con = trajdb.connect()
    scene = os.path.join(tmp, f"scene{seed}")
    trajdb.simulate(con, scene, minutes=5, seed=seed, noise_tracks_per_min=0, noise_sigma_min=0.05, noise_sigma_max=0.05)
    steps = con.execute("SELECT sql FROM trajdb_stages(?) ORDER BY k", [os.path.join(scene, "points.parquet")]).fetchall()
    for (sql,) in steps:
        con.execute(sql)
    con.execute(ANALYSIS)
    for f in ("objects", "truth", "cameras", "world"):
        con.execute(f"CREATE TABLE truth_{f} AS FROM read_csv(?, header = true)", [os.path.join(scene, f + ".csv")])
    # road user -> object (majority of its tracks' points is overkill here: of its tracks)
    con.execute("""CREATE TABLE ru_object AS
        SELECT road_user, mode(t.object_id) AS object_id, count(DISTINCT t.object_id) AS n_objects
        FROM (SELECT road_user, unnest(sources) AS s FROM merged) m
        JOIN truth_truth t ON t.camera = m.s.camera AND t.track_id = m.s.track_id GROUP BY road_user""")
    con.execute("""CREATE TABLE routes_truth AS
        SELECT object_id, class, split_part(split_part(source, ':', 3), '->', 1) AS arm_in, split_part(split_part(source, ':', 3), '->', 2) AS arm_out
        FROM truth_objects WHERE source LIKE 'sim:%:%->%' AND source NOT LIKE '%;%'""")
    # complete: the true path starts and ends outside every camera's view (seen entering and leaving)
    con.execute("""CREATE TABLE complete AS
        WITH w AS (SELECT object_id, arg_min(x, t) AS x0, arg_min(y, t) AS y0, arg_max(x, t) AS x1, arg_max(y, t) AS y1
                   FROM truth_world GROUP BY object_id)
        SELECT w.object_id FROM w JOIN routes_truth USING (object_id)
        WHERE NOT EXISTS (SELECT 1 FROM truth_cameras c WHERE polygon_contains(c.view_wkt_world, w.x0, w.y0)
                                                          OR polygon_contains(c.view_wkt_world, w.x1, w.y1))""")
    return con, scene


def check_movements(con, seed):
    bad = con.execute("SELECT count(*) FROM ru_object WHERE n_objects > 1").fetchone()[0]
    assert bad == 0, f"seed {seed}: {bad} road users mix objects (the scene is not clean enough for an exact test)"
    rows = con.execute("""
        SELECT m.road_user, m.approach_in, m.approach_out, m.movement, r.arm_in, r.arm_out, r.class,
               r.object_id IN (SELECT object_id FROM complete) AS complete
        FROM road_user_movements() m JOIN ru_object o USING (road_user) JOIN routes_truth r USING (object_id)""").fetchall()
    assert rows, "no vehicles"
    # approaches map one to one onto arms
    amap = {}
    for _, ain, aout, mv, rin, rout, _, complete in rows:
        assert (mv is not None) == complete, f"seed {seed}: movement {mv} for a road user whose path is {'complete' if complete else 'cut'}"
        if mv is None:
            continue
        for a, r in ((ain, rin), (aout, rout)):
            assert amap.setdefault(a, r) == r, f"seed {seed}: approach {a} is arm {amap[a]} and {r}"
        assert mv == truth_turn(rin, rout), f"seed {seed}: {rin}->{rout} labelled {mv}"
    assert len(set(amap.values())) == len(amap) == 4, amap
    n_complete = con.execute("SELECT count(*) FROM complete").fetchone()[0]
    labelled = sum(1 for r in rows if r[3] is not None)
    # every complete object is one road user (no object in two road users)
    assert labelled == n_complete, f"seed {seed}: {labelled} road users labelled, {n_complete} complete objects"
    # movements(): counts per route and class, summed over 1-minute bins, equal the truth's
    got = {}
    for _, ain, aout, mv, cls, n in con.execute("FROM movements(bin_s := 60) WHERE class <> 'pedestrian'").fetchall():
        key = (amap[ain], amap[aout], cls)
        got[key] = got.get(key, 0) + n
    want = dict(((a, b, c), n) for a, b, c, n in con.execute(
        "SELECT arm_in, arm_out, class, count(*) FROM routes_truth WHERE object_id IN (SELECT object_id FROM complete) GROUP BY ALL").fetchall())
    assert got == want, f"seed {seed}: movements {got} != truth {want}"
    return amap, n_complete, len(want)


def check_gates(con, seed):
    # the reference camera's frame: p_world = R(theta) p_local + t (cameras.csv)
    ref = con.execute("SELECT any_value(reference) FROM align_frames").fetchone()[0]
    th, tx, ty = con.execute("SELECT theta_rad, tx, ty FROM truth_cameras WHERE camera = ?", [ref]).fetchone()

    def local(x, y):
        dx, dy = x - tx, y - ty
        return (math.cos(th) * dx + math.sin(th) * dy, -math.sin(th) * dx + math.cos(th) * dy)

    gates = []
    for arm, b in ARM_BEARING.items():
        ux, uy = math.cos(math.radians(b)), math.sin(math.radians(b))
        p, q = local(15 * ux - 9 * uy, 15 * uy + 9 * ux), local(15 * ux + 9 * uy, 15 * uy - 9 * ux)
        gates.append((arm, f"LINESTRING ({p[0]} {p[1]}, {q[0]} {q[1]})"))
    con.execute("CREATE TABLE gates_wkt(approach VARCHAR, wkt VARCHAR)")
    con.executemany("INSERT INTO gates_wkt VALUES (?, ?)", gates)
    con.execute("CREATE TABLE my_gates AS SELECT approach, unnest(gate_from_wkt(wkt)) FROM gates_wkt")
    got = dict(((a, b, c), n) for a, b, c, n in con.execute(
        "SELECT approach_in, approach_out, class, sum(road_users) FROM movements(gates := 'my_gates') WHERE class <> 'pedestrian' GROUP BY ALL").fetchall())
    want = dict(((a, b, c), n) for a, b, c, n in con.execute(
        "SELECT arm_in, arm_out, class, count(*) FROM routes_truth WHERE object_id IN (SELECT object_id FROM complete) GROUP BY ALL").fetchall())
    assert got == want, f"seed {seed} gates: {got} != {want}"
    labels = con.execute("""SELECT count(*) FILTER (WHERE m.movement IS DISTINCT FROM d.movement) FROM road_user_movements(gates := 'my_gates') m
                            JOIN road_user_movements() d USING (road_user) WHERE m.movement IS NOT NULL AND d.movement IS NOT NULL""").fetchone()[0]
    assert labels == 0
    check_report_gates(con, seed, gates, want)
    # crossings (issue 39 §9): screenlines along each arm's axis, 8-18 m from the centre (where the
    # crosswalks are), on the merged paths and on the true paths in the same frame: the same road
    # users cross each one in each direction
    lines = []
    for arm, b in ARM_BEARING.items():
        ux, uy = math.cos(math.radians(b)), math.sin(math.radians(b))
        p, q = local(8 * ux, 8 * uy), local(18 * ux, 18 * uy)
        lines.append((arm, p[0], p[1], q[0], q[1]))
    con.execute("CREATE TABLE screenlines(approach VARCHAR, x1 DOUBLE, y1 DOUBLE, x2 DOUBLE, y2 DOUBLE)")
    con.executemany("INSERT INTO screenlines VALUES (?, ?, ?, ?, ?)", lines)
    con.execute("""CREATE TABLE true_paths AS
        SELECT object_id AS road_user, any_value(class) AS class,
               list({'t': t, 'x': cos(?) * (x - ?) + sin(?) * (y - ?), 'y': -sin(?) * (x - ?) + cos(?) * (y - ?)} ORDER BY t) AS traj
        FROM truth_world GROUP BY object_id""", [th, tx, th, ty, th, tx, th, ty])
    q = "SELECT gate, direction, class, sum(road_users) FROM crossings(tbl := ?, gates := 'screenlines') GROUP BY ALL"
    got, want_x = (dict(((g, d, c), n) for g, d, c, n in con.execute(q, [t]).fetchall()) for t in ("merged", "true_paths"))
    peds = sum(n for k, n in want_x.items() if k[2] == "pedestrian")
    assert peds > 0, want_x
    assert got == want_x, f"seed {seed} crossings: {got} != truth {want_x}"
    print(f"  seed {seed}: crossings exact: {sum(want_x.values())} road users over {len(want_x)} (screenline, direction, class) cells, {peds} pedestrians")


def report_movements(html):
    """The movement table of report.html: {(from, to, class): road users}."""
    part = html.split("<h2>Turning movements</h2>", 1)[1].split("<h2>", 1)[0]
    rows = re.findall(r"<tr><th>([^<]*)</th><td>([^<]*)</td><td>[^<]*</td><td>([^<]*)</td><td>(\d+)</td></tr>", part)
    return dict(((a, b, c), int(n)) for a, b, c, n in rows)


def check_report_gates(con, seed, gates, want):
    """(issue 39) report.html counts movements by the analyst's gates (parameter report_gates: a
    CSV file with approach, wkt, or a table of the connection with approach, x1, y1, x2, y2), says
    they were drawn, and its movement table equals the truth; a gate without an approach name is
    an error naming the parameter."""
    scene = os.path.dirname(con.execute("SELECT getvariable('pipeline_input')").fetchone()[0])
    csv = os.path.join(scene, "gates.csv")
    with open(csv, "w", encoding="utf-8") as f:
        f.write("approach,wkt\n" + "".join(f'{a},"{w}"\n' for a, w in gates))
    for how, value in (("file", csv), ("table", "my_gates")):
        out = os.path.join(scene, f"results_{how}")
        trajdb.pipeline(con, os.path.join(scene, "points.parquet"), out=out, report_gates=value)
        html = open(os.path.join(out, "report.html"), encoding="utf-8").read()
        assert "the gates you drew</b> (parameter report_gates = " in html, how
        assert "4 gates drawn by the analyst (report_gates)" in html, how
        got = report_movements(html)
        assert got == want, f"seed {seed} report gates ({how}): {got} != {want}"
    # and without gates, the report says its approaches were found
    html = open(os.path.join(scene, "results_file", "report.html"), encoding="utf-8").read()
    out = os.path.join(scene, "results_found")
    trajdb.pipeline(con, os.path.join(scene, "points.parquet"), out=out)
    assert "found in the data</b>" in open(os.path.join(out, "report.html"), encoding="utf-8").read()
    bad = os.path.join(scene, "bad_gates.csv")
    with open(bad, "w", encoding="utf-8") as f:
        f.write("approach,x1,y1,x2,y2\n,0,0,1,1\n")
    try:
        trajdb.pipeline(con, os.path.join(scene, "points.parquet"), out=os.path.join(scene, "results_bad"), report_gates=bad)
        raise AssertionError("a gate without a name was accepted")
    except duckdb.Error as e:
        assert "report_gates: every gate needs an approach name" in str(e), e
    assert not os.path.exists(os.path.join(scene, "results_bad", "report.html"))


def check_mirror(con):
    con.execute("CREATE TABLE mirrored AS SELECT road_user, class, [{'t': p.t, 'x': p.x, 'y': -p.y} FOR p IN traj] AS traj FROM merged")
    a = con.execute("SELECT road_user, movement FROM road_user_movements() ORDER BY road_user").fetchall()
    b = con.execute("SELECT road_user, movement FROM road_user_movements(tbl := 'mirrored', left_handed := true) ORDER BY road_user").fetchall()
    c = con.execute("SELECT count(*) FROM road_user_movements(tbl := 'mirrored') WHERE movement IN ('left', 'right')").fetchone()[0]
    assert a == b, "the mirrored frame with left_handed := true must give the same movements"
    d = con.execute("""SELECT count(*) FROM road_user_movements(tbl := 'mirrored') m JOIN road_user_movements() o USING (road_user)
                       WHERE m.movement IN ('left', 'right') AND m.movement = o.movement""").fetchone()[0]
    assert c > 0 and d == 0, "without the flag a mirrored frame swaps left and right"


def check_speeds(con, seed):
    rows = con.execute("""
        WITH s AS (FROM road_user_speeds()),
        e AS (SELECT road_user, traj[1].t AS t0, traj[-1].t AS t1 FROM merged),
        w AS (SELECT o.road_user, list({'t': w.t, 'x': w.x, 'y': w.y} ORDER BY w.t) AS tr
              FROM ru_object o JOIN e USING (road_user) JOIN truth_world w ON w.object_id = o.object_id AND w.t BETWEEN e.t0 AND e.t1
              GROUP BY o.road_user),
        j AS (SELECT s.class, s.mean_speed_kmh / 3.6 AS mean_speed, traj_length_m(w.tr) / traj_duration(w.tr) AS true_speed FROM s JOIN w USING (road_user)
              WHERE traj_duration(w.tr) > 2)
        SELECT class, count(*), quantile_cont(mean_speed, 0.5), quantile_cont(true_speed, 0.5),
               quantile_cont(mean_speed, 0.85), quantile_cont(true_speed, 0.85)
        FROM j GROUP BY class ORDER BY class""").fetchall()
    for cls, n, p50, t50, p85, t85 in rows:
        print(f"  seed {seed} {cls:14s} n={n:3d}  p50 {p50:6.2f} (truth {t50:6.2f})  p85 {p85:6.2f} (truth {t85:6.2f}) m/s")
        assert abs(p50 / t50 - 1) < 0.05 and abs(p85 / t85 - 1) < 0.05, (cls, p50, t50, p85, t85)
    out = con.execute("SELECT count(*), count(speed_p85_kmh), count(travel_time_p50_s) FROM speeds()").fetchone()
    assert out[0] > 0 and out[1] == out[0] and out[2] == out[0], out


def check_conflicts():
    con = trajdb.connect()
    con.execute(ANALYSIS)
    # exact kinematics at 10 Hz: t = k / 10
    con.execute("""CREATE TABLE scene AS
        WITH k AS (SELECT k, k / 10.0 AS t FROM range(0, 201) r(k))
        -- 1: car east at 10 m/s through (0, 0) at t = 5; 2: cyclist north at 5 m/s through (0, 0) at t = 6.5 (PET 1.5 with 1)
        SELECT 1 AS road_user, 'car' AS class, list({'t': t, 'x': -50 + 10 * t, 'y': 0.0} ORDER BY t) AS traj FROM k WHERE t <= 10
        UNION ALL SELECT 2, 'cyclist', list({'t': t, 'x': 0.0, 'y': -32.5 + 5 * t} ORDER BY t) FROM k WHERE t <= 13
        -- 3: pedestrian on the diagonal at 1.5 m/s through (20, 0) at t = 7.3 (car 1 there at t = 7: PET 0.3)
        UNION ALL SELECT 3, 'pedestrian', list({'t': t, 'x': 20 + (t - 7.3) * 1.5 / sqrt(2), 'y': (t - 7.3) * 1.5 / sqrt(2)} ORDER BY t) FROM k WHERE t BETWEEN 2 AND 12
        -- 4: a car turning left on a circle of radius 10 about (-5, 0) at 8 m/s (0.8 rad/s), from (-5, -10) heading east at t = 6
        --    to (-5, 10) heading west: it crosses x = 0 (cyclist 2) at y = -/+ 8.66 at t = 6 + (pi/6) / 0.8 and 6 + (5 pi/6) / 0.8,
        --    where the cyclist is at t = (32.5 -/+ 8.66) / 5: the smaller PET is the second; and y = 0 (car 1) at (5, 0)
        UNION ALL SELECT 4, 'car', list({'t': t, 'x': -5 + 10 * cos(-pi() / 2 + 0.8 * (t - 6)), 'y': 10 * sin(-pi() / 2 + 0.8 * (t - 6))} ORDER BY t)
                  FROM k WHERE t BETWEEN 6 AND 6 + pi() / 0.8
        -- 5: like car 1 but 60 s later: crosses 2's path, never near it in time
        UNION ALL SELECT 5, 'car', list({'t': t + 60, 'x': -50 + 10 * t, 'y': 0.0} ORDER BY t) FROM k WHERE t <= 10""")
    res = {(a, b): (pet, x, y) for a, b, pet, x, y in con.execute(
        "SELECT road_user_a, road_user_b, pet, pet_x, pet_y FROM conflicts(tbl := 'scene', max_pet := 5.0) WHERE pet IS NOT NULL").fetchall()}
    y60 = 10 * math.sin(math.pi / 3)
    known = {(1, 2): (1.5, 0.0, 0.0), (1, 3): (0.3, 20.0, 0.0),
             (2, 4): (abs(6 + (5 * math.pi / 6) / 0.8 - (32.5 + y60) / 5), 0.0, y60),
             (1, 4): (abs(6 + (math.pi / 2) / 0.8 - 5.5), 5.0, 0.0)}
    for pair, (pet, x, y) in known.items():
        assert pair in res, f"pair {pair} missing from conflicts(): {res}"
        g = res[pair]
        print(f"  PET {pair}: {g[0]:.4f} s (known {pet:.4f}) at ({g[1]:.3f}, {g[2]:.3f})")
        assert abs(g[0] - pet) < 0.1 and math.hypot(g[1] - x, g[2] - y) < 0.1, (pair, g, pet)
    assert not any(5 in p for p in res), f"road user 5 is a minute away from every other: {res}"
    # top_conflicts: the rows of conflicts() with the k smallest PETs, the same columns and values,
    # whatever k (ties at the k-th included), in PET order
    full = con.execute("FROM conflicts(tbl := 'scene', max_pet := 5.0) WHERE pet IS NOT NULL ORDER BY pet, road_user_a, road_user_b").fetchall()
    for k in (1, 2, 3, 10):
        top = con.execute(f"FROM top_conflicts(tbl := 'scene', k := {k}, max_pet := 5.0)").fetchall()
        assert top == full[:k], (k, top, full)
    print(f"  top_conflicts: the first k rows of conflicts() for k = 1, 2, 3, 10 ({len(full)} crossings)")
    # k NULL: every crossing (no TTC-only rows); a NULL parameter is an error, not an empty table
    assert con.execute("FROM top_conflicts(tbl := 'scene', k := NULL, max_pet := 5.0)").fetchall() == full
    for bad in ("max_pet := NULL", "pedestrian_pairs := NULL"):
        try:
            con.execute(f"FROM top_conflicts(tbl := 'scene', {bad})").fetchall()
            raise AssertionError(f"{bad}: no error")
        except duckdb.Error as e:
            assert "max_pet, max_ttc and pedestrian_pairs must not be NULL" in str(e), e
    # (issue 39) TTC at the classes' radii by default; radius := R for every pair; the
    # pedestrian 3 and car 1 (PET 0.3) are on a collision course at 0.25 + 0.9 m and at 2 m alike
    by_class = dict(((a, b), t) for a, b, t in con.execute("SELECT road_user_a, road_user_b, ttc FROM conflicts(tbl := 'scene', max_pet := 5.0)").fetchall())
    wide = dict(((a, b), t) for a, b, t in con.execute("SELECT road_user_a, road_user_b, ttc FROM conflicts(tbl := 'scene', max_pet := 5.0, radius := 2.0)").fetchall())
    assert set(by_class) <= set(wide), (by_class, wide)
    assert all(by_class[p] is None or wide[p] is None or by_class[p] >= wide[p] - 1e-9 for p in by_class), (by_class, wide)
    # pedestrian_pairs := false leaves no pair of two pedestrians in top_conflicts
    con.execute("CREATE TABLE scene_p AS SELECT road_user, CASE WHEN road_user IN (1, 3) THEN 'pedestrian' ELSE class END AS class, traj FROM scene")
    rows = con.execute("SELECT road_user_a, road_user_b FROM top_conflicts(tbl := 'scene_p', k := 10, pedestrian_pairs := false)").fetchall()
    assert (1, 3) not in rows and rows, rows
    assert (1, 3) in con.execute("SELECT road_user_a, road_user_b FROM top_conflicts(tbl := 'scene_p', k := 10)").fetchall()
    try:
        con.execute("FROM conflicts(tbl := 'scene', max_ttc := NULL)").fetchall()
        raise AssertionError("max_ttc NULL: no error")
    except duckdb.Error as e:
        assert "must not be NULL" in str(e), e
    # road_user of another integer type (UBIGINT, HUGEINT): the same pairs
    con.execute("CREATE TABLE scene_u AS SELECT road_user::UBIGINT AS road_user, class, traj FROM scene")
    assert [(a, b, p) for a, b, p in con.execute("SELECT road_user_a, road_user_b, pet FROM top_conflicts(tbl := 'scene_u', k := 10)").fetchall()] \
        == [(r[0], r[2], r[4]) for r in full]
    # TTC: head-on, both braking to a stop at t = 2, 60 m apart: TTC(s) = 4.9 - s, min 2.9 at t = 2
    con.execute("""CREATE TABLE headon AS
        WITH k AS (SELECT k / 10.0 AS t FROM range(0, 51) r(k))
        SELECT 1 AS road_user, 'car' AS class, list({'t': t, 'x': -50 + 10 * least(t, 2.0), 'y': 0.0} ORDER BY t) AS traj FROM k
        UNION ALL SELECT 2, 'car', list({'t': t, 'x': 50 - 10 * least(t, 2.0), 'y': 0.0} ORDER BY t) FROM k""")
    ttc, t, pet = con.execute("SELECT ttc, ttc_t, pet FROM conflicts(tbl := 'headon', radius := 2.0, max_ttc := 10)").fetchone()
    print(f"  TTC head-on: {ttc:.4f} s at t = {t:.3f} (known 2.9 at 2.0); PET {pet}")
    assert abs(ttc - 2.9) < 1e-6 and abs(t - 2.0) < 1e-6 and pet is None


def check_all_stationary_group():
    """(issue 39) A group whose road users are all stationary keeps its speeds() row: road_users 0,
    stationary n, speeds NULL (it vanished, and its parked cars with it)."""
    con = trajdb.connect()
    con.execute(ANALYSIS)
    con.execute("""CREATE TABLE parked AS SELECT road_user, 'car' AS class,
        list({'t': k::DOUBLE, 'x': road_user * 10 + 0.01 * (k % 2), 'y': 0.0} ORDER BY k) AS traj
        FROM range(1, 3) r(road_user), range(0, 60) s(k) GROUP BY road_user""")
    rows = con.execute("SELECT class, road_users, stationary, speed_p50_kmh FROM speeds(tbl := 'parked')").fetchall()
    assert rows == [("car", 0, 2, None)], rows
    assert con.execute("SELECT road_users, stationary FROM speeds(tbl := 'parked', include_stationary := true)").fetchall() == [(2, 2)]
    print("  speeds: a group of parked cars only keeps its row (road_users 0, stationary 2)")


def check_crossing_edges():
    """(issue 39, review F2) A path through a sample point ON a gate crosses it once; a path that
    touches the line from its left and turns back does not cross it; bin_s must be > 0."""
    con = trajdb.connect()
    con.execute(ANALYSIS)
    con.execute("""CREATE TABLE paths AS SELECT * FROM (VALUES
        (1, 'pedestrian', [{'t': 0.0, 'x': 0.0, 'y': -1.0}, {'t': 1.0, 'x': 0.0, 'y': 0.0}, {'t': 2.0, 'x': 0.0, 'y': 1.0}]),
        (2, 'pedestrian', [{'t': 0.0, 'x': 1.0, 'y': 1.0}, {'t': 1.0, 'x': 1.0, 'y': 0.0}, {'t': 2.0, 'x': 1.0, 'y': 1.0}]),
        (3, 'pedestrian', [{'t': 0.0, 'x': 2.0, 'y': 1.0}, {'t': 1.0, 'x': 2.0, 'y': -1.0}])) p(road_user, class, traj)""")
    con.execute("CREATE TABLE line AS SELECT 'g' AS approach, -5.0 AS x1, 0.0 AS y1, 5.0 AS x2, 0.0 AS y2")
    got = con.execute("SELECT road_user, t, to_left FROM road_user_crossings(tbl := 'paths', gates := 'line') ORDER BY road_user").fetchall()
    assert got == [(1, 1.0, True), (3, 0.5, False)], got
    for bad in ("0", "NULL", "-900"):
        try:
            con.execute(f"FROM crossings(tbl := 'paths', gates := 'line', bin_s := {bad})").fetchall()
            raise AssertionError(f"bin_s {bad}: no error")
        except duckdb.Error as e:
            assert "crossings: bin_s must be a number of seconds > 0" in str(e), e
    print("  crossings: once through a sample point on the gate, none for a touch from the left, bin_s checked")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        for seed in (1, 2):
            con, _ = run_scene(tmp, seed)
            amap, n, routes = check_movements(con, seed)
            print(f"  seed {seed}: movements exact: {n} vehicles and cyclists over {routes} (route, class) cells; approaches {amap}")
            check_gates(con, seed)
            print(f"  seed {seed}: gates exact")
            check_mirror(con)
            check_speeds(con, seed)
    check_conflicts()
    check_crossing_edges()
    check_all_stationary_group()
    print("test_analysis_python: ok")


if __name__ == "__main__":
    main()
