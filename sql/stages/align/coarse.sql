-- stage: align/coarse
-- reads: points, calib_camera_order
-- makes: align_centroids, align_tracks, align_coarse
-- work: align_activity
-- changes: -
-- parameters: align_max_clock_offset_s, align_min_points
--
-- trajdb align, the coarse clock offset of every camera pair (step 0), and the tracks and centroids every later step of align
--        works on.
-- Part of the stage align (sql/stages/align.sql: the method, the files in order).

-- Each camera's centroid (the mean of its real points), the origin every vote is taken about.
-- A hypothesis (theta, tx, ty) is a rotation about the moving frame's ORIGIN: an angle error
-- dtheta moves tx, ty by |p| dtheta for points p far from it, 17 m per km (a frame in UTM or a
-- state plane, x ~ 5e5, y ~ 5.7e6, aligned no camera at all). Where the hypothesis puts the
-- moving camera's centroid, relative to the fixed camera's centroid, moves only by the view's
-- own size times dtheta, and does not change when either camera's frame is moved: hypotheses
-- vote and agree in (theta, qx, qy, dt) instead of (theta, tx, ty, dt).
-- t_origin (the camera's first real time) plays the same part for clocks: every time in this
-- stage is relative to its camera's t_origin, rounded to the microsecond, so that shifting a
-- camera's clock (by a second, a day, or a Unix epoch) gives the same numbers to the last bit
-- and changes nothing but the camera's offset (a clock an hour off once moved the refit's
-- support by one pair through the rounding of t ~ 3600 against t ~ 100; at t ~ 1.8e9 a double
-- resolves only 0.24 us). Offsets found here are between relative clocks; align_clock turns
-- them into the cameras' own clocks.
CREATE OR REPLACE TEMP TABLE align_centroids AS
SELECT camera, avg(x) AS cx, avg(y) AS cy, min(t) AS t_origin FROM points WHERE estimated = 0 GROUP BY camera;

CREATE OR REPLACE TEMP TABLE align_tracks AS
SELECT camera, track_id, class, list({'t': tr, 'x': x, 'y': y} ORDER BY tr) AS traj, min(tr) AS t0, max(tr) AS t1
FROM (SELECT p.camera, p.track_id, p.class, round((p.t - c.t_origin) * 1e6) / 1e6 AS tr, p.x, p.y
      FROM points p JOIN align_centroids c USING (camera) WHERE p.estimated = 0)
GROUP BY camera, track_id, class
HAVING count(*) >= getvariable('align_min_points');

-- 0. the coarse clock offset of every camera pair, over EVERY lag the recordings allow: the
--    cross-correlation peak of the two cameras' activity (tracks in view over time;
--    activity_lag, crates/algo/src/align/xcorr.rs). No range is assumed: a camera seconds, hours or
--    a day off, or on another epoch, is found the same way. It is coarse (a road user is in both
--    views at once only inside their overlap, so mostly one-way traffic between the views puts
--    the peak a few seconds off): step 1 searches around it, widening when needed. Bins of
--    half the first search range (the finest offset step 1 can still correct). With
--    align_max_clock_offset_s = 0 (the user says the clocks agree) the centre is 0.
CREATE OR REPLACE TEMP TABLE align_activity AS
SELECT camera, list({'t': t, 'v': v} ORDER BY t, v) AS events
FROM (SELECT camera, t0 AS t, 1.0 AS v FROM align_tracks UNION ALL SELECT camera, t1, -1.0 FROM align_tracks)
GROUP BY camera;

--    searched again, so in-range results are those of a single pass.
--    Which camera of a pair is fixed and which is moved onto it is the cameras' data order
--    (calib_camera_order: the fixed one comes first), never their ids: the fits below are not
--    exactly symmetric (interpolation goes one way, the trims differ), so fitting by id order
--    moved a pair by 0.09 deg and 5 ms when the cameras were renumbered. Every later choice of
--    this stage (votes, samples, refits) depends on the tracks' content, so with the direction
--    fixed by data the whole stage is a function of the data alone.
CREATE OR REPLACE TEMP TABLE align_coarse AS
SELECT p.cam_fixed, p.cam_moving, l.dt AS centre, l.score, l.runner_up, l.half_width_s
FROM (SELECT DISTINCT a.camera AS cam_fixed, b.camera AS cam_moving
      FROM (SELECT DISTINCT camera, class FROM align_tracks) a JOIN (SELECT DISTINCT camera, class FROM align_tracks) b
        ON a.class = b.class
      JOIN calib_camera_order ra ON ra.camera = a.camera JOIN calib_camera_order rb ON rb.camera = b.camera
      WHERE ra.data_rank < rb.data_rank) p
JOIN align_activity ea ON ea.camera = p.cam_fixed JOIN align_activity eb ON eb.camera = p.cam_moving,
-- bins of half the first search range, but at most 2^22 bins per camera (a recording of more
-- than 24 days, e.g. a month's archive, gets wider bins instead of a memory error naming a
-- bin_s the user never set); times are relative to each camera's t_origin
LATERAL (SELECT CASE WHEN getvariable('align_max_clock_offset_s') > 0
                     THEN activity_lag(ea.events, eb.events,
                                       greatest(getvariable('align_max_clock_offset_s') / 2,
                                                greatest(ea.events[-1].t, eb.events[-1].t) / 4194304)) END AS l);
