-- stage: calibrate
-- reads: points
-- makes: calib_camera_order, calib_cameras, calib_classes, calib_fit_window, calib_pairs, calibration, calibrated(),
--        calibrated_values()
-- work: -
-- changes: -
-- parameters: align_max_rms_m, align_refine_rms_m, clean_min_duration_s, clean_min_points, cluster_camera,
--             merge_min_points, merge_resample_s, quality_max_accel
--
-- trajdb pipeline, stage 1: measure the recording, then set the parameters that depend on it.
--
-- The thesis chose eps and T "by intuition rather than some metric" (section 5.2), and a
-- default tuned to one site's frame rate and noise fails on another's. Every parameter whose
-- default is `auto` (see `trajdb params`) is derived here from what the tracks themselves show;
-- a value set with --param or SET VARIABLE wins over the measurement. This file is the one place
-- where an `auto` parameter gets its value (align.sql adds merge_epsilon, which can only be
-- measured after alignment, to the same table); later stages read it, never re-derive it.
--
-- Input: `points(camera, track_id, class, t, x, y, estimated)`, each camera in its own frame
-- and clock. Output:
--   calib_cameras(camera, period_s, jitter_s, sigma_m, n_intervals, n_triples)   per camera
--   calib_classes(class, accel_p95, n)                                          per class
--   calib_fit_window(camera, class, fit_window_s)                              per camera and class
--   calib_pairs(cam_a, cam_b, sigma_pair_m)                                    per camera pair (a < b)
--   calibration(parameter, scope, cam_a, cam_b, class, measured, given, value, rule)
--       every `auto` parameter's value: given if set, else measured; scope 'pipeline', 'camera
--       pair' (cam_a < cam_b), 'class', or 'default' (where no narrower row applies)
--   the macros calibrated('name') (the run-wide value) and calibrated_values('name') (per camera
--   pair or class: cam_a, cam_b, class, value).
-- sql/stages/align.sql adds the clock offsets and the cross-camera residuals (align_frames,
-- calib_match) and merge_epsilon's rows; `calibration.csv` (sql/export.sql) and the report show
-- all of it.
--
-- What is measured, and how:
--  * sampling period: the median interval between consecutive real points of a track (robust
--    to breaks and dropped frames); jitter: the median absolute deviation of those intervals;
--  * position noise sigma: for evenly sampled smooth motion the second difference
--    p[k+1] - 2 p[k] + p[k-1] is noise with variance 6 sigma^2 per axis, so its squared length
--    is 6 sigma^2 chi2(2), whose median is 6 sigma^2 * 2 ln 2 (the median ignores manoeuvres).
--    At low frame rates real acceleration (a dt^2) adds to it: the estimate errs high, which
--    errs on the side of wider tolerances.
-- What is derived, and why:
--  * clean_min_points = 2, clean_min_duration_s = 1.5 periods: a track is dropped as too short
--    only when it has a single real point, or its real points span less than 1.5 sampling
--    periods; a point count alone would drop a real pedestrian seen for 1.5 s at 2 Hz;
--  * per camera pair, sigma_pair = sqrt(sigma_a^2 + sigma_b^2): a true hypothesis of align.sql
--    leaves residuals of about sigma_pair per axis, so it votes when its RMS is under
--    align_max_rms_m = 0.1 + 3 sigma_pair (noise_align_vote_rms), and is kept in the refit under
--    align_refine_rms_m = 0.05 + 2 sigma_pair (noise_align_refine_rms) (road users walking side by side, 0.7 m apart, are
--    refused while sigma_pair stays under ~0.3 m). The constants 0.1 / 0.05 m cover the
--    interpolation and clock-grid error of a hypothesis;
--  * merge_min_points (LCSS xi) = 2 real samples of the slowest camera on the common clock:
--    ceil(period_max / merge_resample_s) + 1, at least 3;
--  * quality_max_accel, per class: the 95th percentile acceleration of the class's tracks
--    (resampled to 1 s steps); a broken piece may resume that much farther from where its
--    track would be at constant velocity (accel * gap^2 / 2);
--  * merge_epsilon is derived after alignment, per camera pair, from the residuals of the
--    matched tracks themselves (align.sql, calib_match).
--  * the association gates (docs/association.md) are all derived from these measurements, none
--    is a fixed distance: cross-camera candidates (merge.sql) are tested with a chi2 bound on the
--    mean squared distance over their whole common time against the pair's residual sigma
--    (calib_match.sigma_d_m), counting one independent sample per period_s of the slower camera;
--    within-camera break links (quality.sql) extrapolate least-squares lines fitted over
--    calib_fit_window.fit_window_s with the camera's sigma_m, allow the class's accel_p95 during the
--    gap, and compare a link with an unrelated start by the measured density of starts.

