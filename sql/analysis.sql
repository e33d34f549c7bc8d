-- trajdb: the analyst's questions as SQL macros (issue 29 §4; docs/analysis.md).
--
-- Load it after the pipeline (.read sql/pipeline.sql leaves `merged`), or on merged.parquet:
--   CREATE VIEW merged AS FROM read_parquet('results/merged.parquet');  .read sql/analysis.sql
-- Every table macro reads a table or view NAMED by tbl (default 'merged'; query_table, so a name,
-- never SQL) with at least road_user, class, traj (TRAJ = STRUCT(t, x, y)[] ordered by t, one
-- frame, one clock: the pipeline's fused paths on a regular step). Times are the traj's seconds.
-- Everything here is TEMP (never stored in your database file; fine on a read-only one) and named
-- trajdb_*: each macro is trajdb_<name>, its intermediate results (CTEs) are trajdb_* too, so a
-- table of yours of any other name is read as itself. The short names below (routes() ...) are
-- defined last, one statement each: python/trajdb leaves out one whose name is already yours
-- (docs/analysis.md "Your database, your names").
--
--   road_user_ends(tbl, head_m)      each road user's entry / exit point, time and heading
--   approaches(tbl, ...)             the approaches (arms) found in the data: where road users enter and leave
--   road_user_movements(tbl, ...)    each road user's entry approach, exit approach, turn angle and movement
--   movements(tbl, bin_s, ...)       turning movement counts per bin, approach pair, movement and class
--   road_user_crossings(tbl, gates)  every crossing of a gate (crosswalk, screenline) by a road user, with its direction
--   crossings(tbl, gates, bin_s)     road users crossing each gate per bin, direction and class
--   road_user_speeds(tbl, ...)       each road user's speeds and travel time
--   speeds(tbl, ...)                 speed and travel-time percentiles per movement and class
--   conflicts(tbl, max_pet, radius)  PET and TTC of every pair of road users near each other in time and space
--   top_conflicts(tbl, k, max_pet)   the k pairs with the smallest PET, without computing the rest
--   routes(tbl, ...)                 route patterns within each movement (traj_cluster), labelled
--
-- Movement options shared by road_user_movements, movements, speeds and routes:
--   gates := 'table'   user-drawn gates instead of approaches from the data: a table or view with
--                      approach VARCHAR, x1, y1, x2, y2 DOUBLE (one segment per approach; from WKT:
--                      SELECT 'N' AS approach, g.* FROM (SELECT unnest(gate_from_wkt('LINESTRING (-6 20, 6 20)'))) g)
--   left_handed := true   the frame is mirrored (y down, as image pixels, or an alignment with a
--                      reflection): left and right swap. A rigid frame from align.sql keeps the
--                      world's handedness, so the default (false: x right, y up, counter-clockwise
--                      positive) is right for the pipeline's output.
--   head_m (5 m), through_deg (45), uturn_deg (135), min_radius_m (a quarter of the median end distance), gap_deg (25), min_users (3),
--   centre_x / centre_y (default: measured): see approaches() and docs/analysis.md.

-- ---------------------------------------------------------------- scalar helpers
-- An angle in degrees wrapped into (-180, 180].
CREATE OR REPLACE TEMP MACRO trajdb_wrap_deg(a) AS a - 360.0 * ceil((a - 180.0) / 360.0);

-- The movement of a turn of `turn` degrees (counter-clockwise positive in a right-handed frame).
CREATE OR REPLACE TEMP MACRO trajdb_movement_name(turn, through_deg := 45.0, uturn_deg := 135.0) AS
    CASE WHEN turn IS NULL THEN NULL
         WHEN abs(turn) < through_deg THEN 'through'
         WHEN abs(turn) >= uturn_deg THEN 'u-turn'
         WHEN turn > 0 THEN 'left' ELSE 'right' END;

-- A gate from WKT: 'LINESTRING (x1 y1, x2 y2)' -> {x1, y1, x2, y2}; an error for anything else.
CREATE OR REPLACE TEMP MACRO trajdb_wkt_numbers(wkt) AS
    list_transform(regexp_extract_all(wkt, '[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?'), lambda s: s::DOUBLE);
CREATE OR REPLACE TEMP MACRO trajdb_gate_from_wkt(wkt) AS
    CASE WHEN len(trajdb_wkt_numbers(wkt)) = 4 AND regexp_matches(wkt, '^\s*LINESTRING\s*\(', 'i')
         THEN {'x1': trajdb_wkt_numbers(wkt)[1], 'y1': trajdb_wkt_numbers(wkt)[2], 'x2': trajdb_wkt_numbers(wkt)[3], 'y2': trajdb_wkt_numbers(wkt)[4]}
         ELSE error('gate_from_wkt: a gate is LINESTRING (x1 y1, x2 y2) with two points, got ' || coalesce(wkt, 'NULL')) END;

-- Where segment p -> q (points of a TRAJ) crosses the gate (x1, y1)-(x2, y2): its time, or NULL.
-- A crossing goes from one side of the gate's line to the other, a point ON the line counting as
-- the left side (sp, sq: the cross products of the gate with p and q; >= 0 is left), where the
-- line meets the gate segment (v in [0, 1]). So a path through a sample point on the gate crosses
-- once, not twice (the segments before and after it both touched it: issue 39, review F2), and a
-- path that touches the line from the left and turns back does not cross. A gate of zero length
-- is crossed by nothing.
CREATE OR REPLACE TEMP MACRO trajdb_gate_side(p, x1, y1, x2, y2) AS (x2 - x1) * (p.y - y1) - (y2 - y1) * (p.x - x1);
CREATE OR REPLACE TEMP MACRO trajdb_gate_time(p, q, x1, y1, x2, y2) AS (
    CASE WHEN (trajdb_gate_side(p, x1, y1, x2, y2) >= 0) <> (trajdb_gate_side(q, x1, y1, x2, y2) >= 0)
              AND ((p.x + (q.x - p.x) * trajdb_gate_side(p, x1, y1, x2, y2) / (trajdb_gate_side(p, x1, y1, x2, y2) - trajdb_gate_side(q, x1, y1, x2, y2)) - x1) * (x2 - x1)
                 + (p.y + (q.y - p.y) * trajdb_gate_side(p, x1, y1, x2, y2) / (trajdb_gate_side(p, x1, y1, x2, y2) - trajdb_gate_side(q, x1, y1, x2, y2)) - y1) * (y2 - y1))
                  / nullif((x2 - x1) ** 2 + (y2 - y1) ** 2, 0) BETWEEN 0 AND 1
         THEN p.t + (q.t - p.t) * trajdb_gate_side(p, x1, y1, x2, y2) / (trajdb_gate_side(p, x1, y1, x2, y2) - trajdb_gate_side(q, x1, y1, x2, y2))
    END);

