-- trajdb demo: two roadside cameras watch the same intersection; which of their tracks
-- belong to the same road user? Everything is generated here, no external data.
-- Run it with:  cargo run --release -- demo     (or: trajdb run sql/demo.sql)

-- 1. Synthetic road users crossing the intersection on straight lanes.
CREATE OR REPLACE TEMP TABLE demo_objects AS
SELECT o AS object_id,
       CASE WHEN o % 3 = 0 THEN 'pedestrian' ELSE 'car' END AS class,
       (o * 3.7) % 150 AS t_start,
       CASE WHEN o % 2 = 0 THEN -40.0 ELSE 40.0 END AS x_start,
       ((o * 7) % 11 - 5) * 1.5 AS y_lane,
       (CASE WHEN o % 2 = 0 THEN 1 ELSE -1 END) * (CASE WHEN o % 3 = 0 THEN 1.4 ELSE 8.0 + (o % 5) END) AS vx
FROM range(80) r(o);

-- 2. Each camera samples at 10 Hz with its own phase and ~0.1 m noise, and sees only part
--    of the road: camera 1 x <= 8, camera 2 x >= -8 (a 16 m wide shared strip).
CREATE OR REPLACE TEMP TABLE demo_points AS
WITH samples AS (
    SELECT c.camera, o.object_id, o.class,
           o.t_start + k / 10.0 + c.phase AS t,
           o.x_start + o.vx * (k / 10.0 + c.phase) AS x,
           o.y_lane AS y, k
    FROM demo_objects o,
         (VALUES (1, 0.00), (2, 0.05)) c(camera, phase),
         range(0, 1000) r(k)
    WHERE k / 10.0 <= 80.0 / abs(o.vx)
)
SELECT camera,
       -- track ids are per camera and do not reveal the object
       (hash(camera, object_id) % 100000)::BIGINT AS track_id,
       object_id, class, t,
       x + ((hash(camera, object_id, k, 'x') % 2001) / 10000.0 - 0.1) AS x,
       y + ((hash(camera, object_id, k, 'y') % 2001) / 10000.0 - 0.1) AS y
FROM samples
WHERE (camera = 1 AND x <= 8) OR (camera = 2 AND x >= -8);

-- 3. One trajectory per camera and track: the trajdb idiom.
CREATE OR REPLACE TEMP TABLE demo_tracks AS
SELECT camera, track_id, class, any_value(object_id) AS object_id,
       list({'t': t, 'x': x, 'y': y} ORDER BY t) AS traj,
       min(t) AS t0, max(t) AS t1
FROM demo_points
GROUP BY camera, track_id, class;

-- 4. Score every time-overlapping pair of the same class inside the shared strip
--    (eq. 2.10: eps = 1 m, T = 0.5 s, at least 5 points inside the overlap).
CREATE OR REPLACE TEMP TABLE demo_scores AS
SELECT a.track_id AS track_a, b.track_id AS track_b, a.class,
       a.object_id = b.object_id AS same_object,
       lcss_similarity(a.traj, b.traj, 1.0, 0.5, 5,
                       'POLYGON ((-8 -50, 8 -50, 8 50, -8 50, -8 -50))') AS eta
FROM demo_tracks a
JOIN demo_tracks b
  ON a.camera = 1 AND b.camera = 2 AND a.class = b.class
 AND a.t0 <= b.t1 + 0.5 AND b.t0 <= a.t1 + 0.5;

-- 5. Keep each track's best partner above the threshold and check against the generator.
SELECT count(*) AS candidate_pairs,
       count(*) FILTER (WHERE eta >= 0.5) AS above_threshold,
       count(*) FILTER (WHERE eta >= 0.5 AND same_object) AS correct,
       (SELECT count(DISTINCT object_id) FROM demo_tracks WHERE camera = 1
          AND object_id IN (SELECT object_id FROM demo_tracks WHERE camera = 2)) AS objects_seen_by_both,
       round(avg(eta) FILTER (WHERE same_object), 3) AS mean_eta_same,
       round(avg(eta) FILTER (WHERE NOT same_object), 3) AS mean_eta_different
FROM demo_scores;

SELECT class, track_a, track_b, round(eta, 3) AS eta, same_object
FROM demo_scores
WHERE eta > 0
ORDER BY eta DESC, track_a
LIMIT 8;
