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
-- Parameters (edit here): tracks need >= 10 real points; pairs overlap >= 2 s in time and
-- their moving points span >= 3 m; hypotheses with residual < 0.5 m vote; bins are 2 degrees
-- and 1 m; a camera pair needs >= 3 agreeing hypotheses.

CREATE OR REPLACE TEMP TABLE align_tracks AS
SELECT camera, track_id, class,
       list({'t': t, 'x': x, 'y': y} ORDER BY t) AS traj,
       min(t) AS t0, max(t) AS t1
FROM points
WHERE estimated = 0
GROUP BY camera, track_id, class
HAVING count(*) >= 10;

-- 1. hypotheses
CREATE OR REPLACE TEMP TABLE align_hyp AS
WITH cand AS (
    SELECT a.camera AS cam_fixed, b.camera AS cam_moving, a.track_id AS track_fixed, b.track_id AS track_moving,
           traj_correspond(a.traj, b.traj) AS pairs
    FROM align_tracks a JOIN align_tracks b
      ON a.camera < b.camera AND a.class = b.class
     AND a.t0 <= b.t1 - 2 AND b.t0 <= a.t1 - 2
)
SELECT cam_fixed, cam_moving, track_fixed, track_moving, pairs, rigid_fit(pairs) AS f
FROM cand
WHERE len(pairs) >= 10
  AND greatest(list_max([p.mx FOR p IN pairs]) - list_min([p.mx FOR p IN pairs]),
               list_max([p.my FOR p IN pairs]) - list_min([p.my FOR p IN pairs])) >= 3;

-- 2. vote
CREATE OR REPLACE TEMP TABLE align_best AS
SELECT cam_fixed, cam_moving,
       round(degrees(f.theta) / 2) * 2 AS theta_deg, round(f.tx) AS tx, round(f.ty) AS ty, count(*) AS votes
FROM align_hyp
WHERE f.rms < 0.5
GROUP BY cam_fixed, cam_moving, theta_deg, tx, ty
QUALIFY row_number() OVER (PARTITION BY cam_fixed, cam_moving ORDER BY votes DESC, theta_deg, tx, ty) = 1;

-- 3. the agreeing hypotheses (angle difference wrapped to [-180, 180)) are the pre-matched
--    track pairs: same road user in both cameras, found without any coordinates in common.
CREATE OR REPLACE TEMP TABLE align_support AS
SELECT h.cam_fixed, h.cam_moving, h.track_fixed, h.track_moving, h.pairs
FROM align_hyp h JOIN align_best b USING (cam_fixed, cam_moving)
WHERE h.f.rms < 0.5
  AND abs(((degrees(h.f.theta) - b.theta_deg + 540) % 360) - 180) <= 3
  AND abs(h.f.tx - b.tx) <= 2 AND abs(h.f.ty - b.ty) <= 2;

--    refit on all their point pairs together, trimming the worst 10 %
CREATE OR REPLACE TEMP TABLE align_pairs AS
SELECT cam_fixed, cam_moving, rigid_fit(flatten(list(pairs)), 0.1) AS fit, count(*) AS support
FROM align_support
GROUP BY cam_fixed, cam_moving
HAVING count(*) >= 3;

--    second pass: keep the track pairs whose own points sit within 0.3 m RMS of that fit
--    (road users walking side by side agree with the vote to within a metre or two, but not
--    to 0.3 m), and refit on those: this is the final pre-match and the final transform.
CREATE OR REPLACE TEMP TABLE align_support AS
SELECT s.*
FROM align_support s JOIN align_pairs a USING (cam_fixed, cam_moving)
WHERE sqrt(list_avg([(p.fx - (a.fit.scale * (cos(a.fit.theta) * p.mx - sin(a.fit.theta) * p.my) + a.fit.tx)) ** 2
                   + (p.fy - (a.fit.scale * (sin(a.fit.theta) * p.mx + cos(a.fit.theta) * p.my) + a.fit.ty)) ** 2
                     FOR p IN s.pairs])) < 0.3;

CREATE OR REPLACE TEMP TABLE align_pairs AS
SELECT cam_fixed, cam_moving, rigid_fit(flatten(list(pairs)), 0.1) AS fit, count(*) AS support
FROM align_support
GROUP BY cam_fixed, cam_moving
HAVING count(*) >= 3;

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
