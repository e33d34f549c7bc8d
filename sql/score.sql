-- trajdb score: a pipeline's result files against a scenario's ground truth (the format of
-- ../shared/data: points.parquet, cameras.csv, truth.csv). Set score_scenario and
-- score_results (directories) first; `trajdb score SCENARIO --results DIR` does, and prints
-- s_pair_err and s_class_scores.
--
-- A true pair is the same object seen by two cameras at the same time for at least 1 s, with
-- at least 3 points of each track inside the true overlap of the two views.

CREATE OR REPLACE TEMP TABLE s_points AS SELECT * FROM read_parquet(getvariable('score_scenario') || '/points.parquet');
CREATE OR REPLACE TEMP TABLE s_cameras AS SELECT * FROM read_csv(getvariable('score_scenario') || '/cameras.csv');
CREATE OR REPLACE TEMP TABLE s_truth AS SELECT * FROM read_csv(getvariable('score_scenario') || '/truth.csv');
CREATE OR REPLACE TEMP TABLE s_tf AS SELECT * FROM read_csv(getvariable('score_results') || '/transforms.csv');
CREATE OR REPLACE TEMP TABLE s_matches AS SELECT * FROM read_csv(getvariable('score_results') || '/matches.csv');
CREATE OR REPLACE TEMP TABLE s_links AS SELECT * FROM read_csv(getvariable('score_results') || '/links.csv');

-- true local -> world transforms: world = R(theta) p + t
CREATE OR REPLACE TEMP TABLE s_true AS
SELECT camera, {'theta': theta_rad, 'tx': tx, 'ty': ty, 'scale': 1.0} AS tf, view_wkt_world FROM s_cameras;

-- rotation error, and the translation error at the centroid of the moving camera's points
CREATE OR REPLACE TEMP TABLE s_pair_err AS
WITH c AS (SELECT camera, avg(x) AS mx, avg(y) AS my FROM s_points GROUP BY camera),
     e AS (SELECT e.cam_from, e.cam_to, e.theta_rad,
                  transform_point({'theta': e.theta_rad, 'tx': e.tx, 'ty': e.ty, 'scale': 1.0}, c.mx, c.my) AS est,
                  transform_point(tt, c.mx, c.my) AS tru, tt.theta AS true_theta
           FROM s_tf e
           JOIN s_true a ON a.camera = e.cam_from JOIN s_true b ON b.camera = e.cam_to
           JOIN c ON c.camera = e.cam_from,
           LATERAL (SELECT transform_compose(transform_invert(b.tf), a.tf) AS tt))
SELECT cam_from, cam_to,
       abs(((degrees(theta_rad - true_theta) + 540) % 360) - 180) AS rot_deg,
       sqrt((est.x - tru.x) ** 2 + (est.y - tru.y) ** 2) AS trans_m
FROM e;

-- world positions of the real points, with the object of each track
CREATE OR REPLACE TEMP TABLE s_world AS
SELECT camera, track_id, class, t, object_id, w.x AS wx, w.y AS wy
FROM (SELECT p.camera, p.track_id, p.class, p.t, tr.object_id, transform_point(c.tf, p.x, p.y) AS w
      FROM s_points p JOIN s_true c USING (camera) JOIN s_truth tr USING (camera, track_id)
      WHERE p.estimated = 0 AND tr.is_noise = 0);

CREATE OR REPLACE TEMP TABLE s_true_pairs AS
WITH tracks AS (SELECT camera, track_id, any_value(class) AS class, any_value(object_id) AS object_id, min(t) AS t0, max(t) AS t1
                FROM s_world GROUP BY camera, track_id),
     cand AS (SELECT a.camera AS ca, a.track_id AS ta, b.camera AS cb, b.track_id AS tb, a.class
              FROM tracks a JOIN tracks b ON a.object_id = b.object_id AND a.camera < b.camera
              WHERE least(a.t1, b.t1) - greatest(a.t0, b.t0) >= 1.0)
SELECT cand.* FROM cand
JOIN s_true va ON va.camera = cand.ca JOIN s_true vb ON vb.camera = cand.cb
WHERE (SELECT count(*) FROM s_world w WHERE w.camera = cand.ca AND w.track_id = cand.ta
         AND polygon_contains(va.view_wkt_world, w.wx, w.wy) AND polygon_contains(vb.view_wkt_world, w.wx, w.wy)) >= 3
  AND (SELECT count(*) FROM s_world w WHERE w.camera = cand.cb AND w.track_id = cand.tb
         AND polygon_contains(va.view_wkt_world, w.wx, w.wy) AND polygon_contains(vb.view_wkt_world, w.wx, w.wy)) >= 3;

-- predicted pairs are between linked tracks: expand them to the original tracks
CREATE OR REPLACE TEMP TABLE s_pred AS
SELECT DISTINCT la.camera AS ca, la.track_id AS ta, lb.camera AS cb, lb.track_id AS tb
FROM s_matches m
JOIN s_links la ON la.camera = m.camera_a AND la.linked_id = m.track_a
JOIN s_links lb ON lb.camera = m.camera_b AND lb.linked_id = m.track_b;

CREATE OR REPLACE TEMP TABLE s_obj AS SELECT camera, track_id, object_id, is_noise FROM s_truth;

-- precision: predicted pairs whose two tracks are one object; recall: true pairs found
CREATE OR REPLACE TEMP TABLE s_class_scores AS
WITH p AS (SELECT s.*, oa.object_id = ob.object_id AND oa.is_noise = 0 AS correct,
                  (SELECT any_value(class) FROM s_points q WHERE q.camera = s.ca AND q.track_id = s.ta) AS class
           FROM s_pred s JOIN s_obj oa ON oa.camera = s.ca AND oa.track_id = s.ta
           JOIN s_obj ob ON ob.camera = s.cb AND ob.track_id = s.tb),
     t AS (SELECT tp.*, EXISTS (SELECT 1 FROM s_pred s WHERE s.ca = tp.ca AND s.ta = tp.ta AND s.cb = tp.cb AND s.tb = tp.tb) AS found
           FROM s_true_pairs tp),
     cls AS (SELECT DISTINCT class FROM s_true_pairs UNION SELECT '*')
SELECT cls.class,
       (SELECT count(*) FILTER (WHERE correct)::DOUBLE / greatest(count(*), 1) FROM p WHERE cls.class = '*' OR p.class = cls.class) AS precision,
       (SELECT count(*) FILTER (WHERE found)::DOUBLE / greatest(count(*), 1) FROM t WHERE cls.class = '*' OR t.class = cls.class) AS recall,
       (SELECT count(*) FROM t WHERE cls.class = '*' OR t.class = cls.class) AS true_pairs,
       (SELECT count(*) FROM p WHERE cls.class = '*' OR p.class = cls.class) AS predicted
FROM cls;
