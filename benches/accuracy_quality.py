#!/usr/bin/env python3
"""Track quality (sql/stages/quality.sql) on the real-trajectory scenarios, against truth.csv (read only
here, never by the pipeline).

  * broken-track links: precision = share of 'broken' events whose two tracks are the same
    object; recall = share of true breaks (consecutive tracks of one object in one camera) found;
  * effect on the whole pipeline: pair precision / recall / F1 of sql/stages/merge.sql's road users
    over the original tracks, without and with linking.

The pipeline is the extension's manifest up to the merge stage (load, calibrate, clean, quality,
align, overlap, merge; benches/stages.py), run twice per scenario: with the default parameters
(with linking), and with quality_max_gap = 0 (without linking: no end -> start pair is then
within the gap, so the quality stage links nothing; the links it still made are counted and
printed). Nothing is timed.

usage: python benches/accuracy_quality.py --ext trajdb.duckdb_extension [--scenario DIR ...]
"""
import argparse
import itertools
import os

import duckdb

from stages import run_stages

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "shared", "data")


def connect(ext):
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{os.path.abspath(ext)}'")
    return con


def pipeline_f1(con, obj):
    """Pair P/R/F1 over the original tracks (the keys (camera, track_id) of `obj`) of the road users
    of a run up to the merge stage on `con`: an original track is in its chain of the quality
    stage (quality_links: its linked_id, the id merge_tracks uses), the chain in a road user."""
    group = {}
    for cam, trk, g in con.execute("SELECT camera, track_id, road_user FROM merge_tracks JOIN merge_groups USING (uid)").fetchall():
        group[(cam, trk)] = g
    linked = {(c, t): (c, l) for c, t, l in con.execute("SELECT camera, track_id, linked_id FROM quality_links").fetchall()}
    pred, truth = set(), set()
    by_obj, by_grp = {}, {}
    for k in obj:
        by_obj.setdefault(obj[k], []).append(k)
        g = group.get(linked.get(k, k))
        if g is not None:
            by_grp.setdefault(g, []).append(k)
    for ks in by_obj.values():
        truth |= {tuple(sorted(p)) for p in itertools.combinations(ks, 2)}
    for ks in by_grp.values():
        pred |= {tuple(sorted(p)) for p in itertools.combinations(ks, 2)}
    tp = len(pred & truth)
    p = tp / len(pred) if pred else 0.0
    r = tp / len(truth) if truth else 0.0
    return p, r, 2 * p * r / (p + r) if p + r else 0.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ext", required=True)
    ap.add_argument("--scenario", action="append")
    a = ap.parse_args()
    scenarios = a.scenario or [os.path.join(DATA, "dut_intersection_3cam"), os.path.join(DATA, "dut_roundabout_2cam")]
    for sc in scenarios:
        pq = os.path.abspath(os.path.join(sc, "points.parquet"))
        con = connect(a.ext)
        run_stages(con, pq, "merge")
        con.execute(f"CREATE TABLE raw AS SELECT * FROM read_parquet('{pq}')")
        obj = {(c, t): o for c, t, o, noise in con.execute(
            f"SELECT camera, track_id, object_id, is_noise FROM read_csv('{os.path.abspath(os.path.join(sc, 'truth.csv'))}')").fetchall() if not noise}
        events = con.execute("SELECT camera, ev.from_id, ev.to_id FROM quality_events WHERE ev.kind = 'broken'").fetchall()
        ok = sum(1 for c, f, t in events if obj.get((c, f)) is not None and obj.get((c, f)) == obj.get((c, t)))
        # true breaks: consecutive real tracks of one object in one camera
        spans = con.execute("SELECT camera, track_id, min(t) FROM raw WHERE estimated = 0 GROUP BY ALL").fetchall()
        seq = {}
        for c, t, t0 in spans:
            if (c, t) in obj:
                seq.setdefault((c, obj[(c, t)]), []).append((t0, t))
        true_breaks = set()
        for (c, _), v in seq.items():
            v.sort()
            true_breaks |= {(c, v[i][1], v[i + 1][1]) for i in range(len(v) - 1)}
        found = {(c, f, t) for c, f, t in events}
        rec = len(found & true_breaks) / len(true_breaks) if true_breaks else 0.0
        print(f"\n== {os.path.basename(sc)}: {len(events)} broken links, precision {ok / len(events) if events else 0:.3f}, "
              f"recall {rec:.3f} of {len(true_breaks)} true breaks; "
              + ", ".join(f"{k} {n}" for k, n in con.execute("SELECT ev.kind, count(*) FROM quality_events GROUP BY 1 ORDER BY 1").fetchall()))
        with_linking = pipeline_f1(con, obj)
        con.close()
        con = connect(a.ext)
        run_stages(con, pq, "merge", quality_max_gap=0.0)
        left = con.execute("""SELECT (SELECT count(*) FROM quality_links WHERE track_id <> linked_id),
                                     (SELECT count(*) FROM quality_reach_links)""").fetchall()[0]
        without_linking = pipeline_f1(con, obj)
        con.close()
        for name, (p, r, f) in [("without linking", without_linking), ("with linking", with_linking)]:
            print(f"  pipeline pair P/R/F1 {name:16s} {p:.3f} / {r:.3f} / {f:.3f}")
        if any(left):
            print(f"  (without linking, quality_max_gap = 0 still linked {left[0]} tracks into chains, {left[1]} reach links)")

if __name__ == "__main__":
    main()
