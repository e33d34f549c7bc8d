-- trajdb score: a pipeline's result files against a scenario's ground truth (the format of
-- ../shared/data: points.parquet, cameras.csv, truth.csv). Set score_scenario and
-- score_results (directories) first; `trajdb score SCENARIO --results DIR` does, and prints
-- s_pair_err, s_identity (with s_hota) and s_class_scores. docs/scoring.md explains every figure.
--
-- A true pair is the same object seen by two cameras at the same time (world time) for at least
-- 1 s, with at least 3 points of each track inside the true overlap of the two views.
--
-- Clocks (simulator truth, cameras.csv): t_cam = (1 + clock_drift_ppm 1e-6) t_world + clock_offset_s;
-- a cameras.csv without clock_offset_s / clock_drift_ppm has offset / drift 0.

CREATE OR REPLACE TEMP TABLE s_points AS SELECT * FROM read_parquet(getvariable('score_scenario') || '/points.parquet');
-- the clock columns are optional: UNION BY NAME adds them as NULL when the file lacks them
CREATE OR REPLACE TEMP TABLE s_cameras AS
SELECT * REPLACE (coalesce(TRY_CAST(clock_offset_s AS DOUBLE), 0.0) AS clock_offset_s,
                  coalesce(TRY_CAST(clock_drift_ppm AS DOUBLE), 0.0) AS clock_drift_ppm)
FROM (FROM read_csv(getvariable('score_scenario') || '/cameras.csv')
      UNION ALL BY NAME (SELECT NULL::DOUBLE AS clock_offset_s, NULL::DOUBLE AS clock_drift_ppm WHERE false));
CREATE OR REPLACE TEMP TABLE s_truth AS SELECT * FROM read_csv(getvariable('score_scenario') || '/truth.csv');
-- read as text and typed here: a run that placed no camera pair writes empty transform columns, and
-- results older than the clock drift lack clock_drift_ppm (drift 0), older than issue 38 scale (1). transforms.csv's clock model:
-- t_from = (1 + clock_drift_ppm 1e-6) t_to + clock_offset_s.
-- The cameras are named as in cameras.csv, with its type: integer ids stay integers, text ids
-- ('north') text; the camera columns of the other files are matched to them by their text.
CREATE OR REPLACE TEMP TABLE s_tf AS
SELECT a.camera AS cam_from, b.camera AS cam_to, theta_rad::DOUBLE AS theta_rad, tx::DOUBLE AS tx, ty::DOUBLE AS ty,
       clock_offset_s::DOUBLE AS clock_offset_s, coalesce(clock_drift_ppm::DOUBLE, 0.0) AS clock_drift_ppm,
       coalesce(scale::DOUBLE, 1.0) AS scale
FROM (FROM read_csv(getvariable('score_results') || '/transforms.csv', header = true, all_varchar = true)
      UNION ALL BY NAME (SELECT NULL::VARCHAR AS clock_drift_ppm, NULL::VARCHAR AS scale WHERE false)) t
JOIN (SELECT DISTINCT camera FROM s_cameras) a ON a.camera::VARCHAR = t.cam_from
JOIN (SELECT DISTINCT camera FROM s_cameras) b ON b.camera::VARCHAR = t.cam_to;
CREATE OR REPLACE TEMP TABLE s_matches AS SELECT * FROM read_csv(getvariable('score_results') || '/matches.csv');
CREATE OR REPLACE TEMP TABLE s_links AS SELECT * FROM read_csv(getvariable('score_results') || '/links.csv');

-- true local -> world transforms: world = R(theta) p + t
CREATE OR REPLACE TEMP TABLE s_true AS
SELECT camera, {'theta': theta_rad, 'tx': tx, 'ty': ty, 'scale': 1.0} AS tf, view_wkt_world FROM s_cameras;

