-- trajdb score, part 2 (run by `trajdb score` when the scenario has world.csv), after sql/score.sql.
-- Paths against world.csv (the noise-free trajectories), each road user against the object
-- mapped to it (s_id_map), at the same time:
--  * s_path_err: every point of merged.parquet's traj (the fused path, sql/stages/fuse.sql);
--  * s_src_err: every real point of every source track of a road user, put into the reference
--    frame and clock by the PIPELINE's own transforms.csv (not the true transforms: the fair
--    comparison, what the analyst would get from that camera alone);
--  * s_fuse_vs_best: per class, over road users seen by two or more cameras, the fused path's
--    error against that of the best single camera of each road user (the camera with the
--    lowest median error), counted over the best camera's time span;
--  * s_path_quality: per class, the steps of the fused paths: jumps (consecutive points whose
--    errors differ by more than 1 m: a step the true motion does not make), the shortest time
--    step, the fastest step, and the mean speed length_m / duration_s against the true path's
--    over the same time.
-- The merged frame and clock are the reference camera's (calibration.csv, 'reference camera'): a
-- point (t, x, y) is at world time (t - clock_offset_s) / (1 + clock_drift_ppm 1e-6) of the
-- reference camera (cameras.csv; drift 0 when absent) and world position R p + t of its true
-- transform. World positions are interpolated linearly; points outside the object's recorded
-- time are not counted.

-- cameras.csv and transforms.csv with the clock drift column (0 when absent: older files)
CREATE OR REPLACE TEMP TABLE s_cam_clock AS
SELECT camera, coalesce(clock_offset_s, 0.0) AS off, coalesce(clock_drift_ppm, 0.0) * 1e-6 AS drift
FROM (SELECT * FROM s_cameras UNION ALL BY NAME SELECT NULL::DOUBLE AS clock_drift_ppm WHERE false);

-- the reference camera: calibration.csv's value is the stage's camera number; a text id is named
-- at the end of its `how`, (camera 'north') (docs/outputs.md). Matched to cameras.csv by its text.
CREATE OR REPLACE TEMP TABLE s_ref AS
SELECT k.camera, t.tf, c.off, c.drift
FROM (SELECT coalesce(nullif(regexp_extract(how, '\(camera ''(.*)''\)$', 1), ''), value::BIGINT::VARCHAR) AS name
      FROM read_csv(getvariable('score_results') || '/calibration.csv', types = {'value': 'DOUBLE', 'how': 'VARCHAR'})
      WHERE scope = 'pipeline' AND quantity = 'reference camera') r
JOIN (SELECT DISTINCT camera FROM s_cameras) k ON k.camera::VARCHAR = r.name
JOIN s_true t ON t.camera = k.camera JOIN s_cam_clock c ON c.camera = k.camera;

-- the pipeline's camera -> reference transforms and clocks: t_cam = (1 + d) t_ref + off
CREATE OR REPLACE TEMP TABLE s_to_ref AS
SELECT cam_from AS camera, {'theta': theta_rad, 'tx': tx, 'ty': ty, 'scale': scale} AS tf,
       coalesce(clock_offset_s, 0.0) AS off, clock_drift_ppm * 1e-6 AS drift
FROM s_tf
WHERE cam_to = (SELECT camera FROM s_ref) AND theta_rad IS NOT NULL AND tx IS NOT NULL AND ty IS NOT NULL
UNION ALL
SELECT camera, transform_identity(), 0.0, 0.0 FROM s_ref;

