#!/usr/bin/env python3
"""`trajdb.score` (the Python twin of `trajdb score`, the same sql/score.sql) on a hand-made
scenario whose HOTA and clock errors are computed by hand below (issue 26, part 6; the scorer is
sql/score.sql). docs/scoring.md
defines every figure.

Two cameras at identity transforms; clocks t_cam = (1 + D 1e-6) w + o (w: world time) at
Unix-epoch size: camera 0 o = 1 780 000 000 s, D = +100 ppm; camera 1 o = 1 780 003 600 s (an
hour later), D = -50 ppm. One real point per second:
  camera 0: track 1 = object A, car (10 points, w 0..9); 2 = B, pedestrian (10);
            3 = A (5, w 20..24); 9 = noise (car, is_noise = 1, object -1; 4 points)
  camera 1: track 7 = A (10 points, w 0..9, plus one ESTIMATED point at w = 2000 that counts
            nowhere); 8 = B (6 points, w 995..1000)
Road users: RU1 = {0:1, 1:7}, RU2 = {0:2, 0:3, 0:9}; track 1:8 in none.

HOTA, all classes: n_A = 25, n_B = 16; TP = 20 (A in RU1) + 5 (A in RU2) + 10 (B in RU2) = 35,
FN = 6 (track 1:8), FP = 4 (the noise in RU2); n_RU1 = 20, n_RU2 = 5 + 10 + 4 = 19.
  DetA = 35 / (35 + 6 + 4) = 7/9
  AssA = [20^2/(25+20-20) + 5^2/(25+19-5) + 10^2/(16+19-10)] / 35 = (16 + 25/39 + 4) / 35 = 23/39
  HOTA = sqrt(7/9 * 23/39) = sqrt(161/351) = 0.677266...
car only (A and the noise): DetA = 25/29, AssA = (16 + 25/(25+9-5)) / 25 = 489/725,
  HOTA = sqrt(489/841) = sqrt(489)/29; pedestrian only (B): DetA = AssA = HOTA = 10/16.

Clock, pair 0 -> 1 (t_0 = (1 + e) t_1 + C, e = 150 ppm): true pairwise drift
(100 + 50) / (1 - 50e-6) = 150.0075004 ppm, so the drift error is 0.0075004 ppm. C puts the
error at -2 ms at w = 0; it changes by w (e + d_1 + e d_1 - d_0) = w (-7.5e-9) s, so at the end of
camera 1's real span (w = 1000) it is -2.0075 ms: clock error 2.0075 ms. A naive
|C - (o_0 - o_1)| would say 267 000 s.

Then the same scenario in the old formats (no clock_drift_ppm in cameras.csv nor
transforms.csv, no clock offsets): drift 0, and a perfect result scores HOTA 1.

usage: python3 tests/test_score_python.py path/to/trajdb.duckdb_extension
"""
import math
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "python"))
os.environ["TRAJDB_EXTENSION"] = os.path.abspath(sys.argv[1])

import trajdb  # noqa: E402

O0, O1, D0, D1, E = 1_780_000_000.0, 1_780_003_600.0, 100e-6, -50e-6, 150e-6
VIEW = "POLYGON ((-9 -9, 99 -9, 99 99, -9 99, -9 -9))"


