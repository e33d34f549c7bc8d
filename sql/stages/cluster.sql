-- stage: cluster
-- reads: points, load_ids, calibrated()
-- makes: cluster_camera_used, cluster_tracks, cluster_assign, cluster_summary, result_clusters()
-- work: -
-- changes: -
-- parameters: cluster_camera, cluster_classes, cluster_delta, cluster_epsilon, cluster_exact_max, cluster_method,
--             cluster_rho, cluster_threshold, cluster_translation_invariant
--
-- trajdb: route patterns by agglomerative clustering of trajectories (Buzan et al. 4.3-4.5, 5.2).
--
-- Input: `points(camera, track_id, class, t, x, y, estimated)`. One camera's tracks are
-- clustered per class in that camera's own frame (no alignment needed; after sql/stages/merge.sql the
-- same works on merged(road_user, class, traj)).
-- Output:
--   cluster_tracks(track_id, class, traj)                 tracks resampled to 2 Hz (traj_resample, t = k/2 s)
--   cluster_assign(class, track_id, cluster)               average linkage on 1 - Buzan's S1 (or S2,
--                                                          translation-invariant), cut at the threshold
--   cluster_summary(class, cluster, n_tracks, ...)         one row per route pattern
--
-- Distance: 1 - min(S_x, S_y) with delta = 5 samples (2.5 s of time warping), epsilon = 2 m and
-- Buzan's rho = 0.5 (tracks less than half as long as each other are not compared). S1 compares
-- the tracks where they are: route patterns. cluster_translation_invariant = true switches to
-- S2, which compares shapes wherever they are (a walk to the east is a walk to the east) and
-- groups far fewer, larger patterns. Pairs with no common subsequence (distance 1) are left
-- out of the list: they are cannot-links, and under average linkage such tracks never share a
-- cluster.
-- Parameters (cluster_*): declared once in crates/app/src/params.rs, defaults in sql/params.sql;
-- `trajdb params` lists them, `trajdb pipeline --param name=value` or SET VARIABLE sets them.

-- The clustered camera: cluster_camera, or (auto) the camera with the most real tracks, ties to
-- the lowest id (calibrate.sql: the data decides, not a camera number); a given camera must exist.
-- An archive's day (src/archive/task.rs) runs on its site's kept calibration: when the
-- camera chosen there (auto) has no points today, the day's own choice by the same rule stands.
-- (a statement that prints nothing: the DuckDB CLI shows no result box for a check that passed)
CREATE OR REPLACE TEMP TABLE cluster_camera_used AS
SELECT CASE WHEN EXISTS (SELECT 1 FROM points WHERE camera = calibrated('cluster_camera')) OR getvariable('cluster_camera') IS NOT NULL
            THEN calibrated('cluster_camera')
            ELSE (SELECT camera FROM points WHERE estimated = 0 GROUP BY camera ORDER BY count(DISTINCT track_id) DESC, camera LIMIT 1) END AS camera;
SET VARIABLE cluster_check = (SELECT CASE WHEN NOT EXISTS (SELECT 1 FROM points WHERE camera = (SELECT camera FROM cluster_camera_used))
            THEN error('cluster: cluster_camera ' || (SELECT camera FROM cluster_camera_used)::BIGINT || ' is not a camera of the input (cameras: '
                       || (SELECT string_agg(DISTINCT camera::VARCHAR, ', ' ORDER BY camera::VARCHAR) FROM points) || ')') END);
CREATE OR REPLACE TEMP TABLE cluster_tracks AS
SELECT * FROM (
    SELECT track_id, class, traj_resample(list({'t': t, 'x': x, 'y': y} ORDER BY t), 0.5, 1.0) AS traj
    FROM points
    WHERE camera = (SELECT camera FROM cluster_camera_used) AND estimated = 0
      AND (getvariable('cluster_classes') = ''
           OR list_contains([lower(trim(c)) FOR c IN string_split(getvariable('cluster_classes'), ',')], lower(class)))
    GROUP BY track_id, class
)
WHERE len(traj) >= 6;

