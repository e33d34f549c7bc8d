-- A tiny deterministic scene for the stage tests (tests/test_stages_python.py): two cameras,
-- 12 road users on 4 routes (two straight, two 90-degree turns), 10 Hz, +-0.05 m noise.
-- World frame = camera 0's frame and clock. Camera 1 sees x in [-10, 40], y in [-20, 30] of the
-- world in its own frame, local = R(-0.5 rad) (world - (15, 5)), on a clock 0.4 s ahead (and
-- sampled 0.05 s after camera 0). Camera 0 sees |x|, |y| <= 25. Road user k (0..11): route k % 4,
-- starts at 2 + 4k s, 80 m at 6 + 0.5 (k // 4) m/s (route 3: pedestrians at 1.5 + 0.1 (k // 4)
-- m/s), 0.4 (k // 4) m to the side. Extra tracks of camera 0: road user 4 broken (id 104 until
-- 0.5 s before it reaches x = 0, id 150 from 0.5 s after), 901 a single point (too short),
-- 902 moving 1000 m/s (implausible).
CREATE OR REPLACE TEMP TABLE scene_world AS
WITH u AS (
    SELECT k, k % 4 AS route, k // 4 AS n, 2.0 + 4 * k AS ts,
           CASE WHEN k % 4 = 3 THEN 1.5 + 0.1 * (k // 4) ELSE 6.0 + 0.5 * (k // 4) END AS v,
           CASE WHEN k % 4 = 3 THEN 'pedestrian' ELSE 'car' END AS class
    FROM range(12) r(k)
),
g AS (  -- start point, heading, turn rate (a 90-degree turn over the 80 m)
    SELECT u.*, 80.0 / v AS dur,
           [[-40.0, -2.0 + 0.4 * n], [2.0 + 0.4 * n, -40.0], [40.0, 2.0 + 0.4 * n], [-2.0 - 0.4 * n, 40.0]][route + 1] AS p0,
           [0.0, pi() / 2, pi(), -pi() / 2][route + 1] AS h0,
           [0.0, 0.0, pi() / 2, -pi() / 2][route + 1] * v / 80.0 AS w
    FROM u
),
s AS (  -- world samples every 0.01 s (each camera takes its own phase)
    SELECT g.*, i, ts + i * 0.01 AS t, i * 0.01 AS tau FROM g, range(0, (dur * 100)::BIGINT + 1) r(i)
)
SELECT k, class, t,
       CASE WHEN w = 0 THEN p0[1] + v * tau * cos(h0) ELSE p0[1] + v / w * (sin(h0 + w * tau) - sin(h0)) END AS x,
       CASE WHEN w = 0 THEN p0[2] + v * tau * sin(h0) ELSE p0[2] + v / w * (cos(h0) - cos(h0 + w * tau)) END AS y
FROM s;

CREATE OR REPLACE TEMP MACRO scene_noise(a, b, c) AS
    0.05 * (2 * ((sin(a * 12.9898 + b * 78.233 + c * 37.719) * 43758.5453) - floor(sin(a * 12.9898 + b * 78.233 + c * 37.719) * 43758.5453)) - 1);

CREATE OR REPLACE TEMP TABLE points AS
WITH cam0 AS (
    SELECT 0 AS camera, 100 + k AS track_id, class, t, x + scene_noise(k, round(t * 100), 1) AS x, y + scene_noise(k, round(t * 100), 2) AS y
    FROM scene_world
    WHERE round(t * 100)::BIGINT % 10 = 0 AND abs(x) <= 25 AND abs(y) <= 25
),
cam1 AS (
    SELECT 1 AS camera, 200 + k AS track_id, class, t + 0.4 AS t,
           cos(-0.5) * (x - 15) - sin(-0.5) * (y - 5) + scene_noise(k, round(t * 100), 3) AS x,
           sin(-0.5) * (x - 15) + cos(-0.5) * (y - 5) + scene_noise(k, round(t * 100), 4) AS y
    FROM scene_world
    WHERE round(t * 100)::BIGINT % 10 = 5 AND x BETWEEN -10 AND 40 AND y BETWEEN -20 AND 30
),
cross4 AS (SELECT min(t) AS tc FROM scene_world WHERE k = 4 AND x >= 0)
SELECT camera::INTEGER AS camera, track_id::BIGINT AS track_id, class, t::DOUBLE AS t, x::DOUBLE AS x, y::DOUBLE AS y, 0 AS estimated
FROM (
    SELECT * REPLACE (CASE WHEN track_id = 104 AND t > (SELECT tc FROM cross4) THEN 150 ELSE track_id END AS track_id) FROM cam0
    WHERE NOT (track_id = 104 AND abs(t - (SELECT tc FROM cross4)) < 0.5)
    UNION ALL FROM cam1
    UNION ALL SELECT 0, 901, 'car', 30.0, 1.0, 1.0
    UNION ALL SELECT 0, 902, 'car', 40.0 + 0.1 * i, (i % 2) * 100.0, 0.0 FROM range(20) r(i)
);
-- the load's id map (sql/pipeline.sql, load_ids): the scene's ids are integers, kept as they are
CREATE OR REPLACE TEMP TABLE load_ids AS
SELECT DISTINCT camera AS camera_in, camera, track_id AS track_in, track_id FROM points;
