#!/usr/bin/env python3
"""Crowds of slow road users (issue 26, part 3): pedestrians and cyclists waiting at a crossing's
kerb 0.6-2 m apart for 10-60 s, then crossing together (trajdb_simulate's waiting_groups), seen by
three cameras with position noise up to 0.3 m; and (issue 38) a busy crossing whose tracks are cut
mid-view by occlusion. The pipeline runs with its defaults (no per-scene
parameter), and the test scores it against the simulator's truth here:
- cross-camera match precision (pairs of matches.csv whose two tracks are one object) >= 0.99;
- within-camera link precision (consecutive pieces of one chain of links.csv that are one
  object) >= 0.98.
Before association was gated by the measured noise (docs/association.md), the first scene gave
match precision 0.976 and link precision 0.909.

usage: python3 tests/test_crowd_python.py path/to/trajdb.duckdb_extension
"""
import os
import sys
import tempfile
import warnings

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "python"))
os.environ["TRAJDB_EXTENSION"] = os.path.abspath(sys.argv[1])

import trajdb  # noqa: E402

# (name, simulate parameters): small enough to run in seconds, crowded enough to fail the old rules
SCENES = [
    ("3 cameras, 10 Hz, sigma 0.15-0.3 m, 4 waiting groups a minute, seed 11",
     dict(cameras=3, minutes=2.0, seed=11, rate_hz=10.0, waiting_groups=4.0, noise_sigma_min=0.15, noise_sigma_max=0.3)),
    ("3 cameras, 10 Hz, sigma 0.15-0.3 m, 6 waiting groups a minute, seed 13",
     dict(cameras=3, minutes=1.5, seed=13, rate_hz=10.0, waiting_groups=6.0, noise_sigma_min=0.15, noise_sigma_max=0.3)),
    # a busy crossing whose pedestrians are cut into pieces mid-view (occlusion): 6940 pedestrian
    # track pairs against 480 car pairs per camera pair; a uniform sample of align_max_hypotheses
    # pairs left two of three camera pairs 1.7-2 s off (match precision 0.34): the sample now
    # takes the classes in turn (align.sql, align_sample)
    ("3 cameras, 10 Hz, 10x pedestrians cut mid-view (occlusion 0.05), seed 1",
     dict(cameras=3, minutes=5.0, seed=1, rate_hz=10.0, pedestrians=10.0, occlusion=0.05)),
]
# the least share of objects that are exactly one road user, per scene (by name prefix): with two
# camera pairs 2 s off the occluded scene had 0.199 (0.736 aligned: its breaks longer than
# quality_max_gap that no other camera bridges stay split, issue 38 item 5)
MIN_EXACT = {"3 cameras, 10 Hz, 10x pedestrians": 0.6}

MIN_MATCH_PRECISION = 0.99
MIN_LINK_PRECISION = 0.98


def score(con, scenario):
    """(match precision, matches, link precision, links, exact share) of the pipeline's tables in
    con against scenario/truth.csv."""
    con.execute("CREATE OR REPLACE TEMP TABLE crowd_truth AS SELECT * FROM read_csv(?)", [os.path.join(scenario, "truth.csv")])
    m = con.execute(
        """SELECT count(*), count(*) FILTER (WHERE a.object_id = b.object_id AND a.is_noise = 0)
           FROM (SELECT DISTINCT camera_a, track_a, camera_b, track_b FROM result_matches()) m
           JOIN crowd_truth a ON a.camera = m.camera_a AND a.track_id = m.track_a
           JOIN crowd_truth b ON b.camera = m.camera_b AND b.track_id = m.track_b""").fetchone()
    # a predicted link: two consecutive pieces (by start time) of one chain
    k = con.execute(
        """WITH pieces AS (SELECT l.camera, l.track_id, l.linked_id, e.e.t0 AS t0
                           FROM result_links() l JOIN quality_endpoints e USING (camera, track_id)),
                links AS (SELECT camera, track_id AS a, lead(track_id) OVER (PARTITION BY camera, linked_id ORDER BY t0, track_id) AS b
                          FROM pieces QUALIFY b IS NOT NULL)
           SELECT count(*), count(*) FILTER (WHERE x.object_id = y.object_id AND x.is_noise = 0)
           FROM links JOIN crowd_truth x ON x.camera = links.camera AND x.track_id = links.a
           JOIN crowd_truth y ON y.camera = links.camera AND y.track_id = links.b""").fetchone()
    # exact: an object's real tracks are exactly one road user's tracks
    exact = con.execute(
        """WITH ru AS (SELECT road_user, unnest(sources) AS s FROM result_road_users()),
                tr AS (SELECT t.object_id, ru.road_user FROM ru JOIN crowd_truth t ON t.camera = s.camera AND t.track_id = s.track_id
                       WHERE t.is_noise = 0),
                obj AS (SELECT object_id, count(DISTINCT road_user) AS n_ru, any_value(road_user) AS ru FROM tr GROUP BY object_id),
                ru_obj AS (SELECT road_user, count(DISTINCT object_id) AS n_obj FROM tr GROUP BY road_user)
           SELECT avg((o.n_ru = 1 AND r.n_obj = 1)::INT) FROM obj o JOIN ru_obj r ON r.road_user = o.ru""").fetchone()[0]
    return (m[1] / max(m[0], 1), m[0], k[1] / max(k[0], 1), k[0], exact)


def main():
    warnings.simplefilter("ignore")
    failed = []
    w = tempfile.mkdtemp(prefix="trajdb-crowd-")
    for i, (name, params) in enumerate(SCENES):
        scenario = os.path.join(w, f"scene{i}")
        con = trajdb.connect()
        trajdb.simulate(con, scenario, **params)
        groups = con.execute("SELECT count(*) FROM read_csv(?) WHERE source LIKE '%waiting group%'",
                             [os.path.join(scenario, "objects.csv")]).fetchone()[0]
        trajdb.pipeline(con, os.path.join(scenario, "points.parquet"))
        mp, nm, lp, nl, exact = score(con, scenario)
        print(f"{name}: {groups} people in waiting groups; match precision {mp:.4f} ({nm} pairs), "
              f"link precision {lp:.4f} ({nl} links), exact {exact:.4f}")
        if groups == 0 and not params.get("occlusion"):
            failed.append(f"{name}: the scene has no waiting group (the test tests nothing)")
        if nm == 0 or mp < MIN_MATCH_PRECISION:
            failed.append(f"{name}: match precision {mp:.4f} < {MIN_MATCH_PRECISION} ({nm} pairs)")
        floor = next((v for k, v in MIN_EXACT.items() if name.startswith(k)), 0.0)
        if exact < floor:
            failed.append(f"{name}: exact {exact:.4f} < {floor}")
        if lp < MIN_LINK_PRECISION:
            failed.append(f"{name}: link precision {lp:.4f} < {MIN_LINK_PRECISION} ({nl} links)")
    if failed:
        print("FAILED:\n  " + "\n  ".join(failed))
        sys.exit(1)
    print("crowd tests: ok")


if __name__ == "__main__":
    main()