-- points to score: the fused paths (source NULL, k = position in traj) and every placed camera's
-- real points of the road user's tracks (source = camera), in world time and frame
CREATE OR REPLACE TEMP TABLE s_eval AS
WITH mp AS (SELECT road_user, class, unnest(traj) AS p, generate_subscripts(traj, 1) AS k
            FROM read_parquet(getvariable('score_results') || '/merged.parquet')),
     -- source: NULL for the fused path, else the camera (whatever the type of its ids)
     fused AS (SELECT m.road_user, m.class, NULL AS source, m.k, m.p.t AS t_ref, m.p.x, m.p.y FROM mp m),
     src AS (SELECT r.road_user, r.class, p.camera AS source, NULL::BIGINT AS k,
                    clock_to_reference(p.t, c.off, c.drift) AS t_ref, tp.w.x AS x, tp.w.y AS y
             FROM s_points p
             JOIN s_ru r ON r.camera = p.camera AND r.track_id = p.track_id
             JOIN s_to_ref c ON c.camera = p.camera,
             LATERAL (SELECT transform_point(c.tf, p.x, p.y) AS w) tp
             WHERE p.estimated = 0)
SELECT e.road_user, e.class, o.object_id, e.source, e.k, e.t_ref,
       (e.t_ref - s_ref.off) / (1 + s_ref.drift) AS t, transform_point(s_ref.tf, e.x, e.y) AS w
FROM (SELECT * FROM fused UNION ALL SELECT * FROM src) e
JOIN s_id_map o USING (road_user), s_ref;

CREATE OR REPLACE TEMP TABLE s_eval_err AS
WITH world AS (SELECT object_id, t, x, y FROM read_csv(getvariable('score_scenario') || '/world.csv')),
     lo AS (SELECT q.*, b.t AS tb, b.x AS xb, b.y AS yb FROM s_eval q ASOF JOIN world b ON b.object_id = q.object_id AND b.t <= q.t),
     hi AS (SELECT lo.*, a.t AS ta, a.x AS xa, a.y AS ya FROM lo ASOF JOIN world a ON a.object_id = lo.object_id AND a.t >= lo.t),
     e AS (SELECT *, CASE WHEN ta > tb THEN (t - tb) / (ta - tb) ELSE 0.0 END AS u FROM hi)
SELECT road_user, class, object_id, source, k, t_ref, t, w.x AS x, w.y AS y,
       w.x - (xb + u * (xa - xb)) AS ex, w.y - (yb + u * (ya - yb)) AS ey,
       sqrt((w.x - (xb + u * (xa - xb))) ** 2 + (w.y - (yb + u * (ya - yb))) ** 2) AS err_m
FROM e;

CREATE OR REPLACE TEMP TABLE s_path_err AS
SELECT road_user, class, object_id, t, err_m FROM s_eval_err WHERE source IS NULL;
CREATE OR REPLACE TEMP TABLE s_src_err AS
SELECT road_user, class, object_id, source AS camera, t, err_m FROM s_eval_err WHERE source IS NOT NULL;

CREATE OR REPLACE TEMP TABLE s_path_summary AS
WITH cls AS (SELECT DISTINCT class FROM s_path_err UNION SELECT '*')
SELECT cls.class,
       (SELECT count(*) FROM s_path_err e WHERE cls.class IN ('*', e.class)) AS points,
       (SELECT median(err_m) FROM s_path_err e WHERE cls.class IN ('*', e.class)) AS median_m,
       (SELECT quantile_cont(err_m, 0.95) FROM s_path_err e WHERE cls.class IN ('*', e.class)) AS p95_m,
       (SELECT max(err_m) FROM s_path_err e WHERE cls.class IN ('*', e.class)) AS max_m,
       (SELECT count(DISTINCT road_user) FILTER (WHERE err_m > 1.0) FROM s_path_err e WHERE cls.class IN ('*', e.class)) AS off_1m
FROM cls;

-- fused vs the best single camera, road users seen by >= 2 cameras (>= 3 scored points each)
CREATE OR REPLACE TEMP TABLE s_fuse_vs_best AS
WITH per_cam AS (SELECT road_user, camera, median(err_m) AS med, min(t) AS t0, max(t) AS t1
                 FROM s_src_err GROUP BY road_user, camera HAVING count(*) >= 3),
     multi AS (SELECT road_user FROM per_cam GROUP BY road_user HAVING count(*) >= 2),
     best AS (SELECT p.* FROM per_cam p JOIN multi USING (road_user)
              QUALIFY row_number() OVER (PARTITION BY road_user ORDER BY med, camera) = 1),
     fe AS (SELECT f.class, f.err_m FROM s_path_err f JOIN best b USING (road_user) WHERE f.t BETWEEN b.t0 AND b.t1),
     be AS (SELECT s.class, s.err_m FROM s_src_err s JOIN best b USING (road_user, camera)),
     cls AS (SELECT DISTINCT class FROM be UNION SELECT '*')
