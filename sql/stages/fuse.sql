-- stage: fuse
-- reads: points, load_ids, calib_cameras, calib_classes, align_frames, align_origin, merge_tracks, merge_groups,
--        merge_users, merge_road_users()
-- makes: fuse_q, fuse_offsets, fuse_paths, merged, result_road_users()
-- work: -
-- changes: merge_users
-- parameters: merge_resample_max_gap, merge_resample_s
--
-- trajdb pipeline: fused paths (issue 26, part 4; docs/fusion.md). Runs after merge.sql.
--
-- merge.sql's paths (trajectory_merge, thesis eq. 2.11) put the midpoint of LCSS pairs beside
-- the unmatched points of every camera: on dut_intersection_3cam 40% of multi-camera road users
-- had time steps under 1 us, traj_speeds gave up to 1e13 m/s, and length_m / duration_s
-- overstated the mean speed by 23-45%. Here every road user's path is instead the smoothed
-- estimate of one constant-velocity motion model from ALL its real observations in every
-- camera, each with its camera's measured noise (traj_fuse: Kalman filter + Rauch-Tung-Striebel
-- smoother, seed 003 eq. 3.10-3.15, crates/algo/src/fuse/), on the common clock.
--
-- Reads: points (real points, t on the reference clock since align.sql), align_frames
--   (to_reference), merge_tracks (camera, track_id, class -> uid), merge_groups (uid ->
--   road_user), merge_users (the road users), calib_cameras.sigma_m (per camera), calib_classes.accel_p95
--   (per class).
-- Makes:
--   fuse_q(class, accel_p95, q)                    the acceleration noise density per class (m^2/s^3)
--   fuse_offsets(road_user, camera, track_id, dx, dy, n_common)   each source's constant offset (below)
--   fuse_paths(road_user, n_cameras, q, traj, sigma)   the fused path and its per-point sigma (m)
--   merge_users                                     replaced: traj = the fused path, plus sigma_m
--                                                   (median per-point sigma) and sigma (per point)
--   result_road_users()                             merged.parquet's rows (FROM merged): merge_road_users() with
--                                                   sigma_m, sigma, offsets and stationary
--   merged                                          the road users as merged.parquet has them (the
--                                                   input's ids, t_start, ..., geometry, offsets): what
--                                                   stays in the connection is what the file holds
-- Parameters: merge_resample_s, merge_resample_max_gap (the common clock merge.sql uses: the
--   fused path is sampled at t = k * merge_resample_s and not across gaps longer than
--   merge_resample_max_gap between observations; 0 = one point per distinct observation time).
--
-- Measured noise, not guessed:
--  * sigma: each observation's camera's position noise (calibrate.sql, calib_cameras.sigma_m:
--    the median second difference of its tracks); a camera that measured none takes the largest
--    of the others; at least 1 mm (noise-free input measures 0, and the filter needs sigma > 0).
--  * q: the continuous white-noise-acceleration density. calibrate.sql measures per class the
--    95th percentile of |p(t+1) - 2 p(t) + p(t-1)| on tracks resampled to 1 s. Under the model
--    that second difference is Gaussian per axis with variance q * 2 tau^3 / 3 (tau = 1 s: the
--    triangle kernel's integral), so its 2-D length is Rayleigh with scale sqrt(2 q / 3), whose
--    95th percentile is sqrt(2 ln 20) times the scale: q = 1.5 * (accel_p95 / sqrt(2 ln 20))^2
--    = 0.2504 accel_p95^2. The measurement includes position noise: a second difference of
--    noisy positions adds 6 sigma^2 per axis to its variance, so the noise's share is taken
--    out: q = 1.5 * ((accel_p95 / sqrt(2 ln 20))^2 - 6 s2), s2 = the mean sigma_m^2 over the
--    cameras (calib_cameras; the same in every window), and q is at least 0.1 of the uncorrected
--    value (where noise is nearly all of the measurement the difference is uncertain; docs/fusion.md
--    measured q x 0.1 to cost < 5% of accuracy). Without the correction, at sigma 0.2-0.4 m q
--    was 4-15x too high for pedestrians and cyclists, the smoother followed the noise and
--    length_m overstated the true length by 1.6% (median) and 9% (p95), up to 20%
--    (tests/test_paths_python.py, issue 29); at the default sigma 0.05-0.15 m q changes by ~1%.
--    A class calibrate.sql could not measure takes the largest q of the others.
--  * Which road users: every one (one camera too): a single camera's path is smoothed the same
--    way (its error against world.csv falls by about half, and its length stops counting the
--    noise); see docs/fusion.md for the measurement.

CREATE OR REPLACE TEMP TABLE fuse_q AS
SELECT class, accel_p95,
       noise_process_q(accel_p95, coalesce((SELECT avg(sigma_m ** 2) FROM calib_cameras WHERE isfinite(sigma_m)), 0)) AS q
FROM calib_classes WHERE isfinite(accel_p95);

-- Sources that see different points of the road user (issue 38; docs/fusion.md): every source
-- track (one camera's linked track of the road user) gets a constant offset such that all its
-- sources are views of one point, the mean of the sources' points (traj_source_offsets,
-- crates/algo/src/fuse/offsets.rs: least squares over the sources' mean differences in common
-- time). The observations are fused with their source's offset removed: the path follows one
-- point of the road user and does not jump where a camera's view begins or ends.
CREATE OR REPLACE TEMP TABLE fuse_offsets AS
WITH cam AS (
    SELECT c.camera, coalesce(a.to_reference, transform_identity()) AS to_reference
    FROM (SELECT DISTINCT camera FROM points) c LEFT JOIN align_frames a USING (camera)
),
src AS (
    SELECT g.road_user, p.camera, p.track_id,
           list({'t': p.t - o.clock_origin, 'x': w.x, 'y': w.y} ORDER BY p.t, p.x, p.y) AS traj
    FROM points p
    CROSS JOIN align_origin o
    JOIN merge_tracks t ON t.camera = p.camera AND t.track_id = p.track_id AND t.class IS NOT DISTINCT FROM p.class
    JOIN merge_groups g USING (uid)
    JOIN cam c ON c.camera = p.camera,
    LATERAL (SELECT transform_point(c.to_reference, p.x, p.y) AS w)
    WHERE p.estimated = 0
    GROUP BY g.road_user, p.camera, p.track_id
),
o AS (
    SELECT road_user, list(camera ORDER BY camera, track_id) AS cams, list(track_id ORDER BY camera, track_id) AS tids,
           traj_source_offsets(list(traj ORDER BY camera, track_id),
                               CASE WHEN getvariable('merge_resample_max_gap') > 0 THEN getvariable('merge_resample_max_gap') ELSE 'inf'::DOUBLE END) AS off
    FROM src GROUP BY road_user HAVING count(*) >= 2
)
SELECT road_user, u.camera, u.track_id, u.o.dx, u.o.dy, u.o.n_common
FROM o, LATERAL (SELECT unnest(cams) AS camera, unnest(tids) AS track_id, unnest(off) AS o) u;

CREATE OR REPLACE TEMP TABLE fuse_paths AS
WITH cam AS (
    SELECT c.camera, coalesce(a.to_reference, transform_identity()) AS to_reference,
           greatest(coalesce(s.sigma_m, (SELECT max(sigma_m) FROM calib_cameras), 0.0), 1e-3) AS sigma
    FROM (SELECT DISTINCT camera FROM points) c
    LEFT JOIN align_frames a USING (camera) LEFT JOIN calib_cameras s USING (camera)
),
obs AS (
    SELECT g.road_user, any_value(t.class) AS class, count(DISTINCT p.camera) AS n_cameras,
           -- ties in t broken by camera, track and position: the same list in every run and window
           -- times relative to align_origin.clock_origin (align.sql): the clock grid t = clock_origin + k step
           list({'t': p.t - o.clock_origin, 'x': w.x - coalesce(f.dx, 0.0), 'y': w.y - coalesce(f.dy, 0.0), 'sigma': c.sigma}
                ORDER BY p.t, p.camera, p.track_id, p.x, p.y) AS obs
    FROM points p
    CROSS JOIN align_origin o
    JOIN merge_tracks t ON t.camera = p.camera AND t.track_id = p.track_id AND t.class IS NOT DISTINCT FROM p.class
    JOIN merge_groups g USING (uid)
    JOIN cam c ON c.camera = p.camera
    LEFT JOIN fuse_offsets f ON f.road_user = g.road_user AND f.camera = p.camera AND f.track_id = p.track_id,
    LATERAL (SELECT transform_point(c.to_reference, p.x, p.y) AS w)
    WHERE p.estimated = 0
    GROUP BY g.road_user
),
oq AS (
    SELECT o.*, coalesce(q.q, (SELECT max(q) FROM fuse_q)) AS q FROM obs o LEFT JOIN fuse_q q USING (class)
),
f AS (
    -- the path and its uncertainty from one smoother run (traj_fuse_with_sigma)
    SELECT road_user, n_cameras, q,
           CASE WHEN getvariable('merge_resample_s') > 0
                THEN traj_fuse_with_sigma(obs, q, getvariable('merge_resample_s'), getvariable('merge_resample_max_gap')) END AS clock_path,
           obs
    FROM oq
),
-- a path shorter than one clock step has no clock point: one point per observation time instead
g AS (SELECT road_user, n_cameras, q, CASE WHEN len(clock_path) > 0 THEN clock_path ELSE traj_fuse_with_sigma(obs, q) END AS path FROM f)
SELECT road_user, n_cameras, q,
       [{'t': r.t + o.clock_origin, 'x': r.x, 'y': r.y} FOR r IN path] AS traj,
       [r.sigma FOR r IN path] AS sigma
FROM g CROSS JOIN align_origin o;

-- merge_users: the fused path replaces the merged one (a road user without a q, when no class could
-- be measured, keeps it); sigma_m = the median per-point sigma
CREATE OR REPLACE TEMP TABLE merge_users AS
SELECT m.* REPLACE (coalesce(f.traj, m.traj) AS traj),
       CASE WHEN f.traj IS NOT NULL THEN list_median(f.sigma) END AS sigma_m,
       CASE WHEN f.traj IS NOT NULL THEN f.sigma END AS sigma
FROM merge_users m LEFT JOIN fuse_paths f USING (road_user);

SELECT n_cameras, count(*) AS road_users, round(median(list_median(sigma)), 4) AS median_sigma_m
FROM fuse_paths GROUP BY n_cameras ORDER BY n_cameras;

-- road users (merged.parquet): merge.sql's definition (merge_road_users, which reads the fused
-- traj from merge_users), plus sigma_m (the median of the per-point 1-sigma position error per
-- axis, m) and sigma (one per point of traj, m).
-- offsets: each source's offset (fuse_offsets), named by the input's camera and the chain's
-- linked id (links.csv linked_id), ordered by camera and track; NULL for a road user of one track.
-- stationary: the road user never moved (traj_stationary: a parked car); speed statistics leave
-- it out (issue 39).
-- merged: the road users as merged.parquet has them (the README's `FROM merged`): the input's own
-- camera and track ids in sources and offsets, t_start, t_end, duration_s, length_m, geometry,
-- sigma_m, sigma. What stays in the connection is what the file holds (issue 39); the stages'
-- own ids stay in merge_users (its paths dropped: merge_road_users() is merge.sql's, not to be
-- called after this). result_road_users() is defined here only, once merged exists.
CREATE OR REPLACE TEMP TABLE merged AS
SELECT r.*, m.sigma_m, m.sigma, o.offsets, traj_stationary(r.traj, r.class) AS stationary
FROM merge_road_users() r JOIN merge_users m USING (road_user)
LEFT JOIN (SELECT f.road_user, list({'camera': i.camera_in, 'track_id': i.track_in, 'dx': f.dx, 'dy': f.dy} ORDER BY f.camera, f.track_id) AS offsets
           FROM fuse_offsets f JOIN load_ids i ON i.camera = f.camera AND i.track_id = f.track_id
           GROUP BY f.road_user) o USING (road_user)
ORDER BY road_user;
CREATE OR REPLACE TEMP MACRO result_road_users() AS TABLE FROM merged;
-- merge_users keeps only the stages' ids (report.sql counts road users per camera by them): its
-- paths are merged's now, and two copies of a day's paths cost 0.6 GB of a Mellingen-sized day
CREATE OR REPLACE TEMP TABLE merge_users AS SELECT road_user, class, sources, n_tracks FROM merge_users;
