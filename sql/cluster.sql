-- trajdb: route patterns by agglomerative clustering of trajectories (Buzan et al. 4.3-4.5, 5.2).
--
-- Input: `points(camera, track_id, class, t, x, y, estimated)`. One camera's tracks are
-- clustered per class in that camera's own frame (no alignment needed; after sql/merge.sql the
-- same works on merged(road_user, class, traj)).
-- Output:
--   cluster_tracks(track_id, class, traj)                 tracks resampled to 2 Hz
--   cluster_pairs(class, a, b, distance)                   1 - Buzan's S1 (or S2, translation-invariant)
--   cluster_assign(class, track_id, cluster)               average linkage cut at the threshold
--   cluster_summary(class, cluster, n_tracks, ...)         one row per route pattern
--
-- Distance: 1 - min(S_x, S_y) with delta = 5 samples (2.5 s of time warping), epsilon = 2 m and
-- Buzan's rho = 0.5 (tracks less than half as long as each other are not compared). S1 compares
-- the tracks where they are: route patterns. cluster_translation_invariant = true switches to
-- S2, which compares shapes wherever they are (a walk to the east is a walk to the east) and
-- groups far fewer, larger patterns. Pairs with no common subsequence (distance 1) are left
-- out of the list: they are cannot-links, and under average linkage such tracks never share a
-- cluster.
SET VARIABLE cluster_camera = 1;
SET VARIABLE cluster_delta = 5;
SET VARIABLE cluster_epsilon = 2.0;
SET VARIABLE cluster_rho = 0.5;
SET VARIABLE cluster_threshold = 0.5;
SET VARIABLE cluster_translation_invariant = false;

CREATE OR REPLACE TEMP TABLE cluster_tracks AS
SELECT track_id, class, list({'t': t, 'x': x, 'y': y} ORDER BY t) AS traj,
       min(x) AS x0, max(x) AS x1, min(y) AS y0, max(y) AS y1
FROM (
    SELECT *, row_number() OVER (PARTITION BY track_id ORDER BY t) AS k
    FROM points WHERE camera = getvariable('cluster_camera') AND estimated = 0 AND class IN ('car', 'pedestrian')
)
WHERE k % 5 = 1
GROUP BY track_id, class
HAVING count(*) >= 6;

CREATE OR REPLACE TEMP TABLE cluster_pairs AS
SELECT class, a, b, 1 - least(s.sx, s.sy) AS distance
FROM (
    SELECT p.class, p.track_id AS a, q.track_id AS b,
           CASE WHEN getvariable('cluster_translation_invariant')
                THEN lcss_s2(p.traj, q.traj, getvariable('cluster_delta'), getvariable('cluster_epsilon'), getvariable('cluster_rho'))::STRUCT(sx DOUBLE, sy DOUBLE)
                ELSE lcss_s1(p.traj, q.traj, getvariable('cluster_delta'), getvariable('cluster_epsilon'), getvariable('cluster_rho')) END AS s
    FROM cluster_tracks p JOIN cluster_tracks q
      ON p.class = q.class AND p.track_id < q.track_id
     -- S1_x > 0 needs the x ranges within epsilon of each other, S1_y > 0 the y ranges: an exact
     -- pre-filter (a range join) that skips pairs whose distance would be 1 anyway (not for S2,
     -- which translates)
     AND (getvariable('cluster_translation_invariant')
          OR (p.x0 < q.x1 + getvariable('cluster_epsilon') AND q.x0 < p.x1 + getvariable('cluster_epsilon')
              AND p.y0 < q.y1 + getvariable('cluster_epsilon') AND q.y0 < p.y1 + getvariable('cluster_epsilon')))
)
WHERE least(s.sx, s.sy) > 0;

CREATE OR REPLACE TEMP TABLE cluster_assign AS
WITH c AS (
    SELECT class, unnest(agglomerative_cluster(list({'a': a, 'b': b, 'distance': distance}), 'average',
                                               getvariable('cluster_threshold'))) AS m
    FROM cluster_pairs GROUP BY class
)
SELECT t.class, t.track_id, coalesce(c.m.cluster, 0) AS cluster   -- 0: no similar track at all
FROM cluster_tracks t LEFT JOIN c ON c.class = t.class AND c.m.id = t.track_id;

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
