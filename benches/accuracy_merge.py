#!/usr/bin/env python3
"""Accuracy of the multi-camera merge (sql/stages/align.sql -> sql/stages/overlap.sql -> sql/stages/merge.sql) on the
real-trajectory scenarios, against truth.csv (read only here, never by the pipeline). The pipeline
is the extension's manifest up to the merge stage (load, calibrate, clean, quality, align, overlap,
merge; benches/stages.py); the time printed is that of the stages align, overlap and merge.

A track pair (any two tracks, same or different camera) is positive when both tracks belong to
the same true object. The tracks are merge_tracks', the quality stage's linked tracks (a chain of
broken pieces is one track, under the id of one of its pieces). Scored:
  thesis     the thesis's output: the one-to-one Hungarian links per camera pair (eta >= eta_bar),
             nothing else (split pieces in one camera are never joined);
  trajdb     the road users of sql/stages/merge.sql: all track pairs in one merge group (Hungarian links
             + split-piece links, with the same-camera/same-time consistency rule).
Precision, recall and F1 over track pairs; also the number of groups that hold two
time-overlapping tracks of one camera (must be 0).

usage: python benches/accuracy_merge.py --ext trajdb.duckdb_extension [--scenario DIR ...]
"""
import argparse
import itertools
import os

import duckdb

from stages import run_stages

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "shared", "data")


def prf(pred, truth):
    tp = len(pred & truth)
    p = tp / len(pred) if pred else 0.0
    r = tp / len(truth) if truth else 0.0
    return p, r, (2 * p * r / (p + r) if p + r else 0.0), len(pred)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ext", required=True)
    ap.add_argument("--scenario", action="append")
    a = ap.parse_args()
    scenarios = a.scenario or [os.path.join(DATA, "dut_intersection_3cam"), os.path.join(DATA, "dut_roundabout_2cam")]
    print(f"duckdb {duckdb.__version__}")
    for sc in scenarios:
        con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
        con.execute(f"LOAD '{os.path.abspath(a.ext)}'")
        secs = run_stages(con, os.path.join(sc, "points.parquet"), "merge")
        el = sum(secs[s] for s in ("align", "overlap", "merge"))
        obj = {u: o for u, o, noise in con.execute(
            f"""SELECT m.uid, t.object_id, t.is_noise FROM read_csv('{os.path.abspath(os.path.join(sc, 'truth.csv'))}') t
                JOIN merge_tracks m USING (camera, track_id)""").fetchall() if not noise}
        uids = [r[0] for r in con.execute("SELECT uid FROM merge_tracks").fetchall()]
        by_obj = {}
        for u in uids:
            if u in obj:
                by_obj.setdefault(obj[u], []).append(u)
        truth = {tuple(sorted(p)) for us in by_obj.values() for p in itertools.combinations(us, 2)}
        links = {tuple(sorted((x, y))) for x, y in con.execute("SELECT uid_a, uid_b FROM merge_links WHERE kind = 'hungarian'").fetchall()}
        groups = {}
        for u, g in con.execute("SELECT uid, road_user FROM merge_groups").fetchall():
            groups.setdefault(g, []).append(u)
        grouped = {tuple(sorted(p)) for us in groups.values() for p in itertools.combinations(us, 2)}
        bad = con.execute("""SELECT count(DISTINCT g.road_user) FROM merge_groups g JOIN merge_tracks a USING (uid)
                             JOIN merge_groups h ON h.road_user = g.road_user JOIN merge_tracks b ON b.uid = h.uid
                             WHERE a.uid < b.uid AND a.camera = b.camera AND a.t0 <= b.t1 AND b.t0 <= a.t1""").fetchall()[0][0]
        n_users = con.execute("SELECT count(*) FROM merge_users").fetchall()[0][0]
        print(f"\n== {os.path.basename(sc)}: {len(uids)} tracks, {len(by_obj)} objects, {len(truth)} true same-object pairs; "
              f"align+overlap+merge {el:.2f} s; {n_users} road users; inconsistent groups: {bad}")
        print(f"{'method':10s} {'precision':>9s} {'recall':>7s} {'F1':>6s} {'pairs':>7s}")
        for name, pred in [("thesis", links), ("trajdb", grouped)]:
            p, r, f, n = prf(pred, truth)
            print(f"{name:10s} {p:9.3f} {r:7.3f} {f:6.3f} {n:7d}")


if __name__ == "__main__":
    main()