-- ---------------------------------------------------------------- entries and exits
-- Per road user: entry (first point) and exit (last point), their times, and the heading of travel
-- there (degrees, atan2 in the frame): from the first point to the first point at least head_m
-- metres from it, and from the last point at least head_m metres before the end to the end.
CREATE OR REPLACE TEMP MACRO trajdb_road_user_ends(tbl := 'merged', head_m := 5.0) AS TABLE
WITH trajdb_r AS (
    SELECT road_user, class, traj,
           coalesce(list_position(list_transform(traj, lambda p: (p.x - traj[1].x) ** 2 + (p.y - traj[1].y) ** 2 >= head_m::DOUBLE ** 2), true), len(traj)) AS k_in,
           len(traj) + 1 - coalesce(list_position(list_transform(list_reverse(traj), lambda p: (p.x - traj[-1].x) ** 2 + (p.y - traj[-1].y) ** 2 >= head_m::DOUBLE ** 2), true), len(traj)) AS k_out
    FROM query_table(tbl)
    WHERE len(traj) >= 2
)
SELECT road_user, class, traj,
       traj[1].t AS t_in, traj[1].x AS x_in, traj[1].y AS y_in,
       CASE WHEN k_in > 1 THEN degrees(atan2(traj[k_in].y - traj[1].y, traj[k_in].x - traj[1].x)) END AS h_in,
       traj[-1].t AS t_out, traj[-1].x AS x_out, traj[-1].y AS y_out,
       CASE WHEN k_out < len(traj) THEN degrees(atan2(traj[-1].y - traj[k_out].y, traj[-1].x - traj[k_out].x)) END AS h_out
FROM trajdb_r;

-- ---------------------------------------------------------------- approaches from the data
-- 1. the site's centre: the least-squares meeting point of every entry and exit heading line
--    (argmin_p sum |(I - d d^T)(p - a)|^2: arms point at the junction), unless centre_x / centre_y;
-- 2. every entry moving towards the centre and every exit moving away from it (heading within 45
--    degrees of radial), at least min_radius_m from the centre (default: a quarter of the median distance
--    of the ends from it), gives a bearing from the centre; the ends are the vehicles' (every road
--    user not a pedestrian that moved: class_kind, traj_stationary) when there are at least
--    2 min_users of them, else every road user's;
-- 3. the bearings are cut into approaches at every empty sector wider than gap_deg degrees (the
--    circle is opened at its widest gap); approaches with fewer than min_users ends are dropped.
-- Named by the compass point of their mean bearing in the frame (E = +x, N = +y: the frame's
-- axes, not geography), with a number when two share one; lo_deg..hi_deg is the sector.
CREATE OR REPLACE TEMP MACRO trajdb_approaches(tbl := 'merged', centre_x := NULL, centre_y := NULL, min_radius_m := NULL, gap_deg := 25.0,
                                   min_users := 3, head_m := 5.0) AS TABLE
