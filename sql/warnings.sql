-- trajdb: what a finished pipeline run should tell its user, one row each, in table
-- pipeline_warnings (k, message). Every runner (trajdb pipeline, trajdb.pipeline in Python, the
-- DuckDB CLI after `.read sql/pipeline.sql`) reads this one table.
-- reads: points, align_frames, align_pairs, calibration_summary, load_class_flicker, load_duplicates, load_ids, load_twins, load_unit_outliers; parameters: cluster_classes,
-- load_no_class (set by the load), archive_day_note (set by an archive's host)   makes: pipeline_warnings
CREATE OR REPLACE TEMP TABLE pipeline_warnings AS
WITH c AS (SELECT (SELECT count(DISTINCT camera) FROM points) AS cams, (SELECT count(*) FROM align_frames) AS aligned,
                  (SELECT count(*) FROM load_class_flicker) AS flicker,
                  (SELECT coalesce(sum(repeats), 0) FROM load_duplicates) AS repeats,
                  (SELECT count(*) FILTER (WHERE conflicting) FROM load_duplicates) AS conflicting)
SELECT 1 AS k, 'one camera: nothing to align or match across cameras; road users are that camera''s tracks, linked within it' AS message
FROM c WHERE cams = 1
UNION ALL
SELECT 2, format('{} of {} cameras in one frame: cameras {} share no consistent track pairs with the others (no common time, or no common view); '
                 || 'their tracks are road users of their own', aligned, cams,
                 (SELECT list(DISTINCT i.camera_in ORDER BY i.camera_in) FROM load_ids i
                  WHERE i.camera IN (SELECT camera FROM points ANTI JOIN align_frames USING (camera)))::VARCHAR)
FROM c WHERE cams > 1 AND aligned < cams
UNION ALL
SELECT 3, format('{} tracks change class partway; each keeps its majority class (table load_class_flicker)', flicker)
FROM c WHERE flicker > 0
UNION ALL
SELECT 4, format('{} input rows repeat the (camera, track_id, t) of another row ({} of those times with other x, y); each was kept once '
                 || '(table load_duplicates)', repeats, conflicting)
FROM c WHERE repeats > 0
UNION ALL
SELECT 7, format('camera {} is camera {} exported again ({}% of its points coincide with camera {}''s, same x, y to 0.1 mm, at a time difference '
                 || 'of {} s): its points were left out of the run, so that no road user is doubled (table load_twins)',
                 d.camera_in, k.camera_in, round(100 * w.share, 1), k.camera_in, w.time_difference_s)
FROM load_twins w
JOIN (SELECT DISTINCT camera, camera_in FROM load_ids) d ON d.camera = w.camera_dropped
JOIN (SELECT DISTINCT camera, camera_in FROM load_ids) k ON k.camera = w.camera_kept
UNION ALL
SELECT 5, format('cluster_classes names {} that the input does not have (its classes: {}); nothing of that name was clustered',
                 list_filter(wanted, lambda w: NOT list_contains(have, w))::VARCHAR, have::VARCHAR)
FROM (SELECT [lower(trim(x)) FOR x IN string_split(coalesce(getvariable('cluster_classes'), ''), ',') IF trim(x) <> ''] AS wanted,
             (SELECT list(DISTINCT lower(class) ORDER BY lower(class)) FROM points) AS have)
WHERE len(list_filter(wanted, lambda w: NOT list_contains(have, w))) > 0
UNION ALL
SELECT 6, 'the input has no class column: every track is of one class, ''unknown'' (give a class column, or map one with '
          || 'input_columns = ''class=your_column'', to match and cluster each class on its own)'
WHERE getvariable('load_no_class')
UNION ALL
SELECT 8, format('{} tracks have a sampling period or speed far outside a road user''s, unlike the rest of the input (kept; table '
                 || 'load_unit_outliers): {}{}', count(*),
                 string_agg(format('camera {} track {} ({} points over {} h, {})', i.camera_in, i.track_in, o.points, round(o.span_s / 3600, 1), o.why),
                            '; ' ORDER BY o.camera, o.track_id) FILTER (WHERE o.rank <= 10),
                 CASE WHEN count(*) > 10 THEN '; ...' ELSE '' END)
FROM (SELECT *, row_number() OVER (ORDER BY camera, track_id) AS rank FROM load_unit_outliers) o
LEFT JOIN load_ids i ON i.camera = o.camera AND i.track_id = o.track_id
HAVING count(*) > 0
UNION ALL
-- issue 40 (first: the day's headline): an archive's day on which a camera changed (found by the host's daily check,
-- sql/archive_check.sql, and registered again from this day: src/archive/task.rs)
SELECT 0, getvariable('archive_day_note') WHERE getvariable('archive_day_note') IS NOT NULL
UNION ALL
-- issue 38: a camera pair whose clock offset the tracks cannot pin (align.sql, align_offset_se)
SELECT 9, format('cameras {} and {}: their clock offset is uncertain by {} s, more than half the common clock step (merge_resample_s = {} s): '
                 || 'the track pairs'' own offsets disagree (road users moving mostly one way, whose time shift looks like a translation), '
                 || 'so matches between them may be missed and their paths misplaced along the road; check the two clocks '
                 || '(calibration.csv, ''clock offset se'')', a.camera_in, b.camera_in, round(c.value, 3), getvariable('merge_resample_s'))
FROM calibration_summary c
JOIN (SELECT DISTINCT camera, camera_in FROM load_ids) a ON a.camera = try_cast(regexp_extract(c.scope, '^cameras (-?[0-9]+)-', 1) AS INTEGER)
JOIN (SELECT DISTINCT camera, camera_in FROM load_ids) b ON b.camera = try_cast(regexp_extract(c.scope, '^cameras -?[0-9]+-(-?[0-9]+)$', 1) AS INTEGER)
WHERE c.quantity = 'clock offset se' AND c.value > getvariable('merge_resample_s') / 2
UNION ALL
-- issue 38: two cameras' ground planes differ by more than a similarity (register_pair's
-- perspective term, significant at 5 sigma; measured, not applied)
SELECT 10, format('cameras {} and {}: their ground planes differ by a perspective term ({}% of scale at 50 m, se {}%): no rotation, '
                  || 'shift and scale maps one onto the other everywhere, so positions far from the overlap are off by up to that share of '
                  || 'their distance; check the two cameras'' image-to-ground calibrations (calibration.csv, ''perspective'')',
                  a.camera_in, b.camera_in, round(100 * 50 * sqrt(p.reg.perspective_hx ** 2 + p.reg.perspective_hy ** 2), 2), round(100 * 50 * p.reg.perspective_se, 2))
FROM align_pairs p
JOIN (SELECT DISTINCT camera, camera_in FROM load_ids) a ON a.camera = p.cam_fixed
JOIN (SELECT DISTINCT camera, camera_in FROM load_ids) b ON b.camera = p.cam_moving
WHERE p.reg.perspective_significant;
