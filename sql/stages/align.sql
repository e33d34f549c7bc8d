-- stage: align
-- reads: points, load_ids, calib_camera_order, calib_cameras, calib_pairs, calibration, calibrated_values()
-- makes: align_frames, align_origin, align_pairs, align_clock, align_offset_se, calib_match, calibration_summary,
--        result_transforms(), result_calibration()
-- work: align_centroids, align_tracks, align_activity, align_coarse, align_scan, align_keys, align_sample(),
--       align_hypotheses(), align_vote(), align_scan_pass, align_hyp, align_best, align_widen(), align_retry,
--       align_speed_scan, align_speed_votes, align_speed, align_hyp_wide, align_best_wide, align_support,
--       align_refit(), align_drift_pairs, align_drift_obs, align_drift_fitted, align_drift_kept,
--       align_drift, align_support_voted, align_residuals(), align_clean(), align_register_pairs, align_register, align_edges
-- changes: points, calibration
-- parameters: align_agree_deg, align_agree_m, align_bin_deg, align_bin_m, align_bin_s, align_clock_step_s,
--             align_max_clock_offset_s, align_max_hypotheses, align_max_rms_m, align_min_overlap_s,
--             align_min_pairs, align_min_points, align_min_span_m, align_min_support, align_refine_rms_m,
--             align_trim, load_camera_numbers, merge_epsilon, merge_resample_s
--
-- trajdb: put N cameras into one frame and one clock from their tracks alone.
--
-- Reads: `points(camera, track_id, class, t, x, y, estimated)`, each camera in its own frame
-- and on its own clock; calib_cameras, calib_pairs and the resolved align_max_rms_m /
-- align_refine_rms_m per camera pair (calibration, calibrate.sql).
-- Makes: `align_pairs` (one transform and clock fit per camera pair that has support),
-- `align_clock` (its offset and drift), `align_frames` (camera -> reference frame and clock
-- t_camera = (1 + clock_drift) t_reference + clock_offset_s, composed along a spanning tree),
-- `align_origin` (the common clock's grid origin), `calib_match` (the matched tracks'
-- residual sigma per camera pair), merge_epsilon's rows of `calibration`, `calibration_summary`,
-- and `points` with t on the reference camera's clock. Parameters: align_* (below).
--
-- Method (why not the thesis's speed pre-match + CPD from R = I, see docs/alignment.md):
--  0. the coarse clock offset of each camera pair over every lag (activity cross-correlation);
--     no range is assumed;
--  1. every time-overlapping pair of tracks of the same class in two cameras is a hypothesis:
--     if both are the same road user, rigid_fit(traj_correspond(a, b, 0.5, dt)) recovers the
--     camera transform in closed form, whatever the rotation (no start needed), for the right
--     clock offset dt; each pair is fitted at every dt of a grid about the coarse offset (a
--     Hough line); a pair not settled there asks the road users' speed profiles, then searches
--     wider;
--  2. hypotheses vote in (theta, qx, qy, dt) bins about the cameras' centroids; true pairs
--     agree, wrong pairs scatter;
--  3. the tracks of all hypotheses that agree with the winning bin are refitted together, with
--     a trimmed least-squares fit at every dt of a fine grid around the winner; 3b. clock drift
--     from per-pair offsets under that transform, over the recording;
--  4. pairs with too little support are solved through other cameras: the widest path
--     (largest bottleneck support) to the reference camera, composing transforms and clocks.
-- Every time is relative to its camera's first time and every position vote to its camera's
-- centroid: moving a frame or shifting a clock changes nothing but that camera's result
-- (tests/test_invariance_python.py).
--
-- Parameters (align_*): declared once in crates/app/src/params.rs, defaults in sql/params.sql. Tracks
-- need >= align_min_points real points; pairs overlap >= align_min_overlap_s in time, give
-- >= align_min_pairs point pairs and their moving points span >= align_min_span_m; hypotheses
-- with residual < align_max_rms_m vote in bins of align_bin_deg degrees and align_bin_m metres;
-- a hypothesis agrees within align_agree_deg / align_agree_m; a camera pair needs
-- >= align_min_support agreeing hypotheses; the refit trims align_trim of the pairs, and the
-- second pass keeps track pairs within align_refine_rms_m RMS of the first fit.


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

-- 1. hypotheses. Clocks may differ (dt = moving clock - fixed clock): each track pair is fitted
--    at every shift dt on a grid of align_bin_s within +-max_off of its camera pair
--    (rigid_fit_scan, crates/algo/src/align/shift.rs). A straight track fits at every shift, its
--    translation sliding along the road; a turning one only near its true offset. A camera pair
--    needs a few hundred agreeing pairs, not every pair of a 12-hour day: at most
--    align_max_hypotheses track pairs per camera pair are scanned, drawn evenly by a hash of
--    their ids (all of them on the shared scenes' busiest pair: 18k candidates -> 4k).
--    The search range is not a fixed bound (a camera 1.56 s off was placed at the edge of a
--    +-1 s range, 0.995 s): pass 1 searches +-align_max_clock_offset_s; a camera pair whose
--    winning offset lies within two bins of the edge, or whose winner has fewer than
--    align_min_support votes (none at all: no common time within the range), or a small winner
--    (under 4 x align_min_support) with fewer than twice the votes of the next bin (a chance
--    coincidence of a few pairs, not a peak; a true peak's neighbours on the same road can come
--    close to it, so large winners are trusted: a heuristic, not yet measured), is searched again over 4 times the range (passes 2 and 3: up to 16 x), and keeps the wider
--    search's winner when it has more votes. A pair truly in range wins inside it and is never
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

CREATE OR REPLACE TEMP TABLE align_scan AS
SELECT cam_fixed, cam_moving, coalesce(centre, 0.0) AS centre, getvariable('align_max_clock_offset_s') AS max_off, 1 AS pass
FROM align_coarse;

--    Which track pairs are sampled, and the order of the refit's lists, depend on the tracks'
--    content (start time relative to the camera's t_origin, in ms), never on their ids: the same
--    recording with relabelled ids gives the same offsets to the last bit.
CREATE OR REPLACE TEMP TABLE align_keys AS
SELECT camera, track_id, round(t0 * 1000)::BIGINT AS k0, round(t1 * 1000)::BIGINT AS k1 FROM align_tracks;

--    The track pairs a search looks at, for every camera pair of `scan` (a table of cam_fixed,
--    cam_moving, centre, max_off): same class, overlapping in time by align_min_overlap_s on
--    the fixed clock as far as `centre` knows it, +-max_off; at most align_max_hypotheses per
--    camera pair, drawn by a hash of their content. With `scaled`, a search k times wider than
--    the first (passes 2 and 3 of the exact scan) draws sqrt(k) times fewer pairs: a camera
--    pair that shares no view (no offset to find) ran all three passes with every pair, 16 x the
--    work of the first, and a 7-camera crowd took 13 minutes in align (now 14 s). k times fewer
--    (equal cost per pass) was too few: a crowd of pedestrians at 10 Hz then settled 2 s off.
--    The pairs come from a join on (camera, class, time bucket), each pair kept in the first
--    bucket both tracks cover (as merge_scores in merge.sql): an interval join on (camera, class)
--    alone compares every pair of a day, n^2. Bucket width: the median duration of the moving
--    tracks plus the widest reach (max_off - align_min_overlap_s), so a track covers about two.
CREATE OR REPLACE TEMP MACRO align_sample(scan, scaled) AS TABLE
WITH moving AS (
    SELECT s.cam_fixed, s.cam_moving, s.centre, s.max_off, b.track_id, b.class, b.t0 - s.centre AS t0, b.t1 - s.centre AS t1,
           s.max_off - getvariable('align_min_overlap_s') AS reach
    FROM align_tracks b JOIN query_table(scan) s ON s.cam_moving = b.camera
),
bw AS (SELECT greatest(coalesce(median(t1 - t0), 1.0), 1.0) + greatest(coalesce(max(reach), 0.0), 0.0) AS w FROM moving),
fa AS (
    SELECT a.camera, a.track_id, a.class, a.t0, a.t1, floor(a.t0 / w)::BIGINT AS k0,
           unnest(range(floor(a.t0 / w)::BIGINT, floor(a.t1 / w)::BIGINT + 1)) AS k
    FROM align_tracks a, bw
),
mb AS (
    -- [t0 - reach, t1 + reach], or when a negative reach inverts it, the span a fixed track must
    -- cover to qualify: either way a qualifying pair shares bucket greatest(a.k0, b.k0)
    SELECT b.*, floor(least(b.t0 - b.reach, b.t1 + b.reach) / w)::BIGINT AS k0,
           unnest(range(floor(least(b.t0 - b.reach, b.t1 + b.reach) / w)::BIGINT,
                        floor(greatest(b.t0 - b.reach, b.t1 + b.reach) / w)::BIGINT + 1)) AS k
    FROM moving b, bw
)
SELECT cam_fixed, cam_moving, track_fixed, track_moving, centre, max_off
FROM (
    SELECT a.camera AS cam_fixed, b.cam_moving, a.track_id AS track_fixed, b.track_id AS track_moving, b.centre, b.max_off, a.class,
           hash(ka.k0, ka.k1, kb.k0, kb.k1) AS h, ka.k0, ka.k1, kb.k0 AS kb0, kb.k1 AS kb1,
           row_number() OVER (PARTITION BY a.camera, b.cam_moving, a.class ORDER BY hash(ka.k0, ka.k1, kb.k0, kb.k1), ka.k0, ka.k1, kb.k0, kb.k1, a.track_id, b.track_id) AS r_class
    FROM fa a JOIN mb b
      ON a.camera = b.cam_fixed AND a.class = b.class AND a.k = b.k AND a.k = greatest(a.k0, b.k0)
     AND a.t0 <= b.t1 + b.max_off - getvariable('align_min_overlap_s')
     AND b.t0 <= a.t1 + b.max_off - getvariable('align_min_overlap_s')
    JOIN align_keys ka ON ka.camera = a.camera AND ka.track_id = a.track_id
    JOIN align_keys kb ON kb.camera = b.cam_moving AND kb.track_id = b.track_id
)
-- the sample takes the classes in turn (the first pair of each class by the hash, then the
-- second of each, ...): a class with few pairs keeps all of them. Cars are few, and their
-- turns pin the offset; on a crowded crossing with short track pieces (`trajdb simulate
-- --pedestrians 10 --occlusion 0.05`) 6940 pedestrian pairs against 480 car pairs left a
-- uniform sample of 4000 too few true pairs of either, and two of three camera pairs settled
-- 1.7-2 s off with their translation along the sidewalk to match.
QUALIFY row_number() OVER (PARTITION BY cam_fixed, cam_moving ORDER BY r_class, class, h, k0, k1, kb0, kb1, track_fixed, track_moving)
        <= CASE WHEN scaled THEN coalesce(greatest(1, least(getvariable('align_max_hypotheses'),
                                    ceil(getvariable('align_max_hypotheses') * sqrt(getvariable('align_max_clock_offset_s') / nullif(max_off, 0))))),
                                  getvariable('align_max_hypotheses'))
                ELSE getvariable('align_max_hypotheses') END;

CREATE OR REPLACE TEMP MACRO align_hypotheses(scan) AS TABLE
WITH pairs AS (FROM align_sample(scan, true)),
cand AS (
    SELECT p.*, rigid_fit_scan(a.traj, list_transform(b.traj, lambda q: {'t': q.t - p.centre, 'x': q.x, 'y': q.y}),
                               p.max_off, getvariable('align_bin_s')) AS fits
    FROM pairs p
    JOIN align_tracks a ON a.camera = p.cam_fixed AND a.track_id = p.track_fixed
    JOIN align_tracks b ON b.camera = p.cam_moving AND b.track_id = p.track_moving
)
SELECT h.cam_fixed, h.cam_moving, track_fixed, track_moving, h.centre + f.dt AS dt, f.dt AS dt_rel, h.centre, f.theta, f.tx, f.ty, f.rms,
       -- where the hypothesis puts the moving camera's centroid, relative to the fixed camera's
       -- centroid (see align_centroids): the vote's position, invariant to either frame's origin
       cos(f.theta) * m.cx - sin(f.theta) * m.cy + f.tx - fc.cx AS qx,
       sin(f.theta) * m.cx + cos(f.theta) * m.cy + f.ty - fc.cy AS qy
FROM (SELECT cam_fixed, cam_moving, track_fixed, track_moving, centre, unnest(fits) AS f FROM cand) h
JOIN calibrated_values('align_max_rms_m') c ON c.cam_a = least(h.cam_fixed, h.cam_moving) AND c.cam_b = greatest(h.cam_fixed, h.cam_moving)
JOIN align_centroids fc ON fc.camera = h.cam_fixed JOIN align_centroids m ON m.camera = h.cam_moving
WHERE f.n >= getvariable('align_min_pairs') AND f.span >= getvariable('align_min_span_m')
  AND f.rms < c.value;

-- 2. vote in (theta, qx, qy, dt) bins: the true bin collects every true track pair (straight
--    ones vote along a line through it), a wrong one only the pairs that happen to cross it.
--    Ties go to the smaller offset: one road in one direction cannot tell an offset from a
--    translation along it, and then the synchronised reading is the safer one.
CREATE OR REPLACE TEMP MACRO align_vote(hyp) AS TABLE
WITH bins AS (
    SELECT cam_fixed, cam_moving,
           round(degrees(theta) / getvariable('align_bin_deg')) * getvariable('align_bin_deg') AS theta_deg,
           round(qx / getvariable('align_bin_m')) * getvariable('align_bin_m') AS qx,
           round(qy / getvariable('align_bin_m')) * getvariable('align_bin_m') AS qy,
           round(dt_rel / getvariable('align_bin_s')) * getvariable('align_bin_s') AS dt_rel, centre
    FROM query_table(hyp)
)
SELECT cam_fixed, cam_moving, theta_deg, qx, qy, centre + dt_rel AS dt, dt_rel, centre, votes,
       -- the second bin's votes: a true offset stands far above every other bin; a winner that
       -- does not is a chance coincidence of a few pairs
       coalesce(nth_value(votes, 2) OVER (PARTITION BY cam_fixed, cam_moving ORDER BY votes DESC, abs(dt_rel), theta_deg, qx, qy
                                          ROWS BETWEEN UNBOUNDED PRECEDING AND UNBOUNDED FOLLOWING), 0) AS runner_up
FROM (SELECT cam_fixed, cam_moving, theta_deg, qx, qy, dt_rel, any_value(centre) AS centre, count(*) AS votes
      FROM bins GROUP BY cam_fixed, cam_moving, theta_deg, qx, qy, dt_rel)
QUALIFY row_number() OVER (PARTITION BY cam_fixed, cam_moving ORDER BY votes DESC, abs(dt_rel), theta_deg, qx, qy) = 1;

CREATE OR REPLACE TEMP TABLE align_scan_pass AS FROM align_scan WHERE pass = 1;
CREATE OR REPLACE TEMP TABLE align_hyp AS FROM align_hypotheses('align_scan_pass');
CREATE OR REPLACE TEMP TABLE align_best AS FROM align_vote('align_hyp');

-- passes 2 and 3: the pairs at the edge of their range, or without a winner, searched again.
CREATE OR REPLACE TEMP MACRO align_widen(pass_no) AS TABLE
SELECT s.cam_fixed, s.cam_moving, s.centre, 4 * s.max_off AS max_off, pass_no AS pass
FROM align_scan s LEFT JOIN align_best b USING (cam_fixed, cam_moving)
WHERE s.pass = pass_no - 1
  AND (b.dt IS NULL OR b.votes < getvariable('align_min_support')
       OR (b.votes < 2 * b.runner_up AND b.votes < 4 * getvariable('align_min_support'))
       OR abs(b.dt - s.centre) >= s.max_off - 2 * getvariable('align_bin_s'));

CREATE OR REPLACE TEMP TABLE align_retry AS FROM align_widen(2);

--    Pass 2 first asks the road users' SPEED, which does not depend on either frame: the
--    activity peak can sit 10 s or more from the offset where people wait in groups at a
--    crossing (13 s on a simulated crowd), and a 16 x wider exact scan of every sampled pair
--    cost 30 s there. For the pairs to search again only, each sampled track pair (same class,
--    within the activity peak's half width of its centre) votes the lag that best lines up the
--    two speed profiles over at least 4 s (speed_lag, crates/algo/src/align/speed_lag.rs; a best lag
--    on the range's edge is no peak and is dropped), in bins of half the first search range.
--    The best window of three bins, with at least align_min_support votes and 5 Poisson
--    standard deviations above the median window (the background: pairs of different road
--    users, or at a constant speed, scatter over the range), gives the median lag in it as the
--    centre of pass 2, searched over the first range. Without such a peak pass 2 searches 4 x
--    the first range about the activity centre, and pass 3 16 x.
CREATE OR REPLACE TEMP TABLE align_speed_scan AS
SELECT c.cam_fixed, c.cam_moving, c.centre, greatest(c.half_width_s, getvariable('align_max_clock_offset_s')) AS max_off
FROM align_coarse c JOIN align_retry r USING (cam_fixed, cam_moving) WHERE c.centre IS NOT NULL;

CREATE OR REPLACE TEMP TABLE align_speed_votes AS
SELECT p.cam_fixed, p.cam_moving, l.lag, l.corr
FROM align_sample('align_speed_scan', false) p
JOIN align_tracks a ON a.camera = p.cam_fixed AND a.track_id = p.track_fixed
JOIN align_tracks b ON b.camera = p.cam_moving AND b.track_id = p.track_moving,
LATERAL (SELECT speed_lag(a.traj, b.traj, p.centre, p.max_off, getvariable('align_max_clock_offset_s') / 4, 16) AS l)
WHERE l IS NOT NULL AND abs(l.lag - p.centre) < p.max_off - getvariable('align_max_clock_offset_s') / 2;

CREATE OR REPLACE TEMP TABLE align_speed AS
WITH bins AS (
    SELECT cam_fixed, cam_moving, round(lag / (getvariable('align_max_clock_offset_s') / 2))::BIGINT AS bin, count(*) AS votes
    FROM align_speed_votes GROUP BY ALL
),
win AS (  -- votes in three adjacent bins (a peak spreads over its neighbours)
    SELECT b.cam_fixed, b.cam_moving, b.bin, sum(n.votes) AS votes
    FROM bins b JOIN bins n ON n.cam_fixed = b.cam_fixed AND n.cam_moving = b.cam_moving AND abs(n.bin - b.bin) <= 1
    GROUP BY ALL
),
top AS (
    SELECT * FROM win QUALIFY row_number() OVER (PARTITION BY cam_fixed, cam_moving ORDER BY votes DESC, abs(bin), bin) = 1
),
bg AS (SELECT cam_fixed, cam_moving, median(votes) AS m FROM win GROUP BY ALL)
SELECT t.cam_fixed, t.cam_moving, t.votes, bg.m AS background,
       (SELECT median(v.lag) FROM align_speed_votes v
        WHERE v.cam_fixed = t.cam_fixed AND v.cam_moving = t.cam_moving
          AND abs(round(v.lag / (getvariable('align_max_clock_offset_s') / 2)) - t.bin) <= 1) AS centre
FROM top t JOIN bg USING (cam_fixed, cam_moving)
WHERE t.votes >= getvariable('align_min_support') AND t.votes >= bg.m + 5 * sqrt(bg.m);

INSERT INTO align_scan
SELECT r.cam_fixed, r.cam_moving, coalesce(s.centre, r.centre),
       CASE WHEN s.centre IS NULL THEN r.max_off ELSE getvariable('align_max_clock_offset_s') END, 2
FROM align_retry r LEFT JOIN align_speed s USING (cam_fixed, cam_moving);
CREATE OR REPLACE TEMP TABLE align_scan_pass AS FROM align_scan WHERE pass = 2;
CREATE OR REPLACE TEMP TABLE align_hyp_wide AS FROM align_hypotheses('align_scan_pass');
CREATE OR REPLACE TEMP TABLE align_best_wide AS FROM align_vote('align_hyp_wide');
DELETE FROM align_hyp WHERE (cam_fixed, cam_moving) IN (
    SELECT (w.cam_fixed, w.cam_moving) FROM align_best_wide w LEFT JOIN align_best b USING (cam_fixed, cam_moving) WHERE w.votes > coalesce(b.votes, 0));
INSERT INTO align_hyp FROM align_hyp_wide WHERE (cam_fixed, cam_moving) NOT IN (SELECT (cam_fixed, cam_moving) FROM align_hyp);
CREATE OR REPLACE TEMP TABLE align_best AS FROM align_vote('align_hyp');

--    pass 3: what pass 2 did not settle, over 16 x the first range about the activity centre
INSERT INTO align_scan
SELECT w.cam_fixed, w.cam_moving, coalesce(c.centre, 0.0), 16 * getvariable('align_max_clock_offset_s'), 3
FROM align_widen(3) w JOIN align_coarse c USING (cam_fixed, cam_moving);
CREATE OR REPLACE TEMP TABLE align_scan_pass AS FROM align_scan WHERE pass = 3;
CREATE OR REPLACE TEMP TABLE align_hyp_wide AS FROM align_hypotheses('align_scan_pass');
CREATE OR REPLACE TEMP TABLE align_best_wide AS FROM align_vote('align_hyp_wide');
DELETE FROM align_hyp WHERE (cam_fixed, cam_moving) IN (
    SELECT (w.cam_fixed, w.cam_moving) FROM align_best_wide w LEFT JOIN align_best b USING (cam_fixed, cam_moving) WHERE w.votes > coalesce(b.votes, 0));
INSERT INTO align_hyp FROM align_hyp_wide WHERE (cam_fixed, cam_moving) NOT IN (SELECT (cam_fixed, cam_moving) FROM align_hyp);
CREATE OR REPLACE TEMP TABLE align_best AS FROM align_vote('align_hyp');

-- 3. the agreeing hypotheses at the winning shift (angle difference wrapped to [-180, 180)) are
--    the pre-matched track pairs: same road user in both cameras, found without any coordinates
--    or clock in common.
CREATE OR REPLACE TEMP TABLE align_support AS
SELECT h.cam_fixed, h.cam_moving, h.track_fixed, h.track_moving, a.traj AS traj_fixed, m.traj AS traj_moving
FROM align_hyp h JOIN align_best b USING (cam_fixed, cam_moving)
JOIN align_tracks a ON a.camera = h.cam_fixed AND a.track_id = h.track_fixed
JOIN align_tracks m ON m.camera = h.cam_moving AND m.track_id = h.track_moving
WHERE abs(h.dt - b.dt) < 0.5 * getvariable('align_bin_s')
  AND abs(((degrees(h.theta) - b.theta_deg + 540) % 360) - 180) <= getvariable('align_agree_deg')
  AND abs(h.qx - b.qx) <= getvariable('align_agree_m') AND abs(h.qy - b.qy) <= getvariable('align_agree_m');

--    refit all their tracks together at every shift within four vote bins of the winner, on a
--    grid of align_clock_step_s (rigid_fit_shifted; where most road users walk straight the
--    vote's peak is flat, 24 against 23 votes on the shared intersection's cameras 0-1, and a
--    refit within one bin of it settled 30-65 ms off; within four, 6 ms): tracks in several directions pin the
--    offset that a single straight track leaves open. Trims the worst align_trim of the pairs;
--    each squared residual is weighted by the two cameras' measured noise (calib_cameras) so
--    that interpolated pairs do not pull the offset towards the half-sample phase. The same
--    refit (align_refit) runs again after the second pass below, on the kept pairs.
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
    WHERE abs(((degrees(h.theta) - b.theta_deg + 540) % 360) - 180) <= getvariable('align_agree_deg')
      AND abs(h.qx - b.qx) <= getvariable('align_agree_m') AND abs(h.qy - b.qy) <= getvariable('align_agree_m')
),
coarse AS (
    SELECT c.*, a.traj AS traj_fixed, m.traj AS traj_moving, (a.t0 + a.t1) / 2 AS x, cp.value AS gate,
           {'theta': p.fit.theta, 'tx': p.fit.tx, 'ty': p.fit.ty, 'scale': p.fit.scale} AS tf,
           rigid_shift_under(a.traj, m.traj, {'theta': p.fit.theta, 'tx': p.fit.tx, 'ty': p.fit.ty, 'scale': p.fit.scale},
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
       list_transform(p.traj_moving, lambda q: {'t': q.t / (1 + d.drift), 'x': q.x, 'y': q.y}) AS traj_moving
FROM align_drift_kept k JOIN align_drift d USING (cam_fixed, cam_moving)
JOIN align_drift_pairs p USING (cam_fixed, cam_moving, track_fixed, track_moving)
WHERE d.drift <> 0;

UPDATE align_best b SET dt = d.intercept / (1 + d.drift)
FROM align_drift d
WHERE d.cam_fixed = b.cam_fixed AND d.cam_moving = b.cam_moving AND d.drift <> 0;

CREATE OR REPLACE TEMP TABLE align_pairs AS FROM align_refit();

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
FROM (SELECT *, transform_point({'theta': fit.theta, 'tx': fit.tx, 'ty': fit.ty, 'scale': fit.scale}, c.mx, c.my) AS q FROM c);

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
       CASE WHEN coalesce(d.drift, 0.0) = 0 THEN p.fit.dt + (mc.t_origin - fc.t_origin)
            ELSE p.fit.dt * (1 + d.drift) + (mc.t_origin - fc.t_origin) - d.drift * fc.t_origin END AS offset
FROM align_pairs p LEFT JOIN align_drift d USING (cam_fixed, cam_moving)
JOIN align_centroids mc ON mc.camera = p.cam_moving JOIN align_centroids fc ON fc.camera = p.cam_fixed;

CREATE OR REPLACE TEMP TABLE align_edges AS
SELECT p.cam_moving AS src, p.cam_fixed AS dst, p.support,
       {'theta': p.fit.theta, 'tx': p.fit.tx, 'ty': p.fit.ty, 'scale': p.fit.scale} AS tf, c.offset AS dt, c.drift, c.drift_se
FROM align_pairs p JOIN align_clock c USING (cam_fixed, cam_moving)
UNION ALL
SELECT p.cam_fixed, p.cam_moving, p.support,
       transform_invert({'theta': p.fit.theta, 'tx': p.fit.tx, 'ty': p.fit.ty, 'scale': p.fit.scale}),
       -c.offset / (1 + c.drift), -c.drift / (1 + c.drift), c.drift_se
FROM align_pairs p JOIN align_clock c USING (cam_fixed, cam_moving);

CREATE OR REPLACE TEMP TABLE align_frames AS
WITH RECURSIVE
ref AS (
    SELECT e.src AS camera FROM align_edges e JOIN calib_camera_order o ON o.camera = e.src
    GROUP BY e.src ORDER BY sum(e.support) DESC, any_value(o.data_rank) LIMIT 1
),
-- ranks: the path's cameras in the data order (calib_camera_order), the tie-break between
-- paths of equal bottleneck and hops (camera ids are labels)
walk(camera, node, tf, dt, drift, drift_var, bottleneck, hops, visited, ranks) AS (
    -- start at each camera with the identity, walk edges towards the reference; clocks compose:
    -- t_cam = (1 + Dw) t_node + Ow and t_node = (1 + De) t_dst + Oe give
    -- t_cam = (1 + Dw)(1 + De) t_dst + (1 + Dw) Oe + Ow
    SELECT camera, camera, {'theta': 0.0::DOUBLE, 'tx': 0.0::DOUBLE, 'ty': 0.0::DOUBLE, 'scale': 1.0::DOUBLE}, 0.0::DOUBLE, 0.0::DOUBLE, 0.0::DOUBLE,
           1e18::DOUBLE, 0, [camera], [data_rank]
    FROM (SELECT DISTINCT camera FROM points) LEFT JOIN calib_camera_order USING (camera)
    UNION ALL
    SELECT w.camera, e.dst, transform_compose(e.tf, w.tf),
           CASE WHEN w.drift = 0 THEN w.dt + e.dt ELSE (1 + w.drift) * e.dt + w.dt END,
           CASE WHEN w.drift = 0 AND e.drift = 0 THEN 0.0 ELSE w.drift + e.drift + w.drift * e.drift END,
           w.drift_var + e.drift_se ** 2,
           least(w.bottleneck, e.support), w.hops + 1,
           list_append(w.visited, e.dst), list_append(w.ranks, o.data_rank)
    FROM walk w JOIN align_edges e ON e.src = w.node JOIN calib_camera_order o ON o.camera = e.dst
    WHERE NOT list_contains(w.visited, e.dst) AND w.node <> (SELECT camera FROM ref)
)
SELECT w.camera, (SELECT camera FROM ref) AS reference, w.tf AS to_reference, w.dt AS clock_offset_s,
       w.drift AS clock_drift, sqrt(w.drift_var) AS clock_drift_se, w.hops,
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
SELECT p.* REPLACE (CASE WHEN coalesce(f.clock_drift, 0.0) = 0 THEN p.t - coalesce(f.clock_offset_s, 0.0)
                         ELSE (p.t - f.clock_offset_s) / (1 + f.clock_drift) END AS t)
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
       CASE WHEN a.clock_drift = 0 AND b.clock_drift = 0 THEN a.clock_offset_s - b.clock_offset_s
            ELSE a.clock_offset_s - (1 + a.clock_drift) / (1 + b.clock_drift) * b.clock_offset_s END AS clock_offset_s,
       CASE WHEN a.clock_drift = 0 AND b.clock_drift = 0 THEN 0.0
            ELSE ((1 + a.clock_drift) / (1 + b.clock_drift) - 1) * 1e6 END AS clock_drift_ppm,
       tf.scale
FROM align_frames a, align_frames b,
     LATERAL (SELECT transform_compose(transform_invert(b.to_reference), a.to_reference) AS tf),
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
