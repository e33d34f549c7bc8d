-- stage: align/vote
-- reads: calibrated_values(), align_centroids, align_tracks, align_coarse
-- makes: align_scan, align_hyp, align_best
-- work: align_keys, align_sample(), align_hypotheses(), align_vote(), align_scan_pass, align_widen(), align_retry, align_speed_scan,
--       align_speed_votes, align_speed, align_hyp_wide, align_best_wide
-- changes: -
-- parameters: align_bin_deg, align_bin_m, align_bin_s, align_max_clock_offset_s, align_max_hypotheses, align_max_rms_m,
--             align_min_overlap_s, align_min_pairs, align_min_span_m, align_min_support
--
-- trajdb align, hypotheses from track pairs over a grid of clock offsets and their vote (steps 1-2, passes 1-3).
-- Part of the stage align (sql/stages/align.sql: the method, the files in order).

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
