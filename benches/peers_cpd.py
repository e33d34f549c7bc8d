#!/usr/bin/env python3
"""Peer comparison for cpd_align: pycpd's RigidRegistration on the same 5,000 x 5,000 input
(same w, tolerance, iterations, scale enabled, single R = I start), and TimeCPD at
100,000 x 100,000 points. Input: real DUT trajectories (camera-local points), moving set =
the same points under a known similarity transform plus 5 cm noise, shuffled.

usage: python3 benches/peers_cpd.py --ext trajdb.duckdb_extension [--data ../shared/data/dut_intersection_3cam]
"""
import argparse
import math
import os
import sys
import time

import duckdb
import numpy as np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ext", required=True)
    ap.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "dut_intersection_3cam"))
    ap.add_argument("--n", type=int, default=5000)
    ap.add_argument("--big", type=int, default=100000)
    a = ap.parse_args()
    import pycpd
    from pycpd import RigidRegistration

    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{os.path.abspath(a.ext)}'")
    pq = os.path.abspath(os.path.join(a.data, "points.parquet"))
    pts = con.execute(f"SELECT t, x, y FROM read_parquet('{pq}') WHERE camera = 1 ORDER BY t, track_id").fetchnumpy()
    T, X, Y = pts["t"], pts["x"], pts["y"]
    rng = np.random.default_rng(7)
    theta, tx, ty, s = math.radians(30.0), 12.0, -5.0, 1.05
    print(f"data: {pq} (camera 1, {len(T)} points)\nversions: duckdb {duckdb.__version__}, numpy {np.__version__}, pycpd {pycpd.__version__ if hasattr(pycpd, '__version__') else '2.0.0'}")

    def make(n, s=s):
        idx = np.sort(rng.choice(len(T), size=n, replace=n > len(T)))
        # repeat the clip in time when more points than the camera has are asked for
        rep = np.arange(n) // len(T) if n > len(T) else np.zeros(n)
        t = T[idx] + rep * 400.0
        fx, fy = X[idx], Y[idx]
        # moving = inverse transform of fixed, plus noise, shuffled
        c, si = math.cos(-theta), math.sin(-theta)
        ux, uy = (fx - tx) / s, (fy - ty) / s
        mx = c * ux - si * uy + rng.normal(0, 0.05, n)
        my = si * ux + c * uy + rng.normal(0, 0.05, n)
        perm = rng.permutation(n)
        return (t, fx, fy), (t[perm], mx[perm], my[perm])

    def to_sql(name, cols):
        t, x, y = cols
        con.execute(f"CREATE OR REPLACE TABLE {name} AS SELECT * FROM (SELECT unnest($1) AS t, unnest($2) AS x, unnest($3) AS y)", [t.tolist(), x.tolist(), y.tolist()])
        con.execute(f"CREATE OR REPLACE TABLE {name}_l AS SELECT list({{'t': t, 'x': x, 'y': y}} ORDER BY t) AS p FROM {name}")

    # ---------- 5,000 x 5,000 against pycpd
    fixed, moving = make(a.n)
    w, tol, iters = 0.1, 1e-8, 100
    Xf = np.column_stack([fixed[1], fixed[2]])
    Ym = np.column_stack([moving[1], moving[2]])
    t0 = time.perf_counter()
    reg = RigidRegistration(X=Xf, Y=Ym, w=w, tolerance=tol, max_iterations=iters, scale=True)
    _, (s_p, R_p, t_p) = reg.register()
    t_pycpd = time.perf_counter() - t0
    th_p = math.atan2(R_p[0, 1], R_p[0, 0])  # pycpd: TY = s * Y @ R + t, i.e. R_col = R.T
    to_sql("f5", fixed)
    to_sql("m5", moving)
    q = f"SELECT cpd_align(f.p, m.p, {w}, 'inf', {iters}, {tol}, true, 1) FROM f5_l f, m5_l m"
    t0 = time.perf_counter()
    r = con.execute(q).fetchone()[0]
    t_ours = time.perf_counter() - t0
    d = {
        "theta": abs(r["theta"] - th_p),
        "tx": abs(r["tx"] - t_p[0]),
        "ty": abs(r["ty"] - t_p[1]),
        "scale": abs(r["scale"] - s_p),
    }
    if r["iterations"] != reg.iteration:
        print(f"warning: iterations differ (pycpd {reg.iteration}, trajdb {r['iterations']})")
    print(f"\n== rigid CPD with scale, {a.n} x {a.n} points, w={w}, tol={tol}, max_iter={iters}, start R = I")
    print(f"pycpd RigidRegistration: {t_pycpd:8.3f} s  iterations {reg.iteration}  theta {math.degrees(th_p):.6f} deg  t ({t_p[0]:.6f}, {t_p[1]:.6f})  s {s_p:.8f}")
    print(f"trajdb cpd_align (SQL):  {t_ours:8.3f} s  iterations {r['iterations']}  theta {math.degrees(r['theta']):.6f} deg  t ({r['tx']:.6f}, {r['ty']:.6f})  s {r['scale']:.8f}")
    print(f"max |difference| {max(d.values()):.2e} ({', '.join(f'{k} {v:.1e}' for k, v in d.items())}); speed-up {t_pycpd / t_ours:.1f}x")
    print(f"truth: theta 30 deg, t (12, -5), s 1.05")

    # ---------- TimeCPD 100k x 100k
    fixed, moving = make(a.big, s=1.0)
    to_sql("fb", fixed)
    to_sql("mb", moving)
    for tau, starts in [(0.1, 1), (0.1, 8)]:
        q = f"SELECT cpd_align(f.p, m.p, 0.1, {tau}, 100, 1e-5, false, {starts}) FROM fb_l f, mb_l m"
        t0 = time.perf_counter()
        r = con.execute(q).fetchone()[0]
        el = time.perf_counter() - t0
        print(f"\n== TimeCPD {a.big} x {a.big}, tau {tau} s, w 0.1, starts {starts}: {el:.2f} s, {r['iterations']} iterations, "
              f"{r['pairs_in_band'] / a.big:.0f} pairs per point in the time band ({r['pairs_in_band'] / a.big / a.big * 100:.3f}% of N*M)")
        print(f"   theta {math.degrees(r['theta']):.4f} deg (truth 30), t ({r['tx']:.3f}, {r['ty']:.3f}) (truth 12, -5), converged {r['converged']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
