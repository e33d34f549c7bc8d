#!/usr/bin/env python3
"""The refactor guard (issue 41): run the whole pipeline on the shared scenes and on a grid of
simulated scenes, and print one SHA-256 per result file. A refactor that changes no result
prints the same lines before and after; compare two runs with `diff`.

usage: python3 scripts/output_digest.py path/to/trajdb.duckdb_extension [path/to/shared/data] > digest.txt

report.html is left out (it holds the run's date and timings); every other result file is in.
"""
import hashlib
import os
import sys
import tempfile
import shutil
import warnings

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
os.environ["TRAJDB_EXTENSION"] = os.path.abspath(sys.argv[1])
sys.path.insert(0, os.path.join(ROOT, "python"))
import trajdb  # noqa: E402

SHARED = sys.argv[2] if len(sys.argv) > 2 else os.path.join(ROOT, "..", "shared", "data")

# the simulated grid: the demo's scenario, clocks and noise, a crowd, and cameras that do not see
# the same point of a road user (viewpoint bias, ground-plane error)
GRID = {
    "demo": dict(cameras=3, minutes=5, seed=1),
    "clocks": dict(cameras=4, minutes=4, traffic=2, seed=11, clock_offset_max=0.3, noise_sigma_min=0.05, noise_sigma_max=0.2),
    "drift": dict(cameras=4, minutes=6, seed=3, clock_offset_max=2.0, clock_drift_ppm=200),
    "seen_from": dict(cameras=3, minutes=4, seed=7, viewpoint_bias_vehicle=1.2, viewpoint_bias_vru=0.3, ground_plane_scale=0.01, ground_plane_perspective=0.01),
}


def digest(folder):
    """(file, sha256) per result file; in analysis.sql the results folder's own path (a fresh
    temporary folder each run) is written as <out>."""
    out = []
    for f in sorted(os.listdir(folder)):
        p = os.path.join(folder, f)
        if f == "report.html" or not os.path.isfile(p) or f.startswith("."):
            continue
        with open(p, "rb") as fh:
            data = fh.read()
        if f == "analysis.sql":
            data = data.replace(os.path.realpath(folder).encode(), b"<out>").replace(folder.encode(), b"<out>")
        out.append((f, hashlib.sha256(data).hexdigest()))
    return out


def run(name, points, w):
    con = trajdb.connect()
    con.execute("SET threads = 2")
    out = os.path.join(w, "out-" + name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        trajdb.pipeline(con, points, out=out)
    con.close()
    for f, h in digest(out):
        print(f"{name:>24}  {f:<20} {h}", flush=True)


def main():
    w = tempfile.mkdtemp(prefix="trajdb-digest-")
    try:
        for scene in sorted(os.listdir(SHARED)):
            p = os.path.join(SHARED, scene, "points.parquet")
            if os.path.isfile(p):
                run(scene, p, w)
        for name, params in GRID.items():
            sim = os.path.join(w, "sim-" + name)
            trajdb.simulate(trajdb.connect(), sim, **params)
            run("sim-" + name, os.path.join(sim, "points.parquet"), w)
    finally:
        shutil.rmtree(w, ignore_errors=True)


if __name__ == "__main__":
    main()