WITH trajdb_all AS (FROM trajdb_road_user_ends(tbl := tbl, head_m := head_m)),
-- (issue 39) arms come from the vehicles (every class but pedestrians, that moved): pedestrians
-- end at every corner and crosswalk, and on both DUT scenes their ends made 2 approaches of a
-- 4-arm crossing and 1 of a roundabout; with fewer than 2 min_users vehicle road users, all
trajdb_e AS (
    FROM trajdb_all
    WHERE class_kind(class) <> 'pedestrian' AND NOT traj_stationary(traj, class)
       OR (SELECT count(*) FILTER (WHERE class_kind(class) <> 'pedestrian' AND NOT traj_stationary(traj, class)) FROM trajdb_all) < 2 * min_users
),
trajdb_lines AS (
    SELECT x_in AS ax, y_in AS ay, radians(h_in) AS h FROM trajdb_e WHERE h_in IS NOT NULL
    UNION ALL SELECT x_out, y_out, radians(h_out) FROM trajdb_e WHERE h_out IS NOT NULL
),
trajdb_m AS (  -- sum of (I - d d^T) and of (I - d d^T) a over every line
    SELECT sum(1 - cos(h) ** 2) AS m11, sum(-cos(h) * sin(h)) AS m12, sum(1 - sin(h) ** 2) AS m22,
           sum((1 - cos(h) ** 2) * ax - cos(h) * sin(h) * ay) AS b1, sum(-cos(h) * sin(h) * ax + (1 - sin(h) ** 2) * ay) AS b2
    FROM trajdb_lines
),
trajdb_c AS (
    SELECT coalesce(centre_x::DOUBLE, (b1 * m22 - b2 * m12) / nullif(m11 * m22 - m12 * m12, 0)) AS cx,
           coalesce(centre_y::DOUBLE, (m11 * b2 - m12 * b1) / nullif(m11 * m22 - m12 * m12, 0)) AS cy
    FROM trajdb_m
),
-- the least distance of an end from the centre: min_radius_m, or a quarter of the median distance
-- of the ends from it (a site's views set it: 8 m fixed dropped a whole arm of the DUT
-- intersection, whose cars enter 6 m from its centre; half the median dropped the arm of a
-- simulated crossing whose view ends 20 m out where the others end 40 m out)
trajdb_rad AS (
    SELECT coalesce(min_radius_m::DOUBLE, 0.25 * median(d)) AS r_min
    FROM (SELECT sqrt((x_in - cx) ** 2 + (y_in - cy) ** 2) AS d FROM trajdb_e, trajdb_c
          UNION ALL SELECT sqrt((x_out - cx) ** 2 + (y_out - cy) ** 2) FROM trajdb_e, trajdb_c)
),
trajdb_ends AS (
    SELECT 'in' AS side, degrees(atan2(y_in - cy, x_in - cx)) AS bearing FROM trajdb_e, trajdb_c, trajdb_rad
    WHERE sqrt((x_in - cx) ** 2 + (y_in - cy) ** 2) >= r_min AND abs(trajdb_wrap_deg(h_in - degrees(atan2(y_in - cy, x_in - cx)) - 180)) < 45
    UNION ALL
    SELECT 'out', degrees(atan2(y_out - cy, x_out - cx)) FROM trajdb_e, trajdb_c, trajdb_rad
    WHERE sqrt((x_out - cx) ** 2 + (y_out - cy) ** 2) >= r_min AND abs(trajdb_wrap_deg(h_out - degrees(atan2(y_out - cy, x_out - cx)))) < 45
),
trajdb_s AS (SELECT side, (bearing + 360) % 360 AS b FROM trajdb_ends),
trajdb_g AS (SELECT side, b, b - lag(b) OVER (ORDER BY b) AS gap FROM trajdb_s),
trajdb_cut AS (  -- open the circle after its widest gap (the wrap-around gap counts too)
    SELECT CASE WHEN (SELECT min(b) + 360 - max(b) FROM trajdb_s) >= coalesce((SELECT max(gap) FROM trajdb_g), 0) THEN (SELECT min(b) FROM trajdb_s)
                ELSE (SELECT arg_max(b, gap) FROM trajdb_g) END AS start
),
trajdb_r AS (SELECT side, (b - start + 360) % 360 AS br FROM trajdb_s, trajdb_cut),
trajdb_rg AS (SELECT side, br, br - lag(br) OVER (ORDER BY br) AS gap FROM trajdb_r),
trajdb_k AS (SELECT side, br, sum(CASE WHEN gap > gap_deg THEN 1 ELSE 0 END) OVER (ORDER BY br ROWS UNBOUNDED PRECEDING) AS cluster FROM trajdb_rg),
trajdb_a AS (
    SELECT cluster, min(br) AS lo, max(br) AS hi, count(*) FILTER (WHERE side = 'in') AS n_in, count(*) FILTER (WHERE side = 'out') AS n_out,
           (degrees(atan2(avg(sin(radians(br))), avg(cos(radians(br))))) + (SELECT start FROM trajdb_cut) + 720) % 360 AS bearing
    FROM trajdb_k GROUP BY cluster HAVING count(*) >= min_users
),
trajdb_named AS (
    SELECT *, ['E', 'NE', 'N', 'NW', 'W', 'SW', 'S', 'SE'][(round(bearing / 45)::INTEGER % 8) + 1] AS compass FROM trajdb_a
)
SELECT compass || CASE WHEN count(*) OVER (PARTITION BY compass) > 1 THEN row_number() OVER (PARTITION BY compass ORDER BY bearing)::VARCHAR ELSE '' END AS approach,
       bearing AS bearing_deg, (lo + (SELECT start FROM trajdb_cut)) % 360 AS lo_deg, (hi + (SELECT start FROM trajdb_cut)) % 360 AS hi_deg,
       n_in, n_out, (SELECT cx FROM trajdb_c) AS centre_x, (SELECT cy FROM trajdb_c) AS centre_y, (SELECT r_min FROM trajdb_rad) AS min_radius_m
FROM trajdb_named ORDER BY bearing;

-- ---------------------------------------------------------------- movements per road user
-- Entry and exit approach, turn angle and movement of every road user.
-- Approaches from the data (gates NULL): an end belongs to the approach whose sector (widened by
-- gap_deg / 2 each side) holds its bearing, if it is at least min_radius_m from the centre and moving
-- radially (within 45 degrees: in towards the centre, out away from it); otherwise NULL (a road user
-- already inside the site when the recording started, or lost in the middle).
-- Gates: the entry approach is the gate crossed first, the exit the gate crossed last (NULL unless
-- at least two crossings). turn_deg = exit heading - entry heading (road_user_ends), wrapped into
-- (-180, 180], negated when left_handed; movement = through (|turn| < through_deg), u-turn
-- (|turn| >= uturn_deg), left (turn > 0) or right; NULL when either approach is unknown.
CREATE OR REPLACE TEMP MACRO trajdb_road_user_movements(tbl := 'merged', gates := NULL, left_handed := false, head_m := 5.0, through_deg := 45.0,
                                            uturn_deg := 135.0, centre_x := NULL, centre_y := NULL, min_radius_m := NULL,
                                            gap_deg := 25.0, min_users := 3) AS TABLE
