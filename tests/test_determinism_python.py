#!/usr/bin/env python3
"""Determinism (issue 17): the pipeline's result files are byte-identical across DuckDB thread
counts (1, 2, 8) and across input row orders (the points shuffled), on a simulated scene with
clock offsets and noise. Every aggregate that feeds a sum or an order-sensitive function has an
ORDER BY; ties are broken by documented keys (see the stage files). Runs through the Python
package over PyPI DuckDB and the loadable extension (trajdb.simulate, trajdb.pipeline), one
fresh connection per run.

usage: python3 tests/test_determinism_python.py path/to/trajdb.duckdb_extension
"""
import filecmp
import os
import shutil
import sys
import tempfile
import warnings

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
os.environ["TRAJDB_EXTENSION"] = os.path.abspath(sys.argv[1])
sys.path.insert(0, os.path.join(ROOT, "python"))
import trajdb  # noqa: E402

FILES = ["transforms.csv", "calibration.csv", "matches.csv", "links.csv", "clusters.csv", "merged.parquet"]


def run(threads, input, out):
    con = trajdb.connect()
    con.execute(f"SET threads = {int(threads)}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        trajdb.pipeline(con, input, out=out)
    con.close()


def main():
    w = tempfile.mkdtemp(prefix="trajdb-determinism-")
    try:
        sim = os.path.join(w, "sim")
        trajdb.simulate(trajdb.connect(), sim, cameras=4, minutes=6, traffic=2, seed=11, clock_offset_max=0.3,
                        noise_sigma_min=0.05, noise_sigma_max=0.2)
        points, shuffled = os.path.join(sim, "points.parquet"), os.path.join(w, "shuffled.parquet")
        trajdb.connect().execute(f"COPY (SELECT * FROM '{points}' ORDER BY hash(camera * 1000003 + track_id, t)) TO '{shuffled}'")
        runs = {"t1": (1, points), "t2": (2, points), "t8": (8, points), "shuffled": (2, shuffled)}
        for name, (threads, inp) in runs.items():
            run(threads, inp, os.path.join(w, name))
        fail = 0
        for f in FILES:
            for d in ["t2", "t8", "shuffled"]:
                if not filecmp.cmp(os.path.join(w, "t1", f), os.path.join(w, d, f), shallow=False):
                    print(f"FAIL: {f} differs between 1 thread and {d}", file=sys.stderr)
                    fail = 1
        if fail:
            sys.exit(1)
        print(f"ok   determinism: {len(FILES)} result files byte-identical at 1, 2 and 8 threads and with the input rows shuffled")
    finally:
        shutil.rmtree(w, ignore_errors=True)


if __name__ == "__main__":
    main()
