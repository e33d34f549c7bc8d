-- stage: quality
-- reads: points, calib_cameras, calib_fit_window, calibrated(), calibrated_values()
-- makes: quality_endpoints, quality_views, quality_start_density, quality_starts, quality_pi, quality_candidates, quality_breaks,
--        quality_events, quality_labels, quality_links, quality_reach_links, quality_flags
-- work: quality_fit, quality_pairs, quality_events_cv, quality_reach
-- changes: points
-- parameters: quality_inset, quality_max_accel, quality_max_dist, quality_max_gap
--
-- trajdb: track quality within one camera (Zhao et al. III): broken, split and merged tracks,
-- found from track endpoints; broken pieces are linked into one track before cross-camera
-- matching.
--
-- Input: `points(camera, track_id, class, t, x, y, estimated)`, camera-local frames.
-- Output:
--   quality_endpoints(camera, track_id, class, e)     first/last point and final velocity
--   quality_views(camera, interior)                   the camera's convex view shrunk by the inset
--   quality_start_density(camera, class, starts_per_m2_s, span_s, local_radius_m)  starts inside the view per m^2
--                                                     and s (site-wide), the recording's span, the radius of the local density
--   quality_starts(camera, class, x, y, kx, ky)       every start inside the view (the local density's points)
--   quality_pairs                                     every end -> start pair within the acceleration model's gate
--   quality_pi(camera, class, pi, pi_n)               the share of standing continuations at constant velocity (a site measurement)
--   quality_fit(camera, track_id, ...)                least-squares lines over a track's first and last
--                                                     calib_fit_window seconds (calibrate.sql)
--   quality_candidates(camera, class, from_id, to_id, every end -> start pair inside the gates, with its
--                      gap, distance, z2_cv, z2, ll, ...) chi2 statistics and log-likelihoods (below)
--   quality_breaks(..., kind)                         the links: 'broken' (applied here) or 'reach'
--   quality_events_cv                                 traj_events(): the paper's broken / split / merge rules
--   quality_events(camera, class, ev)                 traj_events' splits and merges, the links ('broken',
--                                                     'reach') and the other candidates ('candidate')
--   quality_reach                                     the 'reach' links (as events)
--   quality_links(camera, track_id, linked_id)        every track and the id of its linked chain
--   quality_reach_links(camera, from_id, to_id)       'reach' links between chains (merge.sql offers them last)
--   quality_flags(camera, track_id, flag)             'split' / 'merge' participants
--   quality_labels(camera, track_id, label, coherence) object / fragment / group (traj_labels, motion coherency)
--   points                                            (changed) track_id replaced by linked_id
--
-- Links (docs/association.md): from the measured noise, not from fixed distances. Every end and
-- start of one camera and class within quality_max_gap (2.5 s) and inside the view (more than
-- quality_inset = 1 m from its edge: entries and exits are not events) is a pair; both ends are
-- extrapolated to the middle of the gap by least-squares lines, and the pair is a candidate when
-- the chi2 statistic of position and velocity (4 degrees of freedom) is under 13.28 (0.99) with an
-- acceleration allowance from the class's measured accel_p95. Candidates are scored under a
-- mixture (break_evidence): the road user kept its velocity (share pi, measured on the
-- unambiguous candidates) or accelerated. A link is taken only when it is the mutual best of its
-- end and start and at least 100 times likelier than every other candidate of either (the ratio
-- test). It is applied here ('broken') when it also passes without the acceleration allowance and
-- is 100 times likelier than an unrelated start at that place (the density of starts about the
-- candidate's start, never below the view's average); a winner that is likelier than an unrelated
-- start, but less so or only with the acceleration allowance, is a 'reach' link that merge.sql
-- offers after every cross-camera link, so other cameras can refuse it; any other winner is not
-- linked. traj_events (the paper's
-- three rules with quality_max_dist = 2 m) still flags splits and merges, and traj_labels labels
-- tracks; neither links.
-- Measured (trajdb pipeline + trajdb score; docs/association.md): dut_intersection_3cam break recall
-- 0.906 -> 0.973 at link precision 1.000, dut_roundabout_2cam 1.000 / 1.000; waiting crowds at
-- sigma 0.15-0.3 m: link precision 0.91-0.96 -> 1.000.
--
-- It ends by replacing `points`' track_id by linked_id (the original rows stay in
-- quality_endpoints / quality_links), so the cross-camera stages run on linked tracks.
-- Parameters (quality_*): declared once in crates/app/src/params.rs, defaults in sql/params.sql;
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

