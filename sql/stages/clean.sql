-- stage: clean
-- reads: points, calibrated()
-- makes: clean_dropped
-- work: -
-- changes: points
-- parameters: clean_drop_estimated_tails, clean_max_speed, clean_min_duration_s, clean_min_points, clean_xi
--
-- trajdb pipeline, stage 2: clean the loaded `points` table in place.
--  * optionally (clean_drop_estimated_tails = true) drop a track whose last xi points are all
--    estimated (the thesis, section 4). Off by default, measured: the tracks it drops are real
--    road users with a short coasting tail, and dropping them cut the match recall of
--    `trajdb score` from 0.993 to 0.836 (dut_intersection_3cam) and from 1.000 to 0.802
--    (dut_roundabout_2cam) at unchanged precision. The estimated points themselves are never
--    used for scoring (every later stage reads estimated = 0 only);
--  * drop a track as too short only when it has fewer than clean_min_points real points AND
--    its real points span less than clean_min_duration_s seconds (both `auto` by default:
--    sql/stages/calibrate.sql derives them from the measured sampling period). A point count
--    alone depends on the frame rate: at 2 Hz a pedestrian seen for 1.5 s has 3-4 points and
--    is a real road user. A track without any real point is 'estimated only';
--  * drop a track whose median speed between real points exceeds clean_max_speed (m/s): no
--    road user at an intersection moves at 70 m/s, a tracker's id swap across the view does.
-- Parameters (clean_*): declared once in crates/app/src/params.rs, defaults in sql/params.sql;
-- `trajdb params` lists them, `trajdb pipeline --param name=value` or SET VARIABLE sets them.

CREATE OR REPLACE TEMP TABLE clean_dropped AS
WITH r AS (
    SELECT camera, track_id, estimated,
           row_number() OVER (PARTITION BY camera, track_id ORDER BY t DESC) AS back
    FROM points
),
s AS (
    SELECT camera, track_id,
           sqrt((x - lag(x) OVER w) ** 2 + (y - lag(y) OVER w) ** 2) / nullif(t - lag(t) OVER w, 0) AS speed
    FROM points WHERE estimated = 0
    WINDOW w AS (PARTITION BY camera, track_id ORDER BY t)
)
SELECT camera, track_id, 'estimated tail' AS reason
FROM r WHERE back <= getvariable('clean_xi') AND getvariable('clean_drop_estimated_tails')
GROUP BY camera, track_id
HAVING count(*) = getvariable('clean_xi') AND bool_and(estimated = 1)
UNION ALL
SELECT camera, track_id, CASE WHEN count(*) FILTER (WHERE estimated = 0) = 0 THEN 'estimated only' ELSE 'too short' END
FROM points GROUP BY camera, track_id
HAVING count(*) FILTER (WHERE estimated = 0) < calibrated('clean_min_points')
   AND coalesce(max(t) FILTER (WHERE estimated = 0) - min(t) FILTER (WHERE estimated = 0), 0) < calibrated('clean_min_duration_s')
UNION ALL
SELECT camera, track_id, 'implausible speed'
FROM s GROUP BY camera, track_id
HAVING median(speed) > getvariable('clean_max_speed');

CREATE OR REPLACE TEMP TABLE points AS
SELECT p.* FROM points p ANTI JOIN clean_dropped d USING (camera, track_id);

SELECT reason, count(*) AS tracks_dropped FROM clean_dropped GROUP BY reason ORDER BY reason;