-- Per placed pair (a = cam_from, b = cam_to): the rotation error, the translation error at the
-- centroid of the moving camera's points, the clock error and the drift error.
-- Clock error: the largest |estimated t_a - true t_a| at the two ends of camera b's recorded
-- span (the error is linear in time, so the ends hold its maximum). With world time w,
-- t_b = (1 + d_b) w + o_b, true t_a = (1 + d_a) w + o_a, estimated t_a = (1 + e) t_b + C:
--   est - true = w (e + d_b + e d_b - d_a) + (C - (o_a - o_b)) + e o_b
-- each term a difference formed before anything large is added (offsets of hours, clocks at
-- Unix epochs: w, o ~ 1.8e9 s lose nothing below a microsecond).
-- Drift error: |e - true pairwise drift| in ppm, true = ((1 + d_a) / (1 + d_b) - 1) 1e6 = (D_a - D_b) / (1 + D_b 1e-6).
CREATE OR REPLACE TEMP TABLE s_pair_err AS
WITH c AS (SELECT camera, avg(x) AS mx, avg(y) AS my FROM s_points GROUP BY camera),
     span AS (SELECT p.camera, min(p.t) AS t0, max(p.t) AS t1 FROM s_points p WHERE p.estimated = 0 GROUP BY p.camera),
     e AS (SELECT e.cam_from, e.cam_to, e.theta_rad, e.clock_offset_s AS c_est, e.clock_drift_ppm * 1e-6 AS e_est, e.clock_drift_ppm AS drift_est_ppm,
                  a.clock_offset_s AS o_a, b.clock_offset_s AS o_b, a.clock_drift_ppm * 1e-6 AS d_a, b.clock_drift_ppm * 1e-6 AS d_b,
                  (a.clock_drift_ppm - b.clock_drift_ppm) / (1.0 + b.clock_drift_ppm * 1e-6) AS drift_true_ppm,
                  -- camera b's recorded span in world time
                  coalesce(clock_to_reference(s.t0, b.clock_offset_s, b.clock_drift_ppm * 1e-6), 0.0) AS w0,
                  coalesce(clock_to_reference(s.t1, b.clock_offset_s, b.clock_drift_ppm * 1e-6), 0.0) AS w1,
                  -- a pair written without a transform (empty fields) is not placed: NULL errors, not an error
                  CASE WHEN e.theta_rad IS NOT NULL AND e.tx IS NOT NULL AND e.ty IS NOT NULL
                       THEN transform_point({'theta': e.theta_rad, 'tx': e.tx, 'ty': e.ty, 'scale': e.scale}, c.mx, c.my) END AS est,
                  transform_point(tt, c.mx, c.my) AS tru, tt.theta AS true_theta
           FROM s_tf e
           JOIN s_cameras a ON a.camera = e.cam_from JOIN s_cameras b ON b.camera = e.cam_to
           JOIN s_true ta ON ta.camera = e.cam_from JOIN s_true tb ON tb.camera = e.cam_to
           JOIN c ON c.camera = e.cam_from
           LEFT JOIN span s ON s.camera = e.cam_to,
           LATERAL (SELECT transform_compose(transform_invert(tb.tf), ta.tf) AS tt)),
     k AS (SELECT *, e_est + d_b + e_est * d_b - d_a AS rate_err, (c_est - (o_a - o_b)) + e_est * o_b AS err_at_0 FROM e)
SELECT cam_from, cam_to,
       abs(angle_wrap_deg(degrees(theta_rad - true_theta))) AS rot_deg,
       sqrt((est.x - tru.x) ** 2 + (est.y - tru.y) ** 2) AS trans_m,
       greatest(abs(w0 * rate_err + err_at_0), abs(w1 * rate_err + err_at_0)) AS clock_err_s,
       abs(drift_est_ppm - drift_true_ppm) AS drift_err_ppm
FROM k;