def write_case(con, d, drift, road_users):
    """The scenario above in d (points.parquet, cameras.csv, truth.csv) and its results in d/r;
    drift=False writes the old formats (no clock columns at all, synchronised clocks)."""
    os.makedirs(os.path.join(d, "r"), exist_ok=True)
    o0, o1, d0, d1 = (O0, O1, D0, D1) if drift else (0.0, 0.0, 0.0, 0.0)
    c = -0.002 + (o0 - o1) - E * o1 if drift else 0.0
    con.execute(f"""COPY (SELECT v.camera::INTEGER AS camera, track_id::BIGINT AS track_id, class,
                                 c.o + (1 + c.d) * (w0 + k) AS t, k::DOUBLE AS x, y, est AS estimated
                          FROM (VALUES (0, 1, 'car', 0.0, 0.0, 10, 0), (0, 2, 'pedestrian', 0.0, 5.0, 10, 0), (0, 3, 'car', 20.0, 0.0, 5, 0),
                                       (0, 9, 'car', 0.0, 9.0, 4, 0), (1, 7, 'car', 0.0, 0.0, 10, 0), (1, 7, 'car', 2000.0, 0.0, 1, 1),
                                       (1, 8, 'pedestrian', 995.0, 5.0, 6, 0)) v(camera, track_id, class, w0, y, n, est)
                          JOIN (VALUES (0, {o0!r}, {d0!r}), (1, {o1!r}, {d1!r})) c(camera, o, d) ON c.camera = v.camera,
                          range(10) r(k) WHERE k < n) TO '{d}/points.parquet' (FORMAT parquet)""")
    clock_cols = ", clock_offset_s, clock_drift_ppm" if drift else ""
    clock_vals = [f", {O0!r}, 100.0", f", {O1!r}, -50.0"] if drift else ["", ""]
    con.execute(f"""COPY (SELECT * FROM (VALUES (0, 0.0, 0.0, 0.0, '{VIEW}'{clock_vals[0]}), (1, 0.0, 0.0, 0.0, '{VIEW}'{clock_vals[1]}))
                          v(camera, theta_rad, tx, ty, view_wkt_world{clock_cols})) TO '{d}/cameras.csv' (HEADER)""")
    con.execute(f"""COPY (SELECT * FROM (VALUES (0, 1, 100, 0), (0, 2, 200, 0), (0, 3, 100, 0), (0, 9, -1, 1), (1, 7, 100, 0), (1, 8, 200, 0))
                          v(camera, track_id, object_id, is_noise)) TO '{d}/truth.csv' (HEADER)""")
    drift_col = ", 150.0 AS clock_drift_ppm" if drift else ""
    con.execute(f"""COPY (SELECT 0 AS cam_from, 1 AS cam_to, 0.0 AS theta_rad, 0.0 AS tx, 0.0 AS ty, {c!r} AS clock_offset_s{drift_col})
                    TO '{d}/r/transforms.csv' (HEADER)""")
    con.execute(f"""COPY (SELECT 0 AS camera_a, 1 AS track_a, 1 AS camera_b, 7 AS track_b, 1.0 AS score, 'hungarian' AS kind)
                    TO '{d}/r/matches.csv' (HEADER)""")
    con.execute(f"""COPY (SELECT * FROM (VALUES (0, 1, 1), (0, 2, 2), (0, 3, 1), (0, 9, 9), (1, 7, 7), (1, 8, 8)) v(camera, track_id, linked_id))
                    TO '{d}/r/links.csv' (HEADER)""")
    con.execute(f"""COPY (SELECT road_user, 'car' AS class, list({{'camera': c, 'track_id': t}}) AS sources
                          FROM (VALUES {road_users}) v(road_user, c, t) GROUP BY road_user) TO '{d}/r/merged.parquet' (FORMAT parquet)""")


def close(a, b, tol=1e-12):
    return abs(a - b) < tol


