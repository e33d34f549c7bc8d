#!/usr/bin/env python3
"""Peer comparison for the LCSS family, on 10,000 real trajectory pairs from the DUT scenario.

Times, in one run on the same data:
  * tslearn.metrics.lcss (numba) vs trajdb lcss_index_similarity (index band |i-j| <= delta,
    2-D match), through SQL (stock DuckDB + the loadable extension) and called directly from
    Rust (examples/lcss_pairs.rs). Both sides get equal-length pairs (each pair cut to the
    shorter length), where tslearn's Sakoe-Chiba band and Buzan's band are the same set; the
    results must be identical.
  * a plain-Python transcription of the thesis's Alg. 1 (time-window LCSS, full N x M table)
    vs trajdb lcss_length (banded). Alg. 1 runs on a subset (it is slow) and the per-pair time
    is compared; results must be identical on that subset.

The peers run on subsets (tslearn: --peer-pairs, Alg. 1: --alg1-pairs), trajdb on all --pairs
(default 100,000): one SQL query over 10,000 pairs takes about 4 ms, of which DuckDB's fixed cost
per query (about 0.4 ms: parse, plan, first chunk) is a tenth, so the per-pair figure is read from
a query long enough to amortise it (`--pairs 10000` gives the small-query figure).

usage: python3 benches/peers_lcss.py --ext trajdb.duckdb_extension --example PATH/TO/lcss_pairs
       [--data ../shared/data/dut_intersection_3cam] [--pairs 100000] [--peer-pairs 10000] [--alg1-pairs 300]
"""
import argparse
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
import time

import duckdb
import numpy as np

DELTA, EPS_INDEX = 5, 2.0  # 0.5 s at 10 Hz, 2 m
EPS, T = 1.0, 0.5  # time-window form


