#!/usr/bin/env python3
"""hungarian_match against scipy and lap, in one process on the same data, and the pinned references.

  --pin    writes crates/algo/src/matching/testdata/hungarian_scipy.json: random sparse rectangular
           instances (absent pairs forbidden) with scipy.optimize.linear_sum_assignment's count and total.
  default  times, on the same instances, best of --reps runs each:
           * dense 1,000 x 1,000 and 2,000 x 2,000 (every pair a candidate, uniform scores, maximise):
             trajdb SQL hungarian_match over the pair list vs scipy.optimize.linear_sum_assignment and
             lap.lapjv (both handed the ready numpy matrix: their best case; lap minimises, so it gets
             the negated matrix, made outside the timing);
           * sparse 50,000 x 50,000 with 500,000 candidate pairs (minimise): trajdb vs
             scipy.sparse.csgraph.min_weight_full_bipartite_matching (LAPJVsp; it needs a full
             matching, so the instance contains a hidden perfect matching; the CSR matrix is built
             outside the timing) - the dense solvers cannot hold a 50,000 x 50,000 matrix;
           checks that the totals agree, and prints peer s / trajdb s (above 1: trajdb is faster).
  --before EXT  also times an older build (e.g. main's) on the same instances, in a child process
           (one process cannot load two builds of one extension), for the before/after columns.

trajdb's time is the whole SQL statement: DuckDB handing over the 4M-element list, the call, and
summing the result (`SELECT list_sum([m.score FOR m IN hungarian_match(p, true)]) FROM dense`).

usage: /work/venv-bench/bin/python benches/peers_hungarian.py --ext trajdb.duckdb_extension [--before OLD.duckdb_extension] [--pin]
"""
import argparse
import json
import os
import platform
import subprocess
import sys
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
    out = os.path.join(HERE, "..", "crates", "algo", "src", "matching", "testdata", "hungarian_scipy.json")
    os.makedirs(os.path.dirname(out), exist_ok=True)
    with open(out, "w") as f:
        json.dump({"scipy": scipy.__version__, "numpy": np.__version__, "seed": 20261121, "cases": cases}, f)
    print(f"wrote {len(cases)} cases to {out} (scipy {scipy.__version__})")


def best_of(f, reps):
    best, out = float("inf"), None
    for _ in range(reps):
        t0 = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t0)
    return best, out


def instances():
    """The benchmark instances (fixed seeds): name -> dict."""
    out = {}
    for n in (1000, 2000):
        rng = np.random.default_rng(7 + n)
        score = rng.random((n, n))
        a, b = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        out[f"dense {n} x {n}, maximize"] = {"kind": "dense", "n": n, "a": a.ravel(), "b": b.ravel(), "score": score}
    # sparse 50k x 50k, 500k pairs, a hidden perfect matching so that scipy's sparse solver accepts it
    rng = np.random.default_rng(7)
    n, e = 50_000, 500_000
    perm = rng.permutation(n)
    ra = np.concatenate([np.arange(n), rng.integers(0, n, e - n)])
    rb = np.concatenate([perm, rng.integers(0, n, e - n)])
    w = rng.uniform(1.0, 100.0, e)
    _, first = np.unique(ra.astype(np.int64) * n + rb, return_index=True)
    # in a shuffled order: the list is not pre-sorted for trajdb (scipy gets its CSR matrix)
    first = rng.permutation(first)
    out[f"sparse 50000 x 50000, {len(first)} pairs, minimize"] = {"kind": "sparse", "n": n, "a": ra[first], "b": rb[first], "score": w[first]}
    return out


