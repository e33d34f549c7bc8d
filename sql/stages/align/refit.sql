-- stage: align/refit
-- reads: calib_camera_order, calib_cameras, calibrated_values(), align_tracks, align_scan, align_hyp, align_best
-- makes: align_support, align_transform(), align_refit(), align_pairs, align_drift, align_offset_se
-- work: align_drift_pairs, align_drift_obs, align_drift_fitted, align_drift_kept
-- changes: align_best
-- parameters: align_agree_deg, align_agree_m, align_bin_s, align_clock_step_s, align_min_pairs, align_min_support,
--             align_refine_rms_m, align_trim
--
-- trajdb align, the joint refit of the agreeing track pairs, the clock drift and the clock offset's standard error (steps 3, 3b).
-- Part of the stage align (sql/stages/align.sql: the method, the files in order).

-- 3. the agreeing hypotheses at the winning shift (angle difference wrapped to [-180, 180)) are
--    the pre-matched track pairs: same road user in both cameras, found without any coordinates
--    or clock in common.
CREATE OR REPLACE TEMP TABLE align_support AS
SELECT h.cam_fixed, h.cam_moving, h.track_fixed, h.track_moving, a.traj AS traj_fixed, m.traj AS traj_moving
FROM align_hyp h JOIN align_best b USING (cam_fixed, cam_moving)
JOIN align_tracks a ON a.camera = h.cam_fixed AND a.track_id = h.track_fixed
JOIN align_tracks m ON m.camera = h.cam_moving AND m.track_id = h.track_moving
WHERE abs(h.dt - b.dt) < 0.5 * getvariable('align_bin_s')
  AND abs(angle_wrap_deg(degrees(h.theta) - b.theta_deg)) <= getvariable('align_agree_deg')
  AND abs(h.qx - b.qx) <= getvariable('align_agree_m') AND abs(h.qy - b.qy) <= getvariable('align_agree_m');

--    refit all their tracks together at every shift within four vote bins of the winner, on a
--    grid of align_clock_step_s (rigid_fit_shifted; where most road users walk straight the
--    vote's peak is flat, 24 against 23 votes on the shared intersection's cameras 0-1, and a
--    refit within one bin of it settled 30-65 ms off; within four, 6 ms): tracks in several directions pin the
--    offset that a single straight track leaves open. Trims the worst align_trim of the pairs;
--    each squared residual is weighted by the two cameras' measured noise (calib_cameras) so
--    that interpolated pairs do not pull the offset towards the half-sample phase. The same
--    refit (align_refit) runs again after the second pass below, on the kept pairs.
--    The transform of a fit (rigid_fit_shifted's, register_pair's: dt, theta, tx, ty, scale, ...) as
--    the transform functions take it: the one place that spells it out.
CREATE OR REPLACE TEMP MACRO align_transform(fit) AS {'theta': fit.theta, 'tx': fit.tx, 'ty': fit.ty, 'scale': fit.scale};

CREATE OR REPLACE TEMP MACRO align_refit() AS TABLE
SELECT s.cam_fixed, s.cam_moving,
       rigid_fit_shifted(list(s.traj_fixed ORDER BY s.traj_fixed[1].t, s.traj_moving[1].t, s.track_fixed, s.track_moving),
                         list(s.traj_moving ORDER BY s.traj_fixed[1].t, s.traj_moving[1].t, s.track_fixed, s.track_moving),
                         any_value(b.dt), 4 * getvariable('align_bin_s'), getvariable('align_clock_step_s'),
                         0.5, getvariable('align_trim'), any_value(cf.sigma_m), any_value(cm.sigma_m)) AS fit,
       count(*) AS support
FROM align_support s JOIN align_best b USING (cam_fixed, cam_moving)
JOIN calib_cameras cf ON cf.camera = s.cam_fixed JOIN calib_cameras cm ON cm.camera = s.cam_moving
GROUP BY s.cam_fixed, s.cam_moving
HAVING count(*) >= getvariable('align_min_support');

CREATE OR REPLACE TEMP TABLE align_pairs AS FROM align_refit();

