#!/usr/bin/env python3
"""Agglomerative clustering against scipy, in one process on the same data, and the pins.

  --pin    writes src/algo/cluster/testdata/cluster_scipy.json: random condensed matrices (no ties) with
           scipy.cluster.hierarchy.linkage for single/complete/average/weighted/ward, and
           fcluster at a threshold ('distance') and at k clusters ('maxclust').
  default  n = 5,000 items (12.5 million pairs): scipy.cluster.hierarchy.linkage on the condensed
           matrix vs trajdb's agglomerative_dendrogram (SQL, from the pair list) for each method,
           and checks that the merge heights agree.

usage: python benches/peers_cluster.py --ext trajdb.duckdb_extension [--pin] [--n 5000]
"""
import argparse
import json
import os
import time

import numpy as np
import scipy
from scipy.cluster.hierarchy import fcluster, linkage

HERE = os.path.dirname(os.path.abspath(__file__))
METHODS = ["single", "complete", "average", "weighted", "ward"]


def pin():
    rng = np.random.default_rng(20261122)
    cases = []
    for c in range(20):
        n = int(rng.integers(3, 30))
        method = METHODS[c % 5]
        pts = rng.random((n, 2)) * 100  # Euclidean distances, so that ward is meaningful
        from scipy.spatial.distance import pdist
        cond = pdist(pts)
        z = linkage(cond, method=method)
        # a threshold between two merge heights (not on one: float noise would decide it)
        mid = (n - 1) // 2
        t = float((z[mid - 1, 2] + z[mid, 2]) / 2) if n > 2 else float(z[0, 2] + 1)
        k = int(rng.integers(1, n + 1))
        ids = sorted(int(x) for x in rng.choice(100_000, n, replace=False) - 50_000)
        cases.append({
            "method": method, "ids": ids, "condensed": cond.tolist(), "linkage": z.tolist(),
            "t": t, "fcluster": fcluster(z, t, "distance").tolist(), "k": k, "maxclust": fcluster(z, k, "maxclust").tolist(),
        })
    out = os.path.join(HERE, "..", "src", "algo", "cluster", "testdata", "cluster_scipy.json")
    with open(out, "w") as f:
        json.dump({"scipy": scipy.__version__, "numpy": np.__version__, "seed": 20261122, "cases": cases}, f)
    print(f"wrote {len(cases)} cases to {out} (scipy {scipy.__version__})")


def bench(ext, n):
    import duckdb
    import pyarrow as pa
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{os.path.abspath(ext)}'")
    threads = con.execute("SELECT current_setting('threads')").fetchall()[0][0]
    print(f"duckdb {duckdb.__version__} ({threads} threads), scipy {scipy.__version__}, numpy {np.__version__}; n = {n}")
    rng = np.random.default_rng(5)
    pts = rng.random((n, 2)) * 1000
    from scipy.spatial.distance import pdist
    cond = pdist(pts)
    iu = np.triu_indices(n, 1)
    con.register("p", pa.table({"a": iu[0].astype(np.int64), "b": iu[1].astype(np.int64), "d": cond}))
    con.execute("CREATE TABLE pairs AS SELECT list({'a': a, 'b': b, 'distance': d}) AS l FROM p")
    print(f"{'method':10s} {'trajdb s':>9s} {'scipy s':>9s} {'scipy/trajdb':>13s}")
    con.execute("SELECT sum(len(l)), sum(list_sum([x.distance FOR x IN l[1:10]])) FROM pairs").fetchall()  # warm the column
    for m in METHODS:
        tt = ts = float("inf")
        for _ in range(3):  # best of 3 for both
            t0 = time.perf_counter()
            zt = con.execute(f"SELECT [x.distance FOR x IN agglomerative_dendrogram(l, '{m}')] FROM pairs").fetchall()[0][0]
            tt = min(tt, time.perf_counter() - t0)
            t0 = time.perf_counter()
            z = linkage(cond, method=m)
            ts = min(ts, time.perf_counter() - t0)
        assert np.allclose(np.asarray(zt), z[:, 2], rtol=1e-9, atol=1e-9), m
        print(f"{m:10s} {tt:9.3f} {ts:9.3f} {ts / tt:12.2f}x")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ext")
    ap.add_argument("--pin", action="store_true")
    ap.add_argument("--n", type=int, default=5000)
    a = ap.parse_args()
    if a.pin:
        pin()
    else:
        bench(a.ext, a.n)


if __name__ == "__main__":
    main()
