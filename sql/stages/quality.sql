-- trajdb: track quality within one camera (Zhao et al. III): broken, split and merged tracks,
-- found from track endpoints; broken pieces are linked into one track before cross-camera
-- matching.
--
-- Input: `points(camera, track_id, class, t, x, y, estimated)`, camera-local frames.
-- Output:
--   quality_endpoints(camera, track_id, class, e)     first/last point and final velocity
--   quality_views(camera, interior)                   the camera's convex view shrunk by the inset
--   quality_events(camera, class, ev)                 traj_events(): kind, from_id, to_id, gap, distance
--   quality_events_cv / quality_reach                 pass 1 events / pass 2 'broken' candidates
--   quality_links(camera, track_id, linked_id)        every track and the id of its linked chain (pass 1)
--   quality_reach_links(camera, from_id, to_id)       pass 2 candidates between chains (merge.sql)
--   quality_flags(camera, track_id, flag)             'split' / 'merge' participants
--   quality_labels(camera, track_id, label, coherence) object / fragment / group (traj_labels, motion coherency)
--   points_linked                                     points with track_id replaced by linked_id (and `points` becomes it)
--
-- Parameters (defaults and why): a piece may resume up to 2.5 s later, within 2 m of where the track
-- would be at its final velocity (velocity over the last ~0.4 s); endpoints closer than 1 m to
-- the view's edge are entries and exits, not events. Only tracks of the same class are linked.
-- Measured with benches/accuracy_quality.py: (2.5 s, 2 m, 1 m) links 73 % / 92 % of the true
-- breaks at precision 1.00 on the two DUT scenes; a 2 m inset (entries mistaken for nothing)
-- finds 52 % / 80 %, a 3 m radius adds split/merge ambiguity and finds fewer.
-- The breaks this constant-velocity rule misses are road users that braked or pulled away in
-- the gap (missed car breaks resumed 2.8-5.8 m from the prediction after 1.4-2 s). A second
-- pass over the ends and starts pass 1 left alone allows max_dist + accel * gap^2 / 2, accel
-- the class's measured 95th-percentile acceleration (calib_classes, calibrate.sql;
-- quality_max_accel overrides it, 0 turns the pass into the same rule on the leftovers). Its
-- candidates ('reach') are not applied here but offered to merge_groups() after all
-- cross-camera links (merge.sql), so other cameras can refuse them. Measured with
-- benches/identity_grid.sh: break recall 0.46-0.92 -> 0.91-1.00 over the grid, link precision
-- 1.000 in every cell (applied here directly instead, one wrong 2 Hz link cut precision to 0.947).
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

-- traj_events takes the endpoints without the starting velocity.
-- Pass 1, the constant-velocity rule (accel 0): every end and every start of the class.
CREATE OR REPLACE TEMP TABLE quality_events_cv AS
SELECT q.camera, q.class,
       unnest(traj_events(list({'id': e.id, 't0': e.t0, 'x0': e.x0, 'y0': e.y0, 't1': e.t1, 'x1': e.x1, 'y1': e.y1, 'vx1': e.vx1, 'vy1': e.vy1}),
                          getvariable('quality_max_gap'), getvariable('quality_max_dist'), any_value(v.interior), 0.0)) AS ev
FROM quality_endpoints q JOIN quality_views v USING (camera)
GROUP BY q.camera, q.class;

-- Pass 2, the acceleration allowance (max_dist + accel gap^2/2, accel the class's measured 95th
-- percentile unless quality_max_accel is given), among the ends and starts pass 1 left unlinked.
-- Applied to all endpoints at once it turned one-to-one breaks into split/merge ambiguities
-- (recall on the real DUT pedestrians fell 0.732 -> 0.658) and linked wrong pieces at 2 Hz
-- (precision 0.944). Restricted to the leftovers it only adds candidates, and they are not
-- applied here: merge.sql offers them to merge_groups() after every cross-camera link, so a
-- 'reach' link that would join two road users other cameras see apart at the same time is
-- refused. An end or start pass 1 already linked is moved out of the view (x = 1e300:
-- traj_events ignores endpoints outside `interior`).
CREATE OR REPLACE TEMP TABLE quality_reach AS
WITH used_end AS (SELECT DISTINCT camera, ev.from_id AS track_id FROM quality_events_cv WHERE ev.kind = 'broken'),
used_start AS (SELECT DISTINCT camera, ev.to_id AS track_id FROM quality_events_cv WHERE ev.kind = 'broken'),
reach AS (
    SELECT q.camera, q.class,
           unnest(traj_events(list({'id': e.id, 't0': e.t0,
                                    'x0': CASE WHEN us.track_id IS NULL THEN e.x0 ELSE 1e300 END, 'y0': e.y0,
                                    't1': e.t1,
                                    'x1': CASE WHEN ue.track_id IS NULL THEN e.x1 ELSE 1e300 END, 'y1': e.y1,
                                    'vx1': e.vx1, 'vy1': e.vy1}),
                              getvariable('quality_max_gap'), getvariable('quality_max_dist'), any_value(v.interior),
                              coalesce(getvariable('quality_max_accel'), any_value(c.accel_p95), 0.0))) AS ev
    FROM quality_endpoints q JOIN quality_views v USING (camera) LEFT JOIN calib_classes c USING (class)
    LEFT JOIN used_end ue ON ue.camera = q.camera AND ue.track_id = q.track_id
    LEFT JOIN used_start us ON us.camera = q.camera AND us.track_id = q.track_id
    GROUP BY q.camera, q.class
)
SELECT camera, class, ev FROM reach WHERE ev.kind = 'broken';

-- every event: pass 1, and the pass-2 candidates as kind 'reach'
CREATE OR REPLACE TEMP TABLE quality_events AS
SELECT camera, class, ev FROM quality_events_cv
UNION ALL
SELECT camera, class, {'kind': 'reach', 'from_id': ev.from_id, 'to_id': ev.to_id, 'gap': ev.gap, 'distance': ev.distance}
FROM quality_reach;

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
                         FROM quality_events_cv x WHERE x.camera = q.camera AND ev.kind = 'broken'), []))) AS g
    FROM quality_endpoints q
    GROUP BY camera
);

-- The pass-2 candidates between linked chains (merge.sql offers them to merge_groups last).
CREATE OR REPLACE TEMP TABLE quality_reach_links AS
SELECT r.camera, la.linked_id AS from_id, lb.linked_id AS to_id, r.ev.distance
FROM quality_reach r
JOIN quality_links la ON la.camera = r.camera AND la.track_id = r.ev.from_id
JOIN quality_links lb ON lb.camera = r.camera AND lb.track_id = r.ev.to_id
WHERE la.linked_id <> lb.linked_id;

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
