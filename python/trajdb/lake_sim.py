"""A simulated archive (issue 40): sites x days of `trajdb simulate`, laid out as a lake of
site=S/date=D/points.parquet, each site with its own cameras (site_seed) and each day its own
traffic (seed) and clock epoch; a camera can be moved or turned from a day on, as a truck or a
maintenance crew would.

    trajdb.lake_sim.simulate_lake(con, "lake", sites=2, days=5, minutes=10,
                                  move={"site": "s1", "day": 3, "camera": 1, "dx": 1.0, "dy": 0, "deg": 0})

The truth of every day stays beside the lake (truth/site=S/date=D/: cameras.csv, truth.csv,
world.csv), never inside it.
"""
import datetime
import math
import os
import shutil

from . import simulate as _simulate


def day_name(k, first="2026-05-04"):
    return (datetime.date.fromisoformat(first) + datetime.timedelta(days=k)).isoformat()


def simulate_lake(con, lake, sites=2, days=5, minutes=10.0, cameras=3, move=None, truth=None, first_day="2026-05-04", **sim):
    """Writes the lake (a new folder) and returns its partitions [(site, date, points)]. `move`:
    {"site", "day" (0-based), "camera", "dx", "dy" (m, in the camera's own frame), "deg", "dt"
    (s, optional)}: from that day on, the camera's points are those of a camera moved by (dx, dy)
    and turned by deg (p' = R(-deg) (p - d)), its clock dt ahead (t' = t + dt). `sim`: more trajdb_simulate parameters (viewpoint_bias_vehicle, ...)."""
    if os.path.exists(lake) and os.listdir(lake):
        raise ValueError(f"simulate_lake: {lake!r} is not empty; name a new folder")
    if not str(lake).strip():
        raise ValueError("simulate_lake: name a folder for the lake")
    truth = truth or (os.path.abspath(lake).rstrip(os.sep) + "-truth")
    if os.path.exists(truth) and os.listdir(truth):
        raise ValueError(f"simulate_lake: the truth folder {truth!r} is not empty; name a new lake (its truth goes beside it)")
    out = []
    for s in range(sites):
        site = f"s{s + 1}"
        for d in range(days):
            date = day_name(d, first_day)
            epoch = datetime.datetime.fromisoformat(date + "T07:00:00+00:00").timestamp()
            tdir = os.path.join(truth, f"site={site}", f"date={date}")
            _simulate(con, tdir, cameras=cameras, minutes=minutes, seed=1000 * (s + 1) + d, site_seed=s + 1, clock_epoch=epoch, **sim)
            part = os.path.join(lake, f"site={site}", f"date={date}")
            os.makedirs(part)
            src = os.path.join(tdir, "points.parquet")
            dst = os.path.join(part, "points.parquet")
            m = move if move and move["site"] == site and d >= move["day"] else None
            if m:
                # the camera moved by (dx, dy) and turned by deg: a point p of the old frame is
                # p' = R(-deg) (p - d) in the new one, the inverse of the move (transform_invert)
                move_tf = {"theta": math.radians(float(m.get("deg", 0.0))), "tx": float(m.get("dx", 0.0)), "ty": float(m.get("dy", 0.0)),
                           "scale": 1.0}
                con.execute("SET VARIABLE trajdb_lake_dst = ?", [dst])
                con.execute(
                    """COPY (SELECT * REPLACE (CASE WHEN camera = $cam THEN transform_point(transform_invert($tf), x, y).x ELSE x END AS x,
                                               CASE WHEN camera = $cam THEN transform_point(transform_invert($tf), x, y).y ELSE y END AS y,
                                               CASE WHEN camera = $cam THEN t + $dt ELSE t END AS t)
                             FROM read_parquet($src, hive_partitioning = false)) TO (getvariable('trajdb_lake_dst')) (FORMAT parquet)""",
                    {"cam": int(m["camera"]), "tf": move_tf, "dt": float(m.get("dt", 0.0)), "src": src})
                con.execute("RESET VARIABLE trajdb_lake_dst")
            else:
                shutil.copyfile(src, dst)
            n = con.execute("SELECT count(*) FROM read_parquet(?)", [dst]).fetchone()[0]
            out.append((site, date, n))
    return out