WITH trajdb_e AS (FROM trajdb_road_user_ends(tbl := tbl, head_m := head_m)),
trajdb_ap AS (
    FROM trajdb_approaches(tbl := tbl, centre_x := centre_x, centre_y := centre_y, min_radius_m := min_radius_m, gap_deg := gap_deg,
                    min_users := min_users, head_m := head_m)
    WHERE gates IS NULL
),
trajdb_c AS (SELECT any_value(trajdb_ap.centre_x) AS cx, any_value(trajdb_ap.centre_y) AS cy, any_value(trajdb_ap.min_radius_m) AS r_min FROM trajdb_ap),  -- qualified: centre_x alone is the parameter
trajdb_data_in AS (
    SELECT trajdb_e.road_user, trajdb_ap.approach FROM trajdb_e, trajdb_c, trajdb_ap
    WHERE sqrt((x_in - cx) ** 2 + (y_in - cy) ** 2) >= r_min
      AND abs(trajdb_wrap_deg(h_in - degrees(atan2(y_in - cy, x_in - cx)) - 180)) < 45
      AND abs(trajdb_wrap_deg(degrees(atan2(y_in - cy, x_in - cx)) - (trajdb_ap.lo_deg + trajdb_ap.hi_deg) / 2
                                - CASE WHEN trajdb_ap.hi_deg < trajdb_ap.lo_deg THEN 180 ELSE 0 END))
          <= ((trajdb_ap.hi_deg - trajdb_ap.lo_deg + 360) % 360) / 2 + gap_deg / 2
),
trajdb_data_out AS (
    SELECT trajdb_e.road_user, trajdb_ap.approach FROM trajdb_e, trajdb_c, trajdb_ap
    WHERE sqrt((x_out - cx) ** 2 + (y_out - cy) ** 2) >= r_min
      AND abs(trajdb_wrap_deg(h_out - degrees(atan2(y_out - cy, x_out - cx)))) < 45
      AND abs(trajdb_wrap_deg(degrees(atan2(y_out - cy, x_out - cx)) - (trajdb_ap.lo_deg + trajdb_ap.hi_deg) / 2
                                - CASE WHEN trajdb_ap.hi_deg < trajdb_ap.lo_deg THEN 180 ELSE 0 END))
          <= ((trajdb_ap.hi_deg - trajdb_ap.lo_deg + 360) % 360) / 2 + gap_deg / 2
),
trajdb_gate_cross AS (
    SELECT trajdb_e.road_user, g.approach, unnest(list_filter(
               list_transform(range(1, len(trajdb_e.traj)), lambda i: trajdb_gate_time(trajdb_e.traj[i], trajdb_e.traj[i + 1], g.x1, g.y1, g.x2, g.y2)),
               lambda t: t IS NOT NULL)) AS t
    FROM trajdb_e, query_table(coalesce(gates, 'trajdb_no_gates')) g
    WHERE gates IS NOT NULL
),
trajdb_gate_ends AS (
    SELECT road_user, arg_min(approach, t) AS approach_in, arg_max(approach, t) AS approach_out
    FROM trajdb_gate_cross GROUP BY road_user HAVING count(*) >= 2
),
trajdb_j AS (
    SELECT trajdb_e.*,
           CASE WHEN gates IS NULL THEN (SELECT any_value(approach) FROM trajdb_data_in d WHERE d.road_user = trajdb_e.road_user)
                ELSE (SELECT any_value(approach_in) FROM trajdb_gate_ends d WHERE d.road_user = trajdb_e.road_user) END AS approach_in,
           CASE WHEN gates IS NULL THEN (SELECT any_value(approach) FROM trajdb_data_out d WHERE d.road_user = trajdb_e.road_user)
                ELSE (SELECT any_value(approach_out) FROM trajdb_gate_ends d WHERE d.road_user = trajdb_e.road_user) END AS approach_out,
           CASE WHEN left_handed THEN -1 ELSE 1 END * trajdb_wrap_deg(h_out - h_in) AS turn_deg
    FROM trajdb_e
)
SELECT road_user, class, t_in, t_out, approach_in, approach_out, turn_deg,
       CASE WHEN approach_in IS NOT NULL AND approach_out IS NOT NULL
            THEN trajdb_movement_name(turn_deg, through_deg := through_deg, uturn_deg := uturn_deg) END AS movement
FROM trajdb_j ORDER BY road_user;

-- An empty gates table for query_table when no gates are given (query_table needs an existing name).
CREATE OR REPLACE TEMP VIEW trajdb_no_gates AS
SELECT NULL::VARCHAR AS approach, NULL::DOUBLE AS x1, NULL::DOUBLE AS y1, NULL::DOUBLE AS x2, NULL::DOUBLE AS y2 WHERE false;

-- ---------------------------------------------------------------- crossings of gates (screenlines)
-- Every crossing of a gate by a road user (issue 39 §9): pedestrians per crosswalk, cyclists per
-- path, vehicles per lane or screenline. gates := 'table' is needed: the same table as
-- movements' gates (approach: the gate's name, x1, y1, x2, y2 in the traj frame; from WKT with
-- gate_from_wkt). A crossing is where a segment of the path between two samples meets the gate
-- (its time interpolated); to_left: the road user crosses from the right of the gate (seen from
-- (x1, y1) towards (x2, y2)) to its left; heading_deg: its direction there (degrees, atan2 in the
-- frame: 0 = +x, 90 = +y). Only road users whose path's box meets the gate's box are walked.
CREATE OR REPLACE TEMP MACRO trajdb_road_user_crossings(tbl := 'merged', gates := NULL) AS TABLE
WITH trajdb_g AS (
    SELECT approach::VARCHAR AS gate, x1::DOUBLE AS x1, y1::DOUBLE AS y1, x2::DOUBLE AS x2, y2::DOUBLE AS y2
    FROM query_table(coalesce(gates, 'trajdb_no_gates'))
    UNION ALL
    SELECT error('crossings: gates := ''your_gates'' is needed: a table or view with approach (the gate''s name), x1, y1, x2, y2 '
                 || '(docs/analysis.md, Crossings)'), NULL, NULL, NULL, NULL WHERE gates IS NULL
),
trajdb_r AS (
    SELECT road_user, class, traj, list_min([p.x FOR p IN traj]) AS bx0, list_max([p.x FOR p IN traj]) AS bx1,
           list_min([p.y FOR p IN traj]) AS by0, list_max([p.y FOR p IN traj]) AS by1
    FROM query_table(tbl) WHERE len(traj) >= 2
),
trajdb_x AS (
    SELECT r.road_user, r.class, g.gate, unnest(list_filter(list_transform(range(1, len(r.traj)), lambda i: {
               't': trajdb_gate_time(r.traj[i], r.traj[i + 1], g.x1, g.y1, g.x2, g.y2),
               'to_left': trajdb_gate_side(r.traj[i + 1], g.x1, g.y1, g.x2, g.y2) >= 0,
               'heading_deg': degrees(atan2(r.traj[i + 1].y - r.traj[i].y, r.traj[i + 1].x - r.traj[i].x)),
               'p': r.traj[i], 'q': r.traj[i + 1]}), lambda c: c.t IS NOT NULL)) AS c
    FROM trajdb_r r, trajdb_g g
    WHERE r.bx0 <= greatest(g.x1, g.x2) AND r.bx1 >= least(g.x1, g.x2) AND r.by0 <= greatest(g.y1, g.y2) AND r.by1 >= least(g.y1, g.y2)
)
SELECT road_user, class, gate, c.t AS t, c.to_left AS to_left, c.heading_deg AS heading_deg,
       c.p.x + (c.q.x - c.p.x) * (c.t - c.p.t) / nullif(c.q.t - c.p.t, 0) AS x,
       c.p.y + (c.q.y - c.p.y) * (c.t - c.p.t) / nullif(c.q.t - c.p.t, 0) AS y
FROM trajdb_x ORDER BY gate, t, road_user;

