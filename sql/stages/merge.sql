-- stage: merge
-- reads: points, load_ids, calib_camera_order, calib_cameras, calibrated(), calibrated_values(), quality_endpoints, quality_links,
--        quality_reach_links, align_frames, align_origin, calib_match, view_overlaps, view_merge_order
-- makes: merge_tracks, merge_scores, merge_bias, merge_links, merge_groups, merge_users, merge_chains, merge_road_users(),
--        result_matches(), result_links()
-- work: merge_periods
-- changes: -
-- parameters: input_t_type, merge_epsilon, merge_eta, merge_min_points, merge_resample_max_gap,
--             merge_resample_s, merge_time_window
--
-- trajdb: one row per road user across N cameras (thesis Alg. 2-4 and eq. 2.11).
--
-- Input: `points(camera, track_id, class, t, x, y, estimated)`, plus `align_frames` from
-- sql/stages/align.sql and `view_overlaps` / `view_merge_order` from sql/stages/overlap.sql.
-- Output (the defaults below were chosen on benches/accuracy_merge.py, see the parameters):
--   merge_tracks(camera, track_id, class, uid, traj, t0, t1)   tracks in the common frame
--   merge_scores(uid_a, uid_b, camera_a, camera_b, eta,      LCSS similarity inside P^{a∩b} (eq. 2.10) of every
--                n_common, msd, n_eff, r, r_gate, score,       pair with eta > 0, and for candidates (eta >=
--                candidate)                                     merge_eta) the evidence over the WHOLE common time
--                                                              (below; docs/association.md)
--   merge_links(uid_a, uid_b, eta, score, kind)                'hungarian' (one-to-one per camera pair),
--                                                              'split' (a second piece of a split track) or
--                                                              'reach' (a within-camera break quality.sql leaves
--                                                              to the other cameras; eta, score NULL)
--   merge_groups(uid, road_user)                               consistent groups (merge_groups())
--   merge_users(road_user, class, sources, n_tracks, traj)     the merged trajectories; sources lists the
--                                                              (camera, track_id) pairs it came from (the
--                                                              stages' ids; fuse.sql makes `merged`, the
--                                                              road users as merged.parquet has them)
--
-- How Alg. 4 is carried out, and where it deviates (see docs in crates/algo/src/merge.rs):
--  * every camera pair whose views overlap for the class is scored (the overlap graph prunes the
--    pairs; no merge-order permutations are tried: groups make the order irrelevant for *which*
--    tracks belong together, the order only fixes how points are averaged);
--  * LCSS (eta >= eta_bar) only proposes candidates. The decision uses each pair's whole common
--    time, inside the overlap polygon or not: the mean squared distance msd of the two tracks at
--    every common time step, against the pair's measured residual sigma_d (calib_match, align.sql):
--    r = msd / (2 sigma_d^2) is chi2(2 n_eff) / (2 n_eff) for one road user, n_eff the independent
--    samples (one per period of the slower camera). A candidate must pass r <= r_gate =
--    the chi2 bound at 0.999 (Wilson-Hilferty) + 0.25 (a systematic offset up to 0.71 sigma_d between
--    two cameras' views of one road user; measured: <= 0.43 sigma_d on the shared scenes). Two people
--    standing 1 m apart for 30 s score eta = 1 against each other at sigma_d = 0.35 m (eps = 1.06 m),
--    but r = 1 + 1 / (2 sigma_d^2) = 5 on 300 samples, far above the gate (1.44);
--  * Hungarian per camera pair on score = n_eff (r_gate - r) (the evidence, longer common times
--    weigh more); a 'split' link (a candidate Hungarian did not take) only when it has the lowest
--    r of every candidate of either track that overlaps it in time; then the ratio test: a match
--    (Hungarian or split) is kept only when it is 10 times likelier than every other candidate of
--    either track in the camera pair at that time ((r_other - r) min(n_eff) >= ln 10);
--  * links become road users with merge_groups(), which refuses any link that would give a road
--    user two time-overlapping tracks of one camera (false links across many cameras), and
--    accepts a second, time-disjoint piece of a track that one camera split (the 'split' links,
--    applied after all Hungarian links), then the 'reach' links of quality.sql, which other cameras
--    can veto this way, and which are refused outright when a track another camera matched to one
--    piece was seen at the same time as the other piece, but elsewhere (r above the gate);
--  * each road user is merged with trajectory_merge() in the merge order (view_merge_order), so
--    duplicates (phi_ij next to phi_ijk) cannot arise.
--
-- Parameters (defaults and why). The thesis used eps = 1 m, T = 0.5 s, xi = 5, eta_bar = 0.35-0.5. With an
-- accurate alignment, eps should be a few times the cameras' combined position noise, not the
-- width of a lane: at eps = 1 m pedestrians walking side by side score eta = 1 against each
-- other and Hungarian swaps them (pair precision 0.82 on dut_intersection_3cam). So eps is
-- measured (merge_epsilon = auto): per camera pair, 3.03 x the residual sigma of its matched
-- tracks (sql/stages/align.sql; read from calibration like every `auto` value, through
-- calibrated_values / calibrated). xi (merge_min_points = auto) is 2 real samples of
-- the slowest camera on the common clock (sql/stages/calibrate.sql). T = 0.25 s is 2.5 steps
-- of the common clock: after the clock offsets are removed (align.sql) it only has to cover
-- the clock's step.
-- Parameters (merge_*): declared once in crates/app/src/params.rs, defaults in sql/params.sql;
-- `trajdb params` lists them, `trajdb pipeline --param name=value` or SET VARIABLE sets them.
-- Common clock: every track is resampled to t = clock_origin + k * merge_resample_s (traj_resample;
-- clock_origin is align.sql's align_origin, from the reference camera's first time; 0 keeps the
-- raw samples) without bridging gaps longer than merge_resample_max_gap s. Cameras sample at
-- their own phases, so raw samples of one car lie up to half a period apart in time: at 12 m/s
-- and 5 Hz that is 1.2 m, more than eps, and fast cars went unmatched (car recall 0.76 on a
-- simulated 5 Hz day, `trajdb simulate --rate-hz 5`). The merged trajectories are on this clock.

-- A camera that align.sql could not place (one camera alone, or no common time or view with
-- the others) keeps its own frame: its tracks are road users of their own (the run warns), not
-- lost. It has no view overlap, so none of its tracks is scored against another camera's.
CREATE OR REPLACE TEMP TABLE merge_tracks AS
-- uid: one BIGINT per (camera, track_id), dense, so any camera and track id fits
-- (numbered in the cameras' data order, calib_camera_order: camera ids are labels, and the uid
-- breaks ties between equal scores below)
SELECT p.camera, p.track_id, p.class, dense_rank() OVER (ORDER BY any_value(r.data_rank), p.camera, p.track_id) AS uid,
       CASE WHEN getvariable('merge_resample_s') > 0
            THEN [{'t': q.t + o.clock_origin, 'x': q.x, 'y': q.y}
                  FOR q IN traj_resample(transform_apply(list({'t': p.t - o.clock_origin, 'x': p.x, 'y': p.y} ORDER BY p.t), any_value(f.to_reference)),
                                         getvariable('merge_resample_s'), getvariable('merge_resample_max_gap'))]
            ELSE transform_apply(list({'t': p.t, 'x': p.x, 'y': p.y} ORDER BY p.t), any_value(f.to_reference)) END AS traj,
       min(p.t) AS t0, max(p.t) AS t1
FROM points p
CROSS JOIN align_origin o
LEFT JOIN calib_camera_order r USING (camera)
JOIN (SELECT c.camera, coalesce(a.to_reference, transform_identity()) AS to_reference
      FROM (SELECT DISTINCT camera FROM points) c LEFT JOIN align_frames a USING (camera)) f USING (camera)
WHERE p.estimated = 0
GROUP BY p.camera, p.track_id, p.class, o.clock_origin;

-- per camera pair: the slower camera's sampling period and the step of the common clock
CREATE OR REPLACE TEMP TABLE merge_periods AS
SELECT a.camera AS cam_a, b.camera AS cam_b,
       greatest(coalesce(a.period_s, 0), coalesce(b.period_s, 0), 1e-3) AS period_max,
       CASE WHEN getvariable('merge_resample_s') > 0 THEN getvariable('merge_resample_s') ELSE greatest(coalesce(a.period_s, 0), 1e-3) END AS step_s
FROM calib_cameras a JOIN calib_cameras b ON a.camera < b.camera;

CREATE OR REPLACE TEMP TABLE merge_scores AS
-- The pairs of tracks of one class in two cameras that come within the camera pair's epsilon
-- plus the class's bias reach (bias_search_m: two cameras may see points of one road user up to
-- its length apart, issue 38) of each other, inside their view overlap, within merge_time_window
-- seconds: every pair with eta > 0 at that search radius (a pair not listed has eta = 0).
-- lcss_similarity_pairs scores a whole camera pair's
-- class in one call, its candidates from a space-time grid (crates/algo/src/lcss/sparse.rs):
-- only road users near each other are compared, so the cost grows with the road users per
-- window and not with their square. (It was a join of every pair of a class that overlapped in
-- time, the pair join carrying both trajectories: with 4 times the road users at once that was
-- 16 times the pairs, the stage grew as n^1.6 in density; benches/scale_series.py.)
WITH cfg AS (
    -- what a camera pair's class needs (a few rows)
    SELECT o.class, o.cam_a, o.cam_b, o.polygon, e.value + bias_search_m(o.class) AS search_m, c.sigma_d_m, c.sigma_res_m, m.period_max, m.step_s
    FROM view_overlaps o
    JOIN calib_match c ON c.cam_a = o.cam_a AND c.cam_b = o.cam_b
    JOIN calibrated_values('merge_epsilon') e ON e.cam_a = o.cam_a AND e.cam_b = o.cam_b
    JOIN merge_periods m ON m.cam_a = o.cam_a AND m.cam_b = o.cam_b
    WHERE o.area_m2 > 0
),
sides AS MATERIALIZED (
    SELECT camera, class, list(uid ORDER BY uid) AS ids, list(traj ORDER BY uid) AS trajs
    FROM merge_tracks GROUP BY camera, class
),
-- (the lists are read where they are stored: a copy of them per camera pair in a materialised
-- table, or per candidate pair in a join, was the stage's peak memory)
s AS MATERIALIZED (
    SELECT f.class, f.cam_a, f.cam_b, f.sigma_d_m, f.sigma_res_m, f.period_max, f.step_s,
           lcss_similarity_pairs(a.ids, a.trajs, b.ids, b.trajs, f.search_m, getvariable('merge_time_window'),
                                 calibrated('merge_min_points')::BIGINT, f.polygon) AS q
    FROM cfg f
    JOIN sides a ON a.class = f.class AND a.camera = f.cam_a
    JOIN sides b ON b.class = f.class AND b.camera = f.cam_b
),
-- the whole common time of the candidates (LCSS eta >= merge_eta): the mean squared distance
-- and the mean offset (dx, dy) = mean of a - b at every common time step, wherever the two
-- tracks are, inside the overlap polygon or not (traj_msd_pairs, the tracks read in place)
m AS (
    SELECT unnest(traj_msd_pairs(a.ids, a.trajs, b.ids, b.trajs, [{'a': p.a, 'b': p.b} FOR p IN s.q IF p.eta >= getvariable('merge_eta')],
                                 greatest(getvariable('merge_resample_max_gap'), 1.5 * s.period_max))) AS c
    FROM s
    JOIN sides a ON a.class = s.class AND a.camera = s.cam_a
    JOIN sides b ON b.class = s.class AND b.camera = s.cam_b
),
e AS (SELECT class, cam_a, cam_b, sigma_d_m, sigma_res_m, period_max, step_s, unnest(q) AS q FROM s)
SELECT e.q.a AS uid_a, e.q.b AS uid_b, e.cam_a AS camera_a, e.cam_b AS camera_b, e.class, ta.t0 AS t0_a, ta.t1 AS t1_a, tb.t0 AS t0_b, tb.t1 AS t1_b,
       e.q.eta AS eta, e.sigma_d_m, e.sigma_res_m, e.period_max, e.step_s, m.c.n_common, m.c.msd, m.c.dx, m.c.dy,
       -- independent samples: one per sampling period of the slower camera
       greatest(m.c.n_common * least(e.step_s / e.period_max, 1.0), 1.0) AS n_eff
FROM e
JOIN (SELECT uid, t0, t1 FROM merge_tracks) ta ON ta.uid = e.q.a
JOIN (SELECT uid, t0, t1 FROM merge_tracks) tb ON tb.uid = e.q.b
LEFT JOIN m ON m.c.a = e.q.a AND m.c.b = e.q.b;

-- Each camera pair's bias state per class (issue 38; crates/algo/src/associate/bias.rs): the
-- distribution of the constant offsets between the two cameras' views of one road user, from
-- its unambiguous matches: candidates whose residual about their own offset is noise
-- (pair_evidence with no bias prior) and that are the only such candidate of both their tracks
-- in the camera pair. The class's own state when it has 5 such matches; else the states of the
-- camera pair's other classes combined (bias_state_between: as wide as the classes differ; the
-- robust state of every class's anchors pooled is the largest class's mode, and three heavy
-- vehicles took the cars' state when one camera saw every car 1 m off); else the camera pair's
-- anchors of every class (one class with a state); else 'no bias' (sigma_d^2 I: the tolerance
-- before issue 38).
CREATE OR REPLACE TEMP TABLE merge_bias AS
WITH r AS (
    SELECT *, pair_evidence(msd, dx, dy, sigma_res_m, n_eff, bias_state_none(1e3)) AS e0
    FROM merge_scores WHERE eta >= getvariable('merge_eta') AND n_common > 0
),
ok AS (SELECT * FROM r WHERE e0.r_res <= e0.r_gate),
anchors AS (
    SELECT o.* FROM ok o
    WHERE (SELECT count(*) FROM ok x WHERE x.uid_a = o.uid_a AND x.camera_b = o.camera_b) = 1
      AND (SELECT count(*) FROM ok x WHERE x.uid_b = o.uid_b AND x.camera_a = o.camera_a) = 1
),
pairs AS (SELECT DISTINCT camera_a, camera_b, class, sigma_res_m FROM merge_scores),
by_class AS (
    SELECT camera_a, camera_b, class, bias_state(list({'dx': dx, 'dy': dy, 'se2': sigma_res_m ** 2 / n_eff})) AS state
    FROM anchors GROUP BY ALL
),
pooled AS (
    SELECT camera_a, camera_b, bias_state(list({'dx': dx, 'dy': dy, 'se2': sigma_res_m ** 2 / n_eff})) AS state
    FROM anchors GROUP BY ALL
),
between AS (
    SELECT camera_a, camera_b, bias_state_between(list(state ORDER BY class)) AS state
    FROM by_class WHERE state IS NOT NULL GROUP BY ALL
)
SELECT p.camera_a, p.camera_b, p.class,
       coalesce(c.state, w.state, o.state, bias_state_none(p.sigma_res_m)) AS state,
       CASE WHEN c.state IS NOT NULL THEN 'class' WHEN w.state IS NOT NULL THEN 'classes'
            WHEN o.state IS NOT NULL THEN 'camera pair' ELSE 'none' END AS source
FROM pairs p
LEFT JOIN by_class c USING (camera_a, camera_b, class)
LEFT JOIN between w USING (camera_a, camera_b)
LEFT JOIN pooled o USING (camera_a, camera_b);

-- the evidence of every candidate against its camera pair's bias state (pair_evidence)
CREATE OR REPLACE TEMP TABLE merge_scores AS
SELECT s.*, e.r_res, e.r_gate, e.d2, e.nll, e.nll / s.n_eff AS cost, e.score,
       coalesce(s.eta >= getvariable('merge_eta') AND s.n_common > 0 AND e.candidate, false) AS candidate
FROM merge_scores s
JOIN merge_bias b ON b.camera_a = s.camera_a AND b.camera_b = s.camera_b AND b.class IS NOT DISTINCT FROM s.class,
LATERAL (SELECT pair_evidence(s.msd, s.dx, s.dy, s.sigma_res_m, s.n_eff, b.state) AS e);

CREATE OR REPLACE TEMP TABLE merge_links AS
WITH h AS (
    SELECT unnest(hungarian_match(list({'a': uid_a, 'b': uid_b, 'score': score}), true)) AS m
    FROM merge_scores WHERE candidate
    GROUP BY camera_a, camera_b
),
-- a second piece of a track one camera split: a candidate Hungarian did not take, kept only when
-- it is the best (lowest r) of every candidate of either track that overlaps it in time
s AS (
    SELECT s.* FROM merge_scores s
    WHERE s.candidate AND NOT EXISTS (SELECT 1 FROM h WHERE h.m.a = s.uid_a AND h.m.b = s.uid_b)
      -- (two anti-joins on one key each: an OR of keys would be a nested loop)
      AND NOT EXISTS (SELECT 1 FROM merge_scores o
                      WHERE o.candidate AND o.uid_a = s.uid_a AND o.uid_b <> s.uid_b AND o.camera_b = s.camera_b
                        AND o.cost <= s.cost AND o.t0_b <= s.t1_b AND s.t0_b <= o.t1_b)
      AND NOT EXISTS (SELECT 1 FROM merge_scores o
                      WHERE o.candidate AND o.uid_b = s.uid_b AND o.uid_a <> s.uid_a AND o.camera_a = s.camera_a
                        AND o.cost <= s.cost AND o.t0_a <= s.t1_a AND s.t0_a <= o.t1_a)
),
-- the ratio test: a match is kept only when it is 10 times likelier than every other candidate
-- of either track in this camera pair at that time (log-likelihoods n_eff r apart by ln 10, n_eff
-- the smaller of the two pairs'): two people a few decimetres apart seen for a second at 2 Hz are
-- not told apart by noise; the other cameras, or their longer tracks, decide (ln 100 lost true
-- pairs in waiting crowds at sigma 0.3 m: exact 0.979 against 1.000)
clear AS (
    SELECT k.* FROM (SELECT m.a AS uid_a, m.b AS uid_b, s.eta, m.score, 'hungarian' AS kind, s.r_res, s.d2, s.n_eff, s.t0_a, s.t1_a, s.t0_b, s.t1_b,
                            s.camera_a, s.camera_b
                     FROM h JOIN merge_scores s ON s.uid_a = h.m.a AND s.uid_b = h.m.b
                     UNION ALL
                     SELECT uid_a, uid_b, eta, score, 'split', r_res, d2, n_eff, t0_a, t1_a, t0_b, t1_b, camera_a, camera_b FROM s) k
    WHERE NOT EXISTS (SELECT 1 FROM merge_scores o
                      WHERE o.candidate AND o.uid_a = k.uid_a AND o.uid_b <> k.uid_b AND o.camera_b = k.camera_b
                        AND o.t0_b <= k.t1_b AND k.t0_b <= o.t1_b
                        AND NOT pair_clear_of(k.r_res, k.d2, k.n_eff, o.r_res, o.d2, o.n_eff))
      AND NOT EXISTS (SELECT 1 FROM merge_scores o
                      WHERE o.candidate AND o.uid_b = k.uid_b AND o.uid_a <> k.uid_a AND o.camera_a = k.camera_a
                        AND o.t0_a <= k.t1_a AND k.t0_a <= o.t1_a
                        AND NOT pair_clear_of(k.r_res, k.d2, k.n_eff, o.r_res, o.d2, o.n_eff))
),
x AS (SELECT uid_a, uid_b, eta, score, kind FROM clear),
-- within-camera links quality.sql leaves to the other cameras ('reach'), offered last: refused when
-- a track another camera matched to one piece was seen at the same time as the other piece, but
-- not where it was (r above the gate over their common time): the link would make one road user
-- be in two places at once
reach AS (
    SELECT ta.uid AS uid_a, tb.uid AS uid_b
    FROM quality_reach_links r
    JOIN merge_tracks ta ON ta.camera = r.camera AND ta.track_id = r.from_id
    JOIN merge_tracks tb ON tb.camera = r.camera AND tb.track_id = r.to_id
),
partners AS (SELECT uid_a AS u, uid_b AS v FROM x UNION ALL SELECT uid_b, uid_a FROM x),
checks AS (
    -- each piece against the partners of the other piece
    SELECT r.uid_a, r.uid_b, CASE WHEN k.side = 0 THEN r.uid_a ELSE r.uid_b END AS piece, p.v AS partner
    FROM reach r CROSS JOIN (VALUES (0), (1)) k(side)
    JOIN partners p ON p.u = CASE WHEN k.side = 0 THEN r.uid_b ELSE r.uid_a END
),
contradicted AS (
    SELECT DISTINCT c.uid_a, c.uid_b
    FROM checks c
    JOIN merge_tracks t ON t.uid = c.piece JOIN merge_tracks o ON o.uid = c.partner
    JOIN calib_match cm ON cm.cam_a = least(t.camera, o.camera) AND cm.cam_b = greatest(t.camera, o.camera)
    JOIN merge_periods mp ON mp.cam_a = cm.cam_a AND mp.cam_b = cm.cam_b
    JOIN merge_bias mb ON mb.camera_a = cm.cam_a AND mb.camera_b = cm.cam_b AND mb.class IS NOT DISTINCT FROM t.class,
    -- the offset as the bias state measures it: the lower camera's track minus the other's
    LATERAL (SELECT traj_correspond(CASE WHEN t.camera < o.camera THEN t.traj ELSE o.traj END,
                                    CASE WHEN t.camera < o.camera THEN o.traj ELSE t.traj END,
                                    greatest(getvariable('merge_resample_max_gap'), 1.5 * mp.period_max)) AS cs) d,
    LATERAL (SELECT greatest(len(d.cs) * least(mp.step_s / mp.period_max, 1.0), 1.0) AS n_eff,
                    list_avg([(q.fx - q.mx) ** 2 + (q.fy - q.my) ** 2 FOR q IN d.cs]) AS msd,
                    list_avg([q.fx - q.mx FOR q IN d.cs]) AS dx, list_avg([q.fy - q.my FOR q IN d.cs]) AS dy) n
    WHERE t.t0 <= o.t1 AND o.t0 <= t.t1 AND len(d.cs) > 0
      AND NOT pair_evidence(n.msd, n.dx, n.dy, cm.sigma_res_m, n.n_eff, mb.state).candidate
)
SELECT * FROM x
UNION ALL
SELECT r.uid_a, r.uid_b, NULL, NULL, 'reach'
FROM reach r WHERE NOT EXISTS (SELECT 1 FROM contradicted c WHERE c.uid_a = r.uid_a AND c.uid_b = r.uid_b);

CREATE OR REPLACE TEMP TABLE merge_groups AS
SELECT g.id AS uid, g.grp AS road_user
FROM (
    SELECT unnest(merge_groups(
        (SELECT list({'id': uid, 'camera': camera, 't0': t0, 't1': t1}) FROM merge_tracks),
        (SELECT coalesce(list({'a': uid_a, 'b': uid_b} ORDER BY kind = 'reach', kind = 'split', score DESC, uid_a, uid_b), [])
         FROM merge_links))) AS g
);

CREATE OR REPLACE TEMP TABLE merge_users AS
SELECT g.road_user, any_value(t.class) AS class,
       list({'camera': t.camera, 'track_id': t.track_id} ORDER BY o.position, t.t0) AS sources,
       count(*) AS n_tracks,
       trajectory_merge(list(t.traj ORDER BY o.position, t.t0),
                        -- merge_epsilon for a road user of any cameras (align.sql: the
                        -- largest camera pair's, or the camera paired with itself)
                        calibrated('merge_epsilon'),
                        getvariable('merge_time_window')) AS traj
FROM merge_tracks t
JOIN merge_groups g USING (uid)
LEFT JOIN view_merge_order o USING (camera)  -- an unplaced camera: last (NULLS LAST)
GROUP BY g.road_user;

-- Within-camera chains after merging: the pieces of one camera in one road user, whether
-- quality.sql linked them, a 'reach' link did, or another camera's view bridged the gap
-- ('split' links). linked_id: the chain's first track id. Exported as links.csv.
CREATE OR REPLACE TEMP TABLE merge_chains AS
SELECT l.camera, l.track_id,
       CASE WHEN g.road_user IS NULL THEN l.linked_id
            ELSE min(l.linked_id) OVER (PARTITION BY l.camera, g.road_user) END AS linked_id
FROM quality_links l
LEFT JOIN merge_tracks t ON t.camera = l.camera AND t.track_id = l.linked_id
LEFT JOIN merge_groups g ON g.uid = t.uid;

SELECT n_tracks, count(*) AS road_users FROM merge_users GROUP BY n_tracks ORDER BY n_tracks;

-- The stage's results (sql/export.sql writes them; python/trajdb/windows.py reads them per window).
-- Table macros: they read the tables when called. Unordered: the caller orders. Camera and
-- track ids are the input's own (load_ids maps the stages' numbers back: text stays text).

-- matches: the cross-camera links merge_groups() kept (a refused link contradicts its road
-- user), one row per pair of ORIGINAL tracks (a track quality.sql linked from pieces gives a row
-- per piece), with the road user both belong to and its class
CREATE OR REPLACE TEMP MACRO result_matches() AS TABLE
SELECT ia.camera_in AS camera_a, ia.track_in AS track_a, ib.camera_in AS camera_b, ib.track_in AS track_b,
       m.eta AS score, m.kind, ga.road_user, ta.class
FROM merge_links m
JOIN merge_tracks ta ON ta.uid = m.uid_a JOIN merge_tracks tb ON tb.uid = m.uid_b
JOIN merge_groups ga ON ga.uid = m.uid_a JOIN merge_groups gb ON gb.uid = m.uid_b
JOIN quality_links la ON la.camera = ta.camera AND la.linked_id = ta.track_id
JOIN quality_links lb ON lb.camera = tb.camera AND lb.linked_id = tb.track_id
JOIN load_ids ia ON ia.camera = la.camera AND ia.track_id = la.track_id
JOIN load_ids ib ON ib.camera = lb.camera AND ib.track_id = lb.track_id
WHERE ga.road_user = gb.road_user AND m.kind <> 'reach';  -- within one camera: links

-- road users (merged.parquet): one row per road user; `geometry` is WKB (LINESTRING M, or
-- POINT M for a one-point road user; M is t) in the reference camera's local metric frame.
-- `sources` names the ORIGINAL (camera, track_id) of every piece (quality.sql linked broken
-- pieces under one id before matching), ordered by camera and start time, so any scorer can
-- read a road user's tracks from this alone (the input's own ids: load_ids). t_start / t_end
-- (reference clock: epoch seconds, or TIMESTAMPTZ when the input's t was a TIMESTAMP /
-- TIMESTAMPTZ), duration_s and length_m (metres along the merged path) save the analyst a pass
-- over traj. traj's t (and the geometry's M) stays epoch seconds on the reference clock:
-- to_timestamp(p.t) is a point's time.
-- (merge_road_users is the definition; fuse.sql adds its columns to it and makes the table `merged`.)
CREATE OR REPLACE TEMP MACRO merge_road_users() AS TABLE
SELECT road_user, class, n_tracks, sources,
       COLUMNS(lambda c: c = CASE WHEN getvariable('input_t_type') LIKE 'TIMESTAMP%' THEN 't_start_tz' ELSE 't_start_s' END) AS t_start,
       COLUMNS(lambda c: c = CASE WHEN getvariable('input_t_type') LIKE 'TIMESTAMP%' THEN 't_end_tz' ELSE 't_end_s' END) AS t_end,
       duration_s, length_m, geometry, traj
