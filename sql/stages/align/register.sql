-- stage: align/register
-- reads: calib_cameras, calib_pairs, calibrated_values(), align_tracks, align_support, align_transform(), align_refit(), align_pairs
-- makes: calib_match
-- work: align_support_voted, align_residuals(), align_clean(), align_register_pairs, align_register
-- changes: align_pairs, align_support, calibration
-- parameters: align_bin_s, align_clock_step_s, align_refine_rms_m, align_trim, merge_epsilon
--
-- trajdb align, the cleaned pairs, the final registration per camera pair (register_pair, step 3c), the matched residuals
--        (calib_match) and merge_epsilon's rows of calibration.
-- Part of the stage align (sql/stages/align.sql: the method, the files in order).

--    (the voted pairs, kept for register_pair below: cleaned again under the second fit)
CREATE OR REPLACE TEMP TABLE align_support_voted AS FROM align_support;

--    The residuals of a table of track pairs (cam_fixed, cam_moving, track_fixed, track_moving,
--    traj_fixed, traj_moving) under their camera pair's fit in align_pairs when called: one row
--    per point pair (ex, ey = fixed - transformed moving). calib_match below reads it too.
CREATE OR REPLACE TEMP MACRO align_residuals(src) AS TABLE
WITH c AS (
    SELECT s.cam_fixed, s.cam_moving, s.track_fixed, s.track_moving, a.fit,
           unnest(traj_correspond(s.traj_fixed, s.traj_moving, 0.5, a.fit.dt)) AS c
    FROM query_table(src) s JOIN align_pairs a USING (cam_fixed, cam_moving)
)
SELECT cam_fixed, cam_moving, track_fixed, track_moving, c.fx - q.x AS ex, c.fy - q.y AS ey
FROM (SELECT *, transform_point(align_transform(fit), c.mx, c.my) AS q FROM c);

--    The voted pairs of src that are kept for a fit: each pair's residuals under its camera pair's
--    current fit, taken about the pair's OWN mean (issue 38: two cameras see different points of
--    a road user, a constant offset per track pair, 0.5-2 m for a car seen from its front and its
--    back), within align_refine_rms_m RMS, and one to one: a pair is kept only when it has the
--    smallest such residual of every voted pair of its fixed track and of its moving track
--    (neighbours walking side by side also move in parallel, at a constant offset; the true pair
--    is the closer). Pairs with fewer than 3 point pairs say nothing about their spread.
CREATE OR REPLACE TEMP MACRO align_clean(src) AS TABLE
WITH r AS (
    SELECT cam_fixed, cam_moving, track_fixed, track_moving, sqrt(var_pop(ex) + var_pop(ey)) AS rms_own
    FROM align_residuals(src) GROUP BY ALL HAVING count(*) >= 3
)
SELECT r.cam_fixed, r.cam_moving, r.track_fixed, r.track_moving
FROM r JOIN calibrated_values('align_refine_rms_m') g ON g.cam_a = least(r.cam_fixed, r.cam_moving) AND g.cam_b = greatest(r.cam_fixed, r.cam_moving)
WHERE r.rms_own < g.value
QUALIFY rms_own = min(rms_own) OVER (PARTITION BY r.cam_fixed, r.cam_moving, r.track_fixed)
    AND rms_own = min(rms_own) OVER (PARTITION BY r.cam_fixed, r.cam_moving, r.track_moving);

--    second pass: keep the cleaned pairs (align_clean) and refit on those: this is the final
--    pre-match and clock offset. It was an RMS gate about the first fit itself, which counts a
--    pair's constant offset against it: with every car of one camera seen 1 m off (the camera
--    sees all of them from behind) the first fit sat between the cars and the pedestrians, the
--    gate kept 2 of 91 voted pairs, and the camera was left out of the common frame.
--    And each kept pair's own offset must fit its class's (bias_fits against the bias_state of
--    the class's cleaned pairs in this camera pair; a class of fewer than 5 pairs is not
--    tested): on the shared intersection, pedestrians walking in twos passed the clean (each the
--    other's closest) and, offset by their spacing, pulled the pooled clock 35-40 ms off (9-14
--    ms with the old gate).
CREATE OR REPLACE TEMP TABLE align_support AS
WITH k AS (FROM align_clean('align_support')),
o AS (
    SELECT e.cam_fixed, e.cam_moving, e.track_fixed, e.track_moving, any_value(t.class) AS class,
           avg(e.ex) AS dx, avg(e.ey) AS dy, (var_pop(e.ex) + var_pop(e.ey)) / 2 / count(*) AS se2
    FROM align_residuals('align_support') e SEMI JOIN k USING (cam_fixed, cam_moving, track_fixed, track_moving)
    JOIN align_tracks t ON t.camera = e.cam_fixed AND t.track_id = e.track_fixed
    GROUP BY ALL
),
st AS (
    SELECT cam_fixed, cam_moving, class, bias_state(list({'dx': dx, 'dy': dy, 'se2': se2} ORDER BY track_fixed, track_moving)) AS state
    FROM o GROUP BY ALL
)
SELECT s.* FROM align_support s
SEMI JOIN (SELECT o.* FROM o LEFT JOIN st ON st.cam_fixed = o.cam_fixed AND st.cam_moving = o.cam_moving AND st.class IS NOT DISTINCT FROM o.class
           WHERE st.state IS NULL OR bias_fits(st.state, o.dx, o.dy, o.se2)) k
  USING (cam_fixed, cam_moving, track_fixed, track_moving);

