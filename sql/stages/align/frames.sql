-- stage: align/frames
-- reads: points, load_ids, calib_camera_order, calib_cameras, calibration, align_centroids, align_pairs, align_drift,
--        align_offset_se, align_transform(), calib_match
-- makes: align_frames, align_origin, calibration_summary, result_transforms(), result_calibration()
-- work: align_clock, align_edges
-- changes: points
-- parameters: load_camera_numbers, merge_resample_s
--
-- trajdb align, the spanning tree of camera pairs to the reference camera (step 4), every camera's frame and clock,
--        calibration_summary, and `points` on the reference camera's clock (step 5).
-- Part of the stage align (sql/stages/align.sql: the method, the files in order).
-- At its end it drops the align work tables no later stage needs (align_tracks, align_keys,
-- align_support_voted, align_register_pairs: memory), as the stage's last file.

-- 4. spanning tree: widest path from every camera to the reference camera (the one with the
--    most support; ties: the first in the data order), composing moving -> fixed transforms (inverted when walked backwards).
--    Clocks: each edge src -> dst carries t_src = (1 + D) t_dst + O on the cameras' own clocks.
--    On the relative clocks y = (1 + D) x + O_rel (O_rel = c (1 + D), c the refit's offset), so
--    with the origins o_m, o_f: O = O_rel + o_m - (1 + D) o_f (O = c + o_m - o_f when D = 0).
--    Walked backwards, D' = -D / (1 + D), O' = -O / (1 + D).
CREATE OR REPLACE TEMP TABLE align_clock AS
SELECT p.cam_fixed, p.cam_moving, coalesce(d.drift, 0.0) AS drift,
       CASE WHEN coalesce(d.drift, 0.0) <> 0 THEN d.drift_net_se ELSE 0.0 END AS drift_se,
       d.drift_fit, d.drift_se AS drift_fit_se, coalesce(d.n, 0) AS drift_pairs,
       clock_from_relative(p.fit.dt, coalesce(d.drift, 0.0), mc.t_origin, fc.t_origin).offset AS offset
FROM align_pairs p LEFT JOIN align_drift d USING (cam_fixed, cam_moving)
JOIN align_centroids mc ON mc.camera = p.cam_moving JOIN align_centroids fc ON fc.camera = p.cam_fixed;

CREATE OR REPLACE TEMP TABLE align_edges AS
SELECT p.cam_moving AS src, p.cam_fixed AS dst, p.support,
       align_transform(p.fit) AS tf,
       {'offset': c.offset, 'drift': c.drift} AS clock, c.drift_se
FROM align_pairs p JOIN align_clock c USING (cam_fixed, cam_moving)
UNION ALL
SELECT p.cam_fixed, p.cam_moving, p.support,
       transform_invert(align_transform(p.fit)),
       clock_invert({'offset': c.offset, 'drift': c.drift}), c.drift_se
FROM align_pairs p JOIN align_clock c USING (cam_fixed, cam_moving);

CREATE OR REPLACE TEMP TABLE align_frames AS
WITH RECURSIVE
ref AS (
    SELECT e.src AS camera FROM align_edges e JOIN calib_camera_order o ON o.camera = e.src
    GROUP BY e.src ORDER BY sum(e.support) DESC, any_value(o.data_rank) LIMIT 1
),
-- ranks: the path's cameras in the data order (calib_camera_order), the tie-break between
-- paths of equal bottleneck and hops (camera ids are labels)
walk(camera, node, tf, clock, drift_var, bottleneck, hops, visited, ranks) AS (
    -- start at each camera with the identity, walk edges towards the reference; clocks compose
    -- (clock_compose: the camera's clock against the node after the node's against the edge's end)
    SELECT camera, camera, transform_identity(),
           {'offset': 0.0::DOUBLE, 'drift': 0.0::DOUBLE}, 0.0::DOUBLE,
           1e18::DOUBLE, 0, [camera], [data_rank]
    FROM (SELECT DISTINCT camera FROM points) LEFT JOIN calib_camera_order USING (camera)
    UNION ALL
    SELECT w.camera, e.dst, transform_compose(e.tf, w.tf), clock_compose(w.clock, e.clock),
           w.drift_var + e.drift_se ** 2,
           least(w.bottleneck, e.support), w.hops + 1,
           list_append(w.visited, e.dst), list_append(w.ranks, o.data_rank)
    FROM walk w JOIN align_edges e ON e.src = w.node JOIN calib_camera_order o ON o.camera = e.dst
    WHERE NOT list_contains(w.visited, e.dst) AND w.node <> (SELECT camera FROM ref)
)
SELECT w.camera, (SELECT camera FROM ref) AS reference, w.tf AS to_reference, w.clock.offset AS clock_offset_s,
       w.clock.drift AS clock_drift, sqrt(w.drift_var) AS clock_drift_se, w.hops,
       CASE WHEN w.hops = 0 THEN NULL ELSE w.bottleneck END AS bottleneck_support
FROM walk w
WHERE w.node = (SELECT camera FROM ref)
QUALIFY row_number() OVER (PARTITION BY w.camera ORDER BY w.bottleneck DESC, w.hops, w.ranks) = 1;

-- What was measured and chosen (calibration.csv and the report): per camera, per camera pair,
-- and the pipeline-wide values (`given` when --param / SET VARIABLE set them).
CREATE OR REPLACE TEMP TABLE calibration_summary AS
SELECT 'camera ' || c.camera AS scope, q.quantity, q.value, q.unit, q.how
FROM calib_cameras c LEFT JOIN align_frames f USING (camera),
     LATERAL (VALUES ('sampling period', c.period_s, 's', 'median interval between consecutive real points'),
                     ('sampling jitter', c.jitter_s, 's', 'median absolute deviation of the intervals'),
                     ('position noise sigma', c.sigma_m, 'm', 'median second difference of evenly sampled points'),
                     ('clock offset', f.clock_offset_s, 's', 'O in t_camera = (1 + D) t_reference + O, fitted with the transform'),
                     ('clock drift', f.clock_drift * 1e6, 'ppm', 'D in t_camera = (1 + D) t_reference + O: the slope of per-pair offsets over the recording, one per camera from every camera pair''s (clock_network); 0 when the recording does not show drift (all cameras at once within the 5-sigma bound, or under 8 pairs)'),
                     ('clock drift se', f.clock_drift_se * 1e6, 'ppm', 'standard error of the clock drift (0 when the drift is 0)')) q(quantity, value, unit, how)
UNION ALL
-- the registration of each directly fitted camera pair (register_pair; the moving camera is
-- mapped onto the fixed one): every parameter with its jackknife standard error
SELECT 'cameras ' || least(p.cam_fixed, p.cam_moving) || '-' || greatest(p.cam_fixed, p.cam_moving), q.quantity, q.value, q.unit, q.how
-- (the how texts name the cameras by the input's ids: a text id is the user's camera name)
FROM align_pairs p
JOIN (SELECT DISTINCT camera, camera_in FROM load_ids) nm ON nm.camera = p.cam_moving
JOIN (SELECT DISTINCT camera, camera_in FROM load_ids) nf ON nf.camera = p.cam_fixed,
     LATERAL (VALUES ('scale', p.reg.scale, '',
                      'camera ' || nm.camera_in || ' into camera ' || nf.camera_in || ': ' ||
                      CASE WHEN p.reg.scale_significant THEN 'measured within track pairs, used (|ln s| > 5 se)'
                           ELSE 'rigid: the scale measured within track pairs, ' || round(p.reg.scale_fit, 5) || ', is within 5 se' END),
                     ('scale se', p.reg.se_scale, '', 'jackknife over 16 blocks of track pairs (inf: too few pairs)'),
                     ('rotation se', degrees(p.reg.se_theta), 'deg', 'jackknife over 16 blocks of track pairs'),
                     ('translation se', greatest(p.reg.se_tx, p.reg.se_ty), 'm', 'the larger axis: jackknife, or 1/sqrt(sum of weights) when larger'),
                     ('perspective', 50 * sqrt(p.reg.perspective_hx ** 2 + p.reg.perspective_hy ** 2), '',
                      'camera ' || nm.camera_in || ' into camera ' || nf.camera_in || ': the relative scale error 50 m along the perspective '
                      || 'term of the two ground planes (f (1 + h.(m - m0)) = A m + t + b, fitted within track pairs: perspective_*), '
                      || CASE WHEN p.reg.perspective_significant THEN 'significant (Wald chi2 ' || round(p.reg.perspective_chi2, 1)
                                   || ' > 28.74, 5 sigma); reported, not applied: the registration stays a similarity'
                              ELSE 'within 5 sigma (Wald chi2 ' || coalesce(round(p.reg.perspective_chi2, 1)::VARCHAR, 'NULL') || ')' END),
                     ('perspective se', 50 * p.reg.perspective_se, '', 'standard error of the perspective at 50 m: jackknife over 16 blocks or least squares, the larger'),
                     ('offset spread', p.reg.tau_max, 'm', 'per axis, the largest class''s spread of constant offsets between the two views of a road user (viewpoint bias)'),
                     ('registration pairs', p.reg.pairs_used, '', 'track pairs in the translation (of ' || p.reg.pairs || ')')) q(quantity, value, unit, how)
WHERE p.reg IS NOT NULL
UNION ALL
SELECT 'cameras ' || least(p.cam_fixed, p.cam_moving) || '-' || greatest(p.cam_fixed, p.cam_moving), 'clock offset se',
       CASE WHEN p.reg.dt_moved THEN greatest(o.offset_se, p.reg.se_dt) ELSE o.offset_se END, 's',
       'the jackknife over 8 blocks of the track pairs'' own offsets (rigid_shift_under), or 1/sqrt(sum of weights) when larger; '
       || 'where the registration moved the offset (one class seen off by one camera): the larger of that and the registration''s '
       || 'jackknife over 16 blocks (register_pair); NULL: too few pairs to tell'
FROM align_pairs p LEFT JOIN align_offset_se o USING (cam_fixed, cam_moving)
UNION ALL
SELECT 'cameras ' || m.cam_a || '-' || m.cam_b, q.quantity, q.value, q.unit, q.how
FROM calib_match m,
     LATERAL (VALUES ('residual sigma', m.sigma_d_m, 'm', 'per axis, from ' || m.source)) q(quantity, value, unit, how)
UNION ALL
SELECT 'cameras ' || cam_a || '-' || cam_b, parameter, value, 'm', CASE WHEN given IS NULL THEN rule ELSE 'given' END
FROM calibration WHERE scope = 'camera pair'
UNION ALL
SELECT 'class ' || class, 'acceleration p95', measured, 'm/s2',
       CASE WHEN given IS NULL THEN rule || ': quality_max_accel' ELSE 'measured; quality_max_accel given' END
FROM calibration WHERE parameter = 'quality_max_accel' AND scope = 'class'
UNION ALL
SELECT 'pipeline', parameter, value, '', CASE WHEN given IS NULL THEN rule ELSE 'given' END
FROM calibration WHERE scope = 'pipeline'
UNION ALL
SELECT 'pipeline', 'reference camera', any_value(reference), '',
       'merged.parquet and every later stage are in this camera''s frame and on its clock'
FROM align_frames;

-- 5. every later stage works on the reference camera's clock: t := (t - O) / (1 + D).
CREATE OR REPLACE TEMP TABLE points AS
SELECT p.* REPLACE (clock_to_reference(p.t, coalesce(f.clock_offset_s, 0.0), coalesce(f.clock_drift, 0.0)) AS t)
FROM points p LEFT JOIN align_frames f USING (camera);

--    clock_origin: the reference camera's first real time (every camera's when none was placed).
--    The common clock of merge.sql and fuse.sql is t = clock_origin + k merge_resample_s, not
--    k merge_resample_s: a grid anchored at 0 would move against the data when the reference
--    clock is shifted by a fraction of a step, and so would every resampled point.
--    Half a step after that first time: the grid then falls between the reference camera's own
--    samples (a camera at 10 Hz on a 0.1 s grid would put every sample on a grid point, and
--    whether a track's first grid point is inside it would hang on the last bit of t - origin).
--    (A table, so that python/trajdb/windows.py ships the site's value to every window.)
CREATE OR REPLACE TEMP TABLE align_origin AS
SELECT coalesce((SELECT min(t) FROM points WHERE estimated = 0 AND camera = (SELECT any_value(reference) FROM align_frames)),
                (SELECT min(t) FROM points WHERE estimated = 0), 0.0) + getvariable('merge_resample_s') / 2 AS clock_origin;

SELECT camera, reference, round(degrees(to_reference.theta), 3) AS theta_deg,
       round(to_reference.tx, 3) AS tx, round(to_reference.ty, 3) AS ty,
       round(clock_offset_s, 3) AS clock_offset_s, round(clock_drift * 1e6, 1) AS clock_drift_ppm, hops,
       bottleneck_support::BIGINT AS support
FROM align_frames ORDER BY camera;

-- The stage's results (sql/export.sql writes them; python/trajdb/windows.py reads them per window).
-- Table macros: they read the tables when called. Unordered: the caller orders. Camera and
-- track ids are the input's own (load_ids maps the stages' numbers back: text stays text).

-- transforms: cam_from-local into cam_to-local (p_to = scale R(theta) p_from + (tx, ty); scale 1
-- unless register_pair found one at 5 standard errors), every ordered pair of aligned cameras, and the
-- clocks: t_from = (1 + clock_drift_ppm 1e-6) t_to + clock_offset_s (a road user seen by cam_to
-- at t is seen by cam_from at that time on its clock; without drift, t + clock_offset_s)
CREATE OR REPLACE TEMP MACRO result_transforms() AS TABLE
SELECT ia.camera_in AS cam_from, ib.camera_in AS cam_to, tf.theta AS theta_rad, tf.tx, tf.ty,
       clk.offset AS clock_offset_s, clk.drift * 1e6 AS clock_drift_ppm, tf.scale
FROM align_frames a, align_frames b,
     LATERAL (SELECT transform_compose(transform_invert(b.to_reference), a.to_reference) AS tf,
                     clock_between({'offset': a.clock_offset_s, 'drift': a.clock_drift},
                                   {'offset': b.clock_offset_s, 'drift': b.clock_drift}) AS clk),
     (SELECT DISTINCT camera, camera_in FROM load_ids) ia, (SELECT DISTINCT camera, camera_in FROM load_ids) ib
WHERE a.camera <> b.camera AND ia.camera = a.camera AND ib.camera = b.camera;

-- calibration: what sql/stages/calibrate.sql and align.sql measured, and the parameters
-- derived from it (scope: a camera, a camera pair, or the pipeline). Scopes name the input's
-- cameras ('camera north', 'cameras north-south'); the values 'reference camera' and
-- 'cluster_camera' are the stages' camera numbers, and when the input's camera is text, `how`
-- ends with its name: (camera 'north').
CREATE OR REPLACE TEMP MACRO result_calibration() AS TABLE
-- (a camera of the calibration that has no points in this input, as on an archive's day
-- without it: its name from the site's numbers, load_camera_numbers, else its number)
WITH cams AS (SELECT DISTINCT camera, camera_in::VARCHAR AS camera_in FROM load_ids
              UNION ALL
              SELECT e.value, e.key
              FROM (SELECT unnest(map_entries(coalesce(getvariable('load_camera_numbers'), MAP {}::MAP(VARCHAR, INTEGER)))) AS e)
              WHERE e.value NOT IN (SELECT camera FROM load_ids))
SELECT CASE WHEN regexp_full_match(s.scope, 'camera -?[0-9]+') THEN 'camera ' || coalesce(c1.camera_in, regexp_extract(s.scope, '^camera (-?[0-9]+)', 1))
            WHEN regexp_full_match(s.scope, 'cameras -?[0-9]+--?[0-9]+')
            THEN 'cameras ' || coalesce(c1.camera_in, regexp_extract(s.scope, '^cameras (-?[0-9]+)-', 1)) || '-'
                 || coalesce(c2.camera_in, regexp_extract(s.scope, '^cameras -?[0-9]+-(-?[0-9]+)$', 1))
            ELSE s.scope END AS scope,
       s.quantity, s.value, s.unit,
       CASE WHEN cv.camera_in::VARCHAR <> cv.camera::VARCHAR THEN s.how || ' (camera ''' || cv.camera_in || ''')' ELSE s.how END AS how
FROM calibration_summary s
LEFT JOIN cams c1 ON c1.camera = try_cast(regexp_extract(s.scope, '^cameras? (-?[0-9]+)', 1) AS INTEGER)
LEFT JOIN cams c2 ON c2.camera = try_cast(regexp_extract(s.scope, '^cameras -?[0-9]+-(-?[0-9]+)$', 1) AS INTEGER)
LEFT JOIN cams cv ON s.scope = 'pipeline' AND s.quantity IN ('reference camera', 'cluster_camera') AND cv.camera = s.value;

-- align_tracks (every track's path, resampled) and align_keys have served: dropped, not kept for
-- the rest of the run (memory). IF EXISTS: a window run never makes them.
-- Qualified temp.main: an unqualified name would reach a table of the user's own of that name
-- when the temporary one is absent.
DROP TABLE IF EXISTS temp.main.align_tracks;
DROP TABLE IF EXISTS temp.main.align_keys;
DROP TABLE IF EXISTS temp.main.align_support_voted;
DROP TABLE IF EXISTS temp.main.align_register_pairs;
