#!/usr/bin/env python3
"""Accuracy of the camera-overlap polygons on the real-trajectory scenarios.

Runs the pipeline (the extension's manifest up to the overlap stage: load, calibrate, clean, quality,
align, overlap; benches/stages.py) on points.parquet, once per variant with the variant's overlap_*
parameters (only overlap.sql reads them), takes the pairwise
overlaps of the all-class view polygons (class '*') in the common frame, and compares them with
the true overlap of the cameras' `view_wkt_world` rectangles from cameras.csv, mapped into the
same frame with the true transform of the reference camera (p_local = R(-theta)(p - t), see the
scenario README). Ground truth is read only here, never by the pipeline.

Two references are reported per camera pair:
  rect      true overlap of the two view rectangles (what the issue asks for);
  rect∩site the same, clipped to the site (convex hull of all true world positions): the part of
            the overlap where any road user could be seen at all. The view rectangles extend past
            the roads, and no point-based method can see where nobody drives.
IoU (and the estimated area) for each variant: convex / concave hull, with and without the
density rule, and with the view polygons shrunk by 0, 1 or 2 x the camera's measured noise.
shapely computes the reference geometry and the IoU (an independent implementation).

usage: python3 benches/accuracy_overlap.py --ext trajdb.duckdb_extension [--scenario DIR ...]
"""
import argparse
import csv
import math
import os

import duckdb
import shapely
from shapely import wkb, wkt
from shapely.affinity import affine_transform

from stages import run_stages

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "shared", "data")

# name, then the pipeline parameters overlap_method ('convex' / 'concave'), overlap_concavity,
# overlap_radius_m (density radius), overlap_min_neighbours, overlap_shrink_sigmas (x measured noise sigma)
VARIANTS = [
    ("convex (default)", "convex", 2.0, 2.0, 3, 1.0),
    ("convex, no shrink", "convex", 2.0, 2.0, 3, 0.0),
    ("convex, shrink 2 sigma", "convex", 2.0, 2.0, 3, 2.0),
    ("convex, no density rule", "convex", 2.0, 1.0, 0, 1.0),
    ("concave 2", "concave", 2.0, 2.0, 3, 1.0),
    ("concave 5", "concave", 5.0, 2.0, 3, 1.0),
]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ext", required=True)
    ap.add_argument("--scenario", action="append")
    a = ap.parse_args()
    scenarios = a.scenario or [os.path.join(DATA, "dut_intersection_3cam"), os.path.join(DATA, "dut_roundabout_2cam")]
    print(f"duckdb {duckdb.__version__}, shapely {shapely.__version__}")
    worst = {}
    for sc in scenarios:
        pq = os.path.abspath(os.path.join(sc, "points.parquet"))
        results, ref = {}, None
        for name, method, conc, radius, k, shrink in VARIANTS:
            con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
            con.execute(f"LOAD '{os.path.abspath(a.ext)}'")
            run_stages(con, pq, "overlap", overlap_method=method, overlap_concavity=conc, overlap_radius_m=radius,
                       overlap_min_neighbours=k, overlap_shrink_sigmas=shrink)
            r = con.execute("SELECT any_value(reference) FROM align_frames").fetchone()[0]
            assert ref is None or r == ref, (name, r, ref)
            ref = r
            for ca, cb, blob in con.execute("SELECT cam_a, cam_b, polygon FROM view_overlaps WHERE class = '*'").fetchall():
                results[(name, ca, cb)] = wkb.loads(bytes(blob))
        cams = {}
        with open(os.path.join(sc, "cameras.csv")) as f:
            for row in csv.DictReader(f):
                cams[int(row["camera"])] = (float(row["theta_rad"]), float(row["tx"]), float(row["ty"]), wkt.loads(row["view_wkt_world"]))
        th, tx, ty, _ = cams[ref]
        c, s = math.cos(-th), math.sin(-th)
        # world -> reference-local: R(-theta) (p - t)
        to_ref = [c, -s, s, c, -(c * tx - s * ty), -(s * tx + c * ty)]
        world = con.execute(f"SELECT x, y FROM read_csv('{os.path.abspath(os.path.join(sc, 'world.csv'))}')").fetchall()
        site = affine_transform(shapely.MultiPoint(world).convex_hull, to_ref)
        views = {k: affine_transform(v[3], to_ref) for k, v in cams.items()}
        print(f"\n== {os.path.basename(sc)} (reference camera {ref})")
        print(f"{'pair':6s} {'true m2':>8s} {'∩site m2':>9s} | " + " | ".join(f"{v[0]:>26s}" for v in VARIANTS))
        for ca in sorted(cams):
            for cb in sorted(cams):
                if ca >= cb:
                    continue
                true = views[ca].intersection(views[cb])
                true_site = true.intersection(site)
                cells = []
                for name, *_ in VARIANTS:
                    est = results.get((name, ca, cb))
                    if est is None:
                        cells.append(f"{'unaligned':>26s}")
                        continue
                    iou = est.intersection(true).area / est.union(true).area
                    iou_s = est.intersection(true_site).area / est.union(true_site).area
                    worst[name] = min(worst.get(name, (1.0, 1.0))[0], iou), min(worst.get(name, (1.0, 1.0))[1], iou_s)
                    cells.append(f"IoU {iou:.3f} / {iou_s:.3f} ({est.area:6.1f})")
                print(f"{ca}-{cb:<4d} {true.area:8.1f} {true_site.area:9.1f} | " + " | ".join(cells))
    print("\nworst IoU over all pairs (vs rect / vs rect∩site):")
    for name, (w1, w2) in worst.items():
        print(f"  {name:26s} {w1:.3f} / {w2:.3f}")


if __name__ == "__main__":
    main()