CREATE OR REPLACE TEMP TABLE align_pairs AS FROM align_refit();

DELETE FROM align_pairs WHERE fit IS NULL;

--    3c. the final registration when the cameras do not see the same point of a road user (issue
--    38; register_pair, crates/algo/src/align/register.rs, docs/alignment.md): the pooled fit
--    above treats a car seen from its front by one camera and from its back by the other as
--    noise, and its rotation and translation lean towards the class with the largest offsets.
--    register_pair takes rotation (and scale, only where the jackknife shows it at 5 standard
--    errors; Deming's fit with the cameras' noise ratio) from each track pair's points about the
--    pair's own means, over the voted pairs cleaned under the second fit, and the translation from
--    the pairs' offsets: each class its own mean offset (a camera that sees every car from
--    behind), the classes' means combined as a random-effects meta-analysis. The clock offset is
--    the same model's (register_clock.rs), searched within four vote bins of the pooled fit's: a
--    time shift shows within pairs that turn or change speed and in the classes whose offsets
--    scatter little, and no class's own offset moves it (the pooled fit was 61 ms off on a scene
--    whose camera 1 saw every car 1 m off; this 0.x ms). Where its minimum lies on the search's
--    edge the pooled offset stands. The pooled fit is kept in align_pairs.pooled (calibration.csv
--    compares them).
--    The pairs: the voted ones (align_support_voted), cleaned again (align_clean) under the
--    second fit. On the crowded shared intersection the voted pairs uncleaned read an offset
--    spread of 0.4-0.6 m (wrong pairs) and moved the rotation by 0.36 deg.
CREATE OR REPLACE TEMP TABLE align_register_pairs AS FROM align_clean('align_support_voted');

CREATE OR REPLACE TEMP TABLE align_register AS
SELECT s.cam_fixed, s.cam_moving,
       register_pair(list(s.traj_fixed ORDER BY s.traj_fixed[1].t, s.traj_moving[1].t, s.track_fixed, s.track_moving),
                     list(s.traj_moving ORDER BY s.traj_fixed[1].t, s.traj_moving[1].t, s.track_fixed, s.track_moving),
                     list(c.code ORDER BY s.traj_fixed[1].t, s.traj_moving[1].t, s.track_fixed, s.track_moving),
                     any_value(a.fit.dt), 0.5, getvariable('align_trim'), any_value(cf.sigma_m), any_value(cm.sigma_m),
                     4 * getvariable('align_bin_s'), getvariable('align_clock_step_s'),
                     list(class_length_m(t.class) ORDER BY s.traj_fixed[1].t, s.traj_moving[1].t, s.track_fixed, s.track_moving)) AS reg
FROM align_support_voted s JOIN align_register_pairs USING (cam_fixed, cam_moving, track_fixed, track_moving)
JOIN align_pairs a USING (cam_fixed, cam_moving)
JOIN calib_cameras cf ON cf.camera = s.cam_fixed JOIN calib_cameras cm ON cm.camera = s.cam_moving
JOIN align_tracks t ON t.camera = s.cam_fixed AND t.track_id = s.track_fixed
JOIN (SELECT class, row_number() OVER (ORDER BY class) AS code FROM (SELECT DISTINCT class FROM align_tracks)) c
  ON c.class IS NOT DISTINCT FROM t.class
GROUP BY s.cam_fixed, s.cam_moving;

