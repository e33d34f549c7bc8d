#!/usr/bin/env python3
"""Accuracy of camera alignment on the real-trajectory scenarios (ground truth from cameras.csv,
read only here, never by the pipeline).

For every camera pair (a, b) it compares the estimated transform a-local -> b-local with the
truth T_b^-1 o T_a: rotation error in degrees and the RMS displacement of a's points that lie
in the true overlap of the two views (the convention of shared/data/README.md).

Methods:
  trajdb      the pipeline's align stage (sql/stages/align.sql: sql/stages/align/*.sql; hypotheses from
              track pairs, voting, trimmed refit, spanning tree), run with the stages before it
              (load, calibrate, clean, quality) from the extension's manifest (benches/stages.py);
              only the align stage is timed
  timecpd8    cpd_align on all points of both cameras (a fixed 1/8 sample), tau = 0.5 s, 8 starts
  cpd_RI      plain rigid CPD (tau = inf) from R = I only (the thesis's start)
  timecpd_RI  TimeCPD (tau = 0.5 s) from R = I only
  thesis      the thesis pipeline: speed-LCSS pre-match (eps 2 m/s, T 1 s, eta >= 0.8), Hungarian
              (assign_pairs), TimeCPD from R = I on the matched points
The purity of each pre-match (share of kept pairs that are the same object, from truth.csv)
is printed too: the thesis's speed pre-match, a tighter coordinate-free signature (1 Hz speeds
within 0.3 m/s and turn rates within 0.15 rad/s, Hungarian), and trajdb's consensus pairs
(align_support: track pairs whose closed-form transform agrees with the winning vote).
The errors are measured over the input's points (points.parquet, estimated = 0); the CPD methods
and the pre-matches work on the pipeline's `points` after the align stage (cleaned, linked, on the
reference camera's clock).

usage: python3 benches/accuracy_align.py --ext trajdb.duckdb_extension [--scenario DIR ...] [--no-cpd]
"""
import argparse
import csv
import math
import os
import sys

import duckdb

from stages import run_stages

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "shared", "data")


def tf_apply(tf, x, y):
    th, tx, ty, s = tf
    c, si = math.cos(th), math.sin(th)
    return s * (c * x - si * y) + tx, s * (si * x + c * y) + ty


def tf_compose(a, b):  # a after b
    tx, ty = tf_apply(a, b[1], b[2])
    return (a[0] + b[0], tx, ty, a[3] * b[3])


def tf_invert(t):
    th, tx, ty, s = t
    inv = (-th, 0.0, 0.0, 1.0 / s)
    x, y = tf_apply(inv, -tx, -ty)
    return (-th, x, y, 1.0 / s)