def time_trajdb(ext, cases, reps):
    """trajdb's SQL time per instance: {name: (seconds, count, total)}."""
    import pyarrow as pa
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{os.path.abspath(ext)}'")
    res = {}
    for k, (name, c) in enumerate(cases.items()):
        tbl = pa.table({"a": c["a"], "b": c["b"], "score": c["score"].ravel()})
        con.register(f"t{k}", tbl)
        con.execute(f"CREATE TABLE p{k} AS SELECT list({{'a': a, 'b': b, 'score': score}}) AS p FROM t{k}")
        mx = "true" if c["kind"] == "dense" else "false"
        q = f"SELECT len(m), list_sum([x.score FOR x IN m]) FROM (SELECT hungarian_match(p, {mx}) AS m FROM p{k})"
        t, (cnt, tot) = best_of(lambda: con.execute(q).fetchall()[0], reps)
        t_read, _ = best_of(lambda: con.execute(f"SELECT len(p), p[len(p)].score FROM p{k}").fetchall(), reps)
        res[name] = (t, cnt, tot, t_read)
    return res


def time_peers(cases, reps):
    """[(instance, peer, seconds, count, total)]."""
    import lap
    rows = []
    for name, c in cases.items():
        if c["kind"] == "dense":
            score = c["score"]
            t, (r, cc) = best_of(lambda: linear_sum_assignment(score, maximize=True), reps)
            rows.append((name, f"scipy {scipy.__version__} linear_sum_assignment", t, len(r), float(score[r, cc].sum())))
            neg = -score
            t, (_, x, _) = best_of(lambda: lap.lapjv(neg), reps)
            rows.append((name, f"lap {lap.__version__} lapjv", t, len(x), float(score[np.arange(len(x)), x].sum())))
        else:
            n = c["n"]
            g = csr_matrix((c["score"], (c["a"], c["b"])), shape=(n, n))
            t, (r, cc) = best_of(lambda: min_weight_full_bipartite_matching(g), reps)
            rows.append((name, f"scipy {scipy.__version__} min_weight_full_bipartite_matching", t, len(r), float(np.asarray(g[r, cc]).ravel().sum())))
    return rows


def bench(ext, before, reps):
    import lap
    import pyarrow as pa
    con = duckdb.connect()
    threads = con.execute("SELECT current_setting('threads')").fetchall()[0][0]
    print(f"duckdb {duckdb.__version__} ({threads} threads), scipy {scipy.__version__}, lap {lap.__version__}, "
          f"numpy {np.__version__}, pyarrow {pa.__version__}, python {platform.python_version()}, {os.cpu_count()} cpus; best of {reps}")
    cases = instances()
    old = {}
    if before:
        child = subprocess.run([sys.executable, __file__, "--ext", before, "--trajdb-only", "--reps", str(reps)],
                               capture_output=True, text=True, check=True)
        old = {k: tuple(v) for k, v in json.loads(child.stdout.strip().splitlines()[-1]).items()}
    new = time_trajdb(ext, cases, reps)
    peers = time_peers(cases, reps)
    print(f"\n{'instance':44s} {'before s':>9s} {'trajdb s':>9s} {'peer':>52s} {'peer s':>8s} {'peer/trajdb':>12s}")
    for name, peer, tp, cnt, tot in peers:
        t, tcnt, ttot, t_read = new[name]
        assert tcnt == cnt and abs(ttot - tot) <= 1e-9 * abs(tot), (name, peer, tcnt, ttot, cnt, tot)
        b = f"{old[name][0]:9.3f}" if name in old else f"{'-':>9s}"
        if name in old:
            assert old[name][1] == cnt and abs(old[name][2] - tot) <= 1e-9 * abs(tot), (name, "before", old[name], tot)
        print(f"{name:44s} {b} {t:9.3f} {peer:>52s} {tp:8.3f} {tp / t:11.2f}x")
    print("\ntotals agree (count equal, total within 1e-9 relative) for every instance and solver")
    for name, (t, _, _, t_read) in new.items():
        print(f"  {name}: of trajdb's {t:.3f} s, DuckDB reading the list (SELECT len(p), p[len(p)].score) takes {t_read:.3f} s")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ext")
    ap.add_argument("--before", help="an older build of the extension, timed in a child process")
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--trajdb-only", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--pin", action="store_true")
    a = ap.parse_args()
    if a.pin:
        pin()
    elif a.trajdb_only:
        print(json.dumps(time_trajdb(a.ext, instances(), a.reps)))
    else:
        bench(a.ext, a.before, a.reps)


if __name__ == "__main__":
    main()