CREATE OR REPLACE TEMP TABLE align_pairs AS
SELECT p.* REPLACE (CASE WHEN r.reg IS NULL THEN p.fit
                         ELSE {'dt': r.reg.dt, 'theta': r.reg.theta, 'tx': r.reg.tx, 'ty': r.reg.ty, 'scale': r.reg.scale,
                               'rms': p.fit.rms, 'n': p.fit.n} END AS fit),
       p.fit AS pooled, r.reg
FROM align_pairs p LEFT JOIN align_register r USING (cam_fixed, cam_moving);

-- Calibration from the matched tracks themselves: the residuals of the pre-matched track pairs
-- under their camera pair's final fit and clock offset. For a true pair they are the two
-- cameras' noise plus interpolation and alignment error, i.e. exactly what LCSS has to
-- tolerate. Per-axis sigma_d = median |r| / sqrt(2 ln 2) (Rayleigh median; robust to the few
-- wrong pairs), and merge_epsilon = sigma_d sqrt(2 ln 100) = 3.03 sigma_d: 99% of a true pair's
-- points fall within eps. Pairs of cameras without a direct fit use sqrt(sigma_a^2 + sigma_b^2).
CREATE OR REPLACE TEMP TABLE calib_match AS
WITH e AS (FROM align_residuals('align_support')),
-- each track pair's own constant offset (issue 38: two cameras see different points of a road
-- user, a viewpoint bias that stays while both see it): sigma_res is the noise about it
b AS (
    SELECT cam_fixed, cam_moving, track_fixed, track_moving, avg(ex) AS bx, avg(ey) AS by, count(*) AS n
    FROM e GROUP BY ALL
),
d AS (
    SELECT cam_fixed, cam_moving,
           noise_sigma_from_rayleigh_median(median(sqrt(e.ex ** 2 + e.ey ** 2))) AS sigma_d,
           -- (n / (n - 1): the variance about a mean estimated from the same n points)
           noise_sigma_from_rayleigh_median(median(sqrt(((e.ex - b.bx) ** 2 + (e.ey - b.by) ** 2) * b.n / (b.n - 1))) FILTER (WHERE b.n > 1)) AS sigma_res,
           count(*) AS n_pairs
    FROM e JOIN b USING (cam_fixed, cam_moving, track_fixed, track_moving)
    GROUP BY cam_fixed, cam_moving
)
SELECT p.cam_a, p.cam_b, coalesce(d.sigma_d, p.sigma_pair_m) AS sigma_d_m,
       -- the noise about each pair's own offset (at most sigma_d): what the association's
       -- residual test weighs (crates/algo/src/associate/pair.rs)
       least(coalesce(d.sigma_res, d.sigma_d, p.sigma_pair_m), coalesce(d.sigma_d, p.sigma_pair_m)) AS sigma_res_m,
       coalesce(d.n_pairs, 0) AS n_pairs,
       CASE WHEN d.sigma_d IS NULL THEN 'camera noise' ELSE 'matched residuals' END AS source
FROM calib_pairs p LEFT JOIN d ON least(d.cam_fixed, d.cam_moving) = p.cam_a AND greatest(d.cam_fixed, d.cam_moving) = p.cam_b;

-- merge_epsilon into calibration (calibrate.sql's one table of resolved `auto` values): per
-- camera pair, and the 'default' row trajectory_merge uses for a road user of any cameras (the
-- largest pair's; no camera pair at all: the camera paired with itself, 3.03 sqrt(2) sigma).
-- At least 1 mm: noise-free input (a camera exported twice, simulated exact points) measures
-- sigma = 0, and LCSS needs epsilon > 0; 1 mm is below any camera's noise.
INSERT INTO calibration
SELECT 'merge_epsilon', e.scope, e.cam_a, e.cam_b, NULL, e.measured, g.given, coalesce(g.given, e.measured), e.rule
FROM (SELECT 'camera pair' AS scope, cam_a, cam_b, noise_match_epsilon(sigma_d_m) AS measured, '3.03 x residual sigma' AS rule
      FROM calib_match
      UNION ALL
      SELECT 'default', NULL, NULL,
             coalesce((SELECT max(noise_match_epsilon(sigma_d_m)) FROM calib_match),
                      noise_match_epsilon(sqrt(2) * (SELECT coalesce(max(sigma_m), 0) FROM calib_cameras))),
             'the largest camera pair''s (one camera: 3.03 sqrt(2) sigma)') e,
     (SELECT getvariable('merge_epsilon') AS given) g;