-- world positions and world times of the real points, with the object of each track
CREATE OR REPLACE TEMP TABLE s_world AS
SELECT camera, track_id, class, t, object_id, w.x AS wx, w.y AS wy
FROM (SELECT p.camera, p.track_id, p.class, clock_to_reference(p.t, k.clock_offset_s, k.clock_drift_ppm * 1e-6) AS t, tr.object_id,
             transform_point(c.tf, p.x, p.y) AS w
      FROM s_points p JOIN s_true c USING (camera) JOIN s_cameras k USING (camera) JOIN s_truth tr USING (camera, track_id)
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

-- predicted pairs: matches.csv names the original tracks
CREATE OR REPLACE TEMP TABLE s_pred AS
SELECT DISTINCT camera_a AS ca, track_a AS ta, camera_b AS cb, track_b AS tb FROM s_matches;

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
       (SELECT count(*) FROM p WHERE cls.class = '*' OR p.class = cls.class) AS predicted,
       (SELECT count(*) FROM p WHERE (cls.class = '*' OR p.class = cls.class) AND correct
          AND NOT EXISTS (SELECT 1 FROM s_true_pairs tp WHERE tp.ca = p.ca AND tp.ta = p.ta AND tp.cb = p.cb AND tp.tb = p.tb)) AS neutral
FROM cls;

-- ---------------------------------------------------------------- road-user identity
-- What analysts count and follow: every real track of one road user, in every camera, in
-- exactly one road user with nothing from another road user. Read from merged.parquet alone
-- (its `sources` name the original tracks).

-- every track's real (not estimated) points and start time
CREATE OR REPLACE TEMP TABLE s_track_w AS
SELECT camera, track_id, count(*) AS w, min(t) AS t0 FROM s_points WHERE estimated = 0 GROUP BY camera, track_id;

-- real tracks of real objects, each weighing its real points
CREATE OR REPLACE TEMP TABLE s_gt_tracks AS
SELECT p.camera, p.track_id, tr.object_id, any_value(p.class) AS class, count(*) AS w, min(p.t) AS t0
FROM s_points p JOIN s_truth tr USING (camera, track_id)
WHERE p.estimated = 0 AND tr.is_noise = 0
GROUP BY p.camera, p.track_id, tr.object_id;

-- the predicted road users: (road_user, class, camera, track_id, w) with w the track's real points
CREATE OR REPLACE TEMP TABLE s_ru AS
WITH r AS (SELECT road_user, class, unnest(sources) AS s
           FROM read_parquet(getvariable('score_results') || '/merged.parquet'))
SELECT r.road_user, r.class, s.camera, s.track_id, coalesce(tw.w, 0) AS w
FROM r LEFT JOIN s_track_w tw ON tw.camera = s.camera AND tw.track_id = s.track_id;

-- IDF1 (Ristani et al. 2016) over observations: objects and road users mapped one to one so
-- that the shared points are at a maximum (assign_pairs: maximum total weight), then
-- IDF1 = 2 IDTP / (points of all real tracks + points of all tracks in road users).
CREATE OR REPLACE TEMP TABLE s_id_map AS
WITH shared AS (SELECT g.object_id, r.road_user, sum(g.w) AS w
                FROM s_gt_tracks g JOIN s_ru r USING (camera, track_id)
                GROUP BY g.object_id, r.road_user)
SELECT m.a AS object_id, m.b AS road_user, m.w AS shared
FROM (SELECT unnest(assign_pairs(coalesce(list({'a': object_id, 'b': road_user, 'w': w::DOUBLE}), []))) AS m FROM shared);

CREATE OR REPLACE TEMP TABLE s_objects AS
SELECT object_id, any_value(class) AS class, count(*) AS n_tracks, sum(w) AS w FROM s_gt_tracks GROUP BY object_id;

-- an object is exactly reconstructed when all its real tracks are in one road user whose
-- real tracks are exactly these
CREATE OR REPLACE TEMP TABLE s_exact AS
WITH placed AS (SELECT g.object_id, count(r.road_user) AS n_placed, count(DISTINCT r.road_user) AS n_ru, any_value(r.road_user) AS ru
                FROM s_gt_tracks g LEFT JOIN s_ru r USING (camera, track_id) GROUP BY g.object_id),
     ru_real AS (SELECT r.road_user, count(g.object_id) AS n_real FROM s_ru r LEFT JOIN s_gt_tracks g USING (camera, track_id) GROUP BY r.road_user)
SELECT o.object_id, o.class,
       p.n_placed = o.n_tracks AND p.n_ru = 1 AND coalesce(u.n_real, 0) = o.n_tracks AS exact
FROM s_objects o JOIN placed p USING (object_id) LEFT JOIN ru_real u ON u.road_user = p.ru;

-- within-camera links: a true break is two consecutive real tracks of one object in one
-- camera; it is found when links.csv puts both in one chain. A predicted link is two
-- consecutive pieces of one chain; it is correct when both are real tracks of one object.
CREATE OR REPLACE TEMP TABLE s_breaks AS
-- (window names distinct across the file: DuckDB 1.5's extract_statements refuses a repeated one)
SELECT g.camera, g.class, g.track_id AS a, lead(g.track_id) OVER w_break AS b
FROM s_gt_tracks g
WINDOW w_break AS (PARTITION BY g.camera, g.object_id ORDER BY g.t0, g.track_id)
QUALIFY b IS NOT NULL;

CREATE OR REPLACE TEMP TABLE s_pred_links AS
WITH pieces AS (SELECT l.camera, l.track_id, l.linked_id, tw.t0
                FROM s_links l LEFT JOIN s_track_w tw USING (camera, track_id))
SELECT camera, track_id AS a, lead(track_id) OVER w_link AS b
FROM pieces
WINDOW w_link AS (PARTITION BY camera, linked_id ORDER BY t0, track_id)
QUALIFY b IS NOT NULL;

-- HOTA (Luiten et al. 2021) at the track level: the detection is given (every real point of a
-- track is an observation), so only the association of observations to road users is scored.
-- Observations: the real points (estimated = 0) of every track. A track of a real object
-- (truth.csv is_noise = 0, object_id <> -1) gives its object g; noise and spurious tracks (or
-- tracks truth.csv lacks) give none. Its prediction p is the road user whose sources hold it.
-- TP: observations of an object in a road user; FN: of an object in none; FP: of noise in a road user.
--   DetA = TP / (TP + FN + FP)
--   AssA = 1/TP sum over TP c of TPA(c) / (TPA(c) + FNA(c) + FPA(c)), with c's (g, p):
--          TPA = n_gp, FNA = n_g - n_gp, FPA = n_p - n_gp (n_g: all observations of g; n_p: all
--          observations in p, noise too), so AssA = sum over (g, p) of n_gp^2 / (n_g + n_p - n_gp) / TP
--   HOTA = sqrt(DetA AssA)
-- Per class: the observations of that class only (an object's class; a noise track's own class).
CREATE OR REPLACE TEMP TABLE s_hota_tracks AS
WITH tw AS (SELECT camera, track_id, mode(class) AS class, count(*) AS w FROM s_points WHERE estimated = 0 GROUP BY camera, track_id)
SELECT tw.camera, tw.track_id, coalesce(o.class, tw.class) AS class, tw.w::DOUBLE AS w,
       CASE WHEN g.object_id <> -1 THEN g.object_id END AS g, r.road_user AS p
FROM tw
LEFT JOIN s_gt_tracks g USING (camera, track_id)
LEFT JOIN s_objects o ON o.object_id = g.object_id
LEFT JOIN s_ru r USING (camera, track_id);

CREATE OR REPLACE TEMP TABLE s_hota AS
WITH cls AS (SELECT DISTINCT class FROM s_hota_tracks UNION SELECT '*'),
     o AS (SELECT cls.class AS k, h.g, h.p, h.w FROM cls JOIN s_hota_tracks h ON cls.class IN ('*', h.class)),
     gp AS (SELECT k, g, p, sum(w) AS n_gp FROM o WHERE g IS NOT NULL AND p IS NOT NULL GROUP BY k, g, p),
     ng AS (SELECT k, g, sum(w) AS n_g FROM o WHERE g IS NOT NULL GROUP BY k, g),
     np AS (SELECT k, p, sum(w) AS n_p FROM o WHERE p IS NOT NULL GROUP BY k, p),
     ass AS (SELECT gp.k, sum(n_gp * n_gp / (n_g + n_p - n_gp)) AS s
             FROM gp JOIN ng ON ng.k = gp.k AND ng.g = gp.g JOIN np ON np.k = gp.k AND np.p = gp.p GROUP BY gp.k),
     det AS (SELECT k, coalesce(sum(w) FILTER (WHERE g IS NOT NULL AND p IS NOT NULL), 0) AS tp,
                    coalesce(sum(w) FILTER (WHERE g IS NOT NULL AND p IS NULL), 0) AS fn,
                    coalesce(sum(w) FILTER (WHERE g IS NULL AND p IS NOT NULL), 0) AS fp
             FROM o GROUP BY k),
     r AS (SELECT cls.class, coalesce(det.tp, 0) AS tp, coalesce(det.fn, 0) AS fn, coalesce(det.fp, 0) AS fp,
                  coalesce(det.tp / nullif(det.tp + det.fn + det.fp, 0), 0.0) AS deta,
                  coalesce(ass.s / nullif(det.tp, 0), 0.0) AS assa
           FROM cls LEFT JOIN det ON det.k = cls.class LEFT JOIN ass ON ass.k = cls.class)
SELECT class, tp, fn, fp, sqrt(deta * assa) AS hota, deta, assa FROM r;

-- one row per class and '*': identity measures
CREATE OR REPLACE TEMP TABLE s_identity AS
WITH cls AS (SELECT DISTINCT class FROM s_objects UNION SELECT '*'),
     pred_w AS (SELECT class, sum(w) AS w FROM s_ru GROUP BY class)
SELECT cls.class,
       2.0 * coalesce((SELECT sum(m.shared) FROM s_id_map m JOIN s_objects o USING (object_id) WHERE cls.class IN ('*', o.class)), 0)
           / greatest(coalesce((SELECT sum(w) FROM s_objects o WHERE cls.class IN ('*', o.class)), 0)
                      + coalesce((SELECT sum(w) FROM pred_w p WHERE cls.class IN ('*', p.class)), 0), 1) AS idf1,
       (SELECT avg(exact::INT) FROM s_exact e WHERE cls.class IN ('*', e.class)) AS exact_share,
       (SELECT count(*) FROM s_objects o WHERE cls.class IN ('*', o.class)) AS objects,
       (SELECT count(*) FROM s_breaks k WHERE cls.class IN ('*', k.class)) AS true_breaks,
       (SELECT count(*) FILTER (WHERE la.linked_id = lb.linked_id) FROM s_breaks k
          LEFT JOIN s_links la ON la.camera = k.camera AND la.track_id = k.a
          LEFT JOIN s_links lb ON lb.camera = k.camera AND lb.track_id = k.b
          WHERE cls.class IN ('*', k.class)) AS breaks_found,
       (SELECT count(*) FROM s_pred_links l LEFT JOIN s_gt_tracks ga ON ga.camera = l.camera AND ga.track_id = l.a
          WHERE cls.class = '*' OR ga.class = cls.class) AS links,
       (SELECT count(*) FILTER (WHERE ga.object_id = gb.object_id) FROM s_pred_links l
          LEFT JOIN s_gt_tracks ga ON ga.camera = l.camera AND ga.track_id = l.a
          LEFT JOIN s_gt_tracks gb ON gb.camera = l.camera AND gb.track_id = l.b
          WHERE cls.class = '*' OR ga.class = cls.class) AS links_correct,
       (SELECT hota FROM s_hota h WHERE h.class = cls.class) AS hota,
       (SELECT deta FROM s_hota h WHERE h.class = cls.class) AS deta,
       (SELECT assa FROM s_hota h WHERE h.class = cls.class) AS assa
FROM cls;


-- The match F1 per class (and '*'), written once: `trajdb score`, trajdb.score() and the demo
-- read it here. 0 when precision + recall is 0 or unknown.
CREATE OR REPLACE TEMP TABLE s_match_f1 AS
SELECT class, CASE WHEN precision + recall > 0 THEN 2.0 * precision * recall / (precision + recall) ELSE 0.0 END AS f1
FROM s_class_scores;

-- One row: the worst camera pair (rotation deg, translation m, clock offset error s over the
-- recording, drift error ppm; NULL when no camera pair was placed) and the overall figures.
CREATE OR REPLACE TEMP TABLE s_summary AS
SELECT e.rot_deg, e.trans_m, e.clock_s, e.drift_ppm,
       coalesce((SELECT f1 FROM s_match_f1 WHERE class = '*'), 0.0) AS match_f1,
       i.idf1, i.hota, i.deta, i.assa, i.exact_share AS exact
FROM (SELECT max(rot_deg) AS rot_deg, max(trans_m) AS trans_m, max(clock_err_s) AS clock_s, max(drift_err_ppm) AS drift_ppm
      FROM s_pair_err WHERE cam_from < cam_to) e,
     (SELECT * FROM s_identity WHERE class = '*') i;

-- The demo's targets (`trajdb demo`, scripts/demo.sh and trajdb.demo() read them here, one
-- place): match F1 >= 0.95 and every camera pair within 0.5 deg and 0.3 m.
-- `line` is the verdict `trajdb demo` and trajdb.demo() print (none: no camera pair placed).
CREATE OR REPLACE TEMP TABLE s_demo AS
WITH d AS (SELECT 0.95::DOUBLE AS target_f1, 0.5::DOUBLE AS target_rot_deg, 0.3::DOUBLE AS target_trans_m,
                  coalesce(match_f1 >= 0.95 AND rot_deg <= 0.5 AND trans_m <= 0.3, false) AS passed, s.*
           FROM s_summary s)
SELECT target_f1, target_rot_deg, target_trans_m, passed,
       format('demo {}: match F1 {} (target >= {}), IDF1 {}, worst camera pair {} deg / {} m (targets {} deg / {} m)',
              CASE WHEN passed THEN 'PASSED' ELSE 'FAILED' END, coalesce(printf('%.3f', match_f1), 'none'), target_f1,
              coalesce(printf('%.3f', idf1), 'none'), coalesce(printf('%.3f', rot_deg), 'none'), coalesce(printf('%.3f', trans_m), 'none'),
              target_rot_deg, target_trans_m) AS line
FROM d;

-- ---------------------------------------------------------------- the printout
-- What `trajdb score` (and `trajdb demo`) print, one row per line, in table s_printout
-- (section, k, line), ORDER BY section, k. Sections 10-20 and 40 are written here; section 30
-- (the paths, when the scenario has world.csv) by sql/score_path.sql. benches/identity_grid.sh
-- and tests/test_cli_python.py read the lines by position: change a column, change them too.
-- Numbers are printed as Rust's `{:.N}` did (the printout of the binary that preceded the
-- Python command): NULL or NaN as NaN (s_num), an optional figure's NULL as - (s_opt).
CREATE OR REPLACE TEMP MACRO s_num(v, fmt) AS
    CASE WHEN v IS NULL OR isnan(v::DOUBLE) THEN 'NaN' ELSE printf(fmt, v::DOUBLE) END;