-- Camera ids are labels: every choice the stages make between cameras (which camera of a pair
-- is fitted onto which, the reference camera, the spanning tree's ties, the merge order, the
-- cluster camera, road-user numbering) goes by this order, which the cameras' DATA gives, so
-- renumbering the cameras ((camera + 1) % 3, text ids) changes nothing but the labels
-- (tests/test_invariance_python.py). The key: more real points first, then more tracks, then
-- the longer total track time (ms; a clock shift or a moved frame leaves all three unchanged).
-- The camera id decides only between cameras equal in all three (in practice a camera and its
-- exact copy, which the load has already dropped: sql/pipeline.sql, load_twins).
CREATE OR REPLACE TEMP TABLE calib_camera_order AS
SELECT camera, row_number() OVER (ORDER BY n_points DESC, n_tracks DESC, total_ms DESC, camera) AS data_rank, n_points, n_tracks, total_ms
FROM (SELECT camera, sum(n)::BIGINT AS n_points, count(*) AS n_tracks, sum(round((t1 - t0) * 1000))::BIGINT AS total_ms
      FROM (SELECT camera, track_id, count(*) AS n, min(t) AS t0, max(t) AS t1 FROM points WHERE estimated = 0 GROUP BY camera, track_id)
      GROUP BY camera);

CREATE OR REPLACE TEMP TABLE calib_cameras AS
WITH d AS (
    SELECT camera,
           t - lag(t) OVER w AS dt1, lag(t) OVER w - lag(t, 2) OVER w AS dt2,
           x - 2 * lag(x) OVER w + lag(x, 2) OVER w AS ax, y - 2 * lag(y) OVER w + lag(y, 2) OVER w AS ay
    FROM points WHERE estimated = 0 AND isfinite(t) AND isfinite(x) AND isfinite(y)
    WINDOW w AS (PARTITION BY camera, track_id ORDER BY t)
),
p AS (SELECT camera, median(dt1) AS period_s FROM d WHERE dt1 > 0 GROUP BY camera)
-- one pass over the intervals for every per-camera figure (even triples: both intervals within
-- a quarter period of each other, none longer than 1.5 periods)
SELECT camera, period_s,
       median(abs(dt1 - period_s)) AS jitter_s,
       noise_sigma_from_second_differences(median(ax * ax + ay * ay) FILTER (WHERE even)) AS sigma_m,
       count(*) AS n_intervals,
       count(*) FILTER (WHERE even) AS n_triples
FROM (SELECT d.*, p.period_s, abs(d.dt1 - d.dt2) <= 0.25 * p.period_s AND d.dt1 <= 1.5 * p.period_s AS even
      FROM d JOIN p USING (camera) WHERE d.dt1 > 0)
GROUP BY camera, period_s;

CREATE OR REPLACE TEMP TABLE calib_classes AS
WITH r AS (
    -- resampled on a grid anchored at the camera's first time, not at t = 0: shifting a clock by
    -- 0.3 s must not change what is measured (tests/test_invariance_python.py)
    SELECT class, traj_resample(list({'t': t - t_first, 'x': x, 'y': y} ORDER BY t), 1.0, 1.5) AS tr
    FROM (SELECT *, min(t) OVER (PARTITION BY camera) AS t_first
          FROM points WHERE estimated = 0 AND isfinite(t) AND isfinite(x) AND isfinite(y))
    GROUP BY camera, track_id, class
),
a AS (
    SELECT class, unnest([sqrt((tr[k + 1].x - 2 * tr[k].x + tr[k - 1].x) ** 2 + (tr[k + 1].y - 2 * tr[k].y + tr[k - 1].y) ** 2)
                          / ((tr[k + 1].t - tr[k].t) * (tr[k].t - tr[k - 1].t))
                          FOR k IN range(2, len(tr))
                          IF tr[k + 1].t - tr[k - 1].t < 2.5]) AS accel
    FROM r WHERE len(tr) >= 3
)
SELECT class, quantile_cont(accel, 0.95) AS accel_p95, count(*) AS n
FROM a GROUP BY class;

-- the velocity window of quality.sql's break links, per camera and class: a least-squares line
-- over the last (first) W seconds of a track has velocity variance 12 sigma^2 period / W^3 per
-- axis, and a road user accelerating at sigma_acc = accel_p95 / 2.45 (Rayleigh: p95 = 2.45 sigma)
-- biases it by about sigma_acc W / 2; the sum is least at W^5 = 72 sigma^2 period / sigma_acc^2.
-- At least 3 periods (a slope and its scatter need 3 points). Pedestrians at 10 Hz, sigma 0.3 m:
-- 1.1 s; at 2 Hz: 1.6 s; cars (accel_p95 ~ 4 m/s^2) at 10 Hz, sigma 0.1 m: 0.5 s.
CREATE OR REPLACE TEMP TABLE calib_fit_window AS
SELECT c.camera, k.class,
       noise_velocity_window_s(coalesce(c.sigma_m, 0.0), c.period_s, coalesce(noise_sigma_from_rayleigh_p95(k.accel_p95), 0.0)) AS fit_window_s
