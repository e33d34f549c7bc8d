-- trajdb: report.html, the pipeline's QA report, written into getvariable('out_dir') after
-- sql/export.sql (`trajdb pipeline`, trajdb.pipeline(con, input, out=...) and the DuckDB CLI:
-- SET VARIABLE out_dir = 'results'; .read sql/export.sql; .read sql/report.sql).
--
-- This file gathers the report's data from the pipeline's tables; trajdb_report_html() (Rust,
-- crates/app/src/report/) only draws it. Every row below is one line of the data text: its section
-- name and cells, cells separated by chr(31), rows by chr(30), NULL as chr(21). Numbers are
-- DuckDB's VARCHAR casts, which round-trip exactly. Stage times come from the temp table
-- pipeline_timings(stage, seconds) when the runner filled it.
CREATE TEMP TABLE IF NOT EXISTS pipeline_timings (stage VARCHAR, seconds DOUBLE);
-- the user's camera names (load_ids: the input's own ids, text stays text) by the stages'
-- numbers: the report draws by number (colours, plots) and writes every camera by its name
CREATE OR REPLACE TEMP TABLE report_cams AS
SELECT c.camera, coalesce(any_value(i.camera_in)::VARCHAR, c.camera::VARCHAR) AS name
FROM (SELECT DISTINCT camera FROM points) c LEFT JOIN load_ids i USING (camera) GROUP BY c.camera;
CREATE OR REPLACE TEMP MACRO report_cam(c) AS coalesce((SELECT name FROM report_cams WHERE camera = c), c::VARCHAR);
CREATE OR REPLACE TEMP MACRO report_cell(v) AS coalesce(replace(replace(v::VARCHAR, chr(30), ' '), chr(31), ' '), chr(21));
CREATE OR REPLACE TEMP MACRO report_xy(traj) AS array_to_string([p.x::VARCHAR || ' ' || p.y::VARCHAR FOR p IN traj], ',');
CREATE OR REPLACE TEMP TABLE report_points AS
SELECT p.camera, p.x, p.y, transform_point(f.to_reference, p.x, p.y) AS a, p.k
FROM (SELECT camera, x, y, row_number() OVER (ORDER BY camera, track_id, t) AS k FROM points WHERE estimated = 0) p
LEFT JOIN align_frames f USING (camera)
-- at most about 12,000 points in the plots
WHERE p.k % greatest((SELECT count(*) FROM points WHERE estimated = 0) // 12000, 1) = 0;
CREATE OR REPLACE TEMP TABLE report_samples AS
WITH m AS (SELECT road_user, class, len(list_distinct([s.camera FOR s IN sources])) AS n_cams, traj_length_m(traj) AS len_m
           FROM merged WHERE n_tracks > 1),
     -- variety: the longest road user of every (class, camera count), then round-robin over classes
     best AS (SELECT *, row_number() OVER (PARTITION BY class, n_cams ORDER BY len_m DESC, road_user) AS k FROM m QUALIFY k = 1)
SELECT road_user, class, row_number() OVER (ORDER BY rr, class) AS k
FROM (SELECT road_user, class, row_number() OVER (PARTITION BY class ORDER BY n_cams DESC) AS rr FROM best)
WHERE rr <= 2 ORDER BY k LIMIT 6;
CREATE TEMP TABLE IF NOT EXISTS pipeline_warnings (k INTEGER, message VARCHAR);
-- the headline's time bins: the recording's real span on the reference clock, in the smallest
-- of 1, 5, 15, 60 minutes, 6 hours or a day that gives at most 24 bins
CREATE OR REPLACE TEMP TABLE report_span AS
SELECT min(t) AS t0, max(t) AS t1,
       coalesce(list_filter([60, 300, 900, 3600, 21600, 86400], lambda b: (max(t) - min(t)) / b < 24)[1], 86400) AS bin_s
FROM points WHERE estimated = 0;
-- per road user: its cameras, first time and mean speed (length_m / duration_s, seen >= 1 s)
CREATE OR REPLACE TEMP TABLE report_users AS
SELECT road_user, class, len(list_distinct([s.camera FOR s IN sources])) AS n_cams, traj_time_range(traj).t_start AS t_start,
       traj_duration(traj) AS duration_s,
       CASE WHEN traj_duration(traj) >= 1 THEN traj_length_m(traj) / traj_duration(traj) END AS mean_speed,
       stationary, traj_time_range(traj).t_end AS t_end, len(sources) AS n_sources
FROM merged;
-- the analyst's questions (issue 29 §4): movements and near misses come from sql/analysis.sql's
-- macros, defined again here so that the report stands alone after .read sql/pipeline.sql
.read sql/analysis.sql
-- (issue 39) the gates the report counts movements by, drawn by the analyst: report_gates
-- (sql/report_gates.sql, which the runner ran before the stages, checks report_gates_in). None:
-- the approaches are found in the data, and the report says which.
.read sql/report_gates.sql
SET VARIABLE report_gates_table = CASE WHEN (SELECT count(*) FROM report_gates) > 0 THEN 'report_gates' END;
-- every road user's entry and exit approach and movement, once (the movement table, its diagram,
-- speeds per movement and the confidence lines all read it)
CREATE OR REPLACE TEMP TABLE report_ru_mov AS FROM trajdb_road_user_movements(gates := getvariable('report_gates_table'));
CREATE OR REPLACE TEMP TABLE report_movements AS
SELECT approach_in, approach_out, movement, class, count(*) AS n FROM report_ru_mov WHERE movement IS NOT NULL GROUP BY ALL;
-- the approaches the movements were counted by (found in the data: approaches())
CREATE OR REPLACE TEMP TABLE report_approaches AS FROM trajdb_approaches() WHERE getvariable('report_gates_table') IS NULL;
-- (issue 39 §8) the near misses of the conflict map and of the PET / TTC distributions: the 300
-- smallest PETs under 3 s with a vehicle in them, between road users that moved (two pedestrians
-- are no traffic conflict; on both
-- DUT scenes they were all of the 10 smallest), found without computing the rest; the table shows
-- the first 15
-- (road users that moved: a parked car's jitter is crossed by everyone who walks past it)
CREATE OR REPLACE TEMP VIEW report_moving AS SELECT road_user, class, traj FROM merged WHERE NOT coalesce(stationary, false);
CREATE OR REPLACE TEMP TABLE report_near AS
FROM trajdb_top_conflicts(tbl := 'report_moving', k := 300, max_pet := 3.0, pedestrian_pairs := false) WHERE pet < 3 ORDER BY pet, road_user_a, road_user_b;
CREATE OR REPLACE TEMP TABLE report_conflicts AS FROM report_near ORDER BY pet, road_user_a, road_user_b LIMIT 15;
-- (issue 39) road users that are probably one counted twice: not near misses, listed apart and
-- counted in "needs a look"; and what merging removed from the near-miss table
CREATE OR REPLACE TEMP TABLE report_probably_one AS FROM trajdb_probably_one();
-- every camera's track its own road user (the common frame): of its closest encounters (PET under
-- 3 s), how many were two tracks of one road user. Only the top ones, found without the rest
-- (traj_conflicts_top): counting every near miss of a day before and after merging took 30 s of a
-- Mellingen-sized day's 45. Each track is its own class here, so that no pair is set aside as
-- probably one (the class's words still give its kind).
CREATE OR REPLACE TEMP TABLE report_tracks AS SELECT uid AS road_user, class || ' #' || uid AS class, traj FROM merge_tracks;
CREATE OR REPLACE TEMP TABLE report_near_miss_counts AS
SELECT count(*) AS top, count(*) FILTER (WHERE ga.road_user = gb.road_user) AS same
FROM trajdb_conflicts(tbl := 'report_tracks', max_pet := 3.0, top := 15) c
JOIN merge_groups ga ON ga.uid = c.road_user_a JOIN merge_groups gb ON gb.uid = c.road_user_b
WHERE c.pet < 3;
-- (issue 39 §8) counts per 15 minutes (the peak hour and its factor are the renderer's: it knows
-- which bins the recording covers whole). Road users that moved, by the time they were first
-- seen, in 900 s bins: on a wall clock (TIMESTAMP input, seconds since 1970) at the quarter
-- hours, else from the start of the recording. The span is the merged paths' (reference clock).
CREATE OR REPLACE TEMP TABLE report_flow_span AS
SELECT min(t_start) AS t0, max(t_end) AS t1, coalesce(getvariable('input_t_type') LIKE 'TIMESTAMP%', false) AS wall FROM report_users;
-- the recording's sessions: where road users follow each other with gaps of at most
-- recording_gap_s (10 x the 99th percentile gap between first sightings, at least a minute); a
-- longer empty stretch is the recording stopped (an AM and a PM session), not the traffic
CREATE OR REPLACE TEMP TABLE report_sessions AS
WITH u AS (SELECT t_start AS s, t_end AS e FROM report_users WHERE t_start IS NOT NULL AND t_end IS NOT NULL),
-- the 99th percentile gap between first sightings, once: it sets the gap and the slack
p AS (SELECT quantile_cont(d, 0.99) AS p99 FROM (SELECT s - lag(s) OVER (ORDER BY s) AS d FROM u) WHERE d IS NOT NULL),
o AS (SELECT s, e, max(e) OVER (ORDER BY s, e ROWS BETWEEN UNBOUNDED PRECEDING AND 1 PRECEDING) AS prev_e FROM u),
k AS (SELECT s, e, sum(CASE WHEN prev_e IS NULL OR s - prev_e > (SELECT coalesce(recording_gap_s(p99), 60) FROM p) THEN 1 ELSE 0 END)
                      OVER (ORDER BY s, e ROWS UNBOUNDED PRECEDING) AS session FROM o)
SELECT session, min(s) AS s0, max(e) AS s1,
       -- a session's ends are known to within the gaps between road users: a quarter is whole
       -- when the session covers it but for up to the 99th percentile gap (at most 90 s)
       (SELECT least(coalesce(p99, 1), 90) FROM p) AS slack_s
FROM k GROUP BY session;
CREATE OR REPLACE TEMP TABLE report_flow AS
SELECT b, class, count(*) AS n
FROM (SELECT u.class, CASE WHEN s.wall THEN floor(u.t_start / 900) * 900 ELSE s.t0 + floor((u.t_start - s.t0) / 900) * 900 END AS b
      FROM report_users u, report_flow_span s WHERE NOT coalesce(u.stationary, false))
GROUP BY ALL;
-- (issue 39 §8) how far to trust each number: of its road users, how many were seen by more
-- than one camera (matched across cameras), joined across a break within one camera (more source
-- tracks than cameras: n_tracks counts a linked chain once), and flagged (probably one road user
-- counted twice)
CREATE OR REPLACE TEMP TABLE report_conf AS
WITH d AS (SELECT road_user_a AS road_user FROM report_probably_one UNION SELECT road_user_b FROM report_probably_one),
u AS (SELECT u.*, u.road_user IN (SELECT road_user FROM d) AS dup FROM report_users u),
c AS (SELECT road_user_a AS road_user FROM report_conflicts UNION SELECT road_user_b FROM report_conflicts)
SELECT topic, count(*) AS n, count(*) FILTER (WHERE n_cams > 1) AS multi, count(*) FILTER (WHERE n_sources > n_cams) AS joined,
       count(*) FILTER (WHERE dup) AS flagged
FROM (SELECT 'movement' AS topic, u.* FROM u JOIN report_ru_mov r USING (road_user)
      WHERE r.movement IS NOT NULL AND class_kind(u.class) <> 'pedestrian'
      UNION ALL SELECT 'speed', u.* FROM u WHERE NOT coalesce(u.stationary, false) AND u.mean_speed IS NOT NULL
      UNION ALL SELECT 'conflict', u.* FROM u WHERE road_user IN (SELECT road_user FROM c)
      UNION ALL SELECT 'count', u.* FROM u WHERE NOT coalesce(u.stationary, false))
GROUP BY topic;
-- (issue 39 §8) the site map: up to 1,500 road users' paths, each thinned to about 40 points
CREATE OR REPLACE TEMP TABLE report_site AS
SELECT class, coalesce(stationary, false) AS stationary,
       list_filter(traj, lambda p, i: (i - 1) % greatest(len(traj) // 40, 1) = 0 OR i = len(traj)) AS traj
FROM merged WHERE len(traj) >= 1
QUALIFY row_number() OVER (ORDER BY hash(road_user), road_user) <= 1500;
CREATE OR REPLACE TEMP TABLE report_rows AS
SELECT 'meta' AS s, 1 AS k, ['input', getvariable('pipeline_input')] AS c
UNION ALL SELECT 'meta', 2, ['xi', calibrated('merge_min_points')::BIGINT::VARCHAR]
UNION ALL SELECT 'meta', 3, ['eta', getvariable('merge_eta')::DOUBLE::VARCHAR]
UNION ALL SELECT 'meta', 4, ['cluster_camera', report_cam(coalesce((SELECT camera FROM cluster_camera_used), calibrated('cluster_camera'))::INTEGER)]
UNION ALL SELECT 'meta', 5, ['step', greatest((SELECT count(*) FROM points WHERE estimated = 0) // 12000, 1)::VARCHAR]
UNION ALL SELECT 'stage', row_number() OVER (), [stage, seconds::VARCHAR] FROM pipeline_timings
UNION ALL SELECT 'camera', row_number() OVER (ORDER BY camera), [camera::VARCHAR, name] FROM report_cams
UNION ALL SELECT 'class', row_number() OVER (ORDER BY class), [class] FROM (SELECT DISTINCT class FROM points)
UNION ALL SELECT 'transform', row_number() OVER (ORDER BY camera),
    [report_cam(camera), report_cam(reference), degrees(to_reference.theta)::VARCHAR, to_reference.tx::VARCHAR, to_reference.ty::VARCHAR,
     hops::VARCHAR, bottleneck_support::VARCHAR, (clock_offset_s * 1000)::VARCHAR]
    FROM align_frames
UNION ALL SELECT 'unaligned', row_number() OVER (ORDER BY camera), [report_cam(camera)]
    FROM (SELECT DISTINCT camera FROM points ANTI JOIN align_frames USING (camera))
UNION ALL SELECT 'calibration', row_number() OVER (ORDER BY scope, quantity), [scope, quantity, value::VARCHAR, unit, how]
    FROM result_calibration()  -- the input's camera ids (text stays text)
UNION ALL SELECT 'point', k, [camera::VARCHAR, x::VARCHAR, y::VARCHAR, a.x::VARCHAR, a.y::VARCHAR] FROM report_points
UNION ALL SELECT 'view', row_number() OVER (ORDER BY camera, class), [camera::VARCHAR, class, polygon_to_wkt(polygon)]
    FROM view_polygons
UNION ALL SELECT 'overlap', row_number() OVER (ORDER BY class, cam_a, cam_b),
    [class, cam_a::VARCHAR, cam_b::VARCHAR, polygon_to_wkt(polygon), area_m2::VARCHAR]
    FROM view_overlaps
-- tracks per class and camera; n_xi: with at least ξ points in an overlap with another camera
UNION ALL SELECT 'count', row_number() OVER (ORDER BY class, camera), [class, camera::VARCHAR, n::VARCHAR, n_xi::VARCHAR]
    FROM (SELECT class, camera, count(*) AS n, count(*) FILTER (WHERE best >= calibrated('merge_min_points')) AS n_xi
          FROM (SELECT t.camera, t.track_id, t.class, max(traj_points_inside(t.traj, o.polygon)) AS best
                FROM merge_tracks t
                LEFT JOIN view_overlaps o ON o.class = t.class AND (o.cam_a = t.camera OR o.cam_b = t.camera) AND o.area_m2 > 0
                GROUP BY ALL)
          GROUP BY ALL)
-- Cayley tables: camera's tracks with at least ξ points in its overlap with other
UNION ALL SELECT 'cayley', row_number() OVER (ORDER BY class, camera, other), [class, camera::VARCHAR, other::VARCHAR, n::VARCHAR]
    FROM (SELECT t.class, t.camera, CASE WHEN o.cam_a = t.camera THEN o.cam_b ELSE o.cam_a END AS other,
                 count(*) FILTER (WHERE traj_points_inside(t.traj, o.polygon) >= calibrated('merge_min_points')) AS n
          FROM merge_tracks t JOIN view_overlaps o ON o.class = t.class AND (o.cam_a = t.camera OR o.cam_b = t.camera)
          GROUP BY ALL)
-- accepted cross-camera links per camera pair and class
UNION ALL SELECT 'link', row_number() OVER (ORDER BY pair, class), [pair, class, n::VARCHAR]
    FROM (SELECT report_cam(t.camera) || '–' || report_cam(u.camera) AS pair, t.class, count(*) AS n
          FROM merge_links m JOIN merge_groups ga ON ga.uid = m.uid_a JOIN merge_groups gb ON gb.uid = m.uid_b
          JOIN merge_tracks t ON t.uid = m.uid_a JOIN merge_tracks u ON u.uid = m.uid_b
          WHERE ga.road_user = gb.road_user AND m.kind <> 'reach' GROUP BY ALL)
-- road users per set of cameras that saw them
UNION ALL SELECT 'set', row_number() OVER (ORDER BY length(cams), cams, class), [cams, class, n::VARCHAR]
    FROM (SELECT cams, class, count(*) AS n
          FROM (SELECT array_to_string(list_sort(list_distinct([s.camera::VARCHAR FOR s IN sources])), '+') AS cams, class FROM merged)
          GROUP BY ALL)
UNION ALL SELECT 'sample', k, [road_user::VARCHAR, class] FROM report_samples
UNION ALL SELECT 'sample_source', row_number() OVER (ORDER BY s.k, t.camera, t.t0, t.track_id),
    [s.road_user::VARCHAR, t.camera::VARCHAR, report_cam(t.camera) || ':' || coalesce(i.track_in::VARCHAR, t.track_id::VARCHAR), report_xy(t.traj)]
    FROM report_samples s JOIN merge_groups g USING (road_user) JOIN merge_tracks t USING (uid)
    LEFT JOIN load_ids i ON i.camera = t.camera AND i.track_id = t.track_id
UNION ALL SELECT 'sample_merged', s.k, [s.road_user::VARCHAR, report_xy(m.traj)]
    FROM report_samples s JOIN merged m USING (road_user)
UNION ALL SELECT 'cluster', row_number() OVER (ORDER BY class), [class, n_clusters::VARCHAR, n_in::VARCHAR, n::VARCHAR]
    FROM (SELECT class, count(DISTINCT cluster) FILTER (WHERE cluster > 0) AS n_clusters,
                 count(*) FILTER (WHERE cluster > 0) AS n_in, count(*) AS n
          FROM cluster_assign GROUP BY class)
-- up to 600 tracks per class; rank of the track's cluster by size (0: not among the 8 largest)
UNION ALL SELECT 'route', row_number() OVER (ORDER BY class, rank = 0 DESC, rank DESC, h), [class, rank::VARCHAR, report_xy(traj)]
    FROM (WITH sizes AS (SELECT class, cluster, row_number() OVER (PARTITION BY class ORDER BY count(*) DESC, cluster) AS rank
                         FROM cluster_assign WHERE cluster > 0 GROUP BY class, cluster)
          SELECT t.class, CASE WHEN s.rank <= 8 THEN s.rank ELSE 0 END AS rank, t.traj, hash(t.track_id) AS h
          FROM cluster_tracks t JOIN cluster_assign a USING (class, track_id) LEFT JOIN sizes s USING (class, cluster)
          QUALIFY row_number() OVER (PARTITION BY t.class ORDER BY hash(t.track_id), t.track_id) <= 600)
-- the headline (issue 29 §5): road users per class and time bin, warnings, speeds, per-camera quality
UNION ALL SELECT 'meta', 6, ['span_s', (t1 - t0)::VARCHAR] FROM report_span
UNION ALL SELECT 'meta', 7, ['bin_s', bin_s::VARCHAR] FROM report_span
UNION ALL SELECT 'users', row_number() OVER (ORDER BY class), [class, count(*)::VARCHAR, count(*) FILTER (WHERE n_cams > 1)::VARCHAR,
                                                     median(duration_s)::VARCHAR]
    FROM report_users GROUP BY class
UNION ALL SELECT 'users_bin', row_number() OVER (ORDER BY b, class), [b::VARCHAR, class, n::VARCHAR]
    FROM (SELECT floor((u.t_start - s.t0) / s.bin_s)::BIGINT AS b, u.class, count(*) AS n FROM report_users u, report_span s GROUP BY ALL)
UNION ALL SELECT 'warning', row_number() OVER (ORDER BY k), [message] FROM pipeline_warnings
UNION ALL SELECT 'pair', row_number() OVER (ORDER BY cam_a, cam_b), [report_cam(cam_a), report_cam(cam_b), sigma_d_m::VARCHAR, n_pairs::VARCHAR, source]
    FROM calib_match
-- speeds per class: the road users' mean speeds (length_m / duration_s) and the spot speeds of
-- every point of the fused paths (traj_speeds), in m/s (the report shows km/h); stationary road
-- users (parked cars: merged.stationary) are left out of both and counted in the last cell
UNION ALL SELECT 'speed', row_number() OVER (ORDER BY class), [class, n::VARCHAR, m15::VARCHAR, m50::VARCHAR, m85::VARCHAR,
                                                     s50::VARCHAR, s85::VARCHAR, s95::VARCHAR, smax::VARCHAR, still::VARCHAR]
    FROM (SELECT u.class, count(u.mean_speed) FILTER (WHERE NOT u.stationary) AS n,
                 quantile_cont(u.mean_speed, 0.15) FILTER (WHERE NOT u.stationary) AS m15,
                 quantile_cont(u.mean_speed, 0.5) FILTER (WHERE NOT u.stationary) AS m50,
                 quantile_cont(u.mean_speed, 0.85) FILTER (WHERE NOT u.stationary) AS m85, any_value(p.s50) AS s50, any_value(p.s85) AS s85,
                 any_value(p.s95) AS s95, any_value(p.smax) AS smax, count(*) FILTER (WHERE u.stationary) AS still
          FROM report_users u
          LEFT JOIN (SELECT class, quantile_cont(v, 0.5) AS s50, quantile_cont(v, 0.85) AS s85, quantile_cont(v, 0.95) AS s95, max(v) AS smax
                     FROM (SELECT class, unnest([s.v FOR s IN traj_speeds(traj)]) AS v FROM merged WHERE NOT stationary) GROUP BY class) p USING (class)
          GROUP BY u.class)
-- per camera: its tracks (links.csv: the original ids, before linking) and real points, its measured period and noise, breaks linked within it
-- (links.csv rows with linked_id <> track_id), its tracks matched to another camera
-- (matches.csv), the road users it saw, and its alignment (reference NULL: not aligned)
UNION ALL SELECT 'camq', row_number() OVER (ORDER BY c.camera),
    [report_cam(c.camera), coalesce(l.tracks, 0)::VARCHAR, c.points::VARCHAR, k.period_s::VARCHAR, k.sigma_m::VARCHAR,
     coalesce(l.linked, 0)::VARCHAR, coalesce(m.matched, 0)::VARCHAR, coalesce(u.users, 0)::VARCHAR, report_cam(f.reference),
     (f.clock_offset_s * 1000)::VARCHAR, (f.clock_drift * 1e6)::VARCHAR]
    FROM (SELECT camera, count(*) AS points FROM points WHERE estimated = 0 GROUP BY camera) c
    LEFT JOIN calib_cameras k USING (camera)
    -- (the stages' own tables, in the stages' numbers: the result_*() macros and merged speak the
    -- input's ids, which a text camera id made a join of text with numbers: issue 39)
    LEFT JOIN (SELECT camera, count(*) AS tracks, count(*) FILTER (WHERE track_id <> linked_id) AS linked FROM merge_chains GROUP BY camera) l USING (camera)
    -- (both ends of a match from one scan: a UNION ALL of two scans lost its second branch in
    -- DuckDB 2.0.0)
    LEFT JOIN (SELECT e.camera, count(DISTINCT e.track_id) AS matched
               FROM (SELECT unnest([{'camera': ta.camera, 'track_id': la.track_id}, {'camera': tb.camera, 'track_id': lb.track_id}]) AS e
                     FROM merge_links k
                     JOIN merge_tracks ta ON ta.uid = k.uid_a JOIN merge_tracks tb ON tb.uid = k.uid_b
                     JOIN merge_groups ga ON ga.uid = k.uid_a JOIN merge_groups gb ON gb.uid = k.uid_b
                     JOIN quality_links la ON la.camera = ta.camera AND la.linked_id = ta.track_id
                     JOIN quality_links lb ON lb.camera = tb.camera AND lb.linked_id = tb.track_id
                     WHERE ga.road_user = gb.road_user AND k.kind <> 'reach')
               GROUP BY e.camera) m ON m.camera = c.camera
    LEFT JOIN (SELECT s.camera, count(DISTINCT road_user) AS users FROM (SELECT road_user, unnest(sources) AS s FROM merge_users) GROUP BY s.camera) u
           ON u.camera = c.camera
    LEFT JOIN align_frames f ON f.camera = c.camera
-- the movement table (approaches found in the data) and the worst post-encroachment times
UNION ALL SELECT 'movement', row_number() OVER (ORDER BY n DESC, approach_in, approach_out, movement, class),
       [approach_in, approach_out, movement, class, n::VARCHAR] FROM report_movements
UNION ALL SELECT 'conflict', row_number() OVER (ORDER BY pet, road_user_a, road_user_b),
       [road_user_a::VARCHAR, class_a, road_user_b::VARCHAR, class_b, round(pet, 2)::VARCHAR, kind, round(pet_x, 1)::VARCHAR,
        round(pet_y, 1)::VARCHAR, coalesce(round(ttc, 2)::VARCHAR, '')] FROM report_conflicts
UNION ALL SELECT 'dup', row_number() OVER (ORDER BY road_user_a, road_user_b),
       [road_user_a::VARCHAR, road_user_b::VARCHAR, class_a, round(together_m, 2)::VARCHAR, coalesce(round(pet, 2)::VARCHAR, '')] FROM report_probably_one
-- (issue 39) found approaches that cannot be right: most vehicles entering and leaving by one
UNION ALL SELECT 'meta', 10, ['same_approach_share', (coalesce(sum(n) FILTER (WHERE approach_in = approach_out), 0) / greatest(sum(n), 1))::VARCHAR]
    FROM report_movements WHERE approach_in IS NOT NULL AND approach_out IS NOT NULL AND class_kind(class) <> 'pedestrian'
      AND getvariable('report_gates_table') IS NULL
UNION ALL SELECT 'meta', 14, ['approaches_from', CASE WHEN getvariable('report_gates_table') IS NULL THEN 'data' ELSE 'gates' END]
UNION ALL SELECT 'meta', 15, ['gates_source', coalesce(getvariable('report_gates'), '')]
UNION ALL SELECT 'gate', row_number() OVER (ORDER BY approach, x1, y1), [approach, x1::VARCHAR, y1::VARCHAR, x2::VARCHAR, y2::VARCHAR] FROM report_gates
UNION ALL SELECT 'meta', 8, ['tracks_top_near_misses', top::VARCHAR] FROM report_near_miss_counts
UNION ALL SELECT 'meta', 9, ['tracks_top_same_road_user', same::VARCHAR] FROM report_near_miss_counts
UNION ALL SELECT 'meta', 11, ['flow_t0', t0::VARCHAR] FROM report_flow_span
UNION ALL SELECT 'meta', 12, ['flow_t1', t1::VARCHAR] FROM report_flow_span
UNION ALL SELECT 'meta', 13, ['clock', CASE WHEN getvariable('input_t_type') = 'TIMESTAMP WITH TIME ZONE' THEN 'utc'
                                            WHEN getvariable('input_t_type') LIKE 'TIMESTAMP%' THEN 'wall' ELSE 'relative' END]
UNION ALL SELECT 'flow', row_number() OVER (ORDER BY b, class), [b::VARCHAR, class, n::VARCHAR] FROM report_flow
UNION ALL SELECT 'session', row_number() OVER (ORDER BY s0), [s0::VARCHAR, s1::VARCHAR, slack_s::VARCHAR] FROM report_sessions
UNION ALL SELECT 'conf', row_number() OVER (ORDER BY topic), [topic, n::VARCHAR, multi::VARCHAR, joined::VARCHAR, flagged::VARCHAR] FROM report_conf
UNION ALL SELECT 'approach', row_number() OVER (ORDER BY bearing_deg),
       [approach, bearing_deg::VARCHAR, lo_deg::VARCHAR, hi_deg::VARCHAR, centre_x::VARCHAR, centre_y::VARCHAR, min_radius_m::VARCHAR,
        n_in::VARCHAR, n_out::VARCHAR] FROM report_approaches
UNION ALL SELECT 'site_path', row_number() OVER (), [class, stationary::VARCHAR, report_xy(traj)] FROM report_site
UNION ALL SELECT 'near', row_number() OVER (ORDER BY pet, road_user_a, road_user_b),
       [pet::VARCHAR, ttc::VARCHAR, kind, pet_x::VARCHAR, pet_y::VARCHAR, class_a, class_b] FROM report_near
-- speeds per movement: the road users' mean speeds (m/s), moving road users with a known movement
UNION ALL SELECT 'speed_mov', row_number() OVER (ORDER BY n DESC, approach_in, approach_out, class),
       [approach_in, approach_out, movement, class, n::VARCHAR, p15::VARCHAR, p50::VARCHAR, p85::VARCHAR, mn::VARCHAR, mx::VARCHAR]
    FROM (SELECT r.approach_in, r.approach_out, r.movement, r.class, count(*) AS n, quantile_cont(u.mean_speed, 0.15) AS p15,
                 quantile_cont(u.mean_speed, 0.5) AS p50, quantile_cont(u.mean_speed, 0.85) AS p85, min(u.mean_speed) AS mn, max(u.mean_speed) AS mx
          FROM report_ru_mov r JOIN report_users u USING (road_user)
          WHERE r.movement IS NOT NULL AND NOT coalesce(u.stationary, false) AND u.mean_speed IS NOT NULL GROUP BY ALL)
UNION ALL SELECT 'param', row_number() OVER (ORDER BY stage, name), [name, value, stage, description] FROM pipeline_params;
COPY (SELECT trajdb_report_html(string_agg(s || chr(31) || array_to_string([report_cell(v) FOR v IN c], chr(31)), chr(30) ORDER BY s, k))
      FROM report_rows)
TO (getvariable('out_dir') || '/report.html') (FORMAT csv, HEADER false, QUOTE '', ESCAPE '', DELIMITER chr(1));
