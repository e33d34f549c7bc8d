-- trajdb pipeline parameters: GENERATED from crates/app/src/params.rs by `trajdb params --sql > sql/params.sql`.
-- Each keeps a value you SET VARIABLE before `.read sql/params.sql`; otherwise it takes the default.

-- load
SET VARIABLE input_columns = coalesce(getvariable('input_columns'), ''); -- your column names, as 'camera=cam_id, track_id=id, t=time' (any of camera, track_id, class, t, x, y, estimated; unnamed ones keep their name; estimated may be absent)

-- clean
SET VARIABLE clean_drop_estimated_tails = coalesce(getvariable('clean_drop_estimated_tails'), false); -- drop a track whose last clean_xi points are all estimated
SET VARIABLE clean_xi = coalesce(getvariable('clean_xi'), 3::BIGINT); -- points of the estimated tail rule
SET VARIABLE clean_min_points = coalesce(getvariable('clean_min_points'), NULL::BIGINT); -- a track with fewer real points than this ... (auto: 2, the least that shows motion)
SET VARIABLE clean_min_duration_s = coalesce(getvariable('clean_min_duration_s'), NULL::DOUBLE); -- ... and spanning less than this many seconds is dropped (auto: 1.5 sampling periods)
SET VARIABLE clean_max_speed = coalesce(getvariable('clean_max_speed'), 70.0::DOUBLE); -- a track whose median real speed exceeds this (m/s) is implausible and dropped

