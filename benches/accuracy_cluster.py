#!/usr/bin/env python3
"""Prototype against exact clustering (issue 28, docs/clustering.md): on one camera's tracks per
class, resampled as sql/stages/cluster.sql does, traj_cluster_prototypes and traj_cluster with the
stage's defaults; prints per class the tracks, prototypes, clusters, seconds of each, the adjusted
Rand index (ARI) between the two partitions (isolated tracks as singletons), and with --truth a
scenario folder (truth.csv + objects.csv of `trajdb simulate`) the ARI of each against the true
routes (`objects.csv` source). Timing only: nothing here is a test.

usage: python benches/accuracy_cluster.py POINTS.parquet --camera 1 [--truth DIR] [--radius 0.25] [--no-exact]
       (TRAJDB_EXTENSION: default ./trajdb.duckdb_extension)
"""
import argparse
import os
import time

import duckdb
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def ari(a, b):
    a = np.unique(a, return_inverse=True)[1]
    b = np.unique(b, return_inverse=True)[1]
    m = np.zeros((a.max() + 1, b.max() + 1))
    np.add.at(m, (a, b), 1)
    c2 = lambda x: (x * (x - 1) / 2).sum()  # noqa: E731
    s, sa, sb, n = c2(m), c2(m.sum(1)), c2(m.sum(0)), c2(np.array([len(a)]))
    e = sa * sb / n
    return (s - e) / ((sa + sb) / 2 - e) if (sa + sb) / 2 != e else 1.0


def singletons(x):
    """Cluster 0 (isolated) as one singleton each."""
    y = np.asarray(x).astype(np.int64).copy()
    z = np.where(y == 0)[0]
    y[z] = -1 - z
    return y


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("points")
    ap.add_argument("--camera", type=int, required=True)
    ap.add_argument("--truth")
    ap.add_argument("--radius", type=float, default=0.25)
    ap.add_argument("--no-exact", action="store_true")
    a = ap.parse_args()
    ext = os.environ.get("TRAJDB_EXTENSION", os.path.join(ROOT, "trajdb.duckdb_extension"))
    c = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    c.execute("LOAD ?".replace("?", "'" + ext.replace("'", "''") + "'"))
    c.execute("""CREATE TABLE ct AS SELECT * FROM (
                   SELECT track_id, class, traj_resample(list({'t': t, 'x': x, 'y': y} ORDER BY t), 0.5, 1.0) AS traj
                   FROM read_parquet(?) WHERE camera = ? AND estimated = 0 GROUP BY ALL) WHERE len(traj) >= 6""", [a.points, a.camera])
    print(f"duckdb {duckdb.__version__}; {a.points}, camera {a.camera}; radius {a.radius}")
    for (cls,) in c.execute("SELECT DISTINCT class FROM ct ORDER BY 1").fetchall():
        n = c.execute("SELECT count(*) FROM ct WHERE class = ?", [cls]).fetchall()[0][0]
        t0 = time.perf_counter()
        pr = c.execute("""SELECT traj_cluster_prototypes(list(track_id ORDER BY track_id), list(traj ORDER BY track_id), 'average', 0.5, ?, 5, 2.0, 0.5)
                          FROM ct WHERE class = ?""", [a.radius, cls]).fetchall()[0][0]
        tp = time.perf_counter() - t0
        cp = np.array([r["cluster"] for r in pr])
        line = (f"{cls:14s} tracks {n:6d} prototypes {len({r['prototype'] for r in pr}):5d}  prototypes: {tp:6.2f} s, "
                f"{len(set(cp) - {0}):4d} clusters")
        ce = None
        if not a.no_exact:
            t0 = time.perf_counter()
            ex = c.execute("""SELECT traj_cluster(list(track_id ORDER BY track_id), list(traj ORDER BY track_id), 'average', 0.5, 5, 2.0, 0.5)
                              FROM ct WHERE class = ?""", [cls]).fetchall()[0][0]
            te = time.perf_counter() - t0
            ce = np.array([r["cluster"] for r in ex])
            line += f" | exact: {te:6.2f} s, {len(set(ce) - {0}):4d} clusters | ARI {ari(singletons(cp), singletons(ce)):.3f}"
        if a.truth:
            tr = dict(c.execute("""SELECT t.track_id, o.source FROM read_csv(?) t JOIN read_csv(?) o USING (object_id)
                                   WHERE t.camera = ? AND o.class = ?""",
                                [os.path.join(a.truth, "truth.csv"), os.path.join(a.truth, "objects.csv"), a.camera, cls]).fetchall())
            tl = np.array([hash(tr.get(r["id"], f"noise{r['id']}")) for r in pr])
            line += f" | vs {len(set(tl))} true routes: ARI prototypes {ari(singletons(cp), tl):.3f}"
            if ce is not None:
                line += f", exact {ari(singletons(ce), tl):.3f}"
        print(line, flush=True)


if __name__ == "__main__":
    main()