-- 3b. clock drift. A camera clock running fast or slow by tens to hundreds of ppm (0.36 s over
--    30 minutes at 200 ppm) fits no single offset: the clock model of a camera pair is
--    t_moving = (1 + D) t_fixed + O. With the transform of the first refit KNOWN, every
--    candidate track pair (its hypothesis agrees with the winner in rotation and position, at
--    any offset) has its own offset (rigid_shift_under: even a straight track pins it, since a
--    shift slides the road user along the road), with a standard error from the residual's
--    curvature; D is the slope of those offsets against time, by weighted least squares (1/se^2),
--    refitted once without the pairs beyond 3 robust standard deviations (a wrong pair of two
--    people side by side). D is used only where the recording shows it: at least 8 pairs and
--    |D| > 5 x its standard error (the larger of least squares' and the block jackknife's; 5,
--    not 3: with 21 camera pairs of 7 cameras a 3-sigma test let a false 134 ppm through); otherwise D = 0 and everything below is exactly as without
--    this step. The search per pair reaches as far as the pair's offset search did
--    (max_off of its last pass), so the drift a recording can show is measured, not bounded by
--    a constant.
CREATE OR REPLACE TEMP TABLE align_drift_pairs AS
WITH cand AS (
    SELECT DISTINCT h.cam_fixed, h.cam_moving, h.track_fixed, h.track_moving
    FROM align_hyp h JOIN align_best b USING (cam_fixed, cam_moving)
    WHERE abs(angle_wrap_deg(degrees(h.theta) - b.theta_deg)) <= getvariable('align_agree_deg')
      AND abs(h.qx - b.qx) <= getvariable('align_agree_m') AND abs(h.qy - b.qy) <= getvariable('align_agree_m')
),
coarse AS (
    SELECT c.*, a.traj AS traj_fixed, m.traj AS traj_moving, (a.t0 + a.t1) / 2 AS x, cp.value AS gate,
           align_transform(p.fit) AS tf,
           rigid_shift_under(a.traj, m.traj, align_transform(p.fit),
                             p.fit.dt, s.max_off, getvariable('align_bin_s'), 0.5, getvariable('align_min_pairs')) AS r
    FROM cand c JOIN align_pairs p USING (cam_fixed, cam_moving)
    JOIN (SELECT cam_fixed, cam_moving, max(max_off) AS max_off FROM align_scan GROUP BY ALL) s USING (cam_fixed, cam_moving)
    JOIN align_tracks a ON a.camera = c.cam_fixed AND a.track_id = c.track_fixed
    JOIN align_tracks m ON m.camera = c.cam_moving AND m.track_id = c.track_moving
    JOIN calibrated_values('align_refine_rms_m') cp ON cp.cam_a = least(c.cam_fixed, c.cam_moving) AND cp.cam_b = greatest(c.cam_fixed, c.cam_moving)
    WHERE p.fit IS NOT NULL
)
SELECT cam_fixed, cam_moving, track_fixed, track_moving, x, traj_fixed, traj_moving,
       rigid_shift_under(traj_fixed, traj_moving, tf, r.dt, getvariable('align_bin_s'), getvariable('align_clock_step_s'), 0.5,
                         getvariable('align_min_pairs')) AS r, gate
FROM coarse
WHERE r IS NOT NULL AND NOT r.at_edge AND r.rms < gate;

CREATE OR REPLACE TEMP TABLE align_drift_obs AS
SELECT cam_fixed, cam_moving, track_fixed, track_moving, x, r.dt AS y, 1 / greatest(r.se, getvariable('align_clock_step_s')) ** 2 AS w
FROM align_drift_pairs WHERE isfinite(r.se);

--    The fit is one named function (clock_drift_fit, crates/algo/src/align/drift_fit.rs: the
--    weighted line, the 3-robust-sigma refit, the least-squares and the 8-block jackknife
--    standard errors, the larger deciding). The least-squares standard error alone assumes
--    independent pairs; road users seen close in time share biases (the same crowd, the same
--    interpolation at 2 Hz), which a 5-minute 2 Hz crowd without any drift turned into a
--    '134 ppm +- 17' drift. The pairs go in time order (the jackknife's blocks are spans of the
--    recording), ties broken by the track ids, so that the fit does not depend on the threads.
CREATE OR REPLACE TEMP TABLE align_drift_fitted AS
SELECT cam_fixed, cam_moving,
       list({'track_fixed': track_fixed, 'track_moving': track_moving, 'x': x, 'y': y, 'w': w} ORDER BY x, y, track_fixed, track_moving) AS obs,
       clock_drift_fit(list({'x': x, 'y': y, 'w': w} ORDER BY x, y, track_fixed, track_moving)) AS f
FROM align_drift_obs GROUP BY cam_fixed, cam_moving;

-- the pairs the outlier test kept (unnest of two lists of one length: element by element)
CREATE OR REPLACE TEMP TABLE align_drift_kept AS
SELECT cam_fixed, cam_moving, o.track_fixed, o.track_moving, o.x, o.y, o.w, r.z
FROM (SELECT cam_fixed, cam_moving, unnest(obs) AS o, unnest(f) AS r FROM align_drift_fitted WHERE f IS NOT NULL)
WHERE r.kept;

CREATE OR REPLACE TEMP TABLE align_drift AS
SELECT cam_fixed, cam_moving, f[1].n AS n, f[1].x_span AS x_span, f[1].slope AS drift_fit, f[1].intercept AS intercept,
       f[1].se AS drift_se, f[1].sw AS sw, f[1].swx AS swx, f[1].swy AS swy, f[1].usable AS usable
FROM align_drift_fitted WHERE f IS NOT NULL;