FROM calib_cameras c CROSS JOIN calib_classes k
WHERE c.period_s > 0;

CREATE OR REPLACE TEMP TABLE calib_pairs AS
SELECT a.camera AS cam_a, b.camera AS cam_b,
       sqrt(coalesce(a.sigma_m, 0) ** 2 + coalesce(b.sigma_m, 0) ** 2) AS sigma_pair_m
FROM calib_cameras a JOIN calib_cameras b ON a.camera < b.camera;

-- THE value of every `auto` parameter, resolved once: `given` (--param / SET VARIABLE) if set,
-- else `measured`, one row per parameter and scope:
--   scope 'pipeline'     one value for the whole run (listed in calibration.csv)
--   scope 'camera pair'  per camera pair cam_a < cam_b
--   scope 'class'        per class
--   scope 'default'      the value where no row of a narrower scope applies
-- Later stages never re-derive a value: they read calibrated('name') (the 'pipeline' or
-- 'default' row) or join calibrated_values('name') (the per pair / per class rows), falling back
-- to calibrated('name') where a class has no row of its own. align.sql adds the rows that can
-- only be measured after alignment (merge_epsilon, from the matched tracks' residuals).
CREATE OR REPLACE TEMP TABLE calibration AS
SELECT parameter, scope, cam_a, cam_b, class, measured, given, coalesce(given, measured) AS value, rule
FROM (
    SELECT parameter, 'pipeline' AS scope, NULL::INTEGER AS cam_a, NULL::INTEGER AS cam_b, NULL::VARCHAR AS class,
           measured::DOUBLE AS measured, given::DOUBLE AS given, rule
    FROM (VALUES
        ('clean_min_points', 2.0, getvariable('clean_min_points')::DOUBLE, 'a single real point shows no motion'),
        ('clean_min_duration_s', 1.5 * (SELECT max(period_s) FROM calib_cameras), getvariable('clean_min_duration_s'),
         '1.5 x the longest sampling period'),
        ('merge_min_points', greatest(3, ceil((SELECT max(period_s) FROM calib_cameras) / nullif(getvariable('merge_resample_s'), 0)) + 1),
         getvariable('merge_min_points')::DOUBLE, '2 real samples of the slowest camera on the common clock, at least 3'),
        ('cluster_camera', (SELECT camera FROM calib_camera_order ORDER BY n_tracks DESC, data_rank LIMIT 1),
         getvariable('cluster_camera')::DOUBLE, 'the camera with the most real tracks (ties: the first in calib_camera_order, by data)')
    ) t(parameter, measured, given, rule)
    UNION ALL
    SELECT 'align_max_rms_m', 'camera pair', cam_a, cam_b, NULL, noise_align_vote_rms(sigma_pair_m), getvariable('align_max_rms_m'), '0.1 + 3 sigma_pair (noise_align_vote_rms)'
    FROM calib_pairs
    UNION ALL
    SELECT 'align_refine_rms_m', 'camera pair', cam_a, cam_b, NULL, noise_align_refine_rms(sigma_pair_m), getvariable('align_refine_rms_m'), '0.05 + 2 sigma_pair (noise_align_refine_rms)'
    FROM calib_pairs
    UNION ALL
    SELECT 'quality_max_accel', 'class', NULL, NULL, class, accel_p95, getvariable('quality_max_accel'),
           'tracks resampled to 1 s, 95th percentile of |second difference|'
    FROM calib_classes
    UNION ALL
    SELECT 'quality_max_accel', 'default', NULL, NULL, NULL, 0.0, getvariable('quality_max_accel'),
           'a class without a measurement: no acceleration allowance'
);

-- the value a stage uses, for the whole run: the 'pipeline' (or 'default') row
CREATE OR REPLACE TEMP MACRO calibrated(name) AS
    (SELECT value FROM calibration WHERE parameter = name AND cam_a IS NULL AND class IS NULL);

-- the values per camera pair (cam_a < cam_b) or per class
CREATE OR REPLACE TEMP MACRO calibrated_values(name) AS TABLE
    SELECT cam_a, cam_b, class, value FROM calibration WHERE parameter = name AND (cam_a IS NOT NULL OR class IS NOT NULL);

SELECT camera, round(period_s, 4) AS period_s, round(jitter_s, 4) AS jitter_s, round(sigma_m, 3) AS sigma_m, n_intervals
FROM calib_cameras ORDER BY camera;
