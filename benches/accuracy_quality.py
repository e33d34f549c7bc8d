#!/usr/bin/env python3
"""Track quality (sql/stages/quality.sql) on the real-trajectory scenarios, against truth.csv (read only
here, never by the pipeline).

  * broken-track links: precision = share of 'broken' events whose two tracks are the same
    object; recall = share of true breaks (consecutive tracks of one object in one camera) found;
  * effect on the whole pipeline: pair precision / recall / F1 of sql/stages/merge.sql's road users
    over the original tracks, without and with linking (points vs points_linked).

usage: python benches/accuracy_quality.py --ext trajdb.duckdb_extension [--scenario DIR ...]
"""
import argparse
import itertools
import os

import duckdb

HERE = os.path.dirname(os.path.abspath(__file__))


def stage_sql(name):
    """sql/stages/NAME.sql after the parameter defaults of sql/params.sql (the stages read them)."""
    read = lambda *p: open(os.path.join(HERE, "..", "sql", *p)).read()
    return read("params.sql") + "\n" + read("stages", name)
DATA = os.path.join(HERE, "..", "..", "shared", "data")
SQL = {f: stage_sql(f) for f in ["quality.sql", "align.sql", "overlap.sql", "merge.sql"]}


def pipeline_f1(con, table, obj, linked):
    """Pair P/R/F1 over original tracks; `linked` maps (camera, track) -> id used in `table`."""
    con.execute(f"CREATE OR REPLACE TEMP TABLE points AS SELECT * FROM {table}")
    for f in ["align.sql", "overlap.sql", "merge.sql"]:
        con.execute(SQL[f])
    group = {}
    for cam, trk, g in con.execute("SELECT camera, track_id, road_user FROM merge_tracks JOIN merge_groups USING (uid)").fetchall():
        group[(cam, trk)] = g
    orig = [k for k in linked if k in obj]
    pred, truth = set(), set()
    by_obj, by_grp = {}, {}
    for k in orig:
        by_obj.setdefault(obj[k], []).append(k)
        g = group.get(linked[k])
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
        con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
        con.execute(f"LOAD '{os.path.abspath(a.ext)}'")
        con.execute(f"CREATE TABLE raw AS SELECT * FROM read_parquet('{os.path.abspath(os.path.join(sc, 'points.parquet'))}')")
        con.execute("CREATE OR REPLACE TEMP TABLE points AS SELECT * FROM raw")
        con.execute(SQL["quality.sql"])
        con.execute("CREATE TABLE linked AS SELECT * FROM points_linked")
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
        ident = {k: k[1] for k in obj}
        link = {(c, t): l for c, t, l in con.execute("SELECT camera, track_id, linked_id FROM quality_links").fetchall()}
        for name, table, mapping in [("without linking", "raw", ident), ("with linking", "linked", {k: (k[0], link.get(k, k[1])) for k in obj})]:
            if name == "without linking":
                mapping = {k: k for k in obj}
            p, r, f = pipeline_f1(con, table, obj, mapping)
            print(f"  pipeline pair P/R/F1 {name:16s} {p:.3f} / {r:.3f} / {f:.3f}")


if __name__ == "__main__":
    main()
