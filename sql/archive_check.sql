-- trajdb: an archive's daily check of its kept calibration (issue 40; src/archive/task.rs runs it
-- after a day's run on the site's kept calibration: docs/archive.md).
--
-- A camera knocked by a truck or re-aimed after maintenance changes its frame (or its clock)
-- from one day to the next; the kept calibration would then align it with last week's answer.
-- The day's own matches say whether it still holds: each camera pair is registered again on the
-- day's matched tracks (register_pair, the model of align.sql's final registration: a viewpoint
-- offset per track pair, rotation within pairs, the clock searched within 4 vote bins), in the
-- cameras' own frames on the kept clocks. The moving camera's points are centred on an anchor
-- (the centroid of its matched points on the calibration day) and the fixed camera's on where
-- the kept transform puts the anchor, so the fitted translation IS how far the anchor lands
-- from where the kept calibration puts it (no lever arm from a frame's far origin), and the
-- kept transform is (theta_kept, 0, 0) in those coordinates.
--
-- The same is measured on the calibration day (archive_baseline): the difference between a
-- day's numbers and the calibration day's, in the two fits' standard errors (quadrature), is
-- frame_change's test (crates/algo/src/align/frame_change.rs; threshold archive_change_z). The
-- constant difference between this registration on matches and align.sql's on voted pairs
-- cancels. A pair with fewer than 8 matched track pairs is not tested (too few to fit); the
-- standard errors are block jackknife estimates (at most 16 blocks of track pairs), so the test
-- takes their degrees of freedom from the smaller fit's pairs (Student's t, not the normal:
-- frame_change's `pairs`).
-- A pair whose matches collapse (fewer than a quarter of the calibration day's rate per road
-- user, when that rate predicts at least 20) is `lost`: a camera moved so far that the kept
-- calibration no longer matches anything (a clock off by more than the search, a view turned).
--
-- Input: a day's run (points: every camera's own frame on the reference clock; merge_links,
--        merge_tracks, merge_groups, align_frames, align_origin, calib_cameras, load_ids);
--        archive_baseline(cam_fixed, cam_moving, ax, ay, d_theta, d_x, d_y, d_dt, se_theta, se_x,
--        se_y, se_dt, pairs_per_user, fit_pairs), made by the host: the calibration day's rows (empty ON
--        that day: then the anchor is today's centroid and nothing is tested).
-- Output: archive_check(cam_fixed, cam_moving, pairs (all matched), ax, ay, d_theta, d_x, d_y, d_dt,
--         se_theta, se_x, se_y, se_dt, pairs_per_user, fit_pairs (those in the fit), expected_pairs,
--         change, lost, changed)
--         (stage camera numbers), archive_new_cameras(camera): cameras the calibration never saw;
--         the views the host reads (by camera name): archive_names, archive_baseline_out,
--         archive_changes, archive_checks, archive_cleared.