--    One drift per camera (clock_network, crates/algo/src/align/clock_network.rs): every camera
--    pair with at least 8 pairs measures the difference of its two cameras' drifts; the cameras'
--    drifts are their weighted least-squares solution (the camera with the most support in the first refit, as step 4 chooses its reference,
--    at 0; a group of cameras apart from it at its own first camera), used when the recording shows drift at all (the cameras' drifts against 0 beyond the
--    5-sigma level, one test for all: a single pair's rule was |D| > 5 se). A pair's drift is then
--    the difference of its cameras', and its intercept the weighted mean of its pairs' offsets
--    about that slope. (Each pair on its own, with the tree of step 4 composing them, left a 4-camera
--    recording with 200 ppm clocks at 0 ppm everywhere, 76 ms off at its end: two of six pairs
--    passed |D| > 5 se, neither on the tree.)
CREATE OR REPLACE TEMP TABLE align_drift AS
WITH ref AS (
    SELECT camera FROM (SELECT cam_moving AS camera, support FROM align_pairs UNION ALL SELECT cam_fixed, support FROM align_pairs) e
    JOIN calib_camera_order o USING (camera)
    GROUP BY camera ORDER BY sum(support) DESC, any_value(o.data_rank) LIMIT 1
),
-- (the cameras by their data rank, calib_camera_order: camera ids are labels, and the sums run
-- in the same order whatever they are)
net AS (
    SELECT unnest(clock_network(list({'fixed': rf.data_rank, 'moving': rm.data_rank, 'value': d.drift_fit, 'se': d.drift_se} ORDER BY rf.data_rank, rm.data_rank),
                                (SELECT o.data_rank FROM ref JOIN calib_camera_order o USING (camera)))) AS c
    FROM align_drift d JOIN calib_camera_order rf ON rf.camera = d.cam_fixed JOIN calib_camera_order rm ON rm.camera = d.cam_moving
    WHERE d.usable AND isfinite(d.drift_fit)
),
cam AS (
    SELECT o.camera, CASE WHEN n.c.shown THEN n.c.value ELSE 0.0 END AS d, n.c.se AS se
    FROM net n JOIN calib_camera_order o ON o.data_rank = n.c.camera
)
SELECT d.cam_fixed, d.cam_moving, d.n, d.x_span, d.drift_fit, d.drift_se,
       coalesce(m.d, 0.0) - coalesce(f.d, 0.0) AS drift,
       -- the drift's standard error from the network (the two cameras' se, their covariance left out)
       sqrt(coalesce(m.se, 0.0) ** 2 + coalesce(f.se, 0.0) ** 2) AS drift_net_se,
       (d.swy - (coalesce(m.d, 0.0) - coalesce(f.d, 0.0)) * d.swx) / d.sw AS intercept
FROM align_drift d LEFT JOIN cam m ON m.camera = d.cam_moving LEFT JOIN cam f ON f.camera = d.cam_fixed;

--    The clock offset's standard error (issue 38: a time shift along the main flow looks like a
--    translation, and a camera pair whose road users mostly walk or drive one way cannot pin
--    it): every candidate pair's own offset (align_drift_kept, with the drift line's slope
--    removed) is a measurement of it; the standard error is the larger of the weighted mean's
--    (1 / sqrt(sum of weights)) and the jackknife's over 8 blocks of the recording (road users
--    seen close in time share their errors). NULL with fewer than 4 blocks. calibration.csv
--    reports it; sql/warnings.sql warns when it exceeds half the common clock step.
CREATE OR REPLACE TEMP TABLE align_offset_se AS
SELECT cam_fixed, cam_moving, s.blocks, s.se AS offset_se
FROM (SELECT k.cam_fixed, k.cam_moving,
             clock_offset_se(list({'x': k.x, 'y': k.y, 'w': k.w} ORDER BY k.x, k.y, k.track_fixed, k.track_moving), coalesce(any_value(d.drift), 0.0)) AS s
      FROM align_drift_kept k LEFT JOIN align_drift d USING (cam_fixed, cam_moving)
      GROUP BY k.cam_fixed, k.cam_moving);

--    a pair with drift: on the relative clocks the fit says y = (1 + D) x + a (x, y: fixed and
--    moving times). Its support becomes the kept drift pairs, the moving tracks' times warped
--    onto the fixed camera's rate, u = y / (1 + D) = x + c, and the refit finds c (near
--    a / (1 + D)) and the transform from the whole recording; align_clock: O_rel = c (1 + D).
CREATE OR REPLACE TEMP TABLE align_support AS
SELECT * FROM align_support WHERE (cam_fixed, cam_moving) NOT IN (SELECT (cam_fixed, cam_moving) FROM align_drift WHERE drift <> 0)
UNION ALL
SELECT k.cam_fixed, k.cam_moving, k.track_fixed, k.track_moving, p.traj_fixed,
       list_transform(p.traj_moving, lambda q: {'t': clock_to_reference(q.t, 0.0, d.drift), 'x': q.x, 'y': q.y}) AS traj_moving
FROM align_drift_kept k JOIN align_drift d USING (cam_fixed, cam_moving)
JOIN align_drift_pairs p USING (cam_fixed, cam_moving, track_fixed, track_moving)
WHERE d.drift <> 0;

UPDATE align_best b SET dt = clock_to_reference(d.intercept, 0.0, d.drift)
FROM align_drift d
WHERE d.cam_fixed = b.cam_fixed AND d.cam_moving = b.cam_moving AND d.drift <> 0;

CREATE OR REPLACE TEMP TABLE align_pairs AS FROM align_refit();
