-- trajdb demo, part 3 (after sql/demo.sql and sql/stages/align.sql): bring every track into the
-- reference frame, then score the track pairs of the two cameras with LCSS inside the shared
-- overlap P^{1∩2} of their views for that class, as sql/stages/overlap.sql found it (thesis eq. 2.10:
-- eps = 1 m, T = 0.5 s, at least 5 points in the overlap).

CREATE OR REPLACE TEMP TABLE demo_tracks AS
SELECT p.camera, p.track_id, p.class, any_value(p.object_id) AS object_id,
       transform_apply(list({'t': p.t, 'x': p.x, 'y': p.y} ORDER BY p.t), any_value(f.to_reference)) AS traj,
       min(p.t) AS t0, max(p.t) AS t1
FROM points p JOIN align_frames f USING (camera)
GROUP BY p.camera, p.track_id, p.class;

CREATE OR REPLACE TEMP TABLE demo_scores AS
SELECT a.track_id AS track_a, b.track_id AS track_b, a.class,
       a.object_id = b.object_id AS same_object,    -- the generator's truth, for checking only
       lcss_similarity(a.traj, b.traj, 1.0, 0.5, 5, o.polygon) AS eta
FROM demo_tracks a
JOIN demo_tracks b
  ON a.camera = 1 AND b.camera = 2 AND a.class = b.class
 AND a.t0 <= b.t1 + 0.5 AND b.t0 <= a.t1 + 0.5
JOIN view_overlaps o ON o.class = a.class AND o.cam_a = 1 AND o.cam_b = 2;

SELECT count(*) AS candidate_pairs,
       count(*) FILTER (WHERE eta >= 0.5) AS above_threshold,
       count(*) FILTER (WHERE eta >= 0.5 AND same_object) AS correct,
       (SELECT count(DISTINCT object_id) FROM demo_tracks WHERE camera = 1
          AND object_id IN (SELECT object_id FROM demo_tracks WHERE camera = 2)) AS objects_seen_by_both,
       round(avg(eta) FILTER (WHERE same_object), 3) AS mean_eta_same,
       round(avg(eta) FILTER (WHERE NOT same_object), 3) AS mean_eta_different
FROM demo_scores;