FROM (SELECT m.road_user, m.class, m.n_tracks,
             (SELECT list({'camera': i.camera_in, 'track_id': i.track_in} ORDER BY l.camera, q.e.t0, l.track_id)
              FROM unnest(m.sources) u(s)
              JOIN quality_links l ON l.camera = s.camera AND l.linked_id = s.track_id
              JOIN load_ids i ON i.camera = l.camera AND i.track_id = l.track_id
              LEFT JOIN quality_endpoints q ON q.camera = l.camera AND q.track_id = l.track_id) AS sources,
             traj_time_range(m.traj).t_start AS t_start_s, traj_time_range(m.traj).t_end AS t_end_s,
             CASE WHEN getvariable('input_t_type') LIKE 'TIMESTAMP%' THEN to_timestamp(t_start_s) END AS t_start_tz,
             CASE WHEN getvariable('input_t_type') LIKE 'TIMESTAMP%' THEN to_timestamp(t_end_s) END AS t_end_tz,
             traj_duration(m.traj) AS duration_s, traj_length_m(m.traj) AS length_m,
             traj_to_wkb(m.traj, true) AS geometry, m.traj
      FROM merge_users m);

-- links: tracks linked within a camera (every track and the id of its chain: quality.sql's
-- links, and the pieces of one camera merge.sql put in one road user; merge_chains)
CREATE OR REPLACE TEMP MACRO result_links() AS TABLE
SELECT i.camera_in AS camera, i.track_in AS track_id, j.track_in AS linked_id
FROM merge_chains c
JOIN load_ids i ON i.camera = c.camera AND i.track_id = c.track_id
JOIN load_ids j ON j.camera = c.camera AND j.track_id = c.linked_id;