-- Road users crossing each gate per bin of bin_s seconds (default 900 = 15 minutes, bins at
-- multiples of bin_s on the traj clock, by the time of the crossing), direction and class. A road
-- user counts once per gate and direction (its first crossing that way: a pedestrian who stops
-- on the line and steps back and forth is one crossing, not five); crossings counts them all.
CREATE OR REPLACE TEMP MACRO trajdb_crossings(tbl := 'merged', gates := NULL, bin_s := 900) AS TABLE
SELECT CASE WHEN bin_s IS NULL OR NOT bin_s::DOUBLE > 0 OR NOT isfinite(bin_s::DOUBLE)
            THEN error('crossings: bin_s must be a number of seconds > 0, got ' || coalesce(bin_s::VARCHAR, 'NULL') || ' (900: 15 minutes)')
            ELSE bin_start END AS bin_start,
       gate, direction, class, count(*) AS road_users, sum(n) AS crossings
FROM (SELECT floor(min(t) / bin_s::DOUBLE) * bin_s::DOUBLE AS bin_start, gate, CASE WHEN to_left THEN 'to left' ELSE 'to right' END AS direction,
             class, count(*) AS n
      FROM trajdb_road_user_crossings(tbl := tbl, gates := gates) GROUP BY gate, to_left, class, road_user)
GROUP BY ALL ORDER BY ALL;

-- ---------------------------------------------------------------- turning movement counts
-- Road users per bin of bin_s seconds (by entry time; default 900 = 15 minutes, bins at multiples
-- of bin_s on the traj clock), entry approach, exit approach, movement and class. Only road users
-- with both approaches known (see road_user_movements for the others).
CREATE OR REPLACE TEMP MACRO trajdb_movements(tbl := 'merged', bin_s := 900, gates := NULL, left_handed := false, head_m := 5.0,
                                  through_deg := 45.0, uturn_deg := 135.0, centre_x := NULL, centre_y := NULL,
                                  min_radius_m := NULL, gap_deg := 25.0, min_users := 3) AS TABLE
SELECT floor(t_in / bin_s::DOUBLE) * bin_s::DOUBLE AS bin_start, approach_in, approach_out, movement, class, count(*) AS road_users
FROM trajdb_road_user_movements(tbl := tbl, gates := gates, left_handed := left_handed, head_m := head_m, through_deg := through_deg,
                         uturn_deg := uturn_deg, centre_x := centre_x, centre_y := centre_y, min_radius_m := min_radius_m,
                         gap_deg := gap_deg, min_users := min_users)
WHERE movement IS NOT NULL
GROUP BY ALL ORDER BY ALL;

-- ---------------------------------------------------------------- speeds and travel times
-- Speeds are in km/h everywhere (the column names say so), times in s.
-- Per road user: the speed samples of its path (traj_speeds: finite differences, on the pipeline's
-- regular step each sample weighs the same time), their median, 85th percentile and maximum, the
-- mean speed (path length / duration), the travel time through the site (t_out - t_in), and
-- stationary: it never moved (traj_stationary: a parked car; speeds() leaves these out).
CREATE OR REPLACE TEMP MACRO trajdb_road_user_speeds(tbl := 'merged') AS TABLE
SELECT road_user, class, 3.6 * traj_length_m(traj) / nullif(traj_duration(traj), 0) AS mean_speed_kmh,
       3.6 * list_median([s.v FOR s IN traj_speeds(traj)]) AS median_speed_kmh,
       3.6 * list_aggregate([s.v FOR s IN traj_speeds(traj)], 'quantile_cont', 0.85) AS p85_speed_kmh,
       3.6 * list_max([s.v FOR s IN traj_speeds(traj)]) AS max_speed_kmh, traj_duration(traj) AS travel_time_s, traj_length_m(traj) AS length_m,
       traj_stationary(traj, class) AS stationary
FROM query_table(tbl)
WHERE len(traj) >= 2;

-- Per movement (entry approach, exit approach, movement) and class: road users, and the 15th, 50th,
-- 85th and 95th percentiles (and the mean) of their mean speeds (km/h) and travel times (s), and of
-- every speed sample pooled (the spot-speed distribution, km/h). Road users with an unknown movement
-- form the rows with NULL approaches. Stationary road users (parked cars: traj_stationary) are left
-- out unless include_stationary := true; stationary counts them per row either way, and a row
-- whose road users are all stationary stays (road_users 0, speeds NULL).
CREATE OR REPLACE TEMP MACRO trajdb_speeds(tbl := 'merged', gates := NULL, left_handed := false, head_m := 5.0, through_deg := 45.0,
                               uturn_deg := 135.0, centre_x := NULL, centre_y := NULL, min_radius_m := NULL, gap_deg := 25.0,
                               min_users := 3, include_stationary := false) AS TABLE
WITH trajdb_m AS (FROM trajdb_road_user_movements(tbl := tbl, gates := gates, left_handed := left_handed, head_m := head_m, through_deg := through_deg,
                                    uturn_deg := uturn_deg, centre_x := centre_x, centre_y := centre_y, min_radius_m := min_radius_m,
                                    gap_deg := gap_deg, min_users := min_users)),
trajdb_s_all AS (FROM trajdb_road_user_speeds(tbl := tbl)),
trajdb_s AS (FROM trajdb_s_all WHERE include_stationary OR NOT coalesce(stationary, false)),
-- every road user with its speeds only when kept: a group whose road users are all stationary keeps
-- its row (road_users 0, stationary n, speeds NULL) instead of vanishing
trajdb_k AS (SELECT road_user, include_stationary OR NOT coalesce(stationary, false) AS kept,
                    CASE WHEN include_stationary OR NOT coalesce(stationary, false) THEN mean_speed_kmh END AS mean_speed_kmh,
                    CASE WHEN include_stationary OR NOT coalesce(stationary, false) THEN travel_time_s END AS travel_time_s
             FROM trajdb_s_all),
trajdb_still AS (SELECT trajdb_m.approach_in, trajdb_m.approach_out, trajdb_m.movement, trajdb_m.class, count(*) AS n
                 FROM trajdb_s_all JOIN trajdb_m USING (road_user) WHERE trajdb_s_all.stationary GROUP BY ALL),