def best_of(fn, reps=3):
    best, out = math.inf, None
    for _ in range(reps):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def alg1(A, B, eps, T, xi=0):
    """Thesis Alg. 1, transcribed: full (N+1) x (M+1) table; A, B are lists of (x, y, t).

    (Line 10's index typo is fixed: the time difference uses the same points as the distance.)"""
    N, M = len(A), len(B)
    D = [[0] * (M + 1) for _ in range(N + 1)]
    if N < xi or M < xi:
        return D
    for i in range(1, N + 1):
        for j in range(1, M + 1):
            x = math.hypot(A[i - 1][0] - B[j - 1][0], A[i - 1][1] - B[j - 1][1])
            dt = abs(A[i - 1][2] - B[j - 1][2])
            if x < eps and dt < T:
                D[i][j] = D[i - 1][j - 1] + 1
            else:
                D[i][j] = max(D[i - 1][j], D[i][j - 1])
    return D


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ext", required=True)
    ap.add_argument("--example", required=True, help="built examples/lcss_pairs binary")
    ap.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "dut_intersection_3cam"))
    ap.add_argument("--pairs", type=int, default=100000)
    ap.add_argument("--peer-pairs", type=int, default=10000, help="pairs tslearn scores (the first of --pairs)")
    ap.add_argument("--alg1-pairs", type=int, default=300)
    a = ap.parse_args()

    import tslearn
    from tslearn.metrics import lcss as ts_lcss

    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{os.path.abspath(a.ext)}'")
    pq = os.path.abspath(os.path.join(a.data, "points.parquet"))
    con.execute(f"""
        CREATE TABLE tracks AS
        SELECT camera, track_id, list({{'t': t, 'x': x, 'y': y}} ORDER BY t) AS traj, min(t) AS t0, max(t) AS t1
        FROM read_parquet('{pq}') GROUP BY camera, track_id""")
    # Time-overlapping pairs (same camera or across cameras), a deterministic pseudo-random sample.
    con.execute(f"""
        CREATE TABLE pairs AS
        SELECT a.traj AS a, b.traj AS b,
               a.traj[1:least(len(a.traj), len(b.traj))] AS ea,
               b.traj[1:least(len(a.traj), len(b.traj))] AS eb
        FROM tracks a JOIN tracks b
          ON (a.camera, a.track_id) < (b.camera, b.track_id) AND a.t0 <= b.t1 AND b.t0 <= a.t1
        ORDER BY hash(a.camera, a.track_id, b.camera, b.track_id)
        LIMIT {a.pairs}""")
    n = con.execute("SELECT count(*) FROM pairs").fetchone()[0]
    lens = con.execute("SELECT avg(len(a) + len(b)) / 2, avg(len(ea)) FROM pairs").fetchone()
    print(f"data: {pq}\npairs: {n}, mean points per trajectory {lens[0]:.1f}, mean equal-length cut {lens[1]:.1f}")
    print(f"versions: python {sys.version.split()[0]}, duckdb {duckdb.__version__}, numpy {np.__version__}, tslearn {tslearn.__version__}")

    # --- numpy inputs for the Python peers (conversion not timed)
    rows = con.execute("SELECT [[p.x, p.y] FOR p IN ea], [[p.x, p.y] FOR p IN eb] FROM pairs").fetchall()
    ea = [np.asarray(r[0], dtype=float) for r in rows]
    eb = [np.asarray(r[1], dtype=float) for r in rows]

    # --- binary inputs for the direct Rust call
    def write_pairs(path, cols):
        data = con.execute(f"SELECT [[p.t, p.x, p.y] FOR p IN {cols[0]}], [[p.t, p.x, p.y] FOR p IN {cols[1]}] FROM pairs").fetchall()
        with open(path, "wb") as f:
            f.write(struct.pack("<I", len(data)))
            for ta, tb in data:
                for tr in (ta, tb):
                    f.write(struct.pack("<I", len(tr)))
                    f.write(np.asarray(tr, dtype="<f8").tobytes())

    tmp = tempfile.mkdtemp()
    eq_bin, full_bin = os.path.join(tmp, "eq.bin"), os.path.join(tmp, "full.bin")
    write_pairs(eq_bin, ("ea", "eb"))
    write_pairs(full_bin, ("a", "b"))

    def rust(pairs_bin, *mode):
        out = os.path.join(tmp, "out.bin")
        r = subprocess.run([a.example, pairs_bin, out, *mode], check=True, capture_output=True, text=True)
        return json.loads(r.stdout), np.fromfile(out, dtype="<f8")

    # ================= index-band form: tslearn vs trajdb
    ts_lcss(ea[0], eb[0], eps=EPS_INDEX, global_constraint="sakoe_chiba", sakoe_chiba_radius=DELTA)  # JIT warm-up
    kp = min(a.peer_pairs, n)
    t_ts, ts_vals = best_of(lambda: np.array([
        ts_lcss(x, y, eps=EPS_INDEX, global_constraint="sakoe_chiba", sakoe_chiba_radius=DELTA) for x, y in zip(ea[:kp], eb[:kp])]), reps=2)
    q = f"SELECT lcss_index_similarity(ea, eb, {DELTA}, {EPS_INDEX}) FROM pairs"
    con.execute("SET threads = 1")
    t_sql1, sql_vals = best_of(lambda: con.execute(q).fetchnumpy())
    sql_vals = list(sql_vals.values())[0]
    con.execute("RESET threads")
    t_sqln, _ = best_of(lambda: con.execute(q).fetchnumpy())
    rj, rust_vals = rust(eq_bin, "index", str(DELTA), str(EPS_INDEX))
    mism_sql = int(np.sum(ts_vals != sql_vals[:kp]))
    mism_rust = int(np.sum(ts_vals != rust_vals[:kp]))
    nonzero = float(np.mean(sql_vals > 0))

    # ================= time-window form: plain-Python Alg. 1 vs trajdb
    k = min(a.alg1_pairs, n)
    sub = con.execute(f"SELECT [[p.x, p.y, p.t] FOR p IN a], [[p.x, p.y, p.t] FOR p IN b] FROM (SELECT * FROM pairs LIMIT {k})").fetchall()
    t0 = time.perf_counter()
    alg1_vals = np.array([alg1(x, y, EPS, T)[-1][-1] for x, y in sub], dtype=float)
    t_alg1 = time.perf_counter() - t0
    qt = f"SELECT lcss_length(a, b, {EPS}, {T})::DOUBLE FROM pairs"
    con.execute("SET threads = 1")
    t_tw_sql1, tw_vals = best_of(lambda: con.execute(qt).fetchnumpy())
    tw_vals = list(tw_vals.values())[0]
    con.execute("RESET threads")
    t_tw_sqln, _ = best_of(lambda: con.execute(qt).fetchnumpy())
    # Floor of the SQL path: DuckDB materialising both list columns and calling a trivial function.
    con.execute("SET threads = 1")
    t_floor, _ = best_of(lambda: con.execute("SELECT traj_length(a) + traj_length(b) FROM pairs").fetchnumpy())
    con.execute("RESET threads")
    rt, rust_tw = rust(full_bin, "time", str(EPS), str(T))
    mism_alg1 = int(np.sum(alg1_vals != tw_vals[:k]))
    mism_tw_rust = int(np.sum(rust_tw != tw_vals))

    per = lambda t, m: t / m * 1e6  # microseconds per pair
    print("\n== index-band LCSS (delta=%d points, eps=%.1f m), %d equal-length pairs, %.0f%% nonzero" % (DELTA, EPS_INDEX, n, 100 * nonzero))
    print(f"{'implementation':44s} {'us/pair':>10s} {'speed-up vs tslearn':>20s}")
    base = per(t_ts, kp)
    for name, us in [
        (f"tslearn.metrics.lcss (numba, 1 thread, {kp} pairs)", base),
        ("trajdb SQL lcss_index_similarity, 1 thread", per(t_sql1, n)),
        (f"trajdb SQL, DuckDB default threads", per(t_sqln, n)),
        ("trajdb Rust direct, 1 thread", per(rj["single_thread_s"], n)),
        (f"trajdb Rust direct, {rj['threads']} threads", per(rj["parallel_s"], n)),
    ]:
        print(f"{name:44s} {us:10.3f} {base / us:19.1f}x")
    print(f"results identical to tslearn on its {kp} pairs: SQL {kp - mism_sql}/{kp}, Rust {kp - mism_rust}/{kp}")

    print("\n== time-window LCSS (eps=%.1f m, T=%.1f s), full trajectories" % (EPS, T))
    base = per(t_alg1, k)
    print(f"{'implementation':44s} {'us/pair':>10s} {'speed-up vs Alg. 1':>20s}")
    for name, us in [
        (f"plain-Python thesis Alg. 1 ({k} pairs)", base),
        (f"trajdb SQL lcss_length, 1 thread ({n} pairs)", per(t_tw_sql1, n)),
        ("trajdb SQL, DuckDB default threads", per(t_tw_sqln, n)),
        ("(SQL floor: traj_length(a)+traj_length(b))", per(t_floor, n)),
        ("trajdb Rust direct, 1 thread", per(rt["single_thread_s"], n)),
        (f"trajdb Rust direct, {rt['threads']} threads", per(rt["parallel_s"], n)),
    ]:
        print(f"{name:44s} {us:10.3f} {base / us:19.1f}x")
    print(f"results identical to Alg. 1 on its {k} pairs: {k - mism_alg1}/{k}; Rust direct = SQL: {n - mism_tw_rust}/{n}")
    ok = mism_sql == 0 and mism_rust == 0 and mism_alg1 == 0 and mism_tw_rust == 0
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
