#!/usr/bin/env python3
"""hungarian_match against scipy, in one process on the same data, and the pinned references.

  --pin    writes src/algo/matching/testdata/hungarian_scipy.json: random sparse rectangular instances
           (absent pairs forbidden) with scipy.optimize.linear_sum_assignment's count and total.
  default  times, on the same instances:
           * dense 2,000 x 2,000 (every pair a candidate): trajdb SQL hungarian_match vs
             scipy.optimize.linear_sum_assignment;
           * sparse 50,000 x 50,000 with 500,000 candidate pairs: trajdb vs
             scipy.sparse.csgraph.min_weight_full_bipartite_matching (LAPJVsp; it needs a full
             matching, so the instance contains a hidden perfect matching) - the dense scipy
             solver cannot hold a 50,000 x 50,000 matrix;
           and checks that the totals agree.

usage: python benches/peers_hungarian.py --ext trajdb.duckdb_extension [--pin]
"""
import argparse
import json
import os
import time

import duckdb
import numpy as np
import scipy
from scipy.optimize import linear_sum_assignment
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import min_weight_full_bipartite_matching

HERE = os.path.dirname(os.path.abspath(__file__))


def pin():
    rng = np.random.default_rng(20261121)
    cases = []
    while len(cases) < 24:
        nr, nc = int(rng.integers(2, 40)), int(rng.integers(2, 40))
        density = float(rng.uniform(0.15, 1.0))
        maximize = bool(rng.integers(0, 2))
        mask = rng.random((nr, nc)) < density
        if not mask.any():
            continue
        score = np.round(rng.uniform(-1, 5, (nr, nc)), 3)
        dense = np.where(mask, score, -np.inf if maximize else np.inf)
        try:
            r, c = linear_sum_assignment(dense, maximize=maximize)
        except ValueError:
            continue  # infeasible for scipy
        ids_a = rng.choice(10_000, nr, replace=False) - 5000
        ids_b = rng.choice(10_000, nc, replace=False)
        pairs = [[int(ids_a[i]), int(ids_b[j]), float(score[i, j])] for i in range(nr) for j in range(nc) if mask[i, j]]
        rng.shuffle(pairs)
        cases.append({"maximize": maximize, "pairs": pairs, "count": int(len(r)), "total": float(score[r, c].sum())})
    out = os.path.join(HERE, "..", "src", "algo", "matching", "testdata", "hungarian_scipy.json")
    os.makedirs(os.path.dirname(out), exist_ok=True)
    with open(out, "w") as f:
        json.dump({"scipy": scipy.__version__, "numpy": np.__version__, "seed": 20261121, "cases": cases}, f)
    print(f"wrote {len(cases)} cases to {out} (scipy {scipy.__version__})")


def best_of(f, reps=3):
    best, out = float("inf"), None
    for _ in range(reps):
        t0 = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t0)
    return best, out


def bench(ext):
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{os.path.abspath(ext)}'")
    threads = con.execute("SELECT current_setting('threads')").fetchall()[0][0]
    print(f"duckdb {duckdb.__version__} ({threads} threads), scipy {scipy.__version__}, numpy {np.__version__}")
    rng = np.random.default_rng(7)
    rows = []

    # dense 2000 x 2000
    n = 2000
    score = rng.random((n, n))
    a, b = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    import pyarrow as pa
    tbl = pa.table({"a": a.ravel(), "b": b.ravel(), "score": score.ravel()})
    con.register("dense_t", tbl)
    con.execute("CREATE TABLE dense AS SELECT list({'a': a, 'b': b, 'score': score}) AS p FROM dense_t")
    t_tr, tot_tr = best_of(lambda: con.execute("SELECT list_sum([m.score FOR m IN hungarian_match(p, true)]) FROM dense").fetchall()[0][0])
    t_sp, tot_sp = best_of(lambda: score[linear_sum_assignment(score, maximize=True)].sum())
    assert abs(tot_tr - tot_sp) < 1e-6 * tot_sp, (tot_tr, tot_sp)
    rows.append(("dense 2000 x 2000, maximize", t_tr, "linear_sum_assignment", t_sp))
    # The same input for both: scipy starting from the pair list (matrix built with numpy), and
    # the part of trajdb's time that is DuckDB reading the 4M-element list.
    pa_, pb_, ps_ = a.ravel(), b.ravel(), score.ravel()

    def scipy_from_pairs():
        m = np.full((n, n), -np.inf)
        m[pa_, pb_] = ps_
        r, c = linear_sum_assignment(m, maximize=True)
        return m[r, c].sum()

    t_sp2, _ = best_of(scipy_from_pairs)
    rows.append(("  same, scipy from the pair list", t_tr, "linear_sum_assignment", t_sp2))
    t_scan, _ = best_of(lambda: con.execute("SELECT list_sum([m.score FOR m IN p[1:1]]) , len(p) FROM dense").fetchall())
    print(f"(DuckDB reading the 4M-element list alone: {t_scan:.3f} s)")

    # sparse 50k x 50k, 500k pairs, a hidden perfect matching so that scipy's sparse solver accepts it
    n, e = 50_000, 500_000
    perm = rng.permutation(n)
    ra = np.concatenate([np.arange(n), rng.integers(0, n, e - n)])
    rb = np.concatenate([perm, rng.integers(0, n, e - n)])
    w = rng.uniform(1.0, 100.0, e)
    key = ra.astype(np.int64) * n + rb
    _, first = np.unique(key, return_index=True)
    ra, rb, w = ra[first], rb[first], w[first]
    tbl = pa.table({"a": ra, "b": rb, "score": w})
    con.register("sparse_t", tbl)
    con.execute("CREATE TABLE sparse AS SELECT list({'a': a, 'b': b, 'score': score}) AS p FROM sparse_t")
    t_tr, res = best_of(lambda: con.execute("SELECT len(m), list_sum([x.score FOR x IN m]) FROM (SELECT hungarian_match(p, false) AS m FROM sparse)").fetchall()[0])
    g = csr_matrix((w, (ra, rb)), shape=(n, n))
    t_sp, (r, c) = best_of(lambda: min_weight_full_bipartite_matching(g))
    tot_sp = np.asarray(g[r, c]).ravel().sum()
    assert res[0] == n and abs(res[1] - tot_sp) < 1e-6 * tot_sp, (res, tot_sp)
    rows.append((f"sparse 50000 x 50000, {len(w)} pairs, minimize", t_tr, "min_weight_full_bipartite_matching", t_sp))

    print(f"\n{'task':48s} {'trajdb s':>9s} {'scipy solver':>36s} {'scipy s':>9s} {'scipy/trajdb':>13s}")
    for name, tt, peer, ts in rows:
        print(f"{name:48s} {tt:9.3f} {peer:>36s} {ts:9.3f} {ts / tt:12.2f}x")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ext")
    ap.add_argument("--pin", action="store_true")
    a = ap.parse_args()
    if a.pin:
        pin()
    else:
        bench(a.ext)


if __name__ == "__main__":
    main()