CREATE OR REPLACE TEMP MACRO s_opt(v, fmt) AS CASE WHEN v IS NULL THEN '-' ELSE s_num(v, fmt) END;
CREATE OR REPLACE TEMP MACRO s_pct(v) AS CASE WHEN v IS NULL THEN '-' ELSE s_num(v * 100, '%+.1f') || '%' END;
CREATE OR REPLACE TEMP MACRO s_class(c) AS printf('%-14s', CASE WHEN c IS NULL THEN 'NULL' WHEN c = '*' THEN 'all' ELSE c END);
CREATE OR REPLACE TEMP MACRO s_int(n, w) AS printf('%' || w || 's', coalesce(n::VARCHAR, '-'));

CREATE OR REPLACE TEMP TABLE s_printout AS
SELECT 10 AS section, 0::BIGINT AS k,
       CASE WHEN rot_deg IS NOT NULL AND trans_m IS NOT NULL AND clock_s IS NOT NULL AND drift_ppm IS NOT NULL
            -- the line ends with the clock error in ms: benches/identity_grid.sh reads it there
            THEN format('camera pairs: worst rotation error {} deg, worst translation error {} m, worst clock drift error {} ppm, '
                        || 'worst clock offset error {} ms', s_num(rot_deg, '%.3f'), s_num(trans_m, '%.3f'), s_num(drift_ppm, '%.1f'),
                        s_num(clock_s * 1e3, '%.1f'))
            -- a run that placed no camera pair (transforms.csv without values): a score, not an error
            ELSE 'camera pairs: none placed (transforms.csv has no transform)' END AS line
