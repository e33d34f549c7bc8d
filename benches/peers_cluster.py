#!/usr/bin/env python3
"""Agglomerative clustering against scipy and fastcluster, in one process on the same data, and the pins.

  default  for n = 5,000 and 20,000 items (--n to choose): random 2-D points, their condensed
           Euclidean distances (scipy's pdist), and per method (single, complete, average, weighted, ward)
             trajdb pairs      agglomerative_dendrogram(list of n(n-1)/2 {a, b, distance} structs) through SQL
             trajdb condensed  agglomerative_dendrogram_condensed(the condensed DOUBLE[]) through SQL
             scipy             scipy.cluster.hierarchy.linkage(condensed, method)
             fastcluster       fastcluster.linkage(condensed, method)
           best of --reps runs each (default 3 at n <= 5,000, else 1), the ratios peer / trajdb (> 1: trajdb
           faster), and checks that every tool's merge heights agree and that trajdb's merges are scipy's.
           The times through SQL include DuckDB reading the list from a table and returning the result.
  --pin    writes crates/algo/src/cluster/testdata/cluster_scipy.json: random condensed matrices (no ties) with
           scipy.cluster.hierarchy.linkage for the five methods, and fcluster at a threshold ('distance') and at
           k clusters ('maxclust'); and cluster_scipy_ties.json: small integer distances (many ties, scipy's
           order among them is part of the result).

usage: python benches/peers_cluster.py --ext trajdb.duckdb_extension [--n 5000 --n 20000] [--reps 3] [--pin]
"""
import argparse
import gc
import json
import os
import time

import numpy as np
import scipy
from scipy.cluster.hierarchy import fcluster, linkage
from scipy.spatial.distance import pdist

HERE = os.path.dirname(os.path.abspath(__file__))
TESTDATA = os.path.join(HERE, "..", "crates", "algo", "src", "cluster", "testdata")
METHODS = ["single", "complete", "average", "weighted", "ward"]


