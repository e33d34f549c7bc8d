-- trajdb score, part 2 (run by `trajdb score` when the scenario has world.csv), after sql/score.sql.
-- merged paths against world.csv (the noise-free trajectories): every point of a road user's
-- merged trajectory against the object mapped to it (s_id_map), at the same time. The merged
-- frame and clock are the reference camera's (calibration.csv, 'reference camera'): a point
-- (t, x, y) is at world time t - clock_offset_s(reference) and world position R p + t of the
-- reference camera's true transform. World positions are interpolated linearly; merged points
-- outside the object's recorded time are not counted.
CREATE OR REPLACE TEMP TABLE s_path_err AS
WITH ref AS (SELECT value::INTEGER AS camera FROM read_csv(getvariable('score_results') || '/calibration.csv')
             WHERE scope = 'pipeline' AND quantity = 'reference camera'),
     rc AS (SELECT t.tf, coalesce(c.clock_offset_s, 0.0) AS off FROM s_true t JOIN s_cameras c USING (camera)
            WHERE camera = (SELECT camera FROM ref)),
     mp AS (SELECT road_user, class, unnest(traj) AS p FROM read_parquet(getvariable('score_results') || '/merged.parquet')),
     q AS (SELECT m.road_user, m.class, o.object_id, m.p.t - rc.off AS t, transform_point(rc.tf, m.p.x, m.p.y) AS w
           FROM mp m JOIN s_id_map o USING (road_user), rc),
     world AS (SELECT object_id, t, x, y FROM read_csv(getvariable('score_scenario') || '/world.csv')),
     lo AS (SELECT q.*, b.t AS tb, b.x AS xb, b.y AS yb FROM q ASOF JOIN world b ON b.object_id = q.object_id AND b.t <= q.t),
     hi AS (SELECT lo.*, a.t AS ta, a.x AS xa, a.y AS ya FROM lo ASOF JOIN world a ON a.object_id = lo.object_id AND a.t >= lo.t),
     e AS (SELECT road_user, class, object_id, t, w,
                  CASE WHEN ta > tb THEN (t - tb) / (ta - tb) ELSE 0.0 END AS u, xb, yb, xa, ya FROM hi)
SELECT road_user, class, object_id, t,
       sqrt((w.x - (xb + u * (xa - xb))) ** 2 + (w.y - (yb + u * (ya - yb))) ** 2) AS err_m
FROM e;

CREATE OR REPLACE TEMP TABLE s_path_summary AS
WITH cls AS (SELECT DISTINCT class FROM s_path_err UNION SELECT '*')
SELECT cls.class,
       (SELECT count(*) FROM s_path_err e WHERE cls.class IN ('*', e.class)) AS points,
       (SELECT median(err_m) FROM s_path_err e WHERE cls.class IN ('*', e.class)) AS median_m,
       (SELECT quantile_cont(err_m, 0.95) FROM s_path_err e WHERE cls.class IN ('*', e.class)) AS p95_m,
       (SELECT max(err_m) FROM s_path_err e WHERE cls.class IN ('*', e.class)) AS max_m,
       (SELECT count(DISTINCT road_user) FILTER (WHERE err_m > 1.0) FROM s_path_err e WHERE cls.class IN ('*', e.class)) AS off_1m
FROM cls;