SELECT cls.class,
       (SELECT count(DISTINCT b.road_user) FROM best b JOIN (SELECT DISTINCT road_user, class FROM s_src_err) c USING (road_user)
        WHERE cls.class IN ('*', c.class)) AS road_users,
       (SELECT median(err_m) FROM fe WHERE cls.class IN ('*', fe.class)) AS fused_median_m,
       (SELECT quantile_cont(err_m, 0.95) FROM fe WHERE cls.class IN ('*', fe.class)) AS fused_p95_m,
       (SELECT median(err_m) FROM be WHERE cls.class IN ('*', be.class)) AS best_median_m,
       (SELECT quantile_cont(err_m, 0.95) FROM be WHERE cls.class IN ('*', be.class)) AS best_p95_m
FROM cls;

-- steps of the fused paths, and the mean speed against the truth's over the same time
CREATE OR REPLACE TEMP TABLE s_path_steps AS
SELECT road_user, class, object_id, t, t_ref - lag(t_ref) OVER w AS dt,
       sqrt((x - lag(x) OVER w) ** 2 + (y - lag(y) OVER w) ** 2) AS step_m,
       sqrt((ex - lag(ex) OVER w) ** 2 + (ey - lag(ey) OVER w) ** 2) AS jump_m
FROM s_eval_err WHERE source IS NULL
WINDOW w AS (PARTITION BY road_user ORDER BY k);

CREATE OR REPLACE TEMP TABLE s_speed_ratio AS
WITH ru AS (SELECT road_user, class, object_id, traj_length_m(traj) AS len, traj_duration(traj) AS dur,
                   (traj_time_range(traj).t_start - (SELECT off FROM s_ref)) / (1 + (SELECT drift FROM s_ref)) AS w0,
                   (traj_time_range(traj).t_end - (SELECT off FROM s_ref)) / (1 + (SELECT drift FROM s_ref)) AS w1
            FROM read_parquet(getvariable('score_results') || '/merged.parquet') JOIN s_id_map USING (road_user)),
     world AS (SELECT object_id, t, x, y FROM read_csv(getvariable('score_scenario') || '/world.csv')),
     tl AS (SELECT ru.road_user, sum(sqrt((w.x - w.px) ** 2 + (w.y - w.py) ** 2)) AS true_len, max(w.t) - min(w.pt) AS true_dur
            FROM ru JOIN (SELECT object_id, t, x, y, lag(x) OVER o AS px, lag(y) OVER o AS py, lag(t) OVER o AS pt
                          FROM world WINDOW o AS (PARTITION BY object_id ORDER BY t)) w
              ON w.object_id = ru.object_id AND w.pt >= ru.w0 AND w.t <= ru.w1
            GROUP BY ru.road_user)
SELECT ru.road_user, ru.class, (ru.len / ru.dur) / (tl.true_len / tl.true_dur) AS ratio
FROM ru JOIN tl USING (road_user)
WHERE ru.dur >= 1.0 AND tl.true_dur > 0 AND tl.true_len > 0.5;  -- moving road users seen >= 1 s

CREATE OR REPLACE TEMP TABLE s_path_quality AS
WITH cls AS (SELECT DISTINCT class FROM s_path_steps UNION SELECT '*')
SELECT cls.class,
       (SELECT count(*) FILTER (WHERE jump_m > 1.0) FROM s_path_steps s WHERE cls.class IN ('*', s.class)) AS jumps_1m,
       (SELECT max(jump_m) FROM s_path_steps s WHERE cls.class IN ('*', s.class)) AS max_jump_m,
       (SELECT min(dt) FROM s_path_steps s WHERE cls.class IN ('*', s.class)) AS min_step_s,
       (SELECT max(step_m / dt) FILTER (WHERE dt > 0) FROM s_path_steps s WHERE cls.class IN ('*', s.class)) AS max_speed,
       (SELECT median(ratio) - 1 FROM s_speed_ratio r WHERE cls.class IN ('*', r.class)) AS speed_over_median,
       (SELECT quantile_cont(ratio, 0.95) - 1 FROM s_speed_ratio r WHERE cls.class IN ('*', r.class)) AS speed_over_p95