def pin():
    rng = np.random.default_rng(20261122)
    cases = []
    for c in range(20):
        n = int(rng.integers(3, 30))
        method = METHODS[c % 5]
        pts = rng.random((n, 2)) * 100  # Euclidean distances, so that ward is meaningful
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
    out = os.path.join(TESTDATA, "cluster_scipy.json")
    if os.path.exists(out) and not os.environ.get("REPIN"):
        print(f"kept {out} (REPIN=1 rewrites it)")
    else:
        with open(out, "w") as f:
            json.dump({"scipy": scipy.__version__, "numpy": np.__version__, "seed": 20261122, "cases": cases}, f)
        print(f"wrote {len(cases)} cases to {out} (scipy {scipy.__version__})")
    # ties: distances 0..4 (and 0..1), so that most merges happen among equal heights
    rng = np.random.default_rng(20261123)
    cases = []
    for c in range(60):
        n = int(rng.integers(2, 40))
        method = METHODS[c % 5]
        cond = rng.integers(0, 2 if c % 3 == 0 else 5, n * (n - 1) // 2).astype(float)
        z = linkage(cond, method=method)
        # heights as decimal strings: Rust's str::parse is correctly rounded, serde_json's number parser is not
        cases.append({"method": method, "condensed": cond.tolist(), "merges": z[:, [0, 1, 3]].astype(int).tolist(), "heights": [repr(float(h)) for h in z[:, 2]]})
    out = os.path.join(TESTDATA, "cluster_scipy_ties.json")
    with open(out, "w") as f:
        json.dump({"scipy": scipy.__version__, "numpy": np.__version__, "seed": 20261123, "cases": cases}, f)
    print(f"wrote {len(cases)} cases to {out} (scipy {scipy.__version__})")


def best(f, reps):
    t, out = float("inf"), None
    for _ in range(reps):
        gc.collect()
        t0 = time.perf_counter()
        out = f()
        t = min(t, time.perf_counter() - t0)
    return t, out


def bench(ext, n, reps, pairs_max):
    import duckdb
    import fastcluster
    import pyarrow as pa
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{os.path.abspath(ext)}'")
    threads = con.execute("SELECT current_setting('threads')").fetchall()[0][0]
    print(f"\nn = {n} ({n * (n - 1) // 2:,} pairs), best of {reps}; duckdb {duckdb.__version__} ({threads} threads), "
          f"scipy {scipy.__version__}, fastcluster {fastcluster.__version__}, numpy {np.__version__}, {os.cpu_count()} cores")
    rng = np.random.default_rng(5)
    cond = pdist(rng.random((n, 2)) * 1000)
    # the condensed list as one DOUBLE[] row, and the pairs as one list of structs (arrow, no list() aggregate)
    con.register("c", pa.table({"c": pa.ListArray.from_arrays(pa.array([0, len(cond)], pa.int32()), pa.array(cond))}))
    con.execute("CREATE TABLE condensed AS SELECT c FROM c")
    con.unregister("c")
    with_pairs = n <= pairs_max
    if with_pairs:
        iu = np.triu_indices(n, 1)
        rows = pa.StructArray.from_arrays([pa.array(iu[0].astype(np.int64, copy=False)), pa.array(iu[1].astype(np.int64, copy=False)), pa.array(cond)], names=["a", "b", "distance"])
        del iu
        con.register("p", pa.table({"l": pa.LargeListArray.from_arrays(pa.array([0, len(cond)], pa.int64()), rows)}))
        con.execute("CREATE TABLE pairs AS SELECT l::STRUCT(a BIGINT, b BIGINT, distance DOUBLE)[] AS l FROM p")
        con.unregister("p")
        del rows
        gc.collect()
    else:
        print(f"(the pair list is not built above n = {pairs_max:,}: {n * (n - 1) // 2 * 24 / 2**30:.1f} GiB of structs in the table "
              "and again in the vector DuckDB passes; the condensed DOUBLE[] form is timed)")
    head = f"{'method':9s} {'pairs s':>8s} {'cond. s':>8s} {'scipy s':>8s} {'fastc. s':>8s} {'scipy/pairs':>11s} {'fastc./pairs':>12s} {'scipy/cond.':>11s} {'fastc./cond.':>12s}  same merges as scipy"
    print(head)
    for m in METHODS:
        tp = tc = float("nan")
        zp = None
        if with_pairs:
            tp, zp = best(lambda: con.execute(f"SELECT [[x.left, x.right, x.distance, x.size] FOR x IN agglomerative_dendrogram(l, '{m}')] FROM pairs").fetchall()[0][0], reps)
        tc, zc = best(lambda: con.execute(f"SELECT [[x.left, x.right, x.distance, x.size] FOR x IN agglomerative_dendrogram_condensed(c, '{m}')] FROM condensed").fetchall()[0][0], reps)
        ts, z = best(lambda: linkage(cond, method=m), reps)
        tf, zf = best(lambda: fastcluster.linkage(cond, method=m), reps)
        zc = np.asarray(zc)
        assert np.allclose(zc[:, 2], z[:, 2], rtol=1e-9, atol=1e-9), f"{m}: heights differ from scipy"
        assert np.allclose(zf[:, 2], z[:, 2], rtol=1e-9, atol=1e-9), f"{m}: fastcluster's heights differ from scipy"
        same = bool(np.array_equal(zc[:, [0, 1, 3]], z[:, [0, 1, 3]]))
        if zp is not None:
            assert np.array_equal(np.asarray(zp), zc), f"{m}: pairs and condensed differ"
        r = lambda a, b: f"{a / b:.2f}x" if b == b else "-"
        print(f"{m:9s} {tp:8.3f} {tc:8.3f} {ts:8.3f} {tf:8.3f} {r(ts, tp):>11s} {r(tf, tp):>12s} {r(ts, tc):>11s} {r(tf, tc):>12s}  {'yes' if same else 'NO'}")
    con.close()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ext")
    ap.add_argument("--pin", action="store_true")
    ap.add_argument("--n", type=int, action="append", help="items (repeatable; default 5000 and 20000)")
    ap.add_argument("--reps", type=int, help="runs per tool, best taken (default 3 at n <= 5000, else 1)")
    ap.add_argument("--pairs-max", type=int, default=20_000, help="largest n timed with the pair list (default 20000)")
    a = ap.parse_args()
    if a.pin:
        pin()
        return
    for n in a.n or [5000, 20000]:
        bench(a.ext, n, a.reps or (3 if n <= 5000 else 1), a.pairs_max)


if __name__ == "__main__":
    main()