trajdb_spot AS (SELECT road_user, 3.6 * unnest(traj_speeds(traj)).v AS v FROM query_table(tbl) WHERE road_user IN (SELECT road_user FROM trajdb_s)),
trajdb_spot_q AS (
    SELECT trajdb_m.approach_in, trajdb_m.approach_out, trajdb_m.movement, trajdb_m.class,
           quantile_cont(v, [0.15, 0.5, 0.85, 0.95]) AS q
    FROM trajdb_spot JOIN trajdb_m USING (road_user) GROUP BY ALL
)
SELECT trajdb_m.approach_in, trajdb_m.approach_out, trajdb_m.movement, trajdb_m.class, count(*) FILTER (WHERE trajdb_k.kept) AS road_users,
       coalesce(any_value(st.n), 0) AS stationary,
       avg(trajdb_k.mean_speed_kmh) AS speed_mean_kmh, quantile_cont(trajdb_k.mean_speed_kmh, 0.15) AS speed_p15_kmh, quantile_cont(trajdb_k.mean_speed_kmh, 0.5) AS speed_p50_kmh,
       quantile_cont(trajdb_k.mean_speed_kmh, 0.85) AS speed_p85_kmh, quantile_cont(trajdb_k.mean_speed_kmh, 0.95) AS speed_p95_kmh,
       any_value(q.q[1]) AS spot_p15_kmh, any_value(q.q[2]) AS spot_p50_kmh, any_value(q.q[3]) AS spot_p85_kmh, any_value(q.q[4]) AS spot_p95_kmh,
       avg(trajdb_k.travel_time_s) AS travel_time_mean_s, quantile_cont(trajdb_k.travel_time_s, 0.15) AS travel_time_p15_s,
       quantile_cont(trajdb_k.travel_time_s, 0.5) AS travel_time_p50_s, quantile_cont(trajdb_k.travel_time_s, 0.85) AS travel_time_p85_s,
       quantile_cont(trajdb_k.travel_time_s, 0.95) AS travel_time_p95_s
FROM trajdb_m JOIN trajdb_k USING (road_user)
LEFT JOIN trajdb_spot_q q ON q.approach_in IS NOT DISTINCT FROM trajdb_m.approach_in AND q.approach_out IS NOT DISTINCT FROM trajdb_m.approach_out
                  AND q.movement IS NOT DISTINCT FROM trajdb_m.movement AND q.class IS NOT DISTINCT FROM trajdb_m.class
LEFT JOIN trajdb_still st ON st.approach_in IS NOT DISTINCT FROM trajdb_m.approach_in AND st.approach_out IS NOT DISTINCT FROM trajdb_m.approach_out
                  AND st.movement IS NOT DISTINCT FROM trajdb_m.movement AND st.class IS NOT DISTINCT FROM trajdb_m.class
GROUP BY trajdb_m.approach_in, trajdb_m.approach_out, trajdb_m.movement, trajdb_m.class ORDER BY ALL;

-- ---------------------------------------------------------------- conflicts
-- Every pair of road users near each other in time and space, never all pairs: traj_conflicts
-- scores only pairs whose path pieces come within their reach (radius / 2 + the piece's top speed
-- x max_ttc: where a constant-velocity prediction can take it within max_ttc) within max_pet
-- seconds, found on a space-time grid in one call (linear in the road users near each other), and
-- computes per pair, in parallel and without copying the paths: traj_pet (the crossing with the
-- smallest PET, at most max_pet) and traj_ttc (the minimum TTC at constant velocity: contact when
-- the centres come within the sum of the two road users' radii, each its class's class_radius_m:
-- a pedestrian 0.25 m, a car 0.9 m; radius := R makes every pair's R instead). Kept: pairs with a
-- PET, or a TTC of at most max_ttc.
-- pedestrian_pairs := false (with top): two pedestrians are no near miss (people pass close by);
-- the report ranks only the encounters with a vehicle.
-- road_user must be unique.
-- kind: conflict_kind: SSAM's kinds by the crossing angle between two vehicles (rear-end < 30 deg,
-- lane-change 30-85, crossing > 85), vehicle-pedestrian or pedestrian-pedestrian otherwise, NULL for
-- a class that says nothing (issue 39: a pedestrian pair is no lane change).
-- road_user_first: who passed the conflict point first.
-- together_m: the median distance between the two over their common time (NULL: none);
-- probably_one: one road user counted twice, not two (same class, closer than the class's width:
-- conflict_probably_one; issue 39). A conflict study leaves these out: top_conflicts() does, and
-- probably_one() lists them.
-- top := k: only the first k by (pet, road_user_a, road_user_b) that are not probably_one, as
-- top_conflicts() below.
CREATE OR REPLACE TEMP MACRO trajdb_conflicts(tbl := 'merged', max_pet := 5.0, radius := NULL, max_ttc := 3.0, top := NULL, pedestrian_pairs := true) AS TABLE
WITH trajdb_r AS (SELECT road_user, class, traj FROM query_table(tbl) WHERE len(traj) >= 2),
trajdb_u AS (  -- the pairs are named by road_user: a repeated one would be ambiguous; a NULL parameter
        -- would silently give no rows
    SELECT CASE WHEN max_pet IS NULL OR (max_ttc IS NULL AND top IS NULL) OR pedestrian_pairs IS NULL
                THEN error('conflicts: max_pet, max_ttc and pedestrian_pairs must not be NULL (got max_pet ' || coalesce(max_pet::VARCHAR, 'NULL')
                           || ', max_ttc ' || coalesce(max_ttc::VARCHAR, 'NULL') || ', pedestrian_pairs ' || coalesce(pedestrian_pairs::VARCHAR, 'NULL')
                           || '); leave one out for its default')
                WHEN count(road_user) = count(DISTINCT road_user) THEN true
                ELSE error('conflicts: road_user must be unique in ' || tbl || ' (got ' || (count(road_user) - count(DISTINCT road_user))::VARCHAR
                           || ' repeated); give each road user one row') END AS ok
    FROM trajdb_r
),
trajdb_rc AS (SELECT *, dense_rank() OVER (ORDER BY lower(trim(class))) AS dense_rank_class,
                     -- each road user's disc for TTC: radius / 2 when given, else its class's (class_radius_m)
                     coalesce(radius::DOUBLE / 2, class_radius_m(class), class_radius_m('unknown')) AS r_disc FROM trajdb_r),