FROM cls;

-- The printout's section 30 (sql/score.sql's s_printout: `trajdb score` prints it in order).
INSERT INTO s_printout
SELECT 30, k, line FROM (VALUES
    (-3, 'merged paths against world.csv (each road user''s mapped object, at the same time):'),
    (-2, '  class             points  median m     p95 m     max m   road users > 1 m')) v(k, line)
UNION ALL
SELECT 30, row_number() OVER (ORDER BY class = '*', class),
       format('  {} {} {} {} {} {}', s_class(class), s_int(points, 9), printf('%9s', s_opt(median_m, '%.3f')),
              printf('%9s', s_opt(p95_m, '%.3f')), printf('%9s', s_opt(max_m, '%.3f')), s_int(off_1m, 18))
FROM s_path_summary
UNION ALL
SELECT 30, 100 + k, line FROM (VALUES
    (0, 'fused vs the best single camera (road users seen by >= 2 cameras; each camera mapped by the pipeline''s transforms.csv,'),
    (1, 'the best = lowest median error, over its time span; ratio = fused / best, target <= 0.6):'),
    (2, '  class           road users  fused med m     p95 m  best med m     p95 m  ratio median  ratio p95')) v(k, line)
UNION ALL
SELECT 30, 110 + row_number() OVER (ORDER BY class = '*', class),
       format('  {} {} {} {} {} {} {} {}', s_class(class), s_int(road_users, 11), printf('%12s', s_opt(fused_median_m, '%.3f')),
              printf('%9s', s_opt(fused_p95_m, '%.3f')), printf('%11s', s_opt(best_median_m, '%.3f')), printf('%9s', s_opt(best_p95_m, '%.3f')),
              printf('%13s', CASE WHEN fused_median_m IS NOT NULL AND best_median_m > 0 THEN s_num(fused_median_m / best_median_m, '%.2f') ELSE '-' END),
              printf('%10s', CASE WHEN fused_p95_m IS NOT NULL AND best_p95_m > 0 THEN s_num(fused_p95_m / best_p95_m, '%.2f') ELSE '-' END))
FROM s_fuse_vs_best
UNION ALL
SELECT 30, 200 + k, line FROM (VALUES
    (0, 'fused path steps (jump: consecutive points whose errors differ by > 1 m; mean speed = length_m / duration_s against the'),
    (1, 'true path''s over the same time, road users seen >= 1 s, as over- (+) or understatement):'),
    (2, '  class           jumps>1m max jump m   min step s  max speed m/s mean speed median mean speed p95')) v(k, line)
UNION ALL
SELECT 30, 210 + row_number() OVER (ORDER BY class = '*', class),
       format('  {} {} {} {} {} {} {}', s_class(class), s_int(jumps_1m, 9), printf('%10s', s_opt(max_jump_m, '%.3f')),
              -- Rust's {:.2e} below 1 ms: 1.50e-4 (no plus sign, no zero padding in the exponent)
              printf('%12s', CASE WHEN min_step_s IS NULL THEN '-'
                                  WHEN abs(min_step_s) < 1e-3 THEN regexp_replace(replace(printf('%.2e', min_step_s), 'e+', 'e'), 'e(-?)0+(\d)', 'e\1\2')
                                  ELSE s_num(min_step_s, '%.4f') END),
              printf('%14s', s_opt(max_speed, '%.3f')), printf('%17s', s_pct(speed_over_median)), printf('%14s', s_pct(speed_over_p95)))
FROM s_path_quality;