FROM s_summary
UNION ALL
SELECT 11, row_number() OVER (ORDER BY cam_from, cam_to),
       CASE WHEN rot_deg IS NOT NULL AND trans_m IS NOT NULL AND clock_err_s IS NOT NULL AND drift_err_ppm IS NOT NULL
            THEN format('  {} -> {}: rotation {} deg, translation {} m, clock offset {} ms (worst over camera {}''s recording), '
                        || 'clock drift {} ppm', cam_from, cam_to, s_num(rot_deg, '%.3f'), s_num(trans_m, '%.3f'),
                        s_num(clock_err_s * 1e3, '%.1f'), cam_to, s_num(drift_err_ppm, '%.1f'))
            ELSE format('  {} -> {}: not placed', cam_from, cam_to) END
FROM s_pair_err WHERE cam_from < cam_to
UNION ALL
SELECT 20, k, line FROM (VALUES
    (-2, 'road users (from merged.parquet; IDF1 and HOTA over real points, exact = all of an object''s real tracks and nothing else in one road user):'),
    (-1, '  class            IDF1   exact  objects  link prec. break recall true breaks    links   HOTA   DetA   AssA')) v(k, line)
UNION ALL
SELECT 20, row_number() OVER (ORDER BY class = '*', class),
       format('  {} {} {} {} {} {} {} {} {} {} {}', s_class(class), printf('%6s', s_num(idf1, '%.3f')),
              printf('%7s', s_num(coalesce(exact_share, 0), '%.3f')), s_int(objects, 8),
              -- nothing to measure (no link made, no true break): -, not 0.000
              printf('%11s', CASE WHEN links > 0 THEN s_num(links_correct::DOUBLE / links, '%.3f') ELSE '-' END),
              printf('%12s', CASE WHEN true_breaks > 0 THEN s_num(breaks_found::DOUBLE / true_breaks, '%.3f') ELSE '-' END),
              s_int(true_breaks, 11), s_int(links, 8),
              printf('%6s', s_num(coalesce(hota, 0), '%.3f')), printf('%6s', s_num(coalesce(deta, 0), '%.3f')),
              printf('%6s', s_num(coalesce(assa, 0), '%.3f')))
FROM s_identity
UNION ALL
SELECT 40, k, line FROM (VALUES
    (-3, 'matches (a true pair: same object, >= 1 s together, >= 3 points each in the true overlap; a predicted pair of one'),
    (-2, 'object that misses that rule is neutral: right, so not against precision, but not a true pair either):'),
    (-1, '  class          precision  recall     F1 true pairs  predicted  neutral')) v(k, line)
UNION ALL
SELECT 40, row_number() OVER (ORDER BY s.class = '*', s.class),
       format('  {} {} {} {} {} {} {}', s_class(s.class), printf('%9s', s_num(s.precision, '%.3f')), printf('%7s', s_num(s.recall, '%.3f')),
              printf('%6s', s_num(f.f1, '%.3f')), s_int(s.true_pairs, 10), s_int(s.predicted, 10), s_int(s.neutral, 8))
FROM s_class_scores s JOIN s_match_f1 f ON f.class IS NOT DISTINCT FROM s.class;
