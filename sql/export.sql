-- trajdb: the pipeline's result files, written into the directory getvariable('out_dir')
-- (`trajdb pipeline --out DIR` sets it; after `.read sql/pipeline.sql` in the DuckDB CLI:
-- SET VARIABLE out_dir = 'results'; .read sql/export.sql  -- the directory must exist).

-- transforms.csv: cam_from-local into cam_to-local, every ordered pair of aligned cameras, and
-- clock_offset_s = cam_from's clock minus cam_to's clock (a road user seen by cam_to at t is
-- seen by cam_from at t + clock_offset_s)
COPY (SELECT a.camera AS cam_from, b.camera AS cam_to, tf.theta AS theta_rad, tf.tx, tf.ty,
             a.clock_offset_s - b.clock_offset_s AS clock_offset_s
      FROM align_frames a, align_frames b,
           LATERAL (SELECT transform_compose(transform_invert(b.to_reference), a.to_reference) AS tf)
      WHERE a.camera <> b.camera ORDER BY cam_from, cam_to)
TO (getvariable('out_dir') || '/transforms.csv') (HEADER, DELIMITER ',');

-- calibration.csv: what sql/stages/calibrate.sql and align.sql measured, and the parameters
-- derived from it (scope: a camera, a camera pair, or the pipeline)
COPY (SELECT * FROM calibration_summary ORDER BY scope, quantity)
TO (getvariable('out_dir') || '/calibration.csv') (HEADER, DELIMITER ',');

-- matches.csv: the cross-camera links merge_groups() kept (a refused link contradicts its road
-- user), one row per pair of ORIGINAL tracks (a track quality.sql linked from pieces gives a row
-- per piece), with the road user both belong to and its class
COPY (SELECT la.camera AS camera_a, la.track_id AS track_a, lb.camera AS camera_b, lb.track_id AS track_b,
             m.eta AS score, m.kind, ga.road_user, ta.class
      FROM merge_links m
      JOIN merge_tracks ta ON ta.uid = m.uid_a JOIN merge_tracks tb ON tb.uid = m.uid_b
      JOIN merge_groups ga ON ga.uid = m.uid_a JOIN merge_groups gb ON gb.uid = m.uid_b
      JOIN quality_links la ON la.camera = ta.camera AND la.linked_id = ta.track_id
      JOIN quality_links lb ON lb.camera = tb.camera AND lb.linked_id = tb.track_id
      WHERE ga.road_user = gb.road_user AND m.kind <> 'reach'  -- within one camera: links.csv
      ORDER BY camera_a, track_a, camera_b, track_b)
TO (getvariable('out_dir') || '/matches.csv') (HEADER, DELIMITER ',');

-- merged.parquet: one row per road user; GeoParquet 1.1: `geometry` is WKB (LINESTRING M, or
-- POINT M for a one-point road user) in the reference camera's local metric frame, which has no
-- CRS ("crs": null is GeoParquet's "undefined"; QGIS and GDAL open it as a plain XY layer).
-- `sources` names the ORIGINAL (camera, track_id) of every piece (quality.sql linked broken
-- pieces under one id before matching), ordered by camera and start time, so any scorer can
-- read a road user's tracks from this file alone. t_start / t_end (reference clock, s),
-- duration_s and length_m (metres along the merged path) save the analyst a pass over traj.
-- `geometry` is LINESTRING M (POINT M for one point): M is t, so the geometry keeps time.
-- Checked: geopandas 1.2 / shapely 2.2 and DuckDB spatial (1.5.5) read M from this file.
COPY (SELECT m.road_user, m.class, m.n_tracks,
             (SELECT list({'camera': l.camera, 'track_id': l.track_id} ORDER BY l.camera, q.e.t0, l.track_id)
              FROM unnest(m.sources) u(s)
              JOIN quality_links l ON l.camera = s.camera AND l.linked_id = s.track_id
              LEFT JOIN quality_endpoints q ON q.camera = l.camera AND q.track_id = l.track_id) AS sources,
             traj_time_range(m.traj).t_start AS t_start, traj_time_range(m.traj).t_end AS t_end,
             traj_duration(m.traj) AS duration_s, traj_length_m(m.traj) AS length_m,
             traj_to_wkb(m.traj, true) AS geometry, m.traj
      FROM merged m ORDER BY m.road_user)
TO (getvariable('out_dir') || '/merged.parquet')
(FORMAT parquet, KV_METADATA {geo: '{"version":"1.1.0","primary_column":"geometry","columns":{"geometry":{"encoding":"WKB","geometry_types":["LineString M","Point M"],"crs":null,"edges":"planar"}}}'});

-- clusters.csv: route patterns of one camera
COPY (SELECT calibrated('cluster_camera')::BIGINT AS camera, class, track_id, cluster FROM cluster_assign
      ORDER BY class, cluster, track_id)
TO (getvariable('out_dir') || '/clusters.csv') (HEADER, DELIMITER ',');

-- links.csv: tracks linked within a camera (every track and the id of its chain: quality.sql's
-- links, and the pieces of one camera merge.sql put in one road user; merge_chains)
COPY (SELECT camera, track_id, linked_id FROM merge_chains ORDER BY camera, track_id)
TO (getvariable('out_dir') || '/links.csv') (HEADER, DELIMITER ',');
