"""The archive's daily check on the camera-change lakes of tests/test_archive_python.py: every
camera pair's z on every day (docs/archive.md, "Measured").

    python benches/archive_checks.py --extension trajdb.duckdb_extension

Two simulated lakes of 5 days of 8 minutes (3 cameras, viewpoint offsets up to 1 m, 1 %
ground-plane errors): camera 1 moved by 1 m on day 2 in one, camera 2 turned by 1 degree on
day 2 in the other. Prints per day the checks (camera pair, matched pairs, z) and the change.
"""
import argparse
import json
import os
import shutil
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--extension", required=True)
    a = ap.parse_args()
    os.environ["TRAJDB_EXTENSION"] = os.path.abspath(a.extension)
    import duckdb
    import trajdb
    from trajdb import lake_sim

    real = dict(viewpoint_bias_vehicle=1.0, viewpoint_bias_vru=0.2, ground_plane_scale=0.01)
    w = tempfile.mkdtemp(prefix="trajdb-archive-checks-")
    try:
        con = trajdb.connect()
        unchanged = []
        for name, mv in (("moved 1 m", {"site": "s1", "day": 2, "camera": 1, "dx": 1.0, "dy": 0.0, "deg": 0.0}),
                         ("turned 1 deg", {"site": "s1", "day": 2, "camera": 2, "dx": 0.0, "dy": 0.0, "deg": 1.0})):
            lake = os.path.join(w, name.replace(" ", "-"))
            lake_sim.simulate_lake(con, lake, sites=1, days=5, minutes=8, move=mv, **real)
            trajdb.archive(con, lake, lake + "-out")
            rows = duckdb.sql(f"FROM read_parquet('{lake}-out/_state/partitions.parquet') ORDER BY date").to_arrow_table().to_pylist()
            for r in rows:
                checks = json.loads(r["checks"])
                ch = json.loads(r["changes"]) if r["changes"] != "[]" else None
                if not ch:
                    unchanged += [c["z"] for c in checks if c["z"] is not None]
                what = "" if not ch else f"  CHANGE: camera {ch['camera']}: " + "; ".join(
                    f"{p['camera_fixed']}-{p['camera_moving']} moved {p['moved_m']} m, turned {p['turned_deg']} deg, z {p['z']}" for p in ch["pairs"] if p["kind"] == "moved")
                print(f"{name:13s} {r['date']}  " + "  ".join(f"{c['cameras']}: {c['pairs']} pairs z {c['z']}" for c in checks) + what)
        print(f"unchanged days: z {min(unchanged)} - {max(unchanged)} over {len(unchanged)} checks")
    finally:
        shutil.rmtree(w, ignore_errors=True)


if __name__ == "__main__":
    main()