-- quality
SET VARIABLE quality_max_gap = coalesce(getvariable('quality_max_gap'), 2.5::DOUBLE); -- a broken piece may resume up to this many seconds later
SET VARIABLE quality_max_dist = coalesce(getvariable('quality_max_dist'), 2.0::DOUBLE); -- ... within this many metres of where the track would be at its final velocity
SET VARIABLE quality_max_accel = coalesce(getvariable('quality_max_accel'), NULL::DOUBLE); -- second linking pass: a leftover start may lie max_dist + accel * gap^2 / 2 from the prediction (m/s^2; auto: the class's measured 95th percentile acceleration, see quality.sql)
SET VARIABLE quality_inset = coalesce(getvariable('quality_inset'), 1.0::DOUBLE); -- endpoints closer than this (m) to the view's edge are entries and exits

-- align
SET VARIABLE align_min_points = coalesce(getvariable('align_min_points'), 10::BIGINT); -- tracks need at least this many real points to form hypotheses
SET VARIABLE align_min_overlap_s = coalesce(getvariable('align_min_overlap_s'), 2.0::DOUBLE); -- track pairs overlap at least this long in time (s)
SET VARIABLE align_min_pairs = coalesce(getvariable('align_min_pairs'), 10::BIGINT); -- a hypothesis needs at least this many time-interpolated point pairs
SET VARIABLE align_min_span_m = coalesce(getvariable('align_min_span_m'), 3.0::DOUBLE); -- ... and its moving points span at least this many metres
SET VARIABLE align_max_hypotheses = coalesce(getvariable('align_max_hypotheses'), 4000::BIGINT); -- at most this many track pairs per camera pair are scanned (a hash sample of a long day)
SET VARIABLE align_max_clock_offset_s = coalesce(getvariable('align_max_clock_offset_s'), 1.0::DOUBLE); -- clock offsets between two cameras are searched up to this many seconds either way first; a camera pair whose winner lies at the edge, or is too weak, is searched again over 4x and 16x this range
SET VARIABLE align_bin_s = coalesce(getvariable('align_bin_s'), 0.05::DOUBLE); -- vote bin (and scan step) of the clock offset (s)
SET VARIABLE align_clock_step_s = coalesce(getvariable('align_clock_step_s'), 0.005::DOUBLE); -- step of the joint clock offset search around the winning bin (s)
SET VARIABLE align_max_rms_m = coalesce(getvariable('align_max_rms_m'), NULL::DOUBLE); -- hypotheses fitting their own pairs within this RMS (m) vote (auto: 0.1 + 3 sigma_pair)
SET VARIABLE align_bin_deg = coalesce(getvariable('align_bin_deg'), 2.0::DOUBLE); -- vote bin of the rotation (degrees)
SET VARIABLE align_bin_m = coalesce(getvariable('align_bin_m'), 1.0::DOUBLE); -- vote bin of the translation (m)
SET VARIABLE align_agree_deg = coalesce(getvariable('align_agree_deg'), 3.0::DOUBLE); -- a hypothesis agrees with the winning bin within this rotation (degrees)
SET VARIABLE align_agree_m = coalesce(getvariable('align_agree_m'), 2.0::DOUBLE); -- ... and this translation (m)
SET VARIABLE align_min_support = coalesce(getvariable('align_min_support'), 3::BIGINT); -- a camera pair needs at least this many agreeing track pairs
SET VARIABLE align_trim = coalesce(getvariable('align_trim'), 0.1::DOUBLE); -- share of point pairs the trimmed refit leaves out
SET VARIABLE align_refine_rms_m = coalesce(getvariable('align_refine_rms_m'), NULL::DOUBLE); -- second pass: track pairs within this RMS (m) of the first fit are kept (auto: 0.05 + 2 sigma_pair)

-- overlap
SET VARIABLE overlap_method = coalesce(getvariable('overlap_method'), 'convex'); -- view polygon hull: 'convex' or 'concave'
SET VARIABLE overlap_concavity = coalesce(getvariable('overlap_concavity'), 2.0::DOUBLE); -- concavity of the concave hull
SET VARIABLE overlap_radius_m = coalesce(getvariable('overlap_radius_m'), 2.0::DOUBLE); -- density rule: a point counts with overlap_min_neighbours others within this radius (m)
SET VARIABLE overlap_min_neighbours = coalesce(getvariable('overlap_min_neighbours'), 3::BIGINT); -- density rule: neighbours a point needs
SET VARIABLE overlap_shrink_sigmas = coalesce(getvariable('overlap_shrink_sigmas'), 1.0::DOUBLE); -- each view polygon is shrunk by this many times the camera's measured noise

-- merge
SET VARIABLE merge_epsilon = coalesce(getvariable('merge_epsilon'), NULL::DOUBLE); -- LCSS epsilon (m) for matching and merging (auto: per camera pair, 3.03 x the measured residual sigma: 99% of true pairs)
SET VARIABLE merge_time_window = coalesce(getvariable('merge_time_window'), 0.25::DOUBLE); -- LCSS time window T (s)
SET VARIABLE merge_min_points = coalesce(getvariable('merge_min_points'), NULL::BIGINT); -- LCSS xi: points a track needs inside the overlap (auto: 2 real samples of the slowest camera on the common clock, >= 3)
SET VARIABLE merge_eta = coalesce(getvariable('merge_eta'), 0.5::DOUBLE); -- eta-bar: the lowest similarity that links two tracks
SET VARIABLE merge_resample_s = coalesce(getvariable('merge_resample_s'), 0.1::DOUBLE); -- common clock period (s); 0 keeps the raw samples
SET VARIABLE merge_resample_max_gap = coalesce(getvariable('merge_resample_max_gap'), 1.0::DOUBLE); -- the common clock does not bridge gaps longer than this (s)

-- cluster
SET VARIABLE cluster_camera = coalesce(getvariable('cluster_camera'), NULL::BIGINT); -- the camera whose tracks are clustered (auto: the camera with the most real tracks; ties: the lowest id)
SET VARIABLE cluster_classes = coalesce(getvariable('cluster_classes'), ''); -- the classes clustered, as 'car, pedestrian' ('' : every class)
SET VARIABLE cluster_delta = coalesce(getvariable('cluster_delta'), 5::BIGINT); -- Buzan's delta: samples of time warping
SET VARIABLE cluster_epsilon = coalesce(getvariable('cluster_epsilon'), 2.0::DOUBLE); -- Buzan's epsilon (m)
SET VARIABLE cluster_rho = coalesce(getvariable('cluster_rho'), 0.5::DOUBLE); -- Buzan's rho: length ratio below which tracks are not compared
SET VARIABLE cluster_threshold = coalesce(getvariable('cluster_threshold'), 0.5::DOUBLE); -- average-linkage cut height
SET VARIABLE cluster_method = coalesce(getvariable('cluster_method'), 'auto'); -- 'exact' (every pair of tracks, traj_cluster), 'prototypes' (traj_cluster_prototypes: linear in the tracks) or 'auto' (exact up to cluster_exact_max tracks of a class, prototypes above)
SET VARIABLE cluster_exact_max = coalesce(getvariable('cluster_exact_max'), 3000::BIGINT); -- with cluster_method auto, the most tracks of one class clustered exactly (3,000: 4.5 M pairs, a few seconds)
SET VARIABLE cluster_translation_invariant = coalesce(getvariable('cluster_translation_invariant'), false); -- use S2 (shapes anywhere) instead of S1 (routes)

-- report
SET VARIABLE report_gates = coalesce(getvariable('report_gates'), ''); -- gates the report counts movements by, instead of approaches found in the data: a .csv or .parquet file, or a table or view of this connection, with approach, x1, y1, x2, y2 (metres in the results' frame: the site map's axes) or approach, wkt (LINESTRING (x1 y1, x2 y2)); '' : approaches from the data

-- archive
SET VARIABLE archive_change_z = coalesce(getvariable('archive_change_z'), 5.0::DOUBLE); -- an archive's daily check (trajdb archive): a camera pair whose registration on the day's matches differs from its calibration day's by more than this many standard errors (rotation, position, clock) has moved; the camera is registered again from that day (docs/archive.md)

-- the values in use, one row per parameter (report.html shows them)
CREATE OR REPLACE TEMP TABLE pipeline_params AS SELECT * FROM (VALUES
    ('input_columns', coalesce(getvariable('input_columns')::VARCHAR, 'auto'), 'load', 'your column names, as ''camera=cam_id, track_id=id, t=time'' (any of camera, track_id, class, t, x, y, estimated; unnamed ones keep their name; estimated may be absent)'),
    ('clean_drop_estimated_tails', coalesce(getvariable('clean_drop_estimated_tails')::VARCHAR, 'auto'), 'clean', 'drop a track whose last clean_xi points are all estimated'),
    ('clean_xi', coalesce(getvariable('clean_xi')::VARCHAR, 'auto'), 'clean', 'points of the estimated tail rule'),
    ('clean_min_points', coalesce(getvariable('clean_min_points')::VARCHAR, 'auto'), 'clean', 'a track with fewer real points than this ... (auto: 2, the least that shows motion)'),
    ('clean_min_duration_s', coalesce(getvariable('clean_min_duration_s')::VARCHAR, 'auto'), 'clean', '... and spanning less than this many seconds is dropped (auto: 1.5 sampling periods)'),
    ('clean_max_speed', coalesce(getvariable('clean_max_speed')::VARCHAR, 'auto'), 'clean', 'a track whose median real speed exceeds this (m/s) is implausible and dropped'),
    ('quality_max_gap', coalesce(getvariable('quality_max_gap')::VARCHAR, 'auto'), 'quality', 'a broken piece may resume up to this many seconds later'),
    ('quality_max_dist', coalesce(getvariable('quality_max_dist')::VARCHAR, 'auto'), 'quality', '... within this many metres of where the track would be at its final velocity'),
    ('quality_max_accel', coalesce(getvariable('quality_max_accel')::VARCHAR, 'auto'), 'quality', 'second linking pass: a leftover start may lie max_dist + accel * gap^2 / 2 from the prediction (m/s^2; auto: the class''s measured 95th percentile acceleration, see quality.sql)'),
    ('quality_inset', coalesce(getvariable('quality_inset')::VARCHAR, 'auto'), 'quality', 'endpoints closer than this (m) to the view''s edge are entries and exits'),
    ('align_min_points', coalesce(getvariable('align_min_points')::VARCHAR, 'auto'), 'align', 'tracks need at least this many real points to form hypotheses'),
    ('align_min_overlap_s', coalesce(getvariable('align_min_overlap_s')::VARCHAR, 'auto'), 'align', 'track pairs overlap at least this long in time (s)'),
    ('align_min_pairs', coalesce(getvariable('align_min_pairs')::VARCHAR, 'auto'), 'align', 'a hypothesis needs at least this many time-interpolated point pairs'),
    ('align_min_span_m', coalesce(getvariable('align_min_span_m')::VARCHAR, 'auto'), 'align', '... and its moving points span at least this many metres'),
    ('align_max_hypotheses', coalesce(getvariable('align_max_hypotheses')::VARCHAR, 'auto'), 'align', 'at most this many track pairs per camera pair are scanned (a hash sample of a long day)'),
    ('align_max_clock_offset_s', coalesce(getvariable('align_max_clock_offset_s')::VARCHAR, 'auto'), 'align', 'clock offsets between two cameras are searched up to this many seconds either way first; a camera pair whose winner lies at the edge, or is too weak, is searched again over 4x and 16x this range'),
    ('align_bin_s', coalesce(getvariable('align_bin_s')::VARCHAR, 'auto'), 'align', 'vote bin (and scan step) of the clock offset (s)'),
    ('align_clock_step_s', coalesce(getvariable('align_clock_step_s')::VARCHAR, 'auto'), 'align', 'step of the joint clock offset search around the winning bin (s)'),
    ('align_max_rms_m', coalesce(getvariable('align_max_rms_m')::VARCHAR, 'auto'), 'align', 'hypotheses fitting their own pairs within this RMS (m) vote (auto: 0.1 + 3 sigma_pair)'),
    ('align_bin_deg', coalesce(getvariable('align_bin_deg')::VARCHAR, 'auto'), 'align', 'vote bin of the rotation (degrees)'),
    ('align_bin_m', coalesce(getvariable('align_bin_m')::VARCHAR, 'auto'), 'align', 'vote bin of the translation (m)'),
    ('align_agree_deg', coalesce(getvariable('align_agree_deg')::VARCHAR, 'auto'), 'align', 'a hypothesis agrees with the winning bin within this rotation (degrees)'),
    ('align_agree_m', coalesce(getvariable('align_agree_m')::VARCHAR, 'auto'), 'align', '... and this translation (m)'),
    ('align_min_support', coalesce(getvariable('align_min_support')::VARCHAR, 'auto'), 'align', 'a camera pair needs at least this many agreeing track pairs'),
    ('align_trim', coalesce(getvariable('align_trim')::VARCHAR, 'auto'), 'align', 'share of point pairs the trimmed refit leaves out'),
    ('align_refine_rms_m', coalesce(getvariable('align_refine_rms_m')::VARCHAR, 'auto'), 'align', 'second pass: track pairs within this RMS (m) of the first fit are kept (auto: 0.05 + 2 sigma_pair)'),
    ('overlap_method', coalesce(getvariable('overlap_method')::VARCHAR, 'auto'), 'overlap', 'view polygon hull: ''convex'' or ''concave'''),
    ('overlap_concavity', coalesce(getvariable('overlap_concavity')::VARCHAR, 'auto'), 'overlap', 'concavity of the concave hull'),
    ('overlap_radius_m', coalesce(getvariable('overlap_radius_m')::VARCHAR, 'auto'), 'overlap', 'density rule: a point counts with overlap_min_neighbours others within this radius (m)'),
    ('overlap_min_neighbours', coalesce(getvariable('overlap_min_neighbours')::VARCHAR, 'auto'), 'overlap', 'density rule: neighbours a point needs'),
    ('overlap_shrink_sigmas', coalesce(getvariable('overlap_shrink_sigmas')::VARCHAR, 'auto'), 'overlap', 'each view polygon is shrunk by this many times the camera''s measured noise'),
    ('merge_epsilon', coalesce(getvariable('merge_epsilon')::VARCHAR, 'auto'), 'merge', 'LCSS epsilon (m) for matching and merging (auto: per camera pair, 3.03 x the measured residual sigma: 99% of true pairs)'),
    ('merge_time_window', coalesce(getvariable('merge_time_window')::VARCHAR, 'auto'), 'merge', 'LCSS time window T (s)'),
    ('merge_min_points', coalesce(getvariable('merge_min_points')::VARCHAR, 'auto'), 'merge', 'LCSS xi: points a track needs inside the overlap (auto: 2 real samples of the slowest camera on the common clock, >= 3)'),
    ('merge_eta', coalesce(getvariable('merge_eta')::VARCHAR, 'auto'), 'merge', 'eta-bar: the lowest similarity that links two tracks'),
    ('merge_resample_s', coalesce(getvariable('merge_resample_s')::VARCHAR, 'auto'), 'merge', 'common clock period (s); 0 keeps the raw samples'),
    ('merge_resample_max_gap', coalesce(getvariable('merge_resample_max_gap')::VARCHAR, 'auto'), 'merge', 'the common clock does not bridge gaps longer than this (s)'),
    ('cluster_camera', coalesce(getvariable('cluster_camera')::VARCHAR, 'auto'), 'cluster', 'the camera whose tracks are clustered (auto: the camera with the most real tracks; ties: the lowest id)'),
    ('cluster_classes', coalesce(getvariable('cluster_classes')::VARCHAR, 'auto'), 'cluster', 'the classes clustered, as ''car, pedestrian'' ('''' : every class)'),
    ('cluster_delta', coalesce(getvariable('cluster_delta')::VARCHAR, 'auto'), 'cluster', 'Buzan''s delta: samples of time warping'),
    ('cluster_epsilon', coalesce(getvariable('cluster_epsilon')::VARCHAR, 'auto'), 'cluster', 'Buzan''s epsilon (m)'),
    ('cluster_rho', coalesce(getvariable('cluster_rho')::VARCHAR, 'auto'), 'cluster', 'Buzan''s rho: length ratio below which tracks are not compared'),
    ('cluster_threshold', coalesce(getvariable('cluster_threshold')::VARCHAR, 'auto'), 'cluster', 'average-linkage cut height'),
    ('cluster_method', coalesce(getvariable('cluster_method')::VARCHAR, 'auto'), 'cluster', '''exact'' (every pair of tracks, traj_cluster), ''prototypes'' (traj_cluster_prototypes: linear in the tracks) or ''auto'' (exact up to cluster_exact_max tracks of a class, prototypes above)'),
    ('cluster_exact_max', coalesce(getvariable('cluster_exact_max')::VARCHAR, 'auto'), 'cluster', 'with cluster_method auto, the most tracks of one class clustered exactly (3,000: 4.5 M pairs, a few seconds)'),
    ('cluster_translation_invariant', coalesce(getvariable('cluster_translation_invariant')::VARCHAR, 'auto'), 'cluster', 'use S2 (shapes anywhere) instead of S1 (routes)'),
    ('report_gates', coalesce(getvariable('report_gates')::VARCHAR, 'auto'), 'report', 'gates the report counts movements by, instead of approaches found in the data: a .csv or .parquet file, or a table or view of this connection, with approach, x1, y1, x2, y2 (metres in the results'' frame: the site map''s axes) or approach, wkt (LINESTRING (x1 y1, x2 y2)); '''' : approaches from the data'),
    ('archive_change_z', coalesce(getvariable('archive_change_z')::VARCHAR, 'auto'), 'archive', 'an archive''s daily check (trajdb archive): a camera pair whose registration on the day''s matches differs from its calibration day''s by more than this many standard errors (rotation, position, clock) has moved; the camera is registered again from that day (docs/archive.md)')
) t(name, value, stage, description);