-- At most 400 matched track pairs per camera pair take part: a hash sample (by the pair's ids:
-- the same pairs on every run), as align.sql samples a long day's hypotheses. 400 pairs fix a
-- rotation and a position far better than the kept calibration's own errors, and keep the
-- clock search's work (shifts x points) within register_pair's limit on a 12-hour day (all of
-- a Mellingen day's 7,000 pairs: 2.1e8 point-pair fits). pairs_per_user counts them all.
CREATE OR REPLACE TEMP TABLE archive_matched AS
SELECT least(ta.camera, tb.camera) AS cam_fixed, greatest(ta.camera, tb.camera) AS cam_moving,
       CASE WHEN ta.camera < tb.camera THEN ta.track_id ELSE tb.track_id END AS track_fixed,
       CASE WHEN ta.camera < tb.camera THEN tb.track_id ELSE ta.track_id END AS track_moving,
       ta.class
FROM merge_links m
JOIN merge_tracks ta ON ta.uid = m.uid_a JOIN merge_tracks tb ON tb.uid = m.uid_b
JOIN merge_groups ga ON ga.uid = m.uid_a JOIN merge_groups gb ON gb.uid = m.uid_b
WHERE ga.road_user = gb.road_user AND m.kind <> 'reach' AND ta.camera <> tb.camera;

CREATE OR REPLACE TEMP TABLE archive_pairs AS
FROM archive_matched
QUALIFY row_number() OVER (PARTITION BY cam_fixed, cam_moving ORDER BY hash(track_fixed, track_moving), track_fixed, track_moving) <= 400;

-- every matched track's real points, in its camera's own frame, on the reference clock made
-- relative to the common clock's origin (seconds of the day, not 1.8e9)
CREATE OR REPLACE TEMP TABLE archive_tracks AS
SELECT p.camera, p.track_id, list({'t': p.t - o.clock_origin, 'x': p.x, 'y': p.y} ORDER BY p.t) AS traj
FROM points p CROSS JOIN align_origin o
WHERE p.estimated = 0
  AND ((p.camera, p.track_id) IN (SELECT (cam_fixed, track_fixed) FROM archive_pairs)
       OR (p.camera, p.track_id) IN (SELECT (cam_moving, track_moving) FROM archive_pairs))
GROUP BY p.camera, p.track_id;

-- the kept transform moving -> fixed, and the anchor (the calibration day's, else today's centroid)
CREATE OR REPLACE TEMP TABLE archive_anchor AS
WITH pairs AS (SELECT DISTINCT cam_fixed, cam_moving FROM archive_pairs
               UNION SELECT cam_fixed, cam_moving FROM archive_baseline),
today AS (
    SELECT a.cam_fixed, a.cam_moving, avg(q.x) AS cx, avg(q.y) AS cy
    FROM archive_pairs a JOIN archive_tracks m ON m.camera = a.cam_moving AND m.track_id = a.track_moving, unnest(m.traj) AS u(q)
    GROUP BY ALL
)
SELECT p.cam_fixed, p.cam_moving,
       transform_compose(transform_invert(ff.to_reference), fm.to_reference) AS kept,
       coalesce(b.ax, t.cx) AS ax, coalesce(b.ay, t.cy) AS ay
FROM pairs p
JOIN align_frames ff ON ff.camera = p.cam_fixed JOIN align_frames fm ON fm.camera = p.cam_moving
LEFT JOIN archive_baseline b USING (cam_fixed, cam_moving)
LEFT JOIN today t USING (cam_fixed, cam_moving);

CREATE OR REPLACE TEMP TABLE archive_fit AS
WITH a AS (
    SELECT *, transform_point(kept, ax, ay) AS f0 FROM archive_anchor WHERE ax IS NOT NULL
),
x AS (
    SELECT a.cam_fixed, a.cam_moving, p.class,
           [{'t': q.t, 'x': q.x - a.f0.x, 'y': q.y - a.f0.y} FOR q IN tf.traj] AS traj_fixed,
           [{'t': q.t, 'x': q.x - a.ax, 'y': q.y - a.ay} FOR q IN tm.traj] AS traj_moving,
           least(tf.traj[1].t, tm.traj[1].t) AS t0, p.track_fixed, p.track_moving
    FROM archive_pairs p JOIN a USING (cam_fixed, cam_moving)
    JOIN archive_tracks tf ON tf.camera = p.cam_fixed AND tf.track_id = p.track_fixed
    JOIN archive_tracks tm ON tm.camera = p.cam_moving AND tm.track_id = p.track_moving
),
codes AS (SELECT class, row_number() OVER (ORDER BY class) AS code FROM (SELECT DISTINCT class FROM x))
SELECT x.cam_fixed, x.cam_moving, count(*) AS pairs,
       CASE WHEN count(*) >= 8 THEN
           register_pair(list(x.traj_fixed ORDER BY x.t0, x.track_fixed, x.track_moving),
                         list(x.traj_moving ORDER BY x.t0, x.track_fixed, x.track_moving),
                         list(c.code ORDER BY x.t0, x.track_fixed, x.track_moving),
                         0.0, 0.5, getvariable('align_trim'), any_value(cf.sigma_m), any_value(cm.sigma_m),
                         4 * getvariable('align_bin_s'), getvariable('align_clock_step_s'),
                         list(class_length_m(x.class) ORDER BY x.t0, x.track_fixed, x.track_moving)) END AS reg
FROM x JOIN codes c ON c.class IS NOT DISTINCT FROM x.class
JOIN calib_cameras cf ON cf.camera = x.cam_fixed JOIN calib_cameras cm ON cm.camera = x.cam_moving
GROUP BY x.cam_fixed, x.cam_moving;

CREATE OR REPLACE TEMP TABLE archive_check AS
WITH users AS (SELECT count(DISTINCT road_user) AS n FROM merge_groups),
d AS (
    SELECT a.cam_fixed, a.cam_moving, coalesce(n.pairs, 0) AS pairs, a.ax, a.ay,
           -- the rotation's difference from the kept one, wrapped into (-pi, pi]
           f.reg.theta - a.kept.theta - 2 * pi() * round((f.reg.theta - a.kept.theta) / (2 * pi())) AS d_theta,
           f.reg.tx AS d_x, f.reg.ty AS d_y, f.reg.dt AS d_dt,
           f.reg.se_theta, f.reg.se_tx AS se_x, f.reg.se_ty AS se_y, f.reg.se_dt,
           coalesce(n.pairs, 0) / greatest((SELECT n FROM users), 1) AS pairs_per_user,
           CASE WHEN f.reg IS NOT NULL THEN f.pairs END AS fit_pairs
    FROM archive_anchor a LEFT JOIN archive_fit f USING (cam_fixed, cam_moving)
    LEFT JOIN (SELECT cam_fixed, cam_moving, count(*) AS pairs FROM archive_matched GROUP BY ALL) n USING (cam_fixed, cam_moving)
)
SELECT *, coalesce(change.changed, false) OR coalesce(lost, false) AS changed
FROM (
    SELECT d.*,
           b.pairs_per_user * (SELECT n FROM users) AS expected_pairs,
           -- (a part without a value is NaN, not NULL: frame_change leaves it untested)
           -- (the rotations' difference wrapped into (-pi, pi] again)
           frame_change(coalesce(d.d_theta - b.d_theta - 2 * pi() * round((d.d_theta - b.d_theta) / (2 * pi())), 'nan'),
                        coalesce(sqrt(d.se_theta ** 2 + b.se_theta ** 2), 'nan'),
                        coalesce(d.d_x - b.d_x, 'nan'), coalesce(sqrt(d.se_x ** 2 + b.se_x ** 2), 'nan'),
                        coalesce(d.d_y - b.d_y, 'nan'), coalesce(sqrt(d.se_y ** 2 + b.se_y ** 2), 'nan'),
                        coalesce(d.d_dt - b.d_dt, 'nan'), coalesce(sqrt(d.se_dt ** 2 + b.se_dt ** 2), 'nan'),
                        getvariable('archive_change_z'),
                        -- the smaller fit's pairs (a calibration kept before fit_pairs was
                        -- recorded: today's alone)
                        coalesce(least(d.fit_pairs, coalesce(b.fit_pairs, d.fit_pairs))::DOUBLE, 'nan'::DOUBLE)) AS change,
           b.cam_fixed IS NOT NULL AND b.pairs_per_user * (SELECT n FROM users) >= 20
               AND d.pairs < b.pairs_per_user * (SELECT n FROM users) / 4 AS lost
    FROM d LEFT JOIN archive_baseline b USING (cam_fixed, cam_moving)
);

-- cameras the calibration never saw (calib_cameras: every camera of the calibration day)
CREATE OR REPLACE TEMP TABLE archive_new_cameras AS
SELECT DISTINCT camera FROM points WHERE camera NOT IN (SELECT camera FROM calib_cameras);

-- What the host reads of the check (src/archive/task.rs), by camera name (load_ids: the input's ids):
-- archive_names(camera, name)
CREATE OR REPLACE TEMP VIEW archive_names AS SELECT DISTINCT camera, camera_in::VARCHAR AS name FROM load_ids;

-- the baseline a calibration made today keeps: its rows, in archive_baseline's columns
CREATE OR REPLACE TEMP VIEW archive_baseline_out AS
SELECT cam_fixed::INTEGER AS cam_fixed, cam_moving::INTEGER AS cam_moving, ax, ay, d_theta, d_x, d_y, d_dt,
       se_theta, se_x, se_y, se_dt, pairs_per_user::DOUBLE AS pairs_per_user, fit_pairs::BIGINT AS fit_pairs
FROM archive_check WHERE d_theta IS NOT NULL ORDER BY cam_fixed, cam_moving;

-- the changed pairs (the changes' fields of crates/app/src/archive/change.rs), then the new cameras
CREATE OR REPLACE TEMP VIEW archive_changes AS
SELECT * FROM (
    SELECT 0 AS k, c.cam_fixed AS o1, c.cam_moving AS o2, CASE WHEN c.lost THEN 'lost' ELSE 'moved' END AS kind,
           a.name AS camera_fixed, b.name AS camera_moving, c.pairs::BIGINT AS pairs, round(c.expected_pairs, 1)::DOUBLE AS expected_pairs,
           round(degrees(c.d_theta - coalesce(bl.d_theta, 0)), 3)::DOUBLE AS turned_deg,
           round(sqrt((c.d_x - coalesce(bl.d_x, 0)) ** 2 + (c.d_y - coalesce(bl.d_y, 0)) ** 2), 3)::DOUBLE AS moved_m,
           round(c.d_dt - coalesce(bl.d_dt, 0), 4)::DOUBLE AS clock_s, round(c.change.z, 1)::DOUBLE AS z
    FROM archive_check c LEFT JOIN archive_baseline bl USING (cam_fixed, cam_moving)
    JOIN archive_names a ON a.camera = c.cam_fixed JOIN archive_names b ON b.camera = c.cam_moving
    WHERE c.changed
    UNION ALL
    SELECT 1, 0, 0, 'new camera', NULL, n.name, NULL, NULL, NULL, NULL, NULL, NULL
    FROM archive_new_cameras c JOIN archive_names n USING (camera)
) ORDER BY k, o1, o2, camera_moving;

-- every tested pair's figures (the state's checks)
CREATE OR REPLACE TEMP VIEW archive_checks AS
SELECT a.name || '-' || b.name AS cameras, c.pairs::BIGINT AS pairs, round(c.change.z, 2)::DOUBLE AS z, round(c.change.z_theta, 2)::DOUBLE AS z_theta,
       round(c.change.z_pos, 2)::DOUBLE AS z_pos, round(c.change.z_clock, 2)::DOUBLE AS z_clock, c.lost
FROM archive_check c JOIN archive_names a ON a.camera = c.cam_fixed JOIN archive_names b ON b.camera = c.cam_moving
ORDER BY c.cam_fixed, c.cam_moving;

-- the pairs that were tested and did not change (they clear their cameras)
CREATE OR REPLACE TEMP VIEW archive_cleared AS
SELECT a.name AS camera_fixed, b.name AS camera_moving
FROM archive_check c JOIN archive_names a ON a.camera = c.cam_fixed JOIN archive_names b ON b.camera = c.cam_moving
WHERE NOT c.changed AND c.change IS NOT NULL;
