-- trajdb: put N cameras into one frame from their tracks alone.
--
-- Input: a table `points(camera, track_id, class, t, x, y, estimated)`, each camera in its own
-- frame, clocks synchronised. Output: `align_pairs` (one transform per camera pair that has
-- support) and `align_frames` (camera -> reference frame, composed along a spanning tree).
--
-- Method (why not the thesis's speed pre-match + CPD from R = I, see docs/alignment.md):
--  1. every time-overlapping pair of tracks of the same class in two cameras is a hypothesis:
--     if both are the same road user, rigid_fit(traj_correspond(a, b)) recovers the camera
--     transform in closed form, whatever the rotation (no start needed);
--  2. hypotheses vote in (theta, tx, ty) bins; true pairs agree, wrong pairs scatter;
--  3. the correspondences of all hypotheses that agree with the winning bin are refitted
--     together with a trimmed least-squares fit;
--  4. pairs with too little support are solved through other cameras: the widest path
--     (largest bottleneck support) to the reference camera, composed with transform_compose.
--
-- Parameters (align_*): declared once in src/app/params.rs, defaults in sql/params.sql. Tracks
-- need >= align_min_points real points; pairs overlap >= align_min_overlap_s in time, give
-- >= align_min_pairs point pairs and their moving points span >= align_min_span_m; hypotheses
-- with residual < align_max_rms_m vote in bins of align_bin_deg degrees and align_bin_m metres;
-- a hypothesis agrees within align_agree_deg / align_agree_m; a camera pair needs
-- >= align_min_support agreeing hypotheses; the refit trims align_trim of the pairs, and the
-- second pass keeps track pairs within align_refine_rms_m RMS of the first fit.

CREATE OR REPLACE TEMP TABLE align_tracks AS
SELECT camera, track_id, class,
       list({'t': t, 'x': x, 'y': y} ORDER BY t) AS traj,
       min(t) AS t0, max(t) AS t1
FROM points
WHERE estimated = 0
GROUP BY camera, track_id, class
HAVING count(*) >= getvariable('align_min_points');

-- 1. hypotheses
CREATE OR REPLACE TEMP TABLE align_hyp AS
WITH cand AS (
    SELECT a.camera AS cam_fixed, b.camera AS cam_moving, a.track_id AS track_fixed, b.track_id AS track_moving,
           traj_correspond(a.traj, b.traj) AS pairs
    FROM align_tracks a JOIN align_tracks b
      ON a.camera < b.camera AND a.class = b.class
     AND a.t0 <= b.t1 - getvariable('align_min_overlap_s') AND b.t0 <= a.t1 - getvariable('align_min_overlap_s')
)
SELECT cam_fixed, cam_moving, track_fixed, track_moving, pairs, rigid_fit(pairs) AS f
FROM cand
WHERE len(pairs) >= getvariable('align_min_pairs')
  AND greatest(list_max([p.mx FOR p IN pairs]) - list_min([p.mx FOR p IN pairs]),
               list_max([p.my FOR p IN pairs]) - list_min([p.my FOR p IN pairs])) >= getvariable('align_min_span_m');

-- 2. vote
CREATE OR REPLACE TEMP TABLE align_best AS
SELECT cam_fixed, cam_moving,
       round(degrees(f.theta) / getvariable('align_bin_deg')) * getvariable('align_bin_deg') AS theta_deg,
       round(f.tx / getvariable('align_bin_m')) * getvariable('align_bin_m') AS tx,
       round(f.ty / getvariable('align_bin_m')) * getvariable('align_bin_m') AS ty, count(*) AS votes
FROM align_hyp
WHERE f.rms < getvariable('align_max_rms_m')
GROUP BY cam_fixed, cam_moving, theta_deg, tx, ty
QUALIFY row_number() OVER (PARTITION BY cam_fixed, cam_moving ORDER BY votes DESC, theta_deg, tx, ty) = 1;

-- 3. the agreeing hypotheses (angle difference wrapped to [-180, 180)) are the pre-matched
--    track pairs: same road user in both cameras, found without any coordinates in common.
CREATE OR REPLACE TEMP TABLE align_support AS
SELECT h.cam_fixed, h.cam_moving, h.track_fixed, h.track_moving, h.pairs
FROM align_hyp h JOIN align_best b USING (cam_fixed, cam_moving)
WHERE h.f.rms < getvariable('align_max_rms_m')
  AND abs(((degrees(h.f.theta) - b.theta_deg + 540) % 360) - 180) <= getvariable('align_agree_deg')
  AND abs(h.f.tx - b.tx) <= getvariable('align_agree_m') AND abs(h.f.ty - b.ty) <= getvariable('align_agree_m');

--    refit on all their point pairs together, trimming the worst align_trim share
CREATE OR REPLACE TEMP TABLE align_pairs AS
SELECT cam_fixed, cam_moving, rigid_fit(flatten(list(pairs)), getvariable('align_trim')) AS fit, count(*) AS support
FROM align_support
GROUP BY cam_fixed, cam_moving
HAVING count(*) >= getvariable('align_min_support');

--    second pass: keep the track pairs whose own points sit within align_refine_rms_m RMS of that fit
--    (road users walking side by side agree with the vote to within a metre or two, but not
--    to 0.3 m), and refit on those: this is the final pre-match and the final transform.
CREATE OR REPLACE TEMP TABLE align_support AS
SELECT s.*
FROM align_support s JOIN align_pairs a USING (cam_fixed, cam_moving)
WHERE rigid_rms(s.pairs, {'theta': a.fit.theta, 'tx': a.fit.tx, 'ty': a.fit.ty, 'scale': a.fit.scale})
      < getvariable('align_refine_rms_m');

CREATE OR REPLACE TEMP TABLE align_pairs AS
SELECT cam_fixed, cam_moving, rigid_fit(flatten(list(pairs)), getvariable('align_trim')) AS fit, count(*) AS support
FROM align_support
GROUP BY cam_fixed, cam_moving
HAVING count(*) >= getvariable('align_min_support');

-- 4. spanning tree: widest path from every camera to the reference camera (the one with the
--    most support), composing moving -> fixed transforms (inverted when walked backwards).
CREATE OR REPLACE TEMP TABLE align_edges AS
SELECT cam_moving AS src, cam_fixed AS dst, support,
       {'theta': fit.theta, 'tx': fit.tx, 'ty': fit.ty, 'scale': fit.scale} AS tf
FROM align_pairs
UNION ALL
SELECT cam_fixed, cam_moving, support,
       transform_invert({'theta': fit.theta, 'tx': fit.tx, 'ty': fit.ty, 'scale': fit.scale})
FROM align_pairs;

CREATE OR REPLACE TEMP TABLE align_frames AS
WITH RECURSIVE
ref AS (
    SELECT src AS camera FROM align_edges GROUP BY src ORDER BY sum(support) DESC, src LIMIT 1
),
walk(camera, node, tf, bottleneck, hops, visited) AS (
    -- start at each camera with the identity, walk edges towards the reference
    SELECT camera, camera, {'theta': 0.0::DOUBLE, 'tx': 0.0::DOUBLE, 'ty': 0.0::DOUBLE, 'scale': 1.0::DOUBLE}, 1e18::DOUBLE, 0, [camera]
    FROM (SELECT DISTINCT camera FROM points)
    UNION ALL
    SELECT w.camera, e.dst, transform_compose(e.tf, w.tf), least(w.bottleneck, e.support), w.hops + 1,
           list_append(w.visited, e.dst)
    FROM walk w JOIN align_edges e ON e.src = w.node
    WHERE NOT list_contains(w.visited, e.dst) AND w.node <> (SELECT camera FROM ref)
)
SELECT w.camera, (SELECT camera FROM ref) AS reference, w.tf AS to_reference, w.hops,
       CASE WHEN w.hops = 0 THEN NULL ELSE w.bottleneck END AS bottleneck_support
FROM walk w
WHERE w.node = (SELECT camera FROM ref)
QUALIFY row_number() OVER (PARTITION BY w.camera ORDER BY w.bottleneck DESC, w.hops) = 1;

SELECT camera, reference, round(degrees(to_reference.theta), 3) AS theta_deg,
       round(to_reference.tx, 3) AS tx, round(to_reference.ty, 3) AS ty, hops,
       bottleneck_support::BIGINT AS support
FROM align_frames ORDER BY camera;
