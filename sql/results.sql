-- trajdb: the pipeline's results as table macros, ONE definition each. sql/export.sql writes
-- them to files (transforms.csv, calibration.csv, matches.csv, merged.parquet, clusters.csv,
-- links.csv); python/trajdb/windows.py (the Spark runner) returns them per (site, window).
-- Macros bind when called, so a run that skips a stage (a window skips clustering) can still
-- read the others. Unordered: the caller orders.

-- transforms: cam_from-local into cam_to-local, every ordered pair of aligned cameras, and
-- clock_offset_s = cam_from's clock minus cam_to's clock (a road user seen by cam_to at t is
-- seen by cam_from at t + clock_offset_s)
CREATE OR REPLACE TEMP MACRO result_transforms() AS TABLE
SELECT a.camera AS cam_from, b.camera AS cam_to, tf.theta AS theta_rad, tf.tx, tf.ty,
       a.clock_offset_s - b.clock_offset_s AS clock_offset_s
FROM align_frames a, align_frames b,
     LATERAL (SELECT transform_compose(transform_invert(b.to_reference), a.to_reference) AS tf)
WHERE a.camera <> b.camera;

-- calibration: what sql/stages/calibrate.sql and align.sql measured, and the parameters
-- derived from it (scope: a camera, a camera pair, or the pipeline)
CREATE OR REPLACE TEMP MACRO result_calibration() AS TABLE
SELECT * FROM calibration_summary;

-- matches: the cross-camera links merge_groups() kept (a refused link contradicts its road
-- user), one row per pair of ORIGINAL tracks (a track quality.sql linked from pieces gives a row
-- per piece), with the road user both belong to and its class
CREATE OR REPLACE TEMP MACRO result_matches() AS TABLE
SELECT la.camera AS camera_a, la.track_id AS track_a, lb.camera AS camera_b, lb.track_id AS track_b,
       m.eta AS score, m.kind, ga.road_user, ta.class
FROM merge_links m
JOIN merge_tracks ta ON ta.uid = m.uid_a JOIN merge_tracks tb ON tb.uid = m.uid_b
JOIN merge_groups ga ON ga.uid = m.uid_a JOIN merge_groups gb ON gb.uid = m.uid_b
JOIN quality_links la ON la.camera = ta.camera AND la.linked_id = ta.track_id
JOIN quality_links lb ON lb.camera = tb.camera AND lb.linked_id = tb.track_id
WHERE ga.road_user = gb.road_user AND m.kind <> 'reach';  -- within one camera: links

-- road users (merged.parquet): one row per road user; `geometry` is WKB (LINESTRING M, or
-- POINT M for a one-point road user; M is t) in the reference camera's local metric frame.
-- `sources` names the ORIGINAL (camera, track_id) of every piece (quality.sql linked broken
-- pieces under one id before matching), ordered by camera and start time, so any scorer can
-- read a road user's tracks from this alone. t_start / t_end (reference clock, s), duration_s
-- and length_m (metres along the merged path) save the analyst a pass over traj.
CREATE OR REPLACE TEMP MACRO result_road_users() AS TABLE
SELECT m.road_user, m.class, m.n_tracks,
       (SELECT list({'camera': l.camera, 'track_id': l.track_id} ORDER BY l.camera, q.e.t0, l.track_id)
        FROM unnest(m.sources) u(s)
        JOIN quality_links l ON l.camera = s.camera AND l.linked_id = s.track_id
        LEFT JOIN quality_endpoints q ON q.camera = l.camera AND q.track_id = l.track_id) AS sources,
       traj_time_range(m.traj).t_start AS t_start, traj_time_range(m.traj).t_end AS t_end,
       traj_duration(m.traj) AS duration_s, traj_length_m(m.traj) AS length_m,
       traj_to_wkb(m.traj, true) AS geometry, m.traj
FROM merged m;

-- clusters: route patterns of one camera
CREATE OR REPLACE TEMP MACRO result_clusters() AS TABLE
SELECT calibrated('cluster_camera')::BIGINT AS camera, class, track_id, cluster FROM cluster_assign;

-- links: tracks linked within a camera (every track and the id of its chain: quality.sql's
-- links, and the pieces of one camera merge.sql put in one road user; merge_chains)
CREATE OR REPLACE TEMP MACRO result_links() AS TABLE
SELECT camera, track_id, linked_id FROM merge_chains;
