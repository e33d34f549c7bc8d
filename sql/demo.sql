-- trajdb demo, part 1: two roadside cameras watch one intersection, each in its OWN frame.
-- Everything is generated here, no external data. `trajdb demo` runs this file, then
-- sql/stages/align.sql (finds the camera transform from the tracks alone), then sql/demo_match.sql.

-- Synthetic road users: cars east-west, pedestrians north-south, on straight lanes.
CREATE OR REPLACE TEMP TABLE demo_objects AS
SELECT o AS object_id,
       CASE WHEN o % 3 = 0 THEN 'pedestrian' ELSE 'car' END AS class,
       (o * 3.7) % 150 AS t_start,
       CASE WHEN o % 3 = 0 THEN ((o * 5) % 11 - 5) * 1.0 ELSE (CASE WHEN o % 2 = 0 THEN -40.0 ELSE 40.0 END) END AS x_start,
       CASE WHEN o % 3 = 0 THEN (CASE WHEN o % 2 = 0 THEN -30.0 ELSE 30.0 END) ELSE ((o * 7) % 11 - 5) * 1.5 END AS y_start,
       CASE WHEN o % 3 = 0 THEN 0.0 ELSE (CASE WHEN o % 2 = 0 THEN 1 ELSE -1 END) * (8.0 + (o % 5)) END AS vx,
       CASE WHEN o % 3 = 0 THEN (CASE WHEN o % 2 = 0 THEN 1 ELSE -1 END) * 1.4 ELSE 0.0 END AS vy
FROM range(90) r(o);

-- Each camera samples at 10 Hz with its own phase and ~0.1 m noise and sees part of the road:
-- camera 1 world x <= 8, camera 2 world x >= -8 (a 16 m wide shared strip). Camera 1's frame
-- is the world frame; camera 2 is rotated by 120 degrees and shifted:
-- p_cam2 = R(-120 deg) * (p_world - (15, -8)).
CREATE OR REPLACE TEMP TABLE points AS
WITH samples AS (
    SELECT c.camera, o.object_id, o.class, k,
           o.t_start + k / 10.0 + c.phase AS t,
           o.x_start + o.vx * (k / 10.0 + c.phase) AS wx,
           o.y_start + o.vy * (k / 10.0 + c.phase) AS wy
    FROM demo_objects o, (VALUES (1, 0.00), (2, 0.05)) c(camera, phase), range(0, 600) r(k)
    WHERE k / 10.0 <= 60.0 / greatest(abs(o.vx), abs(o.vy))
), seen AS (
    SELECT *,
           wx + ((hash(camera, object_id, k, 'x') % 2001) / 10000.0 - 0.1) AS nx,
           wy + ((hash(camera, object_id, k, 'y') % 2001) / 10000.0 - 0.1) AS ny
    FROM samples
    WHERE (camera = 1 AND wx <= 8) OR (camera = 2 AND wx >= -8)
)
SELECT camera,
       (hash(camera, object_id) % 100000)::BIGINT AS track_id,   -- per-camera ids reveal nothing
       object_id, class, t,
       CASE WHEN camera = 1 THEN nx ELSE cos(radians(-120)) * (nx - 15) - sin(radians(-120)) * (ny + 8) END AS x,
       CASE WHEN camera = 1 THEN ny ELSE sin(radians(-120)) * (nx - 15) + cos(radians(-120)) * (ny + 8) END AS y,
       0 AS estimated
FROM seen;