def wrap_deg(a):
    return (a + 180.0) % 360.0 - 180.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ext", required=True)
    ap.add_argument("--scenario", action="append")
    ap.add_argument("--no-cpd", action="store_true")
    a = ap.parse_args()
    scenarios = a.scenario or [os.path.join(DATA, "dut_intersection_3cam"), os.path.join(DATA, "dut_roundabout_2cam")]
    worst = (0.0, 0.0)
    for sc in scenarios:
        con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
        con.execute(f"LOAD '{os.path.abspath(a.ext)}'")
        pq = os.path.abspath(os.path.join(sc, "points.parquet"))
        el = run_stages(con, pq, "align")["align"]
        # the input's points (the pipeline's `points` are cleaned and linked by then)
        con.execute(f"CREATE TABLE raw AS SELECT * FROM read_parquet('{pq}')")
        frames = {r[0]: (r[1], r[2], r[3], r[4]) for r in con.execute(
            "SELECT camera, to_reference.theta, to_reference.tx, to_reference.ty, to_reference.scale FROM align_frames").fetchall()}
        support = {(r[0], r[1]): r[2] for r in con.execute("SELECT cam_fixed, cam_moving, support FROM align_pairs").fetchall()}
        truth = {}
        with open(os.path.join(sc, "cameras.csv")) as f:
            for row in csv.DictReader(f):
                truth[int(row["camera"])] = ((float(row["theta_rad"]), float(row["tx"]), float(row["ty"]), 1.0), row["view_wkt_world"])
        cams = sorted(truth)
        print(f"\n== {os.path.basename(sc)}: {len(cams)} cameras; the align stage ran in {el:.2f} s; pair support {support}")

        def errors(est_ab, ca, cb):
            """rotation error (deg) and RMS displacement over a's points in the true overlap."""
            true_ab = tf_compose(tf_invert(truth[cb][0]), truth[ca][0])
            # overlap test in world coordinates (true views), plain point-in-polygon
            wa = truth[ca][0]
            rows = con.execute(f"SELECT x, y FROM raw WHERE camera = {ca} AND estimated = 0").fetchall()
            ov = overlap_polys[(ca, cb)]
            sq, n = 0.0, 0
            for x, y in rows:
                wx, wy = tf_apply(wa, x, y)
                if not (inside(ov[0], wx, wy) and inside(ov[1], wx, wy)):
                    continue
                ex, ey = tf_apply(est_ab, x, y)
                tx_, ty_ = tf_apply(true_ab, x, y)
                sq += (ex - tx_) ** 2 + (ey - ty_) ** 2
                n += 1
            rot = abs(wrap_deg(math.degrees(est_ab[0] - true_ab[0])))
            return rot, math.sqrt(sq / n) if n else float("nan"), n

        overlap_polys = {}
        for ca in cams:
            for cb in cams:
                if ca != cb:
                    overlap_polys[(ca, cb)] = (parse_poly(truth[ca][1]), parse_poly(truth[cb][1]))

        methods = {"trajdb": {}}
        for ca in cams:
            for cb in cams:
                if ca < cb and ca in frames and cb in frames:
                    methods["trajdb"][(ca, cb)] = tf_compose(tf_invert(frames[cb]), frames[ca])
        if not a.no_cpd:
            for name, tau, starts in [("timecpd8", "0.5", 8), ("cpd_RI", "'inf'", 1), ("timecpd_RI", "0.5", 1)]:
                methods[name] = {}
                for ca in cams:
                    for cb in cams:
                        if ca < cb:
                            r = con.execute(f"""
                                WITH s AS (SELECT camera, list({{'t': t, 'x': x, 'y': y}} ORDER BY t) AS p
                                           FROM points WHERE estimated = 0 AND camera IN ({ca}, {cb}) AND hash(track_id, t) % 8 = 0 GROUP BY camera)
                                SELECT cpd_align(b.p, a.p, 0.1, {tau}, 100, 1e-6, false, {starts})
                                FROM s a, s b WHERE a.camera = {ca} AND b.camera = {cb}""").fetchone()[0]
                            methods[name][(ca, cb)] = (r["theta"], r["tx"], r["ty"], r["scale"])
        if not a.no_cpd:
            prematch(con, sc, cams, methods)
        print(f"{'pair':8s} " + " ".join(f"{m:>24s}" for m in methods))
        for ca in cams:
            for cb in cams:
                if ca >= cb:
                    continue
                cells = []
                for m, est in methods.items():
                    if (ca, cb) not in est:
                        cells.append(f"{'unsolved':>24s}")
                        continue
                    rot, rms, n = errors(est[(ca, cb)], ca, cb)
                    ok = rot <= 0.5 and rms <= 0.3
                    if m == "trajdb":
                        worst = (max(worst[0], rot), max(worst[1], rms))
                    cells.append(f"{rot:8.3f} deg {rms:7.3f} m {'ok' if ok else '--':>2s}")
                print(f"{ca}-{cb:<6d} " + " ".join(cells))
        print("(columns: rotation error, RMS over a's points in the true overlap; ok = within 0.5 deg and 0.3 m)")
    print(f"\ntrajdb worst pair: {worst[0]:.3f} deg, {worst[1]:.3f} m")
    return 0


