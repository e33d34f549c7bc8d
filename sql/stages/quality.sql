-- trajdb: track quality within one camera (Zhao et al. III): broken, split and merged tracks,
-- found from track endpoints; broken pieces are linked into one track before cross-camera
-- matching.
--
-- Input: `points(camera, track_id, class, t, x, y, estimated)`, camera-local frames.
-- Output:
--   quality_endpoints(camera, track_id, class, e)     first/last point and final velocity
--   quality_views(camera, interior)                   the camera's convex view shrunk by the inset
--   quality_events(camera, class, ev)                 traj_events(): kind, from_id, to_id, gap, distance
--   quality_links(camera, track_id, linked_id)        every track and the id of its linked chain
--   quality_flags(camera, track_id, flag)             'split' / 'merge' participants
--   quality_labels(camera, track_id, label, coherence) object / fragment / group (traj_labels, motion coherency)
--   points_linked                                     points with track_id replaced by linked_id (and `points` becomes it)
--
-- Parameters (defaults and why): a piece may resume up to 2.5 s later, within 2 m of where the track
-- would be at its final velocity (velocity over the last ~0.4 s), plus accel * gap^2 / 2 with
-- accel the class's measured 95th-percentile acceleration (calib_classes, calibrate.sql):
-- broken car tracks that were missed resumed 2.8-5.8 m from the constant-velocity prediction
-- after 1.4-2 s gaps (braking and pulling away at the stop line). OFF by default
-- (quality_max_accel = 0; `auto` switches it on): measured with benches/identity_grid.sh, it
-- raised break recall on simulated 5-25 Hz days (0.56-0.69 -> 0.94-1.00) but lowered it on the
-- real pedestrians of dut_intersection_3cam (0.732 -> 0.658: more ends with two starts in reach,
-- i.e. split/merge instead of broken) and cut link precision at 2 Hz (1.000 -> 0.944); endpoints closer than 1 m to
-- the view's edge are entries and exits, not events. Only tracks of the same class are linked.
-- Measured with benches/accuracy_quality.py: (2.5 s, 2 m, 1 m) links 73 % / 92 % of the true
-- breaks at precision 1.00 on the two DUT scenes; a 2 m inset (entries mistaken for nothing)
-- finds 52 % / 80 %, a 3 m radius adds split/merge ambiguity and finds fewer.
--
-- It ends by replacing `points` with `points_linked` (the original rows stay in
-- quality_endpoints / quality_links), so the cross-camera stages run on linked tracks.
-- Parameters (quality_*): declared once in src/app/params.rs, defaults in sql/params.sql;
-- `trajdb params` lists them, `trajdb pipeline --param name=value` or SET VARIABLE sets them.

CREATE OR REPLACE TEMP TABLE quality_endpoints AS
WITH t AS (
    SELECT camera, track_id, class, list({'t': t, 'x': x, 'y': y} ORDER BY t) AS traj
    FROM points WHERE estimated = 0
    GROUP BY camera, track_id, class
)
SELECT camera, track_id, class,
       {'id': track_id, 't0': traj[1].t, 'x0': traj[1].x, 'y0': traj[1].y,
        't1': traj[-1].t, 'x1': traj[-1].x, 'y1': traj[-1].y,
        'vx0': CASE WHEN len(traj) < 2 THEN 0 ELSE (traj[least(5, len(traj))].x - traj[1].x)
                    / greatest(traj[least(5, len(traj))].t - traj[1].t, 1e-3) END,
        'vy0': CASE WHEN len(traj) < 2 THEN 0 ELSE (traj[least(5, len(traj))].y - traj[1].y)
                    / greatest(traj[least(5, len(traj))].t - traj[1].t, 1e-3) END,
        'vx1': CASE WHEN len(traj) < 2 THEN 0 ELSE (traj[-1].x - traj[greatest(len(traj) - 4, 1)].x)
                    / greatest(traj[-1].t - traj[greatest(len(traj) - 4, 1)].t, 1e-3) END,
        'vy1': CASE WHEN len(traj) < 2 THEN 0 ELSE (traj[-1].y - traj[greatest(len(traj) - 4, 1)].y)
                    / greatest(traj[-1].t - traj[greatest(len(traj) - 4, 1)].t, 1e-3) END} AS e
FROM t;

CREATE OR REPLACE TEMP TABLE quality_views AS
SELECT camera, polygon_buffer(view_polygon(list({'x': x, 'y': y}), 'convex'), -getvariable('quality_inset')) AS interior
FROM points WHERE estimated = 0
GROUP BY camera;

-- traj_events takes the endpoints without the starting velocity
CREATE OR REPLACE TEMP TABLE quality_events AS
SELECT q.camera, q.class,
       unnest(traj_events(list({'id': e.id, 't0': e.t0, 'x0': e.x0, 'y0': e.y0, 't1': e.t1, 'x1': e.x1, 'y1': e.y1, 'vx1': e.vx1, 'vy1': e.vy1}),
                          getvariable('quality_max_gap'), getvariable('quality_max_dist'), any_value(v.interior),
                          coalesce(getvariable('quality_max_accel'), any_value(c.accel_p95), 0.0))) AS ev
FROM quality_endpoints q JOIN quality_views v USING (camera) LEFT JOIN calib_classes c USING (class)
GROUP BY q.camera, q.class;

CREATE OR REPLACE TEMP TABLE quality_labels AS
SELECT camera, class, l.id AS track_id, l.label, l.coherence
FROM (
    SELECT q.camera, q.class,
           unnest(traj_labels(list(q.e), getvariable('quality_max_gap'), getvariable('quality_max_dist'), any_value(v.interior))) AS l
    FROM quality_endpoints q JOIN quality_views v USING (camera)
    GROUP BY q.camera, q.class
);

-- Chains of broken pieces: merge_groups() joins them and refuses any link that would put two
-- time-overlapping pieces of the camera into one track.
CREATE OR REPLACE TEMP TABLE quality_links AS
SELECT camera, g.id AS track_id, g.grp AS linked_id
FROM (
    SELECT camera,
           unnest(merge_groups(
               list({'id': track_id, 'camera': camera, 't0': e.t0, 't1': e.t1}),
               coalesce((SELECT list({'a': ev.from_id, 'b': ev.to_id} ORDER BY ev.distance, ev.from_id)
                         FROM quality_events x WHERE x.camera = q.camera AND ev.kind = 'broken'), []))) AS g
    FROM quality_endpoints q
    GROUP BY camera
);

CREATE OR REPLACE TEMP TABLE quality_flags AS
SELECT DISTINCT camera, ev.from_id AS track_id, ev.kind AS flag FROM quality_events WHERE ev.kind IN ('split', 'merge')
UNION
SELECT DISTINCT camera, ev.to_id, ev.kind FROM quality_events WHERE ev.kind IN ('split', 'merge');

CREATE OR REPLACE TEMP TABLE points_linked AS
SELECT p.* REPLACE (coalesce(l.linked_id, p.track_id) AS track_id)
FROM points p LEFT JOIN quality_links l USING (camera, track_id);

-- The later stages work on the linked tracks.
CREATE OR REPLACE TEMP TABLE points AS SELECT * FROM points_linked;

SELECT ev.kind, count(*) AS events FROM quality_events GROUP BY ev.kind ORDER BY ev.kind;
SELECT label, count(*) AS tracks FROM quality_labels GROUP BY label ORDER BY label;