-- Exact: all pairs in one call per class: traj_cluster computes every S1 (or S2) distance in
-- parallel straight into the distance matrix, with the exact bounding-box pre-filter (S1_x > 0
-- needs the x ranges within epsilon, likewise y), then average linkage cut at the threshold.
-- Pairs with no common subsequence are cannot-links; a track with no similar track at all gets
-- cluster 0. (The same by hand, for other distances: lcss_s1 over a self-join of cluster_tracks,
-- then agglomerative_cluster(list({'a', 'b', 'distance'}), 'average', threshold): 86 s instead of
-- a few on a Mellingen-sized day, because the join materialises two trajectories per pair.)
-- Prototypes (issue 28): all pairs of a day's 9,500 cars of one camera are 45 M LCSS (9.4 s on 2
-- cores), growing with the square of the day. traj_cluster_prototypes visits the tracks longest
-- first and lets each join the nearest prototype within half the cut height (or become one),
-- then clusters the prototypes exactly: 0.09 s for the same cars. Its partition is not the exact
-- one (docs/clustering.md: adjusted Rand index against the exact clustering and against the
-- simulator's true routes); cluster_method = 'exact' keeps the exact one for any size, 'auto'
-- uses it up to cluster_exact_max tracks of a class.
SET VARIABLE cluster_method_check = (SELECT CASE WHEN lower(trim(getvariable('cluster_method'))) NOT IN ('auto', 'exact', 'prototypes')
            THEN error('cluster: cluster_method must be ''auto'', ''exact'' or ''prototypes'', got ''' || getvariable('cluster_method') || '''') END);
CREATE OR REPLACE TEMP TABLE cluster_assign AS
WITH g AS (
    SELECT class, list(track_id ORDER BY track_id) AS ids, list(traj ORDER BY track_id) AS trajs,
           CASE lower(trim(getvariable('cluster_method')))
               WHEN 'exact' THEN false WHEN 'prototypes' THEN true
               ELSE count(*) > getvariable('cluster_exact_max') END AS by_prototypes
    FROM cluster_tracks GROUP BY class
), c AS (
    SELECT class, unnest(traj_cluster(ids, trajs, 'average', getvariable('cluster_threshold'), getvariable('cluster_delta'),
                                      getvariable('cluster_epsilon'), getvariable('cluster_rho'),
                                      getvariable('cluster_translation_invariant'))) AS m
    FROM g WHERE NOT by_prototypes
    UNION ALL
    SELECT class, unnest(traj_cluster_prototypes(ids, trajs, 'average', getvariable('cluster_threshold'),
                                                 getvariable('cluster_threshold') / 2, getvariable('cluster_delta'),
                                                 getvariable('cluster_epsilon'), getvariable('cluster_rho'),
                                                 getvariable('cluster_translation_invariant'))) AS m
    FROM g WHERE by_prototypes
)
SELECT class, m.id AS track_id, m.cluster FROM c;

CREATE OR REPLACE TEMP TABLE cluster_summary AS
SELECT a.class, a.cluster, count(*) AS n_tracks,
       round(avg(t.traj[1].x), 1) AS start_x, round(avg(t.traj[1].y), 1) AS start_y,
       round(avg(t.traj[-1].x), 1) AS end_x, round(avg(t.traj[-1].y), 1) AS end_y
FROM cluster_assign a JOIN cluster_tracks t USING (class, track_id)
GROUP BY a.class, a.cluster;

SELECT class, count(*) FILTER (WHERE cluster > 0) AS route_patterns,
       sum(n_tracks) FILTER (WHERE n_tracks >= 5) AS tracks_in_patterns_of_5_plus,
       sum(n_tracks) AS tracks
FROM cluster_summary GROUP BY class ORDER BY class;

-- The stage's results (sql/export.sql writes them; python/trajdb/windows.py reads them per window).
-- Table macros: they read the tables when called. Unordered: the caller orders. Camera and
-- track ids are the input's own (load_ids maps the stages' numbers back: text stays text).

-- clusters: route patterns of one camera
CREATE OR REPLACE TEMP MACRO result_clusters() AS TABLE
SELECT i.camera_in AS camera, a.class, i.track_in AS track_id, a.cluster
FROM cluster_assign a JOIN load_ids i ON i.camera = (SELECT camera FROM cluster_camera_used) AND i.track_id = a.track_id;