def main():
    con = trajdb.connect()
    with tempfile.TemporaryDirectory() as w:
        d = os.path.join(w, "drift")
        write_case(con, d, True, "(1, 0, 1), (1, 1, 7), (2, 0, 2), (2, 0, 3), (2, 0, 9)")
        s = trajdb.score(con, d, os.path.join(d, "r"))
        assert close(s["deta"], 7 / 9) and close(s["assa"], 23 / 39) and close(s["hota"], math.sqrt(161 / 351)), s
        per = {r[0]: r[1:] for r in con.sql("SELECT class, hota, deta, assa FROM s_identity").fetchall()}
        h, dt, a = per["car"]
        assert close(dt, 25 / 29) and close(a, 489 / 725) and close(h, math.sqrt(489) / 29), per
        assert all(close(v, 0.625) for v in per["pedestrian"]), per
        assert con.sql("SELECT tp, fn, fp FROM s_hota WHERE class = '*'").fetchall() == [(35.0, 6.0, 4.0)]
        true_drift = (100.0 + 50.0) / (1.0 - 50e-6)
        assert close(s["drift_ppm"], true_drift - 150.0, 1e-9), s
        assert close(s["clock_s"], 0.0020075, 1e-7), s
        print(f"ok   hand-made HOTA {s['hota']:.6f} (DetA 7/9, AssA 23/39), clock error {s['clock_s'] * 1e3:.4f} ms, "
              f"drift error {s['drift_ppm']:.7f} ppm at Unix-epoch clocks")

        d = os.path.join(w, "old")
        write_case(con, d, False, "(1, 0, 1), (1, 0, 3), (1, 1, 7), (2, 0, 2), (2, 1, 8)")
        s = trajdb.score(con, d, os.path.join(d, "r"))
        # the noise track is in no road user: no FP; everything else in its object's one road user
        assert close(s["hota"], 1.0) and s["drift_ppm"] == 0.0 and s["clock_s"] == 0.0, s
        print("ok   old formats (no clock columns): drift 0, clock 0, a perfect result scores HOTA 1")

        # metamorphic: the same scenario with TEXT camera ids (points, cameras.csv, truth.csv)
        # scores the same, line for line, its names put back
        d = os.path.join(w, "sim")
        trajdb.simulate(con, d, cameras=3, minutes=1, seed=4)
        names = {0: "cam-a", 1: "cam-b", 2: "cam-c"}
        t = os.path.join(w, "text")
        os.makedirs(t)
        case = "CASE camera WHEN 0 THEN 'cam-a' WHEN 1 THEN 'cam-b' WHEN 2 THEN 'cam-c' END"
        for f, how in (("points.parquet", "(FORMAT parquet)"), ("cameras.csv", "(HEADER)"), ("truth.csv", "(HEADER)"), ("world.csv", "(HEADER)")):
            src = os.path.join(d, f)
            cols = con.execute("SELECT column_name FROM (DESCRIBE SELECT * FROM read_csv(?))" if f.endswith(".csv")
                               else "SELECT column_name FROM (DESCRIBE SELECT * FROM read_parquet(?))", [src]).fetchall()
            rel = f"SELECT * REPLACE ({case} AS camera) FROM " if ("camera",) in cols else "SELECT * FROM "
            con.execute("SET VARIABLE score_test_dst = ?", [os.path.join(t, f)])
            con.execute(f"COPY ({rel}{'read_csv' if f.endswith('.csv') else 'read_parquet'}(?)) TO (getvariable('score_test_dst')) {how}", [src])
        lines = {}
        for scen in (d, t):
            trajdb.pipeline(con, os.path.join(scen, "points.parquet"), out=os.path.join(scen, "r"))
            summary = trajdb.score(con, scen, os.path.join(scen, "r"))
            text = [r[0] for r in con.execute("SELECT line FROM s_printout ORDER BY section, k").fetchall()]
            for k, v in names.items():
                text = [x.replace(f" {v} -> ", f" {k} -> ").replace(f" -> {v}: ", f" -> {k}: ").replace(f"camera {v}'s", f"camera {k}'s")
                        for x in text]
            lines[scen] = (summary, text)
        assert lines[d][0] == lines[t][0], (lines[d][0], lines[t][0])
        assert lines[d][1] == lines[t][1], "\n".join(a + "  |  " + b for a, b in zip(*[x[1] for x in lines.values()]) if a != b)
        print(f"ok   text camera ids score as integer ids, line for line ({len(lines[d][1])} lines; match F1 {lines[d][0]['match_f1']:.3f})")
    print("test_score_python: OK")


if __name__ == "__main__":
    main()