-- traj_events takes the endpoints without the starting velocity: the paper's rules (for the
-- split / merge flags), every end and every start of the class.
CREATE OR REPLACE TEMP TABLE quality_events_cv AS
SELECT q.camera, q.class,
       unnest(traj_events(list({'id': e.id, 't0': e.t0, 'x0': e.x0, 'y0': e.y0, 't1': e.t1, 'x1': e.x1, 'y1': e.y1, 'vx1': e.vx1, 'vy1': e.vy1}),
                          getvariable('quality_max_gap'), getvariable('quality_max_dist'), any_value(v.interior), 0.0)) AS ev
FROM quality_endpoints q JOIN quality_views v USING (camera)
GROUP BY q.camera, q.class;

-- Break links, by design from the measured noise (calib_cameras.sigma_m, calib_classes.accel_p95,
-- calib_fit_window): every end a and every start b of one camera and class, with
-- 0 <= gap = b.t0 - a.t1 <= quality_max_gap and both endpoints inside the view, are compared at the
-- middle of the gap tau: a's last fit_window_s seconds and b's first, each a least-squares line
-- x(t) = xbar + v (t - tbar), are extrapolated to tau. With the camera's sigma, a line fitted to n
-- points predicts x(tau) with variance sigma^2 (1/n + (tau - tbar)^2 / Sxx) per axis and its
-- velocity with sigma^2 / Sxx (a 10 Hz track's velocity over 0.4 s has sigma 1 m/s at
-- sigma = 0.3 m: a waiting pedestrian's predicted position wanders by metres). So the position
-- difference d and the velocity difference dv have
--   var_cv  = var_a + var_b,               varv_cv  = sigma_a^2 / Sxx_a + sigma_b^2 / Sxx_b    (constant velocity)
--   var     = var_cv + (sigma_acc gap^2 / 2)^2,  varv = varv_cv + (sigma_acc gap)^2
-- with sigma_acc = accel_p95 / 2.45 (Rayleigh: p95 = 2.45 sigma), and z^2 = |d|^2 / var + |dv|^2 / varv
-- is chi2(4) for the true continuation. A pair is a candidate when z^2 <= 13.28 (chi2(4) at 0.99).
-- Its log-likelihood under the mixture of the two models (break_evidence: kept its velocity, share
-- pi, or accelerated) ranks the candidates, and a link is taken only when it is the mutual best of
-- its end and its start and beats every other candidate of either by ll_best - ll_other >= ln(100):
-- the likelihood ratio test, 1 wrong link in 100 at most when two people could both have made the
-- gap (a crowd waiting 0.6-2 m apart). A winner that also passes without the acceleration
-- allowance (z_cv^2 <= 13.28) and whose position is 100 times likelier than an unrelated start
-- there (ll_bg: the mixture's position density against the density of starts about the
-- candidate's start, per m^2 and quality_max_gap seconds) is linked here ('broken'); a winner with
-- 0 <= ll_bg is a 'reach' link, offered to merge_groups() after every cross-camera link
-- (merge.sql), so other cameras can refuse it (a short fragment's prediction is too vague to be
-- taken on its own). Ambiguous gaps are not linked: if another camera sees the road user through
-- the gap, its matches join the pieces (merge.sql, 'split' links, exported as links).
CREATE OR REPLACE TEMP TABLE quality_fit AS
WITH p AS (
    SELECT p.camera, p.track_id, p.t, p.x, p.y,
           p.t - max(p.t) OVER w AS te, p.t - min(p.t) OVER w AS ts,
           coalesce(w.fit_window_s, 1.0) AS win
    FROM points p LEFT JOIN calib_fit_window w USING (camera, class)
    WHERE p.estimated = 0
    WINDOW w AS (PARTITION BY p.camera, p.track_id)
)
SELECT camera, track_id,
       count(*) FILTER (WHERE te >= -win) AS n1, avg(te) FILTER (WHERE te >= -win) AS tbar1,
       avg(x) FILTER (WHERE te >= -win) AS xbar1, avg(y) FILTER (WHERE te >= -win) AS ybar1,
       coalesce(regr_slope(x, te) FILTER (WHERE te >= -win), 0) AS vx1, coalesce(regr_slope(y, te) FILTER (WHERE te >= -win), 0) AS vy1,
       coalesce(regr_sxx(x, te) FILTER (WHERE te >= -win), 0) AS sxx1,
       count(*) FILTER (WHERE ts <= win) AS n0, avg(ts) FILTER (WHERE ts <= win) AS tbar0,
       avg(x) FILTER (WHERE ts <= win) AS xbar0, avg(y) FILTER (WHERE ts <= win) AS ybar0,
       coalesce(regr_slope(x, ts) FILTER (WHERE ts <= win), 0) AS vx0, coalesce(regr_slope(y, ts) FILTER (WHERE ts <= win), 0) AS vy0,
       coalesce(regr_sxx(x, ts) FILTER (WHERE ts <= win), 0) AS sxx0
FROM p GROUP BY camera, track_id;

-- the density of starts inside the view (per m^2 and s, per camera and class): how likely an
-- unrelated road user appears where a broken one was expected; and where starts crowd (a waiting
-- area, a bus stop, a door, a place where people hide each other), the density about a start
-- (quality_starts: the starts themselves, counted within local_radius_m of a candidate's start).
-- local_radius_m: the 95 % radius (chi2(2) 5.99) of where a road user of the class reappears
-- after half the largest gap, from the camera's noise and the class's acceleration allowance
-- (at least 1 m). Measurements of the site (like quality_views): python/trajdb/windows.py ships
-- them to every window.
CREATE OR REPLACE TEMP TABLE quality_start_density AS
SELECT q.camera, q.class,
       greatest(count(*) FILTER (WHERE polygon_contains(v.interior, q.e.x0, q.e.y0)), 1)
         / greatest(any_value(polygon_area(v.interior)), 1.0) / any_value(sp.span_s) AS starts_per_m2_s,
       any_value(sp.span_s) AS span_s,
       noise_reappear_radius_95(greatest(coalesce(any_value(c.sigma_m), 0), 1e-3),
                                coalesce(noise_sigma_from_rayleigh_p95(coalesce(any_value(k.value), calibrated('quality_max_accel'))), 0.0),
                                getvariable('quality_max_gap') / 2, 1.0) AS local_radius_m
FROM quality_endpoints q JOIN quality_views v USING (camera)
-- the camera's recording span (a class seen twice in an hour is rare over the hour, not over the
-- minute between its two road users)
JOIN (SELECT camera, greatest(max(e.t1) - min(e.t0), 1.0) AS span_s FROM quality_endpoints GROUP BY camera) sp USING (camera)
LEFT JOIN calib_cameras c USING (camera) LEFT JOIN calibrated_values('quality_max_accel') k ON k.class = q.class
GROUP BY q.camera, q.class;

CREATE OR REPLACE TEMP TABLE quality_starts AS
SELECT q.camera, q.class, q.e.x0 AS x, q.e.y0 AS y,
       floor(q.e.x0 / d.local_radius_m)::BIGINT AS kx, floor(q.e.y0 / d.local_radius_m)::BIGINT AS ky
FROM quality_endpoints q JOIN quality_views v USING (camera) JOIN quality_start_density d USING (camera, class)
WHERE polygon_contains(v.interior, q.e.x0, q.e.y0);

CREATE OR REPLACE TEMP TABLE quality_pairs AS
WITH e AS (
    SELECT q.camera, q.class, q.track_id, q.e.t1 AS t1, q.e.t0 AS t0, f.*  EXCLUDE (camera, track_id),
           greatest(coalesce(c.sigma_m, 0), 1e-3) ** 2 AS s2,
           -- the class's quality_max_accel (calibrate.sql: given, else its measured accel_p95),
           -- else the default row (given, else no allowance)
           noise_sigma_from_rayleigh_p95(coalesce(k.value, calibrated('quality_max_accel'))) ** 2 AS sa2,
           polygon_contains(v.interior, q.e.x1, q.e.y1) AS end_inside,
           polygon_contains(v.interior, q.e.x0, q.e.y0) AS start_inside
    FROM quality_endpoints q JOIN quality_fit f USING (camera, track_id) JOIN quality_views v USING (camera)
    LEFT JOIN calib_cameras c USING (camera) LEFT JOIN calibrated_values('quality_max_accel') k ON k.class = q.class
),

-- time buckets of quality_max_gap: a start lies in its end's bucket or the next
pairs AS (
    SELECT a.camera, a.class, a.track_id AS from_id, b.track_id AS to_id, b.t0 - a.t1 AS gap,
           (a.t1 + b.t0) / 2 AS tau, a.t1 AS t1, b.t0 AS t0,
           a.xbar1 + a.vx1 * ((b.t0 - a.t1) / 2 - a.tbar1) - (b.xbar0 + b.vx0 * (-(b.t0 - a.t1) / 2 - b.tbar0)) AS dx,
           a.ybar1 + a.vy1 * ((b.t0 - a.t1) / 2 - a.tbar1) - (b.ybar0 + b.vy0 * (-(b.t0 - a.t1) / 2 - b.tbar0)) AS dy,
           a.s2 * (1.0 / a.n1 + ((b.t0 - a.t1) / 2 - a.tbar1) ** 2 / a.sxx1)
             + b.s2 * (1.0 / b.n0 + (-(b.t0 - a.t1) / 2 - b.tbar0) ** 2 / b.sxx0) AS var_cv,
           a.sa2 * ((b.t0 - a.t1) ** 2 / 2) ** 2 AS var_acc,
           b.vx0 - a.vx1 AS dvx, b.vy0 - a.vy1 AS dvy,
           a.s2 / a.sxx1 + b.s2 / b.sxx0 AS varv_cv,
           a.sa2 * (b.t0 - a.t1) ** 2 AS varv_acc,
           -- both ends standing: each velocity within its fit's noise of 0 (break_standing: chi2(2) at 0.99)
           break_standing(a.vx1, a.vy1, a.s2 / a.sxx1) AND break_standing(b.vx0, b.vy0, b.s2 / b.sxx0) AS standing
    -- (the bucket as a hash key: each end is listed in its bucket and the next, so the join is an
    -- equality; a difference of the two buckets IN (0, 1) was a condition on every pair of a class)
    FROM (SELECT *, unnest([floor(t1 / getvariable('quality_max_gap')), floor(t1 / getvariable('quality_max_gap')) + 1]) AS k FROM e) a
    JOIN e b ON a.camera = b.camera AND a.class = b.class
            AND floor(b.t0 / getvariable('quality_max_gap')) = a.k
    WHERE a.end_inside AND b.start_inside AND a.track_id <> b.track_id
      AND b.t0 >= a.t1 AND b.t0 - a.t1 <= getvariable('quality_max_gap')
      AND a.sxx1 > 0 AND b.sxx0 > 0
),
-- every pair within the acceleration model's gate (break_evidence with pi = 1/2: z2 and z2_cv do
-- not depend on pi; crates/algo/src/break_link.rs)
z AS (
    SELECT *, break_evidence(dx, dy, dvx, dvy, var_cv, var_acc, varv_cv, varv_acc, 0.5, 1.0) AS e0
    FROM pairs
),
g AS (
    SELECT z.*, count(*) OVER (PARTITION BY camera, from_id) AS n_end, count(*) OVER (PARTITION BY camera, to_id) AS n_start
    FROM z WHERE e0.candidate
)
FROM g;

-- pi: the share of continuations that kept their velocity through the gap (z2_cv within the
-- gate), measured per camera and class on the unambiguous candidates (the only candidate of their
-- end and of their start) of road users standing at both ends, with Laplace's rule
-- ((k + 1) / (n + 2): never 0 or 1). The mixture scores only standing candidates, and only with
-- at least 10 such measurements; every other candidate is scored under the acceleration model
-- alone (pi = 0): with pi = 1/2 for all, two queued cars of a clean scene were linked crosswise.
-- A measurement of the site (python/trajdb/windows.py ships it to every window: a window's own
-- few candidates would give another pi, and other links).
CREATE OR REPLACE TEMP TABLE quality_pi AS
SELECT camera, class, (count(*) FILTER (WHERE e0.candidate_cv) + 1.0) / (count(*) + 2.0) AS pi, count(*) AS pi_n
FROM quality_pairs WHERE n_end = 1 AND n_start = 1 AND standing GROUP BY ALL;

CREATE OR REPLACE TEMP TABLE quality_candidates AS
WITH g AS (FROM quality_pairs),
-- the density of starts about each candidate's start: the other starts of its camera and class
-- within local_radius_m over the recording (quality_starts, on a grid of that radius for the
-- join only), never below the site-wide density
loc AS (
    SELECT b.camera, b.to_id, greatest(any_value(d.starts_per_m2_s),
                                       (count(o.x) FILTER (WHERE (o.x - b.x) ** 2 + (o.y - b.y) ** 2 < d.local_radius_m ** 2) - 1)
                                         / (pi() * any_value(d.local_radius_m) ** 2 * any_value(d.span_s))) AS starts_per_m2_s
    FROM (SELECT DISTINCT g.camera, g.class, g.to_id, q.e.x0 AS x, q.e.y0 AS y
          FROM g JOIN quality_endpoints q ON q.camera = g.camera AND q.track_id = g.to_id) b
    JOIN quality_start_density d USING (camera, class)
    CROSS JOIN unnest([-1, 0, 1]) i(di) CROSS JOIN unnest([-1, 0, 1]) j(dj)
    LEFT JOIN quality_starts o ON o.camera = b.camera AND o.class = b.class
                              AND o.kx = floor(b.x / d.local_radius_m)::BIGINT + i.di AND o.ky = floor(b.y / d.local_radius_m)::BIGINT + j.dj
    GROUP BY b.camera, b.to_id
),
w AS (
    -- the mixture's evidence (break_evidence): ll ranks the candidates, ll_bg weighs the position
    -- against an unrelated start about that place in the gate's time window
    SELECT g.*, e.z2_cv, e.z2, e.ll, e.ll_bg
    FROM g LEFT JOIN quality_pi p USING (camera, class) JOIN loc l USING (camera, to_id),
    -- (quality_max_gap = 0 links only simultaneous ends and starts: the window is then a millisecond)
    LATERAL (SELECT break_evidence(dx, dy, dvx, dvy, var_cv, var_acc, varv_cv, varv_acc, CASE WHEN g.standing AND p.pi_n >= 10 THEN p.pi ELSE 0.0 END,
                                   l.starts_per_m2_s * greatest(getvariable('quality_max_gap'), 1e-3)) AS e) x(e)
)
SELECT camera, class, from_id, to_id, gap, sqrt(dx * dx + dy * dy) AS distance, z2_cv, z2, ll, ll_bg,
       -- the best other candidate of the end, and of the start
       max(ll) OVER (PARTITION BY camera, from_id ORDER BY ll DESC ROWS BETWEEN 1 FOLLOWING AND UNBOUNDED FOLLOWING) AS ll_next_end,
       max(ll) OVER (PARTITION BY camera, to_id ORDER BY ll DESC ROWS BETWEEN 1 FOLLOWING AND UNBOUNDED FOLLOWING) AS ll_next_start,
       row_number() OVER (PARTITION BY camera, from_id ORDER BY ll DESC, to_id) = 1
         AND row_number() OVER (PARTITION BY camera, to_id ORDER BY ll DESC, from_id) = 1 AS mutual_best
FROM w;

-- the decision is one named function (break_link_kind, crates/algo/src/break_link.rs): the ratio
-- test against the best other candidate of the end and of the start (ln 100), no link when less
-- likely than an unrelated start about that place (else 'candidate' in quality_events), then
-- 'broken' or 'reach'
CREATE OR REPLACE TEMP TABLE quality_breaks AS
SELECT * FROM (
    SELECT *, break_link_kind(z2_cv, ll, ll_bg, coalesce(ll_next_end, '-inf'::DOUBLE), coalesce(ll_next_start, '-inf'::DOUBLE)) AS kind
    FROM quality_candidates WHERE mutual_best)
WHERE kind IS NOT NULL;

-- the 'reach' links (quality_reach keeps the shape of the events)
CREATE OR REPLACE TEMP TABLE quality_reach AS
SELECT camera, class, {'kind': 'broken', 'from_id': from_id, 'to_id': to_id, 'gap': gap, 'distance': distance} AS ev
FROM quality_breaks WHERE kind = 'reach';

-- every event: traj_events' splits and merges (the paper's rules, for quality_flags), the links,
-- and the other candidates (kind 'candidate': sql/window.sql follows them as edges)
CREATE OR REPLACE TEMP TABLE quality_events AS
SELECT camera, class, ev FROM quality_events_cv WHERE ev.kind IN ('split', 'merge')
UNION ALL
SELECT c.camera, c.class, {'kind': coalesce(b.kind, 'candidate'), 'from_id': c.from_id, 'to_id': c.to_id, 'gap': c.gap, 'distance': c.distance}
FROM quality_candidates c LEFT JOIN quality_breaks b USING (camera, from_id, to_id);

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
               coalesce((SELECT list({'a': b.from_id, 'b': b.to_id} ORDER BY b.ll DESC, b.from_id)
                         FROM quality_breaks b WHERE b.camera = q.camera AND b.kind = 'broken'), []))) AS g
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

-- The later stages work on the linked tracks. (In place: a second copy of every point, kept as
-- points_linked, was 150 MB of a day's peak memory.)
CREATE OR REPLACE TEMP TABLE points AS
SELECT p.* REPLACE (coalesce(l.linked_id, p.track_id) AS track_id)
FROM points p LEFT JOIN quality_links l USING (camera, track_id);

SELECT ev.kind, count(*) AS events FROM quality_events GROUP BY ev.kind ORDER BY ev.kind;
SELECT label, count(*) AS tracks FROM quality_labels GROUP BY label ORDER BY label;