trajdb_c AS (  -- (ids as BIGINT: integer and decimal road_user columns of any width)
    SELECT unnest(CASE WHEN top IS NULL
                       THEN traj_conflicts(list(road_user::BIGINT ORDER BY road_user), list(traj ORDER BY road_user), max_pet::DOUBLE,
                                           coalesce(radius, 2.0)::DOUBLE, max_ttc::DOUBLE, list(r_disc ORDER BY road_user))
                       ELSE traj_conflicts_top(list(road_user::BIGINT ORDER BY road_user), list(traj ORDER BY road_user), top::BIGINT,
                                               max_pet::DOUBLE, coalesce(radius, 2.0)::DOUBLE,
                                               -- one road user counted twice is not a near miss: left out of the k
                                               list(dense_rank_class ORDER BY road_user), list(coalesce(class_min_gap_m(class), class_min_gap_m('unknown')) ORDER BY road_user),
                                               list(r_disc ORDER BY road_user),
                                               -- pedestrian_pairs := false: two pedestrians are no near miss either
                                               list(CASE WHEN NOT pedestrian_pairs AND class_kind(class) = 'pedestrian' THEN 1 ELSE 0 END ORDER BY road_user)) END) AS p
    FROM trajdb_rc WHERE road_user IS NOT NULL AND (SELECT ok FROM trajdb_u)
)
SELECT p.a AS road_user_a, ra.class AS class_a, p.b AS road_user_b, rb.class AS class_b,
       p.pet, p.x AS pet_x, p.y AS pet_y, p.t_first, p.t_second, p.angle AS angle_deg,
       conflict_kind(ra.class, rb.class, p.angle) AS kind,
       CASE WHEN p.a_first THEN p.a WHEN NOT p.a_first THEN p.b END AS road_user_first,
       p.ttc, p.ttc_t, p.ttc_x, p.ttc_y, p.together_m,
       coalesce(conflict_probably_one(ra.class, rb.class, p.together_n, p.together_m), false) AS probably_one
FROM trajdb_c JOIN (SELECT road_user, class FROM trajdb_r) ra ON ra.road_user = p.a JOIN (SELECT road_user, class FROM trajdb_r) rb ON rb.road_user = p.b
ORDER BY coalesce(p.pet, 1e300), road_user_a, road_user_b;

-- The k most severe crossings: the first k rows of conflicts() by (pet, road_user_a, road_user_b)
-- (PETs at most max_pet) that are not one road user counted twice (probably_one), without computing the rest (conflicts(top := k) calls traj_conflicts_top,
-- which searches the PET bound upward from max_pet / 16: in congestion conflicts() grows with the
-- square of the road users in a queue, this with the near misses asked for). Same columns as
-- conflicts(); a pair with a TTC but no crossing is not a crossing and is not here. The report's
-- near misses.
-- k := NULL: every crossing (no limit).
CREATE OR REPLACE TEMP MACRO trajdb_top_conflicts(tbl := 'merged', k := 15, max_pet := 5.0, radius := NULL, pedestrian_pairs := true) AS TABLE
FROM trajdb_conflicts(tbl := tbl, max_pet := max_pet, radius := radius, top := k, pedestrian_pairs := pedestrian_pairs) WHERE pet IS NOT NULL AND NOT probably_one
ORDER BY pet, road_user_a, road_user_b;