def prematch(con, sc, cams, methods):
    """Coordinate-free pre-matching, thesis-style and with our signature; purity from truth.csv."""
    con.execute(f"CREATE OR REPLACE TABLE truth AS SELECT * FROM read_csv('{os.path.join(os.path.abspath(sc), 'truth.csv')}')")
    # the tracks the align stage works on (its align_tracks, dropped at the stage's end: real points,
    # >= align_min_points), here on the common clock of the aligned `points`
    con.execute("""
        CREATE OR REPLACE TABLE pm_tracks AS
        SELECT camera, track_id, class, traj, t0, t1, traj_speeds(traj) AS sp, traj_turn_rates(traj, 1.5) AS tu
        FROM (SELECT camera, track_id, class, list({'t': t, 'x': x, 'y': y} ORDER BY t) AS traj, min(t) AS t0, max(t) AS t1
              FROM points WHERE estimated = 0 GROUP BY camera, track_id, class
              HAVING count(*) >= getvariable('align_min_points'))""")
    con.execute("""
        CREATE OR REPLACE TABLE pm_cand AS
        SELECT a.camera AS ca, b.camera AS cb, a.track_id AS ta, b.track_id AS tb,
               lcss_series_similarity(a.sp, b.sp, 2.0, 1.0) AS eta_thesis,
               least(lcss_series_similarity(traj_speeds(list_filter(a.traj, lambda p, i: i % 10 = 1)),
                                            traj_speeds(list_filter(b.traj, lambda p, i: i % 10 = 1)), 0.3, 0.6, 4),
                     lcss_series_similarity(a.tu, b.tu, 0.15, 0.6, 3)) AS eta_sig
        FROM pm_tracks a JOIN pm_tracks b
          ON a.camera < b.camera AND a.class = b.class AND a.t0 <= b.t1 - 2 AND b.t0 <= a.t1 - 2""")
    sup = con.execute("""
        SELECT s.cam_fixed, s.cam_moving, count(*), count(*) FILTER (WHERE x.object_id = y.object_id AND x.object_id >= 0)
        FROM align_support s JOIN truth x ON x.camera = s.cam_fixed AND x.track_id = s.track_fixed
                             JOIN truth y ON y.camera = s.cam_moving AND y.track_id = s.track_moving
        GROUP BY ALL ORDER BY ALL""").fetchall()
    print("pre-match trajdb   : " + ", ".join(f"{ca}-{cb}: {same}/{kept} pure ({100.0 * same / kept:.0f}%)" for ca, cb, kept, same in sup))
    for name, col, thr in [("thesis", "eta_thesis", 0.8), ("signature", "eta_sig", 0.6)]:
        con.execute(f"""
            CREATE OR REPLACE TABLE pm_{name} AS
            SELECT ca, cb, p.a AS ta, p.b AS tb FROM (
                SELECT ca, cb, unnest(assign_pairs(list({{'a': ta, 'b': tb, 'w': {col}}}))) AS p
                FROM pm_cand WHERE {col} >= {thr} GROUP BY ca, cb)""")
        pur = con.execute(f"""
            SELECT k.ca, k.cb, count(*) AS kept, count(*) FILTER (WHERE x.object_id = y.object_id AND x.object_id >= 0) AS same
            FROM pm_{name} k JOIN truth x ON x.camera = k.ca AND x.track_id = k.ta
                             JOIN truth y ON y.camera = k.cb AND y.track_id = k.tb
            GROUP BY ALL ORDER BY ALL""").fetchall()
        print(f"pre-match {name:9s}: " + ", ".join(f"{ca}-{cb}: {same}/{kept} pure ({100.0 * same / kept:.0f}%)" for ca, cb, kept, same in pur))
        if name != "thesis":
            continue
        methods[name] = {}
        for ca in cams:
            for cb in cams:
                if ca >= cb:
                    continue
                # matched points of the kept pairs (speed sample i is stamped at point i + 1)
                pts = f"""
                    SELECT a.traj[m.i + 1] AS pa, b.traj[m.j + 1] AS pb
                    FROM pm_{name} k
                    JOIN pm_tracks a ON a.camera = k.ca AND a.track_id = k.ta
                    JOIN pm_tracks b ON b.camera = k.cb AND b.track_id = k.tb,
                    LATERAL (SELECT unnest(lcss_series_matches(a.sp, b.sp, {'2.0, 1.0' if name == 'thesis' else '0.3, 0.1'})) AS m)
                    WHERE k.ca = {ca} AND k.cb = {cb}"""
                n = con.execute(f"SELECT count(*) FROM ({pts})").fetchone()[0]
                if n < 3:
                    continue
                try:
                    if name == "thesis":
                        r = con.execute(f"""
                            WITH p AS ({pts})
                            SELECT cpd_align(list(pb ORDER BY pb.t), list(pa ORDER BY pa.t), 0.1, 0.5, 100, 1e-6, false, 1) FROM p""").fetchone()[0]
                    else:
                        r = con.execute(f"""
                            WITH p AS ({pts})
                            SELECT rigid_fit(list({{'fx': pb.x, 'fy': pb.y, 'mx': pa.x, 'my': pa.y}}), 0.2) FROM p""").fetchone()[0]
                    methods[name][(ca, cb)] = (r["theta"], r["tx"], r["ty"], r["scale"])
                except duckdb.Error as e:
                    print(f"  {name} {ca}-{cb}: {e}")


def parse_poly(wkt):
    body = wkt[wkt.index("((") + 2: wkt.index("))")]
    return [tuple(float(v) for v in p.split()) for p in body.split(",")]


def inside(poly, x, y):
    c = False
    for i in range(len(poly)):
        x1, y1 = poly[i]
        x2, y2 = poly[(i + 1) % len(poly)]
        if (y1 > y) != (y2 > y) and x < (x2 - x1) * (y - y1) / (y2 - y1) + x1:
            c = not c
    return c


if __name__ == "__main__":
    sys.exit(main())