-- Pairs of road users that are probably one road user counted twice (issue 39): same class, and
-- closer than the class's width over their common time (conflict_probably_one), so a conflict
-- study must not rank them; the report lists and counts them apart ("needs a look"). A split
-- road user crosses "itself" with a PET of about 0 and a TTC of 0, so they are the pairs in
-- contact (TTC 0 at a radius of the widest class's width) at the same moment: linear in the road
-- users near each other, never all pairs. Same columns as conflicts().
CREATE OR REPLACE TEMP MACRO trajdb_probably_one(tbl := 'merged') AS TABLE
FROM trajdb_conflicts(tbl := tbl, max_pet := 0.5, radius := 2.6, max_ttc := 0.0) WHERE probably_one ORDER BY road_user_a, road_user_b;

-- ---------------------------------------------------------------- route patterns
-- Route patterns of the merged road users: per movement (entry approach, exit approach), the paths
-- resampled to 1 s and clustered with traj_cluster (average linkage, Buzan's S1 with epsilon metres
-- and delta samples of warping, cut at threshold): lanes and paths within one movement. One row per
-- pattern: its road users, their classes, and the member of median length as its example.
-- Road users with an unknown movement are not clustered.
CREATE OR REPLACE TEMP MACRO trajdb_routes(tbl := 'merged', epsilon := 1.5, delta := 30, threshold := 0.5, gates := NULL, left_handed := false,
                               head_m := 5.0, through_deg := 45.0, uturn_deg := 135.0, centre_x := NULL, centre_y := NULL,
                               min_radius_m := NULL, gap_deg := 25.0, min_users := 3) AS TABLE
WITH trajdb_m AS (FROM trajdb_road_user_movements(tbl := tbl, gates := gates, left_handed := left_handed, head_m := head_m, through_deg := through_deg,
                                    uturn_deg := uturn_deg, centre_x := centre_x, centre_y := centre_y, min_radius_m := min_radius_m,
                                    gap_deg := gap_deg, min_users := min_users)
           WHERE movement IS NOT NULL),
trajdb_p AS (SELECT trajdb_m.*, traj_resample(t.traj, 1.0) AS traj FROM trajdb_m JOIN query_table(tbl) t USING (road_user)),
trajdb_cl AS (
    SELECT approach_in, approach_out, movement,
           traj_cluster(list(road_user ORDER BY road_user), list(traj ORDER BY road_user), 'average',
                        threshold::DOUBLE, delta::BIGINT, epsilon::DOUBLE) AS ks
    FROM trajdb_p WHERE len(traj) >= 2 GROUP BY approach_in, approach_out, movement
),
trajdb_c AS (SELECT approach_in, approach_out, movement, unnest(ks) AS k FROM trajdb_cl),
trajdb_j AS (SELECT trajdb_c.approach_in, trajdb_c.approach_out, trajdb_c.movement, k.cluster AS pattern, trajdb_p.road_user, trajdb_p.class, traj_length_m(trajdb_p.traj) AS len
      FROM trajdb_c JOIN trajdb_p ON trajdb_p.road_user = k.id),
trajdb_cc AS (
    SELECT approach_in, approach_out, movement, pattern, string_agg(class || ' ' || n, ', ' ORDER BY class) AS classes
    FROM (SELECT approach_in, approach_out, movement, pattern, class, count(*) AS n FROM trajdb_j GROUP BY ALL)
    GROUP BY ALL
)
SELECT approach_in, approach_out, movement, pattern, count(*) AS road_users, list(road_user ORDER BY road_user) AS road_user_ids,
       any_value(trajdb_cc.classes) AS classes, list(road_user ORDER BY len, road_user)[(count(*) + 1) // 2] AS example_road_user
FROM trajdb_j JOIN trajdb_cc USING (approach_in, approach_out, movement, pattern)
GROUP BY approach_in, approach_out, movement, pattern
ORDER BY road_users DESC, approach_in, approach_out, pattern;

-- ---------------------------------------------------------------- the names you call
-- Each name above is trajdb_<name>; these are the short names, one statement each, so that a host
-- can leave out one whose name is yours (python/trajdb: a table, view or macro of yours called
-- routes stays what `routes` means; trajdb_routes() is trajdb's). TEMP, as everything here:
-- nothing of trajdb's is stored in your database file.
CREATE OR REPLACE TEMP MACRO gate_from_wkt(wkt) AS trajdb_gate_from_wkt(wkt);
CREATE OR REPLACE TEMP MACRO road_user_ends(tbl := 'merged', head_m := 5.0) AS TABLE
FROM trajdb_road_user_ends(tbl := tbl, head_m := head_m);
CREATE OR REPLACE TEMP MACRO approaches(tbl := 'merged', centre_x := NULL, centre_y := NULL, min_radius_m := NULL, gap_deg := 25.0, min_users := 3, head_m := 5.0) AS TABLE
FROM trajdb_approaches(tbl := tbl, centre_x := centre_x, centre_y := centre_y, min_radius_m := min_radius_m, gap_deg := gap_deg, min_users := min_users, head_m := head_m);
CREATE OR REPLACE TEMP MACRO road_user_movements(tbl := 'merged', gates := NULL, left_handed := false, head_m := 5.0, through_deg := 45.0, uturn_deg := 135.0, centre_x := NULL, centre_y := NULL, min_radius_m := NULL, gap_deg := 25.0, min_users := 3) AS TABLE
FROM trajdb_road_user_movements(tbl := tbl, gates := gates, left_handed := left_handed, head_m := head_m, through_deg := through_deg, uturn_deg := uturn_deg, centre_x := centre_x, centre_y := centre_y, min_radius_m := min_radius_m, gap_deg := gap_deg, min_users := min_users);
CREATE OR REPLACE TEMP MACRO movements(tbl := 'merged', bin_s := 900, gates := NULL, left_handed := false, head_m := 5.0, through_deg := 45.0, uturn_deg := 135.0, centre_x := NULL, centre_y := NULL, min_radius_m := NULL, gap_deg := 25.0, min_users := 3) AS TABLE
FROM trajdb_movements(tbl := tbl, bin_s := bin_s, gates := gates, left_handed := left_handed, head_m := head_m, through_deg := through_deg, uturn_deg := uturn_deg, centre_x := centre_x, centre_y := centre_y, min_radius_m := min_radius_m, gap_deg := gap_deg, min_users := min_users);
CREATE OR REPLACE TEMP MACRO road_user_crossings(tbl := 'merged', gates := NULL) AS TABLE
FROM trajdb_road_user_crossings(tbl := tbl, gates := gates);
CREATE OR REPLACE TEMP MACRO crossings(tbl := 'merged', gates := NULL, bin_s := 900) AS TABLE
FROM trajdb_crossings(tbl := tbl, gates := gates, bin_s := bin_s);
CREATE OR REPLACE TEMP MACRO road_user_speeds(tbl := 'merged') AS TABLE
FROM trajdb_road_user_speeds(tbl := tbl);
CREATE OR REPLACE TEMP MACRO speeds(tbl := 'merged', gates := NULL, left_handed := false, head_m := 5.0, through_deg := 45.0, uturn_deg := 135.0, centre_x := NULL, centre_y := NULL, min_radius_m := NULL, gap_deg := 25.0, min_users := 3, include_stationary := false) AS TABLE
FROM trajdb_speeds(tbl := tbl, gates := gates, left_handed := left_handed, head_m := head_m, through_deg := through_deg, uturn_deg := uturn_deg, centre_x := centre_x, centre_y := centre_y, min_radius_m := min_radius_m, gap_deg := gap_deg, min_users := min_users, include_stationary := include_stationary);
CREATE OR REPLACE TEMP MACRO conflicts(tbl := 'merged', max_pet := 5.0, radius := NULL, max_ttc := 3.0, top := NULL, pedestrian_pairs := true) AS TABLE
FROM trajdb_conflicts(tbl := tbl, max_pet := max_pet, radius := radius, max_ttc := max_ttc, top := top, pedestrian_pairs := pedestrian_pairs);
CREATE OR REPLACE TEMP MACRO top_conflicts(tbl := 'merged', k := 15, max_pet := 5.0, radius := NULL, pedestrian_pairs := true) AS TABLE
FROM trajdb_top_conflicts(tbl := tbl, k := k, max_pet := max_pet, radius := radius, pedestrian_pairs := pedestrian_pairs);
CREATE OR REPLACE TEMP MACRO probably_one(tbl := 'merged') AS TABLE
FROM trajdb_probably_one(tbl := tbl);
CREATE OR REPLACE TEMP MACRO routes(tbl := 'merged', epsilon := 1.5, delta := 30, threshold := 0.5, gates := NULL, left_handed := false, head_m := 5.0, through_deg := 45.0, uturn_deg := 135.0, centre_x := NULL, centre_y := NULL, min_radius_m := NULL, gap_deg := 25.0, min_users := 3) AS TABLE
FROM trajdb_routes(tbl := tbl, epsilon := epsilon, delta := delta, threshold := threshold, gates := gates, left_handed := left_handed, head_m := head_m, through_deg := through_deg, uturn_deg := uturn_deg, centre_x := centre_x, centre_y := centre_y, min_radius_m := min_radius_m, gap_deg := gap_deg, min_users := min_users);
